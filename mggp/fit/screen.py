"""Free-run stability screen of the best structures of each generation.

Typical use (``MGGPRegressor(screen="freerun")`` wires it in)::

    from mggp.fit.screen import StabilityScreen
    screen = StabilityScreen(data, start=16, top=50)
    values = screen(term_sets, values)      # unstable leaders -> inf

Multiple shooting scores a structure on windows of Δm samples, each
started from measured data, so an instability that needs longer than Δm
to grow is never seen: a search can converge to a family of structures
that fit every window and diverge in free run over the record (on the
piezo case study with Δm = 1000, for example). The screen simulates the best structures
of each batch in free run over the whole training record, with the same
LS (or CLS) parameters, and gives those whose output leaves the band

.. math::  \\min_k y_k - f R \\le \\hat y_k \\le \\max_k y_k + f R,
           \\quad R = \\max_k y_k - \\min_k y_k

(``f = band``) the fitness ``inf``. It repeats until the ``top`` best
finite structures of the batch all passed, so no structure that could
become an elite escapes it. Only those leaders are simulated (about
``top`` free runs per generation, in this process), and the result depends
only on the batch, hence not on the number of workers.

With ``hold=True`` a leader must also *hold*: its structure refitted by
CLS under the derived continuum-of-steady-states constraints is simulated
on a held record built from the training record (four stretches of 1000
samples of the measured input, or a quarter of a shorter record, two
rising and two falling at their end, each followed by the input frozen
for 400 samples), from measured initial conditions; after
``settle`` samples of each hold its output must not move by more than
``hold_tol`` times the output range. A continuum of steady states does not
ensure that: a model whose only linear output term is ``y[k-2]`` with
θ = 1 has every constant as an equilibrium, yet keeps a period-2
oscillation forever when the input stops.

References
----------
S. A. Billings, *Nonlinear System Identification*, Wiley, 2013, sec. 5.
(free-run validation of NARMAX models).
"""
from __future__ import annotations

import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from narx.records.data import Data
from narx.estimation.fitness import StructureScorer
from narx.language.phi import PhiRegistry
from narx.simulation.simulate import recursion_windows
from narx.language.terms import Term

from .params import PARAMS, Int, Real

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
    hold : bool
        Also require the CLS refit to hold its output on held inputs.
    hold_tol : float
        Largest movement of a held output after ``settle`` samples, in
        output ranges (1e-6).
    settle : int
        Samples allowed for the Φ-terms to see the frozen input and the
        transient to die out (100).

    Attributes
    ----------
    checked, rejected, rejected_hold : int
        Structures simulated; those given ``inf`` for leaving the band, and
        for not holding.
    """

    def __init__(self, data: Data, start: int, top: int, band: float = 1.0,
                 constraints: Optional[str] = None,
                 registry: Optional[PhiRegistry] = None, hold: bool = False,
                 hold_tol: float = 1e-6, settle: int = 100):
        Int(1).check("top", top)
        PARAMS["screen_band"].rule.check("band", band)
        self.top = int(top)
        self.scorer = StructureScorer(data, "freerun", start=start, constraints=constraints,
                                      registry=registry, budget_bytes=96 * 2**20)
        y = self.scorer.y[start:]
        self.lo = float(np.min(y) - band * np.ptp(y))
        self.hi = float(np.max(y) + band * np.ptp(y))
        # the kernels' symmetric divergence guard, containing the band
        self.scorer.set_bound(max(abs(self.lo), abs(self.hi)))
        self.checked = 0
        self.rejected = 0
        self.rejected_hold = 0
        self.hold = None
        if hold:
            Real(0).check("hold_tol", hold_tol)
            self.hold = _HeldRecord(data, start, int(settle), float(hold_tol) * float(np.ptp(y)),
                                    registry)

    def stable(self, terms: Tuple[Term, ...]) -> bool:
        """Whether the free run of ``terms`` stays inside the band."""
        self.checked += 1
        ok = self.inside_band(terms)
        self.rejected += not ok
        if ok and self.hold is not None:
            ok = self.holds(terms)
            self.rejected_hold += not ok
        return ok

    def inside_band(self, terms: Tuple[Term, ...]) -> bool:
        """Whether the LS (or CLS) free run of ``terms`` over the record stays
        within ``[min y - f range, max y + f range]``."""
        sc = self.scorer
        theta, s = sc.fitted(terms)
        if theta is None:
            return False
        starts, length, wf, first = recursion_windows("freerun", sc.data.n, s, sc.k)
        if starts.size == 0:
            return False
        out, diverged = sc.run_windows(terms, theta, starts, length, wf)
        out = out[first:]
        return not diverged and bool(np.all((out >= self.lo) & (out <= self.hi)))

    def holds(self, terms: Tuple[Term, ...]) -> bool:
        """Whether the CLS refit of ``terms`` holds on the held record."""
        theta, _ = self.scorer.fitted(terms, constraints="steady-state")
        return theta is not None and self.hold.holds(terms, theta, self.scorer.bound)

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


class _HeldRecord:
    """Stretches of the training record, each followed by a held input."""

    PRE, HOLD, COUNT = 1000, 400, 4

    def __init__(self, data: Data, start: int, settle: int, tol: float, registry):
        if settle < 0 or settle >= self.HOLD:
            raise ValueError(f"settle must be in 0..{self.HOLD - 1}, got {settle!r}")
        U, y, n = data.U.T, data.y, data.n               # U: (N, m)
        # stretches of 1000 samples, or a quarter of a shorter record
        pre = min(self.PRE, (n - start) // 4)
        if pre < 20:
            raise ValueError(f"the hold test needs a record of at least {start + 80} "
                             f"samples, got {n}")
        block = start + pre + self.HOLD
        ends = []
        du = np.diff(U[:, 0])                            # the first input decides
        for i in range(self.COUNT):
            want = 1.0 if i % 2 == 0 else -1.0          # rising, then falling
            p0 = min(n, max(start + pre, int((i + 1) * n / (self.COUNT + 1))))
            p = p0
            while p < n and np.sign(du[p - 2]) != want:    # U[p-1] - U[p-2]
                p += 1
            ends.append(p if p < n else p0)
        Uh, yh, self.holds_at = [], [], []
        for b, p in enumerate(ends):
            a = p - start - pre                          # measured pad + stretch
            Uh.append(U[a:p])
            Uh.append(np.repeat(U[p - 1:p], self.HOLD, axis=0))
            yh.append(y[a:p])
            yh.append(np.repeat(y[p - 1:p], self.HOLD))  # placeholder, never read
            h0 = b * block + start + pre
            self.holds_at.append(slice(h0 + settle, h0 + self.HOLD))
        self.data = Data(np.concatenate(Uh), np.concatenate(yh), inputs=data.inputs,
                         output=data.output)
        self.starts = np.arange(self.COUNT, dtype=np.int64) * block + start
        self.length = pre + self.HOLD
        self.tol = tol
        self.scorer = StructureScorer(self.data, "freerun", start=start, registry=registry,
                                      budget_bytes=16 * 2**20)

    def holds(self, terms, theta, bound) -> bool:
        out, diverged = self.scorer.run_windows(terms, theta, self.starts, self.length,
                                                bound=bound)
        if diverged:
            return False
        return all(np.ptp(out[sl]) <= self.tol for sl in self.holds_at)
