"""Known polynomial NARX systems for structure-recovery tests.

Each generator returns a :class:`TestSystemData` holding the input ``u``,
the output ``y``, the noise ``e`` and the true model (term texts and theta),
so a test can check that an identification method recovers the structure.

Typical use::

    >>> from narx.systems.testsystems import system_S3, system_by_name, SYSTEMS
    >>> d = system_S3(n=500, seed=0)
    >>> d.terms[:2], d.theta[:2]
    (('y[k-1]*y[k-1]*y[k-1]', 'y[k-1]*u[k-1]'), (0.2, 0.7))
    >>> all(len(system_by_name(s, n=200, seed=1).y) == 200 for s in SYSTEMS)
    True

Conventions shared by every generator:

* the system obeys :math:`y_k = \\sum_i \\theta_i\\, t_i(k) + e_k`, where the
  terms :math:`t_i` are products of lagged ``y``, ``u`` and ``e`` written in
  canonical text (``y`` factors by increasing lag, then ``u``, then ``e``;
  powers as repeated factors, e.g. ``y[k-2]*u[k-2]*u[k-2]``);
* ``n + 100`` samples are simulated from zero initial conditions and the
  first ``TRANSIENT = 100`` are discarded, so the returned record starts in
  (near) stationary operation; the relation above holds for every returned
  sample with ``k >= max lag``;
* the input is drawn first, then the noise, from
  ``numpy.random.default_rng(seed)`` (``seed``: int or Generator), so for
  the generators with ``noise_std`` the input does not depend on it;
* :func:`system_by_name` with ``output_snr`` (dB) adds white measurement
  noise to the returned output, :math:`y^m_k = y_k + v_k`,
  :math:`v_k \\sim N(0, \\sigma_v^2)` with
  :math:`\\sigma_v = \\mathrm{std}(y)\\,10^{-\\mathrm{SNR}/20}`, drawn last
  from the same generator (so ``u`` and ``e`` do not depend on it). The
  true model then holds for the noise-free ``y_true``, not for ``y``.

References
----------
L. Piroddi and W. Spinelli, "An identification algorithm for polynomial
NARX models based on simulation error minimization", Int. J. Control 76
(2003) 1767-1781; S. A. Billings, *Nonlinear System Identification: NARMAX
Methods in the Time, Frequency, and Spatio-Temporal Domains*, Wiley, 2013.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Optional, Tuple

import numpy as np

from . import _count, _num, _rng

__all__ = ["TestSystemData", "TRANSIENT", "SYSTEMS", "system_S1", "system_S2",
           "system_S3", "system_S4", "system_S5", "system_S6", "system_piroddi",
           "system_by_name", "polynomial_narx", "hammerstein", "with_output_noise"]

#: samples simulated and discarded before the returned record
TRANSIENT = 100

#: names accepted by :func:`system_by_name`
SYSTEMS = ("S1", "S2", "S3", "S4", "S5", "S6")


@dataclass(frozen=True)
class TestSystemData:
    """Data of a known polynomial NARX system.

    Attributes
    ----------
    u, y, e : ndarray, shape (N,)
        Input, (measured) output and noise (the equation error :math:`e_k`).
    terms : tuple of str
        Canonical term texts of the true model.
    theta : tuple of float
        True parameters, in the order of ``terms``.
    name : str
        Name of the system.
    v : ndarray or None
        White measurement noise added to the output
        (:func:`with_output_noise`); None when there is none.
    """

    __test__ = False  # not a pytest test class despite its name

    u: np.ndarray
    y: np.ndarray
    e: np.ndarray
    terms: Tuple[str, ...]
    theta: Tuple[float, ...]
    name: str
    v: Optional[np.ndarray] = None

    @property
    def y_true(self) -> np.ndarray:
        """The output before measurement noise (``y`` when there is none)."""
        return self.y if self.v is None else self.y - self.v


def _start(n, seed, u_kind, u_scale, e_std):
    """Validated total length, input and noise (input drawn first)."""
    total = _count("n", n, 1) + TRANSIENT
    rng = _rng(seed)
    if u_kind == "uniform":
        u = rng.uniform(-u_scale, u_scale, total)
    else:
        u = rng.normal(0.0, u_scale, total)
    e = rng.normal(0.0, 1.0, total) * e_std
    return total, u, e, np.zeros(total)


def _done(name, u, y, e, terms, theta):
    if not np.all(np.isfinite(y)):  # pragma: no cover - systems are stable
        raise FloatingPointError(f"{name} diverged")
    s = slice(TRANSIENT, None)
    return TestSystemData(u=u[s].copy(), y=y[s].copy(), e=e[s].copy(), terms=tuple(terms),
                          theta=tuple(float(t) for t in theta), name=name)


def system_S1(n=500, seed=0):
    r"""Linear ARX system S1.

    .. math:: y_k = -1.7y_{k-1} - 0.8y_{k-2} + u_{k-1} + 0.81u_{k-2} + e_k,

    :math:`u \sim U(-2, 2)`, :math:`e \sim N(0, 0.01^2)`. ``n`` returned
    samples (after 100 discarded); ``seed`` int or Generator.
    """
    N, u, e, y = _start(n, seed, "uniform", 2.0, 0.01)
    for k in range(2, N):
        y[k] = -1.7 * y[k - 1] - 0.8 * y[k - 2] + u[k - 1] + 0.81 * u[k - 2] + e[k]
    return _done("S1", u, y, e, ("y[k-1]", "y[k-2]", "u[k-1]", "u[k-2]"),
                 (-1.7, -0.8, 1.0, 0.81))


def system_S2(n=500, seed=0):
    r"""System S2, linear dynamics with a cubic input nonlinearity.

    .. math:: y_k = 0.8y_{k-1} + 0.4u_{k-1} + 0.4u_{k-1}^2 + 0.4u_{k-1}^3 + e_k,

    :math:`u \sim N(0, 0.3^2)`, :math:`e \sim N(0, 0.01^2)`.
    """
    N, u, e, y = _start(n, seed, "normal", 0.3, 0.01)
    for k in range(1, N):
        a = u[k - 1]
        y[k] = 0.8 * y[k - 1] + 0.4 * a + 0.4 * a * a + 0.4 * a * a * a + e[k]
    return _done("S2", u, y, e, ("y[k-1]", "u[k-1]", "u[k-1]*u[k-1]", "u[k-1]*u[k-1]*u[k-1]"),
                 (0.8, 0.4, 0.4, 0.4))


def system_S3(n=500, seed=0):
    r"""Nonlinear system S3.

    .. math:: y_k = 0.2y_{k-1}^3 + 0.7y_{k-1}u_{k-1} + 0.6u_{k-2}^2
              - 0.7y_{k-2}u_{k-2}^2 - 0.5y_{k-2} + e_k,

    :math:`u \sim U(-1, 1)`, :math:`e \sim N(0, 0.01^2)`.
    """
    N, u, e, y = _start(n, seed, "uniform", 1.0, 0.01)
    for k in range(2, N):
        y1, y2, u1, u2 = y[k - 1], y[k - 2], u[k - 1], u[k - 2]
        y[k] = (0.2 * y1 * y1 * y1 + 0.7 * y1 * u1 + 0.6 * u2 * u2
                - 0.7 * y2 * u2 * u2 - 0.5 * y2 + e[k])
    return _done("S3", u, y, e, ("y[k-1]*y[k-1]*y[k-1]", "y[k-1]*u[k-1]", "u[k-2]*u[k-2]",
                                 "y[k-2]*u[k-2]*u[k-2]", "y[k-2]"),
                 (0.2, 0.7, 0.6, -0.7, -0.5))


_S4_TERMS = ("y[k-1]*u[k-1]", "y[k-2]", "u[k-2]*u[k-2]", "y[k-2]*u[k-2]*u[k-2]")
_S4_THETA = (0.7, -0.5, 0.6, -0.7)


def system_S4(n=500, seed=0):
    r"""Nonlinear system S4.

    .. math:: y_k = 0.7y_{k-1}u_{k-1} - 0.5y_{k-2} + 0.6u_{k-2}^2
              - 0.7y_{k-2}u_{k-2}^2 + e_k,

    :math:`u \sim U(-1, 1)`, :math:`e \sim N(0, 0.04^2)`.
    """
    N, u, e, y = _start(n, seed, "uniform", 1.0, 0.04)
    for k in range(2, N):
        y1, y2, u1, u2 = y[k - 1], y[k - 2], u[k - 1], u[k - 2]
        y[k] = 0.7 * y1 * u1 - 0.5 * y2 + 0.6 * u2 * u2 - 0.7 * y2 * u2 * u2 + e[k]
    return _done("S4", u, y, e, _S4_TERMS, _S4_THETA)


def system_S5(n=500, seed=0):
    r"""System S4 with coloured (NARMAX) noise, S5.

    .. math:: y_k = 0.7y_{k-1}u_{k-1} - 0.5y_{k-2} + 0.6u_{k-2}^2
              - 0.7y_{k-2}u_{k-2}^2 + 0.2e_{k-1} - 0.3u_{k-1}e_{k-2} + e_k,

    :math:`u \sim U(-1, 1)`, :math:`e \sim N(0, 0.02^2)`. The noise terms
    ``e[k-1]`` and ``u[k-1]*e[k-2]`` are part of ``terms``.
    """
    N, u, e, y = _start(n, seed, "uniform", 1.0, 0.02)
    for k in range(2, N):
        y1, y2, u1, u2 = y[k - 1], y[k - 2], u[k - 1], u[k - 2]
        y[k] = (0.7 * y1 * u1 - 0.5 * y2 + 0.6 * u2 * u2 - 0.7 * y2 * u2 * u2
                + 0.2 * e[k - 1] - 0.3 * u1 * e[k - 2] + e[k])
    return _done("S5", u, y, e, _S4_TERMS + ("e[k-1]", "u[k-1]*e[k-2]"),
                 _S4_THETA + (0.2, -0.3))


def _s6(name, n, seed, e_std):
    N, u, e, y = _start(n, seed, "normal", 0.25, e_std)
    for k in range(2, N):
        y[k] = 0.75 * y[k - 2] + 0.25 * u[k - 1] - 0.2 * y[k - 2] * u[k - 1] + e[k]
    return _done(name, u, y, e, ("y[k-2]", "u[k-1]", "y[k-2]*u[k-1]"), (0.75, 0.25, -0.2))


def system_S6(n=500, seed=0):
    r"""Nonlinear system S6.

    .. math:: y_k = 0.75y_{k-2} + 0.25u_{k-1} - 0.2y_{k-2}u_{k-1} + e_k,

    :math:`u \sim N(0, 0.25^2)`, :math:`e \sim N(0, 0.02^2)`. The
    equation noise carried through the lightly damped dynamics (poles
    :math:`\pm 0.87`) gives a free-run error of std about 0.03, against
    :math:`\sigma_v \approx 0.01` of 20 dB output noise: the simulation
    error of the true structure is coloured.
    """
    return _s6("S6", n, seed, 0.02)


def system_piroddi(n=1000, seed=0, noise_std=0.0):
    r"""Deterministic part of S6 (Piroddi and Spinelli, 2003), noise-free by default.

    .. math:: y_k = 0.75y_{k-2} + 0.25u_{k-1} - 0.2y_{k-2}u_{k-1} + e_k,

    :math:`u \sim N(0, 0.25^2)`, :math:`e \sim N(0,` ``noise_std`` :math:`^2)`.
    With ``noise_std = 0`` least squares on the true terms recovers theta to
    rounding error.
    """
    return _s6("piroddi", n, seed, _num("noise_std", noise_std, "nonneg"))


def system_by_name(name, n=500, seed=0, output_snr=None):
    """The system called ``name`` (one of :data:`SYSTEMS`, case-insensitive).

    ``output_snr`` (dB, optional): add white measurement noise to the
    output at this signal-to-noise ratio (:func:`with_output_noise`), drawn
    from the same generator after the input and the equation noise.
    """
    key = name.upper() if isinstance(name, str) else name
    if key not in SYSTEMS:
        raise ValueError(f"name must be one of {', '.join(SYSTEMS)}, got {name!r}")
    if output_snr is None:
        return globals()[f"system_{key}"](n=n, seed=seed)
    snr = _num("output_snr", output_snr)
    rng = _rng(seed)
    return with_output_noise(globals()[f"system_{key}"](n=n, seed=rng), snr, rng)


def with_output_noise(d: TestSystemData, snr_db: float, seed=0) -> TestSystemData:
    r"""``d`` with white measurement noise on its output at ``snr_db`` dB.

    .. math:: y^m_k = y_k + v_k,\qquad v_k \sim N(0, \sigma_v^2),\qquad
              \sigma_v = \mathrm{std}(y)\,10^{-\mathrm{SNR}/20}

    (SNR = 10 log10 of the ratio of the variances; 20 dB: σ_v is 10 % of
    the output's standard deviation). The noise enters the regressors of
    every output lag, so least squares on the measured record is biased
    (errors in variables). ``seed``: int or Generator; the noise is in
    ``v`` and the noise-free output in ``y_true``.
    """
    if d.v is not None:
        raise ValueError(f"the output of {d.name} already has measurement noise")
    snr = _num("snr_db", snr_db)
    v = _rng(seed).normal(0.0, 1.0, d.y.shape[0]) * (np.std(d.y) * 10.0 ** (-snr / 20.0))
    return replace(d, y=d.y + v, v=v)


def polynomial_narx(n=1000, seed=0, noise_std=0.0):
    r"""Stable polynomial NARX system without hysteresis (diagnosis control).

    .. math:: y_k = 0.5y_{k-1} + 0.3u_{k-1} + 0.1u_{k-1}^2
              - 0.05y_{k-1}u_{k-1} + e_k,

    :math:`u \sim U(-1, 1)`, :math:`e \sim N(0,` ``noise_std`` :math:`^2)`.
    With the input held at :math:`\bar u` it has one steady state
    :math:`\bar y = (0.3\bar u + 0.1\bar u^2)/(0.5 + 0.05\bar u)`, not a continuum.
    """
    N, u, e, y = _start(n, seed, "uniform", 1.0, _num("noise_std", noise_std, "nonneg"))
    for k in range(1, N):
        y1, u1 = y[k - 1], u[k - 1]
        y[k] = 0.5 * y1 + 0.3 * u1 + 0.1 * u1 * u1 - 0.05 * y1 * u1 + e[k]
    return _done("polynomial_narx", u, y, e,
                 ("y[k-1]", "u[k-1]", "u[k-1]*u[k-1]", "y[k-1]*u[k-1]"), (0.5, 0.3, 0.1, -0.05))


def hammerstein(n=1000, seed=0, noise_std=0.0):
    r"""Hammerstein system: static polynomial then a stable 2nd-order filter.

    .. math::

        v_k = u_k + 0.5u_k^2 - 0.3u_k^3, \qquad
        y_k = y_{k-1} - 0.3y_{k-2} + 0.5v_{k-1} + 0.3v_{k-2} + e_k,

    (poles :math:`|z| = \sqrt{0.3}`), :math:`u \sim U(-1, 1)`,
    :math:`e \sim N(0,` ``noise_std`` :math:`^2)`. As a NARX model its terms
    are ``y[k-1]``, ``y[k-2]`` and ``u[k-j]``, ``u[k-j]^2``, ``u[k-j]^3`` for
    j = 1, 2 with theta ``0.5*(1, 0.5, -0.3)`` and ``0.3*(1, 0.5, -0.3)``.
    A diagnosis control: no hysteresis, one steady state per input level.
    """
    N, u, e, y = _start(n, seed, "uniform", 1.0, _num("noise_std", noise_std, "nonneg"))
    v = u + 0.5 * u ** 2 - 0.3 * u ** 3
    for k in range(2, N):
        y[k] = y[k - 1] - 0.3 * y[k - 2] + 0.5 * v[k - 1] + 0.3 * v[k - 2] + e[k]
    terms = ("y[k-1]", "y[k-2]", "u[k-1]", "u[k-1]*u[k-1]", "u[k-1]*u[k-1]*u[k-1]",
             "u[k-2]", "u[k-2]*u[k-2]", "u[k-2]*u[k-2]*u[k-2]")
    theta = (1.0, -0.3, 0.5, 0.5 * 0.5, 0.5 * -0.3, 0.3, 0.3 * 0.5, 0.3 * -0.3)
    return _done("hammerstein", u, y, e, terms, theta)
