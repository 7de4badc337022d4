"""Drift test: does the model keep still, at the data's level, where the data hold?

Typical use::

    from mggp.diagnose.drift import DRIFT
    outcome = DRIFT.run(ctx)             # ctx: a mggp.diagnose.context.Context
    [(c.test, c.statistic, c.threshold) for c in outcome.checks]

In every usable held-input segment of either record
(:func:`~mggp.diagnose.holds.hold_responses`, started from the measured
state) two checks of effect ``steady-state-drift``:

* ``hold <record>:<start>`` — the model's movement against the data's,
  :math:`|d_{\\hat y} - d_y|`, above max(z·se(d_y), resolution floor), z
  Bonferroni over the holds;
* ``rest error <record>:<start>`` — the level the model rests at against
  the data's, just after its transient and at the hold's end
  (:attr:`~mggp.diagnose.holds.HoldResponse.rest_error`), above
  max(z·se of the level, resolution floor). The movement check compares
  each signal with itself, so a model that jumps to a wrong level just
  after the input stops and keeps still there passes it; this one does not.

A hold in which the data themselves move beyond the bound says nothing
about drift: its check has an infinite threshold (no power) and says why.
Each detail names the model's cluster sums off the continuum of steady
states (Σ_y = 1, other sums 0; :func:`~mggp.diagnose.holds.continuum_violations`)
and its steady-state rate at the hold's level, the causes of a drift.
"""
from __future__ import annotations

from typing import List

import numpy as np

from .findings import Check, number_text as _g
from .holds import HoldResponse, hold_bounds
from .registry import DiagnosticTest, Outcome

__all__ = ["hold_checks", "rest_error_check", "no_holds", "DRIFT"]


def hold_checks(ctx) -> List[Check]:
    """The movement and rest-error checks of every usable hold of ``ctx``."""
    out = []
    viol = ", ".join(f"{lab} = {v:.6g} (continuum needs {c:g})"
                     for lab, v, c in ctx.cluster_violations) or "none"
    for h, bound, z, still in hold_bounds(ctx.holds, ctx.alpha, ctx.floor_of):
        if not still:
            why = (f"the data do not hold (move {_g(h.data_move)}, bound {_g(bound)}), so "
                   f"this segment says nothing about drift or the level at rest")
            detail = f"{h.record} samples {h.start}-{h.stop - 1}: {why}"
            out.append(Check(f"hold {h.record}:{h.start}", "steady-state-drift", 0.0,
                             float("inf"), detail, why=why))
            continue
        moves = (f"moves {_g(h.model_move)}" if np.isfinite(h.model_move) else "diverges")
        detail = (f"input held at {h.level:.4g} in {h.record} samples {h.start}-{h.stop - 1}: "
                  f"the data move {_g(h.data_move)}, the model started from the measured "
                  f"state {moves} (compared from sample {h.compare_from}); bound "
                  f"max(z·se = {_g(z * h.noise_se)}, resolution floor "
                  f"{_g(ctx.floor_of(h.record))}); "
                  f"the model's steady-state equation moves {_g(h.rate)} per sample at this "
                  f"level; cluster sums off the continuum: {viol}")
        out.append(Check(f"hold {h.record}:{h.start}", "steady-state-drift", h.excess,
                         bound, detail))
        out.append(rest_error_check(h, z, ctx.floor_of(h.record), viol))
    return out


def rest_error_check(h: HoldResponse, z: float, floor: float, viol: str) -> Check:
    """Does the model, started when the input stops, rest at the data's level?

    Parameters
    ----------
    h : HoldResponse
        A hold in which the data keep still.
    z : float
        Bonferroni z of the hold tests.
    floor : float
        Resolution floor of the hold's record.
    viol : str
        The model's cluster sums off the continuum, in words.

    Returns
    -------
    Check
        ``rest error <record>:<start>``: :attr:`HoldResponse.rest_error`
        against max(z·se of the level, floor).
    """
    bound = max(z * h.level_se, floor)
    if np.isfinite(h.rest_error):
        rests = (f"lands at {_g(h.model_settled)} once the input's last move has passed "
                 f"through its lags (samples {h.compare_from}-) and rests at "
                 f"{_g(h.model_end)} at the end")
    else:
        rests = "diverges"
    detail = (f"input held at {h.level:.4g} in {h.record} samples {h.start}-{h.stop - 1}: "
              f"the model, started from the measured state when the input stops (sample "
              f"{h.start}), {rests}; the data rest at {_g(h.data_settled)} and "
              f"{_g(h.data_end)}: error at rest {_g(h.rest_error)}; bound max(z·se = "
              f"{_g(z * h.level_se)}, resolution floor {_g(floor)}); the model's "
              f"steady-state equation moves {_g(h.rate)} per sample at this level; cluster "
              f"sums off the continuum: {viol}")
    return Check(f"rest error {h.record}:{h.start}", "steady-state-drift", h.rest_error,
                 bound, detail)


def no_holds(ctx) -> str:
    """Why no hold response could be measured (drift, rest levels), in one phrase."""
    names = list(ctx.holds_found)
    if len(names) == 2 and names[1] == f"{names[0]} (tail)":
        names = names[:1]                   # the measuring tail is part of that record
    records = " or ".join(names) or "the data"
    found = sum(ctx.holds_found.values())
    what = "steady-state drift and rest levels"
    if not found:
        size = f" of {ctx.hold_min_len} samples or more" if ctx.hold_min_len else ""
        return (f"{what} (no held-input segment{size} in {records}, so the drift check "
                f"could not run)")
    return (f"{what} ({found} held-input segment{'s' if found > 1 else ''} found in "
            f"{records}, but none starts late enough and lasts long enough after the "
            f"model's largest lag to compare, so the drift check could not run)")


def _run(ctx) -> Outcome:
    if not ctx.holds:
        return Outcome(missing=no_holds(ctx))
    return Outcome(hold_checks(ctx), ctx.holds)


#: Movement and level at rest in every held-input segment.
DRIFT = DiagnosticTest("holds", ("steady-state-drift",), _run)
