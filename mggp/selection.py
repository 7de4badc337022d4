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

from .screen import StabilityScreen

__all__ = ["select_freerun", "select_hold"]


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
