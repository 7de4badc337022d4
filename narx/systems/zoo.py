r"""The system zoo: seeded input/output records of named families, with their truth.

A *draw* is one simulated experiment: a system of a named family with
randomly drawn parameters, a training record and a validation record (other
inputs), output noise, and the *truth*: the structure of the system in the
canonical term language (:mod:`narx.language.terms`), exact where the family is a
NARX model with the project's memory operators (:mod:`narx.language.memory`), else
the best expert structure. The zoo is the measuring instrument of
``mggp diagnose`` and of the defaults: development seeds calibrate, the
evaluation seeds report (:func:`tuning` makes the separation a rule).

Typical use::

    >>> from narx.systems import zoo
    >>> d = zoo.draw(7, n=4000)
    >>> d.family in zoo.FAMILIES, d.train.n, d.validation.n
    (True, 4000, 2000)
    >>> import narx
    >>> m = narx.Model(d.truth.terms).fit(d.train)      # the truth's structure, LS
    >>> with zoo.tuning():                              # calibration code
    ...     d = zoo.draw(12)                            # a development seed: fine
    ...     # zoo.draw(1012) would raise zoo.SeedLeak

What is drawn (every choice from ``numpy.random.default_rng`` streams
spawned from ``SeedSequence(seed)``: one stream each for the family, the
length, the system, the training input, the validation input, the scales
and the noise, so forcing ``family=`` or ``n=`` leaves the other draws
as they were):

* **Family.** A fair coin chooses hysteretic or control, then a family
  uniformly within (:data:`HYSTERETIC_FAMILIES`, :data:`CONTROL_FAMILIES`).
* **Length.** ``n=None`` draws N log-uniform in 1,000–20,000; the
  validation record has ``max(500, N // 2)`` samples.
* **Scales.** The input spans ±a and the output has a static gain of
  about K/a, with a and K log-uniform in 0.1–10 (data in other units than
  ours). Operator parameters in the truth are in the units of their
  argument.
* **Hysteretic families** (operator :math:`H` on an argument of nominal
  amplitude :math:`A`): ``play`` (one radius, 0.05–0.4 A),
  ``prandtl-ishlinskii`` (3–6 plays, radii uniform in 0–0.6 A, Dirichlet
  weights), ``preisach`` (relays on an M×M grid of thresholds over ±A, M
  in 8–14, density a random Gaussian bump in the half-width/centre plane
  times a random factor per relay), ``bouc-wen`` (unit-gain variable of
  :func:`narx.language.memory.bouc_wen`, βA log-uniform in 0.5–10, γ/β in
  −0.5–1, scaled so its virgin curve reaches A at A), ``dahl`` (Dahl
  friction :math:`dF/dx = \sigma(1 - F/F_c\,\mathrm{sgn}\,\dot x)`, that is
  :math:`F = \sigma\,\mathrm{BoucWen}(x, \sigma/F_c, 0)`, σA/F_c
  log-uniform in 1–20) and ``maxwell-slip`` (2–5 elasto-slip elements,
  :math:`F = \sum k_i x - \sum k_i \mathrm{Play}(x, \Delta_i)`,
  Δ_i in 0.05–0.5 A). The hysteresis is mixed with its argument as
  :math:`z = (1 - s)\,x + s\,H(x)` with the share s uniform in 0.4–0.9 (the
  hysteresis is a sizeable part of the output by construction, drawn, not
  picked). Linear dynamics of order 0–3 (uniform; order 0 is the static
  memory, placement ``static``, one sample late: :math:`y_k = H(u)_{k-1}`,
  as every model of the search is strictly proper) with random stable poles and unit static
  gain; the hysteresis is placed (uniformly) ``before`` them (on the
  input), ``after`` them (on the filtered input) or inside the
  ``feedback``: :math:`y_k = \sum a_i y_{k-i} + \sum b_j u_{k-j} +
  c\,H(y)_{k-1}`, with :math:`|c|` a fraction κ (uniform 0.3–0.9) of the
  small-gain bound :math:`\min_\omega |A(e^{i\omega})| / L` (L the largest
  slope of H), so the loop is stable.
* **Controls** (no hysteresis): ``linear`` (order 1–3), ``hammerstein``,
  ``wiener`` and ``wiener-hammerstein`` with a ``polynomial`` (degree 3),
  ``dead-zone`` or ``saturation`` static, ``polynomial-narx`` (linear
  part plus 2–3 monomials of degree 2–3), ``bilinear``
  (:math:`y_{k-1}u_{k-1}` terms), ``quadratic-damping`` (mass–spring with
  damping :math:`c v + q v|v|`, :math:`v` the backward difference of the
  output) and ``dead-time`` (linear dynamics behind a delay of 3–25
  samples).
* **Poles.** Real poles :math:`e^{-1/\tau}` or, with probability 1/2 while
  two remain to draw, a complex pair of that radius at an angle uniform in
  0.05–0.5 rad; τ log-uniform in 2–40 samples. Numerator at lag 1, and lag
  2 with probability 1/2 (ratio uniform in ±0.5).
* **Inputs** (:data:`INPUT_KINDS`, uniform; frequencies in cycles per
  sample): ``filtered-noise`` (Butterworth of order 2–4, cut-off
  log-uniform 0.002–0.05, :func:`narx.systems.training_input`),
  ``multisine`` (3–12 sines, frequencies log-uniform 0.001–0.05, random
  phases), ``chirp`` (logarithmic sweep between 0.0005–0.003 and
  0.01–0.05, up or down), ``steps`` (uniform levels held for 1–4 times a
  minimum hold log-uniform in 10–200 samples), ``sine-holds`` (a sine of
  frequency log-uniform 0.002–0.02 stopped, in each period with
  probability 1/2, at a random phase for 0.2–1 period) and ``sine`` (one
  frequency, log-uniform 0.002–0.02, one amplitude). Each spans ±1 before
  scaling by a.
* **Validation record** (the rule): with probability 0.3 a
  ``sine-holds`` record, else another realisation of the training kind
  (its parameters drawn afresh from the same ranges), spanning 0.9 of the
  training input's range about its centre, so the validation stays inside
  the range the training spans.
* **Noise.** White, or coloured (AR(1), pole uniform in 0.5–0.95) with
  probability 1/2, added to the output at an SNR uniform in 20–60 dB:
  standard deviation :math:`\sigma_y 10^{-\mathrm{SNR}/20}` with
  :math:`\sigma_y` the standard deviation of the noise-free training
  output (the same sensor noise on both records).

**Truths.** Exact (``exact=True``) for every family that is a NARX model
of our term language: the hysteretic families except ``preisach`` placed
``static``, ``before`` or in the ``feedback``; the controls ``linear``,
``hammerstein`` with a polynomial static, ``polynomial-narx``,
``bilinear``, ``quadratic-damping`` (the term
``Phi1(y[k-1],y[k-2])*Phi1(y[k-1],y[k-2])*Phi2(y[k-1],y[k-2])`` is
:math:`v|v|`) and ``dead-time``. The recursion holds from the truth's
largest lag on, the memory operators starting at rest on the first sample
(:mod:`narx.language.memory`), so least squares on a noise-free record recovers the
output to rounding. Otherwise the truth is the best expert structure
(``exact=False``, ``description`` says why): hysteresis ``after`` the
dynamics gets the ``before`` structure (the operator on input lags);
Preisach gets plays at the quartiles of its relays' half-widths; a
dead-zone or saturation static gets odd powers u, u³; Wiener and
Wiener–Hammerstein get the Hammerstein structure of the same static and
total order.

References
----------
M. Brokate and J. Sprekels, *Hysteresis and Phase Transitions*, Springer,
1996 (play, Prandtl–Ishlinskii, Preisach); M. Ismail, F. Ikhouane and J.
Rodellar, "The hysteresis Bouc-Wen model, a survey", Arch. Comput. Methods
Eng. 16 (2009) 161–188; P. R. Dahl, "Solid friction damping of mechanical
vibrations", AIAA J. 14 (1976) 1675–1682; F. Al-Bender, V. Lampaert and J.
Swevers, "Modeling of dry sliding friction dynamics: from heuristic models
to physically motivated models and back", Chaos 14 (2004) 446–460
(Maxwell-slip); S. A. Billings, *Nonlinear System Identification*, Wiley,
2013 (block-oriented and polynomial NARX models).
"""
from __future__ import annotations

import contextlib
import contextvars
import math
from dataclasses import dataclass, field
from typing import Callable, Iterator, Optional, Tuple

import numpy as np
from numba import njit
from scipy import signal

from ..records.data import Data
from ..exceptions import SeedLeakError
from ..language.memory import bouc_wen, bouc_wen_step, play, play_step
from ..language.terms import format_param, parse_term
from . import training_input

__all__ = ["Draw", "Truth", "SeedLeak", "SeedLeakError", "draw", "draws", "tuning", "guard",
           "split_of",
           "HYSTERETIC_FAMILIES", "CONTROL_FAMILIES", "FAMILIES", "INPUT_KINDS",
           "PLACEMENTS", "STATICS", "DEVELOPMENT_SEEDS", "EVALUATION_SEEDS"]

#: families whose output depends on the history of the input (memory operators)
HYSTERETIC_FAMILIES = ("play", "prandtl-ishlinskii", "preisach", "bouc-wen", "dahl",
                       "maxwell-slip")
#: families without hysteresis: what a diagnosis must not call hysteresis
CONTROL_FAMILIES = ("linear", "hammerstein", "wiener", "wiener-hammerstein",
                    "polynomial-narx", "bilinear", "quadratic-damping", "dead-time")
FAMILIES = HYSTERETIC_FAMILIES + CONTROL_FAMILIES
#: input signals of the records
INPUT_KINDS = ("filtered-noise", "multisine", "chirp", "steps", "sine-holds", "sine")
#: where the hysteresis sits relative to the linear dynamics ('none': a control)
PLACEMENTS = ("before", "after", "feedback", "static", "none")
#: static nonlinearities of the block-oriented controls
STATICS = ("polynomial", "dead-zone", "saturation")
#: seeds that tune and calibrate (defaults, thresholds)
DEVELOPMENT_SEEDS = range(0, 1000)
#: seeds that report; never drawn inside :func:`tuning`
EVALUATION_SEEDS = range(1000, 3000)

_N_RANGE = (1000, 20000)            # drawn training length (log-uniform)
_N_LIMITS = (200, 1_000_000)        # accepted training length
_SNR_DB = (20.0, 60.0)
_SCALE = (0.1, 10.0)                # input amplitude a and output scale K
_VAL_HOLDS = 0.3                    # probability of a sine-holds validation record
_VAL_AMPLITUDE = 0.9
_SHARE = (0.4, 0.9)                 # share s of the hysteresis in z = (1-s) x + s H(x)
_KAPPA = (0.3, 0.9)                 # feedback gain as a fraction of the small-gain bound
_TAU = (2.0, 40.0)                  # pole time constants (samples)
_DIVERGED = 100.0                   # |y| beyond this many output scales: redraw
_TRIES = 50

_TUNING = contextvars.ContextVar("narx_systems_zoo_tuning", default=False)


#: the error of an evaluation seed drawn inside :func:`tuning`
#: (:class:`narx.exceptions.SeedLeakError`)
SeedLeak = SeedLeakError


@contextlib.contextmanager
def tuning():
    """Mark the enclosed code as tuning: drawing an evaluation seed raises
    :class:`SeedLeak`. A context variable, not global state: it follows the
    current thread or task and ends with the block."""
    token = _TUNING.set(True)
    try:
        yield
    finally:
        _TUNING.reset(token)


def split_of(seed: int) -> str:
    """``'development'``, ``'evaluation'`` or ``'other'`` (seeds from 2000 on)."""
    seed = _seed(seed)
    if seed in DEVELOPMENT_SEEDS:
        return "development"
    return "evaluation" if seed in EVALUATION_SEEDS else "other"


@dataclass(frozen=True)
class Truth:
    """The structure of a drawn system in the canonical term language.

    Attributes
    ----------
    terms : tuple of str
        Canonical term texts (:func:`narx.language.terms.parse_term`).
    exact : bool
        True when the system *is* a NARX model of these terms (least
        squares on a noise-free record recovers it to rounding); False
        when they are the best expert structure of a family our terms
        cannot express.
    description : str
        The system in words, and why the structure is not exact if not.
    """

    terms: Tuple[str, ...]
    exact: bool
    description: str


@dataclass(frozen=True, eq=False)
class Draw:
    """One draw of the zoo (see the module doc for what is drawn).

    Attributes
    ----------
    seed : int
    family : str
    hysteretic : bool
    placement : {'before', 'after', 'feedback', 'static', 'none'}
    input_kind : str
        Kind of the training input (the validation kind is in ``params``).
    noise : dict
        ``snr_db``, ``colour`` ('white' or 'coloured') and ``pole`` (AR(1)
        pole, 0 for white).
    params : dict
        Every drawn parameter (JSON-able).
    train, validation : narx.Data
        Records (input ``u``, output ``y``) as measured, with noise;
        ``validation`` is None when not asked for.
    train_clean, validation_clean : ndarray
        The noise-free outputs.
    truth : Truth
    """

    seed: int
    family: str
    hysteretic: bool
    placement: str
    input_kind: str
    noise: dict
    params: dict
    train: Data
    validation: Optional[Data]
    train_clean: np.ndarray
    validation_clean: Optional[np.ndarray]
    truth: Truth

    @property
    def split(self) -> str:
        """``'development'``, ``'evaluation'`` or ``'other'``."""
        return split_of(self.seed)


# ------------------------------------------------------------- validation
def _seed(seed) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def _check(seed, n, validation, family) -> Tuple[int, Optional[int]]:
    seed = _seed(seed)
    lo, hi = _N_LIMITS
    if n is not None and (isinstance(n, bool) or not isinstance(n, (int, np.integer))
                          or not lo <= n <= hi):
        raise ValueError(f"n must be None (drawn) or an integer in [{lo}, {hi}], got {n!r}")
    if not isinstance(validation, (bool, np.bool_)):
        raise ValueError(f"validation must be True or False, got {validation!r}")
    if family is not None and family not in FAMILIES:
        raise ValueError(f"family must be None (drawn) or one of {list(FAMILIES)}, "
                         f"got {family!r}")
    return guard(seed), None if n is None else int(n)


def guard(seed: int) -> int:
    """``seed``, checked: inside :func:`tuning` an evaluation seed raises
    :class:`SeedLeak` (call it before long work on a list of seeds)."""
    seed = _seed(seed)
    if _TUNING.get() and seed in EVALUATION_SEEDS:
        raise SeedLeak(f"seed {seed} is an evaluation seed (EVALUATION_SEEDS = "
                       f"{EVALUATION_SEEDS.start}-{EVALUATION_SEEDS.stop - 1}): tuning code "
                       f"may only draw development seeds")
    return seed


# ------------------------------------------------------------- helpers
def _loguniform(rng, lo, hi, size=None):
    return np.exp(rng.uniform(math.log(lo), math.log(hi), size))


def _sig(x, digits=4) -> float:
    """``x`` rounded to ``digits`` significant digits (readable truths)."""
    x = float(x)
    return 0.0 if x == 0 else float(f"{x:.{digits - 1}e}")


def _span(x):
    """``x`` mapped affinely onto [-1, 1]."""
    lo, hi = float(np.min(x)), float(np.max(x))
    return 2.0 * (x - lo) / (hi - lo) - 1.0 if hi > lo else np.zeros_like(x)


def _lag(signal_name: str, j: int) -> str:
    return f"{signal_name}[k]" if j == 0 else f"{signal_name}[k-{j}]"


def _canonical(texts) -> Tuple[str, ...]:
    """Canonical texts of ``texts``, repeats dropped, order kept."""
    out = []
    for t in texts:
        c = str(parse_term(t))
        if c not in out:
            out.append(c)
    return tuple(out)


# ------------------------------------------------------------- inputs
def _input(kind: str, n: int, rng) -> Tuple[np.ndarray, dict]:
    """A normalised input of ``kind`` (spanning ±1) and its parameters."""
    k = np.arange(n, dtype=float)
    if kind == "filtered-noise":
        bw, order = float(_loguniform(rng, 0.002, 0.05)), int(rng.integers(2, 5))
        u = training_input(n=n, dt=1.0, amplitude=1.0, bandwidth=bw, seed=rng, order=order)
        return u, {"bandwidth": bw, "order": order}
    if kind == "multisine":
        m = int(rng.integers(3, 13))
        f = np.sort(_loguniform(rng, 0.001, 0.05, m))
        ph = rng.uniform(0.0, 2 * np.pi, m)
        u = _span(np.sin(2 * np.pi * np.outer(k, f) + ph).sum(axis=1))
        return u, {"frequencies": f.tolist()}
    if kind == "chirp":
        f0, f1 = float(_loguniform(rng, 0.0005, 0.003)), float(_loguniform(rng, 0.01, 0.05))
        up = bool(rng.random() < 0.5)
        a, b = (f0, f1) if up else (f1, f0)
        u = signal.chirp(k, a, max(n - 1, 1), b, method="logarithmic",
                         phi=float(rng.uniform(0, 360)))
        return u, {"f_start": a, "f_end": b}
    if kind == "steps":
        h0 = float(_loguniform(rng, 10.0, 200.0))
        holds, levels = [], []
        while sum(holds) < n:
            holds.append(int(rng.integers(int(h0), int(4 * h0) + 1)))
            levels.append(rng.uniform(-1.0, 1.0))
        u = _span(np.repeat(levels, holds)[:n])
        return u, {"min_hold": h0, "steps": len(holds)}
    if kind in ("sine-holds", "sine"):
        f = float(_loguniform(rng, 0.002, 0.02))
        ph0 = float(rng.uniform(0.0, 2 * np.pi))
        if kind == "sine":
            return np.sin(2 * np.pi * f * k + ph0), {"frequency": f}
        period = 1.0 / f
        idx, j, holds = [], 0, 0
        while len(idx) < n:
            stop = j + int(rng.uniform(0.0, period)) if rng.random() < 0.5 else None
            end = j + int(round(period))
            if stop is not None:
                idx.extend(range(j, stop + 1))
                idx.extend([stop] * int(rng.uniform(0.2, 1.0) * period))
                idx.extend(range(stop + 1, end))
                holds += 1
            else:
                idx.extend(range(j, end))
            j = end
        return (np.sin(2 * np.pi * f * np.asarray(idx[:n], dtype=float) + ph0),
                {"frequency": f, "holds": holds})
    raise ValueError(f"input kind must be one of {list(INPUT_KINDS)}, got {kind!r}")


# ------------------------------------------------------------- linear dynamics
@dataclass(frozen=True)
class _Linear:
    """:math:`y_k = \\sum_i a_i y_{k-i} + \\sum_j b_j x_{k-j}` (lags of b from
    ``delay``), unit static gain; started at rest on ``x[0]``."""

    a: Tuple[float, ...]
    b: Tuple[float, ...]
    poles: Tuple[Tuple[float, float], ...]
    delay: int = 1

    @property
    def order(self) -> int:
        return len(self.a)

    @property
    def in_lags(self) -> Tuple[int, ...]:
        return tuple(range(self.delay, self.delay + len(self.b)))

    def filter(self, x):
        num = np.r_[np.zeros(self.delay), self.b]
        den = np.r_[1.0, -np.asarray(self.a, dtype=float)]
        zi = signal.lfilter_zi(num, den) * x[0]
        return signal.lfilter(num, den, x, zi=zi)[0]

    def min_gain(self) -> float:
        """:math:`\\min_\\omega |A(e^{i\\omega})|` on a fine grid."""
        w = np.linspace(0.0, np.pi, 2049)
        den = np.r_[1.0, -np.asarray(self.a, dtype=float)]
        return float(np.min(np.abs(np.polyval(den[::-1], np.exp(-1j * w)))))

    def y_terms(self, out="y"):
        return [_lag(out, i) for i in range(1, self.order + 1)]

    def to_dict(self):
        return {"a": list(self.a), "b": list(self.b), "delay": self.delay,
                "poles": [list(p) for p in self.poles]}


def _linear(rng, order: int, delay: int = 1) -> _Linear:
    """Random stable dynamics of ``order`` (>= 1) with unit static gain."""
    poles, left = [], order
    while left > 0:
        radius = math.exp(-1.0 / float(_loguniform(rng, *_TAU)))
        if left >= 2 and rng.random() < 0.5:
            ang = float(rng.uniform(0.05, 0.5))
            poles += [radius * np.exp(1j * ang), radius * np.exp(-1j * ang)]
            left -= 2
        else:
            poles.append(complex(radius))
            left -= 1
    den = np.real(np.poly(poles))
    a = -den[1:]
    b = np.array([1.0] if rng.random() < 0.5 else [1.0, rng.uniform(-0.5, 0.5)])
    b *= den.sum() / b.sum()
    return _Linear(tuple(float(v) for v in a), tuple(float(v) for v in b),
                   tuple((float(p.real), float(p.imag)) for p in poles), delay)


# ------------------------------------------------------------- hysteresis
@njit(cache=True)
def _preisach_step(state, x, alphas, betas, weights):  # pragma: no cover - compiled
    """Relays up at x >= alpha, down at x <= beta, else held; weighted sum."""
    acc = 0.0
    for i in range(state.shape[0]):
        if x >= alphas[i]:
            state[i] = 1.0
        elif x <= betas[i]:
            state[i] = -1.0
        acc += weights[i] * state[i]
    return acc


@njit(cache=True)
def _preisach_run(x, state, alphas, betas, weights):  # pragma: no cover - compiled
    out = np.empty(x.shape[0])
    for k in range(x.shape[0]):
        out[k] = _preisach_step(state, x[k], alphas, betas, weights)
    return out


_PLAYS, _BOUC_WEN, _PREISACH = 0, 1, 2


@njit(cache=True)
def _hysteresis_step(kind, state, x, p1, p2, p3):  # pragma: no cover - compiled
    """The operator part of H at the new sample ``x`` (state advanced)."""
    if kind == _PLAYS:                       # p1 radii, p2 weights
        acc = 0.0
        for i in range(p1.shape[0]):
            acc += p2[i] * play_step(state[i:i + 1], x, p1[i:i + 1])
        return acc
    if kind == _BOUC_WEN:                    # p1 (beta, gamma), p2 (gain,)
        return p2[0] * bouc_wen_step(state, x, p1)
    return _preisach_step(state, x, p1, p2, p3)


@njit(cache=True)
def _feedback_run(drive, a, c, d, kind, state, p1, p2, p3, y0, start):  # pragma: no cover
    """:math:`y_k = \\text{drive}_k + \\sum_i a_i y_{k-i} + c\\,(d\\,y_{k-1} + G(y)_{k-1})`
    from ``start`` on (``y0`` before), G the operator part of H at rest on y0."""
    n = drive.shape[0]
    y = np.empty(n)
    g = 0.0
    for k in range(n):
        if k < start:
            yk = y0
        else:
            yk = drive[k] + c * (d * y[k - 1] + g)
            for i in range(a.shape[0]):
                yk += a[i] * y[k - 1 - i]
        y[k] = yk
        g = _hysteresis_step(kind, state, yk, p1, p2, p3)
    return y


@dataclass(frozen=True)
class _Hysteresis:
    """:math:`H(x) = d\\,x + G(x)`, G a weighted sum of plays, a scaled
    Bouc–Wen variable or a Preisach relay sum; parameters in the units of x."""

    kind: int
    d: float
    p1: Tuple[float, ...]
    p2: Tuple[float, ...]
    p3: Tuple[float, ...] = ()
    slope: float = 1.0                      # largest incremental slope of H
    expert: Tuple[float, ...] = ()          # Preisach: radii of its expert plays

    def mixed(self, s: float) -> "_Hysteresis":
        """:math:`(1 - s)\\,x + s\\,H(x)`."""
        scale = (lambda v: tuple(s * w for w in v))
        if self.kind == _PLAYS:
            return _Hysteresis(_PLAYS, 1 - s + s * self.d, self.p1, scale(self.p2),
                               slope=max(1 - s + s * self.slope, 1 - s + s * self.d))
        if self.kind == _BOUC_WEN:
            return _Hysteresis(_BOUC_WEN, 1 - s + s * self.d, self.p1, scale(self.p2),
                               slope=1 - s + s * self.slope)
        return _Hysteresis(_PREISACH, 1 - s + s * self.d, self.p1, self.p2, scale(self.p3),
                           slope=1.0, expert=self.expert)

    @property
    def exact(self) -> bool:
        return self.kind != _PREISACH

    def state(self, x0: float) -> np.ndarray:
        """State at rest on ``x0`` (narx.language.memory's default initial state)."""
        if self.kind == _PLAYS:
            return np.full(len(self.p1), float(x0))
        if self.kind == _BOUC_WEN:
            return np.array([float(x0), 0.0])
        al, be = np.array(self.p1), np.array(self.p2)
        return np.where(x0 >= 0.5 * (al + be), 1.0, -1.0)

    def arrays(self):
        return tuple(np.ascontiguousarray(p, dtype=float) for p in (self.p1, self.p2, self.p3))

    def __call__(self, x) -> np.ndarray:
        x = np.ascontiguousarray(x, dtype=float)
        if self.kind == _PLAYS:
            g = sum(w * play(x, r) for r, w in zip(self.p1, self.p2))
        elif self.kind == _BOUC_WEN:
            g = self.p2[0] * bouc_wen(x, *self.p1)
        else:
            g = _preisach_run(x, self.state(x[0]), *self.arrays())
        return self.d * x + g

    def factors(self, arg: str):
        """Factor texts of H applied to ``arg`` (expert plays for Preisach)."""
        out = [arg] if self.d != 0 else []
        if self.kind == _PLAYS:
            out += [f"Play({arg},{format_param(r)})" for r in self.p1]
        elif self.kind == _BOUC_WEN:
            out.append(f"BoucWen({arg},{format_param(self.p1[0])},{format_param(self.p1[1])})")
        else:
            out += [f"Play({arg},{format_param(r)})" for r in self.expert]
        return out

    def to_dict(self):
        names = {_PLAYS: ("radii", "weights", None), _BOUC_WEN: ("beta_gamma", "gain", None),
                 _PREISACH: ("alphas", "betas", "weights")}[self.kind]
        out = {"direct": self.d, "slope": self.slope}
        for name, p in zip(names, (self.p1, self.p2, self.p3)):
            if name:
                out[name] = list(p)
        if self.expert:
            out["expert_radii"] = list(self.expert)
        return out


def _bouc_wen_hysteresis(beta, gamma, A) -> _Hysteresis:
    """Unit-gain Bouc–Wen variable scaled by g so that its virgin curve from
    0 reaches A at A: :math:`g = A c / (1 - e^{-c A})`, c = β + γ."""
    c = beta + gamma
    g = A * c / -math.expm1(-c * A)
    return _Hysteresis(_BOUC_WEN, 0.0, (beta, gamma), (g,), slope=g * 2 * beta / c)


def _hysteresis(family: str, rng, A: float) -> Tuple[_Hysteresis, dict]:
    """The operator H of a hysteretic family on an argument of amplitude A."""
    if family == "play":
        r = _sig(rng.uniform(0.05, 0.4) * A)
        return _Hysteresis(_PLAYS, 0.0, (r,), (1.0,)), {"radius": r}
    if family == "prandtl-ishlinskii":
        m = int(rng.integers(3, 7))
        r = tuple(_sig(v) for v in np.sort(rng.uniform(0.0, 0.6, m)) * A)
        w = tuple(float(v) for v in rng.dirichlet(np.ones(m)))
        return _Hysteresis(_PLAYS, 0.0, r, w), {"radii": list(r), "weights": list(w)}
    if family == "maxwell-slip":
        m = int(rng.integers(2, 6))
        delta = tuple(_sig(v) for v in rng.uniform(0.05, 0.5, m) * A)
        k = rng.dirichlet(np.ones(m))
        f_max = float(np.dot(k, delta))             # the force once every element slips
        unit = A / f_max                            # F scaled to reach A
        return (_Hysteresis(_PLAYS, float(unit * k.sum()), delta,
                            tuple(float(-unit * v) for v in k), slope=float(unit * k.sum())),
                {"slips": list(delta), "stiffness": k.tolist()})
    if family in ("bouc-wen", "dahl"):
        if family == "dahl":
            beta, gamma = _sig(_loguniform(rng, 1.0, 20.0) / A), 0.0
        else:
            beta = _sig(_loguniform(rng, 0.5, 10.0) / A)
            gamma = _sig(beta * rng.uniform(-0.5, 1.0))
        h = _bouc_wen_hysteresis(beta, gamma, A)
        return h, {"beta": beta, "gamma": gamma, "gain": h.p2[0]}
    if family == "preisach":
        m = int(rng.integers(8, 15))
        t = np.linspace(-A, A, m)
        i, j = np.tril_indices(m, -1)               # alpha = t[i] > beta = t[j]
        al, be = t[i], t[j]
        centre, half = 0.5 * (al + be), 0.5 * (al - be)
        mc, mw = rng.uniform(-0.3, 0.3) * A, rng.uniform(0.1, 0.5) * A
        sc, sw = rng.uniform(0.2, 0.6) * A, rng.uniform(0.1, 0.4) * A
        mu = np.exp(-0.5 * ((centre - mc) / sc) ** 2 - 0.5 * ((half - mw) / sw) ** 2)
        mu *= rng.uniform(0.5, 1.5, mu.size)
        w = A * mu / mu.sum()
        order = np.argsort(half, kind="stable")
        cdf = np.cumsum(w[order]) / w.sum()
        expert = tuple(sorted({_sig(half[order][np.searchsorted(cdf, q)])
                               for q in (0.25, 0.5, 0.75)}))
        return (_Hysteresis(_PREISACH, 0.0, tuple(al.tolist()), tuple(be.tolist()),
                            tuple(w.tolist()), expert=expert),
                {"grid": m, "centre": mc, "half_width": mw, "spread": [sc, sw]})
    raise ValueError(f"not a hysteretic family: {family!r}")


# ------------------------------------------------------------- systems
@dataclass(frozen=True)
class _System:
    simulate: Callable[[np.ndarray], np.ndarray]
    terms: Tuple[str, ...]
    exact: bool
    description: str
    params: dict = field(default_factory=dict)
    placement: str = "none"


def _hysteretic_system(family: str, rng, a: float, K: float) -> _System:
    order = int(rng.integers(0, 4))
    placement = "static" if order == 0 else str(rng.choice(["before", "after", "feedback"]))
    lin = _linear(rng, order) if order else None
    params = {"order": order, "dynamics": lin.to_dict() if lin else None}
    gain = K / a
    if placement == "feedback":
        H, hp = _hysteresis(family, rng, K)
        kappa = float(rng.uniform(*_KAPPA))
        c = float(rng.choice([-1.0, 1.0]) * kappa * lin.min_gain() / H.slope)
        ar = np.asarray(lin.a)
        bs = np.asarray(lin.b) * gain
        p1, p2, p3 = H.arrays()
        start = max(lin.order, max(lin.in_lags))

        def simulate(u):
            drive = signal.lfilter(np.r_[0.0, bs], [1.0], u)
            y0 = gain * u[0]
            return _feedback_run(drive, ar, c, H.d, H.kind, H.state(y0), p1, p2, p3, y0,
                                 start)

        terms = (lin.y_terms() + [_lag("u", j) for j in lin.in_lags]
                 + [f for f in H.factors("y[k-1]") if f != "y[k-1]"])
        params.update(kappa=kappa, c=c, operator=H.to_dict(), **hp)
        where = f"inside the feedback (c = {c:.3g}, {kappa:.2f} of the small-gain bound)"
        why = "Preisach relays are not operators of our terms; plays at the quartiles " \
              "of their half-widths instead" if not H.exact else ""
        return _System(simulate, _canonical(terms), H.exact, _words(family, where, order, why),
                       params, placement)
    H0, hp = _hysteresis(family, rng, a)
    s = float(rng.uniform(*_SHARE))
    H = H0.mixed(s)
    params.update(share=s, operator=H.to_dict(), **hp)
    if placement == "static":
        terms = H.factors("u[k-1]")

        def simulate(u):
            z = H(u)
            return gain * np.r_[z[:1], z[:-1]]
    elif placement == "before":
        terms = lin.y_terms() + [f for j in lin.in_lags for f in H.factors(_lag("u", j))]

        def simulate(u):
            return gain * lin.filter(H(u))
    else:
        terms = lin.y_terms() + [f for j in lin.in_lags for f in H.factors(_lag("u", j))]

        def simulate(u):
            return gain * H(lin.filter(u))
    exact = H.exact and placement != "after"
    why = []
    if placement == "after":
        why.append("the operator acts on the filtered input, which no term measures; "
                   "the operator on input lags instead (the 'before' structure)")
    if not H.exact:
        why.append("Preisach relays are not operators of our terms; plays at the quartiles "
                   "of their half-widths instead")
    where = {"static": "static (order 0, one sample late)", "before": "before the linear dynamics",
             "after": "after the linear dynamics"}[placement]
    return _System(simulate, _canonical(terms), exact,
                   _words(family, f"{where}, share {s:.2f}", order, "; ".join(why)),
                   params, placement)


def _words(family, where, order, why) -> str:
    text = f"{family} hysteresis {where}, linear dynamics of order {order}"
    return text + (f"; not exact: {why}" if why else "")


def _static(rng, a: float):
    """A static nonlinearity on signals of amplitude a: (name, f, powers, exact, params)."""
    name = str(rng.choice(STATICS))
    if name == "polynomial":
        p2, p3 = (float(rng.choice([-1, 1]) * rng.uniform(0.2, 0.6)) for _ in range(2))
        return (name, lambda x: x + p2 * x * x / a + p3 * x ** 3 / a ** 2, (1, 2, 3), True,
                {"p2": p2, "p3": p3})
    if name == "dead-zone":
        delta = float(rng.uniform(0.1, 0.4)) * a
        return (name, lambda x: np.sign(x) * np.maximum(np.abs(x) - delta, 0.0), (1, 3), False,
                {"width": delta})
    level = float(rng.uniform(0.3, 0.7)) * a
    return name, lambda x: np.clip(x, -level, level), (1, 3), False, {"level": level}


def _powers(lags, powers):
    return ["*".join([_lag("u", j)] * p) for j in lags for p in powers]


def _narx_system(terms, theta, K, a, order, description, params) -> _System:
    """A NARX model simulated by narx in normalised units (u/a), output x K."""
    from ..model import Model
    model = Model(list(terms), theta=np.asarray(theta, dtype=float))
    ml = model.max_lag

    def simulate(u):
        un = u / a
        y0 = np.full(ml, float(un[0]) * _dc(model))
        return K * model.simulate(Data(un), mode="freerun", y0=y0).y_hat

    params = dict(params, terms=list(model.term_texts), theta=[float(v) for v in theta],
                  order=order)
    return _System(simulate, _canonical(terms), True, description, params)


def _dc(model) -> float:
    """Static gain of the linear part of a NARX model (its rest level per unit input)."""
    ys = sum(th for t, th in zip(model.term_texts, model.theta)
             if t.startswith("y[") and "*" not in t)
    us = sum(th for t, th in zip(model.term_texts, model.theta)
             if t.startswith("u[") and "*" not in t)
    return us / (1.0 - ys) if ys != 1 else 0.0


def _control_system(family: str, rng, a: float, K: float) -> _System:
    gain = K / a
    if family == "linear":
        lin = _linear(rng, int(rng.integers(1, 4)))
        return _System(lambda u: gain * lin.filter(u),
                       _canonical(lin.y_terms() + [_lag("u", j) for j in lin.in_lags]), True,
                       f"linear dynamics of order {lin.order}", {"dynamics": lin.to_dict()})
    if family == "dead-time":
        lin = _linear(rng, int(rng.integers(1, 4)), delay=int(rng.integers(3, 26)))
        return _System(lambda u: gain * lin.filter(u),
                       _canonical(lin.y_terms() + [_lag("u", j) for j in lin.in_lags]), True,
                       f"linear dynamics of order {lin.order} behind a dead time of "
                       f"{lin.delay} samples", {"dynamics": lin.to_dict()})
    if family in ("hammerstein", "wiener", "wiener-hammerstein"):
        name, f, powers, exact, sp = _static(rng, a)
        if family == "hammerstein":
            lin = _linear(rng, int(rng.integers(1, 4)))
            sim = (lambda u: gain * lin.filter(f(u)))
            order, lags, dyn = lin.order, lin.in_lags, {"dynamics": lin.to_dict()}
        else:
            first = _linear(rng, int(rng.integers(1, 3 if family != "wiener" else 4)))
            second = _linear(rng, int(rng.integers(1, 3))) if family != "wiener" else None
            sim = ((lambda u: gain * f(first.filter(u))) if second is None else
                   (lambda u: gain * second.filter(f(first.filter(u)))))
            order = first.order + (second.order if second else 0)
            nb = len(first.b) + (len(second.b) if second else 0) - (1 if second else 0)
            lags = tuple(range(1, nb + 1))
            exact = False
            dyn = {"dynamics": first.to_dict(),
                   "second_dynamics": second.to_dict() if second else None}
        terms = [_lag("y", i) for i in range(1, order + 1)] + _powers(lags, powers)
        why = []
        if family != "hammerstein":
            why.append("the static acts on a filtered signal no term measures; the "
                       "Hammerstein structure of the same static and total order instead")
        if name != "polynomial":
            why.append(f"a {name} is not a polynomial; odd powers u, u^3 instead")
        desc = f"{family} model, {name} static, total linear order {order}"
        return _System(sim, _canonical(terms), exact,
                       desc + (f"; not exact: {'; '.join(why)}" if why else ""),
                       dict(dyn, static=name, **sp))
    if family == "quadratic-damping":
        omega = 2 * np.pi * float(_loguniform(rng, 0.005, 0.05))
        zeta, rho = float(rng.uniform(0.02, 0.2)), float(rng.uniform(0.2, 1.0))
        c = 2 * zeta * omega
        v = "Phi1(y[k-1],y[k-2])"
        terms = ["y[k-1]", "y[k-2]", "u[k-1]", f"{v}*{v}*Phi2(y[k-1],y[k-2])"]
        theta = [2 - omega ** 2 - c, c - 1, omega ** 2, -rho]
        return _narx_system(terms, theta, K, a, 2,
                            f"mass-spring with damping c v + q v|v| (natural frequency "
                            f"{omega / (2 * np.pi):.3g} cycles/sample, damping ratio "
                            f"{zeta:.2f}, q = {rho:.2f} per unit output)",
                            {"omega": omega, "zeta": zeta, "q": rho})
    lin = _linear(rng, int(rng.integers(1, 3)))
    if family == "bilinear":
        extra = ["y[k-1]*u[k-1]"] + (["y[k-2]*u[k-1]"] if lin.order == 2 else [])
    else:
        pool = ["u[k-1]*u[k-1]", "u[k-1]*u[k-1]*u[k-1]", "u[k-1]*u[k-2]", "y[k-1]*u[k-1]",
                "y[k-1]*y[k-1]", "y[k-1]*u[k-1]*u[k-1]", "u[k-2]*u[k-2]"]
        extra = [pool[i] for i in sorted(rng.choice(len(pool), int(rng.integers(2, 4)),
                                                    replace=False))]
    base = lin.y_terms() + [_lag("u", j) for j in lin.in_lags]
    # a term of the output moves the poles: together such terms stay below
    # the small-gain bound min|A| (for outputs and inputs of unit size); an
    # input-only term is a share of the linear input gain
    n_y = sum("y" in t for t in extra)
    theta = list(lin.a) + list(lin.b) + [
        float(rng.choice([-1, 1]) * rng.uniform(0.3, 0.8)
              * (lin.min_gain() / n_y if "y" in t else sum(lin.b))) for t in extra]
    return _narx_system(base + extra, theta, K, a, lin.order,
                        f"{family}: linear dynamics of order {lin.order} plus "
                        + ", ".join(extra), {"dynamics": lin.to_dict()})


def _system(family, rng, a, K) -> _System:
    if family in HYSTERETIC_FAMILIES:
        return _hysteretic_system(family, rng, a, K)
    return _control_system(family, rng, a, K)


def _noise(rng, n, sigma, pole):
    w = rng.standard_normal(n)
    if pole == 0.0:
        return sigma * w
    e = signal.lfilter([math.sqrt(1 - pole ** 2)], [1.0, -pole], w,
                       zi=[pole * rng.standard_normal()])[0]
    return sigma * e


# ------------------------------------------------------------- draw
def draw(seed: int, n: Optional[int] = 4000, validation: bool = True,
         family: Optional[str] = None) -> Draw:
    """Draw one system and its records (see the module doc).

    Parameters
    ----------
    seed : int
        Non-negative; fixes everything. Inside :func:`tuning`, a seed of
        :data:`EVALUATION_SEEDS` raises :class:`SeedLeak`.
    n : int or None
        Training samples, in [200, 1,000,000]; None draws it log-uniform
        in 1,000–20,000.
    validation : bool
        Also return the validation record (the training record is the same
        either way).
    family : str, optional
        Force a family of :data:`FAMILIES` (the other draws keep their
        streams).

    Returns
    -------
    Draw
    """
    seed, n = _check(seed, n, validation, family)
    (r_fam, r_n, r_sys, r_in, r_val, r_scale, r_noise,
     r_vnoise) = (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(8))
    hyst = bool(r_fam.random() < 0.5)
    pool = HYSTERETIC_FAMILIES if hyst else CONTROL_FAMILIES
    drawn_family = str(pool[int(r_fam.integers(len(pool)))])
    family = family or drawn_family
    drawn_n = int(round(float(_loguniform(r_n, *_N_RANGE))))
    n = drawn_n if n is None else n
    n_val = max(500, n // 2)
    kind = str(INPUT_KINDS[int(r_in.integers(len(INPUT_KINDS)))])
    u_n, in_params = _input(kind, n, r_in)
    val_kind = "sine-holds" if r_val.random() < _VAL_HOLDS else kind
    uv_n, val_params = _input(val_kind, n_val, r_val)
    a, K = (_sig(v) for v in _loguniform(r_scale, *_SCALE, 2))
    u = a * u_n
    mid, half = 0.5 * (u.max() + u.min()), 0.5 * (u.max() - u.min())
    uv = mid + _VAL_AMPLITUDE * half * uv_n
    for _ in range(_TRIES):
        system = _system(family, r_sys, a, K)
        with np.errstate(all="ignore"):
            y, yv = system.simulate(u), system.simulate(uv)
        if all(np.all(np.isfinite(x)) and np.max(np.abs(x)) < _DIVERGED * K for x in (y, yv)):
            break
    else:                                     # pragma: no cover - never seen
        raise RuntimeError(f"seed {seed}: no stable {family} system in {_TRIES} draws")
    snr = float(r_noise.uniform(*_SNR_DB))
    pole = float(r_noise.uniform(0.5, 0.95)) if r_noise.random() < 0.5 else 0.0
    sigma = float(np.std(y)) * 10.0 ** (-snr / 20.0)
    e, ev = _noise(r_noise, n, sigma, pole), _noise(r_vnoise, n_val, sigma, pole)
    noise = {"snr_db": snr, "colour": "coloured" if pole else "white", "pole": pole}
    params = {"family": family, "n": n, "n_validation": n_val, "amplitude": a,
              "output_scale": K, "input": dict(in_params, kind=kind),
              "validation_input": dict(val_params, kind=val_kind,
                                       amplitude=_VAL_AMPLITUDE * half, centre=mid),
              "system": _jsonable(system.params), "noise": dict(noise, sigma=sigma)}
    return Draw(seed=seed, family=family, hysteretic=family in HYSTERETIC_FAMILIES,
                placement=system.placement, input_kind=kind, noise=noise, params=params,
                train=Data(u, y + e), validation=Data(uv, yv + ev) if validation else None,
                train_clean=y, validation_clean=yv if validation else None,
                truth=Truth(system.terms, system.exact, system.description))


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return float(x)
    if isinstance(x, (np.integer, int)) and not isinstance(x, bool):
        return int(x)
    return x


def draws(seeds, **kw) -> Iterator[Draw]:
    """:func:`draw` of each seed of ``seeds`` in turn (same keywords)."""
    for s in seeds:
        yield draw(s, **kw)
