"""The stages of :meth:`mggp.MGGPRegressor.fit` after the structure search.

Typical use (``fit`` does this)::

    from mggp.stages import FitContext, STAGES, run_stages
    ctx = FitContext(est, data, registry, start, scorer)
    ctx.result = evolve(...)                       # the search
    terms = run_stages(shape(ctx.result.best.terms), data, ctx)

Each stage is a function ``stage(terms, data, ctx) -> terms`` of the
structure so far, the training record and the :class:`FitContext`; it sets
the fitted attributes it is responsible for on ``ctx.est``. In order
(:data:`STAGES`):

``select``
    The structure among the best of the run (``select``; 'auto': the one
    whose CLS refit holds with ``constraints``, else the best fitness);
    sets ``selection_`` and ``search_terms_``.
``size``
    'auto': the smallest structure of the run's Pareto front whose
    held-out free-run error is within :data:`mggp.choices.SIZE_TOLERANCE`
    of the least, or within 2/√n on n held-out samples when that is
    larger (``size``).
``constant``
    'auto': the constant term kept only when the held-out free-run error
    is lower with it by over :data:`mggp.choices.GAIN`, significantly at
    p < :data:`mggp.choices.LEVEL` (never with the steady-state constraints).
``operators``
    With ``operators`` and ``operator_entry='stage'``: memory-operator
    terms added stepwise to the structure (:mod:`mggp.operator_stage`);
    sets ``operator_steps_``.
``prune``
    Backward elimination by BIC of the fitness or by t-statistics
    (``prune``; :mod:`mggp.pruning`).
``local_search``
    One-term moves from the chosen structure while they lower the search's
    fitness (``local_search``; :mod:`mggp.local_search`), then the same
    pruning again; sets ``local_search_``.
``noise``
    Moving-average noise terms by extended least squares (``noise_lags``;
    :mod:`mggp.noise`).
``record``
    ``terms_``, ``fitness_`` and the ``meta`` every model of the fit carries.
``qr_refit``
    ``model_``: θ by least squares (QR) on the whole record; with
    ``estimator='oe'`` the output-error θ of the search's scorer.
``precision``
    The fitness with the search's θ and with the QR θ (``precision_``,
    :mod:`mggp.precision`); ``model_`` keeps the search's θ when the QR
    refit simulates worse.
``cls_refit``
    ``model_cls_``: θ by constrained least squares under the
    continuum-of-steady-states equalities of the terms (``constraints``).
``refine``
    θ of both models by minimising the simulation error (``refine``).
``cls_verdict``
    ``cls_rejected_``: why the CLS refit is not the default model
    (:func:`cls_rejection`), with a :class:`CLSRejectedWarning`.
``pareto``
    ``pareto_front_`` of the run, with the θ the search scored.

All stages score with the one :class:`narx.fitness.StructureScorer` of the
search's settings (``ctx.scorer``, also the search's own in this process);
a stage that simulates with other settings asks :meth:`FitContext.scorer_for`,
which builds at most one scorer per setting.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace
from typing import Callable, Dict, Optional, Tuple

from narx import Model
from narx.data import Data
from narx.fitness import StructureScorer
from narx.model import ignore_rank_warnings
from narx.output_error import OE_ESTIMATORS
from narx.ranges import signal_ranges

from .choices import (Choice, constant_choice, constant_off, error_floor, front_rows_heldout,
                      heldout_rmse, heldout_samples, heldout_theta, local_search_kept,
                      resolve_select, size_choice, steady, theta_choice, THETA_WORDS)
from .evaluate import criterion_value
from .exceptions import CLSRejectedWarning
from .noise import full_ma, prune_process, select_noise
from .pareto import ParetoFront, front_rows
from .precision import search_precision
from .pruning import prune_by_criterion, prune_by_t, t_threshold_of
from .selection import run_candidates, select_freerun, select_hold

__all__ = ["FitContext", "STAGES", "run_stages", "cls_rejection", "CLS_WORSE"]

#: a CLS refit whose free-run RMSE on the training record is more than this
#: many times the LS fit's is not preferred to it
CLS_WORSE = 2.0

#: warnings point at the caller of ``fit`` (fit -> run_stages -> stage)
_CALLER = 4

#: the local search starts no step once it has scored this share of the
#: structures the search scored (and at least LOCAL_EVALS_MIN)
LOCAL_EVALS_SHARE = 0.1
LOCAL_EVALS_MIN = 1000


@dataclass
class FitContext:
    """What the stages share.

    Attributes
    ----------
    est : MGGPRegressor
        The settings; the stages set its fitted attributes.
    data : Data
        The training record.
    registry : PhiRegistry
    start : int
        First row of estimation and scoring (fixed by ``max_height``).
    scorer : StructureScorer
        The search's scorer (its fitness, window, horizon, constraints).
    result : EvolutionResult
        The search's outcome.
    shape : callable
        Decoded terms -> the scored structure (allowed terms, the constant).
    screen : StabilityScreen or None
        The search's stability screen.
    seed : int
        The search's seed.
    meta : dict
        What every model of the fit records (set by the ``record`` stage).
    search_class : SearchClass
        The model class searched (:func:`mggp.choices.search_classes`):
        Φ or not, the memory operators and where they enter.
    choices : dict
        The automatic choices made (:class:`mggp.choices.Choice` by
        parameter name), recorded in ``meta['choices']``.
    stress : StressCheck or None
        The stress test of the final choices (``stress``;
        :class:`mggp.extrapolation.StressCheck`).
    """

    est: object
    data: Data
    registry: object
    start: int
    scorer: StructureScorer
    result: object = None
    shape: Callable = tuple
    screen: object = None
    seed: Optional[int] = None
    search_class: object = None
    meta: dict = field(default_factory=dict)
    choices: dict = field(default_factory=dict)
    stress: object = None
    _scorers: Dict[Tuple, StructureScorer] = field(default_factory=dict)

    def scorer_for(self, fitness: str, constraints: Optional[str] = None) -> StructureScorer:
        """The scorer of ``fitness`` (and ``constraints``) on the record from
        ``start``: the search's when they are its settings, else one built
        once per setting (with the search's ``estimator`` where it applies)."""
        sc = self.scorer
        if fitness == sc.fitness and constraints == sc.constraints:
            return sc
        key = (fitness, constraints)
        if key not in self._scorers:
            oe = sc.estimator in OE_ESTIMATORS and fitness in ("ms", "freerun") \
                and constraints is None
            self._scorers[key] = StructureScorer(
                self.data, fitness, window=sc.window, k=sc.k, start=self.start,
                constraints=constraints, registry=self.registry,
                estimator=sc.estimator if oe else "ls")
        return self._scorers[key]


# ---------------------------------------------------------------- stages
def screened(ctx) -> str:
    """The stability screen of the search: ``screen``, or what 'auto' chose."""
    c = ctx.choices.get("screen")
    return ctx.est.screen if c is None else c.value


def selected(ctx) -> str:
    """How the structure is chosen: ``select``, or what 'auto' chose."""
    c = ctx.choices.get("select")
    return ctx.est.select if c is None else c.value


def select(terms, data, ctx):
    """The structure among the best distinct ones of the run (``select``)."""
    est = ctx.est
    if est.select == "auto":
        ctx.choices["select"] = resolve_select(est)
    how = selected(ctx)
    if how == "freerun":
        cands = run_candidates(ctx.result, data.signals, ctx.shape, est.select_candidates)
        chosen, est.selection_ = select_freerun(cands, data, ctx.start, ctx.registry,
                                                scorer=ctx.scorer_for("freerun"),
                                                check=ctx.stress)
        terms = chosen or terms
    elif how == "hold":
        cands = run_candidates(ctx.result, data.signals, ctx.shape, est.select_candidates)
        scr = ctx.screen
        shared = scr if (scr is not None and scr.hold is not None
                         and est.search_constraints is None) else None
        chosen, est.selection_ = select_hold(cands, data, ctx.start, ctx.registry,
                                             est.screen_band, screen=shared)
        if "select" in ctx.choices:
            c, at = ctx.choices["select"], len(est.selection_)
            ctx.choices["select"] = replace(c, why=c.why + (
                f"; candidate {at} of {len(cands)} (best fitness first) holds" if chosen
                else f"; none of the {len(cands)} candidates holds"),
                figures={"candidates": len(cands), "holding": at if chosen else None})
        if not chosen:
            warnings.warn(f"select='hold': none of the {len(est.selection_)} candidates "
                          f"holds its output on a held input; model_ is the best-fitness "
                          f"structure (see selection_)", UserWarning, stacklevel=_CALLER)
        terms = chosen or terms
    est.search_terms_ = terms
    return terms


def local_search(terms, data, ctx):
    """``local_search``: best-improvement one-term moves from the chosen
    structure while the measure that chose it falls: the search's fitness
    (criterion included), or with ``select`` 'freerun' the free-run error
    over the record, each at least the square of
    :func:`mggp.choices.error_floor` (below it rounding, where dropping a
    term keeps the measure and is taken); each accepted move passes the search's stability
    screen (:func:`mggp.local_search.improve`), within
    :data:`LOCAL_EVALS_SHARE` of the search's evaluations; a moved structure is pruned
    again (``prune``), and kept only when its held-out free-run error is not
    worse than the chosen structure's beyond the size choice's tolerance and,
    with ``stress``, its free run stays bounded on the stress inputs when the
    chosen structure's does (:func:`mggp.choices.local_search_kept`;
    otherwise the choice line says so). A structure chosen for its holding
    (``select`` 'hold') is kept as chosen."""
    est = ctx.est
    est.local_search_ = []
    how = selected(ctx)
    if not est.local_search or how == "hold":
        return terms
    from .local_search import improve, term_moves
    from .primitives import reachable_lag
    lags = range(1, reachable_lag(est.max_height_, est.max_lag) + 1)
    degree = est.max_degree or max(3, max((t.degree for t in terms), default=1))
    moves = term_moves(data.signals, lags, degree, est._allowed)
    n = data.n - ctx.start

    sc = ctx.scorer_for("freerun") if how == "freerun" else ctx.scorer
    floor = error_floor(data) ** 2                  # MSE below it: rounding

    def score(ts):
        return criterion_value(max(sc.score(ts), floor), len(ts), n, est.criterion)

    scr = ctx.screen
    passes = None
    if scr is not None:
        def passes(ts):
            return scr.inside_band(ts) and (scr.hold is None or scr.holds(ts))
    budget = max(LOCAL_EVALS_MIN, int(LOCAL_EVALS_SHARE * ctx.result.evaluations))
    moved, steps = improve(terms, score, moves, passes, max_evals=budget)
    if not steps:
        return terms
    moved = prune(moved, data, ctx)
    unbounded = "" if ctx.stress is None or ctx.stress(terms) else ctx.stress(moved)
    theta = heldout_theta(est)
    c = local_search_kept(heldout_rmse(terms, data, ctx.registry, theta=theta),
                          heldout_rmse(moved, data, ctx.registry, theta=theta),
                          heldout_samples(data.n), len(steps), unbounded)
    if not c.value:
        ctx.choices["local_search"] = c
        return terms
    est.local_search_ = [s.to_dict() for s in steps]
    return moved


def size(terms, data, ctx):
    """``size='auto'``: the smallest structure of the run's Pareto front
    whose held-out free-run error is within :data:`mggp.choices.SIZE_TOLERANCE`
    of the least (2/√n on n
    held-out samples when larger: :func:`mggp.choices.size_tolerance`), the chosen
    structure included (:func:`mggp.choices.size_choice`). A structure
    chosen for its holding (``select`` 'hold') is kept, and so is the size an
    information criterion (``criterion`` 'bic'/'aic') or pruning chose."""
    est = ctx.est
    if est.size != "auto" or selected(ctx) == "hold":
        return terms
    if est.criterion != "mse" or est.prune:
        by = (f"the {est.criterion.upper()} criterion" if est.criterion != "mse"
              else f"pruning ({est.prune})")
        ctx.choices["size"] = Choice("size", len(terms), f"size {len(terms)} terms: "
                                     f"chosen by {by}, not by held-out error", {})
        return terms
    theta = heldout_theta(est)
    c = size_choice(front_rows_heldout(terms, ctx.result, ctx.shape, data, ctx.registry,
                                       theta), heldout_samples(data.n), ctx.stress)
    why = c.why + THETA_WORDS.get(theta, "").replace(",", ";", 1)
    ctx.choices["size"] = Choice(c.name, len(c.value), why, c.figures)
    return c.value


def constant(terms, data, ctx):
    """``constant='auto'``: the constant term offered to every structure of
    the search is kept only when the chosen structure's held-out free-run
    error is lower with it by over :data:`mggp.choices.GAIN` at
    p < :data:`mggp.choices.LEVEL`
    (:func:`mggp.choices.constant_choice`);
    with the steady-state constraints it was not offered, and when the
    pilots chose a search without it (:meth:`MGGPRegressor._searches`) the
    structure has none."""
    if ctx.est.constant != "auto":
        return terms
    if steady(ctx.est):
        ctx.choices["constant"] = constant_off()
        return terms
    pilot = ctx.choices.get("constant")
    if pilot is not None and not pilot.value:   # searched without it (the pilots' choice)
        return terms
    c, terms = constant_choice(terms, data, ctx.registry, ctx.seed or 0,
                               heldout_theta(ctx.est))
    if pilot is not None:
        c = replace(c, why=f"{pilot.why}; then {c.why}", figures={**pilot.figures,
                                                                   **c.figures})
    ctx.choices["constant"] = c
    return terms


def operators(terms, data, ctx):
    """Memory-operator terms added stepwise when the searched class has
    operators outside its primitive set (``operators`` named,
    ``operator_entry='stage'``; :func:`mggp.operator_stage.add_operators`)."""
    est = ctx.est
    est.operator_steps_ = None
    cls = ctx.search_class
    if cls is None or not cls.operators or cls.in_search:
        return terms
    names = cls.operators
    from .operator_stage import add_operators, operator_candidates
    terms, est.operator_steps_ = add_operators(
        ctx.scorer, terms, operator_candidates(data, names), est.max_terms,
        keep=ctx.shape(()))
    return terms


def prune(terms, data, ctx):
    """Backward elimination of terms (``prune``: 'bic' or 't')."""
    est = ctx.est
    if est.prune == "bic":
        return prune_by_criterion(ctx.scorer, terms, data.n - ctx.start)
    if est.prune == "t":
        from narx.estimate import t_statistics
        from narx.regressors import regressor_matrix
        crit = est.t_threshold_ = t_threshold_of(est, len(data.inputs))
        return prune_by_t(terms, lambda ts: t_statistics(
            *regressor_matrix(ts, data, start=ctx.start)[:2]), crit)
    return terms


def noise(terms, data, ctx):
    """Moving-average noise terms (``noise_lags`` > 0), as many as
    ``max_terms`` leaves room for beside the process terms; with
    ``prune='t'`` the process terms that only predicted the noise are
    dropped first."""
    est = ctx.est
    if not est.noise_lags:
        return terms
    crit = t_threshold_of(est, len(data.inputs))
    q = int(est.noise_lags)
    if est.prune == "t":
        terms = prune_process(data, terms, full_ma(data, q, ctx.registry), ctx.start,
                              ctx.registry, crit)
    return terms + select_noise(data, terms, ctx.start, ctx.registry, q, crit,
                                limit=max(est.max_terms - len(terms), 0))


def record(terms, data, ctx):
    """``terms_``, ``fitness_`` and the meta of the fit's models."""
    from .version import versions
    from .params import meta_of
    est = ctx.est
    est.terms_ = terms
    est.fitness_ = ctx.result.best.fitness if terms == est.search_terms_ else \
        criterion_value(ctx.scorer.score(terms), len(terms), data.n - ctx.start,
                        est.criterion)
    resolved = {name: c.value for name, c in ctx.choices.items()}
    ctx.meta = dict(meta_of(est), **resolved, seed=ctx.seed,
                    cls_refit=est.constraints == "steady-state",
                    search_fitness_value=est.fitness_, versions=versions(),
                    ranges=signal_ranges(data))
    if ctx.choices:
        ctx.meta["choices"] = {name: c.to_dict() for name, c in ctx.choices.items()}
    if ctx.search_class is not None and ctx.search_class.operators:
        ctx.meta["operators"] = list(ctx.search_class.operators)
        ctx.meta["operator_entry"] = "search" if ctx.search_class.in_search else "stage"
    return terms


def _model(terms, data, ctx, estimation, theta=None, **extra) -> Model:
    return Model(terms, theta, inputs=data.inputs, output=data.output,
                 meta=dict(ctx.meta, estimation=estimation, **extra), registry=ctx.registry)


def qr_refit(terms, data, ctx):
    """``model_``: least squares by QR on the record. Terms the record cannot
    tell apart (``rank_`` below their number) get the minimum-norm θ.
    With ``estimator`` 'oe' or 'bj' (and no noise terms) θ is the output-error
    estimate of the search's scorer (:mod:`narx.output_error`), which
    measurement noise does not bias, and ``model_.meta['estimation']`` is
    ``'oe'``."""
    est = ctx.est
    with ignore_rank_warnings():
        est.model_ = _model(terms, data, ctx, "ls").fit(data)
    est.rank_ = int(est.model_.fit_info_["rank"])
    if est.estimator in OE_ESTIMATORS and not any(t.has_noise for t in terms):
        theta, _ = ctx.scorer.fitted(terms)
        if theta is not None:
            est.model_ = _model(terms, data, ctx, "oe", theta)
    return terms


def precision(terms, data, ctx):
    """``precision_``: the fitness with the search's θ and the QR θ; the
    search's θ is kept when the QR refit simulates worse. Not compared for
    ELS fits of noise terms, CLS fits of a constrained search and
    output-error fits, which are not what the QR refit (LS) is."""
    est = ctx.est
    est.precision_ = check = None if (any(t.has_noise for t in terms)
                                      or est.search_constraints
                                      or est.model_.meta["estimation"] == "oe") else \
        search_precision(ctx.scorer, terms, est.model_.theta, est.model_.fit_info_["start"])
    if check is not None and check.refit_worse:
        est.model_ = _model(terms, data, ctx, "ls-search", check.search_theta,
                            qr_refit_fitness_value=check.refit_mse)
    return terms


def cls_refit(terms, data, ctx):
    """``model_cls_`` (``constraints='steady-state'``), or ``cls_error_``
    saying why the constrained fit is not possible.

    .. math:: \\theta_{CLS} = \\theta_{LS} - (\\Psi^T\\Psi)^{-1} S^T
              [S (\\Psi^T\\Psi)^{-1} S^T]^{-1} (S \\theta_{LS} - c)

    with :math:`S \\theta = c` the continuum-of-steady-states equalities of
    the terms (Abreu et al., Nonlinear Dynamics, 2020)."""
    est = ctx.est
    est.model_cls_ = None
    if est.constraints == "steady-state":
        try:
            with ignore_rank_warnings():
                est.model_cls_ = _model(terms, data, ctx, "cls").fit(
                    data, constraints="steady-state")
        except ValueError as exc:
            est.cls_error_ = str(exc)
    return terms


def refine(terms, data, ctx):
    """θ of ``model_`` and ``model_cls_`` by least simulation error
    (``refine``; ``refinement_`` holds the errors before and after).
    'auto': by free-run simulation error when that refit of the structure
    simulates the held-out part significantly better than its LS θ
    (:func:`mggp.choices.theta_choice`), never with the steady-state
    constraints (the hold selection judged the CLS refit of the LS θ)."""
    est = ctx.est
    est.refinement_ = None
    how = est.refine
    if how == "auto":
        how = None
        if heldout_theta(est) == "best" and not any(t.has_noise for t in terms):
            c = theta_choice(terms, data, ctx.registry, ctx.seed or 0)
            ctx.choices["refine"] = c
            how = c.value
            est.model_.meta.setdefault("choices", {})["refine"] = c.to_dict()
            est.model_.meta["refine"] = c.value
    if how and how != "none":
        from narx.refine import refine_both
        est.refinement_, est.model_, est.model_cls_, why = refine_both(
            est.model_, est.model_cls_, data, how, est.refine_window or est.window)
        if why:
            warnings.warn(f"refine={est.refine!r} is not applied: {why}", UserWarning,
                          stacklevel=_CALLER)
    return terms


def cls_rejection(model, model_cls, data, held: bool = False) -> Optional[str]:
    """Why the CLS refit should not replace the LS fit ``model`` (None: it
    may): its free run on the training record diverges, or (unless the
    structure was chosen for its CLS refit's holding, ``held``) its RMSE is
    over :data:`CLS_WORSE` times the LS fit's."""
    fr_cls = model_cls.simulate(data, mode="freerun")
    if fr_cls.diverged:
        return "diverges on the training record"
    if held:
        return None
    fr_ls = model.simulate(data, mode="freerun")
    if not fr_ls.diverged and fr_ls.rmse > 0 and fr_cls.rmse > CLS_WORSE * fr_ls.rmse:
        return f"is {fr_cls.rmse / fr_ls.rmse:.3g} times the LS fit's free-run RMSE"
    return None


def cls_verdict(terms, data, ctx):
    """``cls_rejected_``: why ``get_best`` uses the LS model, None if the
    CLS refit is used. A structure chosen for its CLS refit's holding
    (``screen='hold'``, or ``select='hold'`` with a candidate that holds)
    is not rejected for its error alone."""
    est = ctx.est
    held = screened(ctx) == "hold" or (selected(ctx) == "hold" and any(
        ok for ok, _ in getattr(est, "selection_", ())))
    est.cls_rejected_ = None if est.model_cls_ is None else cls_rejection(
        est.model_, est.model_cls_, data, held)
    if est.cls_rejected_:
        warnings.warn(f"the CLS refit {est.cls_rejected_}: get_best(), simulate() and "
                      f"predict() use the LS model (constrained=True for the CLS one)",
                      CLSRejectedWarning, stacklevel=_CALLER)
    return terms


def pareto(terms, data, ctx):
    """``pareto_front_``: the run's front with the θ the search scored."""
    est = ctx.est
    est.pareto_front_ = ParetoFront(front_rows(ctx.result.pareto, ctx.scorer, ctx.shape),
                                    inputs=data.inputs, output=data.output,
                                    registry=ctx.registry)
    return terms


#: the stages of ``fit`` after the search, in order
STAGES = (("select", select), ("size", size), ("constant", constant),
          ("operators", operators), ("prune", prune), ("local_search", local_search),
          ("noise", noise), ("record", record), ("qr_refit", qr_refit),
          ("precision", precision), ("cls_refit", cls_refit), ("refine", refine),
          ("cls_verdict", cls_verdict), ("pareto", pareto))


def run_stages(terms, data: Data, ctx: FitContext, stages=STAGES):
    """Pass ``terms`` through ``stages``; returns the final structure."""
    for _, stage in stages:
        terms = stage(terms, data, ctx)
    return terms
