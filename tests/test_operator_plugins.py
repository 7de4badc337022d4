"""A memory operator registered by the user enters the structure search.

The operator table (:data:`narx.language.memory.OPERATOR_BUILTINS` and the plug-ins
of :func:`narx.language.memory.register_operator`) names every operator the search
offers and gives its parameter grid: a toy *stop* operator (the
elastic-plastic complement of a play), registered here with a grid of
radii, is searched by name, with ``MGGPRegressor(operators=[...])`` in both
operator-entry modes and with ``mggp fit --operators stop`` after
``--phi-module`` registers it. On a record generated with it the stop of
the generating radius is found; on a linear record (control) it is not
taken.
"""
import json

import numpy as np
import pytest

from mggp import MGGPRegressor
from mggp.cli.app import main
from narx import Data
from narx.language.memory import default_operators, get_operator, register_operator
from narx.systems import training_input

#: the stop radii the search offers, as fractions of the input's range
STOP_FRACTIONS = (0.05, 0.15)


def stop_init(x0, p, init=None):
    return np.array([float(x0), 0.0 if init is None else float(init)])


def stop_step(s, x, p):
    """Stop of radius r: s_k = clip(s_{k-1} + x_k − x_{k-1}, −r, r)."""
    s[1] = min(p[0], max(-p[0], s[1] + x - s[0]))
    s[0] = x
    return s[1]


def stop_search(span):
    return [(float(f"{f * span:.2g}"),) for f in STOP_FRACTIONS]


def register_stop():
    register_operator("Stop", ("r",), stop_init, stop_step, lambda xb, p: (-p[0], p[0]),
                      search=stop_search, search_words="stops of radii 0.05, 0.15 × the "
                      "input range", overwrite=True)


@pytest.fixture
def stop():
    register_stop()
    yield get_operator("Stop")
    if "Stop" in default_operators():
        default_operators().unregister("Stop")


N = 1000
U = training_input(N, dt=1e-2, amplitude=1.0, bandwidth=1.0, seed=3)


def record(kind):
    """y_k = 0.6 y_{k-1} + 2 Stop(u[k-1], r) (r: the larger radius of the
    grid) or, the control, + 0.8 u[k-1]; output noise 0.002; the Stop
    term's text."""
    r = stop_search(np.ptp(U))[1][0]
    x = get_operator("Stop").sequence(U, (r,)) * 2.5 if kind == "stop" else U
    y = np.zeros(N)
    for k in range(1, N):
        y[k] = 0.6 * y[k - 1] + 0.8 * x[k - 1]
    y += 0.002 * np.random.default_rng(1).normal(size=N)
    return Data(U, y), f"Stop(u[k-1],{r:g})"


KW = dict(use_phi=False, constant=False, population=30, generations=4, max_height=2,
          max_terms=4, random_state=0)


@pytest.mark.parametrize("entry", ["stage", "search"])
def test_a_registered_operator_is_found_where_it_acts_and_only_there(stop, entry):
    data, term = record("stop")
    m = MGGPRegressor(operators=["Stop"], operator_entry=entry, **KW).fit(data)
    assert term in m.model_.term_texts, m.model_.term_texts
    control, _ = record("linear")
    c = MGGPRegressor(operators=["Stop"], operator_entry=entry, **KW).fit(control)
    assert not any(t.startswith("Stop(") for t in c.model_.term_texts), c.model_.term_texts
    assert "u[k-1]" in c.model_.term_texts


def test_the_grid_and_names_come_from_the_table(stop):
    from mggp.gp.primitives import operator_choices, operator_names, search_operators
    assert operator_choices()["stop"] == "Stop"
    assert operator_names("Play, STOP") == ("play", "stop")
    assert search_operators("stop", U[None, :]) == {"Stop": stop_search(np.ptp(U))}
    assert stop.search_grid(0.0) == ()                       # a constant input: none


def test_an_operator_without_a_grid_is_refused_by_name():
    register_operator("Hyst", ("a",), stop_init, stop_step, lambda xb, p: (-1.0, 1.0))
    try:
        data = record("linear")[0]
        with pytest.raises(ValueError, match="operator Hyst has parameters .a. and no "
                                             "search grid"):
            MGGPRegressor(operators="hyst", **KW).fit(data)
        # control: an unknown name is another error, listing the registered ones
        with pytest.raises(ValueError, match="names among play, dengtan, boucwen, hyst "
                                             r"\(a list, or comma-separated text\), got 'nope'"):
            MGGPRegressor(operators="nope", **KW).fit(data)
    finally:
        default_operators().unregister("Hyst")


def test_cli_fit_searches_an_operator_that_phi_module_registers(stop, tmp_path, capsys):
    data, term = record("stop")
    default_operators().unregister("Stop")              # the command registers it
    csv = tmp_path / "d.csv"
    rows = zip(data.U[0].tolist(), data.y.tolist())
    csv.write_text("u,y\n" + "".join(f"{a!r},{b!r}\n" for a, b in rows))
    plugin = tmp_path / "stop_plugin.py"
    plugin.write_text("from test_operator_plugins import register_stop\nregister_stop()\n")
    out = tmp_path / "m.json"
    opts = ["--operators", "stop", "--no-phi", "--no-constant", "--population", "30",
            "--generations", "4", "--max-height", "2", "--max-terms", "4", "--seed", "0",
            "--out", str(out)]
    # control: without the plug-in the name is unknown, one error line
    assert main(["fit", str(csv), *opts]) == 2
    err = capsys.readouterr().err
    assert "--operators must be" in err and "got stop" in err and not out.exists()
    assert main(["--phi-module", str(plugin), "fit", str(csv), *opts]) == 0
    assert term in json.loads(out.read_text())["terms"]
