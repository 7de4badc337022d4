"""mggp diagnose: with a validation record, its blocks join the selection samples.

The training record traces one loop (one sine: one amplitude, one rate), so
on its tail a lag or a memoryless term mimics a play's loop; the validation
record's amplitude falls, so there the play's minor loops and its dead band
part it from dynamics. The hidden effect (a play before first-order
dynamics) must be named hysteresis, and its control (the same dynamics
behind a memoryless tanh, the same inputs) must not. On the training tail
alone the play was named ``unmodelled-nonlinearity`` (gain 1.2 against 20).
"""
import numpy as np
import pytest

from narx.records.data import Data

from mggp.diagnose import Budget, diagnose
from mggp.diagnose.candidates import MIN_SELECT
from mggp.diagnose.run import MEASURE_BLOCKS, _split, block_mask, validation_blocks

SMALL = Budget(population=60, generations=10)


def play(u, radius):
    z = np.zeros(u.size)
    for k in range(1, u.size):
        z[k] = min(max(z[k - 1], u[k] - radius), u[k] + radius)
    return z


def slow_first_order(x, seed):
    y = np.zeros(x.size)
    for k in range(1, x.size):
        y[k] = 0.9 * y[k - 1] + 0.1 * x[k - 1]
    return y + 0.005 * np.random.default_rng(seed).standard_normal(x.size)


def records(static):
    k, kv = np.arange(3000), np.arange(2000)
    u = np.sin(2 * np.pi * k / 200)                          # one amplitude, one rate
    uv = (1 - kv / 2000) * np.sin(2 * np.pi * kv / 150)       # falling amplitude
    return (Data(u, slow_first_order(static(u), 1)),
            Data(uv, slow_first_order(static(uv), 2)))


@pytest.mark.parametrize("static, hysteretic", [
    (lambda u: play(u, 0.15), True),
    (lambda u: np.tanh(2 * u), False),                       # control: no memory
])
def test_a_loop_traced_once_is_named_by_the_validation_head(static, hysteretic):
    train, val = records(static)
    dx = diagnose(train, val, budget=SMALL, seed=0, jobs=1)
    assert ("hysteresis" in dx.effects) == hysteretic, dx.verdict.lines()
    if hysteretic:
        assert dx.gain.recommended == "extended" and dx.gain.ratio > 1.5
    sel, meas = validation_blocks(val.n)
    assert dx.split.validation_select == sel                 # selects ...
    assert dx.split.blocks == meas                           # ... and never measures
    d = dx.to_dict()["samples"]
    assert [b[0] for b in d["select_validation"]["blocks"]][0] == 0
    assert d["measure"]["blocks"] == [[a, b - 1] for a, b in meas]


def test_the_validation_blocks_interleave_and_never_overlap():
    from narx.simulation.simulate import HISTORY_HEAD
    n = 2000
    sel, meas = validation_blocks(n)
    assert sel[0] == (0, int(np.ceil(HISTORY_HEAD * n)))     # the head selects
    assert len(meas) == MEASURE_BLOCKS and len(sel) == MEASURE_BLOCKS + 1
    s, m = block_mask(n, sel), block_mask(n, meas)
    assert not np.any(s & m) and np.all(s | m)               # a partition of the record
    starts = sorted([(a, "s") for a, _ in sel] + [(a, "m") for a, _ in meas])
    kinds = [k for _, k in starts]
    assert kinds == ["s"] + ["m", "s"] * MEASURE_BLOCKS      # they take turns
    assert meas[0][0] < n / 2 < meas[-1][1] - 1              # measured early and late


def test_a_short_validation_record_is_measured_whole():
    k = np.arange(2000)
    u = np.sin(2 * np.pi * k / 200)
    train = Data(u, np.sin(u))
    n_short = 2 * MEASURE_BLOCKS * MIN_SELECT + MIN_SELECT - 1
    short = Data(u[:n_short], np.sin(u[:n_short]))
    *_, (vsel, meas), _, (_, measure) = _split(train, short, 0.3, ("train", "validation"))
    assert vsel == () and meas == ((0, short.n),) and measure == (0, short.n)
    long_ = Data(u[:1000], np.sin(u[:1000]))
    *_, (vsel, meas), _, (_, measure) = _split(train, long_, 0.3, ("train", "validation"))
    assert vsel[0] == (0, 200) and meas[0][0] == measure[0] == 200 and measure[1] == 1000
