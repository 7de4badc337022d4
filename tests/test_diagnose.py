"""mggp diagnose: hidden effects are named and fixed, controls stay silent, CLI contract.

Each hidden-effect test generates data with one effect the baseline cannot
express, requires the diagnosis to name it (the candidate of its class won
the paired held-out test) and the extension to beat the baseline on the
validation record. Controls (polynomial NARX, Hammerstein, both with noise)
must not be named hysteresis (a weak baseline may be extended by more lags
or degree, and then the extension must help). Budgets are small and records
short so the default run stays fast; more seeds run with ``-m slow``.
"""
import hashlib
import json

import numpy as np
import pytest

import narx
from narx.records.data import Data
from narx.systems import (held_sine, piezo_bouc_wen, prandtl_ishlinskii, sine_input,
                          training_input)
from narx.systems.testsystems import hammerstein, polynomial_narx

from mggp.cli.app import main
from mggp.diagnose import EXTENSIONS, VOCABULARY, Budget, diagnose
from mggp.diagnose.extend import Setting, plan_extension
from mggp.diagnose.holds import find_holds, probe_holds, steady_rate
from mggp.diagnose.report import write_report

SMALL = Budget(population=60, generations=10)
CONTROL = Budget(population=60, generations=10, max_height=3)
P1, P2 = "Phi1(u[k-1],u[k-2])", "Phi2(u[k-1],u[k-2])"
PEM32 = ("u[k-1]*u[k-4]*y[k-1]", "u[k-2]*u[k-4]", "u[k-3]*y[k-1]",
         "u[k-1]*y[k-1]*Phi2(u[k-4],u[k-6])", "u[k-1]*y[k-1]", "y[k-1]", "y[k-3]",
         "Phi2(u[k-1],u[k-8])", "Phi2(u[k-1],u[k-3])", "Phi2(u[k-1],u[k-2])",
         "Phi2(u[k-5],u[k-1])", "Phi2(u[k-5],u[k-2])", "y[k-2]", "u[k-1]", "u[k-4]")


def hysteretic(system, seed=0):
    u = training_input(3000, bandwidth=4.0, seed=seed)
    _, uv = sine_input(duration=1.0, freq=2.0, amplitude=60)
    return Data(u, system(u)), Data(uv, system(uv))


def assert_named_and_fixed(dx, effect):
    assert effect in dx.effects, dx.verdict.lines()
    f = next(f for f in dx.findings if f.effect == effect)
    assert f.statistic <= f.threshold and f.evidence          # p-value <= level
    assert dx.gain.recommended == "extended"
    assert dx.gain.extended < dx.gain.baseline
    assert dx.gain.ratio > 1


# ------------------------------------------------------------ hidden effects
def test_hysteresis_is_named_and_phi_extension_beats_baseline():
    train, val = hysteretic(piezo_bouc_wen)
    before = (train.U.copy(), train.y.copy())
    dx = diagnose(train, val, budget=SMALL, seed=0)
    assert_named_and_fixed(dx, "hysteresis")
    assert dx.verdict.winner.effect == "hysteresis"
    assert dx.verdict.p_values["hysteresis"] <= dx.verdict.level
    hyst = ("Phi", "Play(", "DengTan(", "BoucWen(")
    assert any(h in t for t in dx.extended.model.term_texts for h in hyst)
    assert not any(h in t for t in dx.baseline.model.term_texts for h in hyst)
    assert "hysteresis" in " ".join(dx.changes)
    np.testing.assert_array_equal(train.U, before[0])     # data never modified
    np.testing.assert_array_equal(train.y, before[1])


def test_a_prandtl_ishlinskii_record_is_named_once_sizes_must_stay_bounded():
    """On this Prandtl–Ishlinskii record (3000 samples, small budget) the
    polynomial with more lags and degree used to tie the memory candidates
    on the selection samples at a size whose free run left the output's
    range on the probe inputs, and hysteresis was not named. A candidate's
    size is now chosen among the bounded ones: the memory candidates beat
    the best memory-free one, hysteresis is named, and the extension gains
    on the validation record."""
    train, val = hysteretic(prandtl_ishlinskii)
    dx = diagnose(train, val, budget=SMALL, seed=0)
    assert dx.effects == ["hysteresis"], dx.verdict.lines()
    assert dx.verdict.p_values["hysteresis"] <= dx.verdict.level
    assert dx.verdict.best_free.structure.name not in dx.verdict.barred
    assert dx.gain.ratio > 1.5

def drifting_case(seed=0):
    """LS on noisy data leaves Σ_y < 1: the model drifts where the piezo holds."""
    rng = np.random.default_rng(seed)
    u = training_input(3000, bandwidth=4.0, seed=seed)
    y = piezo_bouc_wen(u) + 0.3 * rng.standard_normal(u.size)
    hs = held_sine(amplitude=60, freq=2.0, hold=0.5)
    model = narx.Model(["y[k-1]", "u[k-1]", P1, f"y[k-1]*{P1}*{P2}",
                        f"u[k-1]*{P1}*{P2}"]).fit(u, y)
    return Data(u, y), Data(hs.u, piezo_bouc_wen(hs.u)), model, hs


def test_drift_where_the_system_holds_is_fixed_by_memory_and_the_winner_holds():
    """The piezo is hysteretic: a memory candidate fixes the drifting model's
    error, drift included, and is named."""
    train, val, model, hs = drifting_case()
    assert not model.steady_state_constraints().satisfied(model.theta)
    dx = diagnose(train, val, model, budget=SMALL, seed=0)
    assert_named_and_fixed(dx, "hysteresis")
    ext = dx.extended.model
    assert probe_holds(ext, train) < 1e-3 * np.ptp(train.y)     # the extension keeps still
    assert probe_holds(model, train) > 1e-2 * np.ptp(train.y)   # control: the drifting model
    starts = sorted(h.start for h in dx.evidence.holds)
    assert starts == [hs.hold_rising.start, hs.hold_falling.start]


def test_pem_structure_failing_in_free_run_is_fixed_by_memory():
    train, val = hysteretic(piezo_bouc_wen)
    pem = narx.Model(PEM32, meta={"fitness": "pem"}).fit(train)
    assert pem.simulate(train, mode="osa").rmse < 1e-3            # one step: excellent
    dx = diagnose(train, val, pem, budget=SMALL, seed=0)
    assert_named_and_fixed(dx, "hysteresis")


# ------------------------------------------------------------------ controls
CONTROLS = [(polynomial_narx, s) for s in (0, 1)] + [(hammerstein, s) for s in (0, 1)]


@pytest.mark.parametrize("system, seed", CONTROLS,
                         ids=[f"{f.__name__}-{s}" for f, s in CONTROLS])
def test_controls_without_hidden_effect_are_not_named_hysteresis(system, seed):
    s = system(n=2000, seed=seed, noise_std=0.02)
    dx = diagnose(Data(s.u, s.y), budget=CONTROL, seed=seed)
    assert "hysteresis" not in dx.effects, dx.verdict.lines()
    # no memory candidate is the extension either, named or not
    assert dx.verdict.winner is None or dx.verdict.winner.effect != "hysteresis"
    if not dx.effects:
        assert dx.extended.model is dx.baseline.model and dx.gain.ratio == 1.0
        assert dx.to_dict()["extended"]["changes"] == []
    else:           # a weak baseline extended by lags or degree: the extension helps
        assert dx.gain.ratio > 1 and dx.to_dict()["extended"]["changes"]


@pytest.mark.slow
@pytest.mark.parametrize("noise", [0.02, 0.1])
@pytest.mark.parametrize("seed", range(2, 8))
@pytest.mark.parametrize("system", [polynomial_narx, hammerstein])
def test_controls_more_seeds_and_noise(system, seed, noise):
    s = system(n=3000, seed=seed, noise_std=noise)
    dx = diagnose(Data(s.u, s.y), budget=Budget(population=200, generations=40,
                                                max_height=3), seed=seed)
    assert "hysteresis" not in dx.effects, dx.verdict.lines()


def test_true_model_of_a_control_gets_no_finding():
    s = polynomial_narx(n=2000, seed=3, noise_std=0.05)
    true = narx.Model(s.terms, s.theta)
    dx = diagnose(Data(s.u, s.y), model=true, budget=SMALL, seed=3)
    assert dx.findings == []


@pytest.mark.slow
@pytest.mark.parametrize("system,seed", [(f, s) for f in (piezo_bouc_wen, prandtl_ishlinskii)
                                         for s in (1, 2, 3)])
def test_hysteresis_more_seeds(system, seed):
    """Hysteresis is named on every seed and the winner beats the baseline
    on the validation sine."""
    train, val = hysteretic(system, seed)
    assert_named_and_fixed(diagnose(train, val, budget=SMALL, seed=seed), "hysteresis")


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_drift_more_seeds(seed):
    train, val, model, _ = drifting_case(seed)
    dx = diagnose(train, val, model, budget=SMALL, seed=seed)
    assert_named_and_fixed(dx, "hysteresis")


def test_find_holds_in_held_sine():
    hs = held_sine()
    d = Data(hs.u, np.zeros(hs.u.size))
    assert find_holds(d, 20) == [(hs.hold_rising.start, hs.hold_rising.stop),
                                 (hs.hold_falling.start, hs.hold_falling.stop)]
    assert find_holds(d, 2000) == []


def test_vocabulary_and_extension_plan():
    assert set(VOCABULARY) == set(EXTENSIONS) >= {
        "hysteresis", "steady-state-drift", "prediction-bias", "unmodelled-nonlinearity",
        "unmodelled-dynamics"}
    base = Setting("ms", 100, False, None, 3, 5, 15)
    b = Budget()
    p = plan_extension(["hysteresis"], base, b)
    assert p.search and p.setting.use_phi and p.direction and p.setting.constraints is None
    p = plan_extension(["steady-state-drift"], base, b)
    assert p.refit_cls and not p.search and p.setting.constraints == "steady-state"
    p = plan_extension(["prediction-bias"], base, b)
    assert p.setting.window == 400 and p.search
    p = plan_extension(["prediction-bias"], Setting("pem", 100, True, None, 3, 5, 15), b)
    assert p.setting.fitness == "ms"
    p = plan_extension(["unmodelled-nonlinearity", "unmodelled-dynamics"], base, b)
    assert p.setting.max_degree == 4 and p.setting.max_height == 6 and p.setting.max_terms == 20
    p = plan_extension(["unmodelled-nonlinearity", "hysteresis"], base, b)
    assert p.setting.max_degree == 3 and any("attributed to hysteresis" in c for c in p.changes)


# ----------------------------------------------------------------------- CLI
def write_csv(path, cols):
    names = list(cols)
    arr = np.column_stack([cols[n] for n in names])
    np.savetxt(path, arr, delimiter=",", header=",".join(names), comments="", fmt="%.17g")
    return str(path)


def digest(path):
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


@pytest.fixture(scope="module")
def drift_files(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("dx")
    train, val, model, _ = drifting_case()
    t = write_csv(tmp / "train.csv", {"t": np.arange(train.n), "u": train.U[0], "y": train.y})
    v = write_csv(tmp / "held.csv", {"u": val.U[0], "y": val.y})
    m = tmp / "model.json"
    model.save(m)
    return tmp, t, v, str(m)


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_json_schema_report_and_untouched_data(capsys, drift_files):
    tmp, t, v, m = drift_files
    hashes = [digest(p) for p in (t, v, m)]
    js, rep = tmp / "dx.json", tmp / "rep"
    code, out, err = run(capsys, "diagnose", t, "--validation", v, "--model", m, "--json",
                         js, "--report", rep, "--population", 30, "--generations", 3,
                         "--quiet")
    assert code == 0, err
    assert "steady-state-drift" in out and "gain:" in out and len(out.splitlines()) < 30
    doc = json.loads(js.read_text())
    assert {"findings", "baseline", "extended", "gain", "samples", "tests", "settings",
            "verdict"} <= set(doc)
    for f in doc["findings"]:
        assert set(f) == {"effect", "evidence", "statistic", "threshold"}
        assert f["effect"] in VOCABULARY and f["statistic"] <= f["threshold"]  # p <= level
    vd = doc["verdict"]
    assert vd["level"] == 0.05 and set(vd["p_values"]) >= {"hysteresis", "unmodelled-dynamics"}
    for f in doc["findings"]:            # named: its class's p-value is at most the level
        assert vd["p_values"][f["effect"]] <= vd["level"]
    for c in vd["candidates"]:
        assert {"effect", "changes", "terms", "selection_rmse", "p_value"} <= set(c)
    assert set(doc["baseline"]) == {"terms", "theta", "validation"}
    assert set(doc["extended"]) == {"terms", "theta", "validation", "changes"}
    for k in ("baseline", "extended"):
        assert set(doc[k]["validation"]) == {"rmse", "mape"}
        assert len(doc[k]["terms"]) == len(doc[k]["theta"])
    g = doc["gain"]
    assert g["metric"] == "rmse" and g["ratio"] == pytest.approx(g["baseline"] / g["extended"])
    assert g["ratio"] > 1
    assert doc["samples"]["fit"] == {"record": "train.csv", "first": 0, "last": 2099}
    assert doc["samples"]["select"]["first"] == 2100 and doc["samples"]["select"]["last"] == 2999
    assert doc["samples"]["measure"]["record"] == "held.csv"
    text = (rep / "summary.md").read_text()
    assert "fitted on samples 0-2099 of train.csv" in text and "held.csv" in text
    assert "selected by free run on samples 2100-2999 of train.csv" in text
    for png in ("models.png", "residual_direction.png", "holds.png"):
        assert (rep / png).stat().st_size > 1000
    assert [digest(p) for p in (t, v, m)] == hashes


def test_cli_tail_holdout_without_validation(capsys, tmp_path):
    s = polynomial_narx(n=1500, seed=0, noise_std=0.02)
    t = write_csv(tmp_path / "c.csv", {"u": s.u, "y": s.y})
    js = tmp_path / "dx.json"
    code, out, err = run(capsys, "diagnose", t, "--json", js, "--population", 40,
                         "--generations", 6, "--max-height", 3, "--holdout", 0.25, "--quiet")
    assert code == 0, err
    doc = json.loads(js.read_text())
    # 1125 samples before the tail: 788 fit, 337 select, 375 measure
    assert doc["samples"]["fit"] == {"record": "c.csv", "first": 0, "last": 787}
    assert doc["samples"]["select"]["first"] == 788
    assert doc["samples"]["measure"]["first"] == 1125
    assert doc["samples"]["measure"]["last"] == 1499
    assert "hysteresis" not in [f["effect"] for f in doc["findings"]]


def one_error_line(err):
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0]


@pytest.mark.parametrize("extra, needle", [
    (["--holdout", "1.5"], "--holdout must be a fraction between 0 and 1, got 1.5"),
    (["--jobs", "0"], "--jobs must be >= 1 or -1, got 0"),
    (["--population", "0"], "--population must be >= 2, got 0"),
    (["--alpha", "0.7"], "--alpha must be between 0 and 0.5, got 0.7"),
    (["--input", "x"], "no column 'x'"),
    (["--validation", "missing.csv"], "missing.csv: cannot read file"),
])
def test_cli_bad_input(capsys, drift_files, extra, needle):
    tmp, t, v, m = drift_files
    code, out, err = run(capsys, "diagnose", t, *extra, "--quiet")
    assert code == 2
    assert needle in one_error_line(err)


def test_cli_bad_files(capsys, tmp_path, drift_files):
    _, t, v, m = drift_files
    other = write_csv(tmp_path / "o.csv", {"x": np.arange(50.0), "y": np.zeros(50)})
    code, _, err = run(capsys, "diagnose", t, "--validation", other)
    line = one_error_line(err)
    assert code == 2 and "o.csv" in line and "no column 'u' (columns: x, y; fields separated by ',')" in line
    const = write_csv(tmp_path / "k.csv", {"u": np.ones(300), "y": np.arange(300.0)})
    code, _, err = run(capsys, "diagnose", const)
    assert code == 2 and "input 'u' is constant" in one_error_line(err)
    short = write_csv(tmp_path / "s.csv", {"u": np.arange(60.0), "y": np.arange(60.0)})
    code, _, err = run(capsys, "diagnose", short)
    assert code == 2 and "too few to split" in one_error_line(err)
    code, _, err = run(capsys, "diagnose", t, "--json", str(tmp_path))
    assert code == 2 and "is a folder, not a file" in one_error_line(err)
    two = tmp_path / "two.json"
    two.write_text(json.dumps({"output": "y", "inputs": ["u", "v"], "terms": ["y[k-1]"],
                               "theta": [0.5]}))
    code, _, err = run(capsys, "diagnose", t, "--model", two)
    assert code == 2 and "no column 'v'" in one_error_line(err)


def test_report_without_holds_says_so(tmp_path):
    s = polynomial_narx(n=1200, seed=1, noise_std=0.02)
    dx = diagnose(Data(s.u, s.y), budget=CONTROL, seed=1)
    path = write_report(tmp_path / "r", dx)
    text = open(path).read()
    assert "no held-input segment" in text and "## Vocabulary" in text


@pytest.mark.slow
def test_published_piezo_models_small_budget():
    from benchmarks.diagnose_piezo import run as run_piezo
    rows = {r["case"]: r for r in run_piezo(population=60, generations=10, jobs=2)}
    pem, ms = rows["PEM (32), LS"], rows["MS (33), LS"]
    assert "hysteresis" in pem["findings"]
    assert pem["gain"]["ratio"] > 1 and ms["gain"]["ratio"] > 1


def _aug_record(f, seed, n=2000, sig=0.01):
    r = np.random.default_rng(seed)
    u = r.uniform(-1, 1, n)
    x = np.zeros(n)
    for k in range(3, n):
        x[k] = f(x, u, k) + sig * r.standard_normal()
    return Data(u, x)


def _play_record(seed, n=2000, width=0.3):
    g = np.random.default_rng(seed)
    u = np.clip(np.cumsum(g.uniform(-0.1, 0.1, n)), -1, 1)
    z = np.zeros(n)
    for k in range(1, n):                      # play (backlash) operator
        z[k] = min(max(z[k - 1], u[k] - width), u[k] + width)
    x = np.zeros(n)
    for k in range(1, n):
        x[k] = 0.5 * x[k - 1] + 0.5 * z[k - 1]
    return Data(u, x + 0.002 * g.standard_normal(n))


@pytest.mark.parametrize("name, data, hysteretic", [
    # a model that only misses dynamics, a dead time or a memoryless square:
    # direction terms must not beat placebo ones (they did before the
    # polynomial control terms entered both fits)
    ("second order", lambda: _aug_record(lambda y, u, k: 1.2 * y[k - 1] - 0.5 * y[k - 2]
                                         + 0.3 * u[k - 1], 1), False),
    ("dead time 2", lambda: _aug_record(lambda y, u, k: 0.6 * y[k - 1] + 0.5 * u[k - 2], 1),
     False),
    ("memoryless square", lambda: _aug_record(
        lambda y, u, k: 0.6 * y[k - 1] + 0.5 * u[k - 1] + 0.3 * u[k - 1] ** 2, 1), False),
    ("play operator", lambda: _play_record(1), True),
])
def test_augmentation_names_hysteresis_not_a_misspecified_model(name, data, hysteretic):
    from mggp.diagnose.augmentation import phi_augmentation_test
    d = data()
    m = narx.Model(["y[k-1]", "u[k-1]"]).fit(d)
    a = phi_augmentation_test(m, d, shifts=99, alpha=0.01, seed=0)
    assert (a.statistic > a.null_quantile) == hysteretic, (name, a)


def test_a_drifting_model_of_a_memoryless_system_is_drift_not_hysteresis():
    # the system has no memory (data held at the same input rest at the same
    # level); the model drifts during holds, so it rests apart: that is
    # steady-state drift, and the verdict must not call it hysteresis
    rng = np.random.default_rng(5)

    def steps(n, seed, hold):
        r = np.random.default_rng(seed)
        u = []
        while len(u) < n:
            u += [r.uniform(-1, 1)] * int(r.integers(*hold))
        return np.array(u[:n])

    def record(u):
        y = np.zeros(u.size)
        for k in range(1, u.size):
            y[k] = 0.3 * y[k - 1] + 0.7 * u[k - 1]
        return Data(u, y + 0.005 * rng.standard_normal(u.size))
    slow, fast = steps(3000, 20, (150, 300)), steps(3000, 120, (1, 4))
    train = record(np.where((np.arange(3000) // 500) % 2 == 0, slow, fast))
    val = record(steps(3000, 21, (150, 300)))
    bad = narx.Model(["y[k-1]", "y[k-2]", "u[k-1]", "u[k-2]"],
                     theta=[1.29, -0.297, 0.7, -0.7 * 0.985])
    dx = diagnose(train, val, bad, budget=Budget(population=40, generations=5), seed=0,
                  jobs=1)
    assert "hysteresis" not in dx.effects, dx.verdict.lines()
    assert dx.effects and dx.gain.ratio > 1          # a memory-free candidate fixes it


@pytest.mark.parametrize("name, f", [
    ("second order", lambda y, u, k: 1.2 * y[k - 1] - 0.5 * y[k - 2] + 0.3 * u[k - 1]),
    ("memoryless square", lambda y, u, k: 0.6 * y[k - 1] + 0.5 * u[k - 1]
     + 0.3 * u[k - 1] ** 2),
])
def test_a_missing_memory_free_term_is_fixed_by_a_memory_free_candidate(name, f):
    train, val = _aug_record(f, 1), _aug_record(f, 2)
    linear = narx.Model(["y[k-1]", "u[k-1]"]).fit(train)
    dx = diagnose(train, val, linear, budget=SMALL, seed=0, jobs=1)
    # the verdict: a memory-free candidate wins, not memory
    assert dx.effects and "hysteresis" not in dx.effects, dx.verdict.lines()
    assert dx.gain.ratio > 1.5


# ------------------------------------------------------------ hand back the model
def test_cli_out_writes_the_recommended_model(capsys, drift_files):
    tmp, t, v, m = drift_files
    js, out_model = tmp / "dx_out.json", tmp / "recommended.json"
    code, out, err = run(capsys, "diagnose", t, "--validation", v, "--model", m, "--json", js,
                         "--out", out_model, "--population", 30, "--generations", 3,
                         "--quiet")
    assert code == 0, err
    assert err == ""                                   # --quiet: no progress at all
    doc = json.loads(js.read_text())
    which = doc["gain"]["recommended"]
    loaded = narx.load_model(out_model)
    assert loaded.term_texts == doc[which]["terms"]
    np.testing.assert_allclose(loaded.theta, doc[which]["theta"], rtol=0, atol=0)
    meta = loaded.meta["diagnose"]
    assert meta["recommended"] == which and meta["why"] and meta["gain"] == doc["gain"]
    _, val, _, _ = drifting_case()
    y_doc = narx.Model(doc[which]["terms"], theta=doc[which]["theta"]).simulate(val).y_hat
    np.testing.assert_array_equal(loaded.simulate(val).y_hat, y_doc)


def test_cli_progress_line_of_each_search(capsys, tmp_path):
    s = polynomial_narx(n=800, seed=1, noise_std=0.02)
    t = write_csv(tmp_path / "p.csv", {"u": s.u, "y": s.y})
    code, out, err = run(capsys, "diagnose", t, "--population", 20, "--generations", 4,
                         "--max-height", 2)
    assert code == 0, err
    assert "baseline: MGGP search" in err and "gen    4/4" in err


def test_cli_validation_columns_are_named(capsys, drift_files, tmp_path):
    tmp, t, v, m = drift_files
    train = np.genfromtxt(v, delimiter=",", names=True)
    renamed = write_csv(tmp_path / "renamed.csv", {"volts": train["u"], "um": train["y"]})
    js_a, js_b = tmp_path / "a.json", tmp_path / "b.json"
    common = ["--model", m, "--population", 20, "--generations", 2, "--quiet"]
    code, _, err = run(capsys, "diagnose", t, "--validation", v, "--json", js_a, *common)
    assert code == 0, err
    code, _, err = run(capsys, "diagnose", t, "--validation", renamed, "--validation-input",
                       "volts", "--validation-output", "um", "--json", js_b, *common)
    assert code == 0, err
    a, b = json.loads(js_a.read_text()), json.loads(js_b.read_text())
    assert a["gain"] == b["gain"]
    assert [(f["effect"], f["statistic"]) for f in a["findings"]] == \
        [(f["effect"], f["statistic"]) for f in b["findings"]]
    code, _, err = run(capsys, "diagnose", t, "--validation", renamed, *common)
    assert code == 2 and "no column 'u'" in one_error_line(err)


def test_cli_validation_with_other_inputs_is_one_error(capsys, drift_files, tmp_path):
    tmp, t, v, m = drift_files
    two = write_csv(tmp_path / "two.csv", {"u": np.arange(400.0), "u2": np.arange(400.0),
                                           "y": np.arange(400.0)})
    code, out, err = run(capsys, "diagnose", t, "--validation", two, "--validation-input",
                         "u", "u2", "--quiet")
    assert code == 2
    line = one_error_line(err)
    assert "--validation-input" in line and "1 input(s) ['u']" in line and "u2" in line
    code, out, err = run(capsys, "diagnose", t, "--validation-input", "u", "--quiet")
    assert code == 2 and "--validation VAL.csv, which was not given" in one_error_line(err)


# ------------------------------------------------------------ memory operators
def test_operator_augmentation_on_white_input_tells_a_play_from_a_missing_lag():
    """White input steps across its range every sample, where the Bouc–Wen
    variables (solved exactly over each sample) carry a fading memory of the
    input's path: on a second-order linear record fitted with one output lag
    they would stand in for the missing lag (0.102 -> 0.086 without the
    input-lag controls). With them the drop stays below the threshold;
    control: the same dynamics driven by a play of the input is named."""
    from mggp.diagnose.augmentation import operator_augmentation_test
    from narx.language.memory import play
    r = np.random.default_rng(1)
    n = 2000
    u = r.uniform(-1, 1, n)
    out = {}
    for name, drive in (("linear", u), ("play", play(u, 0.4))):
        x = np.zeros(n)
        for k in range(3, n):
            x[k] = 1.2 * x[k - 1] - 0.5 * x[k - 2] + 0.3 * drive[k - 1] \
                + 0.01 * r.standard_normal()
        d = Data(u, x)
        a = operator_augmentation_test(narx.Model(["y[k-1]", "u[k-1]"]).fit(d), d,
                                       shifts=19, seed=0)
        out[name] = (a.statistic, max(a.null_quantile, 0.005 * np.ptp(d.y)))
    assert out["linear"][0] <= out["linear"][1], out
    assert out["play"][0] > 2 * out["play"][1], out


def test_operator_augmentation_sees_a_play_behind_dynamics_not_a_linear_control():
    from benchmarks.diagnose_panel import behind_dynamics, play
    from mggp.diagnose.augmentation import operator_augmentation_test
    from mggp.diagnose.controls import control_record
    rng = np.random.default_rng(0)
    u = training_input(3000, amplitude=1.0, bandwidth=4.0, seed=0)
    y = behind_dynamics(play(u), 2)
    hyst = Data(u, y + 0.01 * np.std(y) * rng.standard_normal(y.size))
    lin = ["y[k-1]", "y[k-2]", "u[k-1]", "u[k-2]"]
    a = operator_augmentation_test(narx.Model(lin).fit(hyst), hyst, shifts=19, seed=0)
    threshold = max(a.null_quantile, 0.005 * np.ptp(hyst.y))     # as the check applies it
    assert a.statistic > 2 * threshold, (a.statistic, a.null_quantile)
    ctl = control_record("linear", seed=0, n=3000, snr_db=40.0).data
    c = operator_augmentation_test(narx.Model(lin).fit(ctl), ctl, shifts=19, seed=0)
    assert c.statistic < a.statistic / 10
    assert c.statistic <= 0.005 * np.ptp(ctl.y)          # below the resolution floor



def test_operator_augmentation_does_not_take_a_static_saturation_for_memory():
    """On a white input the operators' outputs look like saturating static
    functions of the last input, so an unmodelled 0.4 tanh(3u[k-1]) made
    them lower the simulation error far more than placebo operators of a
    shifted input could (statistic / threshold 22–28 with a linear
    baseline). Shuffled placebos now keep each operator's value at the
    input's own sample (:func:`shuffled_operators`): the static part is
    theirs too, and only memory counts. Control: a play with the same white
    input and dynamics stays far above its threshold."""
    from mggp.diagnose.augmentation import operator_augmentation_test
    from narx.language.memory import play
    r = np.random.default_rng(0)
    n = 3000
    u = r.uniform(-1, 1, n)
    ratio = {}
    for name, drive in (("tanh", 0.5 * u + 0.4 * np.tanh(3 * u)), ("play", play(u, 0.2))):
        y = np.zeros(n)
        for k in range(1, n):
            y[k] = 0.8 * y[k - 1] + drive[k - 1]
        d = Data(u, y + 0.01 * np.std(y) * r.standard_normal(n))
        a = operator_augmentation_test(narx.Model(["y[k-1]", "u[k-1]"]).fit(d), d,
                                       shifts=19, seed=0)
        ratio[name] = a.statistic / max(a.null_quantile, 0.005 * np.ptp(d.y))
    assert ratio["tanh"] < 1.0, ratio
    assert ratio["play"] > 3.0, ratio


def test_shuffled_operators_keep_the_static_part_and_lose_the_path():
    """A play's placebo at sample t is the play's value at the input u[t]
    after a random path: within the play's half-width of u[t] (its static
    part), but not the play's own value (its memory)."""
    from mggp.diagnose.augmentation import shuffled_operators
    from narx.language.memory import play
    r = np.random.default_rng(3)
    u = r.uniform(-1, 1, 500)
    d = Data(u, np.zeros(500))
    out, names = shuffled_operators(d, ["Play(u[k-1],0.3)"], r.permutation(500))
    w = out.input(names["Play(u[k-1],0.3)"])
    assert out.inputs == ("u", names["Play(u[k-1],0.3)"])
    assert np.all(np.abs(w - u) <= 0.3 + 1e-12)
    real = play(u, 0.3)
    assert np.mean(np.isclose(w, real)) < 0.6
    with pytest.raises(ValueError, match="lag 1"):
        shuffled_operators(d, ["Play(u[k-2],0.3)"], r.permutation(500))
    # a record whose signals already use the placebo's name keeps its own
    d2 = Data(np.column_stack([u, u]), np.zeros(500), inputs=("u", "w1"), output="y")
    out2, names2 = shuffled_operators(d2, ["Play(u[k-1],0.3)"], r.permutation(500))
    assert names2["Play(u[k-1],0.3)"] not in ("u", "w1", "y")
    assert np.array_equal(out2.input("w1"), u)

