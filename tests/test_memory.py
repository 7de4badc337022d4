"""Memory operators: play, Deng-Tan, plug-in registry, steady rule, systems."""
import math

import numpy as np
import pytest

from narx.memory import (DENG_TAN_DEPTH, OperatorRegistry, deng_tan,
                         deng_tan_reference, deng_tan_state, deng_tan_step,
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
