"""Regressor columns and matrices of NARX terms.

Typical use::

    from narx.records.regressors import regressor_matrix
    Psi, target, start = regressor_matrix(terms, data)   # rows k = start..N-1
    theta = lstsq(Psi, target)

Each term factor evaluated at time k:

.. math::  x[k-j] \\text{ for a lag},\\qquad
           \\phi(x_1[k-j_1], \\dots) \\text{ for a Φ-call}.

A term's column is the product of its factor columns. The *input part* (the
product of the factors that depend on inputs only) never depends on the
simulated output, so it is computed once per record and cached in the
:class:`~narx.records.data.Data` column cache; simulation kernels multiply it by the
output part at each step.
"""
from __future__ import annotations

from typing import Optional, Sequence, Tuple

import numpy as np

from numba import njit

from .data import Data
from ..language.memory import default_operators
from ..language.phi import PhiRegistry, default_registry, phi_value
from ..language.terms import Lag, OpCall, PhiCall, Term

__all__ = ["shift", "signal_array", "factor_column", "input_part", "input_part_into",
           "term_column", "regressor_matrix", "max_lag"]


def shift(x: np.ndarray, lag: int) -> np.ndarray:
    """``out[k] = x[k - lag]``; the first ``lag`` samples are NaN."""
    if lag == 0:
        return x
    out = np.empty_like(x)
    out[:lag] = np.nan
    out[lag:] = x[:x.shape[0] - lag]
    return out


def max_lag(terms: Sequence[Term]) -> int:
    """Largest lag of any factor (the number of initial samples needed)."""
    return max((t.max_lag for t in terms), default=0)


def signal_array(lag: Lag, data: Data, y=None, noise=None) -> np.ndarray:
    """The unshifted array of the signal a :class:`Lag` refers to."""
    if lag.role == "u":
        return data.input(lag.signal)
    if lag.role == "y":
        return data.require_output("a regressor with output lags") if y is None else y
    if noise is None:
        return np.zeros(data.n)          # noise terms vanish without residuals
    return noise


@njit(cache=True, nogil=True)
def _lagged_builtin(code, x1, a, x2, b):
    """The built-in of kernel ``code`` of ``x1[k-a]`` and ``x2[k-b]``
    (:func:`narx.language.phi.phi_value`), NaN before the larger lag: in one pass,
    without the shifted copies (bit for bit the row's numpy function)."""
    n = x1.shape[0]
    out = np.empty(n)
    m = min(max(a, b), n)
    for k in range(m):
        out[k] = np.nan
    for k in range(m, n):
        out[k] = phi_value(code, x1[k - a], x2[k - b])
    return out


def factor_column(f, data: Data, y=None, noise=None,
                  registry: Optional[PhiRegistry] = None) -> np.ndarray:
    """Column of one factor over the whole record (NaN before its lag)."""
    if isinstance(f, Lag):
        return shift(signal_array(f, data, y, noise), f.lag)
    if isinstance(f, OpCall):
        return shift(operator_sequence(f, signal_array(f.arg, data, y, noise), data.history),
                     f.arg.lag)
    fn = (registry or default_registry()).get(f.name)
    if fn.builtin and len(f.args) == 2:
        (p, q) = f.args
        return _lagged_builtin(fn.code,
                               np.ascontiguousarray(signal_array(p, data, y, noise),
                                                    dtype=np.float64), p.lag,
                               np.ascontiguousarray(signal_array(q, data, y, noise),
                                                    dtype=np.float64), q.lag)
    args = [shift(signal_array(a, data, y, noise), a.lag) for a in f.args]
    with np.errstate(invalid="ignore"):
        return np.asarray(fn.func(*args), dtype=np.float64)


def operator_sequence(f: OpCall, x, history: str = "rest") -> np.ndarray:
    """The operator of ``f`` over the whole (unshifted) signal ``x``, from
    the operator's default initial state after the path of ``history``
    (:mod:`narx.language.memory`, *Histories*). A plug-in
    operator's overflow is left as inf or NaN without a numpy warning (the
    fit refuses a non-finite column: :meth:`narx.estimation.fitness.StructureScorer.fit`)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return default_operators().get(f.name).sequence(x, f.params, history=history)


def _product(cols, n):
    if not cols:
        return np.ones(n)
    return cols[0] if len(cols) == 1 else _multiply_into(cols, np.empty(n))


def _multiply_into(cols, out: np.ndarray) -> np.ndarray:
    """The product of two or more ``cols`` written into ``out``; an overflow
    is left as inf or NaN without a numpy warning (the fit refuses a
    non-finite column: :meth:`narx.estimation.fitness.StructureScorer.fit`)."""
    with np.errstate(over="ignore", invalid="ignore"):
        np.multiply(cols[0], cols[1], out=out)
        for c in cols[2:]:
            out *= c
    return out


def _key(f, reg: PhiRegistry) -> str:
    """Cache key of a factor: its text, plus the identity of its function
    (a re-registered or other registry's Φ-function gets new columns)."""
    if isinstance(f, PhiCall):
        return f"{f}@{id(reg.get(f.name).func):x}"
    if isinstance(f, OpCall):
        return f"{f}@{id(default_operators().get(f.name).step):x}"
    return str(f)


def _input_key(term: Term, reg: PhiRegistry) -> str:
    return "in:" + "*".join(_key(f, reg) for f in term.input_factors)


def _input_columns(term: Term, data: Data, reg: PhiRegistry) -> list:
    """The factor columns of the term's input part (cached per record)."""
    return [data.cached("f:" + _key(f, reg), lambda f=f: factor_column(f, data, registry=reg))
            for f in term.input_factors]


def input_part(term: Term, data: Data,
               registry: Optional[PhiRegistry] = None) -> np.ndarray:
    """Product of the input-only factors of ``term`` (cached per record)."""
    reg = registry or default_registry()
    return data.cached(_input_key(term, reg),
                       lambda: _product(_input_columns(term, data, reg), data.n))


def input_part_into(term: Term, data: Data, out: np.ndarray,
                    registry: Optional[PhiRegistry] = None) -> np.ndarray:
    """:func:`input_part` written into ``out`` (same values, bit for bit):
    from the record's cached product when there is one, else multiplied
    straight into ``out`` from the cached factor columns, without a new
    array for the product (a fresh array costs its page faults)."""
    reg = registry or default_registry()
    done = data.cached_only(_input_key(term, reg))
    if done is not None:
        out[:] = done
        return out
    cols = _input_columns(term, data, reg)
    if not cols:
        out[:] = 1.0
    elif len(cols) == 1:
        out[:] = cols[0]
    else:
        _multiply_into(cols, out)
    return out


def term_column(term: Term, data: Data, y=None, noise=None,
                registry: Optional[PhiRegistry] = None) -> np.ndarray:
    """Full column of ``term`` from measured (or given) output and noise."""
    rest = [f for f in term.factors if not f.input_only]
    base = input_part(term, data, registry)
    if not rest:
        return base
    out = base.copy()
    for f in rest:
        out *= factor_column(f, data, y, noise, registry)
    return out


def regressor_matrix(terms: Sequence[Term], data: Data, y=None, noise=None,
                     start: Optional[int] = None,
                     registry: Optional[PhiRegistry] = None
                     ) -> Tuple[np.ndarray, np.ndarray, int]:
    """Regressor matrix Ψ and target for rows ``k = start..N-1``.

    Parameters
    ----------
    terms : sequence of Term
    data : Data
    y : array, optional
        Output to use in place of ``data.y`` (e.g. a simulation).
    noise : array, optional
        Residual sequence for ``e[k-j]`` factors (zeros when omitted).
    start : int, optional
        First row; default the model's largest lag.

    Returns
    -------
    Psi : ndarray, shape (N - start, len(terms)), Fortran order
    target : ndarray, shape (N - start,)
    start : int
    """
    yy = data.require_output("building a regressor matrix") if y is None else y
    s = max_lag(terms) if start is None else int(start)
    if s >= data.n:
        raise ValueError(f"record of {data.n} samples is too short for the "
                         f"model's largest lag {s}")
    Psi = np.empty((data.n - s, len(terms)), order="F")
    for j, t in enumerate(terms):
        Psi[:, j] = term_column(t, data, yy, noise, registry)[s:]
    return Psi, yy[s:], s
