"""Final choice of a structure among the best of a search run.

Typical use (``MGGPRegressor(select=...)`` calls these)::

    from mggp.selection import select_freerun, select_hold
    terms, table = select_freerun(candidates, data, start, registry)
    terms, table = select_hold(candidates, data, start, registry, band=1.0)

``candidates`` are distinct term tuples, best search fitness first.

* ``select_freerun``: the lowest free-run MSE over the whole training
  record (ties: fewer terms); multiple shooting never sees an instability
  longer than its window.
* ``select_hold``: the first candidate whose LS free run stays in the
  output band and whose CLS refit holds its output on held inputs
  (:class:`mggp.screen.StabilityScreen` with ``hold=True``).

Both return ``(terms or None, table)``, the table listing what was measured
(free-run MSE, or the hold verdict) with each candidate's terms.
"""
from __future__ import annotations

from typing import List, Optional, Sequence, Tuple

import numpy as np

from narx.data import Data
from narx.fitness import StructureScorer
from narx.terms import Term

from .evaluate import criterion_value
from .screen import StabilityScreen

__all__ = ["select_freerun", "select_hold", "prune_by_criterion", "bonferroni_t",
           "cls_rejection", "CLS_WORSE", "CLSRejectedWarning", "run_candidates",
           "t_threshold_of"]

#: a CLS refit whose free-run RMSE on the training record is more than this
#: many times the LS fit's is not preferred to it
CLS_WORSE = 2.0


def select_freerun(cands: Sequence[Tuple[Term, ...]], data: Data, start: int,
                   registry=None) -> Tuple[Optional[Tuple[Term, ...]], List]:
    """Candidate with the lowest whole-record free-run MSE."""
    fr = StructureScorer(data, "freerun", start=start, registry=registry)
    scored = [(fr.score(c), len(c), i) for i, c in enumerate(cands)]
    scored = [r for r in scored if np.isfinite(r[0])]
    table = [(float(m), [str(t) for t in cands[i]]) for m, _, i in sorted(scored)]
    return (cands[min(scored)[2]] if scored else None), table


def select_hold(cands: Sequence[Tuple[Term, ...]], data: Data, start: int,
                registry=None, band: float = 1.0) -> Tuple[Optional[Tuple[Term, ...]], List]:
    """First candidate (best fitness first) that stays in band and holds."""
    sc = StabilityScreen(data, start, 1, band=band, registry=registry, hold=True)
    table = []
    for terms in cands:
        ok = sc.stable(terms)
        table.append((bool(ok), [str(t) for t in terms]))
        if ok:
            return terms, table
    return None, table


def prune_by_criterion(scorer, terms: Tuple[Term, ...], n: int, criterion: str = "bic"):
    """Backward elimination: drop the term whose removal lowers the
    information criterion (of the scorer's fitness, ``n`` samples) most,
    while one does."""
    cur = criterion_value(scorer.score(terms), len(terms), n, criterion)
    while len(terms) > 1:
        trials = []
        for i in range(len(terms)):
            sub = terms[:i] + terms[i + 1:]
            trials.append((criterion_value(scorer.score(sub), len(sub), n, criterion), i))
        best, i = min(trials)
        if not best < cur:
            break
        cur, terms = best, terms[:i] + terms[i + 1:]
    return terms


def bonferroni_t(n_inputs: int, max_lag: int, max_degree: int, alpha: float = 0.05) -> float:
    """Two-sided t threshold at level ``alpha`` shared among the
    :math:`m = \\binom{(n_u + 1)L + d}{d} - 1` candidate monomials of
    lags up to ``L`` and degree up to ``d`` (Bonferroni)."""
    from math import comb
    from scipy.stats import norm
    m = comb((n_inputs + 1) * max_lag + max_degree, max_degree) - 1
    return float(norm.ppf(1 - alpha / (2 * m)))


def t_threshold_of(est, n_inputs: int) -> float:
    """An estimator's ``t_threshold``, or by default :func:`bonferroni_t`
    over the monomials its trees can build (lags up to ``max_lag`` but no
    longer than ``max_height`` trees reach: a larger ``max_lag`` has no
    effect; degree up to ``max_degree``, else 3)."""
    if est.t_threshold is not None:
        return float(est.t_threshold)
    from .primitives import max_lag_for_height
    reach = max_lag_for_height(est.max_height)
    return bonferroni_t(n_inputs, min(est.max_lag or reach, reach), est.max_degree or 3)


class CLSRejectedWarning(UserWarning):
    """The CLS refit is not used by default (see :func:`cls_rejection`)."""


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


def run_candidates(res, signals, shape, count: int) -> List[Tuple[Term, ...]]:
    """The ``count`` best distinct structures of a search run ``res`` (its
    archive and final population), best search fitness first (ties: fewer
    terms); ``shape`` maps decoded terms to the scored structure (the
    estimator's: allowed terms, and the constant term if asked for)."""
    from .individual import fitness_of
    from .primitives import Decoder
    rows = [(r.fitness, tuple(r.terms)) for r in res.pareto]
    dec = Decoder(signals)
    rows += [(fitness_of(ind), dec.decode_individual(ind)) for ind in res.population
             if ind.fitness.valid]
    seen, cands = set(), []
    for fit, terms in sorted((r for r in rows if r[1] and np.isfinite(r[0])),
                             key=lambda r: (r[0], len(r[1]))):
        terms = shape(terms)
        key = frozenset(terms)
        if terms and key not in seen:
            seen.add(key)
            cands.append(terms)
        if len(cands) >= int(count):
            break
    return cands
