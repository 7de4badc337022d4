"""mggp diagnose: findings that do not depend on units, noise on a held input,
a model resting at a wrong level, and an extension that does not help.

Records are short and budgets tiny (the user's model is given, so no
baseline search runs); each test takes a few seconds.
"""
import numpy as np
import pytest

import narx
from narx.records.data import Data
from narx.systems import held_sine, piezo_bouc_wen, training_input

from mggp.diagnose import Budget, diagnose
from mggp.diagnose.holds import find_holds, hold_responses
from mggp.diagnose.report import write_report

TINY = Budget(population=20, generations=2, shifts=19)
P1, P2 = "Phi1(u[k-1],u[k-2])", "Phi2(u[k-1],u[k-2])"


def piezo_case(u_scale=1.0, y_scale=1.0):
    """A 2000-sample piezo record, a held sine to validate on, and a
    deliberately incomplete Bouc–Wen model (no u[k-1]·|Δu| term), all in the
    units given by the scales."""
    u = training_input(2000, bandwidth=4.0, seed=0)
    hs = held_sine(amplitude=60, freq=2.0, hold=0.5)
    train = Data(u * u_scale, piezo_bouc_wen(u) * y_scale)
    val = Data(hs.u * u_scale, piezo_bouc_wen(hs.u) * y_scale)
    model = narx.Model(["y[k-1]", P1, f"y[k-1]*{P1}*{P2}"]).fit(train)
    return train, val, model


# ------------------------------------------------------------------ units
@pytest.fixture(scope="module")
def base_diagnosis():
    train, val, model = piezo_case()
    return diagnose(train, val, model, budget=TINY, seed=0)


@pytest.mark.parametrize("u_scale, y_scale", [(1.0, 1e-6), (1.0, 1e6), (1e3, 1.0)],
                         ids=["y*1e-6", "y*1e6", "u*1e3"])
def test_findings_do_not_depend_on_the_units(base_diagnosis, u_scale, y_scale):
    """The same effects, the same baseline error, and the same extension
    error, in the output's units. The record is noise-free and the
    extension's Bouc–Wen shapes are estimated by free-run error, so its
    error is near the floor of the arithmetic (about 1e-5 of the
    baseline's), where rounding in other units moves it by more than
    0.1 %: there the two must agree within 1e-5 of the output's range."""
    train, val, model = piezo_case(u_scale, y_scale)
    dx = diagnose(train, val, model, budget=TINY, seed=0)
    base = base_diagnosis.gain
    assert dx.effects == base_diagnosis.effects
    assert dx.gain.baseline / y_scale == pytest.approx(base.baseline, rel=1e-3)
    span = float(np.ptp(base_diagnosis.fit_data.y))
    assert dx.gain.extended / y_scale == pytest.approx(
        base.extended, rel=1e-3, abs=1e-5 * span)


# ------------------------------------------------------------------ holds
def with_noise(u, sd=0.005, seed=1):
    """``u`` as measured with white noise of ``sd`` (5 mV by default)."""
    return u + sd * np.random.default_rng(seed).standard_normal(u.size)


def test_a_held_input_with_noise_is_found_as_without_noise():
    from test_diagnose import SMALL, drifting_case
    train, val, model, hs = drifting_case()
    noisy = Data(with_noise(val.U[0]), val.y)             # 5 mV on ±60 V
    held = [(hs.hold_rising.start, hs.hold_rising.stop),
            (hs.hold_falling.start, hs.hold_falling.stop)]
    assert find_holds(val, 20) == held
    assert find_holds(noisy, 20) == held                  # was [] (rtol 1e-9 of the range)
    clean = diagnose(train, val, model, budget=SMALL, seed=0)
    dx = diagnose(train, noisy, model, budget=SMALL, seed=0)
    assert ([(h.record, h.start) for h in dx.evidence.holds]
            == [(h.record, h.start) for h in clean.evidence.holds])
    assert [h.start for h in dx.evidence.holds if h.record == "validation"] == [
        a for a, _ in held]
    assert dx.effects == clean.effects


@pytest.mark.parametrize("u", [
    40 * np.sin(2 * np.pi * 0.05 * np.arange(20_000) * 1e-3),
    np.linspace(-40, 40, 40_001),
    training_input(20_000, seed=3),
], ids=["slow sine 0.05 Hz", "slow ramp 2 mV per sample", "training input 1 Hz"])
def test_a_moving_input_with_the_same_noise_has_no_hold(u):
    # over 20 samples these move less than a band of ±5 noise σ: only the
    # slope and bend tests tell them from a hold
    noisy = Data(with_noise(u), np.zeros(u.size))
    assert find_holds(noisy, 20) == []
    # the noisy held sine of the previous test, for contrast
    hs = held_sine(amplitude=60, freq=2.0, hold=0.5)
    assert len(find_holds(Data(with_noise(hs.u), np.zeros(hs.u.size)), 20)) == 2


def test_a_model_with_a_continuum_of_steady_states_keeps_still_in_noisy_holds():
    # noise on the measured input would drive the direction terms (|Δu| > 0)
    # and move the model in the hold: the model sees the hold's level instead
    u = training_input(3000, bandwidth=4.0, seed=0)
    model = narx.Model(["y[k-1]", "u[k-1]", P1, f"y[k-1]*{P1}*{P2}",
                        f"u[k-1]*{P1}*{P2}"]).fit(u, piezo_bouc_wen(u),
                                                  constraints="steady-state")
    hs = held_sine(amplitude=60, freq=2.0, hold=0.5)
    noisy = Data(with_noise(hs.u), piezo_bouc_wen(hs.u))
    resp = hold_responses(model, noisy, "validation", 20)
    assert [r.start for r in resp] == [hs.hold_rising.start, hs.hold_falling.start]
    for r in resp:
        assert abs(r.model_move) < 1e-9 and abs(r.rate) < 1e-9
        assert r.level == pytest.approx(hs.u[r.start], abs=0.005)


def test_report_says_when_no_held_input_segment_was_found(base_diagnosis, tmp_path):
    from narx.systems import sine_input
    train, _, model = piezo_case()
    _, uv = sine_input(duration=1.0, freq=2.0, amplitude=60)
    dx = diagnose(train, Data(uv, piezo_bouc_wen(uv)), model, budget=TINY, seed=0)
    assert dx.evidence.holds == []
    said = "(No held-input figure: no held-input segment in the data.)"
    assert said in open(write_report(tmp_path / "none", dx)).read()
    # control: the held sine has holds, and the report does not say so
    assert base_diagnosis.evidence.holds
    assert said not in open(write_report(tmp_path / "held", base_diagnosis)).read()


# ------------------------------------------------- an extension that does not help
def test_an_extension_that_lost_the_test_is_not_recommended(base_diagnosis, tmp_path):
    from dataclasses import replace

    from mggp.diagnose import Gain
    b = base_diagnosis.gain.baseline
    # no candidate won the test: the baseline is kept, whatever the measurement
    dx = replace(base_diagnosis, gain=Gain(b, b / 4, won=False))
    text = dx.summary()
    assert ("recommended: the baseline (no candidate extension won the test, so nothing was "
            "changed)" in text), text
    assert dx.to_dict()["gain"]["recommended"] == "baseline"
    report = open(write_report(tmp_path / "r", dx)).read()
    assert "Recommended: the baseline (no candidate extension won the test" in report
    # a winner that measures worse out of sample is said so, with both RMSEs
    worse = replace(dx, gain=Gain(b, 1.5 * b, won=True))
    assert (f"on the measuring samples it is worse, though: RMSE {1.5 * b:.4g} against "
            f"RMSE {b:.4g} for the baseline" in worse.summary()), worse.summary()
    div = replace(dx, gain=Gain(b, float("inf"), won=True))
    assert "it is worse, though: diverges against RMSE" in div.summary()
    # control: a winner that measures better recommends it, with its gain
    better = replace(dx, gain=Gain(b, b / 4, won=True))
    assert ("recommended: the extended model (it won the test on the selection samples; on "
            "the measuring samples its free-run RMSE there is 4 times lower than the "
            "baseline's)" in better.summary()), better.summary()
    assert better.to_dict()["gain"]["recommended"] == "extended"


def test_diverging_baseline_gives_an_undefined_ratio_and_a_warning(base_diagnosis, tmp_path):
    """Both models diverging: the ratio is undefined (it printed 'ratio inf')
    and the summary says the baseline diverges; '|' in a table cell is
    escaped so the Markdown table keeps its columns."""
    from dataclasses import replace

    from mggp.diagnose import Gain
    from mggp.diagnose.report import _table
    dx = replace(base_diagnosis, gain=Gain(float("inf"), float("inf")))
    assert np.isnan(dx.gain.ratio)
    text = dx.summary()
    assert "ratio undefined" in text and "RMSE diverges (baseline)" in text
    assert "warning: the baseline's free run diverges on the measuring samples" in text
    assert dx.gain.recommended == "baseline"
    # without a finding the recommendation itself says the baseline diverges;
    # control: a finite baseline's recommendation does not
    assert "recommended: the baseline (no candidate extension won the test, so nothing was " \
           "changed); its free run diverges on the measuring samples" in text
    quiet = replace(base_diagnosis, gain=Gain(1.0, 1.0))
    assert "diverges" not in quiet.summary().split("recommended:")[1]
    row = _table([["hysteresis", "corr(|Δu|, e) = 0.3"]], ["finding", "evidence"])[2]
    assert row.count("|") - row.count("\\|") == 3


# --------------------------------------------- a model that rests at a wrong level
def ramps_and_holds(n=3000, seed=0, hold=150):
    """Input ramping at a random slope to a random level, then held."""
    r = np.random.default_rng(seed)
    u, level = [0.0], 0.0
    while len(u) < n:
        new = float(r.uniform(-1, 1))
        steps = int(r.integers(20, 60))
        u += list(np.linspace(level, new, steps + 1)[1:]) + [new] * hold
        level = new
    return np.array(u[:n])


def memoryless_record(seed):
    """y[k] = u[k-1], noise-free: the system rests where its input stops."""
    u = ramps_and_holds(seed=seed)
    return Data(u, np.r_[0.0, u[:-1]])


def jumping_model(beta):
    """y[k] = y[k-1] + Δu[k-1] + β (Δu[k-1] - Δu[k-2]): exact while the input
    ramps at a constant slope s, still in every hold (a continuum of steady
    states), but two samples after the input stops it jumps by -β s and
    rests there. β = 0 is the exact model."""
    return narx.Model(["y[k-1]", "u[k-1]", "u[k-2]", "u[k-3]"],
                      theta=[1.0, 1.0 + beta, -(1.0 + 2.0 * beta), beta])


def test_hold_responses_see_a_model_that_lands_at_a_wrong_level_when_the_input_stops():
    # compared from start + L + 1 on, after the jump, a model resting still at
    # the wrong level does not move: its error at rest shows it
    train, val = memoryless_record(1), memoryless_record(2)
    bad = jumping_model(20.0)
    resp = hold_responses(bad, val, "validation", 20)
    assert resp and all(abs(r.model_move) < 1e-9 for r in resp)      # keeps still ...
    assert max(r.rest_error for r in resp) > 0.2                      # ... at a wrong level
    # control: the exact model rests at the data's level and nothing is named
    good = jumping_model(0.0)
    assert all(r.rest_error < 1e-9 for r in hold_responses(good, val, "validation", 20))
    dx = diagnose(train, val, good, budget=TINY, seed=0)
    assert dx.effects == [], dx.verdict.lines()      # nothing beats the exact model


def test_the_summary_describes_the_extension_that_was_chosen(base_diagnosis):
    dx = base_diagnosis
    w = dx.verdict.winner
    assert w is not None and dx.changes == (w.structure.changes,)
    text = dx.summary()
    block = text.split(f"extension ({w.structure.name}, ")[1].split("\ngain:")[0]
    for change in dx.changes:                # the winner's changes
        assert " ".join(change.split())[:60] in " ".join(block.split()), (change, block)
    assert dx.to_dict()["extended"]["changes"] == list(dx.changes)
    assert dx.extended.model.meta["changes"] == list(dx.changes)
    ops = dx.operator_params       # the winner's shapes, estimated by free-run error
    assert ops is not None and ops["kept"], ops
    assert dx.extended.source == (f"{w.structure.name}: " + "; ".join(dx.changes)
                                  + f"; {ops['words']}")
    assert ops["words"] in block
    assert [t.split("(")[0] for t in dx.extended.model.term_texts] == \
        [t.split("(")[0] for t in w.model.term_texts]     # the same structure
    # control: the search-based extension of the library keeps the plan's changes
    from mggp.diagnose.extend import Setting, candidate_changes, plan_extension
    plan = plan_extension(["hysteresis"], Setting("ms", 100, False, None, 3, 5, 15), TINY)
    assert candidate_changes("search", plan)[:-1] == plan.changes
    assert candidate_changes("search", plan)[-1] == "chosen candidate: the search's terms"


def test_a_diverging_augmentation_is_said_so_not_a_drop_of_inf():
    from mggp.diagnose.findings import number_text as _g
    from mggp.diagnose.report import _g as rg
    assert _g(float("-inf")) == "-inf" and rg(float("-inf")) == "-inf"
    assert _g(float("nan")) == "undefined" and rg(float("inf")) == "inf"


def test_tail_free_run_carries_the_memory_operators_state_from_the_input_before_it():
    from mggp.diagnose.simulation import freerun_after
    from narx.systems import training_input
    u = training_input(1200, bandwidth=4.0, seed=5)
    y = np.zeros(u.size)
    d = Data(u, y)
    op = narx.Model(["Play(u[k-1],30)"], theta=np.array([1.0]))
    whole = op.simulate(d, mode="freerun").y_hat
    tail = freerun_after(op, d, 800, None)
    np.testing.assert_allclose(tail.y_hat, whole[800:], rtol=0, atol=1e-12)
    cut = op.simulate(d.slice(800), mode="freerun").y_hat
    assert np.max(np.abs(cut[1:] - whole[801:])) > 1.0       # a cut record starts at rest


def test_tail_free_run_carries_an_output_operator_state_the_outputs_do_not_give():
    """A play of y[k-1] in the feedback: run from the record's start the
    tail is the model's own simulation; started at the tail from the
    measured outputs (the control) its play begins at rest and the error
    stays, since held steps never sweep it back."""
    from mggp.diagnose.simulation import freerun_after
    from narx.systems import training_input
    u = np.repeat(training_input(60, bandwidth=4.0, seed=7), 20)
    terms = ["y[k-1]", "u[k-1]", "Play(y[k-1],40)"]
    true = narx.Model(terms, theta=np.array([0.6, 0.2, 0.3]))
    d = Data(u, np.zeros(u.size))
    d = Data(u, true.simulate(d, mode="freerun").y_hat)
    tail = freerun_after(true, d, 600, None)
    np.testing.assert_allclose(tail.y_hat, d.y[600:], rtol=0, atol=1e-9)
    cut = true.simulate(d.slice(600), mode="freerun")
    assert np.sqrt(np.mean((cut.y - cut.y_hat) ** 2)) > 0.02 * np.ptp(d.y)


def test_share_of_the_measuring_input_outside_the_fitting_range():
    from mggp.diagnose.run import outside_fit_range
    fit = Data(np.linspace(-1, 1, 100), np.zeros(100))
    meas = Data(np.r_[np.zeros(5), np.full(3, 2.0), np.full(2, -1.5)], np.zeros(10))
    assert outside_fit_range(fit, meas) == {"u": 0.5}
    assert outside_fit_range(fit, meas, start=8) == {"u": 1.0}
    assert outside_fit_range(fit, meas, mask=np.arange(10) % 2 == 1) == {"u": 0.6}


def test_augmentation_leaves_out_only_the_control_terms_in_the_span_of_the_others():
    from mggp.diagnose.augmentation import (augmentation_check, independent_terms,
                                            phi_augmentation_test)
    from narx.systems.testsystems import polynomial_narx
    s = polynomial_narx(n=1500, seed=0, noise_std=0.02)
    d = Data(s.u, s.y)
    sig = dict(inputs=d.inputs, output=d.output, registry=narx.Model(["u[k-1]"]).registry)
    kept, dropped = independent_terms(["u[k-1]", "u[k-2]"], [P1, "u[k-1]*u[k-1]"], d, sig, 2)
    assert kept == ["u[k-1]*u[k-1]"] and dropped == [P1]     # P1 = u[k-1] - u[k-2]
    # with both input lags in the baseline only Δu goes; the other controls stay
    both = narx.Model(["y[k-1]", "y[k-2]", "u[k-1]", "u[k-2]"]).fit(d)
    a = phi_augmentation_test(both, d, shifts=9, seed=0)
    assert a is not None and a.dropped_controls == (P1,)
    assert set(a.controls) == {f"y[k-1]*{P1}", f"u[k-1]*{P1}", "u[k-1]*u[k-1]",
                               "u[k-2]*u[k-2]"}
    assert f"left out of the fits as linear combinations of the others: {P1}" in \
        augmentation_check(a, 0.01, 0.0, "y").detail
    # control: a baseline with one input lag keeps every control term
    one = narx.Model(["y[k-1]", "u[k-1]"]).fit(d)
    b = phi_augmentation_test(one, d, shifts=9, seed=0)
    assert b.dropped_controls == () and len(b.controls) == 6
    assert "left out" not in augmentation_check(b, 0.01, 0.0, "y").detail


# ------------------------------------------------------------------ pruning
def _linear_record(seed=0, n=1500):
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, n)
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.8 * y[k - 1] + 0.5 * u[k - 1]
    return Data(u, y + 0.02 * rng.standard_normal(n))


def test_pruning_drops_the_spurious_terms_and_keeps_a_true_structure():
    from mggp.diagnose.extend import _pruned
    d = _linear_record()
    reg = narx.Model(["y[k-1]"]).registry
    spurious = ["y[k-1]", "u[k-1]", "u[k-2]*u[k-2]", "y[k-3]*u[k-1]", "u[k-4]"]
    assert _pruned(spurious, d, None, reg) == ["y[k-1]", "u[k-1]"]
    # control: nothing to drop from the true structure
    assert _pruned(["y[k-1]", "u[k-1]"], d, None, reg) == ["y[k-1]", "u[k-1]"]


def test_a_pruned_candidate_says_it_was_pruned():
    from mggp.diagnose.extend import PRUNED, Setting, ExtensionPlan, candidate_changes
    plan = ExtensionPlan(Setting("ms", 100, True, None, 3, 5, 15), False, False, True,
                         ("hysteresis: ...",))
    for name, at in (("operator dynamics", 0), ("search + direction terms", -1)):
        built = candidate_changes(name, plan)
        pruned = candidate_changes(name + PRUNED, plan)
        assert len(pruned) == len(built) and pruned[at].startswith(built[at])
        assert "pruned" in pruned[at] and "BIC" in pruned[at]
        assert [c for c in pruned if c not in built] == [pruned[at]]



# ------------------------------------------- an oversampled, noise-free record
def test_augmentation_has_power_on_a_slow_noise_free_piezo_record():
    """1 Hz input at 1 kHz, no noise: the LS fit of the increment form with
    the second output lag y[k-2] simulates with drifting dynamics (9.1 here,
    2.4 without it), which hid the direction terms' gain; the form without
    the output-lag control finds it. Control: the baseline given the direction
    terms already (the Bouc–Wen increment itself) gains nothing."""
    from mggp.diagnose.augmentation import NO_LAG_CONTROL, phi_augmentation_test
    u = training_input(14_000, seed=1)
    d = Data(u, piezo_bouc_wen(u))
    base = narx.Model(["y[k-1]", "y[k-4]", "u[k-1]", "u[k-6]", "y[k-1]*y[k-1]*u[k-3]",
                       "u[k-3]", "y[k-1]*y[k-6]*u[k-2]", "y[k-6]*y[k-6]*u[k-1]",
                       "y[k-1]*y[k-5]*u[k-7]", "y[k-2]", "y[k-1]*y[k-3]*u[k-5]",
                       "u[k-6]*u[k-6]*u[k-7]"]).fit(d)
    a = phi_augmentation_test(base, d, shifts=19, seed=0)
    assert a.form == NO_LAG_CONTROL
    assert a.statistic > max(a.null_quantile, 0.005 * np.ptp(d.y)) > 0
    full = narx.Model(["y[k-1]", P1, f"{P1}*{P2}", f"y[k-1]*{P1}*{P2}",
                       f"u[k-1]*{P1}*{P2}"]).fit(d)
    c = phi_augmentation_test(full, d, shifts=19, seed=0)
    assert c is None or c.statistic < 0.005 * np.ptp(d.y)


def test_held_out_augmentation_sees_a_baseline_that_only_fits_its_own_loops():
    """Input seed 3 of the same record: the searched baseline simulates the
    fitting samples well, so the direction terms gain little in sample (below
    the floor), but fitted on the first 70 % it misses the loops of the rest,
    which the Bouc–Wen increment form reproduces: the held-out test fires.
    Control: the Bouc–Wen increment model itself gains nothing held out."""
    from mggp.diagnose.augmentation import HELD_OUT, augmentation_check, phi_augmentation_test
    from mggp.diagnose.thresholds import calibrated
    u = training_input(20_000, seed=3)
    d = Data(u[:14_000], piezo_bouc_wen(u)[:14_000])      # the fitting samples
    floor = 0.005 * np.ptp(d.y)
    base = narx.Model(["y[k-7]*y[k-8]", "u[k-2]*u[k-2]*u[k-5]", "y[k-5]*u[k-6]", "u[k-5]",
                       "u[k-16]", "y[k-4]", "y[k-3]*u[k-3]", "y[k-5]", "y[k-7]*u[k-9]",
                       "u[k-3]*u[k-9]", "u[k-9]", "y[k-1]*y[k-1]", "u[k-1]", "u[k-13]",
                       "y[k-1]"]).fit(d)
    inside = augmentation_check(phi_augmentation_test(base, d, shifts=19, seed=0),
                                0.01, floor, "y")
    held = calibrated(augmentation_check(phi_augmentation_test(base, d, shifts=19, seed=0,
                                                               holdout=0.7), 0.01, floor, "y"))
    assert held.test == HELD_OUT and "on the last 30 % of the fitting samples" in held.detail
    assert not inside.beats and held.beats
    full = narx.Model(["y[k-1]", P1, f"{P1}*{P2}", f"y[k-1]*{P1}*{P2}",
                       f"u[k-1]*{P1}*{P2}"]).fit(d)
    c = phi_augmentation_test(full, d, shifts=19, seed=0, holdout=0.7)
    assert c is None or c.statistic < floor


def test_augmentation_tests_run_on_a_two_input_record():
    """Each input's control terms hold the same output lag y[k-2]: listed
    twice, the fits could not be built and every augmentation test was
    skipped on records with several inputs (the MR damper's v, E)."""
    from mggp.diagnose.augmentation import operator_augmentation_test, phi_augmentation_test
    rng = np.random.default_rng(0)
    n = 2000
    U = rng.uniform(-1, 1, (n, 2))
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.8 * y[k - 1] + 0.3 * U[k - 1, 0] + 0.2 * U[k - 1, 1]
    d = Data(U, y + 0.01 * rng.standard_normal(n), inputs=["u1", "u2"])
    model = narx.Model(["y[k-1]", "u1[k-1]", "u2[k-1]"], inputs=["u1", "u2"]).fit(d)
    floor = 0.005 * np.ptp(d.y)
    for test in (phi_augmentation_test, operator_augmentation_test):
        a = test(model, d, shifts=19, seed=0)
        assert a is not None
        # control: a linear system fitted with its own terms gains nothing
        assert a.statistic <= max(a.null_quantile, floor)
    held = phi_augmentation_test(model, d, shifts=19, seed=0, holdout=0.7)
    assert held is not None and held.statistic <= max(held.null_quantile, floor)


def test_a_skipped_augmentation_test_says_why_with_numbers():
    from mggp.diagnose.augmentation import phi_augmentation_test
    u = training_input(300, bandwidth=4.0, seed=0)
    d = Data(u, piezo_bouc_wen(u))
    model = narx.Model(["y[k-1]", "u[k-1]"]).fit(d)
    why = []
    assert phi_augmentation_test(model, d, shifts=3, holdout=0.9, why=why) is None
    assert why == ["300 fitting samples are too few to fit on 90 % and score on the rest "
                   "(at least 50 rows each)"]
    # control: the same record in sample runs, and says nothing
    why = []
    assert phi_augmentation_test(model, d, shifts=3, why=why) is not None and why == []


def test_bouc_wen_dynamics_candidate_fits_bouc_wen_not_play_records():
    """A Bouc–Wen hysteresis off the shape grid (γ < 0) behind second-order
    dynamics: the Bouc–Wen dynamics candidate, fitted on the head, simulates
    the tail 5 times better than the play-operator dynamics; control: on a
    play record the play-operator dynamics is the better one."""
    from benchmarks.diagnose_panel import behind_dynamics, play
    from mggp.diagnose.extend import bouc_wen_dynamics_terms, operator_dynamics_terms
    from mggp.diagnose.simulation import freerun_rmse
    u = training_input(3000, amplitude=80, bandwidth=4.0, seed=11)
    err = {}
    for kind, y in (("bouc-wen", behind_dynamics(piezo_bouc_wen(u, beta=0.02, gamma=-0.005), 2)),
                    ("play", behind_dynamics(80 * play(u / 80, 0.3), 2))):
        d = Data(u, y)
        for name, terms in (("bw", bouc_wen_dynamics_terms), ("op", operator_dynamics_terms)):
            m = narx.Model(terms(d)).fit(d.slice(0, 2100))
            err[kind, name] = freerun_rmse(m, d, first=2100)
    assert err["bouc-wen", "bw"] < 0.2 * err["bouc-wen", "op"]
    assert err["play", "op"] < err["play", "bw"]
