"""A candidate that moves by itself while the input is held cannot win
(:func:`mggp.diagnose.holds.self_motion`,
:func:`mggp.diagnose.candidates.why_barred`); models built by hand."""
import numpy as np

from narx import Model
from narx.records.data import Data
from mggp.diagnose.candidates import BAR_HOLDS, BAR_RANGE, HOLD_MOTION, why_barred
from mggp.diagnose.holds import find_holds, hold_motion, self_motion

#: y[k] = 1.05 y[k-1] - 0.05 y[k-1]^3 + u[k-1]: two stable branches near
#: ±1; held at u = 0.02, just past the fold of the lower branch, the output
#: creeps for some 200 samples, then jumps to the upper branch
BISTABLE = Model(["y[k-1]", "y[k-1]*y[k-1]*y[k-1]", "u[k-1]"], theta=[1.05, -0.05, 1.0])
#: the same gain at rest, first order: it settles in every hold
SETTLING = Model(["y[k-1]", "u[k-1]"], theta=[0.9, 1.0])


def _record(level=0.02):
    """Held at -0.05 (the lower branch), a ramp, then held at ``level``."""
    u = np.r_[np.full(150, -0.05), np.linspace(-0.05, level, 50), np.full(400, level)]
    y = SETTLING.simulate(Data(u[:, None], np.zeros(u.size)), mode="freerun").y_hat
    return Data(u[:, None], y)


def test_a_jump_late_in_a_hold_is_self_motion_and_a_settling_model_has_none():
    d = _record()
    segs = find_holds(d, 20)
    assert [b for _, b in segs] == [151, 600]
    early, late = hold_motion(BISTABLE, d, segs)[-1]
    assert late > 1.0 > early                     # the jump comes late in the hold
    assert self_motion(BISTABLE, SETTLING, [(d, None, segs)]) > 1.0
    assert self_motion(SETTLING, SETTLING, [(d, None, segs)]) == 0.0        # control
    # control: motion the baseline shows as well is not the candidate's own
    assert self_motion(BISTABLE, BISTABLE, [(d, None, segs)]) == 0.0
    # control: held short of the fold, the lower branch holds and nothing moves late
    d = _record(level=0.015)
    segs = find_holds(d, 20)
    assert self_motion(BISTABLE, SETTLING, [(d, None, segs)]) < 0.01


def test_why_barred_names_the_hold_and_the_range():
    d = _record()
    held = [(d, "own", find_holds(d, 20))]
    fit = Data(d.U.T, np.linspace(-1.5, 1.5, d.n))        # an output range of 3
    assert why_barred(BISTABLE, SETTLING, fit, held) == BAR_HOLDS
    assert why_barred(SETTLING, SETTLING, fit, held) is None                # control
    assert self_motion(BISTABLE, SETTLING, held) > HOLD_MOTION * 3.0
    unstable = Model(["y[k-1]", "u[k-1]"], theta=[1.2, 1.0])
    assert why_barred(unstable, SETTLING, fit, held) == BAR_RANGE
