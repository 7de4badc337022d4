"""Pareto front of a search: table, best row, exports (built by hand, no search)."""
import math

import numpy as np
import pytest

from mggp.gp.pareto import ParetoFront
from narx import Model


def front():
    return ParetoFront([
        {"complexity": 3, "loss": 0.01, "terms": ["y[k-1]", "u[k-1]", "u[k-2]"],
         "theta": [0.5, 1.0, 0.2]},
        {"complexity": 1, "loss": 1.0, "terms": ["y[k-1]"], "theta": [0.9]},
        {"complexity": 2, "loss": 0.02, "terms": ["y[k-1]", "u[k-1]"], "theta": [0.5, 1.0]},
        # dominated: more terms, no lower loss
        {"complexity": 4, "loss": 0.01, "terms": ["y[k-1]", "u[k-1]", "u[k-2]", "u[k-3]"],
         "theta": [0.5, 1.0, 0.2, 0.0]},
    ])


def test_rows_sorted_dominated_dropped_and_scored():
    f = front()
    assert [r["complexity"] for r in f] == [1, 2, 3]
    assert f[0]["score"] == 0.0
    assert f[1]["score"] == pytest.approx(math.log(1.0 / 0.02))
    assert f[2]["score"] == pytest.approx(math.log(2.0))
    assert f[1]["equation"] == "y[k] = 0.5*y[k-1] + 1*u[k-1]"
    text = repr(f)
    assert "complexity" in text and "0.5*y[k-1] + 1*u[k-1]" in text
    assert f.to_markdown().count("\n") == 4


def test_get_best_by_loss_and_by_score():
    f = front()
    best = f.get_best()
    assert isinstance(best, Model) and best.term_texts == ["y[k-1]", "u[k-1]", "u[k-2]"]
    np.testing.assert_array_equal(best.theta, [0.5, 1.0, 0.2])
    # the knee: the second row buys a 50x lower loss with one term
    assert f.get_best("score").term_texts == ["y[k-1]", "u[k-1]"]
    # within 1.5x of the best loss only the last row is eligible
    assert f.get_best("score", tolerance=1.5).n_terms == 3
    with pytest.raises(ValueError, match="criterion must be 'loss' or 'score'"):
        f.get_best("aic")
    bic = ParetoFront([{"complexity": 1, "loss": -10.0, "terms": ["y[k-1]"], "theta": [0.9]},
                       {"complexity": 2, "loss": -30.0, "terms": ["y[k-1]", "u[k-1]"],
                        "theta": [0.5, 1.0]}])
    assert bic.get_best().n_terms == 2 and [r["score"] for r in bic] == [0.0, 0.0]
    with pytest.raises(ValueError, match="needs positive losses"):
        bic.get_best("score")


def test_exports_and_errors():
    f = front()
    assert "u_{k-2}" in f.to_latex() and f.to_latex(0).startswith("y_{k} = 0.9")
    sympy = pytest.importorskip("sympy")
    assert f.to_sympy(0) == sympy.Float(0.9) * sympy.Symbol("y[k-1]")
    with pytest.raises(IndexError, match="row must be in"):
        f.model(7)
    g = ParetoFront([{"complexity": 1, "loss": 1.0, "terms": ["y[k-1]"], "theta": None}])
    assert g[0]["equation"] == "y[k-1]"
    with pytest.raises(ValueError, match="no fitted row"):
        g.get_best()
    with pytest.raises(ValueError, match="empty"):
        ParetoFront().model(0)


def test_search_front_carries_the_search_parameters():
    from mggp import MGGPRegressor
    from narx.systems.testsystems import system_by_name
    d = system_by_name("S6", n=500, seed=0)
    est = MGGPRegressor(fitness="pem", population=60, generations=8, max_terms=5,
                        max_height=3, use_phi=False, random_state=0).fit(d.u, d.y)
    f = est.pareto_front_
    assert len(f) >= 2
    losses = [r["loss"] for r in f]
    assert all(a > b for a, b in zip(losses, losses[1:]))
    last = f.get_best()
    # the front's θ gives the loss it reports (one-step MSE on the scored rows)
    from mggp.gp.primitives import max_lag_for_height
    s = max_lag_for_height(3)                  # the rows the search scores
    r = last.simulate(d.u, d.y, mode="osa")
    assert np.mean((d.y[s:] - r.y_hat[s:]) ** 2) == pytest.approx(f[-1]["loss"], rel=1e-9)


def test_sympy_export_evaluates_to_the_model_prediction():
    sympy = pytest.importorskip("sympy")
    from conftest import MODEL19_TERMS, MODEL19_THETA
    from narx.systems import piezo_bouc_wen, sine_input
    m = Model(list(MODEL19_TERMS), theta=list(MODEL19_THETA))
    expr = m.to_sympy()
    syms = sorted(expr.free_symbols, key=str)
    f = sympy.lambdify(syms, expr, modules=[{"Phi1": lambda a, b: a - b,
                                             "Phi2": lambda a, b: np.sign(a - b)}, "numpy"])
    _, u = sine_input()
    y = piezo_bouc_wen(u)
    osa = m.simulate(u, y, mode="osa").y_hat
    for k in (100, 777, 2500):
        vals = {"u": u, "y": y}
        args = [vals[str(s)[0]][k - int(str(s)[4:-1])] for s in syms]   # 'u[k-3]'
        assert f(*args) == pytest.approx(osa[k], rel=1e-12, abs=1e-12)


def test_equation_writes_a_leading_negative_coefficient_as_a_number():
    """'y[k] = -0.5*y[k-1] + ...', not 'y[k] = - 0.5*y[k-1]'; the
    following terms keep their spaced signs."""
    from narx import Model
    assert Model(["y[k-1]", "u[k-1]"], [-0.5, 0.3]).equation() == \
        "y[k] = -0.5*y[k-1] + 0.3*u[k-1]"
    assert Model(["y[k-1]", "u[k-1]"], [0.5, -0.3]).equation() == \
        "y[k] = 0.5*y[k-1] - 0.3*u[k-1]"
