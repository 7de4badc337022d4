"""Tests of the system zoo (narx.systems.zoo) and its study (benchmarks.zoo)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import warnings

import numpy as np
import pytest

import narx
from narx import Data
from narx.systems import zoo

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _same(a, b):
    return (np.array_equal(a.train.U, b.train.U) and np.array_equal(a.train.y, b.train.y)
            and np.array_equal(a.validation.U, b.validation.U)
            and np.array_equal(a.validation.y, b.validation.y)
            and a.truth == b.truth and json.dumps(a.params) == json.dumps(b.params))


def _ls_misfit(terms, u, y, freerun=False):
    """RMS of the LS equation error of ``terms`` on (u, y) (with ``freerun``:
    of the LS model's free run), relative to std(y)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = narx.Model(list(terms)).fit(Data(u, y))
        if freerun:
            with np.errstate(all="ignore"):
                r = m.simulate(Data(u, y), mode="freerun")
            return np.inf if r.diverged else r.rmse / np.std(y)
    return float(np.sqrt(np.mean(m.fit_info_["residuals"] ** 2)) / np.std(y))


def test_same_seed_same_draw_and_other_seeds_differ():
    a, b, c = zoo.draw(5, n=800), zoo.draw(5, n=800), zoo.draw(6, n=800)
    assert _same(a, b)
    assert not np.array_equal(a.train.y, c.train.y)
    assert not np.array_equal(a.train.U, c.train.U)


def test_every_family_draws_finite_records_whose_truth_parses():
    for i, fam in enumerate(zoo.FAMILIES):
        d = zoo.draw(20 + i, n=600, family=fam)
        assert d.family == fam and d.hysteretic == (fam in zoo.HYSTERETIC_FAMILIES)
        assert d.placement in zoo.PLACEMENTS and d.input_kind in zoo.INPUT_KINDS
        assert (d.placement == "none") == (not d.hysteretic)
        for rec in (d.train, d.validation):
            assert np.all(np.isfinite(rec.y)) and np.all(np.isfinite(rec.U))
        assert d.train.n == 600 and d.validation.n == 500
        narx.Model(list(d.truth.terms))               # parses, no repeated term
        json.dumps(d.params)                          # JSON-able


def test_drawn_family_is_half_hysteretic_and_n_log_uniform():
    ds = [zoo.draw(s, n=None, validation=False) for s in range(60)]
    share = np.mean([d.hysteretic for d in ds])
    assert 0.3 < share < 0.7
    ns = [d.train.n for d in ds]
    assert min(ns) >= 1000 and max(ns) <= 20000 and len(set(ns)) > 50


def test_exact_truths_are_the_system_and_a_wrong_structure_is_not():
    """LS of an exact truth on the noise-free record leaves only rounding;
    the control: the same draws without their memory-operator (or
    nonlinear) terms simulate with an error (a per-sample effect such as
    quadratic damping is small in the one-step error, not in the free run)."""
    seen = set()
    for fam in ("play", "prandtl-ishlinskii", "bouc-wen", "dahl", "maxwell-slip",
                "quadratic-damping", "bilinear", "dead-time"):
        for seed in (41, 42, 48, 53):          # static, before, feedback, feedback
            d = zoo.draw(seed, n=3000, family=fam, validation=False)
            if not d.truth.exact:
                continue
            u = d.train.input("u")
            assert _ls_misfit(d.truth.terms, u, d.train_clean) < 1e-8, (fam, seed)
            seen.add((fam, d.placement))
            if d.hysteretic or fam in ("quadratic-damping", "bilinear"):
                plain = [t for t in d.truth.terms if "(" not in t and "*" not in t]
                assert _ls_misfit(plain, u, d.train_clean, freerun=True) > 1e-3, (fam, seed)
    placements = {p for _, p in seen}
    assert {"before", "feedback", "static"} <= placements


def test_inexact_truths_say_why():
    d = zoo.draw(3, n=800, family="preisach")
    assert not d.truth.exact and "not exact" in d.truth.description


def test_forced_family_keeps_the_input_and_validation_flag_keeps_training():
    a = zoo.draw(11, n=700, family="linear")
    b = zoo.draw(11, n=700, family="play")
    assert np.array_equal(a.train.U, b.train.U)
    c = zoo.draw(11, n=700, family="play", validation=False)
    assert c.validation is None and c.validation_clean is None
    assert np.array_equal(b.train.y, c.train.y)


def test_validation_stays_inside_the_training_range():
    for s in range(8):
        d = zoo.draw(s, n=1000)
        u, v = d.train.input("u"), d.validation.input("u")
        assert v.min() >= u.min() - 1e-12 and v.max() <= u.max() + 1e-12


def test_noise_level_follows_the_drawn_snr():
    d = zoo.draw(2, n=20000)
    e = d.train.y - d.train_clean
    snr = 20 * np.log10(np.std(d.train_clean) / np.std(e))
    assert abs(snr - d.noise["snr_db"]) < 1.0


def test_seed_separation_inside_tuning():
    with zoo.tuning():
        zoo.draw(999, n=300)                           # the control: a development seed
        with pytest.raises(zoo.SeedLeak, match="evaluation seed"):
            zoo.draw(1000, n=300)
        with pytest.raises(zoo.SeedLeak):
            zoo.guard(1999)
        with pytest.raises(zoo.SeedLeak):
            zoo.guard(2999)
        zoo.guard(3000)                                # the control: past the range
    zoo.draw(1000, n=300)                              # outside tuning: allowed
    assert set(zoo.DEVELOPMENT_SEEDS).isdisjoint(zoo.EVALUATION_SEEDS)
    assert zoo.split_of(3) == "development" and zoo.split_of(1500) == "evaluation"
    assert zoo.split_of(2500) == "evaluation" and zoo.split_of(3000) == "other"


@pytest.mark.parametrize("kw, word", [({"seed": -1}, "seed"), ({"seed": 1.5}, "seed"),
                                      ({"n": 10}, "n must"), ({"n": True}, "n must"),
                                      ({"family": "nope"}, "family must"),
                                      ({"validation": "yes"}, "validation must")])
def test_bad_arguments_raise_one_clear_line(kw, word):
    args = {"seed": 1, **kw}
    with pytest.raises(ValueError, match=word) as info:
        zoo.draw(**args)
    assert "\n" not in str(info.value)


def test_long_records_draw_fast():
    for fam in zoo.FAMILIES:                           # compile / warm up
        zoo.draw(1, n=300, family=fam)
    worst = 0.0
    for i, fam in enumerate(zoo.FAMILIES):
        t = time.process_time()
        zoo.draw(100 + i, n=20000, family=fam)
        worst = max(worst, time.process_time() - t)
    assert worst < 1.5


def test_oracle_fits_an_exact_truth_near_the_noise():
    from benchmarks.zoo import oracle
    d = next(d for d in zoo.draws(range(60, 90), n=2000, family="play")
             if d.truth.exact and d.noise["colour"] == "white")
    o = oracle(d)
    sigma = d.params["noise"]["sigma"]
    assert o.method in ("ls", "freerun") and set(o.holdout_rmse) == {"ls", "freerun"}
    assert o.rmse < 1.5 * sigma                         # only the noise is left


def test_parse_seeds_and_calibrate_refuses_evaluation_seeds(tmp_path):
    from benchmarks.zoo import calibrate, parse_seeds
    assert parse_seeds(["3", "10-12", "3"]) == [3, 10, 11, 12]
    with pytest.raises(ValueError, match="--seeds"):
        parse_seeds(["a-b"])
    path = tmp_path / "dev.jsonl"
    with pytest.raises(zoo.SeedLeak):
        calibrate([5, 1005], str(path))
    assert not path.exists()                            # refused before any run


def _record(seed, family, hysteretic, named, gain, identifiable, p):
    return {"seed": seed, "split": "development", "family": family,
            "hysteretic": hysteretic, "placement": "before" if hysteretic else "none",
            "input_kind": "sine", "snr_db": 40.0, "n": 4000, "identifiable": identifiable,
            "oracle_gain": 2.0 if identifiable else 1.1, "named": named, "gain": gain,
            "recommended": "extended" if gain > 1 else "baseline",
            "p_values": {"hysteresis": p}, "seconds": 10.0}


def test_table_counts_and_figure(tmp_path):
    from benchmarks.zoo import table
    recs = [_record(0, "play", True, ["hysteresis"], 2.0, True, 0.001),
            _record(1, "play", True, [], 1.0, True, 0.2),
            _record(2, "bouc-wen", True, ["hysteresis"], 0.9, False, 0.004),
            _record(3, "linear", False, ["unmodelled-dynamics"], 1.0, False, 0.5),
            _record(4, "wiener", False, ["hysteresis"], 0.5, False, 0.003)]
    recs[0].update(extended_rmse=0.1, oracle_rmse=0.08)      # within 1.5x of the oracle
    recs[1].update(baseline_rmse=0.5, oracle_rmse=0.1)       # the baseline kept, 5x
    fig = tmp_path / "power.png"
    text = table(recs, str(fig))
    assert "within 1.5× of the oracle's RMSE on identifiable hysteretic draws: 1/2 (50 %)" \
        in text
    assert text.startswith("**Conclusion.**")
    assert "hysteresis named on identifiable hysteretic draws: 1/2 (50 %)" in text
    assert "hysteresis named on controls: 1/2 (50 %)" in text
    assert "any gain < 0.95 (all draws): 2/5 (40 %)" in text
    assert "| play | 2 | 2 | 1 | 0 | 1 | 0 |" in text
    assert "| linear | 1 | 0 | 0 | 1 | 0 | 0 |" in text
    assert "Non-identifiable hysteretic draws" in text and "| 2 | bouc-wen |" in text
    assert fig.stat().st_size > 1000 and "Figure:" in text


def _cand(name, effect, sel, p, p_free, meas):
    return {"name": name, "effect": effect, "selection_rmse": sel, "p": p, "p_free": p_free,
            "fitted": True, "eligible": True, "measure_rmse": meas}


def test_replay_renames_draws_under_each_memory_share():
    """Records built by hand: a hysteretic draw whose memory candidate
    halves an error already below the resolution (0.01), and a control
    whose memory candidate is 3 % better; at ρ = 1 (the resolution alone)
    neither is named, at ρ = 0.2 the first is and the control is not, at
    ρ = 0 both are."""
    from benchmarks.zoo import replay
    def rec(seed, hysteretic, mem):
        r = _record(seed, "play" if hysteretic else "linear", hysteretic, [], 1.0, True, 0.1)
        r.update(baseline_rmse=0.012, baseline_selection_rmse=0.01, resolution_floor=0.01,
                 candidates=[_cand("plays", "hysteresis", 0.006 * mem, 1e-6, 1e-4, 0.007 * mem),
                             _cand("more degree", "unmodelled-nonlinearity", 0.006, 1e-3,
                                   None, 0.009)])
        return r
    text = replay([rec(0, True, 0.5), rec(1, False, 0.97)], [1.0, 0.2, 0.0])
    assert "| 1 | 0.85 | no | as run | 0.2 | 0.25 | yes | 0/1 (0 %) | 0/1 (0 %) | 0/1 (0 %) | 0/2 (0 %) |" in text, text
    assert "| 0.2 | 0.85 | no | as run | 0.2 | 0.25 | yes | 1/1 (100 %) | 0/1 (0 %) | 1/1 (100 %) | 0/2 (0 %) |" in text, text
    assert "| 0 | 0.85 | no | as run | 0.2 | 0.25 | yes | 1/1 (100 %) | 1/1 (100 %) | 1/1 (100 %) | 0/2 (0 %) |" in text, text
    with pytest.raises(ValueError, match="candidates"):
        replay([_record(2, "play", True, [], 1.0, True, 0.1)], [0.2])


def test_replay_renames_draws_under_each_part_share():
    """A control whose only winner beats the baseline overall through one
    part (the baseline's excursion) and loses the other by a third: with
    the part rule at 0.85, or with its clause that one part may not carry
    the gain, nothing wins and the baseline is kept (gain 1); without
    both (0, carry) the candidate wins and measures 0.8 times the
    baseline."""
    from benchmarks.zoo import replay
    r = _record(0, "linear", False, [], 1.0, True, 0.1)
    r.update(baseline_rmse=0.01, baseline_selection_rmse=0.1, resolution_floor=0.001,
             baseline_part_rmse=[0.01, 0.2],
             candidates=[dict(_cand("more lags", "unmodelled-dynamics", 0.02, 1e-4, None,
                                    0.0125), part_rmse=[0.015, 0.02])])
    text = replay([r], [0.15], [0.0, 0.85], (False, True))
    assert "| 0.15 | 0 | yes | as run | 0.2 | 0.25 | yes | 0/0 (–) | 0/1 (0 %) | 0/0 (–) | 1/1 (100 %) |" in text, text
    # its gain rests on the excursion's part alone: the other clause bars it too
    assert "| 0.15 | 0 | no | as run | 0.2 | 0.25 | yes | 0/0 (–) | 0/1 (0 %) | 0/0 (–) | 0/1 (0 %) |" in text, text
    assert "| 0.15 | 0.85 | no | as run | 0.2 | 0.25 | yes | 0/0 (–) | 0/1 (0 %) | 0/0 (–) | 0/1 (0 %) |" in text, text


def test_replay_bars_candidates_by_their_recorded_hold_motion():
    """A hysteretic draw whose better memory candidate moved by itself in
    a hold (30 % of the output's range) and measures worse than the
    baseline: at a threshold of 0.2 the other memory candidate wins and
    the gain is 1.5; at 0.5 the mover wins and the gain is 0.6. A
    candidate barred for the range stays barred at any threshold."""
    from benchmarks.zoo import replay
    from mggp.diagnose.candidates import BAR_RANGE
    r = _record(0, "play", True, [], 1.0, True, 0.1)
    mover = dict(_cand("Φ of the output lags", "hysteresis", 0.004, 1e-6, 1e-4, 0.02),
                 hold_motion=0.3, bar_reason=None)
    steady = dict(_cand("plays", "hysteresis", 0.005, 1e-6, 1e-4, 0.008),
                  hold_motion=0.0, bar_reason=None)
    wild = dict(_cand("more degree", "unmodelled-nonlinearity", 0.009, 1e-3, None, 0.009),
                hold_motion=0.0, bar_reason=BAR_RANGE, eligible=False)
    r.update(baseline_rmse=0.012, baseline_selection_rmse=0.01, resolution_floor=0.001,
             candidates=[mover, steady, wild])
    text = replay([r], [0.15], None, (False,), (0.2, 0.5))
    assert "| 0.2 | 0.2 | 0.25 | yes | 1/1 (100 %) | 0/0 (–) | 1/1 (100 %) | 0/1 (0 %) |" in text, text
    assert "| 0.5 | 0.2 | 0.25 | yes | 1/1 (100 %) | 0/0 (–) | 0/1 (0 %) | 1/1 (100 %) |" in text, text


@pytest.mark.slow
def test_evaluate_cli_writes_complete_records_and_resumes(tmp_path):
    path = tmp_path / "zoo.jsonl"
    cmd = [sys.executable, "-m", "benchmarks.zoo", "evaluate", "--seeds", "3-3",
           "--json", str(path), "--population", "12", "--generations", "2", "--jobs", "1"]
    env = dict(os.environ, PYTHONPATH=ROOT)
    subprocess.run(cmd, check=True, cwd=ROOT, env=env, capture_output=True)
    recs = [json.loads(line) for line in path.read_text().splitlines()]
    assert [r["seed"] for r in recs] == [3]
    need = {"seed", "family", "hysteretic", "identifiable", "oracle_gain", "named", "gain",
            "recommended", "seconds", "split", "placement", "input_kind", "snr_db", "n",
            "p_values"}
    for r in recs:
        assert need <= set(r), need - set(r)
        assert r["split"] == "development" and r["n"] == 4000
    before = path.read_text()
    out = subprocess.run(cmd, check=True, cwd=ROOT, env=env, capture_output=True, text=True)
    assert path.read_text() == before and out.stdout == ""      # the seed is skipped
    table = subprocess.run([sys.executable, "-m", "benchmarks.zoo", "table", str(path)],
                           check=True, cwd=ROOT, env=env, capture_output=True, text=True)
    assert table.stdout.startswith("**Conclusion.**")


@pytest.mark.slow
def test_standalone_baseline_path():
    """The best model without memory searched without a diagnosis: the
    truth of an exact Bouc-Wen draw beats it (oracle gain > 1.5)."""
    from benchmarks.zoo import baseline_rmse, oracle, oracle_gain
    d = zoo.draw(20, n=4000)
    assert d.family == "bouc-wen" and d.truth.exact
    b = baseline_rmse(d, population=10, generations=2)
    assert np.isfinite(b) and b > 0
    assert oracle_gain(b, oracle(d).rmse) > 1.5


def test_replay_withholds_the_name_on_records_that_cannot_separate():
    """Two hysteretic-looking wins by hand, a memory candidate at 0.7 of the
    best memory-free candidate's RMSE: on a record that separates memory
    from dynamics it is named at any ρ₁; on one that cannot it is named at
    ρ₁ = 0.2 and not at ρ₁ = 0.4, and its gain (1.5) is kept either way."""
    from benchmarks.zoo import replay

    def rec(seed, separates):
        r = _record(seed, "play", True, [], 1.0, True, 0.1)
        r.update(baseline_rmse=0.012, baseline_selection_rmse=0.01, resolution_floor=0.001,
                 separates=separates,
                 candidates=[_cand("plays", "hysteresis", 0.0042, 1e-6, 1e-4, 0.008),
                             _cand("more lags", "unmodelled-dynamics", 0.006, 1e-3, None,
                                   0.009)])
        return r
    sep = replay([rec(0, True)], [0.15], unseparated_shares=[0.2, 0.4])
    assert "| 0.2 | yes | 1/1 (100 %) | 0/0 (–) | 1/1 (100 %) |" in sep, sep
    assert "| 0.4 | yes | 1/1 (100 %) | 0/0 (–) | 1/1 (100 %) |" in sep, sep
    nosep = replay([rec(1, False)], [0.15], unseparated_shares=[0.2, 0.4])
    assert "| 0.2 | yes | 1/1 (100 %) | 0/0 (–) | 1/1 (100 %) |" in nosep, nosep
    assert "| 0.4 | yes | 0/1 (0 %) | 0/0 (–) | 1/1 (100 %) |" in nosep, nosep


def test_naming_level_is_the_least_level_at_which_hysteresis_is_named():
    """A draw whose memory candidate (p 0.01) halves the best memory-free
    candidate's RMSE is named from α = 0.01 on; one whose memory candidate
    is 3 % better than the memory-free one is named at no level (NaN). A
    record without a candidates table gives its recorded p-value."""
    from benchmarks.zoo import naming_level

    def rec(seed, mem):
        r = _record(seed, "play", True, [], 1.0, True, 0.2)
        r.update(baseline_rmse=0.02, baseline_selection_rmse=0.02, resolution_floor=0.001,
                 candidates=[_cand("plays", "hysteresis", 0.01 * mem, 0.01, None, 0.01),
                             _cand("more degree", "unmodelled-nonlinearity", 0.01, 0.001,
                                   None, 0.011)])
        return r
    assert naming_level(rec(0, 0.5)) == pytest.approx(0.01)
    assert np.isnan(naming_level(rec(1, 0.97)))
    assert naming_level(_record(2, "play", True, [], 1.0, True, 0.2)) == pytest.approx(0.2)
