r"""Hysteresis operators with memory: play (backlash), Deng-Tan, plug-ins.

A memory operator maps a whole sequence :math:`x_0, x_1, \dots` to a
sequence :math:`v_0, v_1, \dots` whose value at :math:`k` depends on
:math:`x_0..x_k` through a state carried from sample to sample. Used as a
regressor of a NARX model it brings rate-independent memory that a
polynomial in lags and Φ-functions can only approximate [1]_ [2]_.

Built-ins
---------
**Play** of radius :math:`r \ge 0` (backlash):

.. math::  v_k = \max\bigl(\min(x_k + r,\ v_{k-1}),\ x_k - r\bigr).

Its output follows :math:`x` at distance :math:`r` while :math:`x` moves
and stays put after a reversal until :math:`x` has moved back by
:math:`2r`; ``r = 0`` gives :math:`x` itself. The *initial state* is
:math:`v_{-1}`; by default :math:`v_{-1} = x_0`, so that :math:`v_0 = x_0`
(the operator starts at rest on its first sample). A given ``init`` sets
:math:`v_{-1}`, and then :math:`v_0 = \operatorname{clip}(\text{init},
x_0 - r, x_0 + r)`. A weighted sum of plays of several radii is the
Prandtl-Ishlinskii operator :math:`H(x)_k = \sum_j w_j P_{r_j}(x)_k`.

**Deng-Tan** operator [2]_, with :math:`f(z) = |\arctan z|\, z` (odd,
increasing):

.. math::  h_k = f(x_k - e_k) + g_k, \qquad g_k = h(e_k),

where :math:`e_k` is the *dominant extremum* adjacent to :math:`x_k` and
:math:`g_k` the operator's value when the input was there. The extremum
bookkeeping is a stack of reversal points :math:`(e, g)`:

1. It starts as the single *origin* :math:`(e, g) = (x_{-1}, h_{-1}) =
   (0, 0)` ("both start at 0"; ``init`` sets the origin's input, whose
   value stays 0), the direction of motion is unset.
2. At each sample the direction is :math:`s = \operatorname{sign}(x_k -
   x_{k-1})`; a held input (:math:`s = 0`) changes nothing and
   :math:`h_k = h_{k-1}`.
3. If the direction was set and :math:`s` is opposite to it, the input
   reversed at :math:`x_{k-1}`: the point :math:`(x_{k-1}, h_{k-1})` is
   pushed.
4. Wiping out: while the stack holds at least two reversal points above the
   origin and the input has moved strictly beyond the second-newest one in
   direction :math:`s` (:math:`s\,(x_k - e_{m-1}) > 0`), the minor loop
   they bound is closed and both are popped. Because :math:`f` is odd the
   output on closing equals the value stored at the closed point, so the
   operator has return-point memory.
5. :math:`(e_k, g_k)` is the top of the stack.

The compiled step keeps at most :data:`DENG_TAN_DEPTH` reversal points
above the origin; when a push would exceed it, the two oldest (the largest
open loop) are forgotten. The plain-Python reference keeps them all; the
two agree whenever the depth is not reached.

**Bouc-Wen** hysteretic variable of parameters :math:`\beta > 0`,
:math:`-\beta < \gamma \le \beta`, driven by :math:`x` with unit gain
(the Bouc-Wen law of Rakotondrabe [3]_ with :math:`A = 1`):

.. math::  \frac{dh}{dx} = 1 - \beta\,\operatorname{sign}(\dot x)\,h
           - \gamma\,|h|,

solved exactly over each sample with :math:`x` taken linear between
samples. Counted in the direction of motion, :math:`g = \operatorname{sign}
(\Delta x_k)\,h`, the law is linear on each sign of :math:`g`:
:math:`dg/da = 1 - c\,g` along the input's path :math:`a`, with
:math:`c = \beta + \gamma` while :math:`g \ge 0` and :math:`c = \beta -
\gamma` while :math:`g < 0`, so

.. math::  g(a) = g_0 + (1 - c\,g_0)\,\frac{1 - e^{-c a}}{c}

(:math:`g_0 + a` when :math:`c = 0`) up to :math:`|\Delta x_k|`, switching
branch where :math:`g` reaches 0 (at :math:`a = \ln(1 - c\,g_0)/c`; it
can do so once a sample). This is exact for any step, so an input that
steps across its range in one sample gets the same variable as a fine
integration; one RK4 step a sample, as :func:`narx.systems.piezo_bouc_wen`
takes, agrees with it to :math:`O(((\beta + |\gamma|)\Delta x_k)^5)` and
is wrong on such steps (on some shapes it grows without bound). Its state is
:math:`(x_{k-1}, h_{k-1})`, from :math:`(x_0, 0)` (``init`` sets
:math:`h`). The law is homogeneous in :math:`(h, A)`: the Bouc-Wen
variable of gain :math:`A` is :math:`A` times this one, so a model is
linear in :math:`A` and only :math:`\beta, \gamma` are operator
parameters. :math:`|h|` stays below :math:`1/(\beta + \gamma)`.

Histories
---------
A record that starts in motion leaves its operators' states unknown: the
input arrived at its first value along a path the record does not hold.
The *history* of a record names that path, and the operators are run over
it before the first sample (:func:`history_prefix`, one row each of
:data:`HISTORIES`):

- ``'rest'``: no path; each operator starts from its initial state on the
  first sample (the default).
- ``'rising'``: the signal came down from its record maximum to its record
  minimum and then rose to its first value, as after the last trough of a
  periodic input.
- ``'falling'``: up from the minimum to the maximum, then down to the
  first value.

Each leg is a ramp in steps of the record's median nonzero increment (at
most :data:`HISTORY_RAMP_MAX` samples), so rate-dependent steps see
increments of the record's size. A play of radius :math:`r \le (\max -
\min)/2` then starts at :math:`\max(x_0 - r, \min x + r)` when rising,
its state after the trough. :func:`narx.simulation.simulate.estimate_history`
picks the history that simulates a record's first samples best.

Plug-ins
--------
:func:`register_operator` adds a named operator with an initial state, a
step function and a steady-state rule. Model files and term texts only
*name* operators (with numeric parameters); they never carry code.

Search grids
------------
Each row of the operator table also says what the structure search
(:mod:`mggp`) offers of it: ``search(span)``, the parameter tuples for an
input of range ``span`` = max − min (plays of radii
:data:`PLAY_RADIUS_FRACTIONS` × span, Bouc-Wen variables of the shapes
:data:`BOUC_WEN_SHAPES`), and ``auto_class``, the model class of the
automatic choice that pilots it. The search names an operator by its name
in lower case (``play``, ``dengtan``, ``boucwen``); a plug-in registered
with ``search=`` is searched the same way (``mggp fit --operators stop``).

Steady states
-------------
With its argument held at :math:`\bar x`, an operator holds its value; the
value is fixed by the history, not by :math:`\bar x` alone. The *steady
rule* of an operator gives the interval of values it can rest at:
:math:`[\bar x - r, \bar x + r]` for a play (every point of it is reached:
approaching :math:`\bar x` from below rests at :math:`\bar x - r`, from
above at :math:`\bar x + r`, after a reversal in between);
:math:`(-\infty, \infty)` for Deng-Tan (its value at rest depends on the
extremum history, without a bound set by :math:`\bar x`);
:math:`(-1/(\beta+\gamma), 1/(\beta+\gamma))` for Bouc-Wen (any value
of its range, whatever :math:`\bar x`).

Typical use::

    >>> import numpy as np
    >>> from narx.language.memory import play, deng_tan, get_operator
    >>> play(np.array([0.0, 1.0, 0.5, -1.0]), 0.5).tolist()
    [0.0, 0.5, 0.5, -0.5]
    >>> get_operator("Play").steady_set(2.0, (0.5,))
    (1.5, 2.5)
    >>> from narx.language.memory import bouc_wen
    >>> bouc_wen(np.array([0.0, 10.0, 20.0, 20.0, 10.0]), 0.05, 0.0).round(4).tolist()
    [0.0, 7.8646, 12.6366, 12.6366, -0.1971]

References
----------
.. [1] M. Brokate and J. Sprekels, *Hysteresis and Phase Transitions*,
   Springer, 1996, ch. 2.
.. [2] L. Deng and Y. Tan, "Modeling hysteresis in piezoelectric actuators
   using NARMAX models", Sensors and Actuators A 149 (2009) 106-112.
.. [3] M. Rakotondrabe, "Bouc-Wen modeling and inverse multiplicative
   structure to compensate hysteresis nonlinearity in piezoelectric
   actuators", IEEE Trans. Autom. Sci. Eng. 8 (2011) 428-431.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Callable, Optional, Sequence, Tuple, Union

import numpy as np
from numba import njit

from .registry import NamedRegistry

__all__ = ["MemoryOperator", "OperatorRegistry", "register_operator",
           "unregister_operator", "get_operator", "default_operators",
           "play", "deng_tan", "bouc_wen", "play_step", "deng_tan_step", "bouc_wen_step",
           "deng_tan_state", "play_reference", "deng_tan_reference", "bouc_wen_reference",
           "DENG_TAN_DEPTH", "OPERATOR_BUILTINS", "BUILTIN_OPERATOR_CODES",
           "operator_step", "PLAY_RADIUS_FRACTIONS", "BOUC_WEN_SHAPES", "operator_table",
           "HISTORIES", "HISTORY_RAMP_MAX", "history_prefix", "check_history"]

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")

#: kernel codes of the built-in operators (rows of OPERATOR_BUILTINS)
_PLAY, _DENG_TAN, _BOUC_WEN = 1, 2, 3

#: reversal points kept by the compiled Deng-Tan step above the origin
DENG_TAN_DEPTH = 256



# ------------------------------------------------------------------ play
@njit(cache=True)
def play_step(state, x, params):  # pragma: no cover - compiled
    """One play step: ``state[0]`` holds :math:`v_{k-1}`, becomes :math:`v_k`."""
    r = params[0]
    v = max(min(x + r, state[0]), x - r)
    state[0] = v
    return v


def _play_init(x0, params, init=None):
    """Play state :math:`v_{-1}`: ``init`` if given, else the first sample."""
    return np.array([float(x0) if init is None else float(init)])


def _play_steady(xbar, params):
    r = float(params[0])
    return (xbar - r, xbar + r)


def _play_check(params):
    r = params[0]
    if not r >= 0:
        raise ValueError(f"the play radius must be a finite number >= 0, got {r!r}")


# -------------------------------------------------------------- Deng-Tan
_DT_HEAD = 4            # x_prev, h_prev, direction, number of stack entries


def deng_tan_state(origin=0.0, depth=DENG_TAN_DEPTH):
    """Initial Deng-Tan state: origin ``(origin, 0)``, direction unset.

    Layout: ``[x_prev, h_prev, direction, m, e_0, g_0, e_1, g_1, ...]``
    with ``m`` stack entries, the origin first; room for ``depth`` reversal
    points above it.
    """
    s = np.zeros(_DT_HEAD + 2 * (depth + 1))
    s[0] = float(origin)
    s[3] = 1.0
    s[_DT_HEAD] = float(origin)
    return s


@njit(cache=True)
def deng_tan_step(state, x, params):  # pragma: no cover - compiled
    """One Deng-Tan step on the state of :func:`deng_tan_state`; returns h_k."""
    xp = state[0]
    hp = state[1]
    d = state[2]
    m = int(state[3])
    cap = (state.shape[0] - _DT_HEAD) // 2
    dx = x - xp
    s = 1.0 if dx > 0.0 else (-1.0 if dx < 0.0 else 0.0)
    if s != 0.0:
        if d != 0.0 and s != d:
            if m == cap:                    # forget the two oldest points
                for i in range(1, m - 2):
                    state[_DT_HEAD + 2 * i] = state[_DT_HEAD + 2 * (i + 2)]
                    state[_DT_HEAD + 2 * i + 1] = state[_DT_HEAD + 2 * (i + 2) + 1]
                m -= 2
            state[_DT_HEAD + 2 * m] = xp
            state[_DT_HEAD + 2 * m + 1] = hp
            m += 1
        d = s
        while m >= 3 and s * (x - state[_DT_HEAD + 2 * (m - 2)]) > 0.0:
            m -= 2
    e = state[_DT_HEAD + 2 * (m - 1)]
    g = state[_DT_HEAD + 2 * (m - 1) + 1]
    z = x - e
    h = abs(math.atan(z)) * z + g
    state[0] = x
    state[1] = h
    state[2] = d
    state[3] = m
    return h


# -------------------------------------------------------------- Bouc-Wen
@njit(cache=True)
def _bouc_wen_advance(g, a, c):  # pragma: no cover - compiled
    """g after a path ``a`` >= 0 of the input on a branch of rate ``c`` >= 0:
    the solution g + (1 − c g)(1 − e^{−c a})/c of dg/da = 1 − c g (g + a at
    c = 0), with ``expm1`` so that short paths keep their digits."""
    if c > 0.0:
        return g - (1.0 - c * g) * math.expm1(-c * a) / c
    return g + a


@njit(cache=True)
def bouc_wen_step(state, x, params):  # pragma: no cover - compiled
    """One Bouc-Wen step: ``state`` = [x_{k-1}, h_{k-1}] becomes [x_k, h_k],
    the law solved exactly over the sample with x linear in between (see
    module doc): g = sign(Δx)·h grows at rate 1 − (β − γ)g while negative,
    until it reaches 0, then at rate 1 − (β + γ)g."""
    b = params[0]
    gm = params[1]
    dx = x - state[0]
    h = state[1]
    if dx != 0.0:
        sgn = 1.0 if dx > 0.0 else -1.0
        a = abs(dx)
        g = sgn * h
        if g < 0.0:
            k = b - gm
            reach = math.log1p(-k * g) / k if k > 0.0 else -g
            if a <= reach:
                g = _bouc_wen_advance(g, a, k)
                a = 0.0
            else:
                a -= reach
                g = 0.0
        if a > 0.0:
            g = _bouc_wen_advance(g, a, b + gm)
        h = sgn * g
    state[0] = x
    state[1] = h
    return h


def _bouc_wen_init(x0, params, init=None):
    """Bouc-Wen state (x_{-1}, h_{-1}) = (x_0, ``init`` or 0)."""
    return np.array([float(x0), 0.0 if init is None else float(init)])


def _bouc_wen_steady(xbar, params):
    bound = 1.0 / (params[0] + params[1])
    return (-bound, bound)


def _bouc_wen_check(params):
    b, g = params
    if not (b > 0 and -b < g <= b):
        raise ValueError(f"Bouc-Wen parameters need beta > 0 and -beta < gamma <= beta "
                         f"(a bounded loop), got beta={b!r}, gamma={g!r}")


@njit(cache=True, nogil=True)
def operator_step(code, state, x, params):  # pragma: no cover - compiled
    """One step of the built-in operator of kernel ``code``
    (:data:`BUILTIN_OPERATOR_CODES`); raises ``ValueError`` on another code."""
    if code == _PLAY:
        return play_step(state, x, params)
    if code == _DENG_TAN:
        return deng_tan_step(state, x, params)
    if code == _BOUC_WEN:
        return bouc_wen_step(state, x, params)
    raise ValueError("unknown memory-operator kernel code")


def _deng_tan_init(x0, params, init=None):
    return deng_tan_state(0.0 if init is None else float(init))


def _unbounded(xbar, params):
    return (-math.inf, math.inf)


def _no_params(params):
    return None


# ------------------------------------------------------- search grids
#: play radii of the structure search, as fractions of the input's range
#: (max - min); read when the grid is made (:func:`_play_search`)
PLAY_RADIUS_FRACTIONS = (0.05, 0.1, 0.2, 0.35)

#: shapes (β·range of the input, γ/β) of the Bouc–Wen variables of the
#: structure search (:func:`_bouc_wen_search`): a geometric grid of how
#: far a sweep over the whole range drives the variable into its
#: saturation at 1/(β + γ), from a loop that barely saturates (0.5) to
#: one that saturates within a fortieth of the range, as Dahl friction
#: with stiff bristles does (40.5: a presliding displacement small
#: against the stroke), each with the loop shapes γ = β (the piezo law's)
#: and γ = 0 (Dahl's)
BOUC_WEN_SHAPES = tuple((s, g) for s in (0.5, 1.5, 4.5, 13.5, 40.5) for g in (1.0, 0.0))


def _play_search(span):
    """Radii :data:`PLAY_RADIUS_FRACTIONS` × ``span``, each rounded to two
    significant digits (0.1, 0.2, 0.4, 0.7 for an input spanning [-1, 1])."""
    return tuple((float(f"{f * span:.2g}"),) for f in PLAY_RADIUS_FRACTIONS)


def _play_search_words():
    return ("plays of radii " + ", ".join(f"{f:g}" for f in PLAY_RADIUS_FRACTIONS)
            + " × the input range")


def _bouc_wen_search(span):
    """(β, γ) per shape of :data:`BOUC_WEN_SHAPES`: β = s / ``span``
    rounded to two significant digits, γ = (γ/β)·β."""
    out = []
    for s, ratio in BOUC_WEN_SHAPES:
        beta = float(f"{s / span:.2g}")
        out.append((beta, ratio * beta))
    return tuple(out)


def _bouc_wen_search_words():
    betas = ", ".join(f"{s:g}" for s in dict.fromkeys(s for s, _ in BOUC_WEN_SHAPES))
    return f"Bouc–Wen variables, β = {betas} / the input range, γ = β or 0"


# ------------------------------------------------------- sequences
@njit(cache=True)
def _run_play(x, r, v0):  # pragma: no cover - compiled
    out = np.empty(x.shape[0])
    st = np.array([v0])
    p = np.array([r])
    for k in range(x.shape[0]):
        out[k] = play_step(st, x[k], p)
    return out


@njit(cache=True)
def _run_deng_tan(x, state):  # pragma: no cover - compiled
    out = np.empty(x.shape[0])
    p = np.empty(0)
    for k in range(x.shape[0]):
        out[k] = deng_tan_step(state, x[k], p)
    return out


@njit(cache=True)
def _run_bouc_wen(x, params, state):  # pragma: no cover - compiled
    out = np.empty(x.shape[0])
    for k in range(x.shape[0]):
        out[k] = bouc_wen_step(state, x[k], params)
    return out


def _as_sequence(x):
    try:
        arr = np.ascontiguousarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"x must be a 1-D array of numbers, got {type(x).__name__}") from None
    if arr.ndim != 1:
        raise ValueError(f"x must be 1-D, got shape {arr.shape}")
    return arr


#: the histories a record's operators may be started from (module doc)
HISTORIES = ("rest", "rising", "falling")
#: samples of each leg of a history's ramp at most
HISTORY_RAMP_MAX = 4096


def check_history(history) -> str:
    """``history`` if it is a row of :data:`HISTORIES`, else ``ValueError``."""
    if history not in HISTORIES:
        raise ValueError(f"history must be one of {', '.join(HISTORIES)}, got {history!r}")
    return history


def history_prefix(x, history: str = "rest") -> np.ndarray:
    """The samples an operator runs over before ``x[0]`` under ``history``.

    ``'rest'`` gives none; ``'rising'`` a ramp from ``max(x)`` down to
    ``min(x)`` and up to ``x[0]``; ``'falling'`` from ``min(x)`` up to
    ``max(x)`` and down to ``x[0]`` (the module doc, *Histories*). The
    ramps step by the median nonzero ``|x[k] - x[k-1]|``, each leg at most
    :data:`HISTORY_RAMP_MAX` samples; a constant ``x`` has no path.

    Examples
    --------
    >>> history_prefix(np.array([0.0, 1.0, 2.0, 1.0]), "rising").tolist()
    [2.0, 1.0, 0.0]
    """
    check_history(history)
    x = _as_sequence(x)
    steps = np.abs(np.diff(x))
    steps = steps[steps > 0]
    if history == "rest" or steps.size == 0:
        return np.empty(0)
    lo, hi = float(x.min()), float(x.max())
    a, b = (hi, lo) if history == "rising" else (lo, hi)
    step = float(np.median(steps))

    def leg(p, q):                      # from p towards q, q excluded
        m = int(min(HISTORY_RAMP_MAX, max(1, math.ceil(abs(q - p) / step))))
        return np.linspace(p, q, m + 1)[:-1]
    return np.concatenate([leg(a, b), leg(b, float(x[0]))])


def play(x, r, init=None):
    """Play operator of radius ``r`` over the sequence ``x`` (see module doc).

    Parameters
    ----------
    x : array_like, shape (N,)
    r : float
        Radius, finite and >= 0.
    init : float, optional
        :math:`v_{-1}`; default ``x[0]``, so that ``v[0] == x[0]``.

    Returns
    -------
    v : ndarray, shape (N,)
    """
    return get_operator("Play").sequence(x, (r,), init)


def deng_tan(x, init=None):
    """Deng-Tan operator over the sequence ``x`` (compiled; see module doc).

    ``init`` is the origin's input (default 0); the origin's value is 0.
    """
    return get_operator("DengTan").sequence(x, (), init)


def bouc_wen(x, beta, gamma, init=None):
    """Bouc-Wen variable of unit gain driven by the sequence ``x``
    (compiled; see module doc).

    Parameters
    ----------
    x : array_like, shape (N,)
    beta, gamma : float
        Shape parameters (1/units of ``x``), beta > 0, -beta < gamma <= beta.
    init : float, optional
        :math:`h` before the first sample (default 0); ``h[0] == init``.

    Returns
    -------
    h : ndarray, shape (N,)
    """
    return get_operator("BoucWen").sequence(x, (beta, gamma), init)


#: compiled whole-sequence runs of the built-ins: (x, params, init) -> values
_COMPILED_RUN = {
    "Play": lambda x, p, init: _run_play(x, p[0], float(x[0]) if init is None else float(init)),
    "DengTan": lambda x, p, init: _run_deng_tan(x, _deng_tan_init(0.0, (), init)),
    "BoucWen": lambda x, p, init: _run_bouc_wen(x, p, _bouc_wen_init(x[0], p, init)),
}


def play_reference(x, r, init=None):
    """Plain-Python play operator, the definition written as a loop."""
    out, v = [], None
    for k, xk in enumerate(x):
        if k == 0:
            v = xk if init is None else init
        v = max(min(xk + r, v), xk - r)
        out.append(v)
    return np.array(out, dtype=float)


def deng_tan_reference(x, init=None):
    """Plain-Python Deng-Tan operator with an unbounded extremum stack."""
    origin = 0.0 if init is None else float(init)
    stack = [(origin, 0.0)]
    xp, hp, d, out = origin, 0.0, 0, []
    for xk in map(float, x):
        s = (xk > xp) - (xk < xp)
        if s:
            if d and s != d:
                stack.append((xp, hp))
            d = s
            while len(stack) >= 3 and s * (xk - stack[-2][0]) > 0:
                del stack[-2:]
        e, g = stack[-1]
        hp = abs(math.atan(xk - e)) * (xk - e) + g
        xp = xk
        out.append(hp)
    return np.array(out, dtype=float)


def bouc_wen_reference(x, beta, gamma, init=None):
    """Plain-Python Bouc-Wen variable: over each sample, the law's solution
    h(s) = h∞ + (h − h∞) e^{−c s} along the input's path s, branch by branch
    (c = β + γ while h points the way the input moves, else β − γ), written
    as a loop."""
    out, h, xp = [], 0.0 if init is None else float(init), None
    for xk in map(float, x):
        dx = 0.0 if xp is None else xk - xp
        rest = abs(dx)
        while rest > 0.0:
            with_motion = h * dx >= 0.0
            c = beta + gamma if with_motion else beta - gamma
            if not with_motion:             # path until h reaches 0
                to_zero = math.log(1.0 + c * abs(h)) / c if c > 0 else abs(h)
                if to_zero < rest:
                    h, rest = 0.0, rest - to_zero
                    continue
            if c > 0:
                h_inf = math.copysign(1.0 / c, dx)
                h = h_inf + (h - h_inf) * math.exp(-c * rest)
            else:
                h += math.copysign(rest, dx)
            rest = 0.0
        xp = xk
        out.append(h)
    return np.array(out, dtype=float)


# ------------------------------------------------------------ registry
@dataclass(frozen=True)
class MemoryOperator:
    """A memory operator: name, parameters, state, step and steady rule.

    Parameters
    ----------
    name : str
        Identifier used in term text, e.g. ``Play`` in ``Play(u[k-1],0.3)``.
    params : tuple of str
        Names of the numeric parameters written after the signal argument
        (``("r",)`` for Play, ``()`` for DengTan).
    init : callable
        ``init(x0, params, init=None) -> ndarray``: the state before the
        first sample, given the first sample ``x0`` and, optionally, a
        user-set initial value.
    step : callable
        ``step(state, x, params) -> float``: advances ``state`` (a float64
        array, changed in place) by the sample ``x`` and returns the
        operator's value; ``params`` is a float64 array.
    steady : callable
        ``steady(xbar, params) -> (lo, hi)``: the interval of values the
        operator can rest at with its argument held at ``xbar``.
    check : callable, optional
        ``check(params)`` raises ``ValueError`` naming the rule and value
        for parameters outside the operator's domain (every parameter is
        first checked to be a finite number).
    doc : str
        What the operator computes.
    code : int or None
        Kernel code of a built-in (its branch of :func:`operator_step`);
        None for a plug-in.
    search : callable, optional
        ``search(span) -> sequence of parameter tuples``: the parameters the
        structure search offers for an input whose range ``max - min`` is
        ``span`` > 0 (:meth:`search_grid`). An operator without parameters
        needs none; one with parameters and no ``search`` cannot be
        searched (a model may still name it).
    search_words : str or callable
        What the search offers, for help texts (a callable of no argument
        is read when the text is made); default :attr:`doc`.
    auto_class : str, optional
        The model class of the automatic choice (``operators='auto'``,
        :func:`mggp.fit.choices.search_classes`) whose pilot searches it:
        ``'operators'`` (rate-independent memory), ``'Bouc–Wen'``; None:
        searched only when named.
    """

    name: str
    params: Tuple[str, ...]
    init: Callable
    step: Callable
    steady: Callable
    check: Optional[Callable] = None
    doc: str = ""
    code: Optional[int] = None
    search: Optional[Callable] = None
    search_words: Union[str, Callable] = ""
    auto_class: Optional[str] = None

    @property
    def builtin(self) -> bool:
        """True for a row of :data:`OPERATOR_BUILTINS` (compiled in the kernels)."""
        return self.code is not None

    @property
    def arity(self) -> int:
        """Number of signal arguments (always 1)."""
        return 1

    def check_params(self, values: Sequence) -> Tuple[float, ...]:
        """The parameters as floats, validated; ``ValueError`` otherwise."""
        if len(values) != len(self.params):
            raise ValueError(f"{self.name} takes {len(self.params)} parameter(s) "
                             f"({', '.join(self.params) or 'none'}) after its signal, "
                             f"got {len(values)}")
        out = []
        for pname, v in zip(self.params, values):
            try:
                f = float(v)
            except (TypeError, ValueError):
                f = math.nan
            if isinstance(v, bool) or not math.isfinite(f):
                raise ValueError(f"{self.name} parameter {pname} must be a finite "
                                 f"number, got {v!r}")
            out.append(f)
        if self.check is not None:
            self.check(tuple(out))
        return tuple(out)

    def sequence(self, x, params=(), init=None, history: str = "rest") -> np.ndarray:
        """The operator over a whole sequence (compiled for the built-ins,
        else by repeated :attr:`step`), after the path of ``history``
        (:func:`history_prefix`; its values are dropped)."""
        x = _as_sequence(x)
        p = np.asarray(self.check_params(params), dtype=np.float64)
        if x.size == 0:
            return x.copy()
        pre = history_prefix(x, history)
        if pre.size:
            return self.sequence(np.concatenate([pre, x]), params, init)[pre.size:]
        if self.builtin:
            return _COMPILED_RUN[self.name](x, p, init)
        state = np.asarray(self.init(float(x[0]), tuple(p), init), dtype=np.float64)
        return np.array([self.step(state, float(xk), p) for xk in x])

    def states_after(self, x, params, ends, history: str = "rest") -> np.ndarray:
        """States after the samples ``x[0..e-1]`` for every ``e`` of ``ends``
        (each >= 1), one row each: where a window of a simulation whose
        first simulated sample is ``e`` starts the operator (the measured
        samples before it, after the path of ``history``)."""
        x = _as_sequence(x)
        p = np.asarray(self.check_params(params), dtype=np.float64)
        ends = np.asarray(ends, dtype=np.int64)
        pre = history_prefix(x, history)
        if pre.size:
            return self.states_after(np.concatenate([pre, x]), params, ends + pre.size)
        order = np.argsort(ends, kind="stable")
        state = np.asarray(self.init(float(x[0]), tuple(p)), dtype=np.float64)
        out = np.empty((ends.size, state.size))
        done = 0
        for i in order:
            for k in range(done, int(ends[i])):
                self.step(state, float(x[k]), p)
            done = max(done, int(ends[i]))
            out[i] = state
        return out

    def steady_set(self, xbar, params=()) -> Tuple[float, float]:
        """Interval of rest values with the argument held at ``xbar``."""
        lo, hi = self.steady(float(xbar), self.check_params(params))
        return float(lo), float(hi)

    @property
    def searchable(self) -> bool:
        """True when the structure search can offer it (no parameters, or
        a :attr:`search` grid)."""
        return not self.params or self.search is not None

    def search_grid(self, span) -> Tuple[Tuple[float, ...], ...]:
        """Parameter tuples the structure search offers for an input of
        range ``span`` (max − min): ``((),)`` without parameters; the
        checked tuples of :attr:`search` when ``span`` > 0, none for a
        constant input.

        Raises
        ------
        ValueError
            Parameters and no :attr:`search`, or a tuple outside the
            operator's domain.
        """
        if not self.params:
            return ((),)
        if self.search is None:
            raise ValueError(f"memory operator {self.name} has parameters "
                             f"({', '.join(self.params)}) and no search grid: register it "
                             f"with search=f, f(input range) giving the parameter tuples")
        span = float(span)
        if not span > 0:
            return ()
        return tuple(self.check_params(tuple(p)) for p in self.search(span))

    def search_text(self) -> str:
        """What the search offers, in words (:attr:`search_words`)."""
        words = self.search_words() if callable(self.search_words) else self.search_words
        return words or self.doc or self.name


#: the built-in operators, one row each; :func:`operator_step` steps the
#: row's code in the compiled kernels
OPERATOR_BUILTINS = (
    MemoryOperator("Play", ("r",), _play_init, play_step, _play_steady, _play_check,
                   "play (backlash) operator of radius r", code=_PLAY,
                   search=_play_search, search_words=_play_search_words,
                   auto_class="operators"),
    MemoryOperator("DengTan", (), _deng_tan_init, deng_tan_step, _unbounded, _no_params,
                   "Deng-Tan operator (dominant-extremum memory)", code=_DENG_TAN,
                   search_words="Deng–Tan operator", auto_class="operators"),
    MemoryOperator("BoucWen", ("beta", "gamma"), _bouc_wen_init, bouc_wen_step,
                   _bouc_wen_steady, _bouc_wen_check,
                   "Bouc-Wen hysteretic variable of unit gain (shape beta, gamma)",
                   code=_BOUC_WEN, search=_bouc_wen_search,
                   search_words=_bouc_wen_search_words, auto_class="Bouc–Wen"),
)

#: built-in operator name -> kernel code
BUILTIN_OPERATOR_CODES = {op.name: op.code for op in OPERATOR_BUILTINS}


class OperatorRegistry(NamedRegistry):
    """Mapping name -> :class:`MemoryOperator`; the built-ins always there."""

    what = "memory operator"

    def __init__(self, operators=None):
        super().__init__(OPERATOR_BUILTINS)
        for op in (operators or ()):
            self._items.setdefault(op.name, op)

    def register(self, name: str, params: Sequence[str], init: Callable,
                 step: Callable, steady: Callable, *, check: Optional[Callable] = None,
                 doc: str = "", search: Optional[Callable] = None,
                 search_words: str = "", overwrite: bool = False) -> MemoryOperator:
        """Register a user operator and return it (``search``,
        ``search_words``: see :class:`MemoryOperator`).

        Raises
        ------
        ValueError
            On an invalid name or parameter name, a non-callable ``init``,
            ``step``, ``steady``, ``check`` or ``search``, a name that equals
            another operator's but for case (the command line names
            operators in lower case), or a clash with an existing operator
            (unless ``overwrite``; built-ins never).
        """
        if not isinstance(name, str) or not _NAME.match(name) or name == "k":
            raise ValueError(f"operator name must be an identifier (letters, digits, _; "
                             f"starting with a letter; not 'k'), got {name!r}")
        params = tuple(params)
        bad = [p for p in params if not isinstance(p, str) or not _NAME.match(p)]
        if bad:
            raise ValueError(f"operator parameter names must be identifiers, got {bad[0]!r}")
        for what, f in (("init", init), ("step", step), ("steady", steady)):
            if not callable(f):
                raise ValueError(f"{what} must be callable, got {type(f).__name__}")
        for what, f in (("check", check), ("search", search)):
            if f is not None and not callable(f):
                raise ValueError(f"{what} must be callable or None, got {type(f).__name__}")
        twin = [n for n in self._items if n.lower() == name.lower() and n != name]
        if twin:
            raise ValueError(f"operator name {name!r} differs from the registered "
                             f"{twin[0]!r} only by case")
        return self._add(MemoryOperator(name, params, init, step, steady, check, doc,
                                        search=search, search_words=search_words),
                         overwrite)

    def user_operators(self):
        return self.user_entries()


_DEFAULT = OperatorRegistry()


def default_operators() -> OperatorRegistry:
    """The process-wide operator registry used when none is passed."""
    return _DEFAULT


def register_operator(name, params, init, step, steady, *, check=None, doc="",
                      search=None, search_words="", overwrite=False,
                      registry: Optional[OperatorRegistry] = None) -> MemoryOperator:
    """Register a user memory operator in ``registry`` (default: process-wide).

    Example, a Bouc-Wen hysteretic variable with its gain as a parameter
    and one Euler step per sample (the built-in ``BoucWen`` has unit gain
    and solves the law exactly over each sample),
    :math:`h_k = h_{k-1} + A\\Delta x_k - \\beta|\\Delta x_k|h_{k-1}
    - \\gamma\\Delta x_k|h_{k-1}|`, state ``[x_prev, h]``::

        def init(x0, p, init=None):
            return np.array([x0, 0.0 if init is None else init])
        def step(s, x, p):
            dx = x - s[0]
            s[1] += p[0]*dx - p[1]*abs(dx)*s[1] - p[2]*dx*abs(s[1])
            s[0] = x
            return s[1]
        register_operator("BoucWenEuler", ("A", "beta", "gamma"), init, step,
                          steady=lambda xbar, p: (-np.inf, np.inf))

    With ``search``, a function of the input's range giving the parameter
    tuples to try, the structure search can offer it (``mggp fit
    --operators boucweneuler``, ``MGGPRegressor(operators=["BoucWenEuler"])``),
    e.g. ``search=lambda span: [(1.0, b / span, b / span) for b in (0.5, 2)]``
    (a module-level function when the search runs in several processes).
    """
    return (registry or _DEFAULT).register(name, params, init, step, steady,
                                           check=check, doc=doc, search=search,
                                           search_words=search_words, overwrite=overwrite)


def operator_table(registry: Optional[OperatorRegistry] = None):
    """Every operator of ``registry`` (default: process-wide): the
    built-ins in the order of :data:`OPERATOR_BUILTINS`, then the plug-ins
    in the order they were registered."""
    return list(OPERATOR_BUILTINS) + (registry or _DEFAULT).user_operators()


def unregister_operator(name: str, registry: Optional[OperatorRegistry] = None) -> None:
    (registry or _DEFAULT).unregister(name)


def get_operator(name: str, registry: Optional[OperatorRegistry] = None) -> MemoryOperator:
    return (registry or _DEFAULT).get(name)
