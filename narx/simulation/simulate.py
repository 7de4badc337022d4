"""Simulation of NARX models: one-step-ahead, free run, k-steps-ahead, shooting.

Typical use::

    from narx.simulation.simulate import simulate
    r = simulate(terms, theta, data, mode="freerun")
    r.y_hat, r.valid, r.diverged, r.mse

The modes are one table, :data:`MODE_TABLE`: a row per mode gives its
name, the aliases also accepted and what it simulates. The same names
serve as fitness names (:class:`narx.estimation.fitness.StructureScorer`); the alias
``pem`` (prediction-error method) is the usual name of the one-step-ahead
fitness, as in ``mggp fit --fitness pem``:

=============  ======================  ==========================================
mode           aliases                 what is simulated
=============  ======================  ==========================================
``osa``        ``pem``, ``one-step``   every regressor from measured data
``freerun``    ``free-run``, ``free``  the whole record recursively from the
                                       first ``maxlag`` samples
``ksa``        ``k-steps``             free run of ``k`` steps from every
                                       sample; ŷ_k is the k-step prediction
                                       made from measured data up to k − k_h
``ms``         ``shooting``            multiple shooting: windows of Δm
                                       samples, each a free run from the
                                       measured samples before it
=============  ======================  ==========================================

``ksa`` with k = 1 equals ``osa``; ``ms`` with one window equals ``freerun``.
A record that starts in motion leaves the memory operators' states unknown;
``history`` names the path the signals arrived by
(:data:`narx.language.memory.HISTORIES`), and ``history='estimate'`` picks
the one whose free run fits the record's first samples best
(:func:`estimate_history`).
Noise terms ``e[k-j]`` are zero in every mode (their expectation). A
simulation that diverges ends quietly with ``diverged=True`` and
``mse = inf``; no warnings are emitted.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np

from ..records.data import Data
from ..exceptions import DataError
from .kernels import Plan, run_windows
from ..language.phi import PhiRegistry
from ..language.terms import Term

__all__ = ["SimulationResult", "simulate", "MODES", "MODE_TABLE", "mode_name",
           "window_starts", "recursion_windows", "estimate_history", "HISTORY_HEAD"]

#: :func:`estimate_history` compares the histories on this share of the
#: record's first samples (at least ten times the model's largest lag)
HISTORY_HEAD = 0.2

#: the simulation modes, one row each: (name, aliases also accepted, what is
#: simulated); the module docstring shows it as a table
MODE_TABLE = (
    ("osa", ("pem", "one-step"), "one-step-ahead: every regressor from measured data"),
    ("freerun", ("free-run", "free"), "free run of the whole record from the first "
                                      "maxlag samples"),
    ("ksa", ("k-steps",), "k-steps-ahead: a free run of k steps from every sample"),
    ("ms", ("shooting",), "multiple shooting: windows of Δm samples, each a free run "
                          "from the measured samples before it"),
)
#: the canonical mode names
MODES = tuple(name for name, _, _ in MODE_TABLE)
_ALIASES = {alias: name for name, aliases, _ in MODE_TABLE for alias in aliases}


def mode_name(mode, what: str = "mode") -> str:
    """The canonical name of a mode given by its name or an alias.

    Raises ``ValueError`` naming ``what`` (e.g. ``'fitness'``), the names
    and aliases accepted, and the value given.
    """
    name = _ALIASES.get(mode, mode) if isinstance(mode, str) else None
    if name not in MODES:
        aliases = ", ".join(f"{' and '.join(a)} for {n}" for n, a, _ in MODE_TABLE)
        raise ValueError(f"{what} must be one of {', '.join(MODES)} (aliases: {aliases}), "
                         f"got {mode!r}")
    return name


@dataclass(frozen=True)
class SimulationResult:
    """Outcome of a simulation.

    Attributes
    ----------
    y_hat : ndarray (N,)
        Simulated/predicted output; initial conditions copied from the
        measured output; NaN where a mode makes no prediction.
    y : ndarray (N,) or None
        Measured output, when known.
    valid : ndarray of bool (N,)
        Samples where ``y_hat`` is a prediction (errors are computed there).
    mode : str
    diverged : bool
    horizon : int or None   (``ksa``'s k, ``ms``'s window Δm)
    history : str
        The path that started the memory operators
        (:data:`narx.language.memory.HISTORIES`).
    """

    y_hat: np.ndarray
    y: Optional[np.ndarray]
    valid: np.ndarray
    mode: str
    diverged: bool = False
    horizon: Optional[int] = None
    start: int = 0
    info: dict = field(default_factory=dict)
    history: str = "rest"

    @property
    def residual(self) -> np.ndarray:
        if self.y is None:
            raise DataError("no measured output to compare with")
        return (self.y - self.y_hat)[self.valid]

    @property
    def mse(self) -> float:
        """Mean squared error over valid samples (``inf`` if diverged)."""
        if self.diverged:
            return float("inf")
        r = self.residual
        return float(np.dot(r, r) / r.size) if r.size else float("inf")

    @property
    def rmse(self) -> float:
        return float(np.sqrt(self.mse))

    @property
    def mape(self) -> float:
        """Range-normalised MAPE in %: ``100 mean|y - ŷ| / (max y - min y)``."""
        from .metrics import mape
        if self.diverged:
            return float("inf")
        return mape(self.y[self.valid], self.y_hat[self.valid])


def window_starts(n: int, maxlag: int, window: int) -> np.ndarray:
    """Starts of the multiple-shooting windows of ``window`` samples."""
    return np.arange(maxlag, n, window, dtype=np.int64)


def recursion_windows(mode: str, n: int, start: int, horizon: Optional[int] = None):
    """Windows of a recursive mode: ``(starts, length, write_from, first)``.

    ``first`` is the first sample that receives a prediction. ``horizon`` is
    Δm for ``'ms'`` and k for ``'ksa'`` (ignored for ``'freerun'``).
    """
    if mode == "freerun":
        return np.array([start], dtype=np.int64), n - start, 0, start
    if mode == "ms":
        return window_starts(n, start, horizon), horizon, 0, start
    return (np.arange(start, n - horizon + 1, dtype=np.int64), horizon, horizon - 1,
            start + horizon - 1)


def simulate(terms: Sequence[Term], theta, data: Data, mode: str = "freerun", *,
             k: Optional[int] = None, window: Optional[int] = None,
             y0=None, plan: Optional[Plan] = None, P=None,
             registry: Optional[PhiRegistry] = None,
             force_python: bool = False, history: Optional[str] = None) -> SimulationResult:
    """Simulate a model in one of the four modes.

    Parameters
    ----------
    terms, theta : model terms and parameters (same length).
    data : Data
        Inputs, and the measured output (needed except for ``freerun`` with
        ``y0``).
    mode : str
        A name or an alias of :data:`MODE_TABLE` ('osa', 'freerun', 'ksa', 'ms').
    k : int
        Horizon for ``ksa`` (>= 1).
    window : int
        Window Δm for ``ms`` (>= 1).
    y0 : array_like, optional
        Initial conditions (the first ``maxlag`` outputs) for ``freerun``
        when ``data`` has no output.
    plan, P : optional precomputed :class:`Plan` and input parts.
    history : str, optional
        The path that starts the memory operators: a row of
        :data:`narx.language.memory.HISTORIES`, or ``'estimate'``
        (:func:`estimate_history`, on the measured output); default the
        record's own (``data.history``, 'rest' unless set).
    """
    mode = mode_name(mode)
    for name, v, used in (("k", k, "ksa"), ("window", window, "ms")):
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, np.integer))):
            raise ValueError(f"{name} must be an integer, got {v!r}")
        if v is not None and mode != used:
            raise ValueError(f"{name}={v} applies to mode {used!r} only, not to {mode!r}")
    if history == "estimate":
        history, _, runs = _history_runs(terms, theta, data, registry)
        if mode == "freerun" and history in runs and y0 is None and P is None \
                and not force_python:
            return runs[history]           # the estimate's own run of that history
    if history is not None and history != data.history:
        if P is not None:
            raise ValueError("P was built for the record's own history; pass history=None")
        data = data.with_history(history)
    terms = tuple(terms)
    theta = np.asarray(theta, dtype=np.float64).ravel()
    if theta.shape[0] != len(terms):
        raise ValueError(f"theta has {theta.shape[0]} values for {len(terms)} terms")
    if not np.all(np.isfinite(theta)):
        raise ValueError("theta has non-finite values")
    plan = plan or Plan.from_terms(terms, data.inputs, registry)
    ml, n = plan.maxlag, data.n
    if n <= ml:
        raise DataError(f"record of {n} samples is too short for the model's "
                        f"largest lag {ml}")
    y = data.y
    if y is None:
        if mode != "freerun" or y0 is None:
            raise DataError(f"mode {mode!r} needs the measured output "
                            f"{data.output!r}" + (" (or y0)" if mode == "freerun" else ""))
        y0 = np.asarray(y0, dtype=float).ravel()
        if y0.shape[0] < ml or not np.all(np.isfinite(y0[:ml])):
            raise DataError(f"y0 must hold {ml} finite initial outputs, got {y0.shape[0]}")
        y_meas = np.zeros(n)
        y_meas[:ml] = y0[:ml]
        bound = 1e300            # no measured scale: only non-finite output diverges
    else:
        y_meas = y
        bound = None
    if P is None:
        P = plan.input_parts(data, registry)
    valid = np.zeros(n, dtype=bool)
    horizon = None
    if mode == "osa":
        from ..records.regressors import term_column
        cols = [np.zeros(n) if plan.noise_terms[i] else
                term_column(t, data, y_meas, None, registry)
                for i, t in enumerate(terms)]
        y_hat = np.full(n, np.nan)
        with np.errstate(all="ignore"):
            y_hat[ml:] = np.column_stack(cols)[ml:] @ theta if cols else 0.0
        diverged = not np.all(np.isfinite(y_hat[ml:]))
        valid[ml:] = True
    else:
        if mode == "ms":
            if window is None or int(window) < 1:
                raise ValueError(f"window (Δm) must be an integer >= 1 for mode 'ms', got {window!r}")
            horizon = int(window)
        elif mode == "ksa":
            if k is None or int(k) < 1:
                raise ValueError(f"k must be an integer >= 1 for mode 'ksa', got {k!r}")
            horizon = int(k)
        starts, length, write_from, first = recursion_windows(mode, n, ml, horizon)
        if starts.size == 0:
            raise DataError(f"record of {n} samples is too short for k={horizon} "
                            f"with largest lag {ml}")
        valid[first:] = True
        y_hat, diverged = run_windows(plan, P, data.U, y_meas, theta, starts, length,
                                      write_from, bound=bound, registry=registry,
                                      force_python=force_python, history=data.history)
    y_hat[:ml] = y_meas[:ml]
    return SimulationResult(y_hat, y, valid, mode, bool(diverged), horizon, ml,
                            history=data.history)


def estimate_history(terms: Sequence[Term], theta, data: Data, *,
                     registry: Optional[PhiRegistry] = None):
    r"""The history whose free run fits the record's first samples best.

    Each row :math:`h` of :data:`narx.language.memory.HISTORIES` starts the
    model's memory operators (:func:`narx.language.memory.history_prefix`),
    and the free run from the record's first ``maxlag`` samples is scored
    on its head, the first :math:`n_h = \max(\lceil` :data:`HISTORY_HEAD`
    :math:`\cdot N\rceil, 10\,(\text{maxlag} + 1))` samples:

    .. math::  \hat h = \arg\min_h \sum_{k=\text{maxlag}}^{n_h - 1}
               (y_k - \hat y_k^{(h)})^2 ,

    ties (and a model without operators, or a record without its output)
    going to 'rest'. This is the initial-state estimate of a free run
    ([1]_, ch. 16.6), restricted to three physical paths instead of a free
    state vector.

    Returns
    -------
    history : str
    head_rmse : dict
        ``{history: free-run RMSE on the head}`` (empty when not compared).

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999.
    """
    best, scores, _ = _history_runs(terms, theta, data, registry)
    return best, scores


def _history_runs(terms, theta, data: Data, registry=None):
    """:func:`estimate_history`'s ``(history, head_rmse, runs)``, ``runs``
    the free run of each history compared (empty when none is)."""
    from ..language.memory import HISTORIES
    terms = tuple(terms)
    if data.y is None or not any(t.operator_factors for t in terms):
        return "rest", {}, {}
    plan = Plan.from_terms(terms, data.inputs, registry)
    head = min(data.n, max(int(np.ceil(HISTORY_HEAD * data.n)), 10 * (plan.maxlag + 1)))
    if head <= plan.maxlag:
        return "rest", {}, {}
    scores, runs = {}, {}
    for h in HISTORIES:            # whole runs: a history's path spans the record's range
        runs[h] = r = simulate(terms, theta, data, "freerun", plan=plan, registry=registry,
                               history=h)
        e = r.y[plan.maxlag:head] - r.y_hat[plan.maxlag:head]
        scores[h] = float("inf") if r.diverged else float(np.sqrt(np.mean(e * e)))
    best = min(HISTORIES, key=lambda h: (scores[h], h != "rest"))
    return best, scores, runs
