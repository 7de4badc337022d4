"""narx.linalg: scaling, rank, null space, LS, CLS, t-statistics, divergence."""
import numpy as np
import pytest

from narx import linalg as L


def _closed_cls(Psi, y, S, c):
    """θ_LS − (ΨᵀΨ)⁻¹Sᵀ[S(ΨᵀΨ)⁻¹Sᵀ]⁻¹(Sθ_LS − c), with explicit inverses."""
    M = np.linalg.inv(Psi.T @ Psi)
    th = M @ Psi.T @ y
    return th - M @ S.T @ np.linalg.solve(S @ M @ S.T, S @ th - c)


def _problem(seed=0, n=200, p=5):
    rng = np.random.default_rng(seed)
    # columns of very different scales (as u against u³)
    scales = np.array([1e-3, 1.0, 1e2, 1e4, 3.0])[:p]
    Psi = rng.standard_normal((n, p)) * scales
    y = Psi @ (rng.standard_normal(p) / scales)
    y = y + 0.1 * rng.standard_normal(n)
    S = np.array([[1.0, 1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 2.0, -1.0]])[:, :p]
    c = np.array([1.0, 0.0])
    return Psi, y, S, c


def test_null_space_of_a_known_matrix():
    S = np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 2.0]])
    Z = L.null_space(S)
    assert Z.shape == (3, 1)
    np.testing.assert_allclose(np.abs(Z[:, 0]), [2 ** -0.5, 2 ** -0.5, 0.0], atol=1e-15)
    assert Z[0, 0] == pytest.approx(-Z[1, 0], abs=1e-15)
    # a repeated row does not add a constraint: rank 2, still one direction
    Z2 = L.null_space(np.vstack([S, 3 * S[0]]))
    assert Z2.shape == (3, 1)
    np.testing.assert_allclose(np.abs(Z2), np.abs(Z), atol=1e-15)
    # no constraint: the whole space
    Z0 = L.null_space(np.zeros((1, 3)))
    np.testing.assert_allclose(Z0.T @ Z0, np.eye(3), atol=1e-15)


def test_rank_rule_is_max_shape_eps_times_largest_singular_value():
    shape = (10, 3)
    tol = 10 * np.finfo(float).eps
    assert L.rank_tolerance(shape, 2.0) == tol * 2.0
    assert L.numerical_rank([1.0, 0.5, 3 * tol], shape) == 3
    assert L.numerical_rank([1.0, 0.5, 0.5 * tol], shape) == 2
    assert L.numerical_rank([1.0, 1e-11], shape, rtol=1e-10) == 1
    assert L.numerical_rank([], shape) == 0
    A = np.outer(np.arange(1.0, 7.0), [1.0, 2.0, 3.0])
    assert L.matrix_rank(A) == 1 == np.linalg.matrix_rank(A)


def test_constraint_space_flags_inconsistent_equalities():
    sp = L.constraint_space([[1.0, 1.0], [2.0, 2.0]], [0.0, 1.0])
    assert not sp.consistent and sp.rank == 1 and sp.residual > 0.1
    ok = L.constraint_space([[1.0, 1.0], [2.0, 2.0]], [1.0, 2.0])
    assert ok.consistent and ok.rank == 1
    np.testing.assert_allclose(ok.theta_p, [0.5, 0.5], atol=1e-15)


def test_cls_satisfies_the_constraints_and_equals_the_closed_formula():
    Psi, y, S, c = _problem()
    theta, rank, space = L.scaled_lstsq(Psi, y, S, c)
    assert space.consistent and space.rank == 2 and rank == Psi.shape[1]
    assert np.max(np.abs(S @ theta - c)) <= 1e-10
    ref = _closed_cls(Psi, y, S, c)
    np.testing.assert_allclose(theta, ref, rtol=1e-8, atol=0)
    # the same from the normal equations
    theta_g, space_g = L.gram_lstsq(Psi.T @ Psi, Psi.T @ y, S, c)
    assert space_g.consistent and np.max(np.abs(S @ theta_g - c)) <= 1e-10
    np.testing.assert_allclose(theta_g, ref, rtol=1e-7, atol=0)
    # and through the public estimator
    from narx.estimation.estimate import constrained_least_squares
    est = constrained_least_squares(Psi, y, S, c)
    assert np.array_equal(est.theta, theta) and est.rank == rank


def test_cls_without_constraints_left_is_the_particular_solution():
    Psi, y, _, _ = _problem(p=2)
    S, c = np.eye(2), np.array([0.3, -0.7])
    theta, rank, space = L.scaled_lstsq(Psi, y, S, c)
    assert space.Z.shape == (2, 0)
    np.testing.assert_allclose(theta, c, rtol=1e-14)


def test_column_scaling_round_trip_and_zero_columns():
    rng = np.random.default_rng(2)
    A = rng.standard_normal((50, 4)) * [1e-6, 1.0, 1e6, 0.0]
    As, d = L.scale_columns(A)
    np.testing.assert_allclose(np.linalg.norm(As[:, :3], axis=0), 1.0, rtol=1e-15)
    assert d[3] == 1.0 and np.all(As[:, 3] == 0.0)
    np.testing.assert_allclose(As * d, A, rtol=1e-15, atol=0)
    # the Gram form scales by the same norms
    G, g = A.T @ A, A.T @ rng.standard_normal(50)
    Gs, gs, dg = L.scale_gram(G, g)
    np.testing.assert_allclose(dg, d, rtol=1e-14)
    np.testing.assert_allclose(np.diag(Gs)[:3], 1.0, rtol=1e-14)
    np.testing.assert_allclose(Gs * np.outer(dg, dg), G, rtol=1e-14)
    np.testing.assert_allclose(gs * dg, g, rtol=1e-15)


@pytest.mark.parametrize("driver", ["gelsy", "gelsd"])
def test_rank_deficient_least_squares_is_the_minimum_norm_solution(driver):
    rng = np.random.default_rng(3)
    A = rng.standard_normal((30, 2)) @ rng.standard_normal((2, 4))      # rank 2
    b = rng.standard_normal(30)
    x, rank = L.lstsq(A, b, driver=driver)
    assert rank == 2
    np.testing.assert_allclose(x, np.linalg.pinv(A) @ b, rtol=1e-10, atol=1e-12)
    # on scaled columns: the minimum-norm solution in the scaled coordinates
    Ad = A * [1.0, 1e3, 1e-3, 5.0]
    theta, rank, space = L.scaled_lstsq(Ad, b)
    As, d = L.scale_columns(Ad)
    assert rank == 2 and space is None
    np.testing.assert_allclose(theta, (np.linalg.pinv(As) @ b) / d, rtol=1e-9)


def test_lstsq_rejects_an_unknown_driver():
    with pytest.raises(ValueError, match="driver must be 'gelsy' or 'gelsd', got 'qr'"):
        L.lstsq(np.eye(2), np.ones(2), driver="qr")


@pytest.mark.parametrize("shape, rank", [((5, 5), 5), ((9, 4), 4), ((3, 6), 3), ((6, 6), 4),
                                         ((1, 1), 1)])
def test_gelsy_call_equals_scipy_lstsq_bit_for_bit(shape, rank):
    import scipy.linalg
    rng = np.random.default_rng(sum(shape) + rank)
    A = rng.standard_normal((shape[0], rank)) @ rng.standard_normal((rank, shape[1]))
    b = rng.standard_normal(shape[0])
    ref, _, ref_rank, _ = scipy.linalg.lstsq(A, b, lapack_driver="gelsy", cond=1e-12,
                                             check_finite=False)
    for _ in range(2):                          # the second call uses the cached workspace
        x, r = L.lstsq(A, b, rcond=1e-12)
        assert x.shape == (shape[1],) and np.array_equal(x, ref) and r == ref_rank == rank


def test_t_statistics_against_a_hand_calculation():
    # y = a + b x on x = 0..4: b = Sxy/Sxx = 8/10, a = 3 - 0.8·2 = 1.4,
    # RSS = 3.6, σ² = 3.6/3 = 1.2, se(b)² = σ²/Sxx = 0.12,
    # se(a)² = σ²(1/n + x̄²/Sxx) = 1.2·0.6 = 0.72
    x = np.arange(5.0)
    y = np.array([1.0, 3.0, 2.0, 5.0, 4.0])
    Psi = np.c_[np.ones(5), x]
    theta = np.array([1.4, 0.8])
    t = L.t_values(Psi, y - Psi @ theta, theta)
    np.testing.assert_allclose(t, [1.4 / np.sqrt(0.72), 0.8 / np.sqrt(0.12)], rtol=1e-13)
    from narx.estimation.estimate import t_statistics
    np.testing.assert_allclose(t_statistics(Psi, y), t, rtol=1e-13)


def test_t_statistics_zero_for_an_undetermined_coefficient():
    rng = np.random.default_rng(4)
    x0, x1 = rng.standard_normal((2, 300))
    Psi = np.c_[x0, x1, x1]                      # x1 twice: θ_1, θ_2 undetermined
    y = 2.0 * x0 + 0.1 * rng.standard_normal(300)
    theta = L.scaled_lstsq(Psi, y)[0]
    t = L.t_values(Psi, y - Psi @ theta, theta)
    assert t[0] > 100 and t[1] == 0.0 and t[2] == 0.0


def test_added_column_t_equals_the_t_of_the_joint_fit():
    rng = np.random.default_rng(5)
    Psi = rng.standard_normal((400, 3)) * [1.0, 1e3, 1e-2]
    C = rng.standard_normal((400, 2))
    y = Psi @ [1.0, 1e-3, 1e2] + 0.3 * C[:, 0] + 0.5 * rng.standard_normal(400)
    got = L.added_column_t(Psi, y, C)
    for j in range(2):
        A = np.c_[Psi, C[:, j]]
        theta = L.scaled_lstsq(A, y)[0]
        assert got[j] == pytest.approx(L.t_values(A, y - A @ theta, theta)[-1], rel=1e-9)
    # a candidate in the span of Psi gets 0
    assert L.added_column_t(Psi, y, Psi[:, :1] * 2.0)[0] == 0.0


def test_divergence_bound():
    assert L.divergence_bound(np.array([-3.0, 2.0])) == 3.0e4
    assert L.divergence_bound(np.zeros(4)) == 1e4
    assert L.divergence_bound(np.zeros(0)) == 1e4


def test_solves_run_on_one_blas_thread_and_restore_the_setting():
    from threadpoolctl import threadpool_info
    from narx.linalg import one_blas_thread
    before = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    with one_blas_thread():
        assert all(i["num_threads"] == 1 for i in threadpool_info() if i["user_api"] == "blas")
    assert [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"] == before
