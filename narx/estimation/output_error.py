"""Output-error estimation of θ for one structure, fast enough for a search.

Typical use (inside :class:`narx.estimation.fitness.StructureScorer` with
``estimator='oe'``)::

    from narx.estimation.output_error import (OutputErrorProblem, output_error_theta,
                                   innovation_mse, noise_order)
    problem = OutputErrorProblem(y, Psi, start, instruments, freerun, scored)
    theta = output_error_theta(problem, theta_ls)
    score = innovation_mse(y - simulated, noise_order(len(y) - start))

When the output is measured with white noise, :math:`y_k = x_k + v_k`,
the regressors built from the measured output carry the noise too, and
least squares on them is biased (errors in variables [1]_): the one-step
error is then smallest for a wrong θ, and a structure search scoring
simulations of that θ prefers extra lags that compensate the bias. Two
steps remove the bias:

1. *Instrumental variables* (IV, [1]_ ch. 8; the auxiliary-model
   instruments of Young's refined IV [2]_): the instruments :math:`Z` are
   the regressors rebuilt from the noise-free free-run output
   :math:`\\hat x(\\theta)` of the current model, which depends on the
   input only, so :math:`E[Z^T v] = 0`;
   :math:`\\theta \\leftarrow (Z^T\\Psi)^{-1}Z^Ty`
   (:func:`narx.linalg.iv_lstsq`), repeated :data:`IV_ITERATIONS` times
   from the LS θ. It is consistent for terms linear in each lagged output
   (powers of one output lag keep a bias of order :math:`\\sigma_v^2`).
2. *Gauss–Newton on the simulation error*: IV is consistent but not
   efficient, and an information criterion compares fitness values that
   differ by :math:`\\ln N / N` per term, well below the spread of IV
   estimates on lightly damped systems. Starting at the IV θ,
   :data:`GN_ITERATIONS` Gauss–Newton steps minimise the scored simulation
   error :math:`\\sum_k (y_k - \\hat y_k(\\theta))^2` (the output-error,
   maximum-likelihood criterion for white output noise [3]_), with a
   forward-difference Jacobian (one simulation per parameter) and step
   halving; a step is kept only when it lowers the error.

A structure whose simulations diverge keeps the last θ that did not.

With ``estimator='oe'`` a structure scores the mean squared simulation
error. With ``'bj'`` (same θ) it scores the variance of that error after
an autoregressive noise model, of order chosen by BIC up to
:data:`NOISE_ORDER`, has whitened it (:func:`innovation_mse`): the
prediction error of a Box–Jenkins model [4]_. With white output noise alone
the simulation error of the true structure is white and both agree; with
equation noise too (carried through the dynamics, hence coloured) an
information criterion on the plain mean squared error rewards terms that
fit the disturbance's realisation, which the whitened score does not. The
noise model of a wrong structure also whitens part of its misfit, which is
coloured as well, so wrong structures score closer to the true one than by
the plain error.

References
----------
.. [1] Söderström, T., Stoica, P., *System Identification*, Prentice Hall,
   1989, ch. 7-8.
.. [2] Young, P. C., "Refined instrumental variable estimation: maximum
   likelihood optimization of a unified Box-Jenkins model", Automatica 51
   (2015) 35-46.
.. [3] Piroddi, L., Spinelli, W., "An identification algorithm for
   polynomial NARX models based on simulation error minimization",
   Int. J. Control 76 (2003) 1767-1781.
.. [4] Ljung, L., *System Identification: Theory for the User*, 2nd ed.,
   Prentice Hall, 1999, sec. 4.2 and 7.3.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Tuple

import numpy as np

from .gram import cross_products, fixed_dot
from ..linalg import gram_lstsq, iv_lstsq

__all__ = ["ESTIMATORS", "OE_ESTIMATORS", "IV_ITERATIONS", "GN_ITERATIONS", "GN_RTOL", "BURN_IN",
           "NOISE_ORDER", "OutputErrorProblem", "iv_theta", "gauss_newton",
           "output_error_theta", "burn_in", "check_estimator", "noise_order",
           "innovation_mse"]

#: θ estimators of a structure search: least squares, output error, or
#: output error scored with a noise model (Box–Jenkins)
ESTIMATORS = ("ls", "oe", "bj")
#: the estimators whose θ is the output-error estimate
OE_ESTIMATORS = ("oe", "bj")
#: IV passes, each with instruments from the previous θ's free run
IV_ITERATIONS = 2
#: Gauss-Newton steps on the simulation error
GN_ITERATIONS = 3
#: Gauss-Newton stops when a step lowers the error by less than this fraction
GN_RTOL = 1e-4
#: step halvings tried before a Gauss-Newton step is given up
GN_HALVINGS = 6
#: simulated steps at the start of each window that the output-error score
#: leaves out (the transient of noisy initial conditions)
BURN_IN = 50
#: largest order of the autoregressive noise model of the simulation error
NOISE_ORDER = 8

Simulation = Callable[[np.ndarray], Tuple[np.ndarray, bool]]


def check_estimator(estimator, fitness: str, constraints=None) -> None:
    """Raise ``ValueError`` unless ``estimator`` is one of :data:`ESTIMATORS`
    and, for ``'oe'`` and ``'bj'``, the fitness simulates (``'ms'`` or ``'freerun'``:
    the one-step error is what least squares already minimises) and θ is
    unconstrained."""
    if not any(estimator is e or (type(estimator) is str and estimator == e)
               for e in ESTIMATORS):
        raise ValueError(f"estimator must be one of {', '.join(map(repr, ESTIMATORS))}, "
                         f"got {estimator!r}")
    if estimator in OE_ESTIMATORS and fitness not in ("ms", "freerun"):
        raise ValueError(f"estimator={estimator!r} needs a simulation fitness ('ms' or "
                         f"'freerun'), got fitness={fitness!r}")
    if estimator in OE_ESTIMATORS and constraints is not None:
        raise ValueError(f"estimator={estimator!r} estimates unconstrained θ, got "
                         f"constraints={constraints!r}")


def burn_in(fitness: str, window: int) -> int:
    """Steps left out at the start of each simulated window by the
    output-error score: :data:`BURN_IN`, at most half a multiple-shooting
    window; 0 for the one-step fitness.

    The first outputs of a window are simulated from measured, hence noisy,
    initial conditions; their error is the noise propagated by the model's
    dynamics, which a structure with extra output lags can average away,
    so it would be rewarded for terms the system does not have.
    """
    if fitness == "freerun":
        return BURN_IN
    if fitness == "ms":
        return min(BURN_IN, int(window) // 2)
    return 0


@dataclass
class OutputErrorProblem:
    """One structure on one record, as the output-error estimator sees it.

    Attributes
    ----------
    y : ndarray, shape (N,)
        Measured output.
    Psi : ndarray, shape (p, N - start)
        Regressors from the measured output, one row per term, samples
        ``start..N-1``.
    start : int
        First sample of ``Psi``.
    instruments : callable
        ``instruments(x)``: the regressors rebuilt from a simulated output
        ``x`` (length N), laid out as ``Psi``.
    freerun : callable
        ``freerun(theta) -> (out, diverged)``: the free run from ``start``
        (``out`` of length N, NaN before ``start``).
    scored : callable
        ``scored(theta) -> (out, diverged)``: the simulation whose error is
        minimised, NaN at the samples it does not score.
    """
    y: np.ndarray
    Psi: np.ndarray
    start: int
    instruments: Callable[[np.ndarray], np.ndarray]
    freerun: Simulation
    scored: Simulation


def iv_theta(problem: OutputErrorProblem, theta: np.ndarray,
             iterations: int = IV_ITERATIONS) -> np.ndarray:
    """θ after ``iterations`` IV passes, each with instruments from the
    free run of the previous θ (stops at a diverging free run). Every cross
    product is summed in a fixed order (:func:`narx.estimation.gram.cross_products`),
    so θ does not depend on the process that computes it."""
    s, y = problem.start, problem.y
    Psi = problem.Psi
    b = np.ascontiguousarray(y[s:])[None, :]
    psi_norms = np.sqrt([fixed_dot(row, row) for row in Psi])
    for _ in range(iterations):
        out, diverged = problem.freerun(theta)
        if diverged:
            break
        x = out.copy()
        x[:s] = y[:s]                     # the free run's initial conditions
        Z = np.ascontiguousarray(problem.instruments(x))
        z_norms = np.sqrt([fixed_dot(row, row) for row in Z])
        new = iv_lstsq(cross_products(Z, Psi), cross_products(Z, b)[:, 0], z_norms,
                       psi_norms)
        if not np.all(np.isfinite(new)):
            break
        theta = new
    return theta


def _error(problem, theta):
    """(residual at the scored samples, their mask), or None when diverged."""
    out, diverged = problem.scored(theta)
    if diverged:
        return None
    mask = np.isfinite(out)
    return problem.y[mask] - out[mask], mask


def gauss_newton(problem: OutputErrorProblem, theta: np.ndarray,
                 iterations: int = GN_ITERATIONS) -> np.ndarray:
    r"""θ after at most ``iterations`` Gauss–Newton steps on the scored
    simulation error.

    Each step solves :math:`J^TJ\,\delta = J^Tr` (:func:`narx.linalg.gram_lstsq`,
    unit-diagonal scaling; products in a fixed order) with
    :math:`J_{ki} = \partial\hat y_k/\partial\theta_i`
    by forward differences (:math:`h_i = 10^{-6}\max(1, |\theta_i|)`), and
    takes the first of :math:`\delta, \delta/2, \dots` (:data:`GN_HALVINGS`)
    that lowers :math:`\|r\|^2`; it stops when none does or the decrease is
    below :data:`GN_RTOL`.
    """
    first = _error(problem, theta)
    if first is None:
        return theta
    r, mask = first
    cost = fixed_dot(r, r)
    out = problem.y[mask] - r
    p = theta.size
    for _ in range(iterations):
        J = np.empty((p, r.size))            # one row per parameter
        for i in range(p):
            h = 1e-6 * max(1.0, abs(theta[i]))
            th = theta.copy()
            th[i] += h
            o, diverged = problem.scored(th)
            if diverged:
                return theta
            J[i] = (o[mask] - out) / h
        step = gram_lstsq(cross_products(J, J), cross_products(J, r[None, :])[:, 0])[0]
        lam, accepted = 1.0, None
        for _ in range(GN_HALVINGS):
            th = theta + lam * step
            e = _error(problem, th)
            if e is not None and fixed_dot(e[0], e[0]) < cost:
                accepted = th, e[0], fixed_dot(e[0], e[0])
                break
            lam *= 0.5
        if accepted is None:
            break
        th, r, new_cost = accepted
        done = cost - new_cost < GN_RTOL * cost
        theta, cost, out = th, new_cost, problem.y[mask] - r
        if done:
            break
    return theta


def output_error_theta(problem: OutputErrorProblem, theta: np.ndarray) -> np.ndarray:
    """IV from the least-squares ``theta`` (:func:`iv_theta`), then
    Gauss–Newton on the scored simulation error (:func:`gauss_newton`)."""
    return gauss_newton(problem, iv_theta(problem, np.asarray(theta, dtype=np.float64)))


def noise_order(length: int) -> int:
    """Largest order of the noise model on scored runs of ``length``
    samples: :data:`NOISE_ORDER`, at most a quarter of a run (0 for runs
    shorter than 4 samples: the simulation error is then scored as is)."""
    return max(0, min(NOISE_ORDER, int(length) // 4))


def innovation_mse(r: np.ndarray, order: int) -> float:
    r"""Innovation variance of the simulation error ``r`` under an
    autoregressive noise model of order chosen by BIC, with that choice's
    penalty.

    ``r`` holds the simulation error at the scored samples and NaN
    elsewhere (the runs of a multiple-shooting record are separated by
    NaN). When the disturbance is not white at the output, e.g. equation
    noise :math:`e_k` carried through the dynamics plus measurement noise
    :math:`v_k`, the simulation error of the true structure is coloured,
    :math:`r_k = H(q)\varepsilon_k`, and a mean squared error counts every
    sample as independent: a term that fits the realisation of the
    low-frequency disturbance by chance lowers it by far more than an
    information criterion's per-term penalty assumes. The Gaussian
    likelihood of the Box–Jenkins model :math:`y = G(q,\theta)u +
    H(q)\varepsilon` (Ljung, *System Identification*, 1999, sec. 4.2 and
    7.3) scores the whitened error instead: with
    :math:`1/H \approx A_m(q) = 1 - a_1q^{-1} - \dots - a_mq^{-m}` fitted by
    least squares on the :math:`n` samples of ``r`` whose ``order`` previous
    samples are scored (the same samples for every :math:`m`),

    .. math:: \sigma^2_m = \frac1n\sum_k (A_m(q) r)_k^2,\qquad
              m^* = \arg\min_{0\le m\le M} n\ln\sigma^2_m + m\ln n,

    :math:`M` = ``order``; the value returned is
    :math:`\sigma^2_{m^*} n^{m^*/n}`,
    whose :math:`n\ln(\cdot)` is the noise model's BIC: the structure's
    own terms are penalised by the search's criterion on top. A white
    simulation error (output noise only) gives :math:`m^* = 0`: the mean
    squared error. Every sum is taken in a fixed order
    (:func:`narx.estimation.gram.cross_products`).
    """
    r = np.asarray(r, dtype=np.float64)
    ok = np.isfinite(r)
    order = max(0, int(order))
    rows = ok.copy()                     # samples whose `order` predecessors are scored
    for j in range(1, order + 1):
        rows[j:] &= ok[:-j]
    rows[:order] = False
    k = np.flatnonzero(rows)
    n = k.size
    if n == 0:
        return float("inf")
    t = np.ascontiguousarray(r[k])
    X = np.ascontiguousarray(np.stack([r[k - j] for j in range(1, order + 1)])) if order \
        else np.empty((0, n))
    G, g = cross_products(X, X), cross_products(X, t[None, :])[:, 0]
    best = None
    for m in range(min(order, (n - 1) // 2) + 1):
        w = t.copy()
        if m:
            a = gram_lstsq(G[:m, :m], g[:m])[0]
            for j in range(m):           # fixed order: no BLAS in the residual
                w -= a[j] * X[j]
        var = fixed_dot(w, w) / n
        if not var > 0:                  # an exact fit
            return float(var)
        bic = n * np.log(var) + m * np.log(n)
        if best is None or bic < best[0]:
            best = (bic, var * np.exp(m * np.log(n) / n))
    return float(best[1])
