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

__all__ = ["select_freerun", "select_hold", "prune_by_criterion", "bonferroni_t"]


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
