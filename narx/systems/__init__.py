"""Reference hysteretic systems and excitation signals.

The piezoelectric actuator of the published case study (Bouc-Wen hysteresis,
RK4 at 1 ms), its training and validation inputs, a sine with two holds for
steady-state tests, a Prandtl-Ishlinskii model and a discrete Bouc-Wen model
that is exactly a NARX model with a user Phi-function of the output.

Typical use::

    >>> from narx.systems import piezo_bouc_wen, training_input, sine_input, held_sine
    >>> u = training_input(n=50_000, seed=0)          # +/-80 V, ~1 Hz
    >>> y = piezo_bouc_wen(u)                          # displacement, um
    >>> t, uv = sine_input()                           # 40 sin(2 pi t), 5 s
    >>> yv = piezo_bouc_wen(uv)
    >>> hs = held_sine()                               # loop, then two holds
    >>> drift = piezo_bouc_wen(hs.u)[hs.hold_falling]  # constant if it holds

Every random function takes ``seed`` (int or ``numpy.random.Generator``);
no global random state is used.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy import signal


__all__ = ["piezo_bouc_wen", "training_input", "sine_input", "HeldSine", "held_sine",
           "prandtl_ishlinskii", "bouc_wen_discrete", "bouc_wen_discrete_narx",
           "pi_first_order", "backlash_second_order", "OperatorRecord",
           "OPERATOR_SYSTEMS", "operator_record"]


# ---------------------------------------------------------------- validation
def _num(name, value, rule=None):
    """``float(value)``, checked finite and, for rule 'pos'/'nonneg', > 0 / >= 0."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if not (math.isfinite(x) and (rule is None or (x > 0 if rule == "pos" else x >= 0))):
        need = {None: "", "pos": " > 0", "nonneg": " >= 0"}[rule]
        raise ValueError(f"{name} must be a finite number{need}, got {value!r}")
    return x


def _count(name, value, minimum):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def _signal(name, u, min_len=1):
    """1-D contiguous float64 array of finite values with >= min_len samples."""
    try:
        arr = np.ascontiguousarray(u, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a 1-D array of numbers, "
                         f"got {type(u).__name__}") from None
    if arr.ndim != 1 or arr.size < min_len or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be a 1-D array of at least {min_len} finite numbers, "
                         f"got shape {arr.shape} with {int(np.sum(~np.isfinite(arr)))} non-finite")
    return arr


def _rng(seed):
    if isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative int or a numpy.random.Generator, "
                         f"got {seed!r}")
    return np.random.default_rng(int(seed))


# ------------------------------------------------------------ piezo (RK4)
@njit(cache=True)
def _piezo_rk4(u, dt, d_p, A, beta, gamma, h0):  # pragma: no cover - compiled
    n = u.shape[0]
    y = np.empty(n)
    h = h0
    y[0] = d_p * u[0] - h
    for k in range(n - 1):
        v = (u[k + 1] - u[k]) / dt          # du/dt, constant over the interval
        av = abs(v)
        k1 = A * v - beta * av * h - gamma * v * abs(h)
        h2 = h + 0.5 * dt * k1
        k2 = A * v - beta * av * h2 - gamma * v * abs(h2)
        h3 = h + 0.5 * dt * k2
        k3 = A * v - beta * av * h3 - gamma * v * abs(h3)
        h4 = h + dt * k3
        k4 = A * v - beta * av * h4 - gamma * v * abs(h4)
        h = h + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        y[k + 1] = d_p * u[k + 1] - h
    return y


def piezo_bouc_wen(u, dt=1e-3, d_p=1.6, A=0.9, beta=0.008, gamma=0.008, h0=0.0):
    r"""Simulate the piezoelectric actuator with Bouc-Wen hysteresis.

    .. math::

        \dot h = A\,\dot u - \beta\,|\dot u|\,h - \gamma\,\dot u\,|h|,
        \qquad y = d_p\,u - h

    The input is taken piecewise linear between samples, so
    :math:`\dot u = (u_{k+1}-u_k)/\Delta t` is constant on each interval,
    which is integrated by one classic RK4 step of length ``dt``. With
    ``beta = gamma = 0`` RK4 is exact: ``y = (d_p - A) u`` if ``u[0] = h0 = 0``.

    Parameters
    ----------
    u : array_like, shape (N,)
        Input voltage (V), sampled every ``dt``.
    dt : float
        Sampling period and RK4 step (s), > 0.
    d_p : float
        Piezoelectric coefficient (um/V).
    A, beta, gamma : float
        Bouc-Wen parameters (um/V, 1/V, 1/V).
    h0 : float
        Initial hysteretic state (um).

    Returns
    -------
    y : ndarray, shape (N,)
        Displacement (um); ``y[0] = d_p*u[0] - h0``.

    References
    ----------
    M. Rakotondrabe, "Bouc-Wen modeling and inverse multiplicative structure
    to compensate hysteresis nonlinearity in piezoelectric actuators",
    IEEE Trans. Autom. Sci. Eng. 8 (2011) 428-431.
    """
    u = _signal("u", u)
    dt = _num("dt", dt, "pos")
    args = [_num(n, v) for n, v in
            (("d_p", d_p), ("A", A), ("beta", beta), ("gamma", gamma), ("h0", h0))]
    return _piezo_rk4(u, dt, *args)


# ------------------------------------------------------------------ inputs
def training_input(n=50_000, dt=1e-3, amplitude=80.0, bandwidth=1.0, seed=0, order=4):
    r"""Filtered pseudo-random training input spanning exactly +/-amplitude.

    White Gaussian noise is filtered by a zero-phase Butterworth low-pass of
    order ``order`` (``scipy.signal.sosfiltfilt``, so the magnitude response
    is squared) with cut-off ``bandwidth`` Hz, then scaled affinely so that

    .. math:: \min_k u_k = -a, \qquad \max_k u_k = +a .

    ``1/bandwidth`` s of extra noise on each side is filtered and discarded.

    Parameters
    ----------
    n : int
        Number of samples, >= 2.
    dt : float
        Sampling period (s), > 0.
    amplitude : float
        Half range ``a`` of the signal, > 0.
    bandwidth : float
        Cut-off frequency (Hz), 0 < bandwidth < 1/(2 dt).
    seed : int or numpy.random.Generator
        Seed; the same seed gives the same signal.
    order : int
        Order of the Butterworth filter, >= 1. A low order keeps more power
        above the cut-off, hence faster input rates.

    Returns
    -------
    u : ndarray, shape (n,)

    References
    ----------
    L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
    Prentice Hall, 1999, sec. 13.3 (filtered noise inputs).
    """
    n = _count("n", n, 2)
    dt = _num("dt", dt, "pos")
    amplitude = _num("amplitude", amplitude, "pos")
    bandwidth = _num("bandwidth", bandwidth, "pos")
    order = _count("order", order, 1)
    if bandwidth >= 0.5 / dt:
        raise ValueError(f"bandwidth must be < the Nyquist frequency 1/(2*dt) = {0.5 / dt:g} Hz, "
                         f"got {bandwidth!r}")
    rng = _rng(seed)
    pad = int(math.ceil(1.0 / (bandwidth * dt)))
    noise = rng.standard_normal(n + 2 * pad)
    sos = signal.butter(order, bandwidth, btype="low", output="sos", fs=1.0 / dt)
    x = signal.sosfiltfilt(sos, noise)[pad:pad + n]
    lo, hi = x.min(), x.max()
    return amplitude * (2.0 * (x - lo) / (hi - lo) - 1.0)


def sine_input(duration=5.0, amplitude=40.0, freq=1.0, dt=1e-3):
    r"""Sine input :math:`u_k = a \sin(2\pi f t_k)`, :math:`t_k = k\,\Delta t`.

    ``round(duration/dt)`` samples are returned, so the defaults (the
    published validation input 40 sin(2 pi t) V for 5 s at 1 ms) give 5000
    samples covering exactly five periods.

    Parameters
    ----------
    duration : float
        Length (s), > 0.
    amplitude : float
        Amplitude ``a``, >= 0.
    freq : float
        Frequency ``f`` (Hz), > 0.
    dt : float
        Sampling period (s), > 0 and <= duration.

    Returns
    -------
    t, u : ndarray, shape (N,)
    """
    duration = _num("duration", duration, "pos")
    amplitude = _num("amplitude", amplitude, "nonneg")
    freq = _num("freq", freq, "pos")
    dt = _num("dt", dt, "pos")
    if dt > duration:
        raise ValueError(f"dt must be <= duration = {duration!r}, got {dt!r}")
    t = np.arange(int(round(duration / dt))) * dt
    return t, amplitude * np.sin(2.0 * np.pi * freq * t)


@dataclass(frozen=True)
class HeldSine:
    """A sine with two holds, returned by :func:`held_sine`.

    Attributes
    ----------
    t, u : ndarray, shape (N,)
        Time (s) and input.
    hold_rising, hold_falling : slice
        Samples during which ``u`` is constant, on the rising (loading) and
        on the falling (unloading) branch; each slice starts at the sample
        where the input stops and spans ``hold`` seconds.
    """

    t: np.ndarray
    u: np.ndarray
    hold_rising: slice
    hold_falling: slice


def held_sine(amplitude=40.0, freq=1.0, dt=1e-3, cycles=2, hold=1.0,
              phase_rising=np.pi / 4, phase_falling=3 * np.pi / 4):
    r"""Sine whose input is held constant once while rising and once while falling.

    :math:`u = a\sin\varphi`, the phase :math:`\varphi` advancing by
    :math:`2\pi f \Delta t` per sample except during two holds of ``hold``
    seconds, at :math:`\varphi = 2\pi +` ``phase_rising`` (loading branch)
    and :math:`2\pi +` ``phase_falling`` (unloading branch): a whole loop is
    traced before the first hold, and ``cycles`` periods in all. A
    rate-independent hysteretic system keeps its output constant during each
    hold (continuum of steady states); the slices let callers measure a
    model's drift and steady-state error there.

    Parameters
    ----------
    amplitude : float
        Amplitude ``a``, > 0.
    freq : float
        Frequency (Hz), > 0.
    dt : float
        Sampling period (s), > 0 and < 1/(4 freq).
    cycles : int
        Number of whole periods traced (holds excluded), >= 2.
    hold : float
        Duration of each hold (s), > 0.
    phase_rising, phase_falling : float
        Phases (rad) within the second period where the holds start;
        ``cos(phase_rising) > 0`` and ``cos(phase_falling) < 0`` and
        ``phase_rising`` must come before ``phase_falling`` in [0, 2 pi).

    Returns
    -------
    HeldSine

    References
    ----------
    J. Oh and D. S. Bernstein, "Semilinear Duhem model for rate-independent
    and rate-dependent hysteresis", IEEE TAC 50 (2005) 631-645.
    """
    amplitude = _num("amplitude", amplitude, "pos")
    freq = _num("freq", freq, "pos")
    dt = _num("dt", dt, "pos")
    if dt >= 0.25 / freq:
        raise ValueError(f"dt must be < 1/(4*freq) = {0.25 / freq!r}, got {dt!r}")
    cycles = _count("cycles", cycles, 2)
    hold = _num("hold", hold, "pos")
    pr = _num("phase_rising", phase_rising) % (2 * np.pi)
    pf = _num("phase_falling", phase_falling) % (2 * np.pi)
    for name, ph, sgn, branch in (("phase_rising", pr, 1, "rising"),
                                  ("phase_falling", pf, -1, "falling")):
        if not sgn * np.cos(ph) > 1e-9:
            raise ValueError(f"{name} must be on the {branch} branch, cos({name}) "
                             f"{'>' if sgn > 0 else '<'} 0, got {ph!r}")
    period = 1.0 / (freq * dt)                     # samples per period
    j_r = int(round((1.0 + pr / (2 * np.pi)) * period))
    j_f = int(round((1.0 + pf / (2 * np.pi)) * period))
    if not j_f > j_r:
        raise ValueError(f"phase_falling must come at least one sample after phase_rising "
                         f"(= {phase_rising!r}) within [0, 2*pi), got {phase_falling!r}")
    n_move = int(round(cycles * period)) + 1
    phase = 2.0 * np.pi * freq * dt * np.arange(n_move)
    n_hold = max(1, int(round(hold / dt)))
    idx = np.concatenate([np.arange(j_r + 1), np.full(n_hold, j_r),
                          np.arange(j_r + 1, j_f + 1), np.full(n_hold, j_f),
                          np.arange(j_f + 1, n_move)])
    u = amplitude * np.sin(phase[idx])
    t = np.arange(idx.size) * dt
    return HeldSine(t=t, u=u, hold_rising=slice(j_r, j_r + n_hold + 1),
                    hold_falling=slice(j_f + n_hold, j_f + 2 * n_hold + 1))


# --------------------------------------------------------- Prandtl-Ishlinskii
@njit(cache=True)
def _pi_loop(u, r, w, gain, z0):  # pragma: no cover - compiled
    n, m = u.shape[0], r.shape[0]
    z = z0.copy()
    y = np.empty(n)
    for k in range(n):
        acc = gain * u[k]
        for i in range(m):
            zi = min(u[k] + r[i], z[i])
            zi = max(u[k] - r[i], zi)
            z[i] = zi
            acc += w[i] * zi
        y[k] = acc
    return y


def prandtl_ishlinskii(u, thresholds=None, weights=None, gain=0.5, z0=None):
    r"""Prandtl-Ishlinskii hysteresis: a weighted sum of play operators.

    .. math::

        z_{i,k} = \max\bigl(u_k - r_i,\ \min(u_k + r_i,\ z_{i,k-1})\bigr),
        \qquad y_k = g\,u_k + \sum_i w_i\, z_{i,k}

    Parameters
    ----------
    u : array_like, shape (N,)
        Input.
    thresholds : array_like, shape (m,), optional
        Play radii :math:`r_i \ge 0`; default ``linspace(0, 60, 10)``
        (suited to inputs of about +/-80).
    weights : array_like, shape (m,), optional
        Weights :math:`w_i`; default ``0.1*exp(-r_i/40)``.
    gain : float
        Direct gain :math:`g`.
    z0 : float or array_like, shape (m,), optional
        Initial play states :math:`z_{i,-1}`; default 0.

    Returns
    -------
    y : ndarray, shape (N,)

    References
    ----------
    M. Brokate and J. Sprekels, *Hysteresis and Phase Transitions*,
    Springer, 1996, ch. 2.
    """
    u = _signal("u", u)
    r = (np.linspace(0.0, 60.0, 10) if thresholds is None
         else _signal("thresholds", np.atleast_1d(thresholds)))
    if np.any(r < 0):
        raise ValueError(f"thresholds must all be >= 0, got {r.tolist()!r}")
    w = 0.1 * np.exp(-r / 40.0) if weights is None else _signal("weights", np.atleast_1d(weights))
    if w.shape != r.shape:
        raise ValueError(f"weights must have the length of thresholds ({r.size}), got {w.size}")
    gain = _num("gain", gain)
    try:
        z = np.zeros_like(r) + (0.0 if z0 is None else np.asarray(z0, dtype=np.float64))
    except (TypeError, ValueError):
        z = None
    if z is None or z.shape != r.shape or not np.all(np.isfinite(z)):
        raise ValueError(f"z0 must be a finite scalar or have length {r.size}, got {z0!r}")
    return _pi_loop(u, np.ascontiguousarray(r), np.ascontiguousarray(w), gain, z)


# -------------------------------------------------------- discrete Bouc-Wen
@njit(cache=True)
def _bw_discrete(u, A, beta, gamma, h0):  # pragma: no cover - compiled
    n = u.shape[0]
    y = np.empty(n)
    h = h0
    for k in range(n):
        if k >= 2:
            du = u[k - 1] - u[k - 2]
            h = h + A * du - beta * abs(du) * h - gamma * du * abs(h)
        y[k] = h
    return y


def bouc_wen_discrete(u, A=0.9, beta=0.008, gamma=0.008, h0=0.0):
    r"""Discrete Bouc-Wen model in incremental form; exactly a NARX model.

    With :math:`\Delta u_k = u_{k-1} - u_{k-2}` (lagged, so the model is
    strictly proper) the state is

    .. math::

        h_k = h_{k-1} + A\,\Delta u_k - \beta\,|\Delta u_k|\,h_{k-1}
              - \gamma\,\Delta u_k\,|h_{k-1}|, \qquad k \ge 2,

    with :math:`h_0 = h_1 = h_0^{\text{init}}`, and the **output is the
    state**, :math:`y_k = h_k`. Writing
    :math:`\phi_k = \texttt{Phi1(u[k-1],u[k-2])} = u_{k-1}-u_{k-2}`,
    :math:`|\phi_k| = \texttt{Phi2}\cdot\texttt{Phi1}` and
    :math:`|y_{k-1}| = \texttt{Abs(y[k-1])}`, where ``Abs`` is a user
    Phi-function of arity 1 (``numpy.abs``, steady value ``abs(x)``) whose
    argument is an output (equivalently ``sign(y)*y``), the system is
    exactly the NARX model (for every :math:`k \ge 2`)

    ====================================================== ===========
    term                                                   theta
    ====================================================== ===========
    ``y[k-1]``                                             1
    ``Phi1(u[k-1],u[k-2])``                                A
    ``y[k-1]*Phi1(u[k-1],u[k-2])*Phi2(u[k-1],u[k-2])``     -beta
    ``Abs(y[k-1])*Phi1(u[k-1],u[k-2])``                    -gamma
    ====================================================== ===========

    in canonical factor order (outputs, inputs, then Phi-calls by name);
    :func:`bouc_wen_discrete_narx` returns them. With the input held, every
    Phi is 0 and :math:`y_k = y_{k-1}`: a continuum of steady states.

    Parameters
    ----------
    u : array_like, shape (N,)
        Input.
    A, beta, gamma : float
        Bouc-Wen parameters (per sample increment).
    h0 : float
        Initial state, the output at k = 0 and k = 1.

    Returns
    -------
    y : ndarray, shape (N,)

    References
    ----------
    M. Ismail, F. Ikhouane and J. Rodellar, "The hysteresis Bouc-Wen model,
    a survey", Arch. Comput. Methods Eng. 16 (2009) 161-188.
    """
    u = _signal("u", u)
    args = [_num(n, v) for n, v in (("A", A), ("beta", beta), ("gamma", gamma), ("h0", h0))]
    return _bw_discrete(u, *args)


def bouc_wen_discrete_narx(A=0.9, beta=0.008, gamma=0.008, abs_name="Abs"):
    """Terms and theta of :func:`bouc_wen_discrete` as an exact NARX model.

    Parameters
    ----------
    A, beta, gamma : float
        As in :func:`bouc_wen_discrete`.
    abs_name : str
        Name of the user Phi-function (arity 1, ``numpy.abs``, steady value
        ``abs(x)``) that supplies ``|y[k-1]|``; it must be registered, e.g.
        ``register_phi("Abs", arity=1, func=np.abs, steady=np.abs)``.

    Returns
    -------
    terms, theta : tuple of str, tuple of float
        Canonical term texts (order of the table in :func:`bouc_wen_discrete`)
        and ``(1, A, -beta, -gamma)``.
    """
    A, beta, gamma = (_num(n, v) for n, v in (("A", A), ("beta", beta), ("gamma", gamma)))
    if not isinstance(abs_name, str) or not re.match(r"^[A-Za-z][A-Za-z0-9_]*$", abs_name):
        raise ValueError(f"abs_name must be an identifier starting with a letter, "
                         f"got {abs_name!r}")
    p1, p2 = "Phi1(u[k-1],u[k-2])", "Phi2(u[k-1],u[k-2])"
    phis = sorted([p1, f"{abs_name}(y[k-1])"])      # Phi-calls are ordered by name
    terms = ("y[k-1]", p1, f"y[k-1]*{p1}*{p2}", "*".join(phis))
    return terms, (1.0, A, -beta, -gamma)


# ------------------------------------------ play-operator benchmark systems
def pi_first_order(u, radii=(0.0, 0.2, 0.4, 0.6, 0.8),
                   weights=(0.4, 0.25, 0.15, 0.1, 0.1), a=0.9):
    r"""Prandtl-Ishlinskii operator before first-order dynamics.

    .. math::

        z_k = \sum_j w_j\, P_{r_j}(u)_k, \qquad
        y_k = a\, y_{k-1} + (1 - a)\, z_{k-1}, \quad y_0 = z_0,

    with the plays :math:`P_r` of :func:`narx.language.memory.play` at rest on
    :math:`u_0`. It is exactly the NARX model with terms ``y[k-1]`` and
    ``Play(u[k-1],r_j)`` (``r = 0`` is ``u[k-1]``), θ = (a, (1-a) w_j).

    Parameters
    ----------
    u : array_like, shape (N,)
    radii : sequence of float
        Play radii, each >= 0.
    weights : sequence of float
        One weight per radius.
    a : float
        Pole of the first-order dynamics, in [0, 1).

    Returns
    -------
    y : ndarray, shape (N,)
    """
    from ..language.memory import play
    u = _signal("u", u)
    r = _signal("radii", np.atleast_1d(radii))
    w = _signal("weights", np.atleast_1d(weights))
    if w.shape != r.shape:
        raise ValueError(f"weights must have the length of radii ({r.size}), got {w.size}")
    a = _num("a", a, "nonneg")
    if a >= 1.0:
        raise ValueError(f"a must be in [0, 1), got {a!r}")
    z = sum(wj * play(u, rj) for rj, wj in zip(r, w))
    return _first_order(z, a)


def _first_order(x, a):
    """:math:`y_k = a y_{k-1} + (1-a) x_{k-1}`, :math:`y_0 = x_0`."""
    return signal.lfilter([0.0, 1.0 - a], [1.0, -a], x - x[0]) + x[0]


def backlash_second_order(u, r=0.25, motor=0.7, load=0.85):
    r"""Backlash inside second-order dynamics: motor, gear play, load.

    .. math::

        v_k &= c\, v_{k-1} + (1 - c)\, u_{k-1}, \quad v_0 = u_0
        \quad\text{(motor)}\\
        w_k &= P_r(v)_k \quad\text{(backlash, at rest on } v_0)\\
        y_k &= d\, y_{k-1} + (1 - d)\, w_{k-1}, \quad y_0 = w_0
        \quad\text{(load)}

    The play acts on the motor's filtered position, not on the input, so
    no finite set of ``Play(u[k-j],r)`` terms reproduces it exactly.

    Parameters
    ----------
    u : array_like, shape (N,)
    r : float
        Backlash half-width (play radius), >= 0.
    motor, load : float
        Poles ``c`` and ``d`` of the two first-order stages, in [0, 1).

    Returns
    -------
    y : ndarray, shape (N,)
    """
    from ..language.memory import play
    u = _signal("u", u)
    r = _num("r", r, "nonneg")
    poles = [_num(n, v, "nonneg") for n, v in (("motor", motor), ("load", load))]
    for n, p in zip(("motor", "load"), poles):
        if p >= 1.0:
            raise ValueError(f"{n} must be in [0, 1), got {p!r}")
    return _first_order(play(_first_order(u, poles[0]), r), poles[1])


@dataclass(frozen=True)
class OperatorRecord:
    """Training and validation records of :func:`operator_record`.

    Attributes
    ----------
    name : str
        ``"pi"`` or ``"backlash"``.
    u, y, y_clean : ndarray
        Training input, output with noise, output without noise.
    u_val, y_val, y_val_clean : ndarray
        Validation (held sine) input and outputs.
    hold_rising, hold_falling : slice
        The validation holds (see :class:`HeldSine`).
    dt : float
        Sampling period (s).
    """

    name: str
    u: np.ndarray
    y: np.ndarray
    y_clean: np.ndarray
    u_val: np.ndarray
    y_val: np.ndarray
    y_val_clean: np.ndarray
    hold_rising: slice
    hold_falling: slice
    dt: float


#: systems of :func:`operator_record`
OPERATOR_SYSTEMS = {"pi": pi_first_order, "backlash": backlash_second_order}


def operator_record(name, n=4000, seed=0, snr_db=None, dt=0.01, bandwidth=2.0):
    r"""Record of a play-operator benchmark system, with held-sine validation.

    Training input: :func:`training_input` of ``n`` samples, amplitude 1,
    ``bandwidth`` Hz at ``dt``; validation: :func:`held_sine` of amplitude
    0.8 at 0.5 Hz, two periods, holds of 1 s on the rising and the falling
    branch. With ``snr_db`` each output gets white Gaussian noise of
    standard deviation :math:`\sigma_y 10^{-\mathrm{snr}/20}`
    (:math:`\sigma_y` the standard deviation of that noise-free output).
    The input, then the training noise, then the validation noise are drawn
    from ``numpy.random.default_rng(seed)``.

    Parameters
    ----------
    name : {"pi", "backlash"}
        :func:`pi_first_order` or :func:`backlash_second_order` with its
        defaults.
    n : int
        Training samples, >= 100.
    seed : int or numpy.random.Generator
    snr_db : float, optional
        Output signal-to-noise ratio in dB (e.g. 40); None: no noise.
    dt, bandwidth : float
        Sampling period (s) and training-input bandwidth (Hz).

    Returns
    -------
    OperatorRecord
    """
    if name not in OPERATOR_SYSTEMS:
        raise ValueError(f"name must be one of {sorted(OPERATOR_SYSTEMS)}, got {name!r}")
    n = _count("n", n, 100)
    snr = None if snr_db is None else _num("snr_db", snr_db)
    rng = _rng(seed)
    system = OPERATOR_SYSTEMS[name]
    u = training_input(n=n, dt=dt, amplitude=1.0, bandwidth=bandwidth, seed=rng)
    hs = held_sine(amplitude=0.8, freq=0.5, dt=dt, cycles=2, hold=1.0)
    y, yv = system(u), system(hs.u)

    def noisy(x):
        if snr is None:
            return x.copy()
        return x + np.std(x) * 10.0 ** (-snr / 20.0) * rng.standard_normal(x.size)

    return OperatorRecord(name, u, noisy(y), y, hs.u, noisy(yv), yv,
                          hs.hold_rising, hs.hold_falling, float(dt))
