"""Loop-gap test: the residual's dependence on the direction of input change.

Typical use::

    from mggp.diagnose.loopgap import loop_gap_test
    g = loop_gap_test(model, data, alpha=0.01)       # None: too few reversals
    g.statistic, g.bound, g.p_value

The record is cut into *branches*, maximal runs of
the input moving one way. For every reversal — a branch R1 followed by an
opposite branch R2 — the model is simulated free from the measured
outputs before R1 through the end of R2 (so drift accumulated elsewhere
does not enter), and each sample k of R2 is paired with the point of R1
where the input had the same value:

.. math::  g_k = e_k^{\\downarrow} - e^{\\uparrow}(u_k), \\qquad e = y - \\hat y ,

falling minus rising residual at equal input (the second by linear
interpolation along R1). The mean gap of reversal r is :math:`\\bar g_r`;
the statistic is :math:`|\\bar g| = |\\mathrm{mean}_r \\bar g_r|`, the part
of the loop the model misses, in output units, and its bound is
:math:`t_{1-\\alpha/2,\\,R-1}\\,s_{\\bar g}/\\sqrt R` (a t-test across the R
reversals, which are taken as independent). A drift within the windows
enters with opposite signs at maxima and minima, which alternate, so it
cancels in the mean.

As the diagnose test :data:`LOOP_GAP` (effect ``hysteresis``), one
check per input, ``loop gap (<input>)``, with threshold max(t-bound,
resolution floor).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Tuple

import numpy as np
from scipy.stats import t as student_t

from narx import Model
from narx.records.data import Data

from .findings import Check, number_text as _g
from .registry import DiagnosticTest, Outcome
from .simulation import direction_of_change

__all__ = ["LoopGapTest", "branches", "loop_gap_test", "loop_gap_check", "LOOP_GAP"]


def branches(u) -> List[Tuple[int, int, float]]:
    """Runs ``(a, b, direction)``: samples a..b-1 move one way from a-1."""
    s = direction_of_change(u)
    n, k, out = s.size, 1, []
    while k < n:
        if s[k] == 0:
            k += 1
            continue
        a = k
        while k < n and s[k] == s[a]:
            k += 1
        out.append((a, k, float(s[a])))
    return out


@dataclass(frozen=True)
class LoopGapTest:
    """Mean residual gap at equal input between adjacent branches.

    ``statistic`` = |mean gap| (output units), ``bound`` its t-bound,
    ``gaps`` the per-reversal means, ``u``/``g`` every pair (for plots).
    """

    signal: str
    statistic: float
    bound: float
    p_value: float
    gaps: np.ndarray
    u: np.ndarray
    g: np.ndarray


def loop_gap_test(model: Model, data: Data, *, signal: Optional[str] = None,
                  alpha: float = 0.01, min_len: int = 5,
                  min_reversals: int = 5) -> Optional[LoopGapTest]:
    """Loop-gap test for input ``signal`` (default: the first input)."""
    name = signal or data.inputs[0]
    u = data.input(name)
    y = data.y
    L = model.max_lag
    runs = [r for r in branches(u) if r[1] - r[0] >= min_len]
    gaps, us, gs = [], [], []
    for (a1, b1, d1), (a2, b2, d2) in zip(runs, runs[1:]):
        s0 = a1 - 1 - L
        if a2 != b1 or d1 == d2 or s0 < 0:
            continue
        sub = Data(data.U[:, s0:b2].T, y[s0:b2], inputs=data.inputs, output=data.output)
        r = model.simulate(sub, mode="freerun")
        if r.diverged:
            continue
        e = y[s0:b2] - r.y_hat
        uu, ee = u[a1 - 1:b1], e[a1 - 1 - s0:b1 - s0]
        if d1 < 0:
            uu, ee = uu[::-1], ee[::-1]
        k = np.arange(a2, b2)
        k = k[(u[k] >= uu[0]) & (u[k] <= uu[-1])]
        if k.size < 2:
            continue
        g = (e[k - s0] - np.interp(u[k], uu, ee)) * (1.0 if d2 < 0 else -1.0)
        gaps.append(float(np.mean(g)))
        us.append(u[k])
        gs.append(g)
    if len(gaps) < min_reversals:
        return None
    gaps = np.asarray(gaps)
    m = float(np.mean(gaps))
    se = float(np.std(gaps, ddof=1) / np.sqrt(gaps.size))
    df = gaps.size - 1
    bound = float(student_t.ppf(1.0 - alpha / 2.0, df) * se)
    p = float(2.0 * student_t.sf(abs(m) / se, df)) if se > 0 else (0.0 if m else 1.0)
    return LoopGapTest(name, abs(m), bound, p, gaps, np.concatenate(us), np.concatenate(gs))


def loop_gap_check(g: LoopGapTest, alpha: float, floor: float) -> Check:
    """``g``'s mean gap against max(its t-bound, the resolution floor)."""
    pct = f"{100 * (1 - alpha):g} %"
    detail = (f"at equal {g.signal}, the residual of simulations restarted before each "
              f"reversal differs by {_g(g.statistic)} on average between falling and "
              f"rising {g.signal} ({g.gaps.size} reversals, t-test p = {g.p_value:.3g}, "
              f"{pct} bound {_g(g.bound)}); resolution floor {_g(floor)}")
    return Check(f"loop gap ({g.signal})", "hysteresis", g.statistic, max(g.bound, floor),
                 detail)


def _run(ctx) -> Outcome:
    gaps = [g for g in (loop_gap_test(ctx.model, ctx.fit, signal=n, alpha=ctx.alpha)
                        for n in ctx.fit.inputs) if g is not None]
    if not gaps:
        return Outcome(missing="loop gap (no reversal of the input long enough)")
    return Outcome([loop_gap_check(g, ctx.alpha, ctx.floor) for g in gaps], gaps)


#: The loop-gap test of every input.
LOOP_GAP = DiagnosticTest("loop gap", ("hysteresis",), _run)
