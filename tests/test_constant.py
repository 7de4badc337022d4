"""``constant=True`` / ``mggp fit --constant``: every structure holds the
constant term ``1`` (an intercept), for outputs that rest at an offset."""
import json

import numpy as np
import pytest

from mggp import MGGPRegressor

from conftest import first_order_record

KW = dict(fitness="pem", criterion="bic", population=120, generations=25, max_terms=5,
          max_height=2, use_phi=False, prune="t", max_degree=2, random_state=3)


def affine_record(n=500, seed=0):
    """y = 0.5 + 0.6 y[k-1] + 0.4 u[k-1] + e: at rest y = 1.25 + u, off zero."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, n)
    e = 0.01 * rng.standard_normal(n)
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.5 + 0.6 * y[k - 1] + 0.4 * u[k - 1] + e[k]
    return u, y


def test_intercept_is_recovered_and_needed():
    u, y = affine_record()
    est = MGGPRegressor(constant=True, **KW).fit(u, y)
    assert sorted(est.model_.term_texts) == ["1", "u[k-1]", "y[k-1]"]
    theta = dict(zip(est.model_.term_texts, est.model_.theta))
    assert theta["1"] == pytest.approx(0.5, abs=0.02)
    assert est.model_.meta["constant"] is True
    # every structure scored holds it: the whole Pareto front
    assert len(est.pareto_front_) and all("1" in row["terms"] for row in est.pareto_front_)
    # control: without it the search cannot express the offset; the free
    # run of its best structure is over twice as far off on the same record
    # (θ by LS: a free-run refit of y[k-1]² can mimic the offset in sample)
    plain = MGGPRegressor(constant=False, **dict(KW, refine="none")).fit(u, y)
    assert "1" not in plain.model_.term_texts
    assert plain.model_.meta["constant"] is False
    assert plain.simulate(u, y).rmse > 2 * est.simulate(u, y).rmse


def test_no_intercept_where_there_is_none():
    """Control: on a record without an offset the constant is offered to
    every structure and pruned by its t-statistic."""
    u, y = first_order_record(500, 0, noise=0.01)
    est = MGGPRegressor(constant=True, **KW).fit(u, y)
    assert "1" not in est.model_.term_texts


def test_constant_must_be_a_bool():
    with pytest.raises(ValueError, match=r"constant must be one of True, False, 'auto', got 'yes'"):
        MGGPRegressor(constant="yes", **KW).fit(*affine_record(100))


@pytest.mark.parametrize("first, then", [(dict(constant=True), {}), ({}, dict(constant=True))])
def test_resume_with_other_constant_setting_is_refused(tmp_path, first, then):
    ck = tmp_path / "ck.json"
    kw = dict(KW, generations=2, population=12)
    MGGPRegressor(checkpoint=ck, **dict(kw, **first)).fit(*affine_record(200))
    with pytest.raises(ValueError, match=r"differs in: context\.constant "):
        MGGPRegressor(checkpoint=ck, resume=True, **dict(kw, generations=4, **then)).fit(
            *affine_record(200))


def test_cli_fit_constant(tmp_path):
    from mggp.cli.app import main
    u, y = affine_record(300)
    csv = tmp_path / "d.csv"
    csv.write_text("u,y\n" + "".join(f"{a},{b}\n" for a, b in zip(u, y)))
    out = tmp_path / "m.json"
    rc = main(["fit", str(csv), "--constant", "--no-phi", "--fitness", "pem", "--population",
               "60", "--generations", "10", "--max-height", "2", "--seed", "1", "--quiet",
               "--out", str(out)])
    assert rc == 0
    doc = json.loads(out.read_text())
    assert "1" in doc["terms"] and doc["meta"]["constant"] is True


def test_progress_counts_the_terms_of_the_scored_structure():
    """The logbook's best_terms (the progress line's 'terms N') counts the
    structure scored, the constant included: the final model's terms when
    no pruning or selection changes it; control: the same search without
    the constant counts one term fewer for the same kind of model."""
    u, y = affine_record()
    kw = dict(KW, prune=None, criterion="mse", size="search")
    est = MGGPRegressor(constant=True, **kw).fit(u, y)
    assert est.logbook_[-1]["best_terms"] == est.model_.n_terms
    assert "1" in est.model_.term_texts
    plain = MGGPRegressor(constant=False, **kw).fit(u, y)
    assert plain.logbook_[-1]["best_terms"] == plain.model_.n_terms


#: the kept constant may cost at most this share of validation error
#: against the same fit without it
CONSTANT_COST = 0.10


def _maxwell_slip_check(seed):
    from benchmarks.maxwell_slip import compare
    r = compare(seed, population=40, generations=8)
    if r["constant"]:
        assert r["default_rmse"] <= (1 + CONSTANT_COST) * r["no_constant_rmse"], r["why"]
    return r


@pytest.mark.filterwarnings("ignore")
def test_a_kept_constant_does_not_cost_on_maxwell_slip_friction():
    """Maxwell-slip friction (force without offset, 40 dB output noise),
    population 40 x 8 generations: a constant kept by the defaults costs at
    most 10 % of the validation error of the same fit with constant=False.
    Seed 3 kept one before the significance test (validation RMSE 30.9
    against 2.5 without): its gain on the held-out tail (0.97 against 1.43)
    did not hold at the head, and over both ends the pilot's gain is not
    significant (1.99 against 2.46, p = 0.097)."""
    _maxwell_slip_check(3)


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize("seed", [1, 2, 4, 5])
def test_a_kept_constant_does_not_cost_on_maxwell_slip_friction_seeds(seed):
    """The other seeds of the study (seed 4 also kept a costly constant on main)."""
    _maxwell_slip_check(seed)


@pytest.mark.filterwarnings("ignore:an offset dominates")
def test_an_output_far_from_zero_keeps_the_constant():
    """Control: y = 100 + x, x[k] = 0.6 x[k-1] - 0.1 x[k-2] + 0.5 u[k-1]
    (+ white noise of 0.01 on y; :func:`benchmarks.offset.level_record`):
    the defaults at the same budget keep the constant, its held-out gain
    significant, and the model simulates a validation record whose input
    spans twice the training range at the noise level."""
    from benchmarks.offset import level_record
    train = level_record(seed=3, level=100.0, square=0.0)
    val = level_record(seed=1003, level=100.0, square=0.0, amplitude=2.0)
    est = MGGPRegressor(population=40, generations=8, random_state=3).fit(train)
    c = est.choices_["constant"]
    assert c["value"] is True and "1" in est.model_.term_texts, c["why"]
    assert c["figures"]["gain_p_value"] < 0.05
    assert est.simulate(val).rmse < 1.2 * 0.01
