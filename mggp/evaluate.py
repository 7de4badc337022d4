"""Parallel evaluation of term sets: decode → LS/CLS → simulate → fitness.

Typical use::

    from mggp.evaluate import Evaluator
    ev = Evaluator(data, fitness="ms", window=100, start=16, n_jobs=2)
    fitnesses = ev(list_of_term_tuples)      # one value per term set, in order

Each worker process holds one :class:`narx.fitness.StructureScorer` per
record and settings (keyed by a content hash), so regressor columns and Gram
entries are computed once per worker and reused across generations. The
batch is cut into contiguous chunks in a fixed way and results come back in
order; since a term set's score is a pure function of the set and the data,
the search gives the same result for any number of workers or any backend.

Backends are joblib's: ``'loky'`` processes by default, ``'threading'``,
``'sequential'``, or ``'dask'`` for a ``dask.distributed`` cluster (give
``scheduler='tcp://host:8786'`` or an existing ``Client``).

The fitness minimised by the search is, per ``criterion``:

* ``'mse'``  the simulation MSE J;
* ``'bic'``  :math:`N\\ln J + p\\ln N` and ``'aic'`` :math:`N\\ln J + 2p`,
  with N the scored samples and p the number of terms, which penalise
  spurious terms for exact structure selection.
"""
from __future__ import annotations

import hashlib
import math
from typing import List, Optional, Sequence, Tuple

import numpy as np

from narx.data import Data
from narx.fitness import StructureScorer
from narx.phi import PhiRegistry
from narx.terms import Term

__all__ = ["Evaluator", "CRITERIA", "criterion_value"]

CRITERIA = ("mse", "bic", "aic")

_WORKER_SCORERS = {}          # per process: key -> StructureScorer


def criterion_value(mse: float, p: int, n: int, criterion: str) -> float:
    """Fitness to minimise from the simulation MSE of a p-term set."""
    if not math.isfinite(mse):
        return float("inf")
    if criterion == "mse":
        return float(mse)
    ln = math.log(max(mse, 1e-300))
    pen = p * math.log(n) if criterion == "bic" else 2.0 * p
    return n * ln + pen


def _scorer(key, data, settings, registry):
    sc = _WORKER_SCORERS.get(key)
    if sc is None:
        if len(_WORKER_SCORERS) > 8:
            _WORKER_SCORERS.clear()
        sc = StructureScorer(data, registry=registry, **settings)
        _WORKER_SCORERS[key] = sc
    return sc


def _score_chunk(key, data, settings, registry, criterion, chunk):
    sc = _scorer(key, data, settings, registry)
    n_scored = data.n - (sc.start or 0)
    out = []
    for terms in chunk:
        mse = sc.score(terms)
        out.append(criterion_value(mse, len(terms), n_scored, criterion))
    return out


class Evaluator:
    """Callable mapping a list of term sets to fitness values (in order).

    Parameters
    ----------
    data : Data
    fitness : {'pem', 'freerun', 'ksa', 'ms'}
    window, k : int
        Δm for ``ms``; horizon for ``ksa``.
    constraints : None or 'steady-state'
        CLS during the search (default LS).
    start : int
        Fixed first row for estimation and scoring (>= every set's lag).
    criterion : {'mse', 'bic', 'aic'}
    n_jobs : int
        Worker count (``-1``: all cores). Results do not depend on it.
    backend : str
        joblib backend: 'loky' (default), 'threading', 'sequential', 'dask'.
    scheduler : str or dask.distributed.Client, optional
        For the dask backend.
    """

    def __init__(self, data: Data, fitness: str = "ms", *, window: int = 100,
                 k: int = 10, constraints: Optional[str] = None, start: int = 0,
                 criterion: str = "mse", n_jobs: int = 1, backend: str = "loky",
                 scheduler=None, registry: Optional[PhiRegistry] = None):
        if criterion not in CRITERIA:
            raise ValueError(f"criterion must be one of {', '.join(CRITERIA)}, got {criterion!r}")
        self.data = data
        self.settings = dict(fitness=fitness, window=window, k=k,
                             constraints=constraints, start=start)
        StructureScorer(data, **self.settings)          # validate settings now
        self.criterion = criterion
        self.n_jobs = int(n_jobs)
        if self.n_jobs == 0 or self.n_jobs < -1:
            raise ValueError(f"n_jobs must be >= 1 or -1, got {n_jobs!r}")
        self.backend = backend
        self.scheduler = scheduler
        from narx.phi import default_registry
        self.registry = (registry or default_registry()).snapshot()
        h = hashlib.sha1()
        h.update(np.ascontiguousarray(data.U).tobytes())
        h.update(data.y.tobytes())
        h.update(repr(sorted(self.settings.items())).encode())
        self.key = h.hexdigest()
        self.evaluations = 0
        self._client = None
        self._parallel = None

    # ------------------------------------------------------------------
    def _workers(self) -> int:
        if self.backend == "sequential":
            return 1
        if self.n_jobs == -1:
            import os
            return os.cpu_count() or 1
        return self.n_jobs

    def _get_parallel(self):
        import joblib
        if self._parallel is None:
            if self.backend == "dask":
                self._client = _dask_client(self.scheduler)
            self._parallel = joblib.Parallel(n_jobs=self._workers(), backend=self.backend,
                                             return_as="list")
        return self._parallel

    def __call__(self, term_sets: Sequence[Tuple[Term, ...]]) -> List[float]:
        term_sets = [tuple(t) for t in term_sets]
        self.evaluations += len(term_sets)
        workers = self._workers()
        if workers <= 1 or len(term_sets) < 2 * workers:
            return _score_chunk(self.key, self.data, self.settings, self.registry,
                                self.criterion, term_sets)
        import joblib
        # fixed chunking: a few chunks per worker for balance
        n_chunks = min(len(term_sets), 4 * workers)
        bounds = np.linspace(0, len(term_sets), n_chunks + 1).astype(int)
        chunks = [term_sets[a:b] for a, b in zip(bounds[:-1], bounds[1:]) if b > a]
        par = self._get_parallel()
        parts = par(joblib.delayed(_score_chunk)(self.key, self.data, self.settings,
                                                 self.registry, self.criterion, c)
                    for c in chunks)
        return [v for part in parts for v in part]

    def close(self):
        self._parallel = None
        if self._client is not None and getattr(self, "_own_client", False):
            self._client.close()
        self._client = None


def _dask_client(scheduler):
    try:
        from dask.distributed import Client, get_client
    except ImportError:
        raise ValueError("backend 'dask' needs dask.distributed: "
                         "pip install 'mggp-narx[dask]'") from None
    if scheduler is None:
        try:
            return get_client()
        except ValueError:
            raise ValueError("backend 'dask' needs a scheduler address or a running "
                             "dask.distributed Client") from None
    if isinstance(scheduler, str):
        return Client(scheduler)
    return scheduler
