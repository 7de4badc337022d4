"""Free-run stability screen of the best structures of each generation.

Typical use (``MGGPRegressor(screen="freerun")`` wires it in)::

    from mggp.screen import StabilityScreen
    screen = StabilityScreen(data, start=16, top=50)
    values = screen(term_sets, values)      # unstable leaders -> inf

Multiple shooting scores a structure on windows of Δm samples, each
started from measured data, so an instability that needs longer than Δm
to grow is never seen: a search can converge to a family of structures
that fit every window and diverge in free run over the record (seen on the
piezo case study with Δm = 1000). The screen simulates the best structures
of each batch in free run over the whole training record, with the same
LS (or CLS) parameters, and gives those whose output leaves the band

.. math::  |\\hat y_k| \\le \\max_k |y_k| + f\\,(\\max_k y_k - \\min_k y_k)

(``f = band``) the fitness ``inf``. It repeats until the ``top`` best
finite structures of the batch all passed, so no structure that could
become an elite escapes it. Only those leaders are simulated (about
``top`` free runs per generation, in this process), and the result depends
only on the batch, hence not on the number of workers.

References
----------
S. A. Billings, *Nonlinear System Identification*, Wiley, 2013, sec. 5.
(free-run validation of NARMAX models).
"""
from __future__ import annotations

import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from narx.data import Data
from narx.fitness import StructureScorer
from narx.phi import PhiRegistry
from narx.terms import Term

__all__ = ["StabilityScreen"]


class StabilityScreen:
    """Reject leaders whose free run over the training record diverges.

    Parameters
    ----------
    data : Data
        The training record.
    start : int
        First row for estimation and simulation (the search's).
    top : int
        Leaders per batch that must pass (>= 1); the elite size is natural.
    band : float
        ``f`` of the output band, in output ranges (>= 0; default 1).
    constraints : None or 'steady-state'
        The search's estimation (LS or CLS).
    registry : PhiRegistry, optional

    Attributes
    ----------
    checked, rejected : int
        Structures simulated, and those given ``inf``.
    """

    def __init__(self, data: Data, start: int, top: int, band: float = 1.0,
                 constraints: Optional[str] = None,
                 registry: Optional[PhiRegistry] = None):
        if isinstance(top, bool) or not isinstance(top, (int, np.integer)) or top < 1:
            raise ValueError(f"top must be an integer >= 1, got {top!r}")
        if not (isinstance(band, (int, float)) and math.isfinite(band) and band >= 0):
            raise ValueError(f"band must be a finite number >= 0, got {band!r}")
        self.top = int(top)
        self.scorer = StructureScorer(data, "freerun", start=start, constraints=constraints,
                                      registry=registry, budget_bytes=32 * 2**20)
        y = self.scorer.y[start:]
        self.scorer.bound = float(np.max(np.abs(y)) + band * np.ptp(y))
        self.checked = 0
        self.rejected = 0

    def stable(self, terms: Tuple[Term, ...]) -> bool:
        """Whether the free run of ``terms`` stays inside the band."""
        self.checked += 1
        ok = math.isfinite(self.scorer.score(terms))
        self.rejected += not ok
        return ok

    def __call__(self, term_sets: Sequence[Tuple[Term, ...]],
                 values: Sequence[float]) -> List[float]:
        """``values`` with ``inf`` for the leaders that fail the screen."""
        vals = [float(v) for v in values]
        done = set()
        while True:
            finite = [i for i, v in enumerate(vals) if math.isfinite(v)]
            leaders = sorted(finite, key=lambda i: (vals[i], i))[:self.top]
            todo = [i for i in leaders if i not in done]
            if not todo:
                return vals
            for i in todo:
                done.add(i)
                if not self.stable(tuple(term_sets[i])):
                    vals[i] = math.inf
