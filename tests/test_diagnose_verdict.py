"""The verdict of mggp diagnose: the paired held-out test, its calibration
under the null and its power, Holm's correction, the naming rule, and the
line that says a record cannot separate memory from dynamics."""
import numpy as np
import pytest
from scipy.signal import lfilter
from scipy.stats import binom

import narx
from narx.data import Data
from narx.systems import piezo_bouc_wen, sine_input, training_input

from mggp.diagnose import Budget, diagnose
from mggp.diagnose.candidates import MEMORY, Structure
from mggp.diagnose.paired import block_length, holm, paired_test
from mggp.diagnose.verdict import decide, separation_note

ALPHA = 0.05


def _ar1(rng, n, phi=0.9, scale=1.0):
    return scale * lfilter([1.0], [1.0, -phi], rng.standard_normal(n + 300))[300:]


def _interval(trials, alpha=ALPHA):
    lo, hi = binom.interval(0.95, trials, alpha)
    return lo / trials, hi / trials


# ------------------------------------------------------------ the paired test
def test_paired_test_holds_its_level_on_equally_good_autocorrelated_errors():
    rng = np.random.default_rng(0)
    trials, n = 400, 1000
    rejected = sum(paired_test(_ar1(rng, n), _ar1(rng, n), rng).p_value <= ALPHA
                   for _ in range(trials))
    lo, hi = _interval(trials)
    assert lo <= rejected / trials <= hi, rejected / trials


def test_paired_test_has_power_when_one_sequence_is_better():
    rng = np.random.default_rng(1)
    trials, n = 100, 1000
    # control of the test above: the candidate's error is 30 % smaller
    power = np.mean([paired_test(_ar1(rng, n), _ar1(rng, n, scale=0.7), rng).p_value <= ALPHA
                     for _ in range(trials)])
    assert power > 0.8, power
    # one-sided: the worse candidate is (almost) never called better
    worse = np.mean([paired_test(_ar1(rng, n, scale=0.7), _ar1(rng, n), rng).p_value <= ALPHA
                     for _ in range(trials)])
    assert worse < 0.02, worse


def test_block_length_grows_with_the_correlation_time():
    rng = np.random.default_rng(2)
    white = block_length(rng.standard_normal(2000))
    slow = block_length(_ar1(rng, 2000, phi=0.95))
    assert white <= 3 < slow <= 500, (white, slow)


def test_diverged_simulations_decide_without_bootstrap():
    rng = np.random.default_rng(3)
    e = rng.standard_normal(200)
    assert paired_test(e, np.full(200, np.inf), rng).p_value == 1.0
    assert paired_test(np.full(200, np.inf), e, rng).p_value < 0.01


def test_holm_adjusts_in_step_down_order():
    np.testing.assert_allclose(holm([0.01, 0.04, 0.03, 0.5]), [0.04, 0.09, 0.09, 0.5])
    assert holm([]).size == 0


# -------------------------------------------------------------- naming rule
def _s(effect, name):
    return Structure(effect, name, f"{effect}: {name}", (), ())


M = narx.Model(["y[k-1]"], theta=[0.5])          # stands for a fitted candidate


def test_memory_must_beat_the_best_memory_free_candidate_not_only_the_baseline():
    rng = np.random.default_rng(4)
    n = 1500
    base = _ar1(rng, n, scale=2.0)
    same = _ar1(rng, n)                               # memory and degree equally good
    cands = [(_s(MEMORY, "plays"), M, same),
             (_s("unmodelled-nonlinearity", "more degree"), M, _ar1(rng, n))]
    v = decide(base, cands, ALPHA, rng)
    assert v.named == ("unmodelled-nonlinearity",), v.p_values
    assert v.p_values["hysteresis"] > ALPHA
    # control: a memory candidate truly better than the memory-free one is named
    cands[0] = (_s(MEMORY, "plays"), M, 0.5 * same)
    v = decide(base, cands, ALPHA, rng)
    assert v.named == ("hysteresis",) and v.winner.structure.name == "plays"
    assert v.p_values["hysteresis"] <= ALPHA


def test_nothing_is_named_when_no_candidate_beats_the_baseline():
    rng = np.random.default_rng(5)
    n = 1500
    cands = [(_s(MEMORY, "plays"), M, _ar1(rng, n)),
             (_s("unmodelled-dynamics", "more lags"), M, _ar1(rng, n))]
    v = decide(_ar1(rng, n), cands, ALPHA, rng)
    assert v.named == () and v.winner is None
    d = v.to_dict()
    assert set(d["p_values"]) == {"hysteresis", "unmodelled-dynamics"}
    assert {"effect", "changes", "terms", "selection_rmse", "p_value"} <= set(d["candidates"][0])


# --------------------------------------------------------- separation line
def _one_sine(n=3000, amplitude=40.0, seed=0):
    t = np.arange(n) * 1e-3
    u = amplitude * np.sin(2 * np.pi * 2.0 * t)
    rng = np.random.default_rng(seed)
    return Data(u, piezo_bouc_wen(u) + 0.01 * rng.standard_normal(n))


def test_one_sine_cannot_separate_memory_from_dynamics_a_multi_amplitude_record_can():
    note = separation_note(_one_sine())
    assert note and "several amplitudes, or holds, would" in note
    t = np.arange(3000) * 1e-3
    u = 40 * np.sin(2 * np.pi * 2.0 * t) * (0.4 + 0.6 * np.abs(np.sin(2 * np.pi * 0.3 * t)))
    assert separation_note(Data(u, piezo_bouc_wen(u))) is None          # control
    assert separation_note(Data(training_input(3000, bandwidth=4.0, seed=1),
                                np.zeros(3000))) is None


def test_the_summary_says_the_one_sine_record_cannot_separate():
    d = _one_sine()
    m = narx.Model(["y[k-1]", "u[k-1]"]).fit(d)
    dx = diagnose(d, model=m, budget=Budget(population=20, generations=2), seed=0)
    assert dx.separation and dx.separation in dx.summary()
    assert dx.to_dict()["separation"] == dx.separation
