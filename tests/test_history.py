"""Records that start in motion: the memory operators' history.

A record cut from a longer run starts with its operators in a state the
record does not hold. ``history`` names the path the signals arrived by;
``history='estimate'`` picks it from the record's first samples.
"""
import pickle

import numpy as np
import pytest

from narx import Data
from narx.language.memory import (HISTORIES, bouc_wen, get_operator, history_prefix, play)
from narx.model import Model
from narx.simulation.simulate import estimate_history


def _sine(t, phase=0.0):
    return np.sin(2 * np.pi * t + phase)


def test_history_prefix_paths():
    x = np.array([0.0, 1.0, 2.0, 1.0])
    assert history_prefix(x, "rest").size == 0
    assert history_prefix(x, "rising").tolist() == [2.0, 1.0, 0.0]
    assert history_prefix(x, "falling").tolist() == [0.0, 1.0, 2.0, 1.0]
    assert history_prefix(np.full(5, 3.0), "rising").size == 0     # no motion, no path
    with pytest.raises(ValueError, match="history must be one of rest, rising, falling, "
                                         "got 'up'"):
        history_prefix(x, "up")


@pytest.mark.parametrize("r", [0.05, 0.3, 0.6])
def test_rising_is_the_state_of_a_periodic_record_cut_while_rising(r):
    """Cut a sine that has run for periods while it rises: the play's
    state is the one 'rising' gives, and 'rest' misses it by about r."""
    t = np.arange(0, 6, 0.002)
    x = _sine(t, 0.3)
    cut = 1500                       # three periods in, the sine rising
    whole = play(x, r)
    op = get_operator("Play")
    assert np.allclose(op.sequence(x[cut:], (r,), history="rising"), whole[cut:])
    assert abs(op.sequence(x[cut:], (r,))[0] - whole[cut]) > 0.5 * r
    falling_cut = 1750               # past the crest: the sine falls
    assert np.allclose(op.sequence(x[falling_cut:], (r,), history="falling"),
                       whole[falling_cut:])


def test_states_after_follow_the_history():
    x = _sine(np.arange(0, 2, 0.01), 0.5)
    op = get_operator("BoucWen")
    seq = op.sequence(x, (0.8, 0.2), history="falling")
    st = op.states_after(x, (0.8, 0.2), np.array([1, 50]), "falling")
    assert st[0, 1] == pytest.approx(seq[0]) and st[1, 1] == pytest.approx(seq[49])
    assert not np.allclose(seq, bouc_wen(x, 0.8, 0.2))


def test_data_history_is_kept_by_copies_from_the_start_only():
    d = Data(np.arange(10.0), np.arange(10.0), history="rising")
    assert d.history == "rising" and "history='rising'" in repr(d)
    assert d.slice(0, 5).history == "rising" and d.slice(2).history == "rest"
    assert pickle.loads(pickle.dumps(d)).history == "rising"
    assert d.with_history("rest").history == "rest" and d.history == "rising"
    with pytest.raises(ValueError, match="got 'sideways'"):
        Data(np.arange(3.0), history="sideways")


def _piezo_like(u, history="rest"):
    """y[k] = 0.5 y[k-1] + 0.4 u[k-1] + 0.6 Play(u[k-1], 0.4): a model with
    a play of the input, simulated from ``history``."""
    m = Model(["y[k-1]", "u[k-1]", "Play(u[k-1],0.4)"], [0.5, 0.4, 0.6])
    d = Data(u, np.zeros(u.size))
    return m, m.simulate(d, history=history, y0=[0.0]).y_hat


def test_estimate_finds_a_record_cut_in_motion_and_rest_for_one_at_rest():
    """The effect: a record cut from a long run while rising (and one while
    falling) gets 'rising' ('falling') and its free run matches the long
    run's; the control: a record whose system started at rest gets 'rest'."""
    rng = np.random.default_rng(3)
    t = np.arange(0, 8, 0.005)
    u = 2.0 * _sine(t, 0.2) + 0.5 * _sine(3.1 * t)
    m, y_long = _piezo_like(u)
    y_long = y_long + 0.01 * rng.standard_normal(u.size)
    for cut, want in ((800, "rising"), (880, "falling")):
        assert np.sign(u[cut + 1] - u[cut]) == (1 if want == "rising" else -1)
        rec = Data(u[cut:], y_long[cut:])
        h, scores = estimate_history(m.terms, m.theta, rec)
        assert h == want, scores
        est = m.simulate(rec, history="estimate")
        rest = m.simulate(rec)
        assert est.history == want and rest.history == "rest"
        assert est.rmse < 0.5 * rest.rmse
        np.testing.assert_array_equal(est.y_hat, m.simulate(rec, history=want).y_hat)
    # control: the system started at rest with the record, the input moving
    rec = Data(u, y_long)
    assert abs(u[1] - u[0]) > 0.01
    assert estimate_history(m.terms, m.theta, rec)[0] == "rest"


def test_estimate_is_rest_without_operators_or_output():
    m = Model(["y[k-1]", "u[k-1]"], [0.5, 1.0])
    u = _sine(np.arange(0, 2, 0.01))
    assert estimate_history(m.terms, m.theta, Data(u, u)) == ("rest", {})
    mp = Model(["y[k-1]", "Play(u[k-1],0.2)"], [0.5, 1.0])
    assert estimate_history(mp.terms, mp.theta, Data(u)) == ("rest", {})
    assert set(estimate_history(mp.terms, mp.theta, Data(u, u))[1]) == set(HISTORIES)


def test_output_operators_follow_the_history_in_free_run():
    """A play of the output lag is started by the history too: the compiled
    kernel and the Python reference agree on every history."""
    from narx.simulation.simulate import simulate
    m = Model(["y[k-1]", "u[k-1]", "Play(y[k-1],0.3)"], [0.4, 0.5, 0.3])
    u = _sine(np.arange(0, 4, 0.01), 0.7)
    y = m.simulate(Data(u, np.zeros(u.size)), y0=[0.0]).y_hat
    d = Data(u, y)
    runs = {h: simulate(m.terms, m.theta, d, "freerun", history=h).y_hat for h in HISTORIES}
    for h in HISTORIES:
        ref = simulate(m.terms, m.theta, d, "freerun", history=h, force_python=True).y_hat
        assert np.allclose(runs[h], ref)
    assert not np.allclose(runs["rest"], runs["rising"])


def test_cli_simulate_says_which_history_started_the_operators(capsys, tmp_path):
    """``mggp simulate`` estimates the history by default and says so; with
    ``--history rest`` the same record simulates worse and no line is printed."""
    from mggp.cli.app import main
    t = np.arange(0, 8, 0.005)
    u = 2.0 * _sine(t, 0.2) + 0.5 * _sine(3.1 * t)
    m, y = _piezo_like(u)
    path = tmp_path / "m.json"
    m.save(path)
    csv = tmp_path / "rec.csv"
    np.savetxt(csv, np.column_stack([u[800:], y[800:]]), delimiter=",", header="u,y",
               comments="")
    rmse = {}
    for extra in ([], ["--history", "rest"]):
        assert main(["simulate", str(path), str(csv), *extra]) == 0
        out = capsys.readouterr().out
        rmse[bool(extra)] = float(out.split("RMSE")[1].split()[0])
        said = "memory operators started as if the signals arrived rising" in out
        assert said == (not extra), out
    assert rmse[False] < 0.1 * rmse[True]
    # bad input: an unknown history is one error line and exit code 2
    assert main(["simulate", str(path), str(csv), "--history", "sideways"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and "sideways" in err[0], err
