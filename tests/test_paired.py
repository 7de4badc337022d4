"""narx.analysis.paired: the one paired block-bootstrap test of the choices and the
diagnosis; its level under the null (calibration), its power, the block
length, segments, Holm's correction and bad input."""
import numpy as np
import pytest
from scipy.signal import lfilter
from scipy.stats import binom

from narx.analysis.paired import block_length, holm, paired_bootstrap, paired_test

ALPHA = 0.05


def _ar1(rng, n, phi=0.9, scale=1.0):
    return scale * lfilter([1.0], [1.0, -phi], rng.standard_normal(n + 300))[300:]


def _interval(trials, alpha=ALPHA):
    lo, hi = binom.interval(0.95, trials, alpha)
    return lo / trials, hi / trials


def test_the_choices_and_the_diagnosis_call_the_one_test():
    import mggp.fit.choices
    import mggp.diagnose.paired
    import mggp.diagnose.verdict
    assert mggp.diagnose.paired.paired_test is paired_test
    assert mggp.diagnose.verdict.paired_test is paired_test
    assert "paired_gain" in mggp.fit.choices.heldout_gain.__code__.co_names
    assert "paired_test" in mggp.fit.choices.paired_gain.__code__.co_names


# ------------------------------------------------------------ calibration
@pytest.mark.parametrize("floor", [None, 0.5], ids=["squared", "log"])
def test_paired_test_holds_its_level_on_equally_good_autocorrelated_errors(floor):
    """The diagnosis's use: one segment of 1,000 selection samples."""
    rng = np.random.default_rng(0)
    trials, n = 400, 1000
    rejected = sum(paired_test(_ar1(rng, n), _ar1(rng, n), rng, floor=floor).p_value <= ALPHA
                   for _ in range(trials))
    lo, hi = _interval(trials)
    assert lo <= rejected / trials <= hi, rejected / trials


def test_paired_test_holds_its_level_on_two_held_out_ends():
    """The choices' use: squared errors on the two held-out ends of a record
    (two segments of 300 samples), AR(1) errors of φ = 0.8."""
    rng = np.random.default_rng(0)
    trials, m = 400, 300
    rejected = 0
    for _ in range(trials):
        a = np.r_[_ar1(rng, m, 0.8), _ar1(rng, m, 0.8)]
        b = np.r_[_ar1(rng, m, 0.8), _ar1(rng, m, 0.8)]
        rejected += paired_test(a, b, rng, segments=[m, m]).p_value <= ALPHA
    lo, hi = _interval(trials)
    assert lo <= rejected / trials <= hi, rejected / trials


@pytest.mark.parametrize("floor", [None, 0.5], ids=["squared", "log"])
def test_paired_test_has_power_when_one_sequence_is_better(floor):
    rng = np.random.default_rng(1)
    trials, n = 100, 1000
    # control of the level tests: the second error is 30 % smaller
    power = np.mean([paired_test(_ar1(rng, n), _ar1(rng, n, scale=0.7), rng,
                                 floor=floor).p_value <= ALPHA for _ in range(trials)])
    assert power > 0.8, power
    # one-sided: the worse one is (almost) never called better
    worse = np.mean([paired_test(_ar1(rng, n, scale=0.7), _ar1(rng, n), rng,
                                 floor=floor).p_value <= ALPHA for _ in range(trials)])
    assert worse < 0.02, worse


# ------------------------------------------------------------ block length
def test_block_length_grows_with_the_correlation_time():
    rng = np.random.default_rng(2)
    white = block_length(rng.standard_normal(2000))
    slow = block_length(_ar1(rng, 2000, phi=0.95))
    assert white <= 3 < slow <= 500, (white, slow)
    assert block_length(np.ones(50)) == 1 and block_length([1.0, 2.0]) == 1


# ------------------------------------------------------------ the bootstrap
def test_a_clear_difference_is_significant_and_none_is_not():
    rng = np.random.default_rng(1)
    e = _ar1(rng, 300, 0.8)
    t = paired_test(e + 3.0, e, np.random.default_rng(3))          # a biased model
    assert t.p_value < 0.01 and t.mean_difference > 0 and t.spread(np.sqrt) > 0
    # control: b no better than a (same errors, a little noise on b)
    t0 = paired_test(e, e + 0.01 * rng.standard_normal(300), np.random.default_rng(3))
    assert t0.p_value > 0.2
    # one-sided: a lower than b is no evidence for b
    assert paired_test(e, e + 3.0, np.random.default_rng(3)).p_value > 0.99


def test_the_generator_fixes_the_result_and_no_global_state_is_used():
    rng = np.random.default_rng(2)
    a, b = rng.random(200), rng.random(200)
    np.random.seed(0)
    t1 = paired_bootstrap(a, b, np.random.default_rng(7))
    np.random.seed(99)
    t2 = paired_bootstrap(a, b, np.random.default_rng(7))
    assert (t1.p_value, t1.se, t1.block) == (t2.p_value, t2.se, t2.block)
    np.testing.assert_array_equal(t1.a_star, t2.a_star)
    assert paired_bootstrap(a, b, np.random.default_rng(8)).se != t1.se


def test_segments_resample_within_each_segment():
    """Two segments (e.g. both ends of a record held out): each resample
    keeps each segment's samples and length."""
    a = np.r_[np.zeros(100), np.ones(50)]
    t = paired_bootstrap(a, np.zeros(150), np.random.default_rng(0), segments=[100, 50],
                         draws=50)
    np.testing.assert_allclose(t.a_star, 50 / 150)        # the second segment's share
    with pytest.raises(ValueError, match=r"segments must be positive lengths adding up to "
                                         r"the 150 samples, got \[100, 40\]"):
        paired_bootstrap(a, np.zeros(150), np.random.default_rng(0), segments=[100, 40])


def test_diverged_simulations_decide_without_bootstrap():
    rng = np.random.default_rng(3)
    e = rng.standard_normal(200)
    assert paired_test(e, np.full(200, np.inf), rng).p_value == 1.0
    assert paired_test(np.full(200, np.inf), e, rng).p_value < 0.01


def test_holm_adjusts_in_step_down_order():
    np.testing.assert_allclose(holm([0.01, 0.04, 0.03, 0.5]), [0.04, 0.09, 0.09, 0.5])
    assert holm([]).size == 0


@pytest.mark.parametrize("kw, said", [
    (dict(loss_b=np.zeros(5)), "loss_a and loss_b must be non-empty and of equal length, "
                               "got 10 and 5"),
    (dict(draws=0), "draws must be at least 19, got 0"),
    (dict(block=11), r"block must be within 1..10 \(the samples of the shortest segment\), "
                     r"got 11"),
    (dict(loss_b=np.r_[np.zeros(9), np.nan]), "loss_a and loss_b must be finite"),
])
def test_bad_input_names_the_parameter(kw, said):
    args = dict(loss_a=np.arange(10.0), loss_b=np.zeros(10))
    args.update(kw)
    with pytest.raises(ValueError, match=said):
        paired_bootstrap(args.pop("loss_a"), args.pop("loss_b"), np.random.default_rng(0),
                         **args)


def test_bad_errors_name_the_parameter():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match=r"e_a and e_b must be 1-D of one length, got "
                                         r"shapes \(3,\) and \(4,\)"):
        paired_test(np.zeros(3), np.zeros(4), rng)
    with pytest.raises(ValueError, match="floor must be positive or None, got -1"):
        paired_test(np.zeros(30), np.ones(30), rng, floor=-1)
