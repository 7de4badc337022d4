"""Model-based hysteresis compensation: invert a NARX model by polynomial roots.

Typical use::

    import narx
    from narx.analysis.compensate import compensate
    model = narx.load_model("model.json")             # any model with Phi1/Phi2 terms
    res = compensate(model, r, input_range=(-80, 80))  # r: desired actuator output
    res.m               # actuator input to apply (the compensator's output)
    res.y_model         # the model's output under m (equals r where a root exists)
    res.fallbacks       # steps without an admissible root (see ``fallback``)

Principle [1]_. A one-input model whose smallest input lag is :math:`d`
(``u[k-d]``) is, at step :math:`j`, a function of the input applied now,
:math:`m_j`, and of known values (past inputs, the model's past outputs):

.. math::  \\hat y_{j+d} = \\sum_i c_{i,j}\\; m_j^{p_i}
           \\prod_{\\Phi_1 \\ni m_j} (\\pm m_j \\mp b)
           \\prod_{\\Phi_2 \\ni m_j} \\operatorname{sign}(\\pm(m_j - b)),

with :math:`c_{i,j}` = :math:`\\theta_i` times the term's known factors. A
``Phi1`` of :math:`m_j` is linear in it; a ``Phi2`` of it is a constant sign
on each side of its *breakpoint* ``b`` (the other argument, e.g.
:math:`m_{j-1}`). The breakpoints cut the line into open intervals (branches,
e.g. :math:`m_j > m_{j-1}` and :math:`m_j < m_{j-1}`) and the breakpoints
themselves (the equal case, sign 0); on each piece the model is one
polynomial of any degree, built from the terms' factors. The compensator
solves
:math:`\\hat y_{j+d} = r_{j+\\ell}` on every piece with ``numpy`` roots,
keeps the real roots that lie in their piece (branch consistency) and in the
actuator's input range, and applies the one **nearest to** :math:`m_{j-1}`
(the smallest input step: no jumps to remote roots; on a tie, the smaller).

*Causality and lead.* :math:`m_j` first acts on :math:`\\hat y_{j+d}`, so the
reference is needed :math:`\\ell = d` samples ahead (``lead=d``, default);
targets beyond the record hold :math:`r_{N-1}`. With ``lead=0`` there is no
preview and the model output lags ``d`` samples. A model whose first input
lag is 1, identified on an actuator with direct feed-through (the sampled
piezo: ``y_k`` depends on ``u_k``), renders that feed-through as one sample
of delay; ``lead=d-1`` then aligns the *actuator's* output with ``r``
(``benchmarks/compensation.py`` measures both).

*Fallback.* When no piece has an admissible root (no real root, roots only
on the wrong branch, outside ``input_range`` or beyond ``max_step`` from
:math:`m_{j-1}`) the step is counted in ``fallbacks`` and the input is
``'minimise'``: the candidate of least
:math:`|\\hat y_{j+d} - r_{j+\\ell}|` among the stationary points of every
branch polynomial, its ends (breakpoints and just inside them), the range
bounds and :math:`m_{j-1}`; or ``'hold'``: :math:`m_j = m_{j-1}`.

The model's past outputs are its own predictions (equal to the reference
wherever a root was found). A root within ``rtol`` of a remembered input is
set exactly to it: a held input stays held, later ``Phi2`` of past inputs
are exactly 0.

References
----------
.. [1] Abreu, P. E. O. G. B., Tavares, L. A., Teixeira, B. O. S., Aguirre,
   L. A., "Identification and nonlinearity compensation of hysteresis using
   NARX models", Nonlinear Dynamics, 2020.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Optional

import numpy as np

from .compensate_args import (check_count, check_range, check_reference, past_values,
                              training_magnitudes)
from ..exceptions import NonMinimumPhaseWarning
from .inverse_check import (active_terms, input_lags, inverse_stability,
                            uninvertible_reason)
from ..linalg import DIVERGENCE_FACTOR
from ..language.phi import BUILTINS, phi_value
from ..language.terms import Lag

__all__ = ["CompensationResult", "RootCompensator", "TermPlan", "compensate",
           "check_range", "check_reference", "check_count", "past_values",
           "inverse_stability", "NonMinimumPhaseWarning"]

FALLBACKS = ("minimise", "hold")


@dataclass(frozen=True)
class CompensationResult:
    """Outcome of running a compensator on a reference ``r`` of N samples.

    ``m[j]`` is the actuator input applied at ``j`` (the compensator's
    output); ``target[j] = r[min(j + lead, N - 1)]`` is what step ``j`` aimed
    at; ``y_model[k]`` the model's output under ``m`` (model-based only, else
    None); ``delay`` the model's input delay ``d``; ``fallback[j]`` marks
    steps without an admissible root (``fallbacks`` of them, ``saturated`` of
    which had an exact, branch-consistent root outside the input range or
    beyond ``max_step``); ``n_roots[j]`` counts the admissible roots.
    ``diverged_at`` is the first step whose input or model output left the
    bound (non-finite, or beyond 1e4 times the largest magnitude of the
    reference, the input range, the past values and the signal ranges the
    model was fitted on, ``meta['ranges']``), -1 if none: an inverse can be unstable even when
    the model is not; from there on ``m`` and ``y_model`` are NaN.
    """

    m: np.ndarray
    r: np.ndarray
    target: np.ndarray
    y_model: Optional[np.ndarray]
    lead: int
    delay: int
    fallback: np.ndarray
    fallbacks: int
    saturated: int
    n_roots: np.ndarray
    diverged_at: int = -1

    @property
    def diverged(self) -> bool:
        return self.diverged_at >= 0

    @property
    def fallback_rate(self) -> float:
        """Fraction of steps that fell back."""
        return self.fallbacks / max(1, self.m.size)


def operator_refusal(model) -> str:
    """Why the root compensator cannot invert ``model``'s memory-operator
    terms (``''`` when it has none): an operator carries a state the
    step-by-step root search does not track."""
    for term, th in zip(model.terms, model.theta if model.theta is not None
                        else [1.0] * len(model.terms)):
        if th != 0.0 and term.operator_factors:
            return (f"term {term}: the memory operator {term.operator_factors[0]} "
                    f"cannot be inverted by the model-based compensator (it tracks no "
                    f"operator state); drop the term or use a data-driven compensator")
    return ""


def _invertible_names() -> str:
    """The built-ins with a polynomial form in an argument, e.g. 'Phi1 and Phi2'."""
    names = [f.name for f in BUILTINS if f.form in ("difference", "sign")]
    return ", ".join(names[:-1]) + " and " + names[-1] if len(names) > 1 else names[0]


def _sign(v) -> int:
    return (v > 0) - (v < 0)


def _inside(lo, hi) -> float:
    """A point of the open interval (lo, hi); the ends may be infinite."""
    if lo == -np.inf:
        return 0.0 if hi == np.inf else hi - 1.0
    return lo + 1.0 if hi == np.inf else 0.5 * (lo + hi)


def _pmul(a, b):
    """Product of two polynomials given by increasing-power coefficients."""
    out = [0.0] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        if x:
            for j, y in enumerate(b):
                out[i + j] += x * y
    return out


def _pval(q, x):
    v = 0.0
    for c in reversed(q):
        v = v * x + c
    return v


def _real_roots(q):
    """Real roots of ``q`` (increasing powers, nonzero leading coefficient)."""
    n = len(q) - 1
    if n == 1:
        return [-q[0] / q[1]]
    z = np.roots(q[::-1])
    x = z.real[np.abs(z.imag) <= 1e-7 * np.maximum(1.0, np.abs(z))]
    dq = [i * v for i, v in enumerate(q)][1:]
    out = []
    for v in x:                                   # polish by Newton steps
        for _ in range(2):
            der = _pval(dq, v)
            if der != 0.0:
                v = v - _pval(q, v) / der
        out.append(float(v))
    return out


class TermPlan:
    """A one-input model's terms split into known factors and the unknown ``u[k-d]``.

    With ``unknown_lag=None`` every factor is known and the sum of the
    coefficients of :meth:`parts` is the model's one-step output (a free run
    one sample at a time, as a data-driven compensator in a loop needs).
    """

    def __init__(self, model, unknown_lag=None):
        if model.theta is None:
            raise ValueError("the model has no parameters yet: fit it or pass theta")
        if len(model.inputs) != 1:
            raise ValueError(f"the model must have exactly one input (the actuator input), "
                             f"got inputs {list(model.inputs)}")
        reg, d = model.registry, unknown_lag
        self.rows = []        # (theta, known, power, lin, sgn)
        for term, th in zip(model.terms, model.theta):
            if term.has_noise or th == 0.0:
                continue                       # noise terms: expectation zero
            known, lin, sgn, power, zero = [], [], [], 0, False
            for f in term.factors:
                if isinstance(f, Lag):
                    if f.role == "u" and f.lag == d:
                        power += 1
                    else:
                        known.append((f.role, f.lag))
                    continue
                hit = [a.role == "u" and a.lag == d for a in f.args]
                fn = reg.get(f.name)
                if not any(hit):
                    known.append(("phi", fn, tuple((a.role, a.lag) for a in f.args)))
                elif fn.form not in ("difference", "sign"):
                    raise ValueError(f"term {term}: the Φ-function {f.name} of the current "
                                     f"input u[k-{d}] has no polynomial form; only "
                                     f"{_invertible_names()} may take it")
                elif all(hit):
                    zero = True                # Phi(x, x) = 0
                else:
                    s = 1.0 if hit[0] else -1.0  # Phi(x, b): x - b; Phi(a, x): -(x - a)
                    other = f.args[1] if hit[0] else f.args[0]
                    (lin if fn.form == "difference" else sgn).append(
                        (s, (other.role, other.lag)))
            if not zero:
                self.rows.append((float(th), known, power, lin, sgn))

    @staticmethod
    def _get(spec, ins, outs, ki, ko):
        return ins[ki - spec[1]] if spec[0] == "u" else outs[ko - spec[1]]

    def parts(self, ins, outs, ki, ko):
        """Per term: known coefficient c, power p, linear factors, sign factors.

        ``ki``/``ko`` are the indices of output time k in the input and
        output lists; a factor ``u[k-l]`` is ``ins[ki - l]``.
        """
        get, out = self._get, []
        for th, known, power, lin, sgn in self.rows:
            c = th
            for spec in known:
                if spec[0] == "phi":
                    args = [get(a, ins, outs, ki, ko) for a in spec[2]]
                    fn = spec[1]
                    if fn.builtin:
                        v = phi_value(fn.code, args[0], args[1])
                    else:
                        v = float(np.asarray(fn.func(*[np.array([a]) for a in args]))[0])
                else:
                    v = get(spec, ins, outs, ki, ko)
                c *= v
                if c == 0.0:
                    break
            out.append((c, power, [(s, get(b, ins, outs, ki, ko)) for s, b in lin],
                        [(s, get(b, ins, outs, ki, ko)) for s, b in sgn]))
        return out


class RootCompensator:
    """Model-based compensator: at each step the input whose model output hits the target.

    Parameters
    ----------
    model : narx.Model
        Single-input model with parameters; Φ-functions taking the current
        input ``u[k-d]`` must be Phi1 or Phi2 (others may take past values).
    input_range : (low, high), optional
        Actuator input range; roots outside it are not admissible.
    max_step : float, optional
        Largest input change per sample (slew limit, > 0): roots farther
        from :math:`m_{j-1}` are not admissible. A model identified on
        smooth data is not valid for large one-sample steps.
    lead : int, optional
        Preview of the reference in :meth:`run` (default ``d``).
    fallback : {'minimise', 'hold'}
        What to apply when no root is admissible (module docstring).
    u_past, y_past : float or array_like
        Inputs and model outputs before the record (default 0: at rest).
    rtol : float
        Relative tolerance of the equal-input (breakpoint) case and of
        snapping a root onto a remembered input.

    Attributes
    ----------
    inverse_check : narx.analysis.inverse_check.InverseStability
        Zeros of the model's linear input part; when one lies outside the
        unit circle (``not inverse_check.minimum_phase``) the exact inverse
        is unstable and a :class:`NonMinimumPhaseWarning` is issued.
    """

    def __init__(self, model, *, input_range=None, lead=None, fallback="minimise",
                 max_step=None, u_past=0.0, y_past=0.0, rtol=1e-9):
        refusal = operator_refusal(model)
        if refusal:
            raise ValueError(refusal)
        lags = [la for t, _ in active_terms(model) for la in input_lags(t)]
        if not lags:
            raise ValueError("the model has no input term with a nonzero parameter: there "
                             "is nothing to invert")
        self.delay = int(min(lags))
        self.plan = TermPlan(model, self.delay)
        if not any(r[2] or r[3] for r in self.plan.rows):
            raise ValueError(uninvertible_reason(model, self.delay))
        self.inverse_check = inverse_stability(model)
        if not self.inverse_check.minimum_phase:
            warnings.warn(f"{self.inverse_check.describe()}; use a data-driven compensator "
                          f"(mggp.compensate.identify_inverse) or a PI loop",
                          NonMinimumPhaseWarning, stacklevel=2)
        self.model = model
        self.input_range = check_range(input_range)
        if max_step is not None and not (isinstance(max_step, (int, float)) and
                                         0 < max_step < np.inf):
            raise ValueError(f"max_step must be None or a finite number > 0, got {max_step!r}")
        self.max_step = None if max_step is None else float(max_step)
        self.lead = self.delay if lead is None else check_count("lead", lead)
        if fallback not in FALLBACKS:
            raise ValueError(f"fallback must be one of {', '.join(FALLBACKS)}, got {fallback!r}")
        self.fallback = fallback
        if not (isinstance(rtol, (int, float)) and 0 < rtol < 1e-2):
            raise ValueError(f"rtol must be a number in (0, 0.01), got {rtol!r}")
        self.rtol = float(rtol)
        self.reset(u_past, y_past)

    # -------------------------------------------------------------- state
    def reset(self, u_past=0.0, y_past=0.0):
        """Restart from inputs/outputs before the record; ŷ_0..ŷ_{d-1} follow.

        At least one past input is kept, also for a static model (largest
        lag 0): it is the input the first step's root is chosen nearest to
        (and the held input of ``fallback='hold'``).
        """
        ml, d = self.model.max_lag, self.delay
        self.m = past_values("u_past", u_past, max(ml, 1))
        self.y = past_values("y_past", y_past, ml)
        for t in range(d):                    # outputs already fixed by past inputs
            jm = ml - d + t
            parts = self.plan.parts(self.m, self.y, jm + d, len(self.y))
            self.y.append(float(self._value(self.m[jm], parts)))

    # -------------------------------------------------------------- algebra
    @staticmethod
    def _value(x, parts) -> float:
        """The model output for the input ``x``."""
        tot = 0.0
        for c, p, lin, sgn in parts:
            v = c * x ** p
            for s, b in lin:
                v *= s * (x - b)
            for s, b in sgn:
                v *= _sign(s * (x - b))
            tot += v
        return tot

    @staticmethod
    def _pieces(parts):
        """Polynomial (increasing powers) on each branch interval and breakpoint."""
        bps = sorted({b for _, _, _, sgn in parts for _, b in sgn})
        base = []
        for c, p, lin, _ in parts:
            q = [0.0] * p + [c]
            for s, b in lin:
                q = _pmul(q, (-s * b, s))
            base.append(q)
        edges = [-np.inf] + bps + [np.inf]
        pieces = [(lo, hi, _inside(lo, hi)) for lo, hi in zip(edges[:-1], edges[1:])]
        pieces += [(b, b, b) for b in bps]
        out = []
        for lo, hi, rep in pieces:
            poly = [0.0] * max(len(q) for q in base)
            for (_, _, _, sgn), q in zip(parts, base):
                s = math.prod(_sign(si * (rep - b)) for si, b in sgn)
                for i, v in enumerate(q):
                    poly[i] += s * v
            out.append((lo, hi, poly))
        return out

    def _roots(self, pieces, target):
        """Real, branch-consistent roots of ŷ = target (not range-filtered)."""
        tol = self.rtol * max(1.0, abs(target))
        roots = []
        for lo, hi, poly in pieces:
            q = list(poly)
            q[0] -= target
            if lo == hi:                          # breakpoint: the equal case
                if abs(_pval(q, lo)) <= tol:
                    roots.append(lo)
                continue
            while q and q[-1] == 0.0:
                q.pop()
            if not q:                             # identity on the whole branch
                roots.append(min(max(self.m[-1], np.nextafter(lo, hi)), np.nextafter(hi, lo)))
            elif len(q) > 1:
                roots.extend(v for v in _real_roots(q) if lo < v < hi)
        return self._snap(roots, pieces, target, tol)

    def _snap(self, roots, pieces, target, tol):
        """Put a root within ``rtol`` of a remembered input (or breakpoint) on it
        if the model still hits the target there: a held input must be held
        *exactly*, or later ``Phi2`` of past inputs flip from 0 to ±1."""
        keep = set(self.m[-max(1, self.model.max_lag - self.delay):])
        keep.update(lo for lo, hi, _ in pieces if lo == hi)
        out = set()
        for v in roots:
            for c in keep:
                if c != v and abs(c - v) <= self.rtol * max(1.0, abs(c)) and \
                        abs(self._value(c, self._parts) - target) <= tol:
                    v = c
                    break
            out.add(float(v))
        return np.array(sorted(out))

    def _bounds(self, prev):
        """Admissible inputs now: the input range, within ``max_step`` of ``prev``."""
        lo, hi = self.input_range or (-np.inf, np.inf)
        if self.max_step is not None:
            lo, hi = max(lo, prev - self.max_step), min(hi, prev + self.max_step)
        return lo, hi

    def _minimiser(self, pieces, parts, target, prev):
        cand = [prev]
        for lo, hi, poly in pieces:
            if lo == hi:
                cand.append(lo)
                continue
            for e, inward in ((lo, hi), (hi, lo)):
                if np.isfinite(e):
                    cand += [e, e + 1e-9 * max(1.0, abs(e)) * _sign(inward - e)]
            dq = [i * v for i, v in enumerate(poly)][1:]
            while dq and dq[-1] == 0.0:
                dq.pop()
            if len(dq) > 1:
                cand += [v for v in _real_roots(dq) if lo < v < hi]
        lo, hi = self._bounds(prev)
        cand = [min(max(v, lo), hi) for v in cand + [v for v in (lo, hi) if np.isfinite(v)]]
        err = [(abs(self._value(v, parts) - target), abs(v - prev), v) for v in cand]
        return float(min(err)[2])

    # -------------------------------------------------------------- stepping
    def solve(self, target):
        """The input for ŷ_{j+d} = target at the current step, without applying it.

        Returns ``(m, y_model, n_admissible, saturated)``.
        """
        parts = self._parts = self.plan.parts(self.m, self.y, len(self.m) + self.delay,
                                              len(self.y))
        pieces = self._pieces(parts)
        roots = self._roots(pieces, float(target))
        prev = self.m[-1]
        lo, hi = self._bounds(prev)
        inside = (roots >= lo) & (roots <= hi)
        saturated = bool(roots.size and not inside.any())
        roots = roots[inside]
        if roots.size:                # sorted: nearest to m_{j-1}, on a tie the smaller
            x = float(roots[np.argmin(np.abs(roots - prev))])
        elif self.fallback == "hold":
            x = min(max(prev, lo), hi)
        else:
            x = self._minimiser(pieces, parts, float(target), prev)
        return x, float(self._value(x, parts)), int(roots.size), saturated

    def step(self, target) -> float:
        """Choose, apply and return ``m_j`` so that the model's ŷ_{j+d} = target."""
        x, yv, n, sat = self.solve(target)
        self.m.append(x)
        self.y.append(yv)
        self.last_ = (n, sat)
        return x

    def run(self, r) -> CompensationResult:
        """Compensate a whole reference ``r`` (continuing from the current state)."""
        r = check_reference(r)
        n, i0, y0 = r.size, len(self.m), len(self.y) - self.delay
        target = r[np.minimum(np.arange(n) + self.lead, n - 1)]
        n_roots, sat = np.zeros(n, dtype=int), np.zeros(n, dtype=bool)
        scale = max([1.0, float(np.max(np.abs(r)))]
                    + [abs(v) for v in (self.input_range or ())]
                    + [abs(v) for v in self.m + self.y if math.isfinite(v)]   # the past
                    + training_magnitudes(self.model))
        bound, at = DIVERGENCE_FACTOR * scale, -1
        for j in range(n):
            x = self.step(target[j])
            n_roots[j], sat[j] = self.last_
            if not (abs(x) <= bound and abs(self.y[-1]) <= bound):   # NaN fails too
                at = j
                break
        stop = n if at < 0 else at                    # steps kept (NaN from ``at``)
        m, y_model = np.full(n, np.nan), np.full(n, np.nan)
        m[:stop] = self.m[i0:i0 + stop]
        y_model[:min(n, stop + self.delay)] = self.y[y0:y0 + min(n, stop + self.delay)]
        fb = (n_roots == 0) & (np.arange(n) < stop)
        return CompensationResult(
            m=m, r=r, target=target, y_model=y_model, lead=self.lead, delay=self.delay,
            fallback=fb, fallbacks=int(fb.sum()), saturated=int(sat.sum()), n_roots=n_roots,
            diverged_at=at)


def compensate(model, r, *, input_range=None, lead=None, fallback="minimise",
               max_step=None, u_past=0.0, y_past=0.0, rtol=1e-9) -> CompensationResult:
    """Model-based (root) compensation of a reference ``r``; see :class:`RootCompensator`.

    Returns a :class:`CompensationResult`: ``m`` is the actuator input,
    ``y_model[k]`` equals ``r[k - d + lead]`` wherever a root was admissible.
    """
    return RootCompensator(model, input_range=input_range, lead=lead, fallback=fallback,
                           max_step=max_step, u_past=u_past, y_past=y_past, rtol=rtol).run(r)
