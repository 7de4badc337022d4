"""The memory operators' parameters estimated by free-run error
(narx.refine.refine_operators, mggp.fit.choices.operator_params_choice,
``operator_params='auto'``): a play whose radius lies between the search's
grid values gets its radius back; a structure whose radius is already the
system's keeps it, and a structure without operators is left alone."""
import numpy as np
import pytest

import narx
from mggp import MGGPRegressor
from mggp.fit.choices import operator_params_choice
from mggp.fit.extrapolation import StressCheck
from narx.language.memory import bouc_wen, play
from narx.records.data import Data
from narx.refine import operator_groups, refine_operators

R_TRUE = 0.3


def play_record(n=3000, seed=0, noise=0.01):
    """y = 0.7 y[k-1] + 0.2 u[k-1] + 0.5 Play(u[k-1], 0.3), a sine of slowly
    varying amplitude, white output noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n)
    u = np.sin(2 * np.pi * t / 200) * (1 + 0.5 * np.sin(2 * np.pi * t / n))
    p = play(u, R_TRUE)
    x = np.zeros(n)
    for k in range(1, n):
        x[k] = 0.7 * x[k - 1] + 0.2 * u[k - 1] + 0.5 * p[k - 1]
    return Data(u, x + noise * rng.standard_normal(n))


def test_the_radius_is_recovered_between_grid_values():
    d = play_record()
    m = narx.Model(["y[k-1]", "u[k-1]", "Play(u[k-1],0.2)"]).fit(d)
    r = refine_operators(m, d)
    assert r.improved and r.cost_after < 0.1 * r.cost_before
    (f,) = r.model.terms[2].operator_factors
    assert abs(f.params[0] - R_TRUE) < 0.01 * R_TRUE
    assert r.moved == {"Play(u,0.2)": f"Play(u,{f.params[0]:g})"}
    assert r.model.meta["operators_refined"]["improved"]


def test_the_true_radius_stays():
    """Control: started at the system's radius, the estimate stays within 1 %."""
    d = play_record()
    m = narx.Model(["y[k-1]", "u[k-1]", f"Play(u[k-1],{R_TRUE})"]).fit(d)
    r = refine_operators(m, d)
    (f,) = r.model.terms[2].operator_factors
    assert abs(f.params[0] - R_TRUE) < 0.01 * R_TRUE


def test_lags_of_one_play_move_together_and_zero_parameters_stay():
    terms = narx.Model(["Play(u[k],0.2)", "Play(u[k-1],0.2)", "Play(u[k-1],0.4)",
                        "BoucWen(u[k-1],2,0)", "DengTan(u[k-1])", "u[k-1]"]).terms
    assert operator_groups(terms) == [("Play", "u", (0.2,)), ("Play", "u", (0.4,)),
                                      ("BoucWen", "u", (2.0, 0.0))]
    rng = np.random.default_rng(1)
    u = np.cumsum(rng.standard_normal(2000)) * 0.1
    y = 1.0 * u + 0.8 * bouc_wen(u, 3.0, 0.0)
    r = refine_operators(narx.Model(["u[k]", "BoucWen(u[k],2,0)"]).fit(u, y), u, y)
    (f,) = r.model.terms[1].operator_factors
    assert f.params[1] == 0.0 and abs(f.params[0] - 3.0) < 0.03


def test_no_operator_is_an_error():
    d = play_record(n=500)
    m = narx.Model(["y[k-1]", "u[k-1]"]).fit(d)
    with pytest.raises(ValueError, match="no memory operator"):
        refine_operators(m, d)


def test_the_choice_estimates_an_off_grid_radius():
    d = play_record(seed=2)
    c, terms = operator_params_choice(("y[k-1]", "u[k-1]", "Play(u[k-1],0.2)"), d)
    assert c.value == "freerun" and c.why.startswith("operator parameters estimated")
    assert c.figures["heldout_rmse_estimated"] < c.figures["heldout_rmse_grid"]
    (f,) = [f for t in terms for f in t.operator_factors]
    assert abs(f.params[0] - R_TRUE) < 0.02 * R_TRUE


def test_the_choice_leaves_a_structure_without_operators():
    """Control: nothing to estimate, the structure comes back as it was."""
    d = play_record(seed=3)
    c, terms = operator_params_choice(("y[k-1]", "u[k-1]"), d)
    assert c.value is None and not c.figures and [str(t) for t in terms] == ["y[k-1]",
                                                                           "u[k-1]"]


def test_the_fit_reports_the_choice_and_none_keeps_the_grid():
    d = play_record(seed=4, n=1500)
    kw = dict(population=30, generations=4, random_state=0, operators="play", use_phi=False,
              extend="none", size="search")
    on = MGGPRegressor(**kw).fit(d)
    off = MGGPRegressor(operator_params="none", **kw).fit(d)
    grid = {f.params for t in off.get_best().terms for f in t.operator_factors}
    c = on.choices_.get("operator_params")
    if c is None or c["value"] is None:
        pytest.fail(f"no estimate taken on a play record of radius {R_TRUE}: {c}")
    got = {f.params for t in on.get_best().terms for f in t.operator_factors}
    assert got != grid and "operator_params" not in off.choices_


class _FailsEstimate(StressCheck):
    """A stand-in stress test: the grid's structure passes, any fitted
    model (the estimate) diverges."""

    def __init__(self):
        pass

    def __call__(self, terms):
        return ""

    def model_verdict(self, model):
        return "diverges when the input is held"


def test_an_estimate_that_fails_the_stress_inputs_is_not_taken():
    d = play_record(seed=2)
    grid = ("y[k-1]", "u[k-1]", "Play(u[k-1],0.2)")
    c, terms = operator_params_choice(grid, d, check=_FailsEstimate())
    assert c.value is None and "diverges when the input is held" in c.why
    assert [str(t) for t in terms] == list(grid)
