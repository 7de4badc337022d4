"""Window-major multiple-shooting kernel for the ``ms`` fitness of a search.

Typical use (internal: :class:`narx.estimation.fitness.StructureScorer` creates one
:class:`MultipleShooting` for its record and calls it first)::

    from narx.simulation.ms_kernel import MultipleShooting
    ms = MultipleShooting(y, window=100, budget_bytes=128 * 2**20)
    mse = ms.mse(terms, theta, s, bound, scorer.input_column)
    # None: not handled, use run_windows

Multiple shooting is ``W`` independent windows of Δm steps. The general
kernel (:mod:`narx.simulation.kernels`) runs them one after the other, so every step
waits for the previous one (the recursion ``ŷ_k <- ŷ_{k-1}`` is a chain of
dependent multiply-adds). Here step ``j`` of *all* windows is computed
together: the innermost loop runs over windows, which are independent, so it
vectorises. The input parts are kept in a second column store laid out
window-major (``PT[c, j*W + w] = P[c, s + w*Δm + j]``, zero past the end),
built once per column for the first scored row ``s`` and the window, so the
inner loop reads contiguous memory (the measured output is kept
window-major too). That store is an LRU of at most ``budget_bytes``
(default :data:`BUDGET`, 128 MB, env ``NARX_MS_BUDGET_MB``), allocated
empty: its memory is touched as columns fill it.

Results are bit-for-bit those of the general kernel followed by
:func:`window_sse`: the same operations in the same order for every window,
and the squared errors summed per window (one running sum per window,
updated as the steps advance), then over windows in window order. Hence
identical for any number of workers.

Handled: no term has noise lags, and a Φ-call with an output argument is a
built-in Φ of two output lags (what ``phi_outputs`` searches build).
Anything else returns ``None`` and the general kernel runs.
"""
from __future__ import annotations

import os
from collections import OrderedDict
from typing import Callable, Dict, Optional, Sequence

import numpy as np

from numba import njit

from ..language.phi import builtin_code, phi_value
from ..language.terms import Lag, PhiCall, Term

__all__ = ["MultipleShooting", "window_sse", "WindowStore", "ENABLED", "BUDGET"]

#: False runs the general kernel instead (benchmarks compare the two);
#: the environment variable NARX_MS_KERNEL=0 sets it in worker processes too
ENABLED = os.environ.get("NARX_MS_KERNEL", "1") != "0"
#: default bytes of window-major columns kept per scorer (LRU beyond that)
BUDGET = int(os.environ.get("NARX_MS_BUDGET_MB", "128")) * 2**20


@njit(cache=True, nogil=True)
def window_sse(r, L):
    r"""Sum of squared multiple-shooting errors in the canonical order.

    ``r[i]`` is the error at the ``i``-th sample of the scored range, whose
    windows hold ``L`` samples each (the last may be shorter). Each window's
    squared errors are summed over its steps in order, then the window sums
    are added in window order:

    .. math:: J = \sum_{w} \Big( \sum_{j} r_{wL+j}^2 \Big)

    Both MS kernels use this order (``_ms_sse`` accumulates one sum per
    window while it steps all windows together), so their results are equal
    bit for bit and independent of the number of workers.
    """
    n = r.shape[0]
    total = 0.0
    for a in range(0, n, L):
        acc = 0.0
        for i in range(a, min(a + L, n)):
            acc += r[i] * r[i]
        total += acc
    return total


@njit(cache=True, nogil=True)
def _ms_sse(y, YT, PT, idx, theta, static, dyn, lags, nlag, s, L, W, ml, bound,
            pkind, pla, plb):
    """(diverged, Σ r²) of multiple shooting, window-major, summed as
    :func:`window_sse` does.

    Window ``w`` starts at ``s + w*L``; ``B[ml + j, w]`` is its step ``j``
    and ``B[:ml, w]`` the measured samples before it; ``YT[j*W + w]`` is the
    measured output at that step. ``lags[i, q]`` is the q-th output factor
    of dynamic term i: an output lag (> 0) or ``-f`` for the Φ-call of
    output lags in slot f (the built-in of kernel code ``pkind[f]`` of the
    output at lags ``pla[f]`` and ``plb[f]``, :func:`narx.language.phi.phi_value`),
    computed at each step as :func:`narx.simulation.kernels._kernel` does.
    """
    n = y.shape[0]
    B = np.empty((ml + L, W))
    acc = np.empty(W)
    S = np.zeros(W)
    n_phi = pkind.shape[0]
    PH = np.empty((n_phi, W))
    n_dyn = dyn.shape[0]
    # dynamic terms with a Φ-call of output lags (codes <= 0), once per call
    has_phi = np.zeros(n_dyn, dtype=np.bool_)
    for i in range(n_dyn):
        for q in range(nlag[i]):
            if lags[i, q] <= 0:
                has_phi[i] = True
    for j in range(ml):
        for w in range(W):
            B[j, w] = y[s + w * L - ml + j]
    last = n - (s + (W - 1) * L)            # steps of the last window
    for j in range(L):
        Wj = W if j < last else W - 1
        if Wj == 0:
            break
        pos = ml + j
        off = j * W
        # 1-D views: unit stride, no index wrap-around, so loops vectorise
        for w in range(Wj):
            acc[w] = 0.0
        for i in range(static.shape[0]):        # same order as the base sum
            t = static[i]
            th = theta[t]
            if th != 0.0:
                p = PT[idx[t], off:off + Wj]
                for w in range(Wj):
                    acc[w] += th * p[w]
        for f in range(n_phi):
            ra = B[pos - pla[f]]
            rb = B[pos - plb[f]]
            ph = PH[f]
            c = pkind[f]
            for w in range(Wj):
                ph[w] = phi_value(c, ra[w], rb[w])
        for i in range(n_dyn):
            t = dyn[i]
            th = theta[t]
            p = PT[idx[t], off:off + Wj]
            nl = nlag[i]
            if has_phi[i]:
                for w in range(Wj):
                    v = th * p[w]
                    for q in range(nl):
                        c = lags[i, q]
                        v *= B[pos - c, w] if c > 0 else PH[-c, w]
                    acc[w] += v
                continue
            b0 = B[pos - lags[i, 0]]
            if nl == 1:
                for w in range(Wj):
                    acc[w] += th * p[w] * b0[w]
            elif nl == 2:
                b1 = B[pos - lags[i, 1]]
                for w in range(Wj):
                    acc[w] += th * p[w] * b0[w] * b1[w]
            else:
                for w in range(Wj):
                    v = th * p[w] * b0[w]
                    for q in range(1, nl):
                        v *= B[pos - lags[i, q], w]
                    acc[w] += v
        bad = 0
        for w in range(Wj):
            bad += not (abs(acc[w]) <= bound)       # NaN and inf count too
        if bad:
            return True, 0.0
        out = B[pos]
        yt = YT[off:off + Wj]
        for w in range(Wj):
            out[w] = acc[w]
            e = yt[w] - acc[w]
            S[w] += e * e
    total = 0.0
    for w in range(W):
        total += S[w]
    return False, total


class WindowStore:
    """Input-part columns laid out window-major for one (N, start, Δm): an
    LRU of ``budget_bytes``, allocated empty once (its pages are touched as
    slots fill, and nothing is ever copied to grow it)."""

    def __init__(self, n: int, start: int, window: int, budget_bytes: int):
        self.n, self.start, self.window = int(n), int(start), int(window)
        self.W = len(range(self.start, self.n, self.window))
        width = self.W * self.window
        self.capacity = max(16, int(budget_bytes // (8 * width)))   # > 15 terms
        self.array = np.empty((self.capacity, width))
        self.slots: "OrderedDict[str, int]" = OrderedDict()
        self.builds = 0

    def permute_into(self, col: np.ndarray, row: np.ndarray) -> None:
        """``row[j*W + w] = col[start + w*Δm + j]`` (0 past the end)."""
        L, W, s = self.window, self.W, self.start
        dst = row.reshape(L, W)
        m = self.n - s
        full = m // L
        dst[:, :full] = col[s:s + full * L].reshape(full, L).T
        if full < W:                                  # the last, short window
            rem = m - full * L
            dst[:rem, full] = col[s + full * L:]
            dst[rem:, full] = 0.0

    def clear(self):
        """Forget every column (the array and its pages are kept)."""
        self.slots.clear()

    def slot(self, key: str, natural) -> int:
        """Slot of ``key``; ``natural()`` gives the length-N column on a miss."""
        slot = self.slots.get(key)
        if slot is not None:
            self.slots.move_to_end(key)
            return slot
        if len(self.slots) < self.capacity:
            slot = len(self.slots)
        else:
            _, slot = self.slots.popitem(last=False)
        self.permute_into(natural(), self.array[slot])
        self.slots[key] = slot
        self.builds += 1
        return slot


def _term_info(t: Term):
    """(input-part key, output factors) or None if the fast path cannot run
    it; an output factor is a lag (int) or a built-in Φ of two output lags
    ``(code, lag_a, lag_b)``."""
    if t.has_noise:
        return None
    facs = []
    for f in t.output_factors:
        if isinstance(f, Lag):
            facs.append(f.lag)
        elif (isinstance(f, PhiCall) and builtin_code(f.name) is not None
              and len(f.args) == 2 and all(a.role == "y" for a in f.args)):
            facs.append((builtin_code(f.name), f.args[0].lag, f.args[1].lag))
        else:
            return None                  # Φ mixing output and input: general kernel
    return "*".join(str(f) for f in t.input_factors), tuple(facs)


class MultipleShooting:
    """Multiple-shooting MSE of term sets on one record, window-major.

    Parameters
    ----------
    y : ndarray
        The measured output (initial conditions and targets).
    window : int
        Δm, samples per window.
    budget_bytes : int
        Bytes of the window-major store (default :data:`BUDGET`).

    The window-major store is laid out for one first row ``s``; a call
    with another ``s`` starts a new store. It holds no reference to its
    owner (the input parts come with each call), so an owner that drops it
    frees it at once.
    """

    def __init__(self, y: np.ndarray, window: int, budget_bytes: int = BUDGET):
        self.y = np.ascontiguousarray(y, dtype=np.float64)
        self.window = int(window)
        self.budget_bytes = int(budget_bytes)
        self.store: Optional[WindowStore] = None
        self.info: Dict[Term, Optional[tuple]] = {}
        self.YT: Optional[np.ndarray] = None

    def clear(self) -> None:
        """Forget every column and term layout (the store's array is kept)."""
        if self.store is not None:
            self.store.clear()
        self.info.clear()

    def _layout(self, s: int) -> WindowStore:
        if self.store is None or self.store.start != s:
            self.store = WindowStore(self.y.shape[0], s, self.window, self.budget_bytes)
            #: the measured output, window-major like the input parts
            self.YT = np.empty(self.store.W * self.window)
            self.store.permute_into(self.y, self.YT)
        return self.store

    def mse(self, terms: Sequence[Term], theta, s: int, bound: float,
            input_column: Callable[[Term], np.ndarray]) -> Optional[float]:
        """Multiple-shooting MSE of ``terms`` with ``theta`` from row ``s``.

        ``input_column(term)`` gives the term's input part on the record, a
        length-N array, read at once and not kept. Same value, bit for bit, as :func:`narx.simulation.kernels.run_windows` over
        the windows followed by :func:`window_sse`; ``inf`` when a window
        leaves ``bound``; ``None`` when not handled here (or when
        :data:`ENABLED` is False).
        """
        if not ENABLED or s >= self.y.shape[0]:
            return None
        infos = []
        for t in terms:
            info = self.info.get(t, 0)
            if info == 0:
                if len(self.info) > 200_000:
                    self.info.clear()
                info = self.info[t] = _term_info(t)
            if info is None:
                return None
            infos.append(info)
        ws = self._layout(s)
        idx = np.empty(len(terms), dtype=np.int64)
        static, dyn, lag_rows, phis = [], [], [], {}
        for i, (t, (key, facs)) in enumerate(zip(terms, infos)):
            idx[i] = ws.slot(key, lambda t=t: input_column(t))
            if facs:
                dyn.append(i)
                # a lag, or -slot of a Φ-call of output lags (slots 0, 1, ...)
                lag_rows.append([f if isinstance(f, int) else -phis.setdefault(f, len(phis))
                                 for f in facs])
            else:
                static.append(i)
        width = max((len(r) for r in lag_rows), default=1)
        lags = np.zeros((len(lag_rows), width), dtype=np.int64)
        for i, r in enumerate(lag_rows):
            lags[i, :len(r)] = r
        nlag = np.array([len(r) for r in lag_rows], dtype=np.int64)
        pk = np.array([k for k, _, _ in phis], dtype=np.int64)
        pla = np.array([a for _, a, _ in phis], dtype=np.int64)
        plb = np.array([b for _, _, b in phis], dtype=np.int64)
        ml = max([c for r in lag_rows for c in r] + list(pla) + list(plb) + [0])
        diverged, sse = _ms_sse(self.y, self.YT, ws.array, idx,
                                np.ascontiguousarray(theta, dtype=np.float64),
                                np.array(static, dtype=np.int64),
                                np.array(dyn, dtype=np.int64), lags, nlag,
                                s, ws.window, ws.W, int(ml), float(bound), pk, pla, plb)
        if diverged:
            return float("inf")
        return float(sse / (self.y.shape[0] - s))
