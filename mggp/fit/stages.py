"""The stages of :meth:`mggp.MGGPRegressor.fit` after the structure search.

Typical use (``fit`` does this)::

    from mggp.fit.stages import FitContext, STAGES, run_stages
    ctx = FitContext(est, data, registry, start, scorer)
    ctx.result = evolve(...)                       # the search
    terms = run_stages(shape(ctx.result.best.terms), data, ctx)

Each stage is a function ``stage(terms, data, ctx) -> Decision`` of the
structure so far, the training record and the :class:`FitContext`: it
reads the settings and the decisions of the stages before it
(:meth:`FitContext.latest`) and returns its own decision, a small frozen
dataclass holding the structure it hands on (``terms``) and what it chose.
It never writes to the estimator: :meth:`mggp.MGGPRegressor.fit` assigns the
fitted attributes from the decisions that :func:`run_stages` returns. In
order (:data:`STAGES`, decision in brackets):

``select`` (:class:`Selected`)
    The structure among the best of the run (``select``; 'auto': the one
    whose CLS refit holds with ``constraints``, else the best fitness);
    sets ``selection_`` and ``search_terms_``.
``size``
    'auto': the smallest structure of the run's Pareto front whose
    held-out free-run error is within :data:`mggp.fit.choices.SIZE_TOLERANCE`
    of the least, or within 2/√n on n held-out samples when that is
    larger (``size``).
``constant``
    'auto': the constant term kept only when the held-out free-run error
    is lower with it by over :data:`mggp.fit.choices.GAIN`, significantly at
    p < :data:`mggp.fit.choices.LEVEL` (never with the steady-state constraints).
``operators`` (:class:`OperatorsAdded`)
    With ``operators`` and ``operator_entry='stage'``: memory-operator
    terms added stepwise to the structure (:mod:`mggp.fit.operator_stage`);
    sets ``operator_steps_``.
``prune`` (:class:`Pruned`)
    Backward elimination by BIC of the fitness or by t-statistics
    (``prune``; :mod:`mggp.fit.pruning`).
``local_search`` (:class:`LocalSearched`)
    One-term moves from the chosen structure while they lower the search's
    fitness (``local_search``; :mod:`mggp.fit.local_search`), then the same
    pruning again; sets ``local_search_``.
``extend`` (:class:`Extended`)
    'auto': the catalogue of ``mggp diagnose``'s extensions of the chosen
    structure (plays, Bouc–Wen variables, Φ of the inputs and of the
    output lags, operator dynamics, operators in the feedback, and the
    memory-free rivals), each fitted where the other choices fit and
    tested against it on their held-out part by the diagnosis's paired
    block-bootstrap test; the winner is taken when it also stays bounded
    on the probe and stress inputs (``extend``;
    :mod:`mggp.fit.extension`); sets ``extension_``. After the choices of
    the structure and before the noise terms, the record and every refit,
    so that those apply to the final structure.
``operator_params``
    'auto': the memory operators' parameters (play radii, Bouc–Wen β, γ)
    estimated by free-run error, θ by least squares at each trial, when
    that simulates the held-out part better than the search's grid of them
    (``operator_params``; :func:`mggp.fit.choices.operator_params_choice`).
``noise``
    Moving-average noise terms by extended least squares (``noise_lags``;
    :mod:`mggp.fit.noise`).
``record`` (:class:`Recorded`)
    ``terms_``, ``fitness_`` and the ``meta`` every model of the fit carries.
``qr_refit`` (:class:`Refitted`)
    ``model_``: θ by least squares (QR) on the whole record; with
    ``estimator='oe'`` the output-error θ of the search's scorer.
``precision`` (:class:`PrecisionChecked`)
    The fitness with the search's θ and with the QR θ (``precision_``,
    :mod:`mggp.fit.precision`); ``model_`` keeps the search's θ when the QR
    refit simulates worse.
``cls_refit`` (:class:`ClsRefitted`)
    ``model_cls_``: θ by constrained least squares under the
    continuum-of-steady-states equalities of the terms (``constraints``).
``refine`` (:class:`Refined`)
    θ of both models by minimising the simulation error (``refine``;
    'auto', the default: when the free-run refit simulates the held-out
    part better than least squares; also when the extension taken won with
    θ refined so).
``cls_verdict`` (:class:`ClsVerdict`)
    ``cls_rejected_``: why the CLS refit is not the default model
    (:func:`cls_rejection`), with a :class:`CLSRejectedWarning`.
``pareto`` (:class:`Front`)
    ``pareto_front_`` of the run, with the θ the search scored.

All stages score with the one :class:`narx.estimation.fitness.StructureScorer` of the
search's settings (``ctx.scorer``, also the search's own in this process);
a stage that simulates with other settings asks :meth:`FitContext.scorer_for`,
which builds at most one scorer per setting.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Callable, Dict, List, Optional, Protocol, Tuple

from narx import Model
from narx.records.data import Data
from narx.estimation.fitness import StructureScorer
from narx.model import ignore_rank_warnings
from narx.estimation.output_error import OE_ESTIMATORS
from narx.language.phi import PhiRegistry
from narx.records.ranges import signal_ranges
from narx.language.terms import Term

from .choices import (STAGE_CHOICES, THETA_WORDS, Choice, constant_choice, constant_off,
                      error_floor, front_rows_heldout, heldout_rmse, heldout_samples,
                      heldout_theta, local_search_kept, resolve_select, size_choice, steady,
                      theta_choice)
from ..gp.evaluate import criterion_value
from ..exceptions import CLSRejectedWarning
from .noise import full_ma, prune_process, select_noise
from ..gp.pareto import ParetoFront, front_rows
from .precision import search_precision
from .pruning import prune_by_criterion, prune_by_t, t_threshold_of
from .selection import run_candidates, select_freerun, select_hold

if TYPE_CHECKING:
    from ..gp.evolve import EvolutionResult
    from .choices import SearchClass
    from .extrapolation import StressCheck
    from .precision import PrecisionCheck
    from .screen import StabilityScreen

__all__ = ["FitContext", "Settings", "STAGES", "run_stages", "cls_rejection", "CLS_WORSE",
           "Decision", "Selected", "OperatorsAdded", "Pruned", "LocalSearched", "Extended",
           "Recorded",
           "Refitted", "PrecisionChecked", "ClsRefitted", "Refined", "ClsVerdict", "Front"]

#: a CLS refit whose free-run RMSE on the training record is more than this
#: many times the LS fit's is not preferred to it
CLS_WORSE = 2.0

#: warnings point at the caller of ``fit`` (fit -> run_stages -> stage)
_CALLER = 4

#: the local search starts no step once it has scored this share of the
#: structures the search scored (and at least LOCAL_EVALS_MIN)
LOCAL_EVALS_SHARE = 0.1
LOCAL_EVALS_MIN = 1000


class Settings(Protocol):
    """What the stages read of :class:`mggp.MGGPRegressor`: its parameters
    (:data:`mggp.fit.params.PARAMS`; the stages read these and
    ``max_height_``, and write nothing)."""

    select: str
    select_candidates: int
    screen: str
    screen_band: Any
    size: Any
    constant: Any
    criterion: str
    prune: Any
    t_threshold: Optional[float]
    local_search: bool
    extend: str
    operator_params: str
    max_height_: int
    max_lag: Optional[int]
    max_degree: Optional[int]
    max_terms: int
    noise_lags: int
    estimator: str
    constraints: Optional[str]
    search_constraints: Optional[str]
    refine: Any
    refine_window: Optional[int]
    window: Optional[int]


# ---------------------------------------------------------------- decisions
@dataclass(frozen=True)
class Decision:
    """What a stage decided: the structure it hands on (``size``,
    ``constant`` and ``noise`` decide nothing else; their automatic choices
    record themselves in :attr:`FitContext.choices`)."""

    terms: Tuple[Term, ...]


@dataclass(frozen=True)
class Selected(Decision):
    """``select``: ``terms`` is ``search_terms_``; ``selection`` is
    ``selection_`` (None: no candidates were compared)."""

    selection: Optional[list] = None


@dataclass(frozen=True)
class OperatorsAdded(Decision):
    """``operators``: ``steps`` is ``operator_steps_`` (None: no stage ran)."""

    steps: Optional[list] = None


@dataclass(frozen=True)
class Pruned(Decision):
    """``prune``: ``t_threshold`` is ``t_threshold_`` (``prune='t'`` only)."""

    t_threshold: Optional[float] = None


@dataclass(frozen=True)
class LocalSearched(Decision):
    """``local_search``: ``steps`` is ``local_search_`` (the moves kept)."""

    steps: list = field(default_factory=list)


@dataclass(frozen=True)
class Extended(Decision):
    """``extend``: ``extension`` is ``extension_`` (None: no catalogue was
    tried); ``theta`` is 'freerun' when the extension taken had its θ
    refined by free-run simulation error (the ``refine`` stage then refines
    the final model so), else 'ls'."""

    extension: Optional[dict] = None
    theta: str = "ls"


@dataclass(frozen=True)
class Recorded(Decision):
    """``record``: ``terms`` is ``terms_``, ``fitness`` is ``fitness_``."""

    fitness: float = float("nan")


@dataclass(frozen=True)
class Refitted(Decision):
    """``qr_refit``: ``model`` is ``model_``, ``rank`` is ``rank_``."""

    model: Optional[Model] = None
    rank: int = 0


@dataclass(frozen=True)
class PrecisionChecked(Decision):
    """``precision``: ``check`` is ``precision_``; ``model`` is ``model_``
    (the search's θ where the QR refit simulates worse)."""

    check: Optional["PrecisionCheck"] = None
    model: Optional[Model] = None


@dataclass(frozen=True)
class ClsRefitted(Decision):
    """``cls_refit``: ``model_cls`` is ``model_cls_``; ``error`` is
    ``cls_error_`` (None: no error)."""

    model_cls: Optional[Model] = None
    error: Optional[str] = None


@dataclass(frozen=True)
class Refined(Decision):
    """``refine``: ``refinement`` is ``refinement_``; ``model`` and
    ``model_cls`` are ``model_`` and ``model_cls_``, refined or as they came."""

    refinement: Any = None
    model: Optional[Model] = None
    model_cls: Optional[Model] = None


@dataclass(frozen=True)
class ClsVerdict(Decision):
    """``cls_verdict``: ``rejected`` is ``cls_rejected_``."""

    rejected: Optional[str] = None


@dataclass(frozen=True)
class Front(Decision):
    """``pareto``: ``front`` is ``pareto_front_``."""

    front: Optional[ParetoFront] = None


@dataclass
class FitContext:
    """What the stages share.

    Attributes
    ----------
    est : Settings
        The estimator, read for its settings (the stages write nothing to it).
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
        The model class searched (:func:`mggp.fit.choices.search_classes`):
        Φ or not, the memory operators and where they enter.
    choices : dict
        The automatic choices made (:class:`mggp.fit.choices.Choice` by
        parameter name), recorded in ``meta['choices']``.
    stress : StressCheck or None
        The stress test of the final choices (``stress``;
        :class:`mggp.fit.extrapolation.StressCheck`).
    allowed : callable
        ``allowed(term) -> bool``: whether the search may use a term (the
        local search's moves keep to it).
    decided : dict
        The decisions of the stages run so far, by stage name.
    scans : dict or None
        :func:`narx.records.deadtime.onset_scans` of the record (the dead
        times; ``extend`` reads them).
    """

    est: Settings
    data: Data
    registry: Optional[PhiRegistry]
    start: int
    scorer: Optional[StructureScorer]
    result: Optional["EvolutionResult"] = None
    shape: Callable[[Tuple[Term, ...]], Tuple[Term, ...]] = tuple
    screen: Optional["StabilityScreen"] = None
    seed: Optional[int] = None
    search_class: Optional["SearchClass"] = None
    meta: dict = field(default_factory=dict)
    choices: dict = field(default_factory=dict)
    stress: Optional["StressCheck"] = None
    allowed: Callable[[Term], bool] = lambda term: True
    decided: Dict[str, Decision] = field(default_factory=dict)
    scans: Optional[dict] = None
    _scorers: Dict[Tuple, StructureScorer] = field(default_factory=dict)

    def latest(self, name: str, default=None):
        """Field ``name`` of the last decision so far that has one (e.g.
        ``'model'``: refined, else precision-checked, else refitted)."""
        for d in reversed(list(self.decided.values())):
            if hasattr(d, name):
                return getattr(d, name)
        return default

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
    selection = None
    if how == "freerun":
        cands = run_candidates(ctx.result, data.signals, ctx.shape, est.select_candidates)
        chosen, selection = select_freerun(cands, data, ctx.start, ctx.registry,
                                                scorer=ctx.scorer_for("freerun"),
                                                check=ctx.stress)
        terms = chosen or terms
    elif how == "hold":
        cands = run_candidates(ctx.result, data.signals, ctx.shape, est.select_candidates)
        scr = ctx.screen
        shared = scr if (scr is not None and scr.hold is not None
                         and est.search_constraints is None) else None
        chosen, selection = select_hold(cands, data, ctx.start, ctx.registry,
                                             est.screen_band, screen=shared)
        if "select" in ctx.choices:
            c, at = ctx.choices["select"], len(selection)
            ctx.choices["select"] = replace(c, why=c.why + (
                f"; candidate {at} of {len(cands)} (best fitness first) holds" if chosen
                else f"; none of the {len(cands)} candidates holds"),
                figures={"candidates": len(cands), "holding": at if chosen else None})
        if not chosen:
            warnings.warn(f"select='hold': none of the {len(selection)} candidates "
                          f"holds its output on a held input; model_ is the best-fitness "
                          f"structure (see selection_)", UserWarning, stacklevel=_CALLER)
        terms = chosen or terms
    return Selected(terms, selection)


def local_search(terms, data, ctx):
    """``local_search``: best-improvement one-term moves from the chosen
    structure while the measure that chose it falls: the search's fitness
    (criterion included), or with ``select`` 'freerun' the free-run error
    over the record, each at least the square of
    :func:`mggp.fit.choices.error_floor` (below it rounding, where dropping a
    term keeps the measure and is taken); each accepted move passes the search's stability
    screen (:func:`mggp.fit.local_search.improve`), within
    :data:`LOCAL_EVALS_SHARE` of the search's evaluations; a moved structure is pruned
    again (``prune``), and kept only when its held-out free-run error is not
    worse than the chosen structure's beyond the size choice's tolerance and,
    with ``stress``, its free run stays bounded on the stress inputs when the
    chosen structure's does (:func:`mggp.fit.choices.local_search_kept`;
    otherwise the choice line says so). A structure chosen for its holding
    (``select`` 'hold') is kept as chosen."""
    est = ctx.est
    how = selected(ctx)
    if not est.local_search or how == "hold":
        return LocalSearched(terms)
    from .local_search import improve, term_moves
    from ..gp.primitives import reachable_lag
    lags = range(1, reachable_lag(est.max_height_, est.max_lag) + 1)
    degree = est.max_degree or max(3, max((t.degree for t in terms), default=1))
    moves = term_moves(data.signals, lags, degree, ctx.allowed)
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
        return LocalSearched(terms)
    moved = prune(moved, data, ctx).terms
    unbounded = "" if ctx.stress is None or ctx.stress(terms) else ctx.stress(moved)
    theta = heldout_theta(est)
    c = local_search_kept(heldout_rmse(terms, data, ctx.registry, theta=theta),
                          heldout_rmse(moved, data, ctx.registry, theta=theta),
                          heldout_samples(data.n), len(steps), unbounded)
    if not c.value:
        ctx.choices["local_search"] = c
        return LocalSearched(terms)
    return LocalSearched(moved, [s.to_dict() for s in steps])


def size(terms, data, ctx):
    """``size='auto'``: the smallest structure of the run's Pareto front
    whose held-out free-run error is within :data:`mggp.fit.choices.SIZE_TOLERANCE`
    of the least (2/√n on n
    held-out samples when larger: :func:`mggp.fit.choices.size_tolerance`), the chosen
    structure included (:func:`mggp.fit.choices.size_choice`). A structure
    chosen for its holding (``select`` 'hold') is kept, and so is the size an
    information criterion (``criterion`` 'bic'/'aic') or pruning chose."""
    est = ctx.est
    if est.size != "auto" or selected(ctx) == "hold":
        return Decision(terms)
    if est.criterion != "mse" or est.prune:
        by = (f"the {est.criterion.upper()} criterion" if est.criterion != "mse"
              else f"pruning ({est.prune})")
        ctx.choices["size"] = Choice("size", len(terms), f"size {len(terms)} terms: "
                                     f"chosen by {by}, not by held-out error", {})
        return Decision(terms)
    theta = heldout_theta(ctx.est)
    c = size_choice(front_rows_heldout(terms, ctx.result, ctx.shape, data, ctx.registry,
                                       theta), heldout_samples(data.n), ctx.stress)
    why = c.why + THETA_WORDS.get(theta, "").replace(",", ";", 1)
    ctx.choices["size"] = Choice(c.name, len(c.value), why, c.figures)
    return Decision(c.value)


def constant(terms, data, ctx):
    """``constant='auto'``: the constant term offered to every structure of
    the search is kept only when the chosen structure's held-out free-run
    error is lower with it by over :data:`mggp.fit.choices.GAIN` at
    p < :data:`mggp.fit.choices.LEVEL`
    (:func:`mggp.fit.choices.constant_choice`);
    with the steady-state constraints it was not offered, and when the
    pilots chose a search without it (:meth:`MGGPRegressor._searches`) the
    structure has none."""
    if ctx.est.constant != "auto":
        return Decision(terms)
    if steady(ctx.est):
        ctx.choices["constant"] = constant_off()
        return Decision(terms)
    pilot = ctx.choices.get("constant")
    if pilot is not None and not pilot.value:   # searched without it (the pilots' choice)
        return Decision(terms)
    c, terms = constant_choice(terms, data, ctx.registry, ctx.seed or 0,
                               heldout_theta(ctx.est))
    if pilot is not None:
        c = replace(c, why=f"{pilot.why}; then {c.why}", figures={**pilot.figures,
                                                                   **c.figures})
    ctx.choices["constant"] = c
    return Decision(terms)


def operators(terms, data, ctx):
    """Memory-operator terms added stepwise when the searched class has
    operators outside its primitive set (``operators`` named,
    ``operator_entry='stage'``; :func:`mggp.fit.operator_stage.add_operators`)."""
    est = ctx.est
    cls = ctx.search_class
    if cls is None or not cls.operators or cls.in_search:
        return OperatorsAdded(terms)
    names = cls.operators
    from .operator_stage import add_operators, operator_candidates
    terms, steps = add_operators(
        ctx.scorer, terms, operator_candidates(data, names), est.max_terms,
        keep=ctx.shape(()))
    return OperatorsAdded(terms, steps)


def prune(terms, data, ctx):
    """Backward elimination of terms (``prune``: 'bic' or 't')."""
    est = ctx.est
    if est.prune == "bic":
        return Pruned(prune_by_criterion(ctx.scorer, terms, data.n - ctx.start))
    if est.prune == "t":
        from narx.estimation.estimate import t_statistics
        from narx.records.regressors import regressor_matrix
        crit = t_threshold_of(est, len(data.inputs))
        return Pruned(prune_by_t(terms, lambda ts: t_statistics(
            *regressor_matrix(ts, data, start=ctx.start)[:2]), crit), crit)
    return Pruned(terms)


def extend(terms, data, ctx):
    """``extend='auto'``: the catalogue of ``mggp diagnose``'s extensions
    of the structure chosen so far, each fitted on the part of the record
    the other choices fit on and tested against it on their held-out part
    by the diagnosis's paired test at its ``level`` (``mggp diagnose``'s
    default, :data:`mggp.fit.params.DIAGNOSE_PARAMS`); the winner is taken
    when it also stays bounded on the probe and stress inputs
    (:func:`mggp.fit.extension.extension_choice`).

    It runs after every choice of the structure (select, size, constant,
    operators, prune, local search), so it extends the structure the fit
    would otherwise return; before ``noise``, so that moving-average noise
    terms are selected around the final process terms; and before
    ``record``, ``qr_refit``, ``precision``, ``cls_refit`` and ``refine``,
    so that ``terms_``, the meta and θ on the whole record are those of the
    final structure (a winner whose θ was refined by free-run simulation
    error is refined so on the whole record by ``refine``). Not with the
    steady-state constraints: the hold selection chose the structure for
    its CLS refit, which an extension would not keep."""
    est = ctx.est
    if est.extend == "none":
        return Extended(terms)
    if steady(est):
        ctx.choices["extend"] = Choice(
            "extend", "none", "kept: no extension tried with constraints='steady-state' "
            "(the structure was chosen for its CLS refit)", {"winner": None})
        return Extended(terms)
    from .extension import extension_choice
    from .params import DIAGNOSE_PARAMS
    ext = extension_choice(terms, data, ctx.registry, ctx.seed or 0,
                           DIAGNOSE_PARAMS["level"].default,
                           DIAGNOSE_PARAMS["resolution"].default, heldout_theta(est),
                           est.max_terms, ctx.allowed, ctx.stress, ctx.scans)
    ctx.choices["extend"] = ext.choice
    return Extended(ext.terms, ext.to_dict(), ext.theta)


def operator_params(terms, data, ctx):
    """``operator_params='auto'``: the memory operators' parameters of the
    final structure estimated by free-run error when that simulates the
    held-out part better than the search's grid of them
    (:func:`mggp.fit.choices.operator_params_choice`). After ``extend``, so
    that the parameters are those of the final structure, and before
    ``noise`` and every refit on the whole record. Not with the
    steady-state constraints (the structure was chosen for its CLS refit)."""
    est = ctx.est
    if est.operator_params == "none" or steady(est):
        return Decision(terms)
    from .choices import operator_params_choice
    c, new = operator_params_choice(terms, data, ctx.registry, ctx.stress)
    if c.figures:
        ctx.choices["operator_params"] = c
    return Decision(tuple(new))


def noise(terms, data, ctx):
    """Moving-average noise terms (``noise_lags`` > 0), as many as
    ``max_terms`` leaves room for beside the process terms; with
    ``prune='t'`` the process terms that only predicted the noise are
    dropped first."""
    est = ctx.est
    if not est.noise_lags:
        return Decision(terms)
    crit = t_threshold_of(est, len(data.inputs))
    q = int(est.noise_lags)
    if est.prune == "t":
        terms = prune_process(data, terms, full_ma(data, q, ctx.registry), ctx.start,
                              ctx.registry, crit)
    return Decision(terms + select_noise(data, terms, ctx.start, ctx.registry, q, crit,
                                         limit=max(est.max_terms - len(terms), 0)))


def record(terms, data, ctx):
    """``terms_``, ``fitness_`` and the meta of the fit's models."""
    from ..version import versions
    from .params import meta_of
    est = ctx.est
    fitness = ctx.result.best.fitness if terms == ctx.decided["select"].terms else \
        criterion_value(ctx.scorer.score(terms), len(terms), data.n - ctx.start,
                        est.criterion)
    resolved = {name: c.value for name, c in ctx.choices.items()}
    ctx.meta = dict(meta_of(est), **resolved, seed=ctx.seed,
                    cls_refit=est.constraints == "steady-state",
                    search_fitness_value=fitness, versions=versions(),
                    ranges=signal_ranges(data))
    if ctx.choices:
        ctx.meta["choices"] = {name: c.to_dict() for name, c in ctx.choices.items()}
    if ctx.search_class is not None and ctx.search_class.operators:
        ctx.meta["operators"] = list(ctx.search_class.operators)
        ctx.meta["operator_entry"] = "search" if ctx.search_class.in_search else "stage"
    return Recorded(terms, fitness)


def _model(terms, data, ctx, estimation, theta=None, **extra) -> Model:
    return Model(terms, theta, inputs=data.inputs, output=data.output,
                 meta=dict(ctx.meta, estimation=estimation, **extra), registry=ctx.registry)


def qr_refit(terms, data, ctx):
    """``model_``: least squares by QR on the record. Terms the record cannot
    tell apart (``rank_`` below their number) get the minimum-norm θ.
    With ``estimator`` 'oe' or 'bj' (and no noise terms) θ is the output-error
    estimate of the search's scorer (:mod:`narx.estimation.output_error`), which
    measurement noise does not bias, and ``model_.meta['estimation']`` is
    ``'oe'``."""
    est = ctx.est
    with ignore_rank_warnings():
        model = _model(terms, data, ctx, "ls").fit(data)
    rank = int(model.fit_info_["rank"])
    if est.estimator in OE_ESTIMATORS and not any(t.has_noise for t in terms):
        theta, _ = ctx.scorer.fitted(terms)
        if theta is not None:
            model = _model(terms, data, ctx, "oe", theta)
    return Refitted(terms, model, rank)


def precision(terms, data, ctx):
    """``precision_``: the fitness with the search's θ and the QR θ; the
    search's θ is kept when the QR refit simulates worse. Not compared for
    ELS fits of noise terms, CLS fits of a constrained search and
    output-error fits, which are not what the QR refit (LS) is."""
    est, model = ctx.est, ctx.latest("model")
    check = None if (any(t.has_noise for t in terms)
                     or est.search_constraints
                     or model.meta["estimation"] == "oe") else \
        search_precision(ctx.scorer, terms, model.theta, model.fit_info_["start"])
    if check is not None and check.refit_worse:
        model = _model(terms, data, ctx, "ls-search", check.search_theta,
                       qr_refit_fitness_value=check.refit_mse)
    return PrecisionChecked(terms, check, model)


def cls_refit(terms, data, ctx):
    """``model_cls_`` (``constraints='steady-state'``), or ``cls_error_``
    saying why the constrained fit is not possible.

    .. math:: \\theta_{CLS} = \\theta_{LS} - (\\Psi^T\\Psi)^{-1} S^T
              [S (\\Psi^T\\Psi)^{-1} S^T]^{-1} (S \\theta_{LS} - c)

    with :math:`S \\theta = c` the continuum-of-steady-states equalities of
    the terms (Abreu et al., Nonlinear Dynamics, 2020)."""
    model_cls = error = None
    if ctx.est.constraints == "steady-state":
        try:
            with ignore_rank_warnings():
                model_cls = _model(terms, data, ctx, "cls").fit(
                    data, constraints="steady-state")
        except ValueError as exc:
            error = str(exc)
    return ClsRefitted(terms, model_cls, error)


def refine(terms, data, ctx):
    """θ of ``model_`` and ``model_cls_`` by least simulation error
    (``refine``; ``refinement_`` holds the errors before and after).
    'auto' and 'compare': by free-run simulation error when that refit of
    the structure simulates the held-out part better than its LS θ
    (:func:`mggp.fit.choices.theta_choice`), never with the steady-state
    constraints (the hold selection judged the CLS refit of the LS θ).
    With ``refine`` 'auto', 'compare' or 'none', an extension taken with θ by free-run
    simulation error (:class:`Extended`) is refined so (without noise
    terms, whose θ come from extended least squares)."""
    est = ctx.est
    refinement, model, model_cls = None, ctx.latest("model"), ctx.latest("model_cls")
    how = est.refine
    noisy = any(t.has_noise for t in terms)
    extended = ctx.decided.get("extend")
    c = None
    if (extended is not None and extended.theta == "freerun"
            and how in ("auto", "compare", "none", None) and not noisy):
        how = "freerun"                 # the extension won with θ by simulation error
        if est.refine in ("auto", "compare"):
            c = Choice("refine", how, f"θ by free-run simulation error: the extension taken "
                       f"({extended.extension['winner']}) won the held-out test with them "
                       f"(refined on the whole record from its LS θ)", {})
    elif how in ("auto", "compare"):
        how = None
        if not steady(est) and not noisy:
            c = theta_choice(terms, data, ctx.registry, ctx.seed or 0)
            how = c.value
    if c is not None:
        ctx.choices["refine"] = c
        model.meta.setdefault("choices", {})["refine"] = c.to_dict()
        model.meta["refine"] = c.value
    if how and how != "none":
        from narx.refine import refine_both
        before, before_cls = model, model_cls
        refinement, model, model_cls, why = refine_both(
            model, model_cls, data, how, est.refine_window or est.window)
        if why:
            warnings.warn(f"refine={est.refine!r} is not applied: {why}", UserWarning,
                          stacklevel=_CALLER)
        elif c is not None and ctx.stress is not None:
            model, model_cls, refinement = _stress_refit(ctx, c, before, before_cls, model,
                                                         model_cls, refinement)
    return Refined(terms, refinement, model, model_cls)


def _stress_refit(ctx, c, before, before_cls, model, model_cls, refinement):
    """The automatic θ choice's refit kept only when its free run stays
    bounded on the stress inputs wherever the least-squares θ's does
    (:meth:`mggp.fit.extrapolation.StressCheck.fails_beyond`): the refit
    lowers the error on the training record, where nothing holds its
    poles or its nonlinear gains inside the stable region: on an
    evaluation draw of the zoo fit study (seed 1207, a play after linear
    dynamics with a rate-nonlinearity extension) the refit diverged on the
    validation record and on the training input scaled 1.5×, where the LS
    θ stayed finite. Returns ``(model, model_cls, refinement)``."""
    why = ctx.stress.fails_beyond(model, before)
    if not why:
        return model, model_cls, refinement
    kept = Choice("refine", None, f"θ by least squares: their free-run refit {why}, where "
                  f"the least-squares θ stays bounded (the refit was chosen for: "
                  f"{c.why})", dict(c.figures, stress_refused=why))
    ctx.choices["refine"] = kept
    before.meta.setdefault("choices", {})["refine"] = kept.to_dict()
    before.meta["refine"] = None
    return before, before_cls, None


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
    model, model_cls = ctx.latest("model"), ctx.latest("model_cls")
    held = screened(ctx) == "hold" or (selected(ctx) == "hold" and any(
        ok for ok, _ in ctx.latest("selection") or ()))
    rejected = None if model_cls is None else cls_rejection(model, model_cls, data, held)
    if rejected:
        warnings.warn(f"the CLS refit {rejected}: get_best(), simulate() and "
                      f"predict() use the LS model (constrained=True for the CLS one)",
                      CLSRejectedWarning, stacklevel=_CALLER)
    return ClsVerdict(terms, rejected)


def pareto(terms, data, ctx):
    """``pareto_front_``: the run's front with the θ the search scored."""
    return Front(terms, ParetoFront(front_rows(ctx.result.pareto, ctx.scorer, ctx.shape),
                                    inputs=data.inputs, output=data.output,
                                    registry=ctx.registry))


#: the stages of ``fit`` after the search, in order
STAGES = (("select", select), ("size", size), ("constant", constant),
          ("operators", operators), ("prune", prune), ("local_search", local_search),
          ("extend", extend), ("operator_params", operator_params), ("noise", noise),
          ("record", record), ("qr_refit", qr_refit),
          ("precision", precision), ("cls_refit", cls_refit), ("refine", refine),
          ("cls_verdict", cls_verdict), ("pareto", pareto))


class _Resolved:
    """The estimator's settings with the stage-time automatic choices taken
    (:data:`mggp.fit.choices.STAGE_CHOICES`): each parameter chosen reads as
    the value taken, every other as set."""

    def __init__(self, est, values: dict):
        self._est, self._values = est, values

    def __getattr__(self, name):
        values = self.__dict__["_values"]
        return values[name] if name in values else getattr(self.__dict__["_est"], name)


def resolve_stage_choices(ctx: FitContext) -> None:
    """Take the automatic choices of :data:`mggp.fit.choices.STAGE_CHOICES`
    whose parameter is 'auto', record each in ``ctx.choices``, and let the
    stages read the values taken (``ctx.est``)."""
    values = {}
    for name, resolve in STAGE_CHOICES.items():
        if getattr(ctx.est, name) == "auto":
            ctx.choices[name] = c = resolve(ctx)
            values[name] = c.value
    if values:
        ctx.est = _Resolved(ctx.est, values)


def run_stages(terms, data: Data, ctx: FitContext, stages=STAGES) -> Dict[str, Decision]:
    """Take the stage-time automatic choices (:func:`resolve_stage_choices`),
    then pass ``terms`` through ``stages``, each taking the structure the one
    before handed on; returns the decisions by stage name (also
    :attr:`FitContext.decided`)."""
    resolve_stage_choices(ctx)
    for name, stage in stages:
        ctx.decided[name] = decision = stage(terms, data, ctx)
        terms = decision.terms
    return ctx.decided
