"""Parameter estimation: least squares, constrained LS, extended LS (NARMAX).

Typical use::

    from narx.estimate import least_squares, constrained_least_squares
    theta = least_squares(Psi, target).theta
    theta = constrained_least_squares(Psi, target, S, c).theta

LS solves :math:`\\min_\\theta \\|\\Psi\\theta - y\\|_2` by QR with column
pivoting (LAPACK ``gelsy``) on unit-norm columns; never an explicit inverse.
CLS solves it subject to :math:`S\\theta = c` by the null-space method,
which gives the same solution as the textbook formula [1]_

.. math::

    \\theta_{CLS} = \\theta_{LS} - (\\Psi^T\\Psi)^{-1}S^T
        [S(\\Psi^T\\Psi)^{-1}S^T]^{-1}(S\\theta_{LS} - c)

without forming :math:`(\\Psi^T\\Psi)^{-1}`: with :math:`\\theta_p` the
minimum-norm solution of :math:`S\\theta=c` and :math:`Z` an orthonormal
basis of the null space of S, :math:`\\theta = \\theta_p + Z z` and z is an
ordinary LS solution.

References
----------
.. [1] Aguirre, L. A., Barroso, M. F. S., Saldanha, R. R., Mendes, E. M. A. M.,
   "Imposing steady-state performance on identified nonlinear polynomial
   models by means of constrained parameter estimation", IEE Proc.-Control
   Theory Appl., 2004.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np
import scipy.linalg

from .exceptions import EstimationError

__all__ = ["Estimate", "EstimationError", "least_squares",
           "constrained_least_squares", "t_statistics"]


@dataclass(frozen=True)
class Estimate:
    theta: np.ndarray
    rank: int
    n_params: int
    residual_ss: float
    method: str

    @property
    def rank_deficient(self) -> bool:
        return self.rank < self.n_params


def _check(Psi, target):
    Psi = np.asarray(Psi, dtype=np.float64)
    target = np.asarray(target, dtype=np.float64).ravel()
    if Psi.ndim != 2:
        raise EstimationError(f"regressor matrix must be 2-D, got shape {Psi.shape}")
    if Psi.shape[0] != target.shape[0]:
        raise EstimationError(f"regressor matrix has {Psi.shape[0]} rows but the "
                              f"target has {target.shape[0]}")
    if Psi.shape[0] < Psi.shape[1]:
        raise EstimationError(f"{Psi.shape[0]} samples cannot determine "
                              f"{Psi.shape[1]} parameters")
    if not (np.all(np.isfinite(Psi)) and np.all(np.isfinite(target))):
        raise EstimationError("regressor matrix or target has non-finite values")
    return Psi, target


def _solve(Psi, target):
    """Column-scaled pivoted-QR least squares; returns (theta, rank)."""
    norms = np.sqrt(np.einsum("ij,ij->j", Psi, Psi))
    norms[norms == 0] = 1.0
    A = Psi / norms
    x, _, rank, _ = scipy.linalg.lstsq(A, target, lapack_driver="gelsy",
                                       cond=max(A.shape) * np.finfo(float).eps,
                                       check_finite=False)
    return x / norms, int(rank)


def least_squares(Psi, target) -> Estimate:
    """Ordinary least squares, rank-revealing (minimum-norm if deficient)."""
    Psi, target = _check(Psi, target)
    if Psi.shape[1] == 0:
        return Estimate(np.zeros(0), 0, 0, float(target @ target), "ls")
    theta, rank = _solve(Psi, target)
    r = target - Psi @ theta
    return Estimate(theta, rank, Psi.shape[1], float(r @ r), "ls")


def constrained_least_squares(Psi, target, S, c, *, labels=None,
                              tol: float = 1e-10) -> Estimate:
    """Least squares subject to the linear equalities ``S θ = c``.

    Raises
    ------
    EstimationError
        If S has the wrong width, if its rows are linearly dependent
        (redundant constraints), or if no θ satisfies them (inconsistent).
    """
    Psi, target = _check(Psi, target)
    S = np.atleast_2d(np.asarray(S, dtype=np.float64))
    c = np.asarray(c, dtype=np.float64).ravel()
    p = Psi.shape[1]
    if S.size == 0:
        return least_squares(Psi, target)
    if S.shape[1] != p:
        raise EstimationError(f"constraint matrix has {S.shape[1]} columns for "
                              f"{p} parameters")
    if S.shape[0] != c.shape[0]:
        raise EstimationError(f"constraint matrix has {S.shape[0]} rows but c has "
                              f"{c.shape[0]} values")
    if not (np.all(np.isfinite(S)) and np.all(np.isfinite(c))):
        raise EstimationError("constraints have non-finite values")
    U, sv, Vt = np.linalg.svd(S)
    rank = int(np.sum(sv > max(S.shape) * np.finfo(float).eps * (sv[0] if sv.size else 0)))
    theta_p = np.linalg.lstsq(S, c, rcond=None)[0]
    resid = float(np.max(np.abs(S @ theta_p - c))) if c.size else 0.0
    name = (lambda i: labels[i]) if labels is not None else (lambda i: f"row {i + 1}")
    if resid > tol * max(1.0, float(np.max(np.abs(c)))):
        raise EstimationError(f"inconsistent constraints: no θ satisfies S θ = c "
                              f"(best residual {resid:.3g}); check "
                              f"{', '.join(name(i) for i in range(S.shape[0]))}")
    if rank < S.shape[0]:
        # find the first row that depends on the previous ones
        for i in range(1, S.shape[0] + 1):
            if np.linalg.matrix_rank(S[:i]) < i:
                break
        raise EstimationError(f"redundant constraints: {S.shape[0]} rows but rank "
                              f"{rank}; {name(i - 1)} repeats earlier rows")
    # solved in column-scaled coordinates z = norms * θ (S θ = (S / norms) z),
    # so the result does not depend on the units of the signals
    norms = np.sqrt(np.einsum("ij,ij->j", Psi, Psi))
    norms[norms == 0] = 1.0
    A, Sa = Psi / norms, S / norms
    _, _, Vta = np.linalg.svd(Sa)
    z_p = np.linalg.lstsq(Sa, c, rcond=None)[0]
    Z = Vta[rank:].T                                 # null space of S / norms
    if Z.shape[1] == 0:
        z, z_rank = z_p, 0
    else:
        w, z_rank = _solve(A @ Z, target - A @ z_p)
        z = z_p + Z @ w
    theta = z / norms
    r = target - Psi @ theta
    return Estimate(theta, z_rank + rank, p, float(r @ r), "cls")


def t_statistics(Psi, target, theta=None) -> np.ndarray:
    r"""|θ_i| / se(θ_i) of an LS fit (``inf`` where the residual is zero).

    .. math::  \mathrm{se}(\theta_i) = \hat\sigma \, \|(R^{-T})_{:,i}\|,
               \quad \Psi = QR,\; \hat\sigma^2 = \frac{\|y-\Psi\theta\|^2}{N-p}

    (the diagonal of σ²(ΨᵀΨ)⁻¹ from the triangular factor; columns scaled to
    unit norm first). When the columns are dependent, a coefficient that the
    data do not determine (its unit vector has a component in the null
    space of Ψ) gets t = 0; the others keep their t-statistic, from the
    diagonal of σ²(ΨᵀΨ)⁺ with σ² on N − rank degrees of freedom (θ is then
    the minimum-norm solution, whose determined components are unique).
    """
    Psi, target = _check(Psi, target)
    n, p = Psi.shape
    if theta is None:
        theta = least_squares(Psi, target).theta
    r = target - Psi @ theta
    dof = max(n - p, 1)
    sigma = np.sqrt(float(r @ r) / dof)
    norms = np.sqrt(np.einsum("ij,ij->j", Psi, Psi))
    norms[norms == 0] = 1.0
    R = np.linalg.qr(Psi / norms, mode="r")
    diag = np.abs(np.diag(R))
    out = np.zeros(p)
    ok = diag > 1e-10 * max(diag.max(initial=0.0), 1e-300)
    if not np.all(ok):
        return _t_dependent(Psi / norms, norms, r, theta)
    Rinv_t = scipy.linalg.solve_triangular(R, np.eye(p), lower=False).T
    se = sigma * np.sqrt(np.sum(Rinv_t ** 2, axis=0)) / norms
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(se > 0, np.abs(theta) / se, np.inf)
    return out


def _t_dependent(A, norms, r, theta) -> np.ndarray:
    """t-statistics for dependent (column-scaled) regressors ``A``."""
    n, p = A.shape
    # thin SVD: only V is needed (the full one builds an n × n U: 8 GB at
    # n = 32,000); n >= p here (_check), so Vt is p × p either way
    _, sv, Vt = np.linalg.svd(A, full_matrices=False)
    rank = int(np.sum(sv > 1e-10 * max(sv.max(initial=0.0), 1e-300)))
    V = Vt.T
    null = V[:, rank:]
    determined = np.sqrt(np.sum(null ** 2, axis=1)) < 1e-8
    sigma = np.sqrt(float(r @ r) / max(n - rank, 1))
    var = np.sum((V[:, :rank] / sv[:rank]) ** 2, axis=1)       # diag of (AᵀA)⁺
    se = sigma * np.sqrt(var) / norms
    out = np.zeros(p)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(se > 0, np.abs(theta) / se, np.inf)
    out[determined] = t[determined]
    return out
