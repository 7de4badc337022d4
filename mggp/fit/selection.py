"""Final choice of a structure among the best of a search run.

Typical use (``MGGPRegressor(select=...)`` calls these)::

    from mggp.fit.selection import run_candidates, select_freerun, select_hold
    cands = run_candidates(result, data.signals, shape, 20)
    terms, table = select_freerun(cands, data, start, registry)
    terms, table = select_hold(cands, data, start, registry, band=1.0)

``candidates`` are distinct term tuples, best search fitness first
(:func:`run_candidates`).

* ``select_freerun``: the lowest free-run MSE over the whole training
  record (ties: fewer terms); multiple shooting never sees an instability
  longer than its window.
* ``select_hold``: the first candidate whose LS free run stays in the
  output band and whose CLS refit holds its output on held inputs
  (:class:`mggp.fit.screen.StabilityScreen` with ``hold=True``).

Both return ``(terms or None, table)``, the table listing what was measured
(free-run MSE, or the hold verdict) with each candidate's terms.
"""
from __future__ import annotations

from typing import List, Optional, Sequence, Tuple

import numpy as np

from narx.records.data import Data
from narx.estimation.fitness import StructureScorer
from narx.language.terms import Term

from ..exceptions import CLSRejectedWarning
from .screen import StabilityScreen

__all__ = ["select_freerun", "select_hold", "run_candidates", "CLSRejectedWarning"]


def select_freerun(cands: Sequence[Tuple[Term, ...]], data: Data, start: int,
                   registry=None, scorer: Optional[StructureScorer] = None, check=None
                   ) -> Tuple[Optional[Tuple[Term, ...]], List]:
    """Candidate with the lowest whole-record free-run MSE (``scorer``: a
    free-run scorer of ``data`` from ``start`` to use instead of a new one);
    with ``check`` (:class:`mggp.fit.extrapolation.StressCheck`) the lowest
    whose free run stays bounded on the stress inputs when one has an RMSE
    within the size tolerance of the least
    (:func:`mggp.fit.extrapolation.bounded_first`)."""
    from .choices import SIZE_TOLERANCE
    from .extrapolation import bounded_first
    fr = scorer or StructureScorer(data, "freerun", start=start, registry=registry)
    scored = [(fr.score(c), len(c), i) for i, c in enumerate(cands)]
    scored = sorted(r for r in scored if np.isfinite(r[0]))
    table = [(float(m), [str(t) for t in cands[i]]) for m, _, i in scored]
    if not scored:
        return None, table
    rows = {i: (len(cands[i]), float(np.sqrt(m)), cands[i]) for m, _, i in scored}
    at, _, _ = bounded_first(rows, [i for _, _, i in scored], SIZE_TOLERANCE, check)
    return cands[at], table


def select_hold(cands: Sequence[Tuple[Term, ...]], data: Data, start: int,
                registry=None, band: float = 1.0, screen: Optional[StabilityScreen] = None
                ) -> Tuple[Optional[Tuple[Term, ...]], List]:
    """First candidate (best fitness first) that stays in band and holds
    (``screen``: a hold screen of ``data`` with this band to use instead of
    a new one; its counts are left alone)."""
    sc = screen or StabilityScreen(data, start, 1, band=band, registry=registry, hold=True)
    table = []
    for terms in cands:
        ok = sc.inside_band(terms) and sc.holds(terms)
        table.append((bool(ok), [str(t) for t in terms]))
        if ok:
            return terms, table
    return None, table


def run_candidates(res, signals, shape, count: int) -> List[Tuple[Term, ...]]:
    """The ``count`` best distinct structures of a search run ``res`` (its
    archive and final population), best search fitness first (ties: fewer
    terms); ``shape`` maps decoded terms to the scored structure (the
    estimator's: allowed terms, and the constant term if asked for)."""
    from ..gp.individual import fitness_of
    from ..gp.primitives import Decoder
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
