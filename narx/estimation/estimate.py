"""Parameter estimation: least squares, constrained LS, extended LS (NARMAX).

Typical use::

    from narx.estimation.estimate import least_squares, constrained_least_squares
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
ordinary LS solution. The scaling, rank and solver rules are those of
:mod:`narx.linalg`; this module validates the problem and names what is
wrong with it.

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

from ..linalg import matrix_rank, scaled_lstsq, t_values

from ..exceptions import EstimationError

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


def least_squares(Psi, target) -> Estimate:
    """Ordinary least squares, rank-revealing (minimum-norm if deficient)."""
    Psi, target = _check(Psi, target)
    if Psi.shape[1] == 0:
        return Estimate(np.zeros(0), 0, 0, float(target @ target), "ls")
    theta, rank, _ = scaled_lstsq(Psi, target)
    r = target - Psi @ theta
    return Estimate(theta, rank, Psi.shape[1], float(r @ r), "ls")


def constrained_least_squares(Psi, target, S, c, *, labels=None) -> Estimate:
    """Least squares subject to the linear equalities ``S θ = c``
    (:func:`narx.linalg.scaled_lstsq`: the null-space method on unit-norm
    columns).

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
    theta, rank, space = scaled_lstsq(Psi, target, S, c)
    name = (lambda i: labels[i]) if labels is not None else (lambda i: f"row {i + 1}")
    if not space.consistent:
        raise EstimationError(f"inconsistent constraints: no θ satisfies S θ = c "
                              f"(best residual {space.residual:.3g}); check "
                              f"{', '.join(name(i) for i in range(S.shape[0]))}")
    if space.rank < S.shape[0]:
        # find the first row that depends on the previous ones
        for i in range(1, S.shape[0] + 1):
            if matrix_rank(S[:i]) < i:
                break
        raise EstimationError(f"redundant constraints: {S.shape[0]} rows but rank "
                              f"{space.rank}; {name(i - 1)} repeats earlier rows")
    r = target - Psi @ theta
    return Estimate(theta, rank, p, float(r @ r), "cls")


def t_statistics(Psi, target, theta=None) -> np.ndarray:
    r"""|θ_i| / se(θ_i) of the fit ``theta`` (default: the LS fit) of
    ``target`` on ``Psi``: :func:`narx.linalg.t_values` of its residuals,
    :math:`\mathrm{se}(\theta_i)^2 = \hat\sigma^2 [(\Psi^T\Psi)^{-1}]_{ii}`
    (0 for a coefficient the data do not determine, ``inf`` where the
    residual is zero)."""
    Psi, target = _check(Psi, target)
    if theta is None:
        theta = least_squares(Psi, target).theta
    r = target - Psi @ theta
    return t_values(Psi, r, theta)
