"""Compiled recursion kernels shared by free-run, k-steps-ahead and shooting.

Typical use (internal; :mod:`narx.simulation.simulate` wraps it)::

    plan = Plan.from_terms(terms, data.inputs)
    P = plan.input_parts(data)                      # (T, N), once per record
    out, diverged = run_windows(plan, P, data.U, y_meas, theta,
                                starts, length, write_from)

``P`` may also be a larger column store (C, N) with ``idx`` naming the row
of each term, so callers that cache columns never assemble a matrix.

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

A memory operator of an output lag (``Play(y[k-1],0.1)``, see
:mod:`narx.language.memory`) carries a state. Each window starts it from the state
the operator reaches on the *measured* output before the window's first
sample :math:`s_w` (its initial state, then one step per measured sample
:math:`y_0..y_{s_w-1}`); from there it steps on the simulated output.
Free run therefore starts it on the measured initial conditions, and every
multiple-shooting or k-steps-ahead window on the measured history before
it, as its lags start on measured values. The built-in operators are
compiled (:func:`narx.language.memory.operator_step`); plug-ins run in the numpy
loop.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import numpy as np

from numba import njit

from ..language.phi import PhiRegistry, builtin_code, check_codes, default_registry, phi_value
from ..language.memory import default_operators, operator_step
from ..language.terms import Lag, OpCall, Term

__all__ = ["Plan", "run_windows", "KIND_USER"]

KIND_USER = 99


@njit(cache=True, nogil=True)
def _kernel(y_meas, U, P, idx, theta, static, dyn, d_ptr, d_code, p_kind, p_sig, p_lag,
            starts, length, write_from, maxlag, bound, out, o_code, o_lag, o_par, o_meas,
            o_state0):
    # Input-only terms (``static``) are summed once, outside the recursion.
    # Each term with output factors (``dyn``) gets θ times its input part
    # laid out step-major in C[k, i], and a short list of factor reads from
    # ``buf``: code c > 0 is the output lag c (``buf[pos - c]``), c <= 0 the
    # slot -c holding a Φ-call with an output argument at the current step
    # (slots 1..n_phi), then the operators of output lags (slots after the
    # Φ-calls): from their measured values while j < lag, then stepped from
    # the window's measured-history state o_state0[o, w] on the simulated
    # output. Same products in the same order as the reference path, so
    # results are bit-identical to it.
    n = y_meas.shape[0]
    n_phi = p_kind.shape[0]
    n_op = o_code.shape[0]
    state = np.empty((n_op, o_state0.shape[2]))
    n_dyn = dyn.shape[0]
    first = n
    for w in range(starts.shape[0]):
        first = min(first, starts[w])
    base = np.zeros(n)
    for i in range(static.shape[0]):
        t = static[i]
        row = idx[t]
        th = theta[t]
        if th != 0.0:
            for k in range(first, n):
                base[k] += th * P[row, k]
    C = np.empty((n, n_dyn))
    for i in range(n_dyn):
        t = dyn[i]
        row = idx[t]
        th = theta[t]
        for k in range(first, n):
            C[k, i] = th * P[row, k]
    off = 1 + n_phi + n_op
    buf = np.empty(off + maxlag + length)
    buf[0] = 1.0
    bad = 0
    for w in range(starts.shape[0]):
        s = starts[w]
        for j in range(maxlag):
            buf[off + j] = y_meas[s - maxlag + j]
        for o in range(n_op):
            state[o, :] = o_state0[o, w, :]
        for j in range(length):
            k = s + j
            if k >= n:
                break
            pos = off + maxlag + j
            for f in range(n_phi):
                if p_sig[f, 0] < 0:
                    a = buf[pos - p_lag[f, 0]]
                else:
                    a = U[p_sig[f, 0], k - p_lag[f, 0]]
                if p_sig[f, 1] < 0:
                    b = buf[pos - p_lag[f, 1]]
                else:
                    b = U[p_sig[f, 1], k - p_lag[f, 1]]
                buf[1 + f] = phi_value(p_kind[f], a, b)
            for o in range(n_op):
                d = o_lag[o]
                if j < d:
                    buf[1 + n_phi + o] = o_meas[o, k - d]
                else:
                    buf[1 + n_phi + o] = operator_step(o_code[o], state[o], buf[pos - d],
                                                       o_par[o])
            acc = base[k]
            if n_phi == 0 and n_op == 0:         # output lags only
                for i in range(n_dyn):
                    v = C[k, i]
                    for q in range(d_ptr[i], d_ptr[i + 1]):
                        v *= buf[pos - d_code[q]]
                    acc += v
            else:
                for i in range(n_dyn):
                    v = C[k, i]
                    for q in range(d_ptr[i], d_ptr[i + 1]):
                        c = d_code[q]
                        v *= buf[pos - c] if c > 0 else buf[-c]
                    acc += v
            bad += not (abs(acc) <= bound)       # NaN and inf count too
            buf[pos] = acc
            if j >= write_from:
                out[k] = acc
            if (j & 255) == 255 and bad:
                return True
        if bad:
            return True
    return False


@dataclass(frozen=True)
class Plan:
    """Structure of a term set laid out for the kernels (data independent)."""

    terms: Tuple[Term, ...]
    maxlag: int
    out_factors: tuple          # distinct output-dependent factors
    t_ptr: np.ndarray
    t_fac: np.ndarray           # index into out_factors (reference path)
    static: np.ndarray          # terms without output factors
    dyn: np.ndarray             # terms with output factors
    d_ptr: np.ndarray           # (n_dyn + 1,) factor list bounds per dyn term
    d_code: np.ndarray          # output lag (> 0) or -(Φ slot) (<= 0)
    p_kind: np.ndarray          # per Φ-call with an output argument
    p_sig: np.ndarray
    p_lag: np.ndarray
    noise_terms: np.ndarray     # bool: term has e[k-j] (zero in simulation)
    inputs: Tuple[str, ...]
    out_operators: tuple = ()   # memory operators of output lags (OpCall)

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
        phis = [f for f in facs if not isinstance(f, (Lag, OpCall))]
        ops = [f for f in facs if isinstance(f, OpCall)]
        arity = max([2] + [len(f.args) for f in phis])
        kind = np.zeros(len(phis), dtype=np.int64)
        sig = np.full((len(phis), arity), -1, dtype=np.int64)
        lag = np.zeros((len(phis), arity), dtype=np.int64)
        for j, f in enumerate(phis):
            reg.get(f.name)                      # unknown name -> KeyError
            code = builtin_code(f.name)
            kind[j] = KIND_USER if code is None or len(f.args) != 2 else code
            for a, arg in enumerate(f.args):
                sig[j, a] = -1 if arg.role == "y" else inputs.index(arg.signal)
                lag[j, a] = arg.lag
        dyn = [i for i in range(len(terms)) if t_ptr[i + 1] > t_ptr[i]]
        static = [i for i in range(len(terms)) if t_ptr[i + 1] == t_ptr[i]]
        d_ptr, d_code = [0], []
        for i in dyn:
            for fi in t_fac[t_ptr[i]:t_ptr[i + 1]]:
                f = facs[fi]
                d_code.append(f.lag if isinstance(f, Lag) else
                              -(1 + len(phis) + ops.index(f)) if isinstance(f, OpCall)
                              else -(1 + phis.index(f)))
            d_ptr.append(len(d_code))
        ml = max((t.max_lag for t in terms), default=0)
        return cls(terms, ml, tuple(facs), np.asarray(t_ptr, dtype=np.int64),
                   np.asarray(t_fac, dtype=np.int64),
                   np.asarray(static, dtype=np.int64), np.asarray(dyn, dtype=np.int64),
                   np.asarray(d_ptr, dtype=np.int64), np.asarray(d_code, dtype=np.int64),
                   kind, sig, lag, noise, inputs, tuple(ops))

    @property
    def compiled(self) -> bool:
        """True when every output-dependent factor runs in the kernel."""
        return not np.any(self.p_kind == KIND_USER) and all(
            default_operators().get(f.name).builtin for f in self.out_operators)

    def input_parts(self, data, registry: Optional[PhiRegistry] = None) -> np.ndarray:
        """(T, N) matrix of input parts (row i: term i)."""
        from ..records.regressors import input_part
        P = np.empty((len(self.terms), data.n))
        for i, t in enumerate(self.terms):
            P[i] = input_part(t, data, registry)
        return P


def _run_python(plan, P, idx, U, y_meas, theta, starts, length, write_from, bound,
                out, registry, history="rest"):
    """Reference implementation, vectorised over windows (any Φ-function)."""
    reg = registry or default_registry()
    n, ml = y_meas.shape[0], plan.maxlag
    W = starts.shape[0]
    buf = np.empty((W, ml + length))
    if ml:
        buf[:, :ml] = y_meas[starts[:, None] - ml + np.arange(ml)[None, :]]
    rows = np.arange(W)
    ops = {f: _OperatorWindows(f, y_meas, starts, history) for f in plan.out_operators}
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
            if isinstance(f, OpCall):
                fv.append(ops[f].value(j, buf[:, pos - f.arg.lag], live))
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
                v = theta[t] * P[idx[t], kk]
                for q in range(plan.t_ptr[t], plan.t_ptr[t + 1]):
                    v = v * fv[plan.t_fac[q]]
                acc += v
        if not np.all(np.abs(acc[live]) <= bound):
            return True
        buf[rows, pos] = acc
        if j >= write_from:
            out[kk[live]] = acc[live]
    return False


class _OperatorWindows:
    """Values of an operator of an output lag, ``f = Op(y[k-d], ...)``, in
    every window: at step ``j`` of window ``w`` (sample ``k = s_w + j``)
    the operator's value at sample ``k - d``, from the measured output
    while ``j < d``, else stepped on the simulated ``y[k-d]``."""

    def __init__(self, f: OpCall, y_meas, starts, history: str = "rest"):
        self.op = default_operators().get(f.name)
        self.p = np.asarray(f.params, dtype=np.float64)
        self.d = f.arg.lag
        self.measured = self.op.sequence(y_meas, f.params, history=history)
        self.starts = starts
        self.state = self.op.states_after(y_meas, f.params, starts, history)
        self.play = self.op.builtin and f.name == "Play"

    def value(self, j, y_sim, live):
        if j < self.d:
            return self.measured[self.starts + j - self.d]
        if self.play:                       # vectorised over the windows
            r = self.p[0]
            v = np.maximum(np.minimum(y_sim + r, self.state[:, 0]), y_sim - r)
            self.state[:, 0] = np.where(live, v, self.state[:, 0])
            return v
        out = np.zeros(y_sim.shape[0])
        for w in np.flatnonzero(live):
            out[w] = self.op.step(self.state[w], float(y_sim[w]), self.p)
        return out


def _operator_arrays(plan: Plan, y_meas, starts, history: str = "rest"):
    """Kernel arrays of the operators of output lags: codes, lags,
    parameters, measured values (n_op, N) and window start states
    (n_op, W, S), see :class:`_OperatorWindows`."""
    ops = plan.out_operators
    W = starts.shape[0]
    if not ops:
        return (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64),
                np.zeros((0, 1)), np.zeros((0, 1)), np.zeros((0, W, 1)))
    from ..language.memory import BUILTIN_OPERATOR_CODES
    win = [_OperatorWindows(f, y_meas, starts, history) for f in ops]
    width = max(w.state.shape[1] for w in win)
    npar = max([1] + [len(f.params) for f in ops])
    par = np.zeros((len(ops), npar))
    st0 = np.zeros((len(ops), W, width))
    for o, (f, w) in enumerate(zip(ops, win)):
        par[o, :len(f.params)] = f.params
        st0[o, :, :w.state.shape[1]] = w.state
    return (np.array([BUILTIN_OPERATOR_CODES[f.name] for f in ops], dtype=np.int64),
            np.array([f.arg.lag for f in ops], dtype=np.int64), par,
            np.array([w.measured for w in win]), st0)


def run_windows(plan: Plan, P, U, y_meas, theta, starts, length: int,
                write_from: int = 0, bound: Optional[float] = None,
                out: Optional[np.ndarray] = None,
                registry: Optional[PhiRegistry] = None,
                force_python: bool = False, idx=None, history: str = "rest"):
    """Run the recursion over windows; returns ``(out, diverged)``.

    ``P`` is (T, N) input parts, or a column store (C, N) with ``idx`` the
    row of each term. ``out`` (length N, NaN where nothing was written)
    receives step ``j >= write_from`` of each window at sample
    ``starts[w] + j``. Noise terms are zero (their θ is ignored).
    ``history`` starts the operators of output lags
    (:func:`narx.language.memory.history_prefix`; the input parts ``P``
    carry their record's own).
    """
    y_meas = np.ascontiguousarray(y_meas, dtype=np.float64)
    theta = np.where(plan.noise_terms, 0.0, np.asarray(theta, dtype=np.float64))
    idx = (np.arange(len(plan.terms), dtype=np.int64) if idx is None
           else np.ascontiguousarray(idx, dtype=np.int64))
    starts = np.ascontiguousarray(starts, dtype=np.int64)
    if starts.size and starts.min() < plan.maxlag:
        raise ValueError(f"a window starts at sample {starts.min()} but the "
                         f"model needs {plan.maxlag} initial samples")
    if bound is None:
        from ..linalg import divergence_bound
        bound = divergence_bound(y_meas)
    if out is None:
        out = np.full(y_meas.shape[0], np.nan)
    P = np.ascontiguousarray(P)
    if plan.compiled and not force_python:
        diverged = _kernel(y_meas, np.ascontiguousarray(U), P, idx, theta, plan.static,
                           plan.dyn, plan.d_ptr, plan.d_code, plan.p_kind, plan.p_sig,
                           plan.p_lag, starts,
                           int(length), int(write_from), int(plan.maxlag),
                           float(bound), out, *_operator_arrays(plan, y_meas, starts, history))
    else:
        diverged = _run_python(plan, P, idx, U, y_meas, theta, starts, int(length),
                               int(write_from), float(bound), out, registry, history)
    return out, bool(diverged)
