"""Parameter estimation (narx.estimation.estimate, Model.fit): LS and CLS.

References used here, computed independently of narx: numpy's lstsq (SVD)
for LS, and the textbook CLS formula

    θ_CLS = θ_LS − (ΨᵀΨ)⁻¹Sᵀ[S(ΨᵀΨ)⁻¹Sᵀ]⁻¹(Sθ_LS − c)

(Aguirre et al., 2004) evaluated with explicit inverses on a problem well
conditioned enough for them to be accurate.
"""
import numpy as np
import pytest

from narx import (EstimationError, Model, constrained_least_squares, least_squares,
                  parse_terms, regressor_matrix)
from narx.records.data import Data
from narx.systems.testsystems import system_piroddi

PIRODDI_THETA = np.array([0.75, 0.25, -0.2])


def random_problem(seed, n=300, p=6, noise=0.1):
    rng = np.random.default_rng(seed)
    Psi = rng.normal(size=(n, p))
    theta = rng.normal(size=p)
    target = Psi @ theta + noise * rng.normal(size=n)
    return Psi, target, rng


def textbook_cls(Psi, target, S, c):
    G = np.linalg.inv(Psi.T @ Psi)
    th_ls = G @ Psi.T @ target
    return th_ls - G @ S.T @ np.linalg.inv(S @ G @ S.T) @ (S @ th_ls - c)


# --------------------------------------------------------------- LS
def test_ls_recovers_piroddi_system_exactly():
    d = system_piroddi(n=1000, seed=0)
    assert d.terms == ("y[k-2]", "u[k-1]", "y[k-2]*u[k-1]")
    np.testing.assert_array_equal(d.theta, PIRODDI_THETA)
    m = Model(d.terms).fit(d.u, d.y)
    rel = np.linalg.norm(m.theta - PIRODDI_THETA) / np.linalg.norm(PIRODDI_THETA)
    assert rel < 1e-8
    assert m.fit_info_["method"] == "ls" and m.fit_info_["rank"] == 3
    assert m.fit_info_["start"] == 2 and m.fit_info_["n_samples"] == 998
    assert m.fit_info_["residual_ss"] < 1e-20
    # same through the low-level functions, factors written in another order
    terms = parse_terms(["y[k-2]", "u[k-1]", "u[k-1]*y[k-2]"])
    Psi, target, start = regressor_matrix(terms, Data(d.u, d.y))
    assert start == 2 and Psi.shape == (998, 3)
    np.testing.assert_allclose(Psi[:, 2], d.y[:-2] * d.u[1:-1], rtol=0, atol=0)
    est = least_squares(Psi, target)
    assert np.linalg.norm(est.theta - PIRODDI_THETA) / np.linalg.norm(PIRODDI_THETA) < 1e-8


def test_ls_with_a_spurious_term_gives_it_zero():
    d = system_piroddi(n=1500, seed=3)
    m = Model(list(d.terms) + ["y[k-1]*u[k-2]", "u[k-3]"]).fit(d.u, d.y)
    np.testing.assert_allclose(m.theta, [*PIRODDI_THETA, 0.0, 0.0], rtol=0, atol=1e-9)


@pytest.mark.parametrize("seed", range(5))
def test_ls_matches_numpy_on_random_problems(seed):
    Psi, target, _ = random_problem(seed)
    Psi[:, 1] *= 1e4                                    # badly scaled columns too
    Psi[:, 3] *= 1e-3
    ref = np.linalg.lstsq(Psi, target, rcond=None)[0]
    est = least_squares(Psi, target)
    np.testing.assert_allclose(est.theta, ref, rtol=1e-9, atol=0)
    assert est.rank == 6 and not est.rank_deficient and est.method == "ls"
    r = target - Psi @ ref
    assert est.residual_ss == pytest.approx(r @ r, rel=1e-10)


def test_rank_deficient_regressors_do_not_crash():
    Psi, target, _ = random_problem(0, p=4)
    Psi2 = np.column_stack([Psi, Psi[:, 0]])            # duplicate column
    est = least_squares(Psi2, target)
    assert est.theta.shape == (5,) and np.all(np.isfinite(est.theta))
    Psi3 = np.column_stack([Psi, np.zeros(Psi.shape[0])])   # a zero column
    est = least_squares(Psi3, target)
    assert np.all(np.isfinite(est.theta)) and est.rank == 4 and est.rank_deficient
    assert est.theta[4] == 0.0
    est = constrained_least_squares(Psi2, target, [[0, 1, 0, 0, 0]], [0.5])
    assert np.all(np.isfinite(est.theta)) and est.theta[1] == pytest.approx(0.5)


@pytest.mark.parametrize("seed", [0, 2, 3])
def test_duplicate_column_gives_the_minimum_norm_ls_solution(seed):
    Psi, target, _ = random_problem(seed, p=6)
    Psi2 = np.column_stack([Psi, Psi[:, 2]])
    est = least_squares(Psi2, target)
    ref = np.linalg.lstsq(Psi2, target, rcond=None)[0]       # minimum norm (SVD)
    full = np.linalg.lstsq(Psi, target, rcond=None)[0]
    r = target - Psi @ full
    assert est.rank == 6 and est.rank_deficient
    assert est.residual_ss <= (r @ r) * (1 + 1e-10)           # still the LS optimum
    np.testing.assert_allclose(est.theta, ref, rtol=1e-8, atol=1e-12)
    assert est.theta[2] == pytest.approx(est.theta[6])


def test_ls_input_validation():
    with pytest.raises(EstimationError, match="2-D"):
        least_squares(np.ones(5), np.ones(5))
    with pytest.raises(EstimationError, match="rows"):
        least_squares(np.ones((5, 2)), np.ones(4))
    with pytest.raises(EstimationError, match="cannot determine"):
        least_squares(np.ones((2, 3)), np.ones(2))
    Psi = np.ones((5, 2))
    Psi[3, 1] = np.nan
    with pytest.raises(EstimationError, match="non-finite"):
        least_squares(Psi, np.ones(5))
    with pytest.raises(EstimationError, match="non-finite"):
        least_squares(np.eye(3), [1.0, np.inf, 0.0])


# --------------------------------------------------------------- CLS
@pytest.mark.parametrize("seed", range(4))
def test_cls_satisfies_constraints_and_equals_textbook_formula(seed):
    Psi, target, rng = random_problem(seed, n=400, p=7)
    S = rng.normal(size=(3, 7))
    c = rng.normal(size=3)
    est = constrained_least_squares(Psi, target, S, c)
    assert est.method == "cls"
    np.testing.assert_allclose(S @ est.theta, c, rtol=0, atol=1e-10)
    np.testing.assert_allclose(est.theta, textbook_cls(Psi, target, S, c),
                               rtol=1e-9, atol=1e-12)
    # optimality: any feasible move (in the null space of S) costs more
    Z = np.linalg.svd(S)[2][3:].T
    f0 = np.sum((target - Psi @ est.theta) ** 2)
    assert est.residual_ss == pytest.approx(f0, rel=1e-10)
    for _ in range(20):
        th = est.theta + Z @ rng.normal(scale=1e-3, size=Z.shape[1])
        assert np.sum((target - Psi @ th) ** 2) > f0


def test_cls_sum_constraints_like_steady_state():
    Psi, target, _ = random_problem(11, p=5)
    S = np.array([[1.0, 0, 0, 0, 0], [0, 1.0, 0, 0, 1.0]])
    c = np.array([1.0, 0.0])
    est = constrained_least_squares(Psi, target, S, c)
    assert est.theta[0] == pytest.approx(1.0, abs=1e-12)
    assert est.theta[1] + est.theta[4] == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(est.theta, textbook_cls(Psi, target, S, c), rtol=1e-9)


def test_cls_edge_cases():
    Psi, target, _ = random_problem(5, p=4)
    ls = least_squares(Psi, target).theta
    # a constraint already met by θ_LS changes nothing
    S = np.array([[1.0, -2.0, 0.5, 0.0]])
    est = constrained_least_squares(Psi, target, S, S @ ls)
    np.testing.assert_allclose(est.theta, ls, rtol=1e-9)
    # as many independent constraints as parameters: θ = S⁻¹ c
    S = np.random.default_rng(1).normal(size=(4, 4))
    c = np.arange(4.0)
    np.testing.assert_allclose(constrained_least_squares(Psi, target, S, c).theta,
                               np.linalg.solve(S, c), rtol=1e-10)
    # no constraints: LS
    np.testing.assert_allclose(
        constrained_least_squares(Psi, target, np.zeros((0, 4)), np.zeros(0)).theta, ls)


def test_cls_inconsistent_constraints_raise():
    Psi, target, _ = random_problem(2, p=4)
    S = [[1.0, 1.0, 0, 0], [1.0, 1.0, 0, 0]]
    with pytest.raises(EstimationError, match="inconsistent constraints") as ei:
        constrained_least_squares(Psi, target, S, [1.0, 2.0])
    assert "no θ satisfies" in str(ei.value)
    with pytest.raises(EstimationError, match=r"inconsistent.*Σ_u = 0.*Σ_u' = 1"):
        constrained_least_squares(Psi, target, [[1.0, 0, 0, 1.0], [2.0, 0, 0, 2.0]],
                                  [0.0, 1.0], labels=["Σ_u = 0", "Σ_u' = 1"])


def test_cls_redundant_constraints_raise():
    Psi, target, _ = random_problem(2, p=4)
    with pytest.raises(EstimationError, match="redundant constraints: 2 rows but rank 1; "
                       "row 2 repeats earlier rows"):
        constrained_least_squares(Psi, target, [[1, 1, 0, 0], [2, 2, 0, 0]], [1, 2])
    with pytest.raises(EstimationError, match="redundant constraints: 3 rows but rank 2; "
                       "Σ_c repeats"):
        constrained_least_squares(Psi, target,
                                  [[1, 0, 0, 0], [0, 1, 0, 0], [1, 1, 0, 0]], [1, 1, 2],
                                  labels=["Σ_a", "Σ_b", "Σ_c"])


def test_cls_shape_errors():
    Psi, target, _ = random_problem(2, p=4)
    with pytest.raises(EstimationError, match="columns for 4 parameters"):
        constrained_least_squares(Psi, target, [[1, 0, 0]], [1])
    with pytest.raises(EstimationError, match="c has 2 values"):
        constrained_least_squares(Psi, target, [[1, 0, 0, 0]], [1, 2])
    with pytest.raises(EstimationError, match="non-finite"):
        constrained_least_squares(Psi, target, [[np.nan, 0, 0, 0]], [1])


def test_model_fit_with_explicit_and_steady_state_constraints():
    d = system_piroddi(n=800, seed=1)
    m_ls = Model(d.terms).fit(d.u, d.y)
    S, c = np.array([[1.0, 1.0, 0.0]]), np.array([0.9])
    m = Model(d.terms).fit(d.u, d.y, constraints=(S, c))
    assert m.theta[0] + m.theta[1] == pytest.approx(0.9, abs=1e-12)
    Psi, target, _ = regressor_matrix(m.terms, Data(d.u, d.y))
    np.testing.assert_allclose(m.theta, textbook_cls(Psi, target, S, c), rtol=1e-8)
    assert m.fit_info_["method"] == "cls"
    assert np.sum((target - Psi @ m.theta) ** 2) > np.sum((target - Psi @ m_ls.theta) ** 2)
    # Piroddi terms form clusters y, u, y*u: Σ_y = 1, Σ_u = 0, Σ_yu = 0 pin θ
    m = Model(d.terms).fit(d.u, d.y, constraints="steady-state")
    np.testing.assert_allclose(m.theta, [1.0, 0.0, 0.0], rtol=0, atol=1e-12)
    assert sorted(m.fit_info_["constraints"]) == sorted(["Σ_y = 1", "Σ_u = 0", "Σ_y*u = 0"])
    with pytest.raises(ValueError, match="constraints must be"):
        Model(d.terms).fit(d.u, d.y, constraints="steady")
    with pytest.raises(EstimationError, match="inconsistent"):
        Model(d.terms).fit(d.u, d.y, constraints=([[1, 0, 0], [2, 0, 0]], [1, 1]))


def test_extended_ls_on_narmax_system_s5():
    from narx.systems.testsystems import system_by_name
    d = system_by_name("S5", n=3000, seed=0)
    assert "e[k-1]" in d.terms
    m = Model(d.terms).fit(d.u, d.y)
    np.testing.assert_allclose(m.theta, d.theta, rtol=0, atol=0.05)
    np.testing.assert_allclose(m.theta[:4], d.theta[:4], rtol=0, atol=0.02)
    # the final residuals are (close to) the true noise
    n = m.fit_info_["n_samples"]
    assert m.fit_info_["residual_ss"] / n == pytest.approx(np.var(d.e), rel=0.1)


def test_t_statistics_with_dependent_columns_keep_the_determined_ones():
    from narx.estimation.estimate import t_statistics
    rng = np.random.default_rng(0)
    x0, x1, x2 = rng.standard_normal((3, 500))
    y = 5 * x0 + 0.1 * rng.standard_normal(500)
    t = t_statistics(np.c_[x0, x1, x2, x1 + x2], y)
    # x0 is determined (and strongly significant); x1, x2, x1 + x2 are not
    assert t[0] > 100 and np.all(t[1:] == 0)
    full = t_statistics(np.c_[x0, x1, x2], y)
    assert t[0] == pytest.approx(full[0], rel=1e-6)


def test_cls_does_not_depend_on_the_units_of_the_output():
    """CLS in column-scaled coordinates: y in other units (×1e3, ×1e6) gives
    the same θ up to the implied scaling (the unscaled null-space solve
    used to lose rank at y×1e6 and move θ at y×1e3)."""
    from narx import Model
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(10_000, seed=1)
    y = piezo_bouc_wen(u)
    terms = ["y[k-1]", "y[k-2]", "Phi1(u[k-1],u[k-2])", "y[k-1]*y[k-1]*y[k-1]",
             "y[k-3]*y[k-3]*y[k-3]", "u[k-1]", "u[k-4]", "y[k-1]*u[k-1]", "y[k-2]*u[k-3]"]
    base = Model(terms).fit(u, y, constraints="steady-state")
    for s in (1e3, 1e6):
        m = Model(terms).fit(u, y * s, constraints="steady-state")
        assert m.fit_info_["rank"] == base.fit_info_["rank"] == len(terms)
        back = m.theta * np.array([1, 1, 1 / s, s**2, s**2, 1 / s, 1 / s, 1, 1])
        np.testing.assert_allclose(back, base.theta, rtol=1e-6, atol=1e-12)


def test_t_statistics_of_dependent_columns_on_a_long_record():
    """Dependent columns on 100,000 rows: the t-statistics need V only; a
    full SVD would build a 100,000 × 100,000 U (80 GB: MemoryError, or the
    process killed; a NARMAX selection on 32,000 samples grew to 13 GB)."""
    from narx.estimation.estimate import t_statistics
    rng = np.random.default_rng(1)
    x0, x1 = rng.standard_normal((2, 100_000))
    y = 2.0 * x0 + 0.01 * rng.standard_normal(100_000)
    t = t_statistics(np.c_[x0, x1, np.zeros(100_000)], y)
    assert t[0] > 1e3 and t[1] < 5 and t[2] == 0.0
