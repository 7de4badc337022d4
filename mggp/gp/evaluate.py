"""Parallel evaluation of term sets: decode → LS/CLS → simulate → fitness.

Typical use::

    from mggp.gp.evaluate import Evaluator
    ev = Evaluator(data, fitness="ms", window=100, start=16, n_jobs=2)
    fitnesses = ev(list_of_term_tuples)      # one value per term set, in order
    ev.close()

    # the same on a dask.distributed cluster (pip install 'mggp-narx[dask]')
    ev = Evaluator(data, fitness="ms", backend="dask", scheduler="tcp://10.0.0.5:8786")

Each worker keeps a :class:`narx.estimation.fitness.StructureScorer` per record and
settings (keyed by a content hash), so regressor columns and Gram entries
are computed once per worker and reused across generations; a worker
running several threads keeps one scorer per concurrently busy thread (a
scorer is never shared by two threads). The batch is cut into contiguous
chunks in a fixed way and results come back in order; since a term set's
score is a pure function of the set and the data, the search gives the same
result for any number of workers or any backend.

Backends are joblib's: ``'loky'`` processes by default, ``'threading'``,
``'sequential'``, or ``'dask'`` for a ``dask.distributed`` cluster through
joblib's Dask backend (give ``scheduler='tcp://host:8786'`` or a
``Client``; the record is broadcast to the workers once per run, and with
the dask backend ``n_jobs`` is ignored: the cluster's threads are used).
The Φ-function registry is shipped with every chunk as a snapshot, so
user plug-ins registered in the calling process reach the workers.

Fault tolerance: when a worker process dies while scoring (joblib's
``TerminatedWorkerError``, a lost Dask worker), the chunks not yet returned
are scored again, up to ``max_retries`` times per batch; then
:class:`WorkerLostError` says so. Chunks already returned are kept, and the
scores do not depend on which worker computed them, so a run that lost a
worker ends exactly like one that did not. Each fault is recorded in
``Evaluator.faults``.

The fitness minimised by the search is, per ``criterion``:

* ``'mse'``  the simulation MSE J;
* ``'bic'``  :math:`N\\ln J + p\\ln N` and ``'aic'`` :math:`N\\ln J + 2p`,
  with N the scored samples and p the number of terms, which penalise
  spurious terms for exact structure selection.
"""
from __future__ import annotations

import hashlib
import math
import os
import threading
from collections import OrderedDict
from typing import List, Optional, Sequence, Tuple

import numpy as np

from narx.records.data import Data
from narx.estimation.fitness import StructureScorer
from narx.language.phi import PhiRegistry, default_registry
from narx.language.terms import Term

from ..exceptions import WorkerLostError

__all__ = ["Evaluator", "CRITERIA", "criterion_value", "WorkerLostError",
           "worker_fault_types"]

CRITERIA = ("mse", "bic", "aic")
BACKENDS = ("loky", "threading", "sequential", "dask")

#: per process: key -> idle scorers (one is checked out per busy thread)
_IDLE: "OrderedDict[str, list]" = OrderedDict()
_LOCK = threading.Lock()
#: runs whose idle scorers a process keeps. A scorer holds ~300 MB of
#: column stores written at creation; keeping only the latest run's means a
#: worker that moves on to a new run frees the old stores, its resident size
#: does not grow, and loky does not restart it (it restarts a worker that
#: grew by 300 MB since its first task)
_MAX_KEYS = 1


def criterion_value(mse: float, p: int, n: int, criterion: str) -> float:
    """Fitness to minimise from the simulation MSE of a p-term set."""
    if not math.isfinite(mse):
        return float("inf")
    if criterion == "mse":
        return float(mse)
    ln = math.log(max(mse, 1e-300))
    pen = p * math.log(n) if criterion == "bic" else 2.0 * p
    return n * ln + pen


def worker_fault_types() -> tuple:
    """Exception classes that mean "a worker was lost", not "a bad score".

    joblib/loky's ``TerminatedWorkerError`` and broken pools, and, when
    ``dask.distributed`` is installed, ``KilledWorker``, a closed comm and
    a cancelled future (a worker holding the scattered data vanished).
    """
    from concurrent.futures import BrokenExecutor, CancelledError
    types = [BrokenExecutor, CancelledError]
    try:
        from joblib.externals.loky.process_executor import TerminatedWorkerError
        types.append(TerminatedWorkerError)
    except ImportError:                      # pragma: no cover
        pass
    try:
        from distributed.comm.core import CommClosedError
        from distributed.scheduler import KilledWorker
        types += [KilledWorker, CommClosedError]
        from distributed.client import FutureCancelledError
        types.append(FutureCancelledError)
    except ImportError:
        pass
    return tuple(types)


def _checkout(key, data, settings, registry) -> StructureScorer:
    with _LOCK:
        idle = _IDLE.get(key)
        if idle:
            _IDLE.move_to_end(key)
            return idle.pop()
    # written up front: loky takes a worker's size after its first task and
    # would read stores that fill later as a leak (and restart the worker)
    return StructureScorer(data, registry=registry, prefault=True, **settings)


def _checkin(key, scorer) -> None:
    with _LOCK:
        _IDLE.setdefault(key, []).append(scorer)
        _IDLE.move_to_end(key)
        while len(_IDLE) > _MAX_KEYS:
            _IDLE.popitem(last=False)


def _drop(key) -> None:
    with _LOCK:
        _IDLE.pop(key, None)


def _score_chunk(key, data, settings, registry, criterion, chunk):
    sc = _checkout(key, data, settings, registry)
    try:
        n_scored = data.n - (sc.start or 0)
        return [criterion_value(sc.score(terms), len(terms), n_scored, criterion)
                for terms in chunk]
    finally:
        _checkin(key, sc)


#: loky restarts a worker whose resident size grew by this much after its
#: first task (its "memory leak" guard)
_LOKY_GUARD = 300 * 2**20


def _store_bytes(n: int) -> int:
    """Bytes a worker's scorer allocates for a record of ``n`` samples (the
    column store, at least 64 columns, and the window-major store)."""
    from narx.estimation.fitness import SCORER_BUDGET, ColumnStore
    from narx.simulation.ms_kernel import BUDGET
    return ColumnStore.slots_for(n, SCORER_BUDGET) * 8 * n + BUDGET


#: store bytes of the largest record loky's current workers have scored
_LOKY_SEEN = {"bytes": 0}


def _fit_loky_workers(need: int) -> None:
    """Shut down loky's reusable workers when this record's stores outgrow
    those they have held by half the guard, so the next workers take their
    reference size with these stores. Workers kept from a fit on a shorter
    record would see them as growth past the guard and be restarted
    mid-run (a warning, and their caches lost)."""
    if need - _LOKY_SEEN["bytes"] <= _LOKY_GUARD // 2:
        _LOKY_SEEN["bytes"] = max(_LOKY_SEEN["bytes"], need)
        return
    try:
        from joblib.externals.loky import reusable_executor
        ex = getattr(reusable_executor, "_executor", None)
        if ex is not None:
            ex.shutdown(wait=True)
    except ImportError:                        # pragma: no cover
        pass
    _LOKY_SEEN["bytes"] = need


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
    start : int, optional
        Fixed first row for estimation and scoring (>= every set's lag;
        ``MGGPRegressor`` fixes it from ``max_height``, so all structures
        are scored on the same rows). Default: each set's own largest lag.
    estimator : {'ls', 'oe', 'bj'}
        θ of each set (:class:`narx.estimation.fitness.StructureScorer`).
    criterion : {'mse', 'bic', 'aic'}
    n_jobs : int
        Worker count (``-1``: all cores). Results do not depend on it.
        Ignored by the dask backend (the cluster's threads are used).
    backend : {'loky', 'threading', 'sequential', 'dask'}
    scheduler : str or dask.distributed.Client, optional
        For the dask backend: a scheduler address (a client is opened and
        closed by :meth:`close`) or a client; default the current client.
    registry : PhiRegistry, optional
        Φ-functions (default: the process-wide registry); a snapshot is
        taken now and shipped to the workers.
    max_retries : int
        Re-scorings of a batch after lost workers before giving up.
    scorer : StructureScorer, optional
        A scorer of ``data`` with these settings, used by this process for
        the batches it scores itself (no second column store is built).

    Attributes
    ----------
    faults : list of str
        One line per lost-worker event survived (exception type and text).
    """

    def __init__(self, data: Data, fitness: str = "ms", *, window: int = 100,
                 k: int = 10, constraints: Optional[str] = None,
                 start: Optional[int] = None, estimator: str = "ls",
                 criterion: str = "mse", n_jobs: int = 1, backend: str = "loky",
                 scheduler=None, registry: Optional[PhiRegistry] = None,
                 max_retries: int = 3, scorer: Optional[StructureScorer] = None):
        if criterion not in CRITERIA:
            raise ValueError(f"criterion must be one of {', '.join(CRITERIA)}, got {criterion!r}")
        if backend not in BACKENDS:
            raise ValueError(f"backend must be one of {', '.join(BACKENDS)}, got {backend!r}")
        self.data = data
        self.settings = dict(fitness=fitness, window=window, k=k,
                             constraints=constraints, start=start, estimator=estimator)
        if scorer is None:
            StructureScorer(data, **self.settings)       # validate settings now
        self.criterion = criterion
        self.n_jobs = int(n_jobs)
        if self.n_jobs == 0 or self.n_jobs < -1:
            raise ValueError(f"n_jobs must be >= 1 or -1, got {n_jobs!r}")
        if not isinstance(max_retries, int) or max_retries < 0:
            raise ValueError(f"max_retries must be an integer >= 0, got {max_retries!r}")
        self.max_retries = max_retries
        self.backend = backend
        self.scheduler = scheduler
        self.registry = (registry or default_registry()).snapshot()
        h = hashlib.sha1()
        h.update(np.ascontiguousarray(data.U).tobytes())
        h.update(data.y.tobytes())
        h.update(repr((data.inputs, data.output)).encode())
        h.update(repr(sorted(self.settings.items())).encode())
        # a re-registered plug-in must not reuse columns of the old function
        h.update(repr([(f.name, f.arity, id(f.func))
                       for f in self.registry.user_functions()]).encode())
        self.key = h.hexdigest()
        if scorer is not None:
            _checkin(self.key, scorer)          # this process scores with it
        self.evaluations = 0
        self.faults: List[str] = []
        self._client = None
        self._own_client = False
        self._parallel = None

    # ------------------------------------------------------------------
    def _workers(self) -> int:
        if self.backend == "sequential":
            return 1
        if self.backend == "dask":
            client = self._get_client()
            return max(1, sum(client.nthreads().values()))
        if self.n_jobs == -1:
            return os.cpu_count() or 1
        return self.n_jobs

    def _get_client(self):
        if self._client is None:
            self._client, self._own_client = _dask_client(self.scheduler)
        return self._client

    def _get_parallel(self):
        import joblib
        if self._parallel is None:
            if self.backend == "dask":
                # the record is broadcast to every worker once, not sent with
                # every chunk; the Parallel keeps that backend (and the
                # scattered copies) until a fault or close() drops it
                with joblib.parallel_config(backend="dask", client=self._get_client(),
                                            scatter=[self.data]):
                    self._parallel = joblib.Parallel(n_jobs=-1, return_as="generator")
            else:
                if self.backend == "loky":
                    _fit_loky_workers(_store_bytes(self.data.n))
                # max_nbytes=None: the record is pickled with a chunk, not
                # memory-mapped through /dev/shm, whose files loky's resource
                # tracker miscounts (KeyError tracebacks at exit for records
                # over ~150,000 samples; joblib issue 1243)
                self._parallel = joblib.Parallel(n_jobs=self._workers(),
                                                 backend=self.backend,
                                                 return_as="generator", max_nbytes=None)
        return self._parallel

    def _chunks(self, term_sets, workers):
        # fixed chunking: a few chunks per worker for balance
        n_chunks = min(len(term_sets), 4 * workers)
        bounds = np.linspace(0, len(term_sets), n_chunks + 1).astype(int)
        return [term_sets[a:b] for a, b in zip(bounds[:-1], bounds[1:]) if b > a]

    def __call__(self, term_sets: Sequence[Tuple[Term, ...]]) -> List[float]:
        term_sets = [tuple(t) for t in term_sets]
        self.evaluations += len(term_sets)
        workers = self._workers()
        if self.backend == "dask":
            local = len(term_sets) < 2          # a cluster of one thread is still used
        else:
            local = workers <= 1 or len(term_sets) < 2 * workers
        if local:
            return _score_chunk(self.key, self.data, self.settings, self.registry,
                                self.criterion, term_sets)
        chunks = self._chunks(term_sets, workers)
        parts = self._run_chunks(chunks)
        return [v for part in parts for v in part]

    def _run_chunks(self, chunks):
        """Score chunks in parallel; re-score those lost with a worker."""
        import joblib
        faults = worker_fault_types()
        parts = [None] * len(chunks)
        failures = 0
        while True:
            todo = [i for i, p in enumerate(parts) if p is None]
            if not todo:
                return parts
            try:
                gen = self._get_parallel()(
                    joblib.delayed(_score_chunk)(self.key, self.data, self.settings,
                                                 self.registry, self.criterion,
                                                 chunks[i]) for i in todo)
                for i, part in zip(todo, gen):
                    parts[i] = part
            except faults as exc:
                failures += 1
                text = _describe(exc)
                self._parallel = None            # a fresh pool / backend next time
                if failures > self.max_retries:
                    n = sum(len(chunks[i]) for i in todo)
                    raise WorkerLostError(
                        f"evaluation failed: a worker was lost {failures} times while "
                        f"scoring a batch ({n} structures left; last: {text}); resume "
                        f"from the last checkpoint, or try --jobs 1 / --backend "
                        f"sequential to find a crashing Φ-function") from None
                self.faults.append(text)

    def close(self):
        """Drop this run's scorer in this process and an owned dask client."""
        self._parallel = None
        _drop(self.key)
        if self._client is not None and self._own_client:
            self._client.close()
        self._client, self._own_client = None, False

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _describe(exc) -> str:
    try:
        msg = str(exc)
    except Exception:                        # a broken __str__ must not hide the fault
        msg = repr(exc.args)
    return " ".join(f"{type(exc).__name__}: {msg}".split())[:300]


def _dask_client(scheduler):
    """(client, owned): a client for ``scheduler`` (address or Client)."""
    try:
        from dask.distributed import Client, get_client
    except ImportError:
        raise ValueError("backend 'dask' needs dask.distributed: "
                         "pip install 'mggp-narx[dask]'") from None
    if scheduler is None:
        try:
            return get_client(), False
        except ValueError:
            raise ValueError("backend 'dask' needs a scheduler address or a running "
                             "dask.distributed Client") from None
    if isinstance(scheduler, str):
        try:
            return Client(scheduler, set_as_default=False), True
        except (OSError, TimeoutError) as exc:
            raise ValueError(f"--scheduler {scheduler}: cannot connect to the dask "
                             f"scheduler ({type(exc).__name__}: "
                             f"{' '.join(str(exc).split())[:200]})") from None
    return scheduler, False
