"""Memory operators: play, Deng-Tan, plug-in registry, steady rule, systems."""
import math

import numpy as np
import pytest

from narx.language.memory import (DENG_TAN_DEPTH, OperatorRegistry, bouc_wen, bouc_wen_reference,
                         deng_tan, deng_tan_reference, deng_tan_state, deng_tan_step,
                         get_operator, play, play_reference)
from narx.systems import (backlash_second_order, held_sine, operator_record,
                          pi_first_order)


def _walk(n=3000, seed=0):
    return np.cumsum(np.random.default_rng(seed).standard_normal(n)) * 0.1


# ------------------------------------------------------------------ play
def test_play_by_hand_and_initial_state():
    x = np.array([0.0, 1.0, 3.0, 2.0, 1.5, 0.5, -1.0, 0.0, 0.5])
    np.testing.assert_array_equal(play(x, 1.0), [0, 0, 2, 2, 2, 1.5, 0, 0, 0])
    assert play(x, 1.0)[0] == x[0]                      # default: at rest on x_0
    np.testing.assert_array_equal(play(x, 1.0, init=5.0)[:3], [1.0, 1.0, 2.0])   # clipped
    np.testing.assert_array_equal(play(x, 0.0), x)       # r = 0 is the identity


@pytest.mark.parametrize("r", [0.0, 0.05, 0.3, 2.0])
def test_play_compiled_equals_reference(r):
    x = _walk()
    np.testing.assert_array_equal(play(x, r), play_reference(x, r))
    np.testing.assert_array_equal(play(x, r, init=1.0), play_reference(x, r, init=1.0))
    np.testing.assert_array_equal(get_operator("Play").sequence(x, (r,)), play(x, r))


def test_play_rejects_bad_radius():
    for bad in (-1.0, math.nan, "abc", math.inf):
        with pytest.raises(ValueError, match="radius|parameter r"):
            play([0.0, 1.0], bad)


# -------------------------------------------------------------- Deng-Tan
def test_deng_tan_compiled_equals_reference_and_starts_at_zero():
    x = _walk()
    np.testing.assert_array_equal(deng_tan(x), deng_tan_reference(x))
    np.testing.assert_array_equal(deng_tan(x, init=0.7), deng_tan_reference(x, init=0.7))
    assert deng_tan([0.0, 0.0])[0] == 0.0
    z = 0.4
    assert deng_tan([z])[0] == pytest.approx(abs(math.atan(z)) * z)


def test_deng_tan_return_point_memory_and_hold():
    x = np.array([0.0, 1.0, 0.5, 0.8, 0.5, 1.0, 1.2, 1.2])
    h = deng_tan_reference(x)
    assert h[4] == pytest.approx(h[2])      # minor loop 0.5 -> 0.8 -> 0.5 closes
    assert h[5] == pytest.approx(h[1])      # back at the dominant maximum
    # beyond it the initial branch from the origin continues
    assert h[6] == pytest.approx(abs(math.atan(1.2)) * 1.2)
    assert h[7] == h[6]                     # held input, held value
    # control: without the wipe-out rule h[6] would follow the branch from 0.5
    assert h[6] != pytest.approx(abs(math.atan(0.7)) * 0.7 + h[4])


def test_deng_tan_depth_limit_forgets_oldest_loops_only():
    # decaying oscillation: every reversal stays open, the stack grows
    k = np.arange(400)
    x = np.cos(np.pi * k / 2) * np.exp(-k / 300.0)
    x = np.concatenate([x, np.linspace(x[-1], 2.0, 200)])   # then pass them all
    s = deng_tan_state(depth=8)
    p = np.empty(0)
    h = np.array([deng_tan_step(s, xi, p) for xi in x])
    ref = deng_tan_reference(x)
    assert np.isfinite(h).all() and int(s[3]) <= 9
    np.testing.assert_array_equal(deng_tan(x), ref)       # default depth suffices
    assert DENG_TAN_DEPTH >= 200
    # equal while the forgotten loops are not passed, different after
    np.testing.assert_array_equal(h[:400], ref[:400])
    assert np.abs(h - ref).max() > 1e-3
    assert h[-1] == ref[-1]                 # beyond every extremum: origin branch


# ------------------------------------------------------------ registry
# -------------------------------------------------------------- Bouc-Wen
def test_bouc_wen_is_the_piezo_law_of_unit_gain_and_equals_its_reference():
    """The operator is h/A of narx.systems.piezo_bouc_wen, whose one RK4
    step per sample it solves exactly (they agree to RK4's own error, 1e-7
    of the loop's size); the plain-Python reference agrees to rounding;
    control: other shape parameters give another loop."""
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(3000, seed=2)
    h = 1.6 * u - piezo_bouc_wen(u, A=0.9, beta=0.008, gamma=0.005)
    bw = bouc_wen(u, 0.008, 0.005)
    scale = np.max(np.abs(bw))
    np.testing.assert_allclose(bw, h / 0.9, rtol=0, atol=1e-7 * scale)
    np.testing.assert_allclose(bw, bouc_wen_reference(u, 0.008, 0.005), rtol=0,
                               atol=1e-12 * scale)
    np.testing.assert_allclose(bouc_wen(u, 0.01, 0.0, init=2.0),
                               bouc_wen_reference(u, 0.01, 0.0, init=2.0), rtol=0,
                               atol=1e-12 * scale)
    assert np.max(np.abs(bouc_wen(u, 0.02, 0.005) - bw)) > 1.0


def _bouc_wen_rk4(x, beta, gamma, substeps):
    """The law integrated by ``substeps`` RK4 steps per sample (x linear in
    between); one substep is the old per-sample rule."""
    def rate(h, dx):
        return dx - beta * abs(dx) * h - gamma * dx * abs(h)
    out, h = [], 0.0
    for xp, xk in zip(np.r_[x[0], x[:-1]], x):
        dx = (xk - xp) / substeps
        for _ in range(substeps):
            k1 = rate(h, dx)
            k2 = rate(h + k1 / 2, dx)
            k3 = rate(h + k2 / 2, dx)
            k4 = rate(h + k3, dx)
            h += (k1 + 2 * k2 + 2 * k3 + k4) / 6
        out.append(h)
    return np.array(out)


@pytest.mark.parametrize("beta, gamma", [(4.5, 4.5), (4.5, 0.0), (1.5, 1.5), (2.0, -1.0)])
def test_bouc_wen_on_steps_is_the_law_solved_over_each_sample(beta, gamma):
    """A binary input steps its whole range in one sample: the variable is
    the law integrated finely (500 RK4 substeps a sample, to 1e-7 of its
    bound 1/(β + γ)) and stays within the bound; control: one RK4 step a
    sample, on the same input, leaves the bound far behind."""
    rng = np.random.default_rng(3)
    x = (rng.random(120) > 0.5).astype(float)
    bound = 1.0 / (beta + gamma)
    h = bouc_wen(x, beta, gamma)
    np.testing.assert_allclose(h, _bouc_wen_rk4(x, beta, gamma, 500), rtol=0,
                               atol=1e-7 * bound)
    assert np.max(np.abs(h)) <= bound
    coarse = _bouc_wen_rk4(x, beta, gamma, 1)
    assert not np.max(np.abs(coarse - h)) < 0.1 * bound


def test_bouc_wen_holds_stays_bounded_and_rejects_unbounded_shapes():
    x = np.r_[np.linspace(0, 400, 200), np.full(50, 400.0), np.linspace(400, -400, 300)]
    h = bouc_wen(x, 0.01, 0.01)
    assert np.all(h[200:250] == h[199])                 # held input, held value
    assert np.max(np.abs(h)) < 1 / 0.02                 # |h| < 1/(beta + gamma)
    assert np.max(np.abs(h)) > 0.95 / 0.02              # and it gets there
    assert get_operator("BoucWen").steady_set(3.0, (0.01, 0.01)) == (-50.0, 50.0)
    for beta, gamma in ((0.0, 0.0), (-0.01, 0.0), (0.01, -0.01), (0.01, 0.02)):
        with pytest.raises(ValueError, match="beta > 0 and -beta < gamma <= beta"):
            bouc_wen(x, beta, gamma)


def test_ls_recovers_the_piezo_model_from_its_bouc_wen_term():
    """y = d_p u − A h is linear in (d_p, A) given the operator: LS on the
    two regressors returns (1.6, −0.9) and simulates the record exactly."""
    from narx import Data, Model
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(4000, seed=3)
    data = Data(u, piezo_bouc_wen(u))
    m = Model(("u[k]", "BoucWen(u[k],0.008,0.008)")).fit(data)
    np.testing.assert_allclose(m.theta, [1.6, -0.9], atol=1e-6)
    assert m.simulate(data, mode="freerun").rmse < 1e-6     # the record's RK4 error


def test_plugin_operator_registration_and_sequence():
    """A stop operator (elastic-plastic element) as a plug-in."""
    reg = OperatorRegistry()

    def init(x0, p, init=None):
        return np.array([x0, 0.0 if init is None else init])

    def step(s, x, p):
        s[1] = min(p[0], max(-p[0], s[1] + x - s[0]))
        s[0] = x
        return s[1]

    op = reg.register("Stop", ("r",), init, step,
                      steady=lambda xbar, p: (-p[0], p[0]))
    x = np.sin(np.linspace(0, 4 * np.pi, 200))
    h = op.sequence(x, (0.5,))
    # a stop of radius r is the input minus the play of radius r
    np.testing.assert_allclose(h, x - x[0] - (play(x, 0.5) - x[0]), rtol=0, atol=1e-15)
    assert op.steady_set(3.0, (0.5,)) == (-0.5, 0.5)
    assert "Stop" in reg and "Stop" in reg.snapshot()
    with pytest.raises(ValueError, match="already registered"):
        reg.register("Stop", (), init, step, steady=lambda xb, p: (0, 0))
    with pytest.raises(ValueError, match="already registered"):
        reg.register("Play", (), init, step, steady=lambda xb, p: (0, 0), overwrite=True)
    with pytest.raises(ValueError, match="step must be callable"):
        reg.register("X", (), init, None, steady=lambda xb, p: (0, 0))
    with pytest.raises(ValueError, match="takes 1 parameter"):
        op.sequence(x, (1.0, 2.0))
    with pytest.raises(ValueError, match="cannot unregister"):
        reg.unregister("Play")
    reg.unregister("Stop")
    with pytest.raises(KeyError, match="unknown memory operator"):
        reg.get("Stop")


# ---------------------------------------------------------- steady rule
def test_play_steady_set_is_the_continuum_of_a_first_order_model():
    """y_k = a y_{k-1} + b P_r(u)_{k-1}: held at ū, y rests at b w/(1-a),
    w anywhere in [ū - r, ū + r] by the history (closed form)."""
    a, b, r, ubar = 0.8, 0.5, 0.3, 0.2
    lo, hi = get_operator("Play").steady_set(ubar, (r,))
    assert (lo, hi) == pytest.approx((ubar - r, ubar + r))

    def rest(u_path):
        u = np.concatenate([u_path, np.full(400, ubar)])
        p, y = play(u, r), 0.0
        for k in range(1, u.size):
            y = a * y + b * p[k - 1]
        return y

    g = b / (1 - a)
    assert rest(np.linspace(-1, ubar, 50)) == pytest.approx(g * lo)      # from below
    assert rest(np.linspace(1, ubar, 50)) == pytest.approx(g * hi)       # from above
    mid = rest(np.concatenate([np.linspace(-1, 0.35, 50), np.linspace(0.35, ubar, 10)]))
    assert mid == pytest.approx(g * (0.35 - r))                          # in between
    assert g * lo < mid < g * hi
    assert get_operator("DengTan").steady_set(0.0) == (-math.inf, math.inf)


# --------------------------------------------------------------- systems
def test_pi_first_order_is_the_play_narx_model():
    u = operator_record("pi", n=500, seed=1).u
    radii, w, a = (0.0, 0.2, 0.4, 0.6), (0.4, 0.3, 0.2, 0.1), 0.9
    y = pi_first_order(u, radii, w, a)
    z = sum(wj * play_reference(u, rj) for rj, wj in zip(radii, w))
    yy = [z[0]]
    for k in range(1, u.size):
        yy.append(a * yy[-1] + (1 - a) * z[k - 1])
    np.testing.assert_allclose(y, yy, rtol=0, atol=1e-13)


def test_backlash_second_order_holds_and_has_dead_band():
    hs = held_sine(amplitude=0.8, freq=0.5, dt=0.01)
    y = backlash_second_order(hs.u)
    seg = y[hs.hold_falling][-20:]
    assert np.ptp(seg) < 1e-6                      # settles during the hold
    # control: without play the loop area vanishes, with it it does not
    y0 = backlash_second_order(hs.u, r=0.0)
    assert np.abs(y - y0).max() > 0.1


def test_operator_record_noise_level_and_seed():
    a = operator_record("backlash", n=1000, seed=3, snr_db=40)
    b = operator_record("backlash", n=1000, seed=3, snr_db=40)
    np.testing.assert_array_equal(a.y, b.y)
    snr = 20 * np.log10(np.std(a.y_clean) / np.std(a.y - a.y_clean))
    assert 38.5 < snr < 41.5
    c = operator_record("backlash", n=1000, seed=3)
    np.testing.assert_array_equal(c.y, c.y_clean)
    np.testing.assert_array_equal(c.u, a.u)
    assert a.u_val.size == a.y_val.size > 500
    with pytest.raises(ValueError, match="name must be one of"):
        operator_record("piezo")


# ------------------------------------------------- terms with operators
from narx import Model  # noqa: E402
from narx.records.data import as_data  # noqa: E402
from narx.simulation.simulate import simulate  # noqa: E402
from narx.analysis.steady import (cluster_sums, clusters, held_outputs,  # noqa: E402
                         steady_state_constraints)
from narx.language.terms import OpCall, TermError, parse_term  # noqa: E402

ISSUE_TERMS = ("y[k-1]", "Play(u[k-1],0.3)", "Play(u[k-1],0.8)", "u[k-1]*Play(u[k-1],0.3)")
ISSUE_THETA = (0.8, 0.15, 0.1, -0.2)


def _issue_model_loop(u, theta=ISSUE_THETA):
    """Independent plain-Python loop of the issue's model (y_0 = 0)."""
    p3, p8 = play_reference(u, 0.3), play_reference(u, 0.8)
    y = [0.0]
    for k in range(1, len(u)):
        y.append(theta[0] * y[-1] + theta[1] * p3[k - 1] + theta[2] * p8[k - 1]
                 + theta[3] * u[k - 1] * p3[k - 1])
    return np.array(y)


@pytest.mark.parametrize("text, canonical", [
    ("Play(u[k-1],0.30)", "Play(u[k-1],0.3)"),
    ("Play(u[k-1],0.3)*y[k-1]", "y[k-1]*Play(u[k-1],0.3)"),
    ("Play(y[k-1],1e-1)", "Play(y[k-1],0.1)"),
    ("DengTan(u[k-1])*u[k-2]", "u[k-2]*DengTan(u[k-1])"),
    ("Play(u[k-1],2.0)^2", "Play(u[k-1],2)*Play(u[k-1],2)"),
    ("Play(u[k-2],.5)*Phi1(u[k-1],u[k-2])", "Phi1(u[k-1],u[k-2])*Play(u[k-2],0.5)"),
])
def test_operator_terms_print_canonically(text, canonical):
    t = parse_term(text)
    assert str(t) == canonical and str(parse_term(str(t))) == canonical
    assert any(isinstance(f, OpCall) for f in t.factors)


@pytest.mark.parametrize("text, match", [
    ("Play(u[k-1])", "takes 1 parameter"),
    ("Play(u[k-1],-1)", "radius must be a finite number >= 0"),
    ("Play(u[k-1],abc)", "must be a finite number, got 'abc'"),
    ("Play(u[k-1],inf)", "must be a finite number"),
    ("Play(Play(u[k-1],0.3),0.1)", "nested calls"),
    ("Phi1(Play(u[k-1],0.3),u[k-1])", "nested Φ-calls"),
    ("DengTan(u[k-1],1)", "takes 0 parameter"),
    ("Play(e[k-1],0.3)", "noise"),
    ("Play", "needs arguments"),
])
def test_bad_operator_texts_raise_term_error(text, match):
    with pytest.raises(TermError, match=match):
        parse_term(text)


def test_issue_model_columns_equal_the_plain_loop_and_ls_recovers_theta():
    u = operator_record("pi", n=1500, seed=2).u
    y = _issue_model_loop(u)
    m = Model(ISSUE_TERMS).fit(u, y)
    np.testing.assert_allclose(m.theta, ISSUE_THETA, rtol=1e-8)
    for mode, kw in (("freerun", {}), ("osa", {}), ("ksa", {"k": 7}), ("ms", {"window": 50})):
        r = simulate(m.terms, ISSUE_THETA, as_data(u, y), mode=mode, **kw)
        ok = np.isfinite(r.y_hat)
        assert ok.sum() >= u.size - 8, mode
        np.testing.assert_allclose(r.y_hat[ok], y[ok], rtol=0, atol=1e-12)


def test_operator_clusters_are_held_state_symbols():
    terms = ("y[k-1]", "Play(u[k-1],0.3)", "Play(u[k-2],0.3)",
             "u[k-1]*Play(u[k-2],0.3)", "Play(u[k-1],0)", "u[k-1]", "Play(y[k-1],0.1)")
    keys = [c.key for c in clusters(terms)]
    assert keys == ["y", "Play(u,0.3)", "u*Play(u,0.3)", "u", "Play(y,0.1)"]
    sums = cluster_sums(terms, [1, 2, 3, 4, 5, 6, 7])
    assert sums["Play(u,0.3)"] == 5 and sums["u"] == 11      # radius 0 is u
    cons = steady_state_constraints(terms)
    assert "Σ_Play(u,0.3) = 0" in cons.labels and "Σ_y = 1" in cons.labels


def test_cls_with_operator_terms_recovers_a_static_backlash():
    """y_k = b P_r(u)_k-1 + c, i.e. y_k = y_k-1 + b P_k-1 - b P_k-2: Σ_y = 1
    and Σ_Play = 0 hold, CLS keeps them exactly on noisy data, and the
    model's held output rests anywhere in c + b [ū - r, ū + r]."""
    rec = operator_record("pi", n=2000, seed=4)
    b, c, r = 0.7, 0.2, 0.3
    rng = np.random.default_rng(0)
    y = c + b * np.concatenate([[0.0], play(rec.u, r)[:-1]])
    y[0] = y[1]
    y = y + 1e-4 * rng.standard_normal(y.size)
    terms = ("y[k-1]", "Play(u[k-1],0.3)", "Play(u[k-2],0.3)")
    ls = Model(terms).fit(rec.u, y)
    cls = Model(terms).fit(rec.u, y, constraints="steady-state")
    cons = steady_state_constraints(terms)
    assert cons.satisfied(cls.theta, tol=1e-12)
    assert not cons.satisfied(ls.theta, tol=1e-9)           # control: LS does not
    np.testing.assert_allclose(cls.theta, [1.0, b, -b], atol=5e-3)


def test_held_outputs_closed_form_matches_simulation():
    """y_k = a y_k-1 + b1 P.3 + b2 P.8 + c u P.3: held at ū the output rests
    at (b1 w1 + b2 w2 + c ū w1)/(1 - a), w at ū ∓ r after an approach from
    below / above, and in between after a reversal."""
    ubar, n_hold = 0.1, 300
    lo, hi = held_outputs(ISSUE_TERMS, ISSUE_THETA, ubar)
    a, b1, b2, c = ISSUE_THETA

    def closed(w1, w2):
        return (b1 * w1 + b2 * w2 + c * ubar * w1) / (1 - a)

    assert (lo, hi) == pytest.approx((closed(ubar - 0.3, ubar - 0.8),
                                      closed(ubar + 0.3, ubar + 0.8)))
    rests = []
    for path in (np.linspace(-1, ubar, 100), np.linspace(1, ubar, 100),
                 np.concatenate([np.linspace(-1, 0.5, 100), np.linspace(0.5, ubar, 20)])):
        u = np.concatenate([path, np.full(n_hold, ubar)])
        y = simulate(parse_terms_(ISSUE_TERMS), ISSUE_THETA,
                     as_data(u, _issue_model_loop(u)), mode="freerun").y_hat
        assert np.ptp(y[-50:]) < 1e-12                       # it holds
        rests.append(y[-1])
    assert rests[:2] == pytest.approx([lo, hi], abs=1e-12)
    assert min(lo, hi) < rests[2] < max(lo, hi)
    # rise to 0.5 then fall to ū: the 0.3-play stays at 0.2, the 0.8-play at -0.3
    assert rests[2] == pytest.approx(closed(0.5 - 0.3, 0.5 - 0.8), abs=1e-12)


def parse_terms_(texts):
    return tuple(parse_term(t) for t in texts)


# ------------------------------------------------------------ command line
def _cli(capsys, *argv):
    from mggp.cli.app import main
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_estimate_and_simulate_issue_model(capsys, tmp_path):
    u = operator_record("pi", n=2000, seed=0).u
    y = _issue_model_loop(u)
    data = tmp_path / "op.csv"
    np.savetxt(data, np.c_[u, y], delimiter=",", header="u,y", comments="", fmt="%.17g")
    model = tmp_path / "m.json"
    code, out, err = _cli(capsys, "estimate", data, "--terms", *ISSUE_TERMS, "--out", model)
    assert code == 0, err
    import json
    spec = json.loads(model.read_text())
    assert spec["terms"] == list(ISSUE_TERMS)
    np.testing.assert_allclose(spec["theta"], ISSUE_THETA, rtol=1e-8)
    spec["theta"] = list(ISSUE_THETA)
    model.write_text(json.dumps(spec))
    for mode in ("freerun", "osa", "ksa", "ms"):
        pred = tmp_path / f"p_{mode}.csv"
        code, out, err = _cli(capsys, "simulate", model, data, "--mode", mode, "--out", pred)
        assert code == 0, err
        got = np.genfromtxt(pred, delimiter=",", names=True)["y_hat"]
        ok = np.isfinite(got)
        assert ok.sum() >= u.size - 11
        np.testing.assert_allclose(got[ok], y[ok], rtol=0, atol=1e-12)


@pytest.mark.parametrize("bad", ["Play(u[k-1])", "Play(u[k-1],-1)", "Play(u[k-1],abc)",
                                 "Play(Play(u[k-1],0.3),0.1)"])
def test_cli_bad_operator_text_exits_2_with_one_line(capsys, tmp_path, bad):
    data = tmp_path / "d.csv"
    u = np.sin(np.arange(50) / 5.0)
    np.savetxt(data, np.c_[u, u], delimiter=",", header="u,y", comments="")
    code, out, err = _cli(capsys, "estimate", data, "--terms", "y[k-1]", bad)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and bad in lines[0]


# ------------------------------------------------------------------ search
def test_search_pset_with_operators_decodes_and_keeps_phi_only_set():
    import random
    from mggp.gp.operators import random_individual
    from mggp.gp.primitives import (Decoder, make_pset, play_radii, search_operators,
                                 tree_from_tokens)
    assert play_radii(np.linspace(-1, 1, 5)) == (0.1, 0.2, 0.4, 0.7)
    ops = search_operators(("play", "dengtan"), np.linspace(-1, 1, 5)[None, :])
    pset = make_pset(operators=ops)
    tree = tree_from_tokens(["mul", "y[k-1]", "q1", "Play@0.2", "u[k-1]"], pset)
    assert str(Decoder().decode(tree)) == "y[k-1]*Play(u[k-2],0.2)"
    # an operator's argument is u[k-1] alone: no back-shift inside it
    with pytest.raises(ValueError, match="not allowed where OperatorArg_u"):
        tree_from_tokens(["Play@0.2", "q1", "u[k-1]"], pset)
    tree = tree_from_tokens(["q2", "DengTan", "u[k-1]"], pset)
    assert str(Decoder().decode(tree)) == "DengTan(u[k-3])"
    # u[k-1] as a Φ-function's argument, where the operator's argument
    # (a subtype of the input lag) is listed too: read back as the input lag
    # (a checkpoint of a search with Φ and operators was refused before)
    phi = make_pset(use_phi=True, operators=ops)
    tokens = ["Phi1", "u[k-1]", "q1", "u[k-1]"]
    tree = tree_from_tokens(tokens, phi)
    assert [n.name for n in tree] == tokens and tree[1].ret.__name__ == "InputLag"
    # control: without operators the set is the Φ-only one, node for node
    base = make_pset()
    assert [p.name for t in base.primitives for p in base.primitives[t]] == \
        [p.name for t in make_pset(operators={}).primitives
         for p in make_pset(operators={}).primitives[t]]
    # the plays of all radii are one choice: about as frequent as DengTan
    rng, dec, count = random.Random(0), Decoder(), {"Play": 0, "DengTan": 0}
    for _ in range(300):
        for t in dec.decode_individual(random_individual(pset, rng, 5, 4)):
            for f in t.operator_factors:
                count[f.name] += 1
    assert 0.6 < count["Play"] / count["DengTan"] < 1.6
    with pytest.raises(ValueError, match="operators must name"):
        search_operators(("hysteron",), np.zeros((1, 3)))


def test_operator_stage_adds_plays_to_a_pi_record_not_to_a_linear_one():
    from narx.estimation.fitness import StructureScorer
    from mggp.fit.operator_stage import add_operators, operator_candidates
    rec = operator_record("pi", n=1500, seed=0, snr_db=40)
    start = [parse_term("y[k-1]"), parse_term("u[k-1]")]
    data = as_data(rec.u, rec.y)
    cands = operator_candidates(data, "play,dengtan")
    assert [c.text for c in cands] == ["Play(u[k-1],0.1)", "Play(u[k-1],0.2)",
                                       "Play(u[k-1],0.4)", "Play(u[k-1],0.7)",
                                       "DengTan(u[k-1])"]
    scorer = StructureScorer(data, "ms", window=100, start=16)
    terms, steps = add_operators(scorer, start, cands, max_terms=15)
    added = [s["term"] for s in steps if s["step"] == "add"]
    assert len(added) >= 3 and all(t.startswith("Play(") for t in added)
    assert scorer.score(terms) < 0.1 * scorer.score(start)
    # control: a linear first-order record with the same input gains nothing
    y = np.zeros_like(rec.u)
    for k in range(1, y.size):
        y[k] = 0.9 * y[k - 1] + 0.1 * rec.u[k - 1]
    lin = as_data(rec.u, y + 1e-3 * np.random.default_rng(0).standard_normal(y.size))
    same, none = add_operators(StructureScorer(lin, "ms", window=100, start=16), start,
                               cands, max_terms=15)
    assert none == [] and same == tuple(start)


def test_operator_candidates_name_each_input_with_its_own_radii():
    from narx import Data
    from mggp.fit.operator_stage import operator_candidates
    t = np.linspace(0, 6, 60)
    d = Data(np.c_[np.sin(t), 4 * np.cos(t)], np.sin(t), inputs=("E", "v"), output="f")
    texts = [c.text for c in operator_candidates(d, "play,dengtan")]
    assert texts[:5] == ["Play(E[k-1],0.1)", "Play(E[k-1],0.2)", "Play(E[k-1],0.4)",
                         "Play(E[k-1],0.7)", "DengTan(E[k-1])"]
    assert texts[5:] == ["Play(v[k-1],0.4)", "Play(v[k-1],0.8)", "Play(v[k-1],1.6)",
                         "Play(v[k-1],2.8)", "DengTan(v[k-1])"]


def test_operator_entry_search_or_stage():
    from mggp import MGGPRegressor
    rec = operator_record("pi", n=800, seed=0, snr_db=40)
    kw = dict(operators="play", population=20, generations=2, random_state=1,
              use_phi=True, extend="none")          # the operator stage alone
    stage = MGGPRegressor(**kw).fit(rec.u, rec.y)
    # the search ran without operators: only the stage's additions hold any
    assert stage.operator_steps_ and stage.model_.meta["operator_entry"] == "stage"
    added = {s["term"] for s in stage.operator_steps_ if s["step"] == "add"}
    assert {t for t in stage.model_.term_texts if "Play(" in t} <= added
    assert all("Play(" not in t.text for t in stage.result_.best.terms)
    search = MGGPRegressor(operator_entry="search", **kw).fit(rec.u, rec.y)
    assert search.operator_steps_ is None
    assert any("Play(" in t.text for r in search.result_.pareto for t in r.terms)


def test_fit_with_operators_finds_play_terms(capsys, tmp_path):
    rec = operator_record("pi", n=1500, seed=0, snr_db=40)
    data = tmp_path / "pi.csv"
    np.savetxt(data, np.c_[rec.u, rec.y], delimiter=",", header="u,y", comments="")
    model = tmp_path / "m.json"
    code, out, err = _cli(capsys, "fit", data, "--operators", "play", "--population", "30",
                          "--generations", "3", "--seed", "1", "--quiet", "--out", model)
    assert code == 0, err
    import json
    spec = json.loads(model.read_text())
    assert any("Play(" in t for t in spec["terms"]) and spec["meta"]["operators"] == ["play"]
    code, out, err = _cli(capsys, "fit", data, "--operators", "play,hysteron")
    assert code == 2 and err.startswith("error: --operators")


# ----------------------------------------------- operators of output lags
OUT_TERMS = ("y[k-1]", "Play(y[k-1],0.1)", "u[k-1]", "u[k-1]*Play(y[k-2],0.05)",
             "DengTan(y[k-1])")
OUT_THETA = (0.5, 0.3, 0.2, -0.1, 0.05)


def _window_loop(u, y_meas, s, length, theta=OUT_THETA):
    """Plain-Python window from sample s: the operators run over the measured
    output before s, then over the simulated output (the documented rule)."""
    z = [float(v) for v in y_meas[:s]]
    for k in range(s, min(s + length, len(u))):
        p1 = play_reference(z, 0.1)[k - 1]
        p2 = play_reference(z, 0.05)[k - 2]
        d = deng_tan_reference(z)[k - 1]
        z.append(theta[0] * z[k - 1] + theta[1] * p1 + theta[2] * u[k - 1]
                 + theta[3] * u[k - 1] * p2 + theta[4] * d)
    return np.array(z[s:])


@pytest.mark.parametrize("mode, kw", [("freerun", {}), ("osa", {}), ("ksa", {"k": 4}),
                                      ("ms", {"window": 25})])
def test_output_operators_every_mode_equals_plain_window_loop(mode, kw):
    from narx.simulation.simulate import recursion_windows
    rec = operator_record("backlash", n=150, seed=5, snr_db=30)
    u, y = rec.u, rec.y                      # not the model's output: windows matter
    r = simulate(tuple(parse_term(t) for t in OUT_TERMS), OUT_THETA, as_data(u, y),
                 mode=mode, **kw)
    ref = np.full(u.size, np.nan)
    if mode == "osa":
        for k in range(2, u.size):
            ref[k] = _window_loop(u, y, k, 1)[0]
    else:
        horizon = kw.get("k", kw.get("window"))
        starts, length, wf, _ = recursion_windows(mode, u.size, 2, horizon)
        for s in starts:
            w = _window_loop(u, y, s, length)
            ref[s + wf:s + w.size] = w[wf:]
    ok = np.isfinite(ref)
    assert ok.sum() >= u.size - 6
    np.testing.assert_allclose(r.y_hat[ok], ref[ok], rtol=0, atol=1e-12)
    # control: starting the operators of every window from the simulated
    # output instead (one free run) differs for windowed modes
    if mode in ("ksa", "ms"):
        fr = simulate(tuple(parse_term(t) for t in OUT_TERMS), OUT_THETA, as_data(u, y))
        assert np.abs(fr.y_hat[ok] - ref[ok]).max() > 1e-4


# ------------------------------------------------------------ compensation
def test_compensate_refuses_operator_terms_naming_the_term(capsys, tmp_path):
    from narx.analysis.compensate import RootCompensator
    m = Model(("y[k-1]", "Play(u[k-1],0.3)", "u[k-1]"), theta=(0.5, 0.2, 0.3))
    with pytest.raises(ValueError, match=r"Play\(u\[k-1\],0.3\) cannot be inverted"):
        RootCompensator(m)
    RootCompensator(Model(("y[k-1]", "u[k-1]"), theta=(0.5, 0.3)))    # control
    model, ref = tmp_path / "m.json", tmp_path / "r.csv"
    m.save(str(model))
    np.savetxt(ref, np.sin(np.arange(50) / 5.0), header="r", comments="")
    code, out, err = _cli(capsys, "compensate", model, ref)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "Play(u[k-1],0.3)" in lines[0] \
        and lines[0].startswith("error:")


def test_output_operators_compiled_equals_numpy_loop_and_plugin_runs():
    from narx.simulation.kernels import Plan, run_windows
    from narx.language.memory import OperatorRegistry, default_operators
    rec = operator_record("backlash", n=300, seed=6, snr_db=30)
    terms = tuple(parse_term(t) for t in OUT_TERMS)
    plan = Plan.from_terms(terms, ("u",))
    assert plan.compiled
    data = as_data(rec.u, rec.y)
    P = plan.input_parts(data)
    starts = np.arange(2, 300, 20)
    a, da = run_windows(plan, P, data.U, rec.y, OUT_THETA, starts, 20)
    b, db = run_windows(plan, P, data.U, rec.y, OUT_THETA, starts, 20, force_python=True)
    np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-15)  # sums in another order
    assert not da and not db
    # a plug-in operator of an output runs in the numpy loop: a stop of
    # radius r is the input minus its play, so the model is the same
    reg = default_operators()

    def init(x0, p, init=None):
        return np.array([x0, 0.0])

    def step(s, x, p):
        s[1] = min(p[0], max(-p[0], s[1] + x - s[0]))
        s[0] = x
        return s[1]

    reg.register("StopT", ("r",), init, step, steady=lambda xb, p: (-p[0], p[0]))
    try:
        t2 = tuple(parse_term(t) for t in ("y[k-1]", "StopT(y[k-1],0.1)", "u[k-1]"))
        t3 = tuple(parse_term(t) for t in ("y[k-1]", "Play(y[k-1],0.1)", "u[k-1]"))
        p2 = Plan.from_terms(t2, ("u",))
        assert not p2.compiled
        # y - Play(y) - (y_0 - Play(y)_0) = Stop(y); Play(y)_0 = y_0
        th2, th3 = (0.5, 0.3, 0.2), (0.8, -0.3, 0.2)
        c, _ = run_windows(p2, p2.input_parts(data), data.U, rec.y, th2, starts, 20)
        p3 = Plan.from_terms(t3, ("u",))
        d, _ = run_windows(p3, p3.input_parts(data), data.U, rec.y, th3, starts, 20)
        ok = np.isfinite(c)
        np.testing.assert_allclose(c[ok], d[ok], rtol=0, atol=1e-12)
    finally:
        reg.unregister("StopT")


def test_every_builtin_operator_row_steps_by_its_code():
    from narx.language.memory import OPERATOR_BUILTINS, operator_step
    x = _walk(500, seed=9)
    for op in OPERATOR_BUILTINS:
        params = (0.3,) * len(op.params)
        p = np.asarray(params, dtype=np.float64)
        s1 = op.init(float(x[0]), params)
        s2 = op.init(float(x[0]), params)
        a = [operator_step(op.code, s1, xi, p) for xi in x]
        b = [op.step(s2, xi, p) for xi in x]
        assert a == b and op.builtin
    with pytest.raises(ValueError, match="unknown memory-operator kernel code"):
        operator_step(7, np.zeros(1), 0.0, np.zeros(1))


def test_export_writes_operator_parameters():
    from narx.export import to_latex
    m = Model(("y[k-1]", "Play(u[k-1],0.3)", "DengTan(u[k-2])"), theta=(0.5, 0.2, 0.1))
    tex = to_latex(m)
    assert r"P_{0.3}(u_{k-1})" in tex and r"\mathrm{DengTan}(u_{k-2})" in tex


def test_benchmark_operators_runs_and_tabulates(capsys):
    from benchmarks.operators import main
    assert main(["--cases", "pi", "--seeds", "1", "--population", "10",
                 "--generations", "1", "--max-terms", "4", "--max-height", "3"]) == 0
    out = capsys.readouterr().out
    assert "| pi | RMSE |" in out and "ops/Φ" in out


def test_search_with_bouc_wen_operators_finds_them_on_a_piezo_record():
    """``operators='boucwen'`` in the search's primitive set: on a piezo
    Bouc–Wen record the search keeps Bouc–Wen terms and simulates the tail
    far better than the same search without operators (control); the
    automatic classes offer them in a class of their own, not with the plays."""
    from mggp import MGGPRegressor
    from mggp.fit.choices import search_classes
    from mggp.gp.primitives import bouc_wen_shapes, search_operators
    from narx import Data
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(2000, seed=4)
    data = Data(u, piezo_bouc_wen(u))
    assert search_operators("boucwen", u[None, :])["BoucWen"] == list(bouc_wen_shapes(u))
    # the constant searched in both (not chosen by pilots of 1 generation):
    # the test compares the operators, at a tiny budget
    # the extend stage off: the test compares what the searches find
    kw = dict(population=40, generations=5, random_state=1, use_phi=False, max_height=2,
              constant=True, extend="none")
    bw = MGGPRegressor(operators="boucwen", operator_entry="search", **kw).fit(data)
    plain = MGGPRegressor(operators="none", **kw).fit(data)
    assert any("BoucWen(" in t for t in bw.model_.term_texts)
    e_bw = bw.model_.simulate(data, mode="freerun").rmse
    e_plain = plain.model_.simulate(data, mode="freerun").rmse
    assert e_bw < 0.2 * e_plain, (e_bw, e_plain)
    auto = {c.label: c.operators for c in search_classes(MGGPRegressor())}
    assert auto["operators"] == ("play", "dengtan") and auto["Bouc–Wen"] == ("boucwen",)


def test_an_overflowing_operator_column_scores_inf_without_numpy_warnings():
    """A binary input steps its whole range in one sample; a plug-in
    Bouc–Wen variable of one Euler step a sample (the example of
    register_operator) grows without bound on a stiff shape (β = 9, γ = 0
    per unit of range: each reversal multiplies it by about 9). The
    structure is refused (fitness inf) without numpy warnings on the user's
    terminal; controls: a gentle shape of the plug-in,
    and the built-in BoucWen of that shape (solved exactly, bounded),
    fit on the same record."""
    import warnings

    from narx.records.data import Data
    from narx.estimation.fitness import StructureScorer
    from narx.language.memory import register_operator, unregister_operator
    from narx.language.terms import parse_terms

    def init(x0, p, init=None):
        return np.array([x0, 0.0 if init is None else init])

    def step(s, x, p):
        dx = x - s[0]
        s[1] += dx - p[0] * abs(dx) * s[1] - p[1] * dx * abs(s[1])
        s[0] = x
        return s[1]

    rng = np.random.default_rng(3)
    u = (rng.random(1000) > 0.5).astype(float)
    y = np.convolve(u, [0.0, 0.5, 0.25])[:u.size]
    register_operator("EulerBW", ("beta", "gamma"), init, step,
                      steady=lambda xbar, p: (-np.inf, np.inf))
    try:
        sc = StructureScorer(Data(u, y), "ms", start=4)
        stiff = parse_terms(["y[k-1]", "EulerBW(u[k-1],9,0)",
                             "u[k-1]*EulerBW(u[k-1],9,0)"])
        gentle = parse_terms(["y[k-1]", "EulerBW(u[k-1],0.1,0.1)"])
        exact = parse_terms(["y[k-1]", "BoucWen(u[k-1],9,0)",
                             "u[k-1]*BoucWen(u[k-1],9,0)"])
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with np.errstate(over="ignore", invalid="ignore"):
                col = get_operator("EulerBW").sequence(u, (9.0, 0.0))
            assert not np.all(np.abs(col) < 1e100)                  # it overflows
            assert sc.score(stiff) == np.inf
            assert np.isfinite(sc.score(gentle))
            assert np.isfinite(sc.score(exact))
    finally:
        unregister_operator("EulerBW")
