"""Quasi-static analysis (narx.quasistatic, `mggp quasistatic`) on known models.

Model (19) against eqs. (20)-(21) computed here independently, model (16)
and its asymmetric variant (regressor (18)) against the bounding structure
of eq. (17), linear models of one and two output lags against their static
gain and characteristic roots, and a polynomial and a non-polynomial model
whose fixed points are known in closed form.
"""
import json
import time

import numpy as np
import pytest

import narx
from mggp.cli.app import main

from conftest import MODEL19_TERMS, MODEL19_THETA


def sine(amplitude, freq, ts, periods):
    t = np.arange(int(round(periods / (freq * ts)))) * ts
    return amplitude * np.sin(2 * np.pi * freq * t)


def model19():
    return narx.Model(MODEL19_TERMS, MODEL19_THETA)


def eq20(u, th):
    """a_k, b_k of eq. (20) for model (19), k = 3 .. N-1, written from the
    DESIGN table (θ1 .. θ9 in its order)."""
    k = np.arange(3, u.size)
    p1 = u[k - 2] - u[k - 3]                    # Phi1(u[k-2],u[k-3])
    p2 = np.sign(p1)                            # Phi2(u[k-2],u[k-3])
    q1 = u[k - 1] - u[k - 2]                    # Phi1(u[k-1],u[k-2])
    v = u[k - 2]
    a = th[0] + th[3] * p2 * p1 + th[5] * p1 * v + th[6] * p2
    b = th[1] * p1 + th[2] * p2 * p1 * v + th[4] * p1 * v * v + th[7] * q1 \
        + th[8] * p2 * p1 * p1
    return k, a, b


# ------------------------------------------------------------------ model (19)
def test_model19_roots_are_eq20_and_class_is_eq21():
    u = sine(70.0, 1.0, 1e-3, 2)
    qs = narx.quasistatic(model19(), u)
    k, a, b = eq20(u, MODEL19_THETA)
    assert qs.method == "polynomial" and qs.lags == (1,)
    assert np.all(qs.solution[:3] == "initial")
    assert np.all(qs.solution[k] == "isolated")
    assert np.all(np.isnan(qs.roots[k, 1:]))               # one root per sample
    np.testing.assert_allclose(qs.roots[k, 0], b / (1 - a), rtol=1e-9, atol=0)
    att = (-1 < a) & (a < 1)
    np.testing.assert_array_equal(qs.attracting[k, 0], att)
    assert 0 < att.mean() < 1                              # both classes occur
    np.testing.assert_allclose(qs.points.radius[k, 0], np.abs(a), rtol=1e-12)
    # the free run is the model's own simulation
    ref = model19().simulate(u, mode="freerun", y0=[0, 0, 0]).y_hat
    np.testing.assert_array_equal(qs.y, ref)
    assert set(qs.branch[1:]) == {"loading", "unloading"}


def eq20_exact(u, th):
    """ỹ = b_k / (1 − a_k) of eq. (20) in exact rational arithmetic from the
    factor values the model sees (Phi1 of the input: the float difference),
    rounded once; NaN where a_k = 1."""
    from fractions import Fraction as F
    th = [F(t) for t in th]
    out = []
    for k in range(3, u.size):
        p1 = F(float(u[k - 2] - u[k - 3]))
        p2 = (p1 > 0) - (p1 < 0)
        q1, v = F(float(u[k - 1] - u[k - 2])), F(float(u[k - 2]))
        a = th[0] + th[3] * p2 * p1 + th[5] * p1 * v + th[6] * p2
        b = th[1] * p1 + th[2] * p2 * p1 * v + th[4] * p1 * v * v + th[7] * q1 \
            + th[8] * p2 * p1 * p1
        out.append(float(b / (1 - a)) if a != 1 else np.nan)
    return np.arange(3, u.size), np.array(out)


def test_model19_roots_to_full_precision_and_the_polish_does_it():
    """At θ1 = 1 the coefficient 1 − a_k of eq. (20) is θ4 Φ2 Φ1 + θ6 Φ1 u +
    θ7 Φ2, down to 2e-6 here: summed in float with the y[k-1] term it keeps
    few digits. The polished roots agree with eq. (20) computed exactly to
    1e-12; control: the roots from the eigenvalues (closed form) alone are
    off by more than ten times that."""
    from narx.analysis.quasistatic import _Frozen, _solve_polynomial
    u = sine(70.0, 1.0, 1e-3, 2)
    k, exact = eq20_exact(u, MODEL19_THETA)
    assert np.all(np.isfinite(exact))
    qs = narx.quasistatic(model19(), u)
    rel = np.abs(qs.roots[k, 0] - exact) / np.abs(exact)
    assert rel.max() < 1e-12, rel.max()
    fz = _Frozen(model19(), narx.Data(u), k).finish()
    raw, _ = _solve_polynomial(*fz.polynomial(), 1e-9)
    rel_raw = np.abs(raw[:, 0] - exact) / np.abs(exact)
    assert rel_raw.max() > 1e-11, rel_raw.max()


def test_model19_held_input_is_a_continuum_and_an_ls_model_is_not():
    u = np.concatenate([sine(70.0, 1.0, 1e-3, 0.3), np.full(20, 0.0)])
    u[-20:] = u[-21]                                       # hold the last value
    qs = narx.quasistatic(model19(), u)
    held = np.arange(u.size - 17, u.size)                  # u[k-1] = u[k-2] = u[k-3]
    assert np.all(qs.solution[held] == "continuum")
    assert np.all(qs.branch[held] == "rest")
    assert all(p["roots"] == [] for p in qs.to_dict()["points"][-17:])
    assert np.all(qs.bounding.rest.solution == "continuum")
    # control: Σ_y = 0.999 (no continuum): one isolated attracting point, 0
    th = np.array(MODEL19_THETA)
    th[0] = 0.999
    ls = narx.quasistatic(narx.Model(MODEL19_TERMS, th), u)
    assert np.all(ls.solution[held] == "isolated")
    np.testing.assert_allclose(ls.roots[held, 0], 0.0, atol=1e-12)
    assert np.all(ls.attracting[held, 0])


def test_speed_5000_samples():
    m = model19()
    narx.quasistatic(m, sine(70.0, 1.0, 1e-3, 0.1))         # compiled kernels warm
    u = sine(70.0, 1.0, 1e-3, 10)                          # 10,000 samples
    t0 = time.perf_counter()
    qs = narx.quasistatic(m, u)
    assert time.perf_counter() - t0 < 5.0
    assert qs.k.size == 10_000


# ------------------------------------------------------------------ model (16)
def model16(registry=None, phi="Phi2"):
    return narx.Model(["y[k-1]", f"{phi}(u[k-1],u[k-2])"], [0.9, 0.5], registry=registry)


def assert_inside(qs, lo, hi):
    y = qs.y
    assert np.all(np.isfinite(y))
    assert np.all((y >= lo - 1e-9) & (y <= hi + 1e-9)), (y.min(), y.max(), lo, hi)


@pytest.mark.parametrize("omega", [0.5, 1.0, 2.0, 5.0])
def test_model16_bounding_structure_is_eq17_and_holds_every_loop(omega):
    t = np.arange(int(3 * 2 * np.pi / omega / 0.05)) * 0.05
    qs = narx.quasistatic(model16(), np.sin(omega * t))
    b = qs.bounding
    np.testing.assert_allclose(b.loading.roots[:, 0], 5.0, rtol=1e-12)    # +Σ_Φ2/(1-Σ_y)
    np.testing.assert_allclose(b.unloading.roots[:, 0], -5.0, rtol=1e-12)
    assert b.loading.attracting[:, 0].all() and b.unloading.attracting[:, 0].all()
    np.testing.assert_allclose(b.rest.roots[:, 0], 0.0, atol=1e-12)      # Σ_y = 0.9
    assert np.all(b.rest.solution == "isolated")
    assert b.envelope() == (pytest.approx(-5.0, rel=1e-12), pytest.approx(5.0, rel=1e-12))
    assert_inside(qs, -5.0, 5.0)
    roots = qs.roots[qs.solution == "isolated", 0]
    assert set(np.round(roots, 12)) <= {-5.0, 0.0, 5.0}


def test_model16_slow_loop_reaches_the_bounding_structure():
    """Control: the bound is tight (a slow loop comes near ±5), so the
    inside-check above can fail."""
    t = np.arange(int(3 * 2 * np.pi / 0.1 / 0.05)) * 0.05
    qs = narx.quasistatic(model16(), np.sin(0.1 * t))
    assert qs.y.max() > 4.9 and qs.y.min() < -4.9


def r18(a, b):
    """Regressor (18): a when a > b (rising), -1 when a < b, 0 when equal."""
    return np.where(a > b, a, np.where(a < b, -1.0, 0.0))


def test_asymmetric_model16_with_plugin_regressor18():
    reg = narx.PhiRegistry()
    reg.register("R18", 2, r18, steady=0.0)
    t = np.arange(int(3 * 2 * np.pi / 0.05)) * 0.05
    u = np.sin(t)                                          # ω = 1
    qs = narx.quasistatic(model16(reg, "R18"), u)
    b = qs.bounding
    np.testing.assert_allclose(b.loading.roots[:, 0], 5.0 * b.u, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(b.unloading.roots[:, 0], -5.0, rtol=1e-9)
    np.testing.assert_allclose(b.rest.roots[:, 0], 0.0, atol=1e-12)
    lo, hi = b.envelope()
    assert lo == pytest.approx(-5.0) and hi == pytest.approx(5.0 * u.max(), rel=1e-6)
    assert_inside(qs, lo, hi)
    k = np.flatnonzero((qs.solution == "isolated") & (np.arange(u.size) >= 2))
    rising = u[k - 1] > u[k - 2]
    np.testing.assert_allclose(qs.roots[k[rising], 0], 5.0 * u[k[rising] - 1], rtol=1e-12)
    # control: the symmetric model's bound is not this one
    assert not np.allclose(narx.quasistatic(model16(), u).bounding.loading.roots[:, 0],
                           b.loading.roots[:, 0])


# ------------------------------------------------------------------ linear models
U = np.sin(np.linspace(0.1, 6.0, 300)) + 0.3


def test_stable_first_order_one_attracting_point_at_static_gain():
    qs = narx.quasistatic(narx.Model(["y[k-1]", "u[k-1]"], [0.5, 2.0]), U)
    k = np.arange(1, U.size)
    np.testing.assert_allclose(qs.roots[k, 0], 4.0 * U[k - 1], rtol=1e-12)
    assert qs.roots.shape[1] == 1 and qs.attracting[k, 0].all()


def test_unstable_first_order_one_repelling_point():
    qs = narx.quasistatic(narx.Model(["y[k-1]", "u[k-1]"], [1.5, 1.0]), U)
    k = np.arange(1, U.size)
    np.testing.assert_allclose(qs.roots[k, 0], -2.0 * U[k - 1], rtol=1e-12)
    assert qs.roots.shape[1] == 1 and not qs.attracting[k, 0].any()
    assert qs.counts()["loading"]["repelling_only"] == qs.counts()["loading"]["samples"]


@pytest.mark.parametrize("a1,a2,stable", [(1.2, -0.5, True), (0.5, 0.6, False)])
def test_two_lags_classified_by_the_characteristic_polynomial(a1, a2, stable):
    """|∂ŷ_k/∂ŷ_{k-1}| = 1.2 > 1, yet z² − 1.2 z + 0.5 has |z| = √0.5:
    attracting; z² − 0.5 z − 0.6 has a root 1.06: repelling."""
    qs = narx.quasistatic(narx.Model(["y[k-1]", "y[k-2]", "u[k-1]"], [a1, a2, 1.0]), U)
    k = np.arange(2, U.size)
    np.testing.assert_allclose(qs.roots[k, 0], U[k - 1] / (1 - a1 - a2), rtol=1e-12)
    assert np.all(qs.attracting[k, 0] == stable)
    z = np.roots([1.0, -a1, -a2])
    np.testing.assert_allclose(qs.points.radius[k, 0], np.max(np.abs(z)), rtol=1e-9)


# ------------------------------------------------------------------ other forms
def test_quadratic_model_two_roots_one_attracting():
    u = np.linspace(-1.0, 0.45, 200)
    u = np.concatenate([u, [0.6, 0.7]])                    # 1 - 2u < 0: no real root
    qs = narx.quasistatic(narx.Model(["y[k-1]*y[k-1]", "u[k-1]"], [0.5, 1.0]), u)
    k = np.arange(1, 200)
    s = np.sqrt(1 - 2 * u[k - 1])
    np.testing.assert_allclose(qs.roots[k, 0], 1 - s, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(qs.roots[k, 1], 1 + s, rtol=1e-9)
    assert qs.attracting[k, 0].all() and not qs.attracting[k, 1].any()
    assert np.all(qs.solution[201:] == "none")


def test_plugin_of_outputs_numerical_method(abs_registry):
    m = narx.Model(["Abs(y[k-1])", "u[k-1]"], [0.5, 1.0], registry=abs_registry)
    u = np.linspace(-1.0, 1.0, 101) + 0.003                # never exactly 0
    qs = narx.quasistatic(m, u)
    assert qs.method == "numerical"
    k = np.arange(1, u.size)
    v = u[k - 1]
    np.testing.assert_allclose(qs.roots[k, 0], np.where(v > 0, 2 * v, v / 1.5), rtol=1e-9)
    assert np.all(np.isnan(qs.roots[k, 1:])) and qs.attracting[k, 0].all()
    np.testing.assert_allclose(qs.points.radius[k, 0], 0.5, rtol=1e-6)


def test_mixed_phi2_jump_is_not_a_root():
    """ỹ = 0.5 + Phi2(y[k-1],u[k-1]) has G(ỹ) = 0.5 + sign(ỹ − u) − ỹ:
    roots 1.5 (if 1.5 > u) and -0.5 (if -0.5 < u); the
    jump at ỹ = u is not a root."""
    m = narx.Model(["1", "Phi2(y[k-1],u[k-1])"], [0.5, 1.0])
    u = np.array([0.0, 0.2, 1.0, 2.0, -1.0, 0.7])
    qs = narx.quasistatic(m, u)
    exp = {0.0: [-0.5, 1.5], 0.2: [-0.5, 1.5], 1.0: [-0.5, 1.5], 2.0: [-0.5], -1.0: [1.5],
           0.7: [-0.5, 1.5]}
    for k in range(1, u.size):
        r, _ = qs.points.at(k)
        np.testing.assert_allclose(r, exp[u[k - 1]], rtol=1e-9, err_msg=f"k={k}")


def test_two_inputs_phi_of_outputs_and_noise_terms():
    """Phi1/Phi2 of output lags are 0 at ỹ (their steady value) but enter the
    linearisation; a noise term is 0; the other input's lag keeps its value."""
    U = np.column_stack([np.sin(np.linspace(0, 12, 400)), np.cos(np.linspace(0, 5, 400))])
    m = narx.Model(["y[k-1]", "u1[k-1]", "u2[k-1]", "Phi2(u1[k-1],u1[k-2])", "1",
                    "y[k-1]*e[k-1]", "Phi1(y[k-1],y[k-2])*u1[k-1]", "Phi2(y[k-1],y[k-2])"],
                   [0.5, 1, 0.3, 0.2, 0.1, 0.4, 0.7, 0.3], inputs=["u1", "u2"])
    qs = narx.quasistatic(m, U)
    assert qs.method == "polynomial" and qs.lags == (1, 2)
    k = np.arange(2, 400)
    v = U[k - 1, 0]
    ref = (v + 0.3 * U[k - 1, 1] + 0.2 * np.sign(v - U[k - 2, 0]) + 0.1) / 0.5
    np.testing.assert_allclose(qs.roots[k, 0], ref, rtol=1e-12)
    d1, d2 = 0.5 + 0.7 * v, -0.7 * v                      # ∂/∂y[k-1], ∂/∂y[k-2]
    rad = np.array([np.max(np.abs(np.roots([1, -a, -b]))) for a, b in zip(d1, d2)])
    np.testing.assert_allclose(qs.points.radius[k, 0], rad, rtol=1e-9)


def test_numerical_default_range_finds_a_far_repelling_root():
    """ỹ = 0.5 ỹ + u² − 0.1 Sq(ỹ) with a callable steady value: roots
    (−0.5 ± √(0.25 + 0.4 u²)) / 0.2, the lower one (≈ −6.5) far outside the
    free run's range, repelling (slope 0.5 − 0.2 ỹ > 1)."""
    reg = narx.PhiRegistry()
    reg.register("Sq", 1, np.square, steady=np.square)
    u = np.sin(np.linspace(0, 6, 200))
    qs = narx.quasistatic(narx.Model(["y[k-1]", "Sq(u[k-1])", "Sq(y[k-1])"],
                                     [0.5, 1.0, -0.1], registry=reg), u)
    assert qs.method == "numerical"
    k = np.arange(1, 200)
    w = np.sqrt(0.25 + 0.4 * u[k - 1] ** 2)
    np.testing.assert_allclose(qs.roots[k, 0], (-0.5 - w) / 0.2, rtol=1e-9)
    np.testing.assert_allclose(qs.roots[k, 1], (-0.5 + w) / 0.2, rtol=1e-9, atol=1e-12)
    assert not qs.attracting[k, 0].any() and qs.attracting[k, 1].all()


def test_diverging_free_run_json_and_figure(tmp_path):
    from mggp.report.quasistatic import plot_quasistatic, summary_markdown
    qs = narx.quasistatic(narx.Model(["y[k-1]", "u[k-1]"], [1.5, 1.0]),
                          np.sin(np.linspace(0, 30, 3000)))
    assert qs.diverged
    json.dumps(qs.to_dict(), allow_nan=False)
    assert (tmp_path / "d.png") == plot_quasistatic(tmp_path / "d.png", qs)
    text = summary_markdown(qs)
    assert "diverges" in text and "No sample of the moving input has an attracting" in text


def _F(model, data, k, ylags):
    """ŷ_k of the model evaluated by the regressor code (not the frozen
    polynomial), with output lag j at ``ylags[j]``; inputs from the record."""
    from narx.records.regressors import regressor_matrix
    y = np.zeros(data.n)
    for j, v in ylags.items():
        y[k - j] = v
    Psi, _, start = regressor_matrix(model.terms, data, y=y)
    return float(Psi[k - start] @ model.theta)


def test_ms_model33_roots_and_classes_by_the_regressors(model33_terms):
    """Model (33) (output lags 1..5 and 8, products of two output lags,
    Phi2 with reversed lags) with θ drawn at random: at every checked
    sample each root solves F_k(ỹ) = ỹ evaluated by the regressor code, the
    quadratic through three evaluations has exactly the real roots found, and
    the class follows from the characteristic polynomial of finite
    differences of that code in each lag."""
    rng = np.random.default_rng(3)
    th = rng.normal(0, 1, len(model33_terms)) * np.array(
        [1e-4, .05, 1e-4, 1e-5, 1e-3, 1e-3, .6, .05, .5, 1e-3, 1e-3, 1e-4, 1e-5, 1e-4, .05])
    th[6] = 0.5                                            # y[k-1]
    m = narx.Model(model33_terms, th)
    u = sine(70.0, 1.0, 1e-3, 1)
    qs = narx.quasistatic(m, u)
    data = narx.Data(u)
    lags = (1, 2, 3, 4, 5, 8)
    n_roots, classes = 0, set()
    for k in range(10, u.size, 37):
        g = [_F(m, data, k, {j: x for j in lags}) - x for x in (-1.0, 0.0, 1.0)]
        c2, c1, c0 = (g[0] + g[2]) / 2 - g[1], (g[2] - g[0]) / 2, g[1]
        exp = np.sort(np.roots([c2, c1, c0]).real[np.abs(np.roots([c2, c1, c0]).imag) < 1e-9])
        r, att = qs.points.at(k)
        np.testing.assert_allclose(r, exp, rtol=1e-6, atol=1e-9, err_msg=f"k={k}")
        for x, a in zip(r, att):
            base = {j: x for j in lags}
            h = 1e-6 * max(1.0, abs(x))
            d = np.zeros(8)
            for j in lags:
                hi, lo = dict(base), dict(base)
                hi[j], lo[j] = x + h, x - h
                d[j - 1] = (_F(m, data, k, hi) - _F(m, data, k, lo)) / (2 * h)
            radius = np.max(np.abs(np.roots(np.concatenate([[1.0], -d]))))
            assert abs(radius - 1) < 1e-6 or a == (radius < 1), (k, x, radius)
            n_roots += 1
            classes.add(a)
    assert n_roots > 10 and classes == {True, False}
    assert set(qs.solution[10:]) == {"isolated", "none"}


# ------------------------------------------------------------------ bad input
def test_bad_arguments_raise_named_errors():
    m = model19()
    with pytest.raises(ValueError, match="bounding_step"):
        narx.quasistatic(m, U, bounding_step=-1)
    with pytest.raises(ValueError, match="too short"):
        narx.quasistatic(m, U[:4])
    with pytest.raises(ValueError, match="no parameters"):
        narx.quasistatic(narx.Model(["y[k-1]"]), U)


# ------------------------------------------------------------------ CLI
def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def m19_file(tmp_path):
    p = tmp_path / "m19.json"
    model19().save(str(p))
    return str(p)


def test_cli_json_schema_from_data_rows(capsys, tmp_path, m19_file):
    u = sine(70.0, 1.0, 1e-3, 1.2)
    csv = tmp_path / "d.csv"
    csv.write_text("t,u\n" + "".join(f"{i * 1e-3!r},{float(v)!r}\n" for i, v in enumerate(u)))
    js = tmp_path / "qs.json"
    code, out, err = run(capsys, "quasistatic", m19_file, csv, "--json", js)
    assert code == 0, err
    doc = json.loads(js.read_text())
    pts = doc["points"]
    assert [p["k"] for p in pts] == list(range(u.size))
    for p in pts:
        assert {"k", "u", "branch", "roots", "attracting", "y"} <= set(p)
        assert p["branch"] in ("loading", "unloading", "rest")
        assert len(p["roots"]) == len(p["attracting"])
    assert pts[10]["u"] == u[10]
    k, a, b = eq20(u, MODEL19_THETA)
    assert pts[100]["roots"] == [pytest.approx(b[97] / (1 - a[97]), rel=1e-9)]
    assert pts[0]["roots"] == [] and pts[0]["solution"] == "initial"
    assert set(doc["bounding"]) >= {"u", "loading", "unloading", "rest"}
    assert all(s == "continuum" for s in doc["bounding"]["rest"]["solution"])
    assert "counter-clockwise" in out


def test_cli_sine_and_report(capsys, tmp_path, m19_file):
    rep = tmp_path / "rep"
    js = tmp_path / "qs.json"
    code, out, err = run(capsys, "quasistatic", m19_file, "--sine", 70, 1, "--rate", 1000,
                         "--periods", 1.5, "--json", js, "--report", rep, "--units", "V", "µm")
    assert code == 0, err
    doc = json.loads(js.read_text())
    assert len(doc["points"]) == 1500
    assert doc["points"][250]["u"] == pytest.approx(70.0)
    assert (rep / "quasistatic.png").stat().st_size > 10_000
    md = (rep / "summary.md").read_text()
    assert md.splitlines()[2].startswith("**Conclusion.** The free-run loop runs")


@pytest.mark.parametrize("argv,needle", [
    ([], "give DATA.csv or --sine"),
    (["--sine", "70", "1"], "needs --rate"),
    (["--sine", "70", "600", "--rate", "1000"], "below half of --rate"),
    (["--sine", "-1", "1", "--rate", "1000"], "AMPLITUDE"),
    (["--sine", "70", "1", "--rate", "1000", "--periods", "0"], "--periods"),
    (["--sine", "70", "1", "--rate", "1000", "--bounding-step", "-1"], "--bounding-step"),
    (["DATA", "--rate", "1000"], "--rate applies to --sine only"),
    (["DATA", "--input", "v"], "no column 'v'"),
    (["NOFILE"], "cannot read"),
])
def test_cli_bad_input_exit_2_one_line(capsys, tmp_path, m19_file, argv, needle):
    csv = tmp_path / "d.csv"
    csv.write_text("u\n" + "".join(f"{float(v)!r}\n" for v in U))
    js = tmp_path / "qs.json"
    argv = [str(csv) if a == "DATA" else str(tmp_path / "no.csv") if a == "NOFILE" else a
            for a in argv]
    code, out, err = run(capsys, "quasistatic", m19_file, *argv, "--json", js)
    assert code == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and needle in lines[0], err
    assert not js.exists()


# ------------------------------------------------------------------ report hooks
def test_fit_and_diagnose_reports_show_the_quasistatic_figure(capsys, tmp_path):
    from conftest import first_order_record
    from mggp.diagnose import Budget, diagnose
    from mggp.diagnose.report import write_report
    u, y = first_order_record(600, 0)
    csv = tmp_path / "d.csv"
    csv.write_text("u,y\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(u, y)))
    code, out, err = run(capsys, "fit", csv, "--population", 20, "--generations", 2,
                         "--seed", 0, "--jobs", 1, "--quiet", "--report", tmp_path / "fit")
    assert code == 0, err
    assert (tmp_path / "fit" / "quasistatic.png").stat().st_size > 10_000
    assert "](quasistatic.png)" in (tmp_path / "fit" / "summary.md").read_text()
    dx = diagnose(narx.Data(u, y), budget=Budget(population=20, generations=2,
                                                  max_height=3), seed=0)
    text = open(write_report(tmp_path / "dx", dx)).read()
    assert (tmp_path / "dx" / "quasistatic.png").stat().st_size > 10_000
    assert "](quasistatic.png)" in text


def test_caption_names_only_the_curves_the_figure_draws():
    """y[k] = y[k-1] + 0.5 (u[k-1] - u[k-2]) has a continuum of steady
    states at the rate's limit 0 too: no bounding curve is drawn, the rest
    band is, and the caption says so (it described dashed and dotted
    bounding curves on every figure); control: model (19), whose
    attracting (unloading) and repelling (loading) bounding curves are
    drawn and named."""
    from mggp.report.quasistatic import caption
    u = sine(70.0, 1.0, 1e-3, 2.0)
    flat = caption(narx.quasistatic(narx.Model(["y[k-1]", "Phi1(u[k-1],u[k-2])"],
                                               [1.0, 0.5]), u))
    assert "bounding structure" not in flat and "grey band" in flat
    c19 = caption(narx.quasistatic(model19(), u))
    assert "dashed: the attracting and dotted: the repelling bounding structure" in c19
