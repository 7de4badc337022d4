"""Dead time beyond the search's reach: found by the ARX scan and named
before the search (narx.records.deadtime, mggp.fit.precision.dead_time_message)."""
import warnings

import numpy as np
import pytest

from narx import Data
from narx.records.deadtime import GAIN as DEAD_TIME_GAIN, SPAN, onset_scan
from mggp.fit.precision import dead_time_message


def _delayed(d, n=2000, seed=5, second=None):
    """y[k] = 0.8 y[k-1] + 0.5 u[k-d] + 0.2 u[k-d]², a held random input
    (steps every 10 samples), output noise 0.01; with ``second`` a second
    input acting at lag 1 (0.3 v[k-1])."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1, 1, n // 10), 10)
    v = rng.uniform(-1, 1, n)
    y = np.zeros(n)
    for k in range(d + 1, n):
        y[k] = 0.8 * y[k - 1] + 0.5 * u[k - d] + 0.2 * u[k - d] ** 2 \
            + (0.3 * v[k - 1] if second else 0.0)
    y += 0.01 * rng.standard_normal(n)
    return Data(np.c_[u, v], y, inputs=["u", "v"]) if second else Data(u, y)


def test_the_scan_finds_the_dead_time():
    for d in (3, 10, 25, 40):
        scan = onset_scan(_delayed(d), "u")
        assert scan.best <= d <= scan.best + SPAN - 1, d


def test_a_dead_time_beyond_reach_is_named_with_the_height_that_reaches_it():
    msg = dead_time_message(_delayed(25), reach=16, max_height=5)
    assert msg.startswith("input 'u' acts on the output from about lag 2")
    assert "--max-height 9" in msg and "starting within 16" in msg
    # controls: within reach at height 5, or at height 9
    assert dead_time_message(_delayed(10), reach=16, max_height=5) == ""
    assert dead_time_message(_delayed(25), reach=28, max_height=9) == ""
    # a max_lag below it: raise that
    msg = dead_time_message(_delayed(25), reach=10, max_height=9, max_lag=10)
    assert "raise max_lag to 2" in msg and "max_height" not in msg


def test_only_the_late_input_is_named():
    msg = dead_time_message(_delayed(30, second=True), reach=16, max_height=5)
    assert "input 'u'" in msg and "input 'v'" not in msg


def test_the_fit_raises_its_height_to_reach_a_dead_time():
    """max_height='auto' (the default) takes the height that reaches the
    dead time and says so; an explicit height (the control) keeps it and
    warns instead; without a dead time 'auto' stays at 5."""
    from mggp import MGGPRegressor
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        est = MGGPRegressor(population=20, generations=2, random_state=0).fit(_delayed(25))
    c = est.choices_["max_height"]
    assert est.max_height_ == 9 == c["value"] and "acts on the output from about lag 2" in c["why"]
    assert est.model_.meta["max_height"] == 9
    with pytest.warns(UserWarning, match="acts on the output from about lag"):
        fixed = MGGPRegressor(population=20, generations=2, random_state=0,
                              max_height=5).fit(_delayed(25))
    assert fixed.max_height_ == 5 and "max_height" not in fixed.choices_
    plain = MGGPRegressor(population=20, generations=2, random_state=0).fit(_delayed(10))
    assert plain.max_height_ == 5 and plain.choices_["max_height"]["value"] == 5


def test_no_dead_time_named_on_the_panel_records():
    """Control: records whose input acts at once (measured and simulated);
    the scan's best model beyond reach gains at most a few per cent there."""
    from benchmarks.panel import RECORDS
    seen = 0
    for name, make in RECORDS.items():
        rec = make()
        if rec is None:
            continue
        d = rec[0]
        assert dead_time_message(d, reach=16, max_height=5) == "", name
        for inp in d.inputs:
            s = onset_scan(d, inp)
            assert s.best_within(16) < 0.5 * (1 + DEAD_TIME_GAIN) * s.best_rmse, name
        seen += 1
    assert seen >= 9


def test_a_periodic_input_is_not_taken_for_a_dead_time():
    """A sine input repeats itself every 50 samples, so lags a period back
    carry the input of lag 0 (here a direct feedthrough): the scan gains
    beyond reach, but no dead time is named; control: the same system on
    a held random input, whose best lag is 1."""
    n = 3000
    u = np.sin(2 * np.pi * np.arange(n) / 50)
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.5 * y[k - 1] + u[k] + 0.3 * u[k - 1]
    d = Data(u, y)
    scan = onset_scan(d, "u")
    assert scan.best > 16 and scan.best_within(16) > DEAD_TIME_GAIN * scan.best_rmse
    assert scan.periodic(u)
    assert dead_time_message(d, reach=16, max_height=5) == ""
    rng = np.random.default_rng(0)
    w = np.repeat(rng.uniform(-1, 1, n // 10), 10)
    assert not onset_scan(Data(w, y), "u").periodic(w)


def test_an_error_that_only_drifts_with_the_lag_is_no_dead_time():
    """The inverse of the piezo record (input: the output one sample ahead):
    the scan's error falls slowly from 2.5e-4 at lag 1 to 1.9e-4 at lag
    176, 1.3 times, with no lag where it drops: no dead time is named."""
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(3000, seed=1)
    y = piezo_bouc_wen(u)
    d = Data(np.r_[y[1:], y[-1]], u, inputs=["r"], output="u")
    scan = onset_scan(d, "r")
    assert scan.best > 16 and scan.best_within(16) > DEAD_TIME_GAIN * scan.best_rmse
    assert scan.onset_gain() < 1.05
    assert dead_time_message(d, reach=16, max_height=5) == ""
    assert onset_scan(_delayed(25), "u").onset_gain() > 5     # control: a dead time


def test_the_benchmark_warns_exactly_beyond_reach():
    from benchmarks.dead_time import DELAYS, REACH, detection
    rows = [r.split("|")[1:6] for r in detection(seeds=1).splitlines()[2:]]
    for (d, n, found, warned, heights), delay in zip(rows, DELAYS):
        assert int(d) == delay and found.strip() == "1"
        assert warned.strip() == ("1" if delay > REACH else "0"), delay
        h = int(heights.split("(")[0])
        assert (h > 5) == (delay > REACH) and 1 + 3 * h >= delay, delay


def test_the_diagnosis_reaches_a_dead_time_and_does_not_call_it_hysteresis():
    """A 25-sample dead time: the diagnosis raises its searches' height to 9,
    says so, and names no hysteresis; with the dead time hidden from it
    (the control: late_inputs patched to find none) the baseline at height
    5 cannot reach lag 25 and simulates far worse."""
    import narx.records.deadtime
    from mggp.diagnose import diagnose
    from mggp.diagnose.extend import Budget
    kw = dict(budget=Budget(population=100, generations=15), seed=1)
    dx = diagnose(_delayed(25), **kw)
    assert dx.settings["dead_time"]["height"] == 9
    assert "the searches' trees have height 9" in dx.summary()
    assert "hysteresis" not in dx.effects
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(narx.records.deadtime, "late_inputs", lambda data, reach, scans=None: [])
        blind = diagnose(_delayed(25), **kw)
    assert blind.settings["dead_time"] is None
    assert blind.baseline.rmse > 2 * dx.baseline.rmse


def test_the_height_is_not_raised_past_what_max_lag_allows():
    """max_lag below the dead time: raising the height would not let the
    search use the lags, so the height stays and the line says why; with
    max_lag above it (the control) the height is raised."""
    from mggp.fit.choices import height_choice
    low = height_choice(_delayed(25), max_lag=10)
    assert low.value == 5 and low.why.endswith("beyond what max_lag allows")
    assert height_choice(_delayed(25), max_lag=40).value == 9
