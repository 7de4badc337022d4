"""Simulation-error refinement of θ (narx.refine) and its wiring."""
import numpy as np
import pytest

import narx
from narx.refine import refine


def first_order(noise, seed=0, n=5000):
    """y[k] = 0.95 y[k-1] + 0.5 u[k-1]; the output measured with white noise."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1, 1, n // 20), 20)
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.95 * y[k - 1] + 0.5 * u[k - 1]
    return u, y, y + (rng.normal(0, noise * y.std(), n) if noise else 0.0)


@pytest.mark.parametrize("mode", ["freerun", "ms"])
def test_refinement_removes_the_noise_bias_of_least_squares(mode):
    u, y, ym = first_order(0.1)
    m = narx.Model(["y[k-1]", "u[k-1]"]).fit(u, ym)
    truth = np.array([0.95, 0.5])
    assert np.max(np.abs(m.theta - truth)) > 0.01             # LS is biased
    r = refine(m, u, ym, mode=mode, window=100)
    assert r.improved and r.cost_after < r.cost_before
    assert np.max(np.abs(r.model.theta - truth)) < 0.002
    err = lambda mm: np.mean((mm.simulate(u, y).y_hat - y)[1:] ** 2)   # noqa: E731
    assert err(r.model) < err(m) / 100
    assert r.model.meta["refined"]["mode"] == mode
    assert m.theta[1] != r.model.theta[1]                     # the model itself is kept


def test_noise_free_data_leave_theta_where_it_is():
    u, y, _ = first_order(0.0)
    m = narx.Model(["y[k-1]", "u[k-1]"]).fit(u, y)
    r = refine(m, u, y, mode="freerun")
    np.testing.assert_allclose(r.model.theta, [0.95, 0.5], atol=1e-9)


def test_cls_constraints_are_kept(piezo_validation):
    """A CLS model keeps its continuum of steady states (Σ_y = 1, Σ_u = 0)."""
    u, y = piezo_validation
    rng = np.random.default_rng(1)
    ym = y + rng.normal(0, 0.01 * np.ptp(y), y.size)
    terms = ["y[k-1]", "u[k-1]", "Phi1(u[k-1],u[k-2])",
             "y[k-1]*Phi2(u[k-1],u[k-2])*Phi1(u[k-1],u[k-2])",
             "u[k-1]*Phi2(u[k-1],u[k-2])*Phi1(u[k-1],u[k-2])"]
    m = narx.Model(terms).fit(u, ym, constraints="steady-state")
    r = refine(m, u, ym, mode="ms", window=200)
    assert r.cost_after <= r.cost_before
    sums = r.model.cluster_sums()
    assert sums["y"] == pytest.approx(1.0, abs=1e-9) and sums["u"] == pytest.approx(0, abs=1e-9)


def test_refine_refuses_what_it_cannot_do():
    u, y, ym = first_order(0.1)
    m = narx.Model(["y[k-1]", "u[k-1]"]).fit(u, ym)
    with pytest.raises(ValueError, match="mode must be 'ms' or 'freerun'"):
        refine(m, u, ym, mode="osa")
    with pytest.raises(ValueError, match="window must be an integer >= 1"):
        refine(m, u, ym, mode="ms", window=0)
    noisy = narx.Model(["y[k-1]", "u[k-1]", "e[k-1]"]).fit(u, ym)
    with pytest.raises(ValueError, match="noise terms"):
        refine(noisy, u, ym)


def test_estimator_and_cli_refine(tmp_path, capsys):
    from mggp import MGGPRegressor
    from mggp.cli.app import main
    u, y, ym = first_order(0.1)
    kw = dict(population=20, generations=2, use_phi=False, max_lag=1, max_degree=1,
              random_state=0)
    plain = MGGPRegressor(refine="none", extend="none", **kw).fit(u, ym)  # no extension's θ
    est = MGGPRegressor(refine="freerun", **kw).fit(u, ym)
    assert plain.refinement_ is None and est.refinement_.improved
    # refine='auto' finds the held-out gain under 10 % output noise
    auto = MGGPRegressor(refine="auto", **kw).fit(u, ym)
    assert auto.choices_["refine"]["value"] == "freerun" and auto.refinement_.improved
    err = lambda mm: np.mean((mm.simulate(u, y).y_hat - y)[1:] ** 2)   # noqa: E731
    assert err(est.model_) < err(plain.model_)
    assert est.model_.meta["refine"] == "freerun"
    with pytest.raises(ValueError, match="refine must be one of"):
        MGGPRegressor(refine="osa", **kw).fit(u, ym)
    csv = tmp_path / "d.csv"
    np.savetxt(csv, np.c_[u, ym], delimiter=",", header="u,y", comments="")
    assert main(["estimate", str(csv), "--terms", "y[k-1]", "u[k-1]", "--refine",
                 "freerun"]) == 0
    out = capsys.readouterr().out
    assert "refined by freerun simulation error: MSE" in out and "0.95" in out


def test_a_cls_model_loaded_from_a_file_keeps_its_constraints(tmp_path, piezo_validation):
    from narx.analysis.steady import steady_state_constraints
    u, y = piezo_validation
    ym = y + np.random.default_rng(2).normal(0, 0.01 * np.ptp(y), y.size)
    terms = ["y[k-1]", "u[k-1]", "Phi1(u[k-1],u[k-2])",
             "y[k-1]*Phi2(u[k-1],u[k-2])*Phi1(u[k-1],u[k-2])"]
    narx.Model(terms).fit(u, ym, constraints="steady-state").save(tmp_path / "c.json")
    loaded = narx.load_model(tmp_path / "c.json")
    assert loaded.fit_info_ is None
    r = refine(loaded, u, ym, mode="freerun")
    cons = steady_state_constraints(loaded.terms)
    assert np.max(np.abs(cons.S @ r.model.theta - cons.c)) < 1e-9
    if r.improved:
        assert r.model.meta["estimation"] == "cls+refined-freerun"


def test_a_refit_names_its_own_method(tmp_path, piezo_validation):
    """A model fitted by LS and then refitted by CLS is a CLS model (its
    file says so, and refine keeps its constraints after loading); refitted
    by LS again, it is an LS model that refine may change freely. Before,
    the first fit's method stayed in meta['estimation']."""
    from narx.analysis.steady import steady_state_constraints
    u, y = piezo_validation
    ym = y + np.random.default_rng(2).normal(0, 0.01 * np.ptp(y), y.size)
    terms = ["y[k-1]", "u[k-1]", "Phi1(u[k-1],u[k-2])",
             "y[k-1]*Phi2(u[k-1],u[k-2])*Phi1(u[k-1],u[k-2])"]
    m = narx.Model(terms).fit(u, ym)
    assert m.meta["estimation"] == "ls"
    m.fit(u, ym, constraints="steady-state")
    assert m.meta["estimation"] == "cls"
    m.save(tmp_path / "c.json")
    r = refine(narx.load_model(tmp_path / "c.json"), u, ym, mode="ms", window=100)
    cons = steady_state_constraints(m.terms)
    assert np.max(np.abs(cons.S @ r.model.theta - cons.c)) < 1e-9
    m.fit(u, ym)                                   # control: LS again, refine runs
    assert m.meta["estimation"] == "ls"
    refine(m, u, ym, mode="ms", window=100)


def test_a_diverging_start_is_refused_and_noise_terms_warned(capsys, tmp_path):
    from mggp import MGGPRegressor
    from mggp.cli.app import main
    u, y, ym = first_order(0.1)
    with pytest.raises(ValueError, match="freerun simulation diverges"):
        refine(narx.Model(["y[k-1]", "u[k-1]"], [1.5, 0.1]), u, ym, mode="freerun")
    with pytest.warns(UserWarning, match="refine='ms' is not applied: the model has noise"):
        MGGPRegressor(refine="ms", noise_lags=1, population=10, generations=1,
                      use_phi=False, max_lag=1, random_state=0).fit(u, ym)
    csv = tmp_path / "d.csv"
    np.savetxt(csv, np.c_[u, ym], delimiter=",", header="u,y", comments="")
    assert main(["estimate", str(csv), "--terms", "y[k-1]", "u[k-1]", "--refine", "freerun",
                 "--refine-window", "7"]) == 2
    assert "--refine-window applies to --refine ms only" in capsys.readouterr().err
    assert main(["fit", str(csv), "--fitness", "pem", "--k", "5", "--refine", "ms",
                 "--population", "10", "--generations", "1"]) == 2
    assert "--k applies to --fitness ksa only" in capsys.readouterr().err
