"""Input/output records: validated arrays plus a per-record column cache.

Typical use::

    from narx.records.data import Data
    d = Data(u, y)                       # one input named 'u', output 'y'
    d = Data(U, y, inputs=("x", "v"))    # U of shape (N, 2)
    d.n, d.inputs, d.output

Validation follows one rule: every problem raises :class:`DataError` with
one line naming the signal, the rule and the offending value or sample.
The cache holds input-only regressor factors (they never depend on the
simulated output), so each is computed once per record.
"""
from __future__ import annotations

from collections import OrderedDict
from typing import Optional, Sequence

import numpy as np

from ..exceptions import DataError
from ..language.memory import check_history
from ..language.terms import HasSignals, Signals

__all__ = ["Data", "DataError", "as_data"]


def _as_float(name, a, ndim_ok=(1,)):
    try:
        arr = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise DataError(f"{name} must be numeric: {exc}") from None
    if arr.ndim not in ndim_ok:
        raise DataError(f"{name} must have {' or '.join(map(str, ndim_ok))} "
                        f"dimension(s), got shape {arr.shape}")
    return arr


#: largest magnitude accepted in a record: products of a few such samples
#: (regressors of degree 3, their squares in LS) stay finite in float64
MAX_ABS = 1e75


def _check_finite(name, arr):
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = np.argwhere(bad)[0]
        val = arr[tuple(idx)]
        raise DataError(f"{name} has a non-finite value ({'NaN' if np.isnan(val) else val}) "
                        f"at sample {int(idx[0])}")
    big = np.abs(arr) > MAX_ABS
    if big.any():
        idx = np.argwhere(big)[0]
        raise DataError(f"{name} has a value too large to model ({arr[tuple(idx)]!r} at "
                        f"sample {int(idx[0])}; |values| up to {MAX_ABS:.0e} are accepted): "
                        f"rescale the data")


class Data(HasSignals):
    """A validated record: inputs ``U`` (N, m), output ``y`` (N,), names.

    Parameters
    ----------
    u : array_like, shape (N,) or (N, m)
    y : array_like, shape (N,), optional
        Measured output. May be omitted for pure simulation, in which case
        ``y0`` initial conditions are supplied at simulation time.
    inputs : sequence of str
    output : str
    history : str
        The path the signals arrived by before the first sample, which
        starts the memory operators (:data:`narx.language.memory.HISTORIES`:
        'rest', 'rising', 'falling'); :meth:`with_history` sets it.
    """

    history = "rest"

    def __init__(self, u, y=None, *, inputs: Optional[Sequence[str]] = None,
                 output: str = "y", noise: str = "e", history: str = "rest"):
        U = _as_float("u", u, (1, 2))
        if U.ndim == 1:
            U = U[:, None]
        if inputs is None:
            inputs = ("u",) if U.shape[1] == 1 else tuple(f"u{i + 1}" for i in range(U.shape[1]))
        inputs = (inputs,) if isinstance(inputs, str) else tuple(inputs)
        if len(inputs) != U.shape[1]:
            raise DataError(f"u has {U.shape[1]} column(s) but {len(inputs)} input "
                            f"name(s) were given: {list(inputs)}")
        self.signals = Signals(output, inputs, noise)
        _check_finite("u", U)
        self.U = np.ascontiguousarray(U.T)          # (m, N): one row per input
        if y is not None:
            yy = _as_float(output, y)
            if yy.shape[0] != U.shape[0]:
                raise DataError(f"{output} has {yy.shape[0]} samples but u has "
                                f"{U.shape[0]}: lengths must match")
            _check_finite(output, yy)
            self.y = np.ascontiguousarray(yy)
        else:
            self.y = None
        self._cache = OrderedDict()
        self._cache_bytes = 0
        if history != "rest":
            self.history = check_history(history)

    #: upper bound of the column cache in bytes (least recently used dropped)
    cache_limit = 512 * 2**20

    # ------------------------------------------------------------------
    @property
    def n(self) -> int:
        return self.U.shape[1]

    def input(self, name: str) -> np.ndarray:
        return self.U[self.signals.inputs.index(name)]

    def require_output(self, what="this operation"):
        if self.y is None:
            raise DataError(f"{what} needs the measured output {self.output!r}")
        return self.y

    def require_varying_output(self, why: str) -> None:
        """Raise :class:`DataError` when the output holds one value on every
        sample: ``output 'y' is constant (every sample 5.0): {why}``."""
        if self.y is not None and self.n > 1 and np.ptp(self.y) == 0:
            raise DataError(f"output {self.output!r} is constant (every sample "
                            f"{float(self.y[0])!r}): {why}")

    def slice(self, start=None, stop=None) -> "Data":
        """A new record of samples ``start:stop`` (own empty cache); it keeps
        the history when it starts where this record starts, else starts
        at rest."""
        d = Data.__new__(Data)
        d.signals = self.signals
        d.U = np.ascontiguousarray(self.U[:, start:stop])
        d.y = None if self.y is None else np.ascontiguousarray(self.y[start:stop])
        d._cache, d._cache_bytes = OrderedDict(), 0
        if not start and self.history != "rest":
            d.history = self.history
        return d

    def with_history(self, history: str) -> "Data":
        """The same samples started from ``history`` (own empty cache;
        :data:`narx.language.memory.HISTORIES`)."""
        check_history(history)
        if history == self.history:
            return self
        d = self.slice()
        d.history = history
        return d

    def cached(self, key: str, fn):
        """Column cache: ``fn()`` is called once per key and record."""
        v = self.cached_only(key)
        if v is not None:
            return v
        v = fn()
        self._cache[key] = v
        self._cache_bytes += v.nbytes
        while self._cache_bytes > self.cache_limit and len(self._cache) > 1:
            _, old = self._cache.popitem(last=False)
            self._cache_bytes -= old.nbytes
        return v

    def cached_only(self, key: str):
        """The cached column of ``key``, or None (nothing is built)."""
        v = self._cache.get(key)
        if v is not None:
            self._cache.move_to_end(key)
        return v

    def clear_cache(self):
        self._cache.clear()
        self._cache_bytes = 0

    def __getstate__(self):
        # worker processes rebuild their own cache
        return {"signals": self.signals, "U": self.U, "y": self.y, "history": self.history}

    def __setstate__(self, st):
        self.signals, self.U, self.y = st["signals"], st["U"], st["y"]
        self._cache, self._cache_bytes = OrderedDict(), 0
        if st.get("history", "rest") != "rest":
            self.history = st["history"]

    def __repr__(self):
        return (f"Data(n={self.n}, inputs={list(self.inputs)}, output={self.output!r}"
                f"{', no output' if self.y is None else ''}"
                f"{'' if self.history == 'rest' else f', history={self.history!r}'})")


def as_data(u, y=None, *, inputs=None, output="y") -> Data:
    """Return ``u`` if it is already :class:`Data`, else wrap ``(u, y)``."""
    if isinstance(u, Data):
        if y is not None:
            raise DataError("pass either a Data record or (u, y), not both")
        return u
    return Data(u, y, inputs=inputs, output=output)
