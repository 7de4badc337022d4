"""Rest-level test: memory at rest that the model does not express.

Typical use::

    from mggp.diagnose.restlevels import REST_LEVELS
    outcome = REST_LEVELS.run(ctx)       # ctx: a mggp.diagnose.context.Context

Two holds at the same input (levels within ``ctx.input_tolerance``) in
which the data keep still but rest at different levels are direct
evidence of hysteresis: the level remembers the way the input came. For
each such pair the check ``rest levels <record>:<a>/<b>`` (effect
``hysteresis``) compares the data's gap with the gap of the model started
from the measured state at each hold,

.. math:: s = |(y^{(2)}_{end} - y^{(1)}_{end}) - (\\hat y^{(2)}_{end} - \\hat y^{(1)}_{end})| ,

against max(z·√(se₁² + se₂²), resolution floor), z Bonferroni over the
pairs. Where the data's own gap is within that bound (no memory to see),
the statistic is at most that gap, so a model that rests apart while the
data do not is not called hysteretic (that is drift, :mod:`.drift`).
"""
from __future__ import annotations

from typing import List

import numpy as np

from .findings import Check, number_text as _g
from .holds import hold_bounds
from .registry import DiagnosticTest, Outcome
from .thresholds import bonferroni_z

__all__ = ["rest_level_checks", "REST_LEVELS"]


def rest_level_checks(ctx) -> List[Check]:
    """A check per pair of still holds at the same input (see the module doc)."""
    still = [(h, b) for h, b, _, ok in hold_bounds(ctx.holds, ctx.alpha, ctx.floor_of) if ok]
    pairs = [(a, b) for i, a in enumerate(still) for b in still[i + 1:]
             if abs(a[0].level - b[0].level) <= ctx.input_tolerance]
    z = bonferroni_z(ctx.alpha, max(len(pairs), 1))
    out = []
    for (h1, _), (h2, _) in pairs:
        gap = h2.data_end - h1.data_end
        mgap = h2.model_end - h1.model_end
        floor = max(ctx.floor_of(h1.record), ctx.floor_of(h2.record))
        thr = max(z * float(np.hypot(h1.noise_se, h2.noise_se)), floor)
        stat = abs(gap - mgap) if np.isfinite(mgap) else float("inf")
        if not abs(gap) > thr:
            stat = min(stat, abs(gap))
        rests = f"{_g(mgap)} apart" if np.isfinite(mgap) else "nowhere (it diverges)"
        detail = (f"with the input held at {h1.level:.4g}, the data rest at "
                  f"{_g(h1.data_end)} ({h1.record} samples {h1.start}-{h1.stop - 1}) and at "
                  f"{_g(h2.data_end)} ({h2.record} samples {h2.start}-{h2.stop - 1}), "
                  f"{_g(gap)} apart: a memory of the way the input came; the model, started "
                  f"from the measured state at each hold, rests {rests}; bound "
                  f"max(z·se, resolution floor {_g(floor)})")
        out.append(Check(f"rest levels {h1.record}:{h1.start}/{h2.start}", "hysteresis",
                         stat, thr, detail))
    return out


def _run(ctx) -> Outcome:
    return Outcome(rest_level_checks(ctx))


#: Pairs of holds at the same input where the data rest apart.
REST_LEVELS = DiagnosticTest("rest levels", ("hysteresis",), _run)
