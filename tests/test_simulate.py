"""Simulation modes (narx.simulate, narx.simulation.kernels, Model.simulate) and metrics.

The main reference is a slow, obvious Python simulator written here from
factor descriptions (not from narx's parsed terms): for a window starting at
sample s it copies the measured output, overwrites samples s, s+1, ... with
the model's prediction and reads lagged outputs from that same array. Every
mode is a set of such windows: osa (length 1 at every sample), freerun (one
window), ksa (length k at every sample, keep the last), ms (consecutive
windows of Δm). narx must agree with it, with its own pure-numpy path
(``force_python=True``) and, where a real system is exactly a NARX model,
with the system.
"""
import time
import warnings

import numpy as np
import pytest

import narx
from narx import Model, PhiRegistry, parse_terms, simulate
from narx.records.data import Data, DataError
from narx.simulation.kernels import Plan
from narx.simulation.metrics import mape, mse, nrmse, rmse, rrse
from narx.systems import bouc_wen_discrete, bouc_wen_discrete_narx, training_input
from narx.systems.testsystems import system_piroddi

# --------------------------------------------------------------- reference
REF_PHI = {"Phi1": lambda a, b: a - b,
           "Phi2": lambda a, b: float(np.sign(a - b)),
           "Sat": lambda a: float(np.tanh(a)),
           "Abs": lambda a: abs(a)}


def f_text(f):
    def lag(sig, j):
        return f"{sig}[k]" if j == 0 else f"{sig}[k-{j}]"
    if f[0] == "lag":
        return lag(f[1], f[2])
    return f"{f[1]}({','.join(lag(s, j) for s, j in f[2])})"


def t_text(factors):
    return "*".join(f_text(f) for f in factors) if factors else "1"


def ref_value(factors, z, sig, k):
    """Value of a term at sample k; z is the output array, sig the inputs."""
    def val(s, j):
        return z[k - j] if s == "y" else sig[s][k - j]
    v = 1.0
    for f in factors:
        if f[0] == "lag":
            v *= val(f[1], f[2])
        else:
            v *= REF_PHI[f[1]](*[val(s, j) for s, j in f[2]])
    return v


def ref_window(desc, theta, y, sig, start, length):
    z = np.array(y, dtype=float)
    for j in range(length):
        k = start + j
        if k >= len(z):
            break
        z[k] = sum(th * ref_value(fs, z, sig, k) for th, fs in zip(theta, desc))
    return z


def ref_simulate(desc, theta, y, sig, mode, ml, k=None, window=None):
    n = len(y)
    out = np.full(n, np.nan)
    out[:ml] = y[:ml]
    if mode == "freerun":
        z = ref_window(desc, theta, y, sig, ml, n - ml)
        out[ml:] = z[ml:]
    elif mode == "osa":
        for s in range(ml, n):
            out[s] = ref_window(desc, theta, y, sig, s, 1)[s]
    elif mode == "ksa":
        for s in range(ml, n - k + 1):
            out[s + k - 1] = ref_window(desc, theta, y, sig, s, k)[s + k - 1]
    elif mode == "ms":
        for s in range(ml, n, window):
            z = ref_window(desc, theta, y, sig, s, window)
            out[s:s + window] = z[s:s + window]
    return out


def random_model(rng, inputs=("u", "w"), user_phi=False):
    """Random stable-looking model: list of factor lists, theta."""
    def lag_y():
        return ("y", int(rng.integers(1, 5)))

    def lag_u():
        return (inputs[int(rng.integers(len(inputs)))], int(rng.integers(0, 5)))

    def factor():
        r = rng.random()
        if r < 0.3:
            return ("lag",) + lag_y()
        if r < 0.6:
            return ("lag",) + lag_u()
        name = "Phi1" if rng.random() < 0.5 else "Phi2"
        if r < 0.75:
            return ("phi", name, (lag_u(), lag_u()))
        if r < 0.9:
            args = [(lag_y(), lag_y()), (lag_y(), lag_u()), (lag_u(), lag_y())]
            return ("phi", name, args[int(rng.integers(3))])
        if user_phi:
            return ("phi", "Abs" if rng.random() < 0.5 else "Sat",
                    ((lag_y() if rng.random() < 0.5 else lag_u()),))
        return ("phi", "Sat", (lag_u(),))

    desc, texts = [[("lag", "y", 1)]], {"y[k-1]"}
    theta = [0.5]
    while len(desc) < int(rng.integers(4, 9)):
        fs = [factor() for _ in range(int(rng.integers(1, 4)))]
        text = str(narx.parse_term(t_text(fs), narx.Signals("y", inputs),
                                   registry=_REG))
        if text in texts or any(f[0] == "phi" and f[2][0] == f[2][-1] and len(f[2]) == 2
                                for f in fs):
            continue
        texts.add(text)
        desc.append(fs)
        theta.append(float(rng.uniform(-0.25, 0.25)))
    return desc, np.array(theta)


_REG = PhiRegistry()
_REG.register("Sat", 1, np.tanh, steady=np.tanh)
_REG.register("Abs", 1, np.abs, steady=np.abs)


def random_record(rng, n, inputs=("u", "w")):
    U = rng.uniform(-1, 1, size=(n, len(inputs)))
    y = np.convolve(rng.normal(size=n), np.ones(5) / 5, mode="same")
    return Data(U, y, inputs=inputs), {s: U[:, i] for i, s in enumerate(inputs)}


MODES = [("osa", {}), ("freerun", {}), ("ksa", {"k": 1}), ("ksa", {"k": 4}),
         ("ms", {"window": 1}), ("ms", {"window": 7}), ("ms", {"window": 10_000})]


def _ref_kwargs(mode, kw):
    return {"k": kw.get("k"), "window": kw.get("window")}


# --------------------------------------------------------------- against the reference
@pytest.mark.parametrize("seed", range(6))
def test_random_models_match_reference_compiled_and_python(seed):
    rng = np.random.default_rng(1000 + seed)
    desc, theta = random_model(rng)
    data, sig = random_record(rng, 160)
    terms = parse_terms([t_text(fs) for fs in desc], narx.Signals("y", ("u", "w")),
                        registry=_REG)
    plan = Plan.from_terms(terms, data.inputs, _REG)
    assert plan.compiled                      # Φ of outputs here are built-ins
    ml = plan.maxlag
    for mode, kw in MODES:
        ref = ref_simulate(desc, theta, data.y, sig, mode, ml, **_ref_kwargs(mode, kw))
        fast = simulate(terms, theta, data, mode, registry=_REG, **kw)
        slow = simulate(terms, theta, data, mode, registry=_REG, force_python=True, **kw)
        assert not fast.diverged and not slow.diverged, (mode, kw)
        np.testing.assert_array_equal(np.isnan(fast.y_hat), np.isnan(ref), err_msg=mode)
        np.testing.assert_allclose(fast.y_hat, ref, rtol=1e-12, atol=1e-12,
                                   err_msg=f"{mode} {kw}")
        np.testing.assert_allclose(slow.y_hat, fast.y_hat, rtol=1e-13, atol=1e-14,
                                   err_msg=f"{mode} {kw}")
        np.testing.assert_array_equal(fast.valid, ~np.isnan(ref) & (np.arange(160) >= ml))
        assert fast.mse == pytest.approx(np.mean((data.y - ref)[fast.valid] ** 2), rel=1e-10)


@pytest.mark.parametrize("seed", range(3))
def test_user_phi_of_outputs_matches_reference(seed):
    rng = np.random.default_rng(2000 + seed)
    desc, theta = random_model(rng, user_phi=True)
    desc.append([("phi", "Abs", (("y", 2),)), ("lag", "u", 1)])
    theta = np.append(theta, -0.1)
    data, sig = random_record(rng, 120)
    terms = parse_terms([t_text(fs) for fs in desc], narx.Signals("y", ("u", "w")),
                        registry=_REG)
    assert not Plan.from_terms(terms, data.inputs, _REG).compiled
    ml = max(t.max_lag for t in terms)
    for mode, kw in MODES:
        ref = ref_simulate(desc, theta, data.y, sig, mode, ml, **_ref_kwargs(mode, kw))
        r = simulate(terms, theta, data, mode, registry=_REG, **kw)
        assert not r.diverged
        np.testing.assert_allclose(r.y_hat, ref, rtol=1e-12, atol=1e-12,
                                   err_msg=f"{mode} {kw}")


def test_phi_of_output_arguments_compiled_equals_python():
    rng = np.random.default_rng(7)
    texts = ["y[k-1]", "Phi2(y[k-1],y[k-2])*u[k-1]", "Phi1(y[k-1],u[k-2])",
             "u[k-1]*Phi1(u[k-3],y[k-2])", "Phi2(u[k-1],y[k-1])*Phi1(u[k-1],u[k-2])",
             "Phi1(u[k-1],u[k-2])", "u[k]*y[k-3]"]
    desc = [[("lag", "y", 1)], [("phi", "Phi2", (("y", 1), ("y", 2))), ("lag", "u", 1)],
            [("phi", "Phi1", (("y", 1), ("u", 2)))],
            [("lag", "u", 1), ("phi", "Phi1", (("u", 3), ("y", 2)))],
            [("phi", "Phi2", (("u", 1), ("y", 1))), ("phi", "Phi1", (("u", 1), ("u", 2)))],
            [("phi", "Phi1", (("u", 1), ("u", 2)))], [("lag", "u", 0), ("lag", "y", 3)]]
    theta = np.array([0.6, 0.2, -0.15, 0.1, 0.05, 0.7, -0.1])
    m = Model(texts, theta)
    u = rng.uniform(-1, 1, 400)
    y = np.sin(np.arange(400) / 9.0) + 0.01 * rng.normal(size=400)
    data = Data(u, y)
    for mode, kw in MODES:
        ref = ref_simulate(desc, theta, y, {"u": u}, mode, 3, **_ref_kwargs(mode, kw))
        fast = simulate(m.terms, theta, data, mode, **kw)
        slow = simulate(m.terms, theta, data, mode, force_python=True, **kw)
        np.testing.assert_allclose(fast.y_hat, ref, rtol=1e-12, atol=1e-12, err_msg=mode)
        np.testing.assert_allclose(slow.y_hat, ref, rtol=1e-12, atol=1e-12, err_msg=mode)
        assert np.isfinite(fast.mse)


def test_phi_of_outputs_at_ties_is_exact_in_the_kernel():
    # quantised signals make Phi2's argument difference exactly 0 often:
    # sign(0) = 0 must hold in the compiled kernel as in the reference
    rng = np.random.default_rng(9)
    u = np.round(rng.uniform(-2, 2, 300))
    y = np.round(rng.uniform(-2, 2, 300))
    desc = [[("lag", "y", 1)], [("phi", "Phi2", (("y", 1), ("y", 2)))],
            [("phi", "Phi2", (("u", 1), ("y", 1)))], [("phi", "Phi1", (("y", 2), ("u", 2)))]]
    theta = np.array([0.3, 0.7, -0.4, 0.2])
    m = Model([t_text(fs) for fs in desc], theta)
    d = Data(u, y)
    assert np.mean(y[1:-1] == y[:-2]) > 0.1
    for mode, kw in MODES + [("ksa", {"k": 2})]:
        ref = ref_simulate(desc, theta, y, {"u": u}, mode, 2, **_ref_kwargs(mode, kw))
        for force in (False, True):
            r = simulate(m.terms, theta, d, mode, force_python=force, **kw)
            np.testing.assert_allclose(r.y_hat, ref, rtol=1e-13, atol=1e-13,
                                       err_msg=f"{mode} {kw} python={force}")


def test_multiple_named_inputs_model_simulates_like_reference():
    rng = np.random.default_rng(3)
    n = 300
    U = rng.uniform(-1, 1, size=(n, 3))
    x, v, E = U.T
    f = np.zeros(n)
    for k in range(2, n):
        f[k] = (0.7 * f[k - 1] - 0.1 * f[k - 2] + 0.3 * x[k - 1] * v[k - 2]
                + 0.2 * (E[k] - E[k - 1]) + 0.1 * np.sign(f[k - 1] - x[k - 1]))
    m = Model(["f[k-1]", "f[k-2]", "v[k-2]*x[k-1]", "Phi1(E[k],E[k-1])",
               "Phi2(f[k-1],x[k-1])"], [0.7, -0.1, 0.3, 0.2, 0.1],
              inputs=("x", "v", "E"), output="f")
    d = Data(U, f, inputs=("x", "v", "E"), output="f")
    for mode, kw in MODES:
        r = m.simulate(d, mode=mode, **kw)
        assert r.valid.sum() == n - 2 - (kw.get("k", 1) - 1)
        np.testing.assert_allclose(r.y_hat[r.valid], f[r.valid], rtol=0, atol=1e-12,
                                   err_msg=mode)
    # the same fitted by LS recovers θ exactly (noise-free)
    fit = Model(m.term_texts, inputs=("x", "v", "E"), output="f").fit(U, f)
    np.testing.assert_allclose(fit.theta, m.theta, rtol=0, atol=1e-10)
    with pytest.raises(ValueError, match="do not match"):
        m.simulate(Data(U, f, inputs=("x", "E", "v"), output="f"))


def test_noise_terms_are_zero_in_every_mode():
    rng = np.random.default_rng(12)
    u, y = rng.uniform(-1, 1, 200), rng.normal(size=200)
    full = Model(["y[k-1]", "u[k-1]", "e[k-1]", "u[k-1]*e[k-2]", "Phi1(y[k-1],e[k-3])",
                  "y[k-2]*e[k-1]"], [0.5, 0.8, 3.0, -2.0, 5.0, 7.0])
    bare = Model(["y[k-1]", "u[k-1]", "y[k-2]", "u[k-3]"], [0.5, 0.8, 0.0, 0.0])
    for mode, kw in MODES:
        for force in (False, True):
            a = simulate(full.terms, full.theta, Data(u, y), mode, force_python=force, **kw)
            b = simulate(bare.terms, bare.theta, Data(u, y), mode, force_python=force, **kw)
            np.testing.assert_allclose(a.y_hat, b.y_hat, rtol=1e-14, atol=1e-15,
                                       err_msg=f"{mode} {kw} python={force}")


# --------------------------------------------------------------- mode identities
def _piroddi_model():
    d = system_piroddi(n=600, seed=4)
    return Model(d.terms, d.theta), d


def test_mode_identities_on_piroddi():
    m, d = _piroddi_model()
    y = d.y + 0.01 * np.random.default_rng(0).normal(size=d.y.size)   # not exact data
    osa = m.simulate(d.u, y, "osa")
    ksa1 = m.simulate(d.u, y, "ksa", k=1)
    np.testing.assert_allclose(ksa1.y_hat, osa.y_hat, rtol=1e-14, atol=1e-15)
    np.testing.assert_array_equal(ksa1.valid, osa.valid)
    assert ksa1.mse == pytest.approx(osa.mse, rel=1e-12)
    fr = m.simulate(d.u, y, "freerun")
    for w in (d.y.size, d.y.size - 2, 10 * d.y.size):
        ms = m.simulate(d.u, y, "ms", window=w)
        np.testing.assert_array_equal(ms.y_hat, fr.y_hat)
        assert ms.horizon == w
    ms1 = m.simulate(d.u, y, "ms", window=1)
    np.testing.assert_allclose(ms1.y_hat, osa.y_hat, rtol=1e-14, atol=1e-15)
    # osa is Ψ θ from the regressor matrix
    Psi, _, s = narx.regressor_matrix(m.terms, Data(d.u, y))
    np.testing.assert_allclose(osa.y_hat[s:], Psi @ m.theta, rtol=1e-14, atol=1e-15)
    # aliases and Model.predict
    np.testing.assert_array_equal(m.simulate(d.u, y, "pem").y_hat, osa.y_hat)
    np.testing.assert_array_equal(m.predict(d.u, y, "freerun"), fr.y_hat)
    # exact model, exact data: every mode reproduces the system
    for mode, kw in MODES:
        r = m.simulate(d.u, d.y, mode, **kw)
        assert r.mse < 1e-25, mode


def test_ksa_horizon_semantics_and_valid_mask():
    m, d = _piroddi_model()
    y = d.y + 0.05 * np.random.default_rng(1).normal(size=d.y.size)
    r = m.simulate(d.u, y, "ksa", k=5)
    ml = 2
    assert r.horizon == 5 and r.start == ml
    assert np.all(np.isnan(r.y_hat[ml:ml + 4])) and np.all(np.isfinite(r.y_hat[ml + 4:]))
    assert not r.valid[:ml + 4].any() and r.valid[ml + 4:].all()
    np.testing.assert_array_equal(r.y_hat[:ml], y[:ml])
    # ŷ[s+4] is a free run of 5 steps from the measured samples before s
    for s in (2, 50, 300, d.y.size - 5):
        y_cut = np.concatenate([y[s - ml:s], np.full(5, 1e6)])   # no data after s-1
        expect = m.simulate(Data(d.u[s - ml:s + 5], y_cut), mode="freerun").y_hat[-1]
        assert r.y_hat[s + 4] == pytest.approx(expect, rel=1e-13, abs=1e-15)


def test_freerun_initial_conditions_are_the_first_maxlag_samples():
    m, d = _piroddi_model()
    r = m.simulate(d.u, d.y, "freerun")
    np.testing.assert_array_equal(r.y_hat[:2], d.y[:2])
    y2 = d.y.copy()
    y2[2:] = 1e3 * np.random.default_rng(0).normal(size=y2.size - 2)   # garbage after
    r2 = m.simulate(d.u, y2, "freerun")
    np.testing.assert_array_equal(r2.y_hat, r.y_hat)
    y3 = d.y.copy()
    y3[1] += 0.1                                                        # changes all after
    r3 = m.simulate(d.u, y3, "freerun")
    assert r3.y_hat[1] == y3[1] and r3.y_hat[3] != r.y_hat[3]


def test_y0_path_without_measured_output():
    m, d = _piroddi_model()
    ref = m.simulate(d.u, d.y, "freerun").y_hat
    r = m.simulate(Data(d.u), y0=d.y[:2])
    assert r.y is None and not r.diverged
    np.testing.assert_array_equal(r.y_hat, ref)
    r = simulate(m.terms, m.theta, Data(d.u), "freerun", y0=list(d.y[:5]))  # extra ignored
    np.testing.assert_array_equal(r.y_hat, ref)
    with pytest.raises(DataError, match="y0 must hold 2"):
        m.simulate(Data(d.u), y0=[0.1])
    with pytest.raises(DataError, match="y0"):
        m.simulate(Data(d.u), y0=[0.1, np.nan])
    with pytest.raises(DataError, match="needs the measured output"):
        m.simulate(Data(d.u))
    with pytest.raises(DataError, match="needs the measured output"):
        m.simulate(Data(d.u), mode="osa", y0=d.y[:2])
    with pytest.raises(DataError, match="no measured output"):
        r.residual


def test_y0_path_does_not_misflag_a_stable_large_output_as_diverged():
    u = np.full(300, 1e4)
    m = Model(["y[k-1]", "u[k-1]"], [0.5, 1.0])          # stable, steady state 2e4
    r = m.simulate(Data(u), y0=[0.0])
    assert not r.diverged
    assert r.y_hat[-1] == pytest.approx(2e4)


def test_diverging_model_is_quiet_and_scores_inf():
    rng = np.random.default_rng(0)
    u = rng.uniform(-1, 1, 500)
    y = np.cumsum(rng.normal(size=500)) * 0.01
    terms = parse_terms(["y[k-1]", "u[k-1]"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for force in (False, True):
            for mode, kw in [("freerun", {}), ("ksa", {"k": 60}), ("ms", {"window": 100}),
                             ("ms", {"window": 10_000})]:
                r = simulate(terms, [2.0, 1.0], Data(u, y), mode, force_python=force, **kw)
                assert r.diverged, (mode, force)
                assert r.mse == np.inf and r.rmse == np.inf and r.mape == np.inf
        # quadratic blow-up reaches inf/NaN in float arithmetic: still quiet
        m = Model(["y[k-1]*y[k-1]", "u[k-1]"], [2.0, 1.0])
        r = m.simulate(np.ones(3000), np.linspace(1, 2, 3000), "freerun")
        assert r.diverged and r.mse == np.inf
        # a stable model is not flagged
        r = simulate(terms, [0.5, 1.0], Data(u, y), "freerun")
        assert not r.diverged and np.isfinite(r.mse)


# --------------------------------------------------------------- Bouc-Wen (user Φ of y)
@pytest.mark.parametrize("mode,kw", MODES + [("ksa", {"k": 50}), ("ms", {"window": 250})])
def test_discrete_bouc_wen_is_reproduced_exactly_in_every_mode(mode, kw, abs_registry):
    A, beta, gamma = 0.9, 0.008, 0.008
    u = training_input(n=3000, seed=5)
    y = bouc_wen_discrete(u, A, beta, gamma, h0=1.5)
    terms, theta = bouc_wen_discrete_narx(A, beta, gamma)
    m = Model(terms, theta, registry=abs_registry)
    assert m.term_texts == list(terms)
    assert not Plan.from_terms(m.terms, ("u",), abs_registry).compiled
    r = m.simulate(u, y, mode, **kw)
    assert not r.diverged
    err = np.max(np.abs(r.y_hat - y)[r.valid])
    assert err < 1e-9 * np.ptp(y), err
    assert r.valid.sum() == 3000 - 2 - (kw.get("k", 1) - 1 if mode == "ksa" else 0)
    slow = simulate(m.terms, theta, Data(u, y), mode, registry=abs_registry,
                    force_python=True, **kw)
    np.testing.assert_array_equal(slow.y_hat, r.y_hat)


def test_discrete_bouc_wen_from_y0_and_needs_its_registry(abs_registry):
    u = training_input(n=2000, seed=8)
    y = bouc_wen_discrete(u, h0=-0.7)
    terms, theta = bouc_wen_discrete_narx()
    r = Model(terms, theta, registry=abs_registry).simulate(Data(u), y0=[-0.7, -0.7])
    np.testing.assert_allclose(r.y_hat, y, rtol=0, atol=1e-9 * np.ptp(y))
    if "Abs" not in narx.default_registry():
        with pytest.raises(narx.TermError, match="unknown Φ-function 'Abs'"):
            Model(terms, theta)


def test_input_columns_follow_the_registry_in_use():
    rng = np.random.default_rng(0)
    u, y = rng.normal(size=100), rng.normal(size=100)
    d = Data(u, y)
    reg = PhiRegistry()
    reg.register("G", 1, np.abs, steady=np.abs)
    terms = parse_terms(["G(u[k-1])"], registry=reg)
    r1 = simulate(terms, [1.0], d, "osa", registry=reg)
    np.testing.assert_array_equal(r1.y_hat[1:], np.abs(u[:-1]))
    reg.register("G", 1, np.square, steady=np.square, overwrite=True)
    r2 = simulate(terms, [1.0], d, "osa", registry=reg)
    other = PhiRegistry()
    other.register("G", 1, np.negative, steady=np.negative)
    r3 = simulate(terms, [1.0], d, "freerun", registry=other)
    np.testing.assert_array_equal(r2.y_hat[1:], u[:-1] ** 2)
    np.testing.assert_array_equal(r3.y_hat[1:], -u[:-1])


# --------------------------------------------------------------- argument checking
def test_bad_arguments_raise_informative_errors():
    m, d = _piroddi_model()
    data = Data(d.u, d.y)
    t, th = m.terms, m.theta
    with pytest.raises(ValueError, match="mode must be one of osa, freerun, ksa, ms.*'fast'"):
        simulate(t, th, data, "fast")
    for k in (0, -3, None):
        with pytest.raises(ValueError, match=f"k must be an integer >= 1 .*got {k!r}"):
            simulate(t, th, data, "ksa", k=k)
    for w in (0, -1, None):
        with pytest.raises(ValueError, match=f"window .* must be an integer >= 1 .*got {w!r}"):
            simulate(t, th, data, "ms", window=w)
    with pytest.raises(ValueError, match="theta has 2 values for 3 terms"):
        simulate(t, th[:2], data)
    with pytest.raises(ValueError, match="theta has 4 values for 3 terms"):
        simulate(t, np.append(th, 1.0), data)
    with pytest.raises(ValueError, match="non-finite"):
        simulate(t, [np.nan, 0.0, 0.0], data)
    with pytest.raises(ValueError, match="theta has 2 values but the model has 3"):
        Model(m.term_texts, [1.0, 2.0])
    with pytest.raises(ValueError, match="no parameters yet"):
        Model(m.term_texts).simulate(d.u, d.y)
    with pytest.raises(DataError, match="too short"):
        simulate(t, th, data.slice(0, 2))
    with pytest.raises(DataError, match="too short for k=700"):
        simulate(t, th, data, "ksa", k=700)


@pytest.mark.parametrize("kw", [{"mode": "ksa", "k": 2.5}, {"mode": "ms", "window": 2.5}])
def test_non_integer_horizon_is_rejected(kw):
    m, d = _piroddi_model()
    with pytest.raises(ValueError, match="integer"):
        simulate(m.terms, m.theta, Data(d.u, d.y), **kw)


# --------------------------------------------------------------- published model (19)
def test_published_reference_model_19_mape(model19, piezo_validation):
    terms, theta = model19
    u, y = piezo_validation
    assert u.shape == (5000,)
    m = Model(terms, theta)
    assert m.max_lag == 3
    r = m.simulate(u, y, "freerun")
    assert not r.diverged
    np.testing.assert_array_equal(r.y_hat[:3], y[:3])
    published = 100 * np.mean(np.abs(y - r.y_hat)) / (y.max() - y.min())
    assert published == pytest.approx(0.24, abs=0.03)
    assert r.mape == pytest.approx(0.24, abs=0.03)
    assert mape(y, r.y_hat) == pytest.approx(published, rel=1e-12)


def test_freerun_is_compiled_fast(model33_terms, piezo_training):
    u, y = piezo_training
    theta = np.zeros(15)
    theta[6] = 1.0
    m = Model(model33_terms, theta)
    d = Data(u, y)
    m.simulate(d)                                          # warm-up and column cache
    best = min(_timed(lambda: m.simulate(d)) for _ in range(3))
    assert best < 0.25, f"free run of 50,000 samples took {best:.3f} s"


def _timed(f):
    t0 = time.perf_counter()
    f()
    return time.perf_counter() - t0


# --------------------------------------------------------------- metrics
def test_metrics_against_hand_calculations():
    y = np.array([1.0, 3.0, 2.0, 6.0])
    yh = np.array([2.0, 3.0, 0.0, 5.0])
    # errors 1, 0, -2... |e| = 1, 0, 2, 1; e^2 = 1, 0, 4, 1
    assert mse(y, yh) == pytest.approx(6 / 4)
    assert rmse(y, yh) == pytest.approx(np.sqrt(1.5))
    assert mape(y, yh) == pytest.approx(100 * (4 / 4) / (6 - 1))       # 20 %
    # mean 3; (y - mean)^2 = 4, 0, 1, 9 -> 14
    assert rrse(y, yh) == pytest.approx(np.sqrt(6 / 14))
    assert nrmse(y, yh) == pytest.approx(np.sqrt(1.5) / np.sqrt(14 / 4))
    assert rrse(y, np.full(4, y.mean())) == pytest.approx(1.0)
    assert mape(y, y) == 0.0 and rmse(y, y) == 0.0 and rrse(y, y) == 0.0
    for f in (mse, rmse, mape, rrse):
        assert f(y, [1.0, np.nan, 2.0, 6.0]) == np.inf
        assert f(y, [1.0, np.inf, 2.0, 6.0]) == np.inf
        with pytest.raises(ValueError, match="lengths differ"):
            f(y, yh[:3])
        with pytest.raises(ValueError, match="no samples"):
            f([], [])
    with pytest.raises(ValueError, match="range is zero"):
        mape([2.0, 2.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="constant"):
        rrse([2.0, 2.0], [1.0, 2.0])


def test_result_metrics_use_valid_samples_only():
    m, d = _piroddi_model()
    y = d.y + 0.02 * np.random.default_rng(5).normal(size=d.y.size)
    r = m.simulate(d.u, y, "ksa", k=3)
    e = (y - r.y_hat)[r.valid]
    assert e.size == y.size - 2 - 2
    assert r.mse == pytest.approx(np.mean(e ** 2), rel=1e-12)
    assert r.rmse == pytest.approx(np.sqrt(np.mean(e ** 2)), rel=1e-12)
    assert r.mape == pytest.approx(100 * np.mean(np.abs(e)) / np.ptp(y[r.valid]), rel=1e-12)
    np.testing.assert_array_equal(r.residual, e)


def test_a_horizon_or_window_for_another_mode_is_refused():
    import narx
    from conftest import first_order_record
    u, y = first_order_record(200)
    m = narx.Model(["y[k-1]", "u[k-1]"], theta=[0.5, 1.0])
    with pytest.raises(ValueError, match="k=5 applies to mode 'ksa' only, not to 'freerun'"):
        m.simulate(u, y, mode="freerun", k=5)
    with pytest.raises(ValueError, match="window=50 applies to mode 'ms' only, not to 'osa'"):
        m.simulate(u, y, mode="osa", window=50)
    assert np.isfinite(m.simulate(u, y, mode="ksa", k=5).rmse)        # control


# --------------------------------------------------------------- mode names
def test_one_table_names_each_mode_once_and_its_aliases():
    from narx.estimation.fitness import FITNESS, StructureScorer
    from narx.simulation.simulate import MODE_TABLE, MODES, mode_name
    assert MODES == ("osa", "freerun", "ksa", "ms") and FITNESS == MODES
    names = [n for n, _, _ in MODE_TABLE] + [a for _, al, _ in MODE_TABLE for a in al]
    assert len(names) == len(set(names))                 # no name means two modes
    assert mode_name("pem") == "osa" and mode_name("osa") == "osa"
    with pytest.raises(ValueError, match=r"fitness must be one of osa, freerun, ksa, ms "
                                         r"\(aliases: pem and one-step for osa.*got 'PEM'"):
        mode_name("PEM", "fitness")
    with pytest.raises(ValueError, match="got None"):
        mode_name(None)
    m, d = _piroddi_model()
    data = Data(d.u, d.y)
    a = simulate(m.terms, m.theta, data, "osa")
    b = simulate(m.terms, m.theta, data, "pem")
    assert a.mode == b.mode == "osa"
    np.testing.assert_array_equal(a.y_hat, b.y_hat)
    sa, sb = StructureScorer(data, "osa"), StructureScorer(data, "pem")
    assert sa.fitness == sb.fitness == "osa"
    assert sa.score(m.terms) == sb.score(m.terms) == pytest.approx(a.mse, rel=1e-9)
    with pytest.raises(ValueError, match="fitness must be one of osa, freerun, ksa, ms"):
        StructureScorer(data, "fast")
