"""Dense linear algebra of NARX estimation: scaling, rank, least squares, CLS, t.

Typical use::

    from narx.linalg import scaled_lstsq, constraint_space, t_values
    theta, rank, space = scaled_lstsq(Psi, y, S, c)      # LS, or CLS when S given
    space.consistent, space.rank                         # the constraints' verdict
    t = t_values(Psi, y - Psi @ theta, theta)            # |θ_i| / se(θ_i)

Every rule of the package's linear algebra is stated once here.

*Column scaling.* Regressors of polynomial NARX models differ by orders of
magnitude (u against u³), so every solve works on unit-norm columns
:math:`A = \\Psi D^{-1}`, :math:`D = \\mathrm{diag}(\\|\\psi_j\\|_2)`, and maps
back :math:`\\theta = D^{-1} z`; a zero column keeps scale 1 (its coefficient
is then 0 in the minimum-norm solution). On normal equations the same
scaling is :math:`D^{-1} G D^{-1}` with :math:`D = \\mathrm{diag}(G)^{1/2}`.

*Rank.* A matrix with singular values :math:`\\sigma_1 \\ge \\dots` has
numerical rank :math:`\\#\\{i : \\sigma_i > \\max(m, n)\\,\\epsilon\\,\\sigma_1\\}`
([1]_ §5.4.1; the default of LAPACK's least-squares drivers as called by
numpy and of ``numpy.linalg.matrix_rank``). Two uses take a wider relative
tolerance, each for a stated reason: normal equations, whose condition
number is the square of the regressors' (:data:`GRAM_RCOND`), and the
t-statistics, which call a coefficient undetermined well before rounding
does (:data:`T_RTOL`).

*Least squares.* :math:`\\min_x \\|Ax - b\\|_2` by a complete orthogonal
factorisation (QR with column pivoting, LAPACK ``gelsy``), or by the SVD
(``gelsd``); both return the minimum-norm solution when A is rank
deficient [1]_ §5.5. Never an explicit inverse.

*Threads.* The solves run with the BLAS library on one thread
(:func:`one_blas_thread`): NARX regressor matrices are tall and narrow
(N × 15), where a second BLAS thread gains little on an idle machine and,
on a machine already busy (the evaluator's worker processes, other jobs),
makes each solve wait for a core (``python -m benchmarks.blas_threads``
measures both cases). Parallelism belongs to the population (joblib), not
to one solve.

*Constrained least squares.* Subject to :math:`S\\theta = c` the solution
is [2]_

.. math::

    \\theta_{CLS} = \\theta_{LS} - (\\Psi^T\\Psi)^{-1}S^T
        [S(\\Psi^T\\Psi)^{-1}S^T]^{-1}(S\\theta_{LS} - c),

computed here by the null-space method ([1]_ §6.2): with :math:`\\theta_p`
the minimum-norm solution of :math:`S\\theta = c` and the columns of Z an
orthonormal basis of the null space of S (the right singular vectors past
the rank), :math:`\\theta = \\theta_p + Zw` where w is the ordinary LS
solution of :math:`\\min_w \\|\\Psi Z w - (y - \\Psi\\theta_p)\\|`.

*t-statistics.* :math:`t_i = |\\theta_i| / \\mathrm{se}(\\theta_i)`,
:math:`\\mathrm{se}(\\theta_i)^2 = \\hat\\sigma^2 [(\\Psi^T\\Psi)^{-1}]_{ii}`,
:math:`\\hat\\sigma^2 = \\|r\\|^2 / (N - p)` ([3]_ §3.3).

References
----------
.. [1] Golub, G. H., Van Loan, C. F., *Matrix Computations*, 4th ed.,
   Johns Hopkins, 2013.
.. [2] Aguirre, L. A., Barroso, M. F. S., Saldanha, R. R., Mendes, E. M. A. M.,
   "Imposing steady-state performance on identified nonlinear polynomial
   models by means of constrained parameter estimation", IEE Proc.-Control
   Theory Appl., 2004.
.. [3] Draper, N. R., Smith, H., *Applied Regression Analysis*, 3rd ed.,
   Wiley, 1998.
.. [4] Söderström, T., Stoica, P., *System Identification*, Prentice Hall,
   1989, ch. 8 (instrumental variable methods).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Optional, Tuple

import numpy as np
import scipy.linalg

__all__ = ["EPS", "GRAM_RCOND", "T_RTOL", "CONSISTENCY_RTOL", "DIVERGENCE_FACTOR",
           "column_norms", "scale_columns", "scale_gram", "rank_tolerance",
           "numerical_rank", "matrix_rank", "lstsq", "ConstraintSpace",
           "constraint_space", "null_space", "scaled_lstsq", "gram_lstsq", "iv_lstsq",
           "range_basis", "t_values", "added_column_t", "divergence_bound"]

#: machine epsilon of float64
EPS = float(np.finfo(np.float64).eps)
#: relative rank tolerance on normal equations (unit-diagonal Gram matrices):
#: their condition number is the square of the regressors', so columns
#: dependent to about 1e-6 count as dependent
GRAM_RCOND = 1e-12
#: relative tolerance below which the t-statistics call a regressor
#: direction undetermined (diagonal of R, or singular value, against the
#: largest)
T_RTOL = 1e-10
#: S θ = c counts as solvable when the minimum-norm solution leaves a
#: residual at most this times max(1, max|c|)
CONSISTENCY_RTOL = 1e-10
#: a simulation diverges when its output leaves this many times the scale
#: of the measured output (:func:`divergence_bound`)
DIVERGENCE_FACTOR = 1e4


# ------------------------------------------------------------------ scaling
def _unit_scale(norms: np.ndarray) -> np.ndarray:
    """``norms`` with zero entries set to 1 (in place): a zero column keeps
    its scale."""
    norms[norms == 0] = 1.0
    return norms


def column_norms(A) -> np.ndarray:
    """Euclidean norm of every column of ``A``, with 1 for a zero column:
    :math:`d_j = \\|a_j\\|_2` (or 1 where :math:`a_j = 0`)."""
    return _unit_scale(np.sqrt(np.einsum("ij,ij->j", A, A)))


def scale_columns(A) -> Tuple[np.ndarray, np.ndarray]:
    """``(A D⁻¹, d)``: ``A`` with unit-norm columns and the norms
    ``d`` (:func:`column_norms`); ``x = z / d`` maps a solution back."""
    d = column_norms(A)
    return A / d, d


def scale_gram(G, g) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(D⁻¹GD⁻¹, D⁻¹g, d)`` for normal equations ``G x = g``, with
    :math:`d = \\mathrm{diag}(G)^{1/2}` (the column norms of the regressors,
    1 for a zero column): the unit-diagonal scaling of :func:`scale_columns`."""
    d = _unit_scale(np.sqrt(np.diag(G)))
    return G / np.outer(d, d), g / d, d


# ------------------------------------------------------------------ rank
def rank_tolerance(shape, smax: float, rtol: Optional[float] = None) -> float:
    """Threshold on singular values: ``rtol * smax``, by default
    :math:`\\max(m, n)\\,\\epsilon\\,\\sigma_{max}`."""
    if rtol is None:
        rtol = max(shape) * EPS
    return rtol * smax


def numerical_rank(sv, shape, rtol: Optional[float] = None) -> int:
    """Number of ``sv`` (singular values, or magnitudes of the diagonal of
    a pivoted R) above :func:`rank_tolerance` of their largest."""
    sv = np.asarray(sv)
    if sv.size == 0:
        return 0
    return int(np.sum(sv > rank_tolerance(shape, float(np.max(sv)), rtol)))


def matrix_rank(A, rtol: Optional[float] = None) -> int:
    """Numerical rank of ``A`` (:func:`numerical_rank` of its singular values)."""
    A = np.atleast_2d(A)
    return numerical_rank(np.linalg.svd(A, compute_uv=False), A.shape, rtol)


# ------------------------------------------------------------------ least squares
_GELSY, _GELSY_LWORK = scipy.linalg.lapack.get_lapack_funcs(("gelsy", "gelsy_lwork"),
                                                             (np.empty((1, 1)),))
_LWORK: Dict[Tuple[int, int, int], int] = {}


def _gelsy(A: np.ndarray, b: np.ndarray, cond: float) -> Tuple[np.ndarray, int]:
    """``scipy.linalg.lstsq(A, b, lapack_driver='gelsy', cond=cond)``, bit for
    bit, without its per-call checks and with the workspace size (which
    depends only on the shape) asked once per shape: a structure search
    solves ~10^5 small systems."""
    m, n = A.shape
    nrhs = 1 if b.ndim == 1 else b.shape[1]
    lwork = _LWORK.get((m, n, nrhs))
    if lwork is None:
        work, info = _GELSY_LWORK(m, n, nrhs, cond)
        if info != 0:
            raise ValueError(f"gelsy workspace query failed (info={info})")
        lwork = _LWORK[(m, n, nrhs)] = int(np.real(work))
    if m < n:                              # room for the n unknowns, as scipy does
        b = np.concatenate((b, np.zeros((n - m,) + b.shape[1:])))
    jpvt = np.zeros((n, 1), dtype=np.int32)
    _, x, _, rank, info = _GELSY(A, b, jpvt, cond, lwork, False, False)
    if info < 0:
        raise ValueError(f"illegal value in argument {-info} of gelsy")
    return x[:n], int(rank)


_BLAS = None


def one_blas_thread():
    """Context manager: the loaded BLAS libraries on one thread inside it
    (``threadpoolctl``; the controller is built once, on first use, after
    numpy's and scipy's BLAS are loaded); see *Threads* in the module doc."""
    global _BLAS
    if _BLAS is None:
        from threadpoolctl import ThreadpoolController
        _BLAS = ThreadpoolController()
    return _BLAS.limit(limits=1, user_api="blas")


def lstsq(A, b, *, rcond: Optional[float] = None,
          driver: str = "gelsy") -> Tuple[np.ndarray, int]:
    """Minimum-norm solution of :math:`\\min_x \\|Ax - b\\|_2` and the rank used.

    Parameters
    ----------
    A : (m, n) array
    b : (m,) or (m, k) array
    rcond : float, optional
        Relative rank tolerance (default :math:`\\max(m, n)\\,\\epsilon`,
        :func:`rank_tolerance`).
    driver : {'gelsy', 'gelsd'}
        QR with column pivoting (complete orthogonal factorisation), or the
        SVD (``numpy.linalg.lstsq``).

    Returns
    -------
    x : ndarray
    rank : int
    """
    A = np.asarray(A, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if rcond is None:
        rcond = max(A.shape) * EPS
    if driver == "gelsy":
        with one_blas_thread():
            return _gelsy(A, b, rcond)
    if driver == "gelsd":
        with one_blas_thread():
            x, _, rank, _ = np.linalg.lstsq(A, b, rcond=rcond)
        return x, int(rank)
    raise ValueError(f"driver must be 'gelsy' or 'gelsd', got {driver!r}")


# ------------------------------------------------------------------ constraints
@dataclass(frozen=True)
class ConstraintSpace:
    """Solutions of :math:`S\\theta = c`: :math:`\\theta = \\theta_p + Zw`
    (of :math:`(SD^{-1})z = c` when built with a ``scale``,
    :func:`constraint_space`).

    Attributes
    ----------
    theta_p : ndarray
        Minimum-norm (least-squares) solution of :math:`S\\theta = c`.
    Z : ndarray
        Orthonormal basis of the null space of S (n × (n − rank)).
    rank : int
        Numerical rank of S (:func:`numerical_rank`).
    residual : float
        :math:`\\max_i |(S\\theta_p - c)_i|`.
    consistent : bool
        Whether some θ satisfies the equalities: ``residual`` at most
        :data:`CONSISTENCY_RTOL` × max(1, max|c|).
    """
    theta_p: np.ndarray
    Z: np.ndarray
    rank: int
    residual: float
    consistent: bool

    def lstsq(self, A, b) -> Tuple[np.ndarray, int]:
        """Constrained LS on the data matrix: θ minimising
        :math:`\\|A\\theta - b\\|` over this space, and the rank of the
        reduced problem :math:`AZ` (solved by :func:`scaled_lstsq`)."""
        if self.Z.shape[1] == 0:
            return self.theta_p, 0
        w, rank, _ = scaled_lstsq(A @ self.Z, b - A @ self.theta_p)
        return self.theta_p + self.Z @ w, rank

    def gram_lstsq(self, G, g, rcond: float = GRAM_RCOND) -> np.ndarray:
        """Constrained LS on normal equations :math:`G\\theta = g`:
        :math:`Z^TGZ\\,w = Z^T(g - G\\theta_p)` (``gelsy`` with ``rcond``)."""
        if self.Z.shape[1] == 0:
            return self.theta_p
        Z = self.Z
        w = lstsq(Z.T @ G @ Z, Z.T @ (g - G @ self.theta_p), rcond=rcond)[0]
        return self.theta_p + Z @ w


def constraint_space(S, c, scale=None) -> ConstraintSpace:
    """:class:`ConstraintSpace` of :math:`S\\theta = c`, or with ``scale``
    (d) of :math:`(SD^{-1})z = c` in the scaled coordinates
    :math:`z = D\\theta` of :func:`scale_columns`.

    The rank is that of S itself (:func:`numerical_rank`): a property of
    the constraints, not of the units of the regressors, whose column
    norms may span many orders of magnitude. θ_p is the SVD least-squares
    solution (``gelsd``), Z the right singular vectors of the (scaled)
    matrix past that rank.
    """
    S = np.atleast_2d(np.asarray(S, dtype=np.float64))
    c = np.asarray(c, dtype=np.float64).ravel()
    if scale is None:
        Z, rank = _null_space(S)
    else:
        rank = matrix_rank(S)
        S = S / scale
        Z, _ = _null_space(S, rank)
    theta_p = lstsq(S, c, driver="gelsd")[0]
    resid = float(np.max(np.abs(S @ theta_p - c))) if c.size else 0.0
    ok = resid <= CONSISTENCY_RTOL * max(1.0, float(np.max(np.abs(c), initial=0.0)))
    return ConstraintSpace(theta_p, Z, rank, resid, bool(ok))


def _null_space(S: np.ndarray, rank: Optional[int] = None) -> Tuple[np.ndarray, int]:
    """(Z, rank): the right singular vectors of S past ``rank`` (default
    its numerical rank)."""
    _, sv, Vt = np.linalg.svd(S)
    if rank is None:
        rank = numerical_rank(sv, S.shape)
    return Vt[rank:].T, rank


def null_space(S) -> np.ndarray:
    """Orthonormal basis Z (columns) of the null space of S:
    :math:`SZ = 0`, :math:`Z^TZ = I`, rank by :func:`numerical_rank`."""
    return _null_space(np.atleast_2d(np.asarray(S, dtype=np.float64)))[0]


def scaled_lstsq(A, b, S=None, c=None
                 ) -> Tuple[np.ndarray, int, Optional[ConstraintSpace]]:
    """LS (or CLS with ``S θ = c``) on unit-norm columns.

    Solves in the scaled coordinates :math:`z = D\\theta`
    (:func:`scale_columns`), where the constraints read
    :math:`(SD^{-1})z = c`, so the result does not depend on the units of
    the regressors. LS is :func:`lstsq` (``gelsy``, default rank rule);
    CLS is the null-space method (:meth:`ConstraintSpace.lstsq`).

    Returns
    -------
    theta : ndarray
    rank : int
        Rank of the LS problem; for CLS, rank of S plus rank of the reduced
        problem.
    space : ConstraintSpace or None
        The constraints in scaled coordinates (:func:`constraint_space`
        with ``scale``; None without ``S``); the
        caller decides what an inconsistent (``space.consistent``) or
        redundant (``space.rank < len(c)``) set means.
    """
    A, d = scale_columns(A)
    if S is None:
        z, rank = lstsq(A, b)
        return z / d, rank, None
    space = constraint_space(S, c, d)
    z, rank = space.lstsq(A, b)
    return z / d, rank + space.rank, space


def gram_lstsq(G, g, S=None, c=None, rcond: float = GRAM_RCOND
               ) -> Tuple[np.ndarray, Optional[ConstraintSpace]]:
    """LS (or CLS with ``S θ = c``) from normal equations ``G θ = g``.

    On the unit-diagonal scaling (:func:`scale_gram`), by ``gelsy`` with
    relative rank tolerance ``rcond`` (:data:`GRAM_RCOND`: the Gram matrix
    squares the regressors' condition number); the constraints as in
    :func:`scaled_lstsq`. Returns ``(theta, space)``.
    """
    Gs, gs, d = scale_gram(G, g)
    if S is None:
        return lstsq(Gs, gs, rcond=rcond)[0] / d, None
    space = constraint_space(S, c, d)
    return space.gram_lstsq(Gs, gs, rcond) / d, space


def iv_lstsq(ZtPsi, Ztb, z_norms, psi_norms, rcond: float = GRAM_RCOND) -> np.ndarray:
    r"""Instrumental-variable estimate from cross products: θ solving
    :math:`Z^T\Psi\theta = Z^Tb`.

    .. math:: \hat\theta_{IV} = (Z^T\Psi)^{-1} Z^T b

    with one instrument column per regressor ([4]_). The system is taken on
    unit-norm columns of both matrices (``z_norms`` and ``psi_norms``, the
    column norms :math:`\|z_j\|`, :math:`\|\psi_j\|`, 0 read as 1 as in
    :func:`column_norms`) and solved by ``gelsy`` with relative rank
    tolerance ``rcond`` (:data:`GRAM_RCOND`: like normal equations,
    :math:`Z^T\Psi` squares the columns' condition), so a rank-deficient
    system gives the minimum-norm solution. LS is the case :math:`Z = \Psi`.
    """
    dz = _unit_scale(np.array(z_norms, dtype=np.float64))
    dp = _unit_scale(np.array(psi_norms, dtype=np.float64))
    M = np.asarray(ZtPsi, dtype=np.float64) / np.outer(dz, dp)
    return lstsq(M, np.asarray(Ztb, dtype=np.float64) / dz, rcond=rcond)[0] / dp


def range_basis(A) -> np.ndarray:
    """Orthonormal basis Q of the column space of ``A``: QR with column
    pivoting of the unit-norm columns, truncated at the numerical rank of
    the diagonal of R (:func:`numerical_rank`)."""
    As, _ = scale_columns(A)
    Q, R, _ = scipy.linalg.qr(As, mode="economic", pivoting=True)
    return Q[:, :numerical_rank(np.abs(np.diag(R)), A.shape)]


# ------------------------------------------------------------------ t-statistics
def t_values(Psi, r, theta) -> np.ndarray:
    r"""|θ_i| / se(θ_i) of an LS fit with residuals ``r`` (``inf`` where
    the residual is zero).

    .. math::  \mathrm{se}(\theta_i) = \hat\sigma \, \|(R^{-T})_{:,i}\| / d_i,
               \quad \Psi D^{-1} = QR,\; \hat\sigma^2 = \frac{\|r\|^2}{N-p}

    (the diagonal of σ²(ΨᵀΨ)⁻¹ from the triangular factor of the unit-norm
    columns, :func:`scale_columns`). When the columns are dependent (a
    diagonal entry of R at most :data:`T_RTOL` of the largest), a
    coefficient that the data do not determine (its unit vector has a
    component in the null space of Ψ) gets t = 0; the others keep their
    t-statistic, from the diagonal of σ²(ΨᵀΨ)⁺ (thin SVD) with σ² on
    N − rank degrees of freedom (θ is then the minimum-norm solution, whose
    determined components are unique).
    """
    n, p = Psi.shape
    dof = max(n - p, 1)
    sigma = np.sqrt(float(r @ r) / dof)
    A, norms = scale_columns(Psi)
    R = np.linalg.qr(A, mode="r")
    if numerical_rank(np.abs(np.diag(R)), R.shape, T_RTOL) < p:
        return _t_dependent(A, norms, r, theta)
    Rinv_t = scipy.linalg.solve_triangular(R, np.eye(p), lower=False).T
    se = sigma * np.sqrt(np.sum(Rinv_t ** 2, axis=0)) / norms
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(se > 0, np.abs(theta) / se, np.inf)


def _t_dependent(A, norms, r, theta) -> np.ndarray:
    """t-statistics for dependent unit-norm regressors ``A``."""
    n, p = A.shape
    # thin SVD: only V is needed (the full one builds an n × n U: 8 GB at
    # n = 32,000); n >= p here, so Vt is p × p either way
    _, sv, Vt = np.linalg.svd(A, full_matrices=False)
    rank = numerical_rank(sv, A.shape, T_RTOL)
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


def added_column_t(Psi, b, C) -> np.ndarray:
    r"""|t| of each column of ``C`` added alone to the LS fit of ``b`` on
    ``Psi`` (one projection each, Frisch–Waugh):

    .. math:: t_c = \frac{|c_\perp^T r|/c_\perp^T c_\perp}
              {\sqrt{s^2/c_\perp^T c_\perp}},\quad
              s^2 = \frac{r^T r - (c_\perp^T r)^2/c_\perp^T c_\perp}{n - p - 1}

    with :math:`r` the residuals of the fit, :math:`c_\perp` the column
    minus its projection on the range of Psi (:func:`range_basis`) and p
    its rank. A column whose :math:`\|c_\perp\|^2` is at most
    :data:`GRAM_RCOND` of :math:`\|c\|^2` (dependent on Psi) gets 0.
    """
    Q = range_basis(Psi)
    r = b - Q @ (Q.T @ b)
    Cp = C - Q @ (Q.T @ C)
    cc = np.einsum("ij,ij->j", Cp, Cp)
    cr = Cp.T @ r
    dof = max(Psi.shape[0] - Q.shape[1] - 1, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        s2 = (r @ r - cr ** 2 / cc) / dof
        t = np.abs(cr / cc) / np.sqrt(s2 / cc)
    return np.where(cc > GRAM_RCOND * np.einsum("ij,ij->j", C, C), np.nan_to_num(t), 0.0)


# ------------------------------------------------------------------ divergence
def divergence_bound(y) -> float:
    """:data:`DIVERGENCE_FACTOR` × max|y| (× 1 when y is empty or zero): a
    simulated output beyond it counts as diverged."""
    y = np.asarray(y)
    scale = float(np.max(np.abs(y))) if y.size else 1.0
    return DIVERGENCE_FACTOR * (scale if scale > 0 else 1.0)
