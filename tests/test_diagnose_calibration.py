"""False-alarm rates of diagnose tests measured over control records: the
controls are reproducible and have nothing to name, the measurement counts
alarms and turns the ratios into the threshold factor of a stated rate."""
import numpy as np
import pytest

import narx

from mggp.diagnose import Check, DiagnosticTest, Outcome
from mggp.diagnose.calibration import false_alarm_rate
from mggp.diagnose.controls import CONTROL_KINDS, control_record
from mggp.diagnose.holds import find_holds

EXACT = ("linear", "polynomial NARX", "Hammerstein")      # the model is the system's


def test_control_records_are_reproducible_and_their_exact_models_fit_to_the_noise():
    for kind in CONTROL_KINDS:
        a, b = control_record(kind, 3), control_record(kind, 3)
        np.testing.assert_array_equal(a.data.y, b.data.y)
        assert not np.array_equal(a.data.y, control_record(kind, 4).data.y)
        assert np.all(np.isfinite(a.data.y)) and np.ptp(a.data.y) > 0
    for kind in EXACT:
        r = control_record(kind, 0, snr_db=40.0)
        noise = 0.01 * np.std(r.data.y)
        fr = narx.Model(list(r.terms)).fit(r.data).simulate(r.data, mode="freerun")
        assert fr.rmse < 3 * noise, (kind, fr.rmse, noise)
    # held segments only where asked for
    d = control_record("dead zone", 0, holds=3).data
    assert len(find_holds(d, 100)) == 3
    assert find_holds(control_record("dead zone", 0).data, 100) == []
    with pytest.raises(ValueError, match="kind must be one of"):
        control_record("backlash", 0)


def _dummy(stat):
    """A test whose one check has statistic ``stat(ctx)`` and threshold 1."""
    return DiagnosticTest("dummy", ("hysteresis",), lambda ctx: Outcome(
        [Check("dummy", "hysteresis", stat(ctx), 1.0, "")]))


def test_false_alarm_rate_counts_alarms_and_gives_the_threshold_factor():
    seeds = dict(kinds=("linear",), per_kind=10, n=300)
    always = false_alarm_rate(_dummy(lambda ctx: 2.0), **seeds)
    assert always.rate == 1.0 and always.by_kind == {"linear": (10, 10)}
    # ratios 0.1, 0.2, ..., 1.0: none above the threshold 1
    fa = false_alarm_rate(_dummy(lambda ctx: (ctx.seed + 1) / 10), **seeds)
    assert fa.rate == 0.0 and fa.seeds == tuple(range(10))
    lo, hi = fa.interval()
    assert lo == 0.0 and hi == pytest.approx(1 - 0.025 ** 0.1)      # Clopper-Pearson
    f = fa.threshold_factor(0.2)
    assert f == pytest.approx(0.9)
    assert np.mean(np.asarray(fa.ratios) > f) <= 0.2               # the rate it states
    assert "0 false alarms in 10 control realisations" in fa.describe()


def _fam(name, ratios):
    return [Check(name, "steady-state-drift", r, 1.0, "") for r in ratios]


def test_threshold_factors_hold_the_rate_per_test_not_per_family():
    from mggp.diagnose.calibration import threshold_factors
    rng = np.random.default_rng(0)
    a, b = rng.uniform(0, 3, 100), rng.uniform(0, 3, 100)     # independent families
    rows = [[Check("hold (x)", "steady-state-drift", x, 1.0, ""),
             Check("rest error (x)", "steady-state-drift", y, 1.0, "")] for x, y in zip(a, b)]
    f = threshold_factors(rows, 0.05)
    per_family = {k: float(np.quantile(v, 0.95, method="higher")) for k, v in
                  (("hold", a), ("rest error", b))}
    alarms = lambda F: np.mean((a > max(F["hold"], 1)) | (b > max(F["rest error"], 1)))
    assert alarms(per_family) > 0.05                 # each family at 5 %: the test above it
    assert alarms(f) <= 0.05 and alarms(f) >= 0.03   # per test: at the stated rate
    # one family: its (1 - rate) quantile
    assert threshold_factors([[c] for c in _fam("loop gap (u)", a)], 0.05) == {
        "loop gap": per_family["hold"]}
