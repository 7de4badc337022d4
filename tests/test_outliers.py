"""Isolated glitches of the output and inputs: found, repaired, and the fit
that follows (narx.records.outliers, MGGPRegressor(outliers=...), mggp fit --outliers)."""
import json
import subprocess
import sys
import warnings

import numpy as np
import pytest

import narx.records.outliers as outliers
from benchmarks.outliers import (RECEIVERS, TRUE, bilinear_record, glitched, glitched_input,
                                 received)
from narx import Data, Model
from narx.records.outliers import find_spikes, repaired


def test_the_planted_spikes_are_found_and_nothing_else():
    u, y = bilinear_record()
    spikes = find_spikes(Data(u, glitched(y)))
    assert [(s.start, s.stop) for s in spikes] == [(300, 301), (431, 433)]
    assert spikes[0].values == (pytest.approx(glitched(y)[300]),)
    assert all(s.beyond > outliers.SPIKE_BAND and s.sigmas > outliers.ARX_SIGMAS
               for s in spikes)
    assert find_spikes(Data(u, y)) == []                    # control: the clean record


def test_a_glitch_inside_the_range_or_a_short_one_is_not_taken():
    """Control: a spike that stays within the rest of the range by the band,
    and one that reaches only 10 % beyond it, are left alone."""
    u, y = bilinear_record()
    ys = y.copy()
    ys[300] = np.min(y) + 0.5 * np.ptp(y)                   # inside the range
    ys[200] = np.max(y) + 0.1 * np.ptp(y)                   # 10 % beyond it
    assert find_spikes(Data(u, ys)) == []


def test_an_output_that_answers_an_input_pulse_is_no_spike():
    """An impulse test passes the isolation and range tests, and the ARX
    test tells it from a glitch: with that test off (ARX_SIGMAS = 0) the
    same samples would be taken."""
    rng = np.random.default_rng(1)
    u = np.zeros(600)
    u[[100, 300, 500]] = 1.0
    y = np.zeros(600)
    for k in range(1, 600):
        y[k] = 0.3 * y[k - 1] + 2.0 * u[k - 1]
    d = Data(u, y + 1e-3 * rng.standard_normal(600))
    assert find_spikes(d) == []
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(outliers, "ARX_SIGMAS", 0.0)
        assert len(find_spikes(d)) >= 1


def test_equal_glitches_do_not_hide_each_other_up_to_max_share():
    """Five equal spikes of 600 samples are found together (each alone lies
    within the range the others make); ten exceed MAX_SHARE (six a side)
    and are left as measured."""
    u, y = bilinear_record(n=600)
    assert int(outliers.MAX_SHARE * 600) == 6
    five, ten = y.copy(), y.copy()
    five[100:600:100] += 20.0
    ten[50:550:50] += 20.0
    assert [s.start for s in find_spikes(Data(u, five))] == [100, 200, 300, 400, 500]
    assert find_spikes(Data(u, ten)) == []


def test_repair_draws_the_line_between_the_neighbours_and_copies():
    u, y = bilinear_record()
    ys = glitched(y)
    d = Data(u, ys)
    r = repaired(d, find_spikes(d))
    assert r.y[300] == pytest.approx((ys[299] + ys[301]) / 2)
    assert r.y[431:433] == pytest.approx(ys[430] + (ys[433] - ys[430]) * np.array([1, 2]) / 3)
    assert np.array_equal(np.delete(r.y, [300, 431, 432]), np.delete(ys, [300, 431, 432]))
    assert np.array_equal(r.input("u"), d.input("u"))
    assert d.y[300] == ys[300]                              # the record given is not changed
    assert repaired(d, []) is d


def test_input_glitches_are_found_where_the_output_does_not_answer():
    """Glitched input samples the output never answered are found exactly,
    after the output's own glitch; the clean record (control) has none."""
    u, y = bilinear_record()
    spikes = find_spikes(Data(glitched_input(u), glitched(y)))
    assert [(s.signal, s.start, s.stop) for s in spikes] == [
        ("y", 300, 301), ("y", 431, 433), ("u", 300, 301), ("u", 431, 433)]
    assert all(s.sigmas > outliers.ARX_SIGMAS for s in spikes)
    assert find_spikes(Data(u, y)) == []
    r = repaired(Data(glitched_input(u), y), spikes[2:])
    assert r.input("u")[300] == pytest.approx((u[299] + u[301]) / 2)
    assert np.array_equal(r.y, y)


def _taken_pulses(seeds):
    return sum(bool([s for s in find_spikes(received(name, seed)) if s.signal == "u"])
               for name in RECEIVERS for seed in seeds)


def test_pulses_the_system_received_are_kept():
    """Five systems (a saturating one among them) driven through real input
    pulses one to two ranges out: none is taken for a glitch. Controls: the
    same pulses are taken when the output's answer is not looked at (tests
    3'b and 3'c off), and the saturating system's with 3'c alone off."""
    seeds = range(10)
    assert _taken_pulses(seeds) == 0
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(outliers, "QUIET_SIGMAS", np.inf)
        mp.setattr(outliers, "EDGE_SIGMAS", -np.inf)
        assert _taken_pulses(seeds) >= 30
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(outliers, "EDGE_SIGMAS", -np.inf)
        assert sum(bool(find_spikes(received("saturating", s))) for s in range(30)) >= 1


def test_no_spike_on_the_panel_records():
    """Control on real and simulated records without glitches: the measured
    cascaded tanks, buck converter and MR damper, the simulated piezo,
    Prandtl-Ishlinskii, Bouc-Wen oscillator and Piroddi S1-S6 (training and
    validation parts)."""
    from benchmarks.panel import RECORDS
    seen = 0
    for name, make in RECORDS.items():
        rec = make()
        if rec is None:
            continue
        for part in rec:
            assert find_spikes(part) == [], name
            seen += 1
    assert seen >= 18


def _fit(u, y, seed, how):
    from mggp import MGGPRegressor
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return MGGPRegressor(population=100, generations=20, max_height=2, random_state=seed,
                             outliers=how).fit(u, y)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_fit_repairs_the_glitches_and_finds_the_true_terms(seed):
    """With the default the true terms are found and the model validates
    like the clean record's; with outliers='keep' (the control) the glitches
    decide the fit: true terms are missing and the free run is far worse."""
    u, y = bilinear_record()
    uv, yv = bilinear_record(seed=4)
    ys = glitched(y)
    est = _fit(u, ys, seed, "auto")
    assert TRUE <= {str(t) for t in est.terms_}
    assert [(s.start, s.stop) for s in est.outliers_] == [(300, 301), (431, 433)]
    c = est.choices_["outliers"]
    assert c["value"] == [["y", 300, 301], ["y", 431, 433]] and "y[300]" in c["why"]
    assert est.model_.meta["outliers"] == [["y", 300, 301], ["y", 431, 433]]
    clean = _fit(u, y, seed, "auto")
    assert clean.choices_["outliers"]["value"] == []
    val = Data(uv, yv)
    e_auto = est.simulate(val).rmse
    assert e_auto < 1.5 * clean.simulate(val).rmse
    kept = _fit(u, ys, seed, "keep")
    assert "outliers" not in kept.choices_ and kept.outliers_ == ()
    assert not TRUE <= {str(t) for t in kept.terms_}
    assert kept.simulate(val).rmse > 3 * e_auto


@pytest.mark.parametrize("seed", [1, 2])
def test_the_fit_repairs_a_glitched_input(seed):
    """Three glitched input samples: the default repairs them and finds the
    exact structure; with outliers='keep' (the control) it does not."""
    u, y = bilinear_record()
    us = glitched_input(u)
    est = _fit(us, y, seed, "auto")
    assert {str(t) for t in est.terms_} == TRUE
    assert est.choices_["outliers"]["value"] == [["u", 300, 301], ["u", 431, 433]]
    assert "2 isolated glitches of u" in est.choices_["outliers"]["why"]
    kept = _fit(us, y, seed, "keep")
    assert {str(t) for t in kept.terms_} != TRUE


def test_mggp_fit_says_what_it_repaired(tmp_path):
    u, y = bilinear_record()
    path = tmp_path / "glitch.csv"
    np.savetxt(path, np.c_[u, glitched(y)], delimiter=",", header="u,y", comments="")
    out = tmp_path / "m.json"
    p = subprocess.run([sys.executable, "-m", "mggp", "fit", str(path), "--seed", "1",
                        "--population", "60", "--generations", "6", "--max-height", "2",
                        "--out", str(out)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    line = [ln for ln in p.stderr.splitlines() if ln.startswith("auto: outliers:")]
    assert len(line) == 1 and "2 isolated glitches of y" in line[0] and "y[431:433]" in line[0]
    meta = json.loads(out.read_text())["meta"]
    assert meta["outliers"] == [["y", 300, 301], ["y", 431, 433]]
    m = Model.load(str(out))
    assert m.meta["choices"]["outliers"]["figures"]["spikes"][0]["start"] == 300
    p = subprocess.run([sys.executable, "-m", "mggp", "fit", str(path), "--seed", "1",
                        "--population", "60", "--generations", "6", "--max-height", "2",
                        "--outliers", "keep"], capture_output=True, text=True)
    assert p.returncode == 0 and "auto: outliers" not in p.stderr


def test_the_benchmark_finds_its_large_planted_glitches_and_misses_small_ones():
    """benchmarks.outliers on two seeds: glitches two ranges out are all found
    exactly; half a range out (inside the band) none is, and nothing
    outside the glitches is taken."""
    from benchmarks.outliers import planted
    rows = {r.split("|")[1].strip(): [c.strip() for c in r.split("|")[2:7]]
            for r in planted(seeds=2, amplitudes=(0.5, 2.0)).splitlines()[2:]}
    n = rows["2"][0]
    assert rows["2"] == [n, n, "0", "0", "0"] and int(n) >= 20
    assert rows["0.5"][1:] == ["0", "0", n, "0"]


def test_mggp_estimate_repairs_the_glitches_of_the_same_rule(tmp_path):
    """The θ of the true terms on the glitched record: near the truth with
    the repair, biased without it (the control)."""
    u, y = bilinear_record()
    path = tmp_path / "glitch.csv"
    np.savetxt(path, np.c_[u, glitched(y)], delimiter=",", header="u,y", comments="")
    terms = ["y[k-1]", "y[k-2]", "u[k-1]", "y[k-1]*u[k-1]"]
    truth = np.array([0.6, -0.1, 0.8, 0.3])
    theta = {}
    for how in ("auto", "keep"):
        out = tmp_path / f"{how}.json"
        p = subprocess.run([sys.executable, "-m", "mggp", "estimate", str(path), "--terms",
                            *terms, "--outliers", how, "--out", str(out)],
                           capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
        assert ("auto: outliers: 2 isolated glitches" in p.stderr) == (how == "auto")
        m = Model.load(str(out))
        theta[how] = np.asarray(m.theta)
        assert ("outliers" in m.meta) == (how == "auto")
    assert np.max(np.abs(theta["auto"] - truth)) < 0.02
    assert np.max(np.abs(theta["keep"] - truth)) > 0.1


def test_the_diagnosis_repairs_the_glitches_of_both_records_and_says_so():
    """A given model diagnosed on a glitched training record and a validation
    record with one glitch: both repaired, listed in the settings and the
    summary; with outliers='keep' (the control) nothing is repaired and the
    glitch stays in the measured error."""
    from mggp.diagnose import diagnose
    from mggp.diagnose.extend import Budget
    u, y = bilinear_record()
    uv, yv = bilinear_record(seed=4)
    yv_glitched = yv.copy()
    g = 450                                   # in the measuring half of the record
    yv_glitched[g] += 12.0
    model = Model(sorted(TRUE), inputs=["u"], output="y").fit(Data(u, y))
    kw = dict(budget=Budget(population=24, generations=3, shifts=19), seed=0,
              names=("train.csv", "val.csv"))
    dx = diagnose(Data(u, glitched(y)), Data(uv, yv_glitched), model, **kw)
    got = {k: [(d["start"], d["stop"]) for d in v] for k, v in dx.settings["outliers"].items()}
    assert got == {"train.csv": [(300, 301), (431, 433)], "val.csv": [(g, g + 1)]}
    assert "train.csv: y[300]" in dx.summary() and f"val.csv: y[{g}]" in dx.summary()
    first = dx.split.measure[0]
    assert first <= g and np.isclose(dx.measure_data.y[g - first], (yv[g - 1] + yv[g + 1]) / 2)
    kept = diagnose(Data(u, glitched(y)), Data(uv, yv_glitched), model, outliers="keep", **kw)
    assert kept.settings["outliers"] == "keep" and "glitches" not in kept.summary()
    assert kept.baseline.rmse > 3 * dx.baseline.rmse


@pytest.mark.parametrize("cmd", [["fit"], ["estimate", "--terms", "y[k-1]"]])
def test_a_bad_outliers_value_is_one_error_line(tmp_path, cmd):
    """fit and estimate take --outliers from the one row of mggp.fit.params:
    a value not in it gets one error line naming the choices, exit code 2."""
    u, y = bilinear_record()
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.c_[u, y], delimiter=",", header="u,y", comments="")
    p = subprocess.run([sys.executable, "-m", "mggp", cmd[0], str(path), *cmd[1:],
                        "--outliers", "drop"], capture_output=True, text=True)
    assert p.returncode == 2 and p.stdout == ""
    assert p.stderr.strip() == (f"error: {cmd[0]}: argument --outliers: invalid choice: "
                                f"'drop' (choose from 'auto', 'keep')")
