"""Baseline search, the diagnosis budget, and the search-based extension.

:func:`mggp.diagnose.diagnose` uses :class:`Budget`,
:func:`baseline_search` and :func:`user_setting` from here; its
extensions are the candidates of :mod:`.candidates`, chosen by the test of
:mod:`.verdict`. :func:`plan_extension` and :func:`fit_extension` (an MGGP
search set up for named effects) remain as a library route to a searched
extension once the effect is known.

Typical use::

    from mggp.diagnose.extend import Budget, baseline_search, plan_extension, fit_extension
    base, setting = baseline_search(fit_data, Budget(), seed=0, jobs=2)
    plan = plan_extension(["hysteresis"], setting, Budget())
    ext = fit_extension(plan, base, fit_data, Budget(), seed=0, jobs=2)
    ext.model, ext.chosen, ext.candidates

The baseline, when the user gives no model, is a plain polynomial NARX
model found by MGGP with multiple-shooting fitness and no Φ-functions.
The extension changes the search the way each cause calls for
(:data:`mggp.diagnose.findings.EXTENSIONS`):

* ``hysteresis`` — Φ-functions and the memory operators Play, DengTan
  (:mod:`narx.language.memory`) in the primitive set (if the baseline already had
  Φ-functions: five more terms), the three Bouc–Wen direction terms
  (:func:`~mggp.diagnose.augmentation.direction_terms`) added to the
  baseline's terms, to the search's, and as a discrete Bouc–Wen
  increment model of their own, and memory-operator terms
  (:func:`operator_terms`) added to the baseline's terms and as linear
  dynamics of order up to 3 driven by them (:func:`operator_dynamics_terms`),
  and linear dynamics of order up to 3 driven by Bouc–Wen variables of the
  input on a grid of shapes (:func:`bouc_wen_dynamics_terms`; the Bouc–Wen
  gain is a coefficient, so LS fits it);
* ``prediction-bias`` — multiple-shooting fitness (if the baseline already
  used it: windows four times longer, closer to a free run);
* ``steady-state-drift`` — CLS under the continuum-of-steady-states
  constraints derived from the terms (:mod:`narx.analysis.steady`), in the search
  and in the final fit; with no other cause the baseline's own terms are
  refitted by CLS, and a CLS search is run only if that refit is impossible
  or diverges on the fitting record;
* ``unmodelled-nonlinearity`` / ``unmodelled-dynamics`` — one more degree /
  taller trees (longer lags) and five more terms, applied only when no
  specific cause above was named (they are then its symptoms).

When a search is run, its model and its union with the baseline's terms
are candidates (with the direction-term candidates for hysteresis). Each
candidate not taken from the search is offered as built and pruned
(:func:`_pruned`: backward elimination by BIC on its free-run error on the
fitting samples), as a union of term sets or a generic structure such as
the operator dynamics carries terms that the others make redundant, and
those extrapolate worst; the search's candidates are not pruned again
(their terms were already selected on the fitting samples). Each is
ranked by hold-out validation inside the fitting samples: estimated
(LS or CLS) on their first :data:`HOLDOUT_FIT` share and scored by its
free-run RMSE on the rest, so a candidate is not favoured by fitting the
samples that rank it; it is also estimated on all the fitting samples
(the model that would be kept) and its score is the larger of that
hold-out RMSE and this model's free-run RMSE on the fitting samples, so
the kept model must simulate well too. The smallest score wins. The
samples that measure the gain play no part in building the extension. Under CLS
(drift named, so the system holds) candidates that do not keep still in
holds inserted into the fitting input
(:func:`~mggp.diagnose.holds.probe_holds`) rank after those that do,
by how far they move.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from typing import List, Optional, Sequence, Tuple

import numpy as np

from narx import Model
from narx.records.data import Data
from narx.estimation.estimate import EstimationError
from narx.model import ignore_rank_warnings
from narx.language.terms import Signals, parse_term

from ..gp.primitives import AUTO_OPERATORS
from ..fit.selection import CLSRejectedWarning
from .augmentation import bouc_wen_terms, direction_terms, operator_terms
from .budget import Budget
from .holds import probe_holds
from .simulation import freerun_rmse

__all__ = ["Budget", "Setting", "ExtensionPlan", "Extension", "baseline_search", "bounded_baseline",
           "SEARCH_MODEL_KEPT",
           "user_setting", "plan_extension", "fit_extension", "candidate_changes",
           "operator_terms", "operator_dynamics_terms", "bouc_wen_dynamics_terms",
           "OPERATORS"]

_SPECIFIC = ("hysteresis", "prediction-bias", "steady-state-drift")
#: memory operators of the hysteresis search (:mod:`narx.language.memory`)
OPERATORS = AUTO_OPERATORS


def _linear_dynamics(data: Data) -> List[str]:
    """y[k-1..3] and u[k-1..2] of every input: the linear part of the
    operator-driven candidates."""
    return ([f"{data.output}[k-{j}]" for j in (1, 2, 3)]
            + [f"{n}[k-{j}]" for n in data.inputs for j in (1, 2)])


def operator_dynamics_terms(data: Data) -> List[str]:
    """Linear dynamics of order up to 3 driven by the inputs and their
    memory operators: y[k-1..3], u[k-1..2] and :func:`operator_terms` at
    lags 1 and 2 (a play or Prandtl–Ishlinskii operator behind a linear
    filter of order up to 3 is such a model)."""
    return _linear_dynamics(data) + operator_terms(data, (1, 2))


def bouc_wen_dynamics_terms(data: Data) -> List[str]:
    """Linear dynamics of order up to 3 driven by the inputs and their
    Bouc–Wen variables: y[k-1..3], u[k-1..2] and :func:`bouc_wen_terms` at
    lags 1 and 2 (a Bouc–Wen hysteresis y = d·u − A·h behind a linear
    filter of order up to 3 is such a model when a shape of the grid is
    near its own)."""
    return _linear_dynamics(data) + bouc_wen_terms(data, (1, 2))


@dataclass(frozen=True)
class Setting:
    """How a model is (or was) searched and estimated."""

    fitness: Optional[str]
    window: int
    use_phi: bool
    constraints: Optional[str]
    max_degree: int
    max_height: int
    max_terms: int
    operators: Tuple[str, ...] = ()

    def describe(self) -> str:
        return (f"fitness {self.fitness or 'unknown'}"
                + (f" (window {self.window})" if self.fitness == "ms" else "")
                + f", {'with' if self.use_phi else 'no'} Φ-functions, "
                f"{'CLS' if self.constraints else 'LS'}, at most {self.max_terms} terms, "
                f"degree <= {self.max_degree}, tree height <= {self.max_height}"
                + (f", memory operators {', '.join(self.operators)}" if self.operators
                   else ""))


@dataclass(frozen=True)
class ExtensionPlan:
    """The new search setting, whether to search, refit by CLS, and add
    the Bouc–Wen direction terms as candidates, and the changes in words."""

    setting: Setting
    search: bool
    refit_cls: bool
    direction: bool
    changes: Tuple[str, ...]


@dataclass(frozen=True)
class Extension:
    """The fitted extension: the chosen model, its name among the
    candidates, every candidate as (name, terms, score: the larger of its
    hold-out free-run RMSE on the tail of the fitting samples and its
    free-run RMSE on the fitting samples (:func:`fit_extension`), movement in
    probe holds — NaN when not checked), the
    plan, and ``changes``: what the *chosen* candidate changed, in words
    (:func:`candidate_changes`; the plan's changes describe the search,
    which the chosen candidate may not come from)."""

    model: Model
    chosen: str
    candidates: Tuple[Tuple[str, int, float, float], ...]
    plan: ExtensionPlan
    changes: Tuple[str, ...] = ()


def _regressor(setting: Setting, budget: Budget, seed, jobs, data: Data, callbacks=None):
    from ..fit.choices import AS_SEARCHED
    from ..fit.estimator import MGGPRegressor
    return MGGPRegressor(fitness=setting.fitness or "ms", window=setting.window,
                         use_phi=setting.use_phi, constraints=setting.constraints,
                         search_constraints=setting.constraints,
                         population=budget.population, generations=budget.generations,
                         max_terms=setting.max_terms, max_height=setting.max_height,
                         max_degree=setting.max_degree, random_state=int(seed),
                         screen=None, select="fitness", **AS_SEARCHED,
                         n_jobs=jobs, inputs=list(data.inputs), output=data.output,
                         operators=list(setting.operators) or None,
                         operator_entry="search",
                         callbacks=callbacks(budget.generations) if callbacks else None)


def _fit_window(window: int, data: Data) -> int:
    return int(max(1, min(window, data.n // 4)))


def baseline_search(data: Data, budget: Budget, seed=0, jobs=1,
                    callbacks=None, records: Sequence[Tuple[str, Data]] = ()
                    ) -> Tuple[Model, Setting]:
    """MGGP with MS fitness and no Φ on ``data``; returns the LS model,
    bounded over ``records`` ``[(name, Data)]`` (:func:`bounded_baseline`;
    default ``data``).

    ``callbacks(generations)``, if given, returns the search's per-generation
    callbacks (:class:`~mggp.fit.estimator.MGGPRegressor` ``callbacks``)."""
    setting = Setting("ms", _fit_window(budget.window, data), False, None, budget.max_degree,
                      budget.max_height, budget.max_terms)
    est = _regressor(setting, budget, seed, jobs, data, callbacks).fit(data)
    model = bounded_baseline(est.model_, est.pareto_front_, data, records)
    model.meta.update({"source": "mggp diagnose baseline", "fitness": "ms",
                       "use_phi": False})
    return model, setting


#: ``meta['bounded']`` of a baseline that is the search's own model
#: (:func:`bounded_baseline`)
SEARCH_MODEL_KEPT = "the search's model"


def _unbounded(model: Model, data: Data, records) -> str:
    """Why the free run of ``model`` over one of ``records`` (``[(name,
    Data)]``) diverges or leaves the fitting output's mean ± 3 ranges (the
    band of the stress rule, :func:`mggp.fit.extrapolation.band_verdict`),
    else ``''``."""
    from ..fit.extrapolation import band_verdict, output_band
    with np.errstate(all="ignore"):
        return band_verdict(model, [(f"over {name}", rec) for name, rec in records],
                            *output_band(data))


def bounded_baseline(model: Model, front, data: Data,
                     records: Sequence[Tuple[str, Data]] = ()) -> Model:
    """The search's model when its free run stays bounded over the records
    the diagnosis runs it on, else the least-loss structure of the search's
    Pareto ``front`` whose free run does, estimated by LS on ``data``; the
    search's model when none does. ``meta['bounded']`` says which and why.

    Bounded: the free run over each of ``records`` (``[(name, Data)]``:
    the whole training record and the validation record; default
    ``data``), from its first
    samples, stays finite and within the fitting output's mean ± 3 ranges
    (the band of the stress rule of ``mggp fit``). Only the records'
    inputs and first samples enter; nothing is scored. Every candidate and
    the test compare free runs with the baseline's there: a baseline whose
    free run diverges on the selection samples makes every finite
    candidate win, and the candidates built on its terms inherit its
    instability. On 55 of the 900 development draws of the zoo (seeds
    0-899) the search's model diverged on the selection samples; on the
    shared MR damper (x, v, E -> f) the 15-term search model simulated the
    fitting samples at 55 N and diverged over the rest of the training
    record, where the voltage falls below the fitting samples' range.
    """
    from .candidates import _estimate
    records = tuple(records) or (("the fitting samples", data),)
    why = _unbounded(model, data, records)
    if not why:
        model.meta["bounded"] = SEARCH_MODEL_KEPT
        return model
    for r in sorted(front, key=lambda r: r["loss"]):
        if sorted(r["terms"]) == sorted(model.term_texts):
            continue
        m = _estimate(r["terms"], data, None, model.registry)
        if m is None or _unbounded(m, data, records):
            continue
        m.meta.update({k: v for k, v in model.meta.items() if k not in m.meta})
        m.meta["bounded"] = (f"the search's {model.n_terms}-term model {why}, so the "
                             f"baseline is the least-loss structure of its front that stays "
                             f"bounded there")
        return m
    model.meta["bounded"] = (f"the search's model {why}, and so does every structure of its "
                             f"front; kept")
    return model


def user_setting(model: Model, budget: Budget) -> Setting:
    """What can be read of a user model's search from its terms and meta."""
    fit = model.meta.get("fitness")
    fit = fit if fit in ("pem", "freerun", "ksa", "ms") else None
    has_phi = any(t.phi_names for t in model.terms)
    cls = bool(model.meta.get("estimation") == "cls")
    deg = max(t.degree for t in model.terms)
    height = max(budget.max_height, math.ceil(max(model.max_lag - 1, 0) / 3))
    win = model.meta.get("window")
    win = int(win) if isinstance(win, (int, float)) and win >= 1 else budget.window
    return Setting(fit, win, has_phi, "steady-state" if cls else None,
                   max(budget.max_degree, deg), height, max(budget.max_terms, model.n_terms))


def plan_extension(effects: Sequence[str], base: Setting, budget: Budget,
                   n_fit: Optional[int] = None) -> ExtensionPlan:
    """Turn named effects into a new search setting and a list of changes."""
    effects = set(effects)
    s, changes, search, refit = base, [], False, False
    if "hysteresis" in effects:
        search = True
        if not s.use_phi:
            s = replace(s, use_phi=True, operators=OPERATORS)
            changes.append("hysteresis: Φ-functions (Phi1, Phi2) and the memory operators "
                           "Play, DengTan added to the search (use_phi=True, operators="
                           "play, dengtan), and the Bouc–Wen direction terms "
                           "|Δu|, y[k-1]|Δu|, u[k-1]|Δu| and memory-operator terms as "
                           "candidates")
        else:
            s = replace(s, max_terms=s.max_terms + 5)
            changes.append(f"hysteresis: the baseline already had Φ-functions; new search "
                           f"with up to {s.max_terms} terms")
    if "prediction-bias" in effects:
        search = True
        if s.fitness != "ms":
            old = (f" instead of {s.fitness}" if s.fitness
                   else " (the baseline's own fitting is not known)")
            s = replace(s, fitness="ms", window=budget.window)
            changes.append(f"prediction-bias: a search with multiple-shooting fitness "
                           f"(window {budget.window}){old}")
        else:
            w = 4 * s.window if n_fit is None else min(4 * s.window, max(1, n_fit // 4))
            changes.append(f"prediction-bias: the baseline already used multiple shooting; "
                           f"windows {s.window} -> {w} samples")
            s = replace(s, window=w)
    if "steady-state-drift" in effects:
        s = replace(s, constraints="steady-state")
        refit = not search
        changes.append("steady-state-drift: CLS under the derived continuum-of-steady-states "
                       "constraints (Σ_y = 1, other cluster sums 0)")
    generic = [e for e in ("unmodelled-nonlinearity", "unmodelled-dynamics") if e in effects]
    if generic and not effects & set(_SPECIFIC):
        search = True
        if "unmodelled-nonlinearity" in effects:
            s = replace(s, max_degree=s.max_degree + 1)
            changes.append(f"unmodelled-nonlinearity: degree up to {s.max_degree}")
        if "unmodelled-dynamics" in effects:
            s = replace(s, max_height=s.max_height + 1)
            changes.append(f"unmodelled-dynamics: tree height up to {s.max_height} "
                           f"(lags up to {1 + 3 * s.max_height})")
        s = replace(s, max_terms=s.max_terms + 5)
        changes.append(f"up to {s.max_terms} terms")
    elif generic:
        changes.append(f"{', '.join(generic)}: no separate change (attributed to "
                       f"{', '.join(e for e in _SPECIFIC if e in effects)})")
    if search and s.fitness is None:
        s = replace(s, fitness="ms")
    return ExtensionPlan(s, search, refit, "hysteresis" in effects, tuple(changes))


_DRIFT = "steady-state-drift:"
#: suffix of a candidate's name when its terms were pruned (:func:`_pruned`)
PRUNED = ", pruned"


def _built_as(name: str) -> str:
    """The name of the candidate that ``name`` was pruned from (or ``name``)."""
    return name[:-len(PRUNED)] if name.endswith(PRUNED) else name


#: candidates estimated by LS even when drift is named: their memory operators
#: hold at a held input by themselves, and the continuum constraints (Σ_y = 1,
#: every other cluster 0) would set the operators' clusters to 0
_LS_CANDIDATES = ("baseline + operator terms", "operator dynamics", "Bouc–Wen dynamics")
_DIRECTION = "the Bouc–Wen direction terms |Δu|, y[k-1]|Δu|, u[k-1]|Δu|"


def candidate_changes(name: str, plan: ExtensionPlan) -> Tuple[str, ...]:
    """What the candidate ``name`` of :func:`fit_extension` changed, in words.

    Parameters
    ----------
    name : str
        The candidate's name (``'search'``, ``'search + baseline terms'``,
        ``'search + direction terms'``, ``'baseline + direction terms'``,
        ``'Bouc–Wen increment'``, ``'baseline + operator terms'``,
        ``'operator dynamics'``, ``'Bouc–Wen dynamics'``, ``'baseline terms,
        CLS'``), each possibly followed by :data:`PRUNED`.
    plan : ExtensionPlan
        The plan the candidates were built from.

    Returns
    -------
    tuple of str
        A candidate from the search carries the plan's changes (they set up
        the search) and how its terms were made; any other carries its own
        structure, the estimation (CLS when drift was named), the plan's
        remarks that change nothing, and — when a search ran — that its
        candidates were not chosen; a pruned candidate says so where its
        structure is named.
    """
    if name.endswith(PRUNED):
        # the line that names the structure says it was pruned
        built = list(candidate_changes(_built_as(name), plan))
        i = next((j for j, c in enumerate(built) if c.startswith("chosen candidate:")), 0)
        built[i] += ("; its terms then pruned by backward elimination (BIC on the free-run "
                     "error on the fitting samples)")
        return tuple(built)
    drift = [c for c in plan.changes if c.startswith(_DRIFT)]
    remarks = [c for c in plan.changes if "no separate change" in c]
    search = [c for c in plan.changes if c not in drift and c not in remarks]
    if name.startswith("search"):
        how = {"search": "the search's terms",
               "search + baseline terms": "the search's terms together with the baseline's",
               "search + direction terms": f"the search's terms and {_DIRECTION}"}
        return tuple(plan.changes) + (f"chosen candidate: {how.get(name, name)}",)
    own = {"baseline terms, CLS": "steady-state-drift: the baseline's own terms refitted by "
                                  "CLS under the derived continuum-of-steady-states "
                                  "constraints (Σ_y = 1, other cluster sums 0); no new terms",
           "baseline + direction terms": f"hysteresis: {_DIRECTION} added to the baseline's "
                                         f"terms (no search)",
           "Bouc–Wen increment": f"hysteresis: a discrete Bouc–Wen increment model in place "
                                 f"of the baseline: y[k-1], Phi1(u[k-1],u[k-2]) and "
                                 f"{_DIRECTION} (no search)",
           "baseline + operator terms": "hysteresis: memory-operator terms Play(u[k-1],r) "
                                        "(the search's radii) and DengTan(u[k-1]) added to "
                                        "the baseline's terms (no search)",
           "operator dynamics": "hysteresis: linear dynamics of order up to 3 driven by the "
                                "input and its memory operators (y[k-1..3], u[k-1..2], "
                                "Play(u[k-1..2],r), DengTan(u[k-1..2])) in place of the "
                                "baseline (no search)",
           "Bouc–Wen dynamics": "hysteresis: linear dynamics of order up to 3 driven by the "
                                "input and Bouc–Wen variables of it (y[k-1..3], u[k-1..2], "
                                "BoucWen(u[k-1..2],β,γ) on a grid of shapes) in place of the "
                                "baseline (no search)"}
    out = [own.get(name, name)]
    if name in _LS_CANDIDATES:
        if drift or plan.setting.constraints:
            out.append("estimated by LS: the memory operators hold at a held input by "
                       "themselves (no continuum constraints)")
    elif name != "baseline terms, CLS":
        out += drift or (["estimated by CLS under the continuum-of-steady-states constraints, "
                          "as the baseline was"] if plan.setting.constraints else [])
    out += remarks
    if plan.search and search:
        out.append("not chosen: the candidates of the new search ("
                   + "; ".join(search) + ") ranked after it by their hold-out scores on "
                   "the fitting samples")
    return tuple(out)


def _unique(terms, data: Data, registry) -> List[str]:
    """Canonical texts of ``terms``, each once, in order."""
    sig = Signals(data.output, data.inputs)
    return list(dict.fromkeys(str(parse_term(t, sig, registry=registry)) for t in terms))


def _pruned(terms: List[str], data: Data, constraints, registry) -> List[str]:
    r"""``terms`` after backward elimination by BIC on the free-run error.

    The structure is estimated (LS, or CLS under ``constraints``) on
    ``data`` and simulated in free run; while dropping one term lowers
    BIC = n ln J + p ln n, with J the free-run mean squared error on the
    n samples and p the number of terms [1]_, the term whose removal lowers
    it most is dropped (:func:`mggp.fit.pruning.prune_by_criterion`). A term
    that only fits the noise of the fitting samples, or an input lag an
    added memory operator makes redundant, costs more in the simulation
    beyond them than it gains inside. The criterion is computed on the
    fitting samples only: the hold-out score that ranks the candidates is
    left untouched by it.

    References
    ----------
    .. [1] Piroddi, L., Spinelli, W., "An identification algorithm for
       polynomial NARX models based on simulation error minimization",
       Int. J. Control 76(17), 2003, 1767-1781 (pruning by simulation error).
    """
    from ..fit.pruning import prune_by_criterion

    class _FreeRun:
        @staticmethod
        def score(ts) -> float:
            m = _candidate(list(ts), data, constraints, registry)
            return freerun_rmse(m, data) ** 2

    sig = Signals(data.output, data.inputs)
    parsed = tuple(parse_term(t, sig, registry=registry) for t in terms)
    return [str(t) for t in prune_by_criterion(_FreeRun, parsed, data.n, "bic")]


def _candidate(terms, data: Data, constraints, registry) -> Optional[Model]:
    try:
        with ignore_rank_warnings():            # a candidate, not a result
            return Model(terms, inputs=data.inputs, output=data.output,
                         registry=registry).fit(data, constraints=constraints)
    except (EstimationError, ValueError):
        return None


#: share of the fitting samples that builds a candidate when ranking them;
#: the rest (the tail) ranks them by free-run RMSE
HOLDOUT_FIT = 0.7


def _holdout_scores(structures, data: Data, registry) -> dict:
    """Free-run RMSE of each structure on the tail of the fitting samples.

    Each structure ``(name, terms, constraints)`` is estimated on the first
    :data:`HOLDOUT_FIT` of ``data`` and simulated in free run over the whole
    record; its score is the RMSE on the remaining samples only,
    RMSE_tail = sqrt(mean_{k >= cut} (y[k] - ŷ[k])²). A candidate scored on
    the samples that estimated it is favoured by its own over-fitting;
    scoring it on samples it was not fitted to is hold-out validation
    (Stone 1974, J. R. Stat. Soc. B 36:111–147). A structure that cannot
    be estimated on the first part, or whose free run diverges, scores
    ``inf``. Returns ``{}`` when either part would be under 50 samples.
    """
    cut = int(HOLDOUT_FIT * data.n)
    if cut < 50 or data.n - cut < 50:
        return {}
    head = data.slice(0, cut)
    return {name: freerun_rmse(_candidate(terms, head, cons, registry), data, cut)
            for name, terms, cons in structures}


def fit_extension(plan: ExtensionPlan, baseline: Model, data: Data, budget: Budget,
                  seed=0, jobs=1, floor: float = 0.0, callbacks=None) -> Extension:
    """Fit the planned extension on ``data`` (the fitting samples).

    Each candidate is scored by the larger of its free-run RMSE on the last
    ``1 - HOLDOUT_FIT`` of ``data`` after estimation on the first
    :data:`HOLDOUT_FIT` (:func:`_holdout_scores`; left out on a record too
    short to split) and the free-run RMSE on ``data`` of its estimate on
    all of ``data``, the model that is kept.

    With CLS (drift named: the system holds) a candidate must also keep
    still in holds inserted into the fitting input (:func:`probe_holds`,
    movement at most ``floor``); those that do not rank after those that
    do, by how far they move. The memory-operator candidates are fitted by
    LS even then and not probed: their operators hold at a held input, and
    the continuum constraints (Σ_y = 1) would force an integrator on them.
    A candidate whose free run diverges on the fitting samples ranks last.
    """
    reg = baseline.registry
    cons = plan.setting.constraints
    base = baseline.term_texts
    cands: List[Tuple[str, Optional[Model]]] = []
    structures = []
    if plan.refit_cls:
        structures.append(("baseline terms, CLS", baseline.terms, cons))
        cands.append(("baseline terms, CLS", _candidate(baseline.terms, data, cons, reg)))
        m0 = cands[0][1]
        if not np.isfinite(freerun_rmse(m0, data)) or probe_holds(m0, data) > floor:
            plan = replace(plan, search=True, changes=plan.changes + (
                "the CLS refit of the baseline's terms is impossible, diverges or does not "
                "keep still in probe holds: CLS structure search",))
    sets = []
    if plan.search:
        setting = replace(plan.setting, window=_fit_window(plan.setting.window, data))
        with warnings.catch_warnings():       # only its LS structure is used
            warnings.simplefilter("ignore", CLSRejectedWarning)
            est = _regressor(setting, budget, int(seed) + 1, jobs, data, callbacks).fit(data)
        found = [str(t) for t in est.model_.terms]
        sets += [("search", found), ("search + baseline terms", base + found)]
    if plan.direction:
        d = [t for n in data.inputs for t in direction_terms(n, data.output)]
        inc = [f"{data.output}[k-1]"] + [f"Phi1({n}[k-1],{n}[k-2])" for n in data.inputs]
        sets += [("baseline + direction terms", base + d), ("Bouc–Wen increment", inc + d),
                 ("baseline + operator terms", base + operator_terms(data)),
                 ("operator dynamics", operator_dynamics_terms(data)),
                 ("Bouc–Wen dynamics", bouc_wen_dynamics_terms(data))]
        if plan.search:
            sets.append(("search + direction terms", found + d))
    seen, kept = set(), set()
    for name, terms in sets:
        terms = _unique(terms, data, reg)
        if frozenset(terms) in seen:
            continue
        seen.add(frozenset(terms))
        # memory operators hold their value at a held input by themselves: a
        # stable model driven by them settles without the continuum constraints
        own = None if name in _LS_CANDIDATES else cons
        built = [(name, terms)]
        if not name.startswith("search"):
            built.append((name + PRUNED, _pruned(terms, data, own, reg)))
        for label, ts in built:
            if (frozenset(ts), own) not in kept:
                kept.add((frozenset(ts), own))
                structures.append((label, ts, own))
                cands.append((label, _candidate(ts, data, own, reg)))
    if not cands:
        return Extension(baseline, "baseline (no change)", (), plan,
                         ("no candidate could be built: the baseline is kept",))
    scores = _holdout_scores(structures, data, reg)
    scored = [(name, m, max(scores.get(name, 0.0), freerun_rmse(m, data)),
               probe_holds(m, data) if cons and m is not None
               and _built_as(name) not in _LS_CANDIDATES else float("nan"))
              for name, m in cands]
    ok = [c for c in scored if c[1] is not None]
    if not ok:
        raise EstimationError("no extension could be fitted: every candidate structure "
                              "failed its estimation")
    name, best, _, _ = min(ok, key=lambda c: (not np.isfinite(c[2]),
                                              max(c[3] - floor, 0.0) if c[3] == c[3] else 0.0,
                                              c[2], c[1].n_terms))
    changes = candidate_changes(name, plan)
    best.meta.update({"source": "mggp diagnose extension", "fitness": plan.setting.fitness,
                      "window": plan.setting.window, "use_phi": plan.setting.use_phi,
                      "estimation": "cls" if cons and _built_as(name) not in _LS_CANDIDATES
                      else "ls", "changes": list(changes)})
    table = tuple((n, (m.n_terms if m is not None else 0), s, h) for n, m, s, h in scored)
    return Extension(best, name, table, plan, changes)
