"""mggp diagnose: with a validation record, its head joins the selection samples.

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
from mggp.diagnose.run import VALIDATION_SELECT, _split

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
    half = int(round(val.n * VALIDATION_SELECT))
    assert dx.split.validation_select == (0, half)           # selects ...
    assert dx.split.measure == (half, val.n)                 # ... and never measures
    d = dx.to_dict()["samples"]
    assert d["select_validation"]["last"] < d["measure"]["first"]


def test_a_short_validation_record_is_measured_whole():
    k = np.arange(2000)
    u = np.sin(2 * np.pi * k / 200)
    train = Data(u, np.sin(u))
    short = Data(u[:2 * MIN_SELECT - 1], np.sin(u[:2 * MIN_SELECT - 1]))
    *_, n_vsel, _, (_, measure) = _split(train, short, 0.3, ("train", "validation"))
    assert n_vsel == 0 and measure == (0, short.n)
    long_ = Data(u[:1000], np.sin(u[:1000]))
    *_, n_vsel, _, (_, measure) = _split(train, long_, 0.3, ("train", "validation"))
    assert n_vsel == 500 and measure == (500, 1000)
