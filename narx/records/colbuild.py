"""Compiled regressor columns for the structure scorer.

Typical use (internal: :class:`narx.estimation.fitness.StructureScorer` fills its
column store with it)::

    from narx.records.colbuild import ColumnBuilder
    cb = ColumnBuilder(data, y, registry)
    if not cb.build(term, row):             # False: not compiled here
        ...                                 # the numpy path (narx.records.regressors)

A term's column on measured data is the product of its factors,

.. math:: \\psi_k = f_1(k)\\, f_2(k) \\cdots f_m(k),

input factors first, then output factors, each in the term's order; a
factor is a lagged signal :math:`x_{k-a}` or a built-in Φ of two lags,
:math:`\\Phi(x_{k-a}, z_{k-b})` computed by :func:`narx.language.phi.phi_value`.
Rows before the term's largest lag are 0 and non-finite products are
clipped as in :func:`narx.estimation.fitness._finite_inplace`.

Each factor is computed on the fly and multiplied into the store's row, one
pass per factor, without a new array per factor (the numpy path builds
each factor as a new array, whose first touch costs more than the
arithmetic). The products are formed in the numpy path's order (a left fold
over the same factor columns), so every value is the same bit for bit.

Terms with noise lags or user Φ-functions return ``False`` from
:meth:`ColumnBuilder.build` and keep the general path.
"""
from __future__ import annotations

from typing import Dict, Optional, Tuple

import numpy as np

from numba import njit

from ..language.phi import PhiRegistry, builtin_code, phi_value
from ..language.terms import Lag, PhiCall, Term

__all__ = ["ColumnBuilder", "build_into", "LAG"]

#: factor kind of a lagged signal; a built-in Φ has its kernel code (> 0)
#: of :data:`narx.language.phi.BUILTINS` (built-ins cannot be re-registered, so the
#: name decides)
LAG = 0


@njit(cache=True, nogil=True)
def build_into(out, S, kind, sa, la, sb, lb):
    """Write the product of the encoded factors into ``out``.

    Factor ``f`` is ``S[sa[f], k - la[f]]`` (kind 0), or the built-in of
    kernel code ``kind[f]`` of that and ``S[sb[f], k - lb[f]]``
    (:func:`narx.language.phi.phi_value`, which raises on an unknown code). Rows
    before the largest lag are 0; NaN -> 0 and ±inf -> ±max float.
    """
    n = out.shape[0]
    nf = kind.shape[0]
    m = 0
    for f in range(nf):
        m = max(m, la[f])
        if kind[f] != LAG:
            m = max(m, lb[f])
    m = min(m, n)
    o = out[m:]
    # slices from 0, so the loops carry no negative-index checks and vectorise
    if nf == 0:
        o[:] = 1.0
    for f in range(nf):
        x = S[sa[f], m - la[f]:n - la[f]]
        if kind[f] == LAG:
            if f == 0:
                o[:] = x
            else:
                for i in range(o.shape[0]):
                    o[i] *= x[i]
            continue
        z = S[sb[f], m - lb[f]:n - lb[f]]
        c = kind[f]
        if f == 0:
            for i in range(o.shape[0]):
                o[i] = phi_value(c, x[i], z[i])
        else:
            for i in range(o.shape[0]):
                o[i] *= phi_value(c, x[i], z[i])
    out[:m] = 0.0
    big = np.finfo(np.float64).max
    for i in range(o.shape[0]):
        v = o[i]
        o[i] = 0.0 if v != v else (big if v > big else (-big if v < -big else v))


class ColumnBuilder:
    """Encodes terms for :func:`build_into` over one record.

    Parameters
    ----------
    data : Data
        The record (its inputs).
    y : ndarray
        The measured output.
    registry : PhiRegistry
        Φ-functions; the built-ins (:data:`narx.language.phi.BUILTINS`) are compiled.
    """

    def __init__(self, data, y: np.ndarray, registry: PhiRegistry):
        self.registry = registry
        self.index = {name: i for i, name in enumerate(data.inputs)}
        self.output = len(self.index)
        # one row per input, then the output
        self.S = np.ascontiguousarray(np.vstack([data.U, np.asarray(y)[None, :]]),
                                      dtype=np.float64)
        self._codes: Dict[Tuple[Term, bool], Optional[tuple]] = {}

    def _signal(self, lag: Lag) -> Optional[int]:
        if lag.role == "u":
            return self.index.get(lag.signal)
        return self.output if lag.role == "y" else None

    def _factor(self, f) -> Optional[tuple]:
        if isinstance(f, Lag):
            s = self._signal(f)
            return None if s is None else (LAG, s, f.lag, 0, 0)
        if not isinstance(f, PhiCall) or len(f.args) != 2:
            return None
        self.registry.get(f.name)                  # an unknown name raises KeyError
        kind = builtin_code(f.name)
        sa, sb = (self._signal(a) for a in f.args)
        if kind is None or sa is None or sb is None:
            return None
        return (kind, sa, f.args[0].lag, sb, f.args[1].lag)

    def code(self, term: Term, input_only: bool = False) -> Optional[tuple]:
        """Arrays for :func:`build_into` (None: not compiled here): the
        term's input factors, then (unless ``input_only``) its other
        factors in the term's order, as the numpy path multiplies them."""
        key = (term, input_only)
        if key in self._codes:
            return self._codes[key]
        if len(self._codes) > 200_000:
            self._codes.clear()
        code = None
        if not term.has_noise:
            factors = list(term.input_factors)
            if not input_only:
                factors += [f for f in term.factors if not f.input_only]
            rows = [self._factor(f) for f in factors]
            if all(r is not None for r in rows):
                cols = np.array(rows, dtype=np.int64).reshape(len(rows), 5).T
                code = tuple(np.ascontiguousarray(c) for c in cols)
        self._codes[key] = code
        return code

    def build(self, term: Term, out: np.ndarray, input_only: bool = False) -> bool:
        """Write the term's column (or its input part) into ``out``; False
        when the term is not compiled here (nothing written)."""
        code = self.code(term, input_only)
        if code is None:
            return False
        build_into(out, self.S, *code)
        return True
