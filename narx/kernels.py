"""Compiled recursion kernels shared by free-run, k-steps-ahead and shooting.

Typical use (internal; :mod:`narx.simulate` wraps it)::

    plan = Plan.from_terms(terms)
    P = plan.input_parts(data)                      # (N, T), once per record
    out, diverged = run_windows(plan, P, data.U, y_meas, theta,
                                starts, length, write_from)

Every recursive mode is a set of *windows*: window ``w`` starts at sample
``s_w`` with the measured outputs before ``s_w`` as initial conditions and
runs ``length`` steps of

.. math::  \\hat y_k = \\sum_i \\theta_i P_{k,i}
           \\prod_{f \\in \\mathcal{O}_i} f(\\hat y, u)_k ,

where :math:`P_{k,i}` is the input-only part of term ``i`` (precomputed) and
:math:`\\mathcal{O}_i` its output-dependent factors. Free run is one window;
multiple shooting is windows of Δm samples; k-steps-ahead is a window of k
steps starting at every sample, keeping only its last step. Output lags and
the built-in Φ-functions are compiled (numba, cached on disk); a user
Φ-function with output arguments runs in a numpy loop vectorised over
windows. A window whose output leaves ``bound`` or becomes non-finite
flags the simulation as diverged and stops quietly.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import numpy as np

from .phi import BUILTIN_KERNEL_CODES, PhiRegistry, default_registry
from .terms import Lag, Term

try:                                     # numba is a hard dependency, but
    from numba import njit               # keep the module importable
except ImportError:                      # pragma: no cover
    def njit(*a, **k):
        return (lambda f: f) if not a or not callable(a[0]) else a[0]

__all__ = ["Plan", "run_windows", "KIND_LAG", "KIND_USER"]

KIND_LAG = 0
KIND_USER = 99


@njit(cache=True, nogil=True)
def _kernel(y_meas, U, P, theta, t_ptr, t_fac, f_kind, f_sig, f_lag,
            starts, length, write_from, maxlag, bound, out):
    n = y_meas.shape[0]
    n_terms = P.shape[1]
    n_fac = f_kind.shape[0]
    buf = np.empty(maxlag + length)
    fv = np.empty(n_fac)
    for w in range(starts.shape[0]):
        s = starts[w]
        for j in range(maxlag):
            buf[j] = y_meas[s - maxlag + j]
        for j in range(length):
            k = s + j
            if k >= n:
                break
            pos = maxlag + j
            for f in range(n_fac):
                kind = f_kind[f]
                if kind == 0:
                    fv[f] = buf[pos - f_lag[f, 0]]
                else:
                    if f_sig[f, 0] < 0:
                        a = buf[pos - f_lag[f, 0]]
                    else:
                        a = U[f_sig[f, 0], k - f_lag[f, 0]]
                    if f_sig[f, 1] < 0:
                        b = buf[pos - f_lag[f, 1]]
                    else:
                        b = U[f_sig[f, 1], k - f_lag[f, 1]]
                    d = a - b
                    if kind == 1:
                        fv[f] = d
                    else:
                        fv[f] = 1.0 if d > 0 else (-1.0 if d < 0 else 0.0)
            acc = 0.0
            for t in range(n_terms):
                v = theta[t] * P[k, t]
                for q in range(t_ptr[t], t_ptr[t + 1]):
                    v *= fv[t_fac[q]]
                acc += v
            if not (abs(acc) <= bound):          # catches NaN and inf too
                return True
            buf[pos] = acc
            if j >= write_from:
                out[k] = acc
    return False


@dataclass(frozen=True)
class Plan:
    """Structure of a term set laid out for the kernels (data independent)."""

    terms: Tuple[Term, ...]
    maxlag: int
    out_factors: tuple          # distinct output-dependent factors
    t_ptr: np.ndarray
    t_fac: np.ndarray
    f_kind: np.ndarray
    f_sig: np.ndarray
    f_lag: np.ndarray
    noise_terms: np.ndarray     # bool: term has e[k-j] (zero in simulation)
    inputs: Tuple[str, ...]

    @classmethod
    def from_terms(cls, terms: Sequence[Term], inputs: Sequence[str],
                   registry: Optional[PhiRegistry] = None) -> "Plan":
        reg = registry or default_registry()
        terms = tuple(terms)
        inputs = tuple(inputs)
        facs, index, t_fac, t_ptr = [], {}, [], [0]
        noise = np.zeros(len(terms), dtype=bool)
        for i, t in enumerate(terms):
            noise[i] = t.has_noise
            for f in t.output_factors:
                if f not in index:
                    index[f] = len(facs)
                    facs.append(f)
                t_fac.append(index[f])
            t_ptr.append(len(t_fac))
        F = len(facs)
        arity = max([1] + [len(f.args) for f in facs if not isinstance(f, Lag)])
        kind = np.zeros(F, dtype=np.int64)
        sig = np.full((F, max(arity, 2)), -1, dtype=np.int64)
        lag = np.zeros((F, max(arity, 2)), dtype=np.int64)
        for j, f in enumerate(facs):
            if isinstance(f, Lag):
                kind[j], lag[j, 0] = KIND_LAG, f.lag
                continue
            reg.get(f.name)                      # unknown name -> KeyError
            code = BUILTIN_KERNEL_CODES.get(f.name)
            kind[j] = code if code is not None else KIND_USER
            for a, arg in enumerate(f.args):
                sig[j, a] = -1 if arg.role == "y" else inputs.index(arg.signal)
                lag[j, a] = arg.lag
        ml = max((t.max_lag for t in terms), default=0)
        return cls(terms, ml, tuple(facs), np.asarray(t_ptr, dtype=np.int64),
                   np.asarray(t_fac, dtype=np.int64), kind, sig, lag, noise, inputs)

    @property
    def compiled(self) -> bool:
        """True when every output-dependent factor runs in the kernel."""
        return not np.any(self.f_kind == KIND_USER)

    def input_parts(self, data, registry: Optional[PhiRegistry] = None) -> np.ndarray:
        """(N, T) matrix of input parts; noise terms get a zero column."""
        from .regressors import input_part
        P = np.empty((data.n, len(self.terms)))
        for i, t in enumerate(self.terms):
            if self.noise_terms[i]:
                P[:, i] = 0.0
            else:
                P[:, i] = input_part(t, data, registry)
        return P


def _run_python(plan, P, U, y_meas, theta, starts, length, write_from, bound,
                out, registry):
    """Reference implementation, vectorised over windows (any Φ-function)."""
    reg = registry or default_registry()
    n, ml = y_meas.shape[0], plan.maxlag
    W = starts.shape[0]
    buf = np.empty((W, ml + length))
    if ml:
        buf[:, :ml] = y_meas[starts[:, None] - ml + np.arange(ml)[None, :]]
    rows = np.arange(W)
    for j in range(length):
        k = starts + j
        live = k < n
        if not live.any():
            break
        kk = np.where(live, k, n - 1)
        pos = ml + j
        fv = []
        for f in plan.out_factors:
            if isinstance(f, Lag):
                fv.append(buf[:, pos - f.lag])
                continue
            args = []
            for a in f.args:
                if a.role == "y":
                    args.append(buf[:, pos - a.lag])
                else:
                    args.append(U[plan.inputs.index(a.signal)][kk - a.lag])
            with np.errstate(all="ignore"):
                fv.append(np.asarray(reg.get(f.name).func(*args), dtype=float))
        acc = np.zeros(W)
        with np.errstate(all="ignore"):
            for t in range(len(plan.terms)):
                v = theta[t] * P[kk, t]
                for q in range(plan.t_ptr[t], plan.t_ptr[t + 1]):
                    v = v * fv[plan.t_fac[q]]
                acc += v
        if not np.all(np.abs(acc[live]) <= bound):
            return True
        buf[rows, pos] = acc
        if j >= write_from:
            out[kk[live]] = acc[live]
    return False


def run_windows(plan: Plan, P, U, y_meas, theta, starts, length: int,
                write_from: int = 0, bound: Optional[float] = None,
                out: Optional[np.ndarray] = None,
                registry: Optional[PhiRegistry] = None,
                force_python: bool = False):
    """Run the recursion over windows; returns ``(out, diverged)``.

    ``out`` (length N, NaN where nothing was written) receives step
    ``j >= write_from`` of each window at sample ``starts[w] + j``.
    """
    y_meas = np.ascontiguousarray(y_meas, dtype=np.float64)
    theta = np.ascontiguousarray(theta, dtype=np.float64)
    starts = np.ascontiguousarray(starts, dtype=np.int64)
    if starts.size and starts.min() < plan.maxlag:
        raise ValueError(f"a window starts at sample {starts.min()} but the "
                         f"model needs {plan.maxlag} initial samples")
    if bound is None:
        scale = float(np.max(np.abs(y_meas))) if y_meas.size else 1.0
        bound = 1e4 * (scale if scale > 0 else 1.0)
    if out is None:
        out = np.full(y_meas.shape[0], np.nan)
    P = np.ascontiguousarray(P)
    if plan.compiled and not force_python:
        diverged = _kernel(y_meas, np.ascontiguousarray(U), P, theta, plan.t_ptr,
                           plan.t_fac, plan.f_kind, plan.f_sig, plan.f_lag, starts,
                           int(length), int(write_from), int(plan.maxlag),
                           float(bound), out)
    else:
        diverged = _run_python(plan, P, U, y_meas, theta, starts, int(length),
                               int(write_from), float(bound), out, registry)
    return out, bool(diverged)
