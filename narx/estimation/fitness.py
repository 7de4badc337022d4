"""Score term sets on one record: LS/CLS, then the chosen simulation's MSE.

Typical use (the inner loop of a structure search)::

    from narx.estimation.fitness import StructureScorer
    sc = StructureScorer(data, fitness="ms", window=100, start=16)
    mse, theta = sc.evaluate(terms)

For a term set :math:`\\{t_i\\}` the scorer estimates θ by least squares
on the one-step regressors of rows ``start..N-1`` (``start`` fixed for the
whole search so results are comparable and cacheable), then returns

.. math::  J = \\frac{1}{|K|}\\sum_{k\\in K} (y_k - \\hat y_k)^2

where ŷ is the one-step (``osa``, alias ``pem``), free-run, k-steps-ahead
(``ksa``) or multiple-shooting (``ms``) simulation and K its valid samples; a
diverging simulation scores ``inf``.

Speed comes from caching across term sets, as a structure search meets the
same terms again and again:

* every distinct regressor column (on measured data) and every input-only
  part is computed once (compiled, :mod:`narx.records.colbuild`, for the built-in
  Φ-functions) and kept in a :class:`ColumnStore` (bounded LRU);
* every Gram entry :math:`\\psi_i^T\\psi_j` and :math:`\\psi_i^T y` is
  computed once, in a fixed summation order (:mod:`narx.estimation.gram`); θ then
  comes from the small normal equations, solved on unit-diagonal scaling
  by a rank-revealing pivoted-QR least-squares solve
  (:func:`narx.linalg.gram_lstsq`), which is the minimum-norm LS solution
  when columns are dependent. Final models
  are refitted with :func:`narx.estimation.estimate.least_squares` on the regressor
  matrix itself (``Model.fit``);
* the compiled kernel reads input parts straight from the store;
* the ``ms`` fitness with a fixed ``start`` runs the window-major kernel of
  a :class:`~narx.simulation.ms_kernel.MultipleShooting` the scorer owns.

The stores are allocated empty (``numpy.empty``): a scorer's resident
memory grows with the columns it actually holds, up to its budget.
"""
from __future__ import annotations

from collections import OrderedDict
from typing import Dict, Optional, Sequence, Tuple

import numpy as np
from numba import njit

from ..records.colbuild import ColumnBuilder
from ..records.data import Data
from ..exceptions import EstimationError
from .gram import fill_gram as _fill_gram, fixed_dot
from ..simulation.kernels import Plan, run_windows
from ..linalg import divergence_bound, gram_lstsq
from ..simulation.ms_kernel import BUDGET as MS_BUDGET, MultipleShooting, window_sse
from ..language.phi import PhiRegistry, default_registry
from .output_error import (OE_ESTIMATORS, OutputErrorProblem, burn_in, check_estimator,
                           innovation_mse, noise_order, output_error_theta)
from ..records.regressors import factor_column, input_part_into, regressor_matrix
from ..simulation.simulate import MODES, mode_name, recursion_windows
from ..analysis.steady import steady_state_constraints
from ..language.terms import Term

__all__ = ["StructureScorer", "ColumnStore", "FITNESS", "fixed_dot"]


@njit(cache=True, nogil=True)
def _finite_inplace(x):
    """``x`` with NaN -> 0 and ±inf -> ±max float, in one pass, in place
    (``numpy.nan_to_num(x, nan=0.0)`` without its three temporaries)."""
    big = np.finfo(np.float64).max
    for i in range(x.shape[0]):
        v = x[i]
        if v != v:
            x[i] = 0.0
        elif v > big:
            x[i] = big
        elif v < -big:
            x[i] = -big
    return x


@njit(cache=True, nogil=True)
def _osa_sse(P, idx, theta, y, s):
    """Σ (y_k − Σ_i θ_i P[idx_i, k])² over k >= s, in a fixed order."""
    acc = 0.0
    for k in range(s, y.shape[0]):
        p = 0.0
        for i in range(idx.shape[0]):
            p += theta[i] * P[idx[i], k]
        r = y[k] - p
        acc += r * r
    return acc


#: the fitness names: the simulation modes (``pem`` is accepted for ``osa``,
#: :data:`narx.simulation.simulate.MODE_TABLE`)
FITNESS = MODES
#: default size of a scorer's column cache (bytes)
SCORER_BUDGET = 160 * 2**20


class ColumnStore:
    """(C, N) array of cached columns with LRU slot reuse.

    ``budget_bytes`` sets the capacity C (at least ``min_slots``, at most
    ``max_slots``). The array is allocated once and empty, so its memory is
    touched only as columns fill it (nothing is ever copied to grow it);
    ``prefault`` writes it all at construction instead, so a long-lived
    worker's resident size does not grow later (joblib's loky restarts a
    worker whose resident size grows by 300 MB after its first task).
    """

    @staticmethod
    def slots_for(n: int, budget_bytes: int = 256 * 2**20, min_slots: int = 64,
                  max_slots: int = 1024) -> int:
        """Capacity of a store for ``n``-sample columns."""
        return min(max_slots, max(min_slots, int(budget_bytes // (8 * max(n, 1)))))

    def __init__(self, n: int, budget_bytes: int = 256 * 2**20, min_slots: int = 64,
                 max_slots: int = 1024, prefault: bool = False):
        self.capacity = self.slots_for(n, budget_bytes, min_slots, max_slots)
        self.n = n
        self.array = np.empty((self.capacity, n))
        if prefault:
            self.array[:] = 0.0
        self.slots: "OrderedDict[str, int]" = OrderedDict()
        self.free = list(range(self.capacity - 1, -1, -1))
        self.builds = 0
        #: slots whose content was replaced since the owner last looked
        self.evicted = []

    def get(self, key: str, fill) -> int:
        """Slot of ``key``; if absent, ``fill(row)`` writes the column into
        its (reused) row of the store."""
        slot = self.slots.get(key)
        if slot is not None:
            self.slots.move_to_end(key)
            return slot
        if not self.free:
            _, slot = self.slots.popitem(last=False)
            self.evicted.append(slot)
            self.free.append(slot)
        slot = self.free.pop()
        fill(self.array[slot])
        self.slots[key] = slot
        self.builds += 1
        return slot

    def __contains__(self, key):
        return key in self.slots

    def clear(self):
        """Forget every column (the array and its pages are kept)."""
        self.evicted.extend(self.slots.values())
        self.slots.clear()
        self.free = list(range(self.capacity - 1, -1, -1))


class StructureScorer:
    """LS/CLS + simulation fitness of term sets on one record.

    Parameters
    ----------
    data : Data
        The record (inputs and measured output).
    fitness : {'osa', 'freerun', 'ksa', 'ms'} or an alias ('pem' for 'osa')
    window : int
        Δm for ``ms`` (default 100).
    k : int
        Horizon for ``ksa`` (default 10).
    constraints : None or 'steady-state'
        CLS with the derived continuum-of-steady-states constraints.
    start : int, optional
        First row used for estimation and scoring; must be at least the
        largest lag of every scored set (default: the set's own).
    budget_bytes : int
        Size of the column cache (default 160 MB; the ``ms`` fitness keeps
        a second, window-major cache of ``narx.simulation.ms_kernel.BUDGET``, 128 MB,
        at most the column cache's size). Both are allocated empty and
        touched as they fill.
    bound : float, optional
        Divergence bound of the simulations: a window whose output leaves
        ``[-bound, bound]`` scores ``inf`` (default ``1e4 max|y|``; see
        :meth:`set_bound`).
    prefault : bool
        Write the column cache at construction, so the resident size does
        not grow later (for long-lived worker processes).
    estimator : {'ls', 'oe', 'bj'}
        θ of a term set: least squares (default), or output error
        (:mod:`narx.estimation.output_error`: IV from the LS θ, then Gauss–Newton on
        the simulation error), which is not biased by white noise on the
        measured output; for the ``ms`` and ``freerun`` fitness, without
        ``constraints``. With ``'oe'`` the first
        :func:`narx.estimation.output_error.burn_in` steps of each simulated window
        are not scored. ``'bj'``: θ as ``'oe'``, and the score is the
        simulation error's variance after an autoregressive noise model
        has whitened it (:func:`narx.estimation.output_error.innovation_mse`; the
        mean squared error when it is white).

    Attributes
    ----------
    bound : float
        The divergence bound in use.
    shooting : narx.simulation.ms_kernel.MultipleShooting or None
        The window-major multiple-shooting kernel (``ms`` fitness with a
        fixed ``start``), else None.
    """

    def __init__(self, data: Data, fitness: str = "ms", *, window: Optional[int] = None,
                 k: Optional[int] = None, constraints: Optional[str] = None,
                 start: Optional[int] = None, registry: Optional[PhiRegistry] = None,
                 budget_bytes: int = SCORER_BUDGET, bound: Optional[float] = None,
                 prefault: bool = False, estimator: str = "ls"):
        fitness = mode_name(fitness, "fitness")
        check_estimator(estimator, fitness, constraints)
        self.estimator = estimator
        if constraints not in (None, "steady-state"):
            raise ValueError(f"constraints must be None or 'steady-state', got {constraints!r}")
        self.data = data
        self.y = data.require_output("scoring a structure")
        self.fitness = fitness
        self.window = int(window) if window is not None else 100
        self.k = int(k) if k is not None else 10
        if self.window < 1 or self.k < 1:
            raise ValueError(f"window and k must be >= 1, got window={window!r}, k={k!r}")
        #: simulated steps of each window left out of the score
        self.burn = burn_in(fitness, self.window) if estimator in OE_ESTIMATORS else 0
        self.constraints = constraints
        self.start = None if start is None else int(start)
        self.registry = registry or default_registry()
        self.store = ColumnStore(data.n, budget_bytes, prefault=prefault)
        self._builder = ColumnBuilder(data, self.y, self.registry)
        # besides the stores, what may grow is bounded: the record's column
        # cache, the decoder and term caches
        data.cache_limit = min(data.cache_limit, 48 * 2**20)
        # Gram entries psi_i^T psi_j and psi_i^T y of cached columns, indexed
        # by store slot, for rows >= self._gram_start (NaN: not computed)
        cap = self.store.capacity
        self._G = np.full((cap, cap), np.nan)
        self._b = np.full(cap, np.nan)
        self._gram_start = -1
        self._out_cols: Dict[str, np.ndarray] = {}
        self.set_bound(divergence_bound(self.y) if bound is None else bound)
        self.shooting = None
        if self.fitness == "ms" and self.start is not None:
            self.shooting = MultipleShooting(
                self.y, self.window, min(MS_BUDGET, self.store.capacity * 8 * data.n))
        self.evaluations = 0

    @property
    def bound(self) -> float:
        """Divergence bound of the simulations (set by :meth:`set_bound`)."""
        return self._bound

    def set_bound(self, bound: float) -> "StructureScorer":
        """Set the divergence bound: a simulation whose output leaves
        ``[-bound, bound]`` (or is not finite) scores ``inf``."""
        try:
            value = float(bound)
        except (TypeError, ValueError):
            value = float("nan")
        if not (value >= 0 and np.isfinite(value)):
            raise ValueError(f"bound must be a finite number >= 0, got {bound!r}")
        self._bound = value
        return self

    def clear_cache(self):
        """Forget every cached column and Gram entry, and the record's column
        cache, so the next evaluation builds everything (the allocated
        stores are kept)."""
        self.store.clear()
        self._gram_start = -1
        self._out_cols.clear()
        if self.shooting is not None:
            self.shooting.clear()
        self.data.clear_cache()

    # ------------------------------------------------------------ columns
    def _out_column(self, f) -> np.ndarray:
        """Column of an output (or noise) factor on measured data, cached."""
        key = str(f)
        col = self._out_cols.get(key)
        if col is None:
            # at most 64 columns and 48 MB (long records), so a worker's
            # resident size stays bounded
            if len(self._out_cols) >= min(64, max(4, (48 << 20) // (8 * max(self.data.n, 1)))):
                self._out_cols.clear()
            col = self._out_cols[key] = factor_column(f, self.data, self.y, None,
                                                      self.registry)
        return col

    def _reg_slot(self, t: Term) -> int:
        def fill(row):
            if self._builder.build(t, row):
                return
            # (input part) * out_1 * out_2 ..., in this order, into the store
            input_part_into(t, self.data, row, self.registry)
            for f in t.factors:
                if not f.input_only:
                    row *= self._out_column(f)
            _finite_inplace(row)
        return self.store.get("r:" + t.text, fill)

    def input_column(self, t: Term) -> np.ndarray:
        """The input part of term ``t`` on the record (a row of the column
        store: read it before the next column is added)."""
        return self.store.array[self._in_slot(t)]

    def _in_slot(self, t: Term) -> int:
        if not t.output_factors and not t.has_noise:
            return self._reg_slot(t)

        def fill(row):
            if not self._builder.build(t, row, input_only=True):
                input_part_into(t, self.data, row, self.registry)
                _finite_inplace(row)
        return self.store.get("i:" + "*".join(str(f) for f in t.input_factors), fill)

    def _gram(self, slots: np.ndarray, s: int) -> Tuple[np.ndarray, np.ndarray]:
        """(G, b) of the columns in ``slots`` for rows ``s..N-1``; every entry
        is computed once (``fixed_dot``) and kept until its slot is reused."""
        G, bv, arr = self._G, self._b, self.store.array
        if s != self._gram_start:
            G.fill(np.nan)
            bv.fill(np.nan)
            self._gram_start = s
        if self.store.evicted:
            ev = np.array(self.store.evicted, dtype=np.int64)
            self.store.evicted.clear()
            G[ev, :] = np.nan
            G[:, ev] = np.nan
            bv[ev] = np.nan
        return _fill_gram(G, bv, arr, slots, self.y, int(s))

    # ------------------------------------------------------------ estimation
    def fit(self, terms: Sequence[Term], constraints="default") -> Tuple[np.ndarray, int]:
        """θ of a term set (LS, or CLS when constrained); returns (θ, start).

        ``constraints`` (None or 'steady-state') overrides the scorer's."""
        terms = tuple(terms)
        if constraints == "default":
            constraints = self.constraints
        ml = max((t.max_lag for t in terms), default=0)
        s = ml if self.start is None else self.start
        if s < ml:
            raise ValueError(f"start={s} is below the terms' largest lag {ml}")
        if s >= self.data.n:
            # no row to fit or score (the compiled columns are all 0 then: a
            # set would otherwise score a perfect 0)
            raise ValueError(f"record of {self.data.n} samples is too short for "
                             f"the terms' largest lag {ml} (start {s})")
        slots = np.array([self._reg_slot(t) for t in terms], dtype=np.int64)
        G, b = self._gram(slots, s)
        if not (np.all(np.isfinite(G)) and np.all(np.isfinite(b))):
            # an operator or Φ-column overflowed on this record: no LS fit
            # (and no numpy warning from scaling by an infinite norm)
            bad = [str(terms[i]) for i in np.flatnonzero(~np.isfinite(np.diag(G)))]
            raise EstimationError("the regressors' cross products are not finite"
                                  + (f" (columns {', '.join(bad)})" if bad else ""))
        if constraints is None:
            theta = gram_lstsq(G, b)[0]
            if self.estimator in OE_ESTIMATORS and any(t.output_factors for t in terms) \
                    and np.all(np.isfinite(theta)):
                theta = output_error_theta(self._output_error(terms, slots, s), theta)
            return theta, s
        cons = steady_state_constraints(terms, self.registry)
        theta, space = gram_lstsq(G, b, cons.S, cons.c)
        if not space.consistent:
            raise EstimationError("inconsistent steady-state constraints")
        return theta, s

    def _output_error(self, terms, slots, s) -> OutputErrorProblem:
        """The :class:`~narx.estimation.output_error.OutputErrorProblem` of ``terms``
        (regressor columns in store ``slots``) from row ``s``."""
        n = self.data.n
        Psi = self.store.array[slots, s:]
        plan = Plan.from_terms(terms, self.data.inputs, self.registry)
        idx = np.array([self._in_slot(t) for t in terms], dtype=np.int64)

        def windows(starts, length, write_from):
            return lambda theta: run_windows(plan, self.store.array, self.data.U, self.y,
                                             theta, starts, length, write_from,
                                             bound=self.bound, registry=self.registry,
                                             idx=idx)
        starts, length, _, _ = recursion_windows(self.fitness, n, s, self.window)
        return OutputErrorProblem(
            self.y, Psi, s,
            lambda x: regressor_matrix(terms, self.data, y=x, start=s,
                                       registry=self.registry)[0].T,
            windows(np.array([s], dtype=np.int64), n - s, 0),
            windows(starts, length, self.burn))

    # ------------------------------------------------------------ scoring
    def evaluate(self, terms: Sequence[Term]) -> Tuple[float, Optional[np.ndarray]]:
        """(fitness, θ); fitness is ``inf`` for a diverging or failed fit."""
        terms = tuple(terms)
        self.evaluations += 1
        if not terms:
            return float("inf"), None
        theta, s = self.fitted(terms)
        if theta is None:
            return float("inf"), None
        return self._simulate_mse(terms, theta, s), theta

    def fitted(self, terms: Sequence[Term], constraints="default"):
        """:meth:`fit` that does not raise: ``(θ, s)``, θ None when the fit
        failed or is not finite (and s None when it failed)."""
        try:
            theta, s = self.fit(terms, constraints)
        except (EstimationError, np.linalg.LinAlgError, ValueError):
            return None, None
        return (theta if np.all(np.isfinite(theta)) else None), s

    def score(self, terms: Sequence[Term]) -> float:
        return self.evaluate(terms)[0]

    def run_windows(self, terms, theta, starts, length: int, write_from: int = 0,
                    bound: Optional[float] = None):
        """:func:`narx.simulation.kernels.run_windows` of ``terms`` on this record, with
        the input parts from the column store; returns ``(out, diverged)``.
        ``bound`` defaults to the scorer's."""
        plan = Plan.from_terms(terms, self.data.inputs, self.registry)
        idx = np.array([self._in_slot(t) for t in terms], dtype=np.int64)
        return run_windows(plan, self.store.array, self.data.U, self.y, theta, starts,
                           length, write_from, bound=self.bound if bound is None else bound,
                           registry=self.registry, idx=idx)

    def simulated_mse(self, terms: Sequence[Term], theta, s: int) -> float:
        """The fitness MSE of ``terms`` with a given ``theta`` (e.g. a final
        QR fit) from row ``s``; ``inf`` for a diverging simulation."""
        return self._simulate_mse(tuple(terms), np.asarray(theta, dtype=np.float64), int(s))

    def _simulate_mse(self, terms, theta, s) -> float:
        n, y = self.data.n, self.y
        if self.burn:
            return self._burnt_mse(terms, theta, s)
        if self.fitness == "osa":
            idx = np.array([self._reg_slot(t) for t in terms], dtype=np.int64)
            mse = _osa_sse(self.store.array, idx, theta, y, s) / (n - s)
            return mse if np.isfinite(mse) else float("inf")
        if self.shooting is not None:            # window-major fast path
            mse = self.shooting.mse(terms, theta, s, self.bound, self.input_column)
            if mse is not None:
                return mse
        horizon = self.window if self.fitness == "ms" else self.k
        starts, length, wf, first = recursion_windows(self.fitness, n, s, horizon)
        if starts.size == 0:
            return float("inf")
        out, diverged = self.run_windows(terms, theta, starts, length, wf)
        if diverged:
            return float("inf")
        r = y[first:] - out[first:]
        if self.fitness == "ms":                 # the fast path's summation order
            return float(window_sse(r, self.window) / r.size)
        return float(fixed_dot(r, r) / r.size)

    def _burnt_mse(self, terms, theta, s) -> float:
        """MSE of the ``ms``/``freerun`` simulation without the first
        ``self.burn`` steps of each window, or with ``estimator='bj'`` its
        variance whitened by a noise model
        (:func:`narx.estimation.output_error.innovation_mse`); ``inf`` when it
        diverges."""
        starts, length, _, _ = recursion_windows(self.fitness, self.data.n, s, self.window)
        out, diverged = self.run_windows(terms, theta, starts, length, self.burn)
        if diverged:
            return float("inf")
        scored = np.isfinite(out)
        if not scored.any():
            return float("inf")
        if self.estimator == "bj":
            return innovation_mse(self.y - out, noise_order(length - self.burn))
        r = self.y[scored] - out[scored]
        return float(fixed_dot(r, r) / r.size)
