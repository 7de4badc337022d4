"""Compensation (issue 7): root inversion, fallbacks, data-driven inverse, PI loop, CLI."""
import json

import numpy as np
import pytest

import narx
from narx.analysis.compensate import RootCompensator, compensate
from narx.systems import (bouc_wen_discrete, bouc_wen_discrete_narx, piezo_bouc_wen,
                          sine_input, training_input)
from mggp.compensate import (InverseCompensator, PiezoPlant, identify_inverse,
                             pi_loop)
from mggp.cli.app import main

from conftest import MODEL19_TERMS, MODEL19_THETA


def held_random(n, amplitude, seed):
    """Band-limited input with stretches where it is held (equal-input case)."""
    u = training_input(n, amplitude=amplitude, bandwidth=5.0, seed=seed)
    for a in range(n // 10, n, n // 5):
        u[a:a + n // 20] = u[a]
    return u


# ------------------------------------------------------------ exact inversion
def test_root_compensator_recovers_bouc_wen_input_exactly(abs_registry):
    terms, theta = bouc_wen_discrete_narx()
    model = narx.Model(terms, theta, registry=abs_registry)
    u = held_random(3000, 30.0, seed=3)
    y = bouc_wen_discrete(u)
    assert model.simulate(u, y, mode="osa").rmse < 1e-9        # y is exactly the model
    s = 2
    res = compensate(model, y[s:], u_past=u[:s], y_past=y[:s])
    assert res.delay == 1 and res.lead == 1 and res.fallbacks == 0
    np.testing.assert_allclose(res.m[:-1], u[s:-1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.y_model, y[s:], rtol=0, atol=1e-9)


def test_root_compensator_generic_branches_and_degree():
    """Cubic in the current input, a Phi2 against u[k-3] (not the last input),
    Phi1 of the current input times a past one, held stretches (sign 0)."""
    terms = ["y[k-1]", "u[k-1]", "u[k-1]*u[k-1]*u[k-1]", "Phi2(u[k-1],u[k-3])",
             "Phi1(u[k-1],u[k-2])*u[k-2]", "Phi2(u[k-2],u[k-3])*y[k-1]"]
    model = narx.Model(terms, [0.5, 0.8, 0.001, 0.1, 0.01, 0.02])
    u = held_random(3000, 10.0, seed=5)
    y = model.simulate(u, None, mode="freerun", y0=np.zeros(3)).y_hat
    s = 3
    res = compensate(model, y[s:], u_past=u[:s], y_past=y[:s])
    assert not res.fallback[:-1].any()      # the last target (held r) may be out of reach
    np.testing.assert_allclose(res.m[:-1], u[s:-1], rtol=0, atol=1e-9)
    held = np.flatnonzero(np.diff(u[s:-1]) == 0)
    assert held.size > 100 and np.all(np.diff(res.m[:-1])[held] == 0)


def test_lead_and_delay_two():
    model = narx.Model(["y[k-1]", "Phi1(u[k-2],u[k-3])"], [1.0, 2.0])
    u = np.sin(np.linspace(0, 6, 400))
    y = model.simulate(u, None, mode="freerun", y0=np.zeros(3)).y_hat
    res = compensate(model, y[3:], u_past=u[:3], y_past=y[:3])
    assert res.delay == 2 and res.lead == 2
    np.testing.assert_allclose(res.m[:-2], u[3:-2], atol=1e-12)
    late = compensate(model, y[3:], lead=0, u_past=u[:3], y_past=y[:3])
    np.testing.assert_allclose(late.y_model[2:], y[3:-2], atol=1e-12)   # 2 samples late


# ------------------------------------------------------------ fallbacks
def test_no_real_root_is_counted_and_minimised():
    model = narx.Model(["u[k-1]*u[k-1]"], [1.0])
    r = np.array([4.0, 9.0, -1.0, -2.0, -0.5])
    res = compensate(model, r, lead=0, u_past=1.0)
    assert res.fallbacks == 3 and res.saturated == 0
    np.testing.assert_array_equal(res.fallback, r < 0)
    np.testing.assert_allclose(res.m[:2], [2.0, 3.0])   # roots nearest the previous input
    np.testing.assert_array_equal(res.m[2:], 0.0)       # argmin |x^2 - r| is 0
    np.testing.assert_allclose(res.y_model[1:], [4.0, 9.0, 0.0, 0.0])
    assert res.fallback_rate == pytest.approx(0.6)


def test_roots_on_the_wrong_branch_are_not_admissible():
    # a jump of +-1 with the direction of the input: a dead zone |r - y_prev| < 1
    model = narx.Model(["y[k-1]", "Phi1(u[k-1],u[k-2])", "Phi2(u[k-1],u[k-2])"],
                       [1.0, 1.0, 1.0])
    comp = RootCompensator(model, lead=0)
    assert comp.step(3.0) == pytest.approx(2.0) and comp.last_ == (1, False)
    x = comp.step(3.6)                       # would need a rise of 0.6 minus a jump of 1
    assert comp.last_[0] == 0
    assert comp.y[-1] == pytest.approx(3.0 + 1.0)   # closest reachable: just above, +1
    assert x == pytest.approx(2.0) and x > 2.0
    hold = RootCompensator(model, lead=0, fallback="hold")
    hold.step(3.0)
    assert hold.step(3.6) == hold.m[-2] and hold.y[-1] == 3.0
    res = compensate(model, [3.0, 3.4, 3.2, 6.0], lead=0)
    assert res.fallbacks == 2 and list(res.n_roots) == [1, 0, 0, 1]


def test_input_range_saturation_is_counted():
    model = narx.Model(["u[k-1]"], [2.0])
    res = compensate(model, [1.0, 5.0, -1.0], lead=0, input_range=(-1, 1))
    assert res.fallbacks == 1 and res.saturated == 1
    np.testing.assert_allclose(res.m, [0.5, 1.0, -0.5])


def test_max_step_limits_the_input_slew():
    model = narx.Model(["y[k-1]", "Phi1(u[k-1],u[k-2])"], [1.0, 1.0])
    res = compensate(model, [0.0, 5.0, 5.0, 5.0, 5.0], lead=0, max_step=2.0)
    np.testing.assert_allclose(res.m, [0.0, 2.0, 4.0, 5.0, 5.0])
    assert res.fallbacks == 2 and res.saturated == 2


@pytest.mark.parametrize("kw, match", [
    (dict(lead=-1), "lead must be an integer >= 0"),
    (dict(input_range=(80, -80)), "input_range must be None or finite"),
    (dict(fallback="nearest"), "fallback must be one of"),
    (dict(rtol=0.5), "rtol"),
    (dict(max_step=0.0), "max_step must be"),
    (dict(u_past=[1.0, np.nan, 2.0]), "u_past must be"),
])
def test_bad_parameters(kw, match):
    with pytest.raises(ValueError, match=match):
        RootCompensator(narx.Model(list(MODEL19_TERMS), MODEL19_THETA), **kw)


def test_models_that_cannot_be_inverted(abs_registry):
    with pytest.raises(ValueError, match="no input term"):
        RootCompensator(narx.Model(["y[k-1]"], [0.5]))
    with pytest.raises(ValueError, match="exactly one input"):
        RootCompensator(narx.Model(["u[k-1]", "v[k-1]"], [1, 1], inputs=("u", "v")))
    with pytest.raises(ValueError, match="Abs of the current input"):
        RootCompensator(narx.Model(["Abs(u[k-1])"], [1.0], registry=abs_registry))
    with pytest.raises(ValueError, match="no parameters"):
        RootCompensator(narx.Model(["u[k-1]"]))
    with pytest.raises(ValueError, match="r must be"):
        compensate(narx.Model(["u[k-1]"], [1.0]), [1.0, np.inf])


def test_one_step_evaluation_equals_free_run():
    """TermPlan without an unknown (the data-driven compensator's recursion)."""
    model = narx.Model(list(MODEL19_TERMS), MODEL19_THETA)
    _, u = sine_input(duration=1.0)
    ref = model.simulate(u, None, mode="freerun", y0=np.zeros(3)).y_hat
    stepper = InverseCompensator(model, lead=0)
    got = stepper.run(u[3:], u_past=ref[:3], r_past=u[:3]).m
    np.testing.assert_allclose(got, ref[3:], atol=1e-10)


# ------------------------------------------------------------ on the piezo
def test_published_model_compensates_the_piezo_five_times_better():
    model = narx.Model(list(MODEL19_TERMS), MODEL19_THETA)
    u = training_input(20_000)
    g = float(u @ piezo_bouc_wen(u) / (u @ u))          # least-squares static gain
    _, r = sine_input(duration=2.0, amplitude=60.0, freq=2.0)
    base = np.sqrt(np.mean((piezo_bouc_wen(r / g) - r) ** 2))
    res = compensate(model, r, input_range=(-80, 80))
    comp = np.sqrt(np.mean((piezo_bouc_wen(res.m) - r) ** 2))
    assert res.fallbacks == 0
    assert comp * 5 < base


def test_piezo_plant_steps_like_the_batch_simulation():
    u = training_input(2000, seed=2)
    p = PiezoPlant()
    np.testing.assert_allclose([p.step(v) for v in u], piezo_bouc_wen(u), atol=1e-10)


def test_pi_loop_around_compensator_beats_pi_alone():
    model = narx.Model(list(MODEL19_TERMS), MODEL19_THETA)
    _, r = sine_input(duration=1.0, amplitude=60.0, freq=2.0)
    alone = pi_loop(PiezoPlant(), r, kp=0.1, ki=0.2, gain=1.03, input_range=(-80, 80))
    comp = RootCompensator(model, input_range=(-80, 80), lead=0)
    both = pi_loop(PiezoPlant(), r, compensator=comp, kp=0.1, ki=0.2, input_range=(-80, 80))
    assert both.rmse * 5 < alone.rmse
    with pytest.raises(ValueError, match="ki must be"):
        pi_loop(PiezoPlant(), r, ki=-1.0)


# ------------------------------------------------------------ data-driven
def test_inverse_compensator_runs_a_hand_built_inverse(tmp_path):
    p1, p2 = "Phi1(r[k-1],r[k-2])", "Phi2(r[k-1],r[k-2])"
    terms = ["u[k-1]", p1, f"u[k-1]*{p1}*{p2}", f"r[k-1]*{p1}*{p2}"]
    u = training_input(10_000)
    y = piezo_bouc_wen(u)
    d = narx.Data(y[1:], u[:-1], inputs=("r",), output="u")
    inv = InverseCompensator(narx.Model(terms, inputs=("r",), output="u").fit(d), lead=1)
    _, r = sine_input(duration=2.0, amplitude=60.0, freq=0.5)
    res = inv.run(r, input_range=(-80, 80))
    rho = np.r_[0.0, 0.0, r[1:], r[-1]]             # at rest before the record
    ref = inv.model.simulate(rho, None, y0=np.zeros(2)).y_hat[2:]
    np.testing.assert_allclose(res.m, np.clip(ref, -80, 80), atol=1e-9)
    assert np.sqrt(np.mean((piezo_bouc_wen(res.m) - r) ** 2)) < 2.0
    inv.save(tmp_path / "inv.json")
    again = InverseCompensator.from_model(narx.load_model(tmp_path / "inv.json"))
    assert again.lead == 1
    with pytest.raises(ValueError, match="not a data-driven compensator"):
        InverseCompensator.from_model(narx.Model(["u[k-1]"], [1.0]))


def test_identify_inverse_small_search():
    u = training_input(3000, seed=1)
    inv = identify_inverse(u, piezo_bouc_wen(u), population=20, generations=2,
                           random_state=0, n_jobs=1, backend="sequential", max_terms=4)
    assert inv.model.inputs == ("r",) and inv.model.output == "u"
    assert inv.estimator_.n_evaluations_ > 0
    # an inverse runs free: its structure is chosen by free-run error unless told
    assert inv.estimator_.select == "freerun" and inv.estimator_.selection_
    chosen = identify_inverse(u, piezo_bouc_wen(u), population=20, generations=2,
                              random_state=0, n_jobs=1, backend="sequential", max_terms=4,
                              select="fitness")
    assert chosen.estimator_.select == "fitness"
    with pytest.raises(ValueError, match="same length"):
        identify_inverse(u, u[:10])


# ------------------------------------------------------------ CLI
def _csv(path, header, rows):
    path.write_text(",".join(header) + "\n" + "".join(
        ",".join(str(v) for v in row) + "\n" for row in rows))
    return str(path)


@pytest.fixture
def files(tmp_path):
    m = tmp_path / "m19.json"
    m.write_text(json.dumps({"output": "y", "inputs": ["u"], "terms": list(MODEL19_TERMS),
                             "theta": list(MODEL19_THETA)}))
    t, r = sine_input(duration=1.0, amplitude=50.0)
    ref = _csv(tmp_path / "ref.csv", ["t", "r"], zip(t, r))
    return str(m), ref, tmp_path


def test_cli_writes_the_input(files, capsys):
    model, ref, tmp = files
    out = tmp / "input.csv"
    code = main(["compensate", model, ref, "--out", str(out), "--input-range", "-80", "80"])
    text, err = capsys.readouterr()
    assert code == 0, err
    assert "fallbacks 0" in text and "input delay d = 1" in text
    data = np.genfromtxt(out, delimiter=",", names=True)
    assert data.dtype.names == ("r", "u", "y_model", "fallback")
    y = piezo_bouc_wen(data["u"])
    assert np.sqrt(np.mean((y - data["r"]) ** 2)) < 1.0


@pytest.mark.parametrize("case, match", [
    ("nocol", "no column 'r'"),
    ("nan", "not finite"),
    ("badmodel", "invalid JSON"),
    ("range", "--input-range must be"),
    ("noinput", "nothing to invert"),
    ("outdir", "is a folder"),
    ("lead", "--lead must be >= 0"),
    ("step", "--max-step must be"),
])
def test_cli_bad_input(files, capsys, case, match):
    model, ref, tmp = files
    args = ["compensate", model, ref, "--out", str(tmp / "o.csv")]
    if case == "nocol":
        args[2] = _csv(tmp / "x.csv", ["t", "y"], [(0, 1), (1, 2)])
    elif case == "nan":
        args[2] = _csv(tmp / "x.csv", ["r"], [(1,), ("nan",)])
    elif case == "badmodel":
        (tmp / "bad.json").write_text("{")
        args[1] = str(tmp / "bad.json")
    elif case == "range":
        args += ["--input-range", "80", "-80"]
    elif case == "noinput":
        (tmp / "y.json").write_text(json.dumps({"output": "y", "inputs": ["u"],
                                                "terms": ["y[k-1]"], "theta": [1.0]}))
        args[1] = str(tmp / "y.json")
    elif case == "outdir":
        args[4] = str(tmp)
    elif case == "lead":
        args += ["--lead", "-1"]
    elif case == "step":
        args += ["--max-step", "0"]
    code = main(args)
    _, err = capsys.readouterr()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: "), err
    assert match in lines[0]
    assert not (tmp / "o.csv").exists()


def test_cli_runs_a_data_driven_compensator(files, capsys):
    model, ref, tmp = files
    inv = InverseCompensator(narx.Model(["u[k-1]", "Phi1(r[k-1],r[k-2])"], [1.0, 0.9],
                                        inputs=("r",), output="u"), lead=1)
    inv.save(tmp / "inv.json")
    code = main(["compensate", str(tmp / "inv.json"), ref, "--out", str(tmp / "o.csv")])
    text, err = capsys.readouterr()
    assert code == 0, err
    assert "data-driven" in text
    data = np.genfromtxt(tmp / "o.csv", delimiter=",", names=True)
    assert np.all(np.isnan(data["y_model"]))


@pytest.mark.slow
def test_benchmark_quick_run(tmp_path):
    from benchmarks.compensation import main as bench
    assert bench(["--quick", "--seeds", "1", "--out", str(tmp_path),
                  "--json", str(tmp_path / "c.json")]) == 0
    doc = json.loads((tmp_path / "c.json").read_text())
    row = doc["rows"]["sine 0.5 Hz"]
    assert row["root, model (19), lead 1 (= d)"]["ratio"] >= 5
    assert (tmp_path / "sine_2_Hz.png").exists() and (tmp_path / "compensation.md").exists()


def test_an_unstable_inverse_is_detected_and_the_cli_writes_nothing(tmp_path, capsys):
    # model (19)'s terms refitted on Prandtl-Ishlinskii data: a stable model
    # whose inverse (solved for u[k-1]) is not; it used to write inf and NaN
    from narx.systems import prandtl_ishlinskii, training_input
    u = training_input(20000, seed=0)
    m = narx.Model(list(MODEL19_TERMS)).fit(u, prandtl_ishlinskii(u),
                                            constraints="steady-state")
    assert not m.simulate(u, prandtl_ishlinskii(u), mode="freerun").diverged
    t = np.arange(3000) * 1e-3
    r = 36 * np.sin(2 * np.pi * 0.5 * t)
    from narx.analysis.compensate import NonMinimumPhaseWarning
    with pytest.warns(NonMinimumPhaseWarning, match="non-minimum-phase"):
        res = compensate(m, r)
    assert res.diverged and 0 <= res.diverged_at < r.size
    assert np.all(np.isnan(res.m[res.diverged_at:]))
    assert np.all(np.isfinite(res.m[:res.diverged_at]))
    # control: the published model (19) inverts this reference stably
    ok = compensate(narx.Model(list(MODEL19_TERMS), theta=list(MODEL19_THETA)), r)
    assert not ok.diverged and np.all(np.isfinite(ok.m))
    mp, ref, out = tmp_path / "pi.json", tmp_path / "r.csv", tmp_path / "o.csv"
    m.save(mp)
    ref.write_text("r\n" + "\n".join(repr(float(v)) for v in r) + "\n")
    out.write_text("KEEP")
    assert main(["compensate", str(mp), str(ref), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    # the reason is named: its linear input part has a zero outside the unit circle
    assert err.count("\n") == 1 and "diverges on" in err and "non-minimum-phase" in err
    assert "identify_inverse" in err and "|z| = " in err
    assert out.read_text() == "KEEP"


def test_data_driven_compensator_counts_clipping_and_refuses_root_options(tmp_path, capsys):
    inv = InverseCompensator(narx.Model(["r[k]", "u[k-1]"], theta=[1.2, 0.1], inputs=("r",),
                                        output="u"), lead=0)
    res = inv.run(np.linspace(-100, 100, 400), input_range=(-80, 80))
    assert res.saturated == int(np.sum(np.abs(res.m) >= 80 - 1e-12)) > 0
    assert inv.run(np.linspace(-10, 10, 400), input_range=(-80, 80)).saturated == 0
    path, ref, out = tmp_path / "inv.json", tmp_path / "r.csv", tmp_path / "o.csv"
    inv.save(path)
    ref.write_text("r\n" + "\n".join(str(v) for v in np.linspace(-1, 1, 50)) + "\n")
    assert main(["compensate", str(path), str(ref), "--out", str(out), "--max-step", "1"]) == 2
    assert "--max-step 1.0 applies to model-based compensators only" in capsys.readouterr().err
    assert not out.exists()


def test_cli_warns_when_most_steps_fall_back(tmp_path, capsys):
    m = tmp_path / "m19.json"
    narx.Model(list(MODEL19_TERMS), theta=list(MODEL19_THETA)).save(m)
    levels = np.random.default_rng(5).uniform(-40, 40, 5)
    steps = np.concatenate([np.zeros(200)] + [np.full(800, v) for v in levels])
    smooth = 40 * np.sin(2 * np.pi * 0.5 * np.arange(3000) * 1e-3)
    for r, warned in ((steps, True), (smooth, False)):
        ref = tmp_path / "r.csv"
        ref.write_text("r\n" + "\n".join(repr(float(v)) for v in r) + "\n")
        assert main(["compensate", str(m), str(ref), "--out", str(tmp_path / "o.csv"),
                     "--input-range", "-80", "80"]) == 0
        err = capsys.readouterr().err
        assert ("warning: " in err and "no admissible root" in err) == warned, err


@pytest.mark.parametrize("u_scale,u_off,y_scale,y_off", [
    (1e3, 0.0, 1e-6, 0.0),          # input in mV, output in metres
    (1.0, 50.0, 1.0, 1000.0),       # offsets on both signals
])
def test_cli_compensates_in_any_units_and_offsets(capsys, tmp_path, u_scale, u_off,
                                                  y_scale, y_off):
    """A model fitted on rescaled or offset data compensates with the CLI's
    defaults: the divergence bound follows the training ranges the model
    records (meta['ranges']) and the state before the record defaults to
    rest on the reference's first value and the middle of the training input
    range (it used to report a divergence at sample 45, or 2)."""
    u = training_input(10_000, seed=1)
    y = piezo_bouc_wen(u)
    m = narx.Model(list(MODEL19_TERMS)).fit(u * u_scale + u_off, y * y_scale + y_off,
                                             constraints="steady-state")
    lo, hi = m.meta["ranges"]["u"]
    assert lo == pytest.approx(u.min() * u_scale + u_off) and hi > lo
    mp = tmp_path / "m.json"
    m.save(mp)
    assert narx.load_model(mp).meta["ranges"] == m.meta["ranges"]
    t = np.arange(3000) * 1e-3
    ref = tmp_path / "r.csv"
    np.savetxt(ref, (30 * np.sin(2 * np.pi * t)) * y_scale + y_off, header="r",
               comments="")
    out = tmp_path / "c.csv"
    assert main(["compensate", str(mp), str(ref), "--out", str(out)]) == 0, \
        capsys.readouterr().err
    assert "fallbacks 0 " in capsys.readouterr().out


# ------------------------------------------ inverse stability (non-minimum-phase)
def test_a_non_minimum_phase_model_is_reported_with_its_zeros():
    """y[k] = 0.5 y[k-1] + u[k-1] - 2 u[k-2]: B(q⁻¹) = q⁻¹ - 2q⁻² has the zero
    z = 2, so the exact inverse u[k-1] = y[k] - 0.5 y[k-1] + 2 u[k-2] doubles
    any error every step; the compensator says so (it used to say nothing)."""
    import warnings
    from narx.analysis.compensate import NonMinimumPhaseWarning, inverse_stability
    nmp = narx.Model(["y[k-1]", "u[k-1]", "u[k-2]"], theta=[0.5, 1.0, -2.0])
    chk = inverse_stability(nmp)
    assert not chk.minimum_phase and not chk.linearised
    assert chk.coefficients == {1: 1.0, 2: -2.0}
    np.testing.assert_allclose(chk.unstable_zeros, [2.0])
    assert "non-minimum-phase" in chk.describe() and "z = 2" in chk.describe()
    with pytest.warns(NonMinimumPhaseWarning, match="z = 2"):
        comp = RootCompensator(nmp)
    assert not comp.inverse_check.minimum_phase
    # Phi1 of input lags is linear: u[k-1] + 3 Phi1(u[k-2],u[k-3]) gives
    # q⁻¹ + 3q⁻² - 3q⁻³, zeros (-3 ± √21)/2; a cubic term makes it "linearised"
    phi = narx.Model(["y[k-1]", "u[k-1]", "Phi1(u[k-2],u[k-3])", "u[k-1]*u[k-1]*y[k-1]"],
                     theta=[0.5, 1.0, 3.0, 0.01])
    chk = inverse_stability(phi)
    assert chk.coefficients == {1: 1.0, 2: 3.0, 3: -3.0} and chk.linearised
    np.testing.assert_allclose(chk.unstable_zeros, [(-3 - 21 ** 0.5) / 2])
    assert "linearised" in chk.describe()
    # controls: minimum-phase (zero 0.5), the published model (19) (zeros on
    # or inside the unit circle: Phi1 gives z = 1) construct without a warning
    for ok in (narx.Model(["y[k-1]", "u[k-1]", "u[k-2]"], theta=[0.5, 1.0, -0.5]),
               narx.Model(list(MODEL19_TERMS), theta=list(MODEL19_THETA))):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            comp = RootCompensator(ok)
        assert comp.inverse_check.minimum_phase and comp.inverse_check.zeros.size
        assert "minimum-phase" in comp.inverse_check.describe()


def test_cli_refuses_when_most_steps_fall_back_unless_allowed(tmp_path, capsys):
    mp, ref, out = tmp_path / "nmp.json", tmp_path / "r.csv", tmp_path / "o.csv"
    narx.Model(["y[k-1]", "u[k-1]", "u[k-2]"], theta=[0.5, 1.0, -2.0]).save(mp)
    r = np.sin(2 * np.pi * np.arange(1000) / 250)
    ref.write_text("r\n" + "\n".join(repr(float(v)) for v in r) + "\n")
    out.write_text("KEEP")
    args = ["compensate", str(mp), str(ref), "--out", str(out), "--input-range", "-5", "5"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: "), err
    assert "non-minimum-phase" in err and "z = 2" in err and "identify_inverse" in err
    assert "--allow-fallbacks" in err and "reference jumps" not in err
    assert out.read_text() == "KEEP"
    assert main(args + ["--allow-fallbacks"]) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("warning: "), err
    assert "non-minimum-phase" in err and "z = 2" in err and "reference jumps" not in err
    assert np.genfromtxt(out, delimiter=",", names=True)["fallback"].mean() > 0.5


def test_an_input_lag_entering_only_through_a_sign_is_named():
    """u[k-1] enters only through Phi2 (a sign): it cannot be inverted, and
    the message says so (it used to say no term depends on u[k-1])."""
    m = narx.Model(["y[k-1]", "Phi2(u[k-3],u[k-1])", "Phi1(u[k-4],u[k-2])", "u[k-5]"],
                   theta=[0.5, -0.003, 1.0, 0.2])
    with pytest.raises(ValueError) as exc:
        RootCompensator(m)
    msg = str(exc.value)
    assert "u[k-1]" in msg and "only through a sign" in msg and "Phi2(u[k-3],u[k-1])" in msg
    assert "first input lag that enters polynomially is u[k-2]" in msg
    assert "no term" not in msg
    only = narx.Model(["y[k-1]", "Phi2(u[k-2],u[k-1])"], theta=[0.5, 1.0])
    with pytest.raises(ValueError, match="no input lag enters polynomially"):
        RootCompensator(only)
    # a term with θ = 0 does not act: the delay is that of the terms that do
    zero = narx.Model(["y[k-1]", "u[k-1]", "u[k-2]"], theta=[0.5, 0.0, 1.0])
    assert RootCompensator(zero).delay == 2


def test_cli_fallback_verdict_blames_the_reference_only_for_a_minimum_phase_model():
    import warnings
    from mggp.cli.app import CLIError
    from mggp.cli.compensate import _fallback_verdict
    nmp = "the model is non-minimum-phase: ... z = 2 (|z| = 2) ..."
    for rate, text, expect in ((0.0, "", None), (0.0, nmp, "z = 2"),
                               (0.1, nmp, "z = 2"), (0.1, "", "the reference jumps"),
                               (0.9, nmp, "z = 2")):
        with warnings.catch_warnings(record=True) as got:
            warnings.simplefilter("always")
            _fallback_verdict(rate, text, allow=True)
        assert len(got) == (expect is not None)
        if got:
            msg = str(got[0].message)
            assert expect in msg and ("reference jumps" in msg) == (not text)
    with pytest.raises(CLIError, match="--allow-fallbacks"):
        _fallback_verdict(0.51, "", allow=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _fallback_verdict(0.5, "", allow=False)             # half: still written


def test_inverse_check_refuses_several_inputs():
    from narx.analysis.inverse_check import inverse_stability
    m = narx.Model(["y[k-1]", "u1[k-1]", "u2[k-2]"], [0.5, 0.3, 1.0], inputs=["u1", "u2"])
    with pytest.raises(ValueError, match="one-input models, got inputs"):
        inverse_stability(m)


def test_rest_actuator_solves_the_rest_state():
    from narx.analysis.compensate_args import rest_actuator
    gain1 = narx.Model(["y[k-1]", "u[k-1]", "u[k-2]"], [0.5, 0.3, 0.2])      # y_ss = u
    assert rest_actuator(gain1, 2.0, "u", -5, 5) == pytest.approx(2.0)
    assert rest_actuator(gain1, 20.0, "u", -5, 5) is None                  # out of range
    hyst = narx.Model(["y[k-1]", "Phi1(u[k-1],u[k-2])"], [1.0, 0.5])        # a continuum
    assert rest_actuator(hyst, 2.0, "u", -5, 5) is None
    inv = narx.Model(["r[k-1]", "u[k-1]"], [0.5, 0.5], inputs=("r",), output="u")  # m_ss = r
    assert rest_actuator(inv, 1.5, "u", -5, 5) == pytest.approx(1.5)


@pytest.mark.parametrize("inverse", [False, True])
def test_cli_default_rest_input_is_the_models_rest_state(tmp_path, capsys, inverse):
    """Without --u-past the compensator starts at rest: the input at which the
    model rests on the reference's first value (here 2, in a training input
    range 0..10 whose middle, 5, the old default took; a data-driven
    compensator took the middle of the reference's range instead)."""
    if inverse:
        m = narx.Model(["r[k-1]", "u[k-1]"], [0.5, 0.5], inputs=("r",), output="u")
        m.meta["ranges"] = {"r": [50.0, 60.0], "u": [0.0, 10.0]}
        path = tmp_path / "inv.json"
        InverseCompensator(m, lead=1).save(path)
    else:
        m = narx.Model(["y[k-1]", "u[k-1]", "u[k-2]"], [0.5, 0.3, 0.2])
        m.meta["ranges"] = {"u": [0.0, 10.0], "y": [0.0, 10.0]}
        path = tmp_path / "m.json"
        m.save(path)
    ref = tmp_path / "ref.csv"
    ref.write_text("r\n" + "\n".join(["2.0"] * 20) + "\n")
    out = tmp_path / "o.csv"
    assert main(["compensate", str(path), str(ref), "--out", str(out)]) == 0, \
        capsys.readouterr().err
    data = np.genfromtxt(out, delimiter=",", names=True)
    assert np.allclose(data["u"], 2.0, atol=1e-9)          # held at rest from the start


@pytest.mark.parametrize("terms, theta, fallbacks", [
    (["u[k]"], [0.5], False),
    (["u[k]", "1"], [0.5, 1.0], False),
    (["u[k]*u[k]"], [0.5], True),          # no root for a negative reference
])
def test_cli_inverts_a_static_model(tmp_path, capsys, terms, theta, fallbacks):
    """A model without past terms (largest lag 0) has a well-defined static
    inverse: u = (r - c) / θ for y = θ u + c, a square root for θ u²."""
    m = tmp_path / "static.json"
    m.write_text(json.dumps({"output": "y", "inputs": ["u"], "terms": terms, "theta": theta}))
    t, r = sine_input(duration=1.0, amplitude=5.0)
    ref = _csv(tmp_path / "ref.csv", ["t", "r"], zip(t, r))
    out = tmp_path / "in.csv"
    code = main(["compensate", str(m), ref, "--out", str(out), "--allow-fallbacks"])
    _, err = capsys.readouterr()
    assert code == 0, err
    data = np.genfromtxt(out, delimiter=",", names=True)
    ok = data["fallback"] == 0
    assert ok.any() and (not ok.all()) == fallbacks
    model = narx.load_model(m)
    y = model.simulate(data["u"], data["u"], mode="osa").y_hat
    np.testing.assert_allclose(y[ok], data["r"][ok], atol=1e-9)
