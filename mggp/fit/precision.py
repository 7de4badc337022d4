"""Did the search's fast least squares lose precision on these data?

Typical use (``MGGPRegressor.fit`` does it for its result)::

    from mggp.fit.precision import search_precision
    check = search_precision(scorer, terms, model.theta)
    check.search_mse, check.refit_mse, check.refit_worse

The structure search fits θ from the normal equations ΨᵀΨ θ = Ψᵀy, whose
condition number is the square of Ψ's [1]_: every Gram entry is computed
once and reused, which is what makes a search of 10⁵ structures fast. On
data whose columns are nearly collinear, most often because an offset
dominates a signal (y = 10⁵ + a few units: every output lag is nearly the
same column), the normal equations lose the digits that the final QR fit
keeps, the search's fitness of a structure is worse than its QR refit's, and
the search is misled (:func:`offsets` names such signals before a search).
The other way round, the exact LS θ of nearly collinear terms may carry
large cancelling coefficients that the search's rank-truncated solve did
not, and simulate far worse than what the search scored. This module
measures both on the chosen structure: its fitness with the search's θ and
with the QR θ of the returned model, on the same rows and simulation.

References
----------
.. [1] Golub, G. H., Van Loan, C. F., *Matrix Computations*, 4th ed., §5.3.7
   (normal equations versus QR), Johns Hopkins, 2013.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .choices import HEIGHT, error_floor
from ..exceptions import SearchPrecisionWarning

__all__ = ["SearchPrecisionWarning", "PrecisionCheck", "search_precision", "offsets",
           "offset_message", "horizon_message", "dead_time_message", "saturation",
           "saturation_message", "data_warnings"]

#: the QR refit scoring this many times better than the search's own fit
#: counts as lost precision
RATIO = 1.25


@dataclass(frozen=True)
class PrecisionCheck:
    """The chosen structure's fitness (MSE) with the search's θ and with
    the QR refit's θ.

    ``refit_worse``: the exact LS θ of nearly collinear terms has large
    cancelling coefficients that the search's rank-truncated normal
    equations did not have, and simulates worse (or diverges);
    ``refit_better``: the search's fits were imprecise, so it ranked
    structures on errors it did not measure well.
    """
    search_mse: float
    refit_mse: float
    #: MSEs below this are rounding (exact data), never compared: the square
    #: of :func:`mggp.fit.choices.error_floor`
    floor: float = 0.0
    #: the search's θ of the structure (None if its fit failed)
    search_theta: Optional[np.ndarray] = None

    @property
    def refit_worse(self) -> bool:
        s, r = self.search_mse, self.refit_mse
        return bool(np.isfinite(s) and (not np.isfinite(r) or r > max(RATIO * s, self.floor)))

    @property
    def refit_better(self) -> bool:
        s, r = self.search_mse, self.refit_mse
        return bool(np.isfinite(r) and (not np.isfinite(s) or s > max(RATIO * r, self.floor)))


def offsets(data, factor: float = 10.0) -> list:
    """``(name, mean, std)`` of the signals whose mean exceeds ``factor``
    times their standard deviation (an offset that dominates the signal)."""
    out = []
    for name, x in [(n, data.input(n)) for n in data.inputs] + [(data.output, data.y)]:
        m, s = float(np.mean(x)), float(np.std(x))
        if abs(m) > factor * s:
            out.append((name, m, s))
    return out


def offset_message(data) -> str:
    """A sentence naming the signals an offset dominates ('' if none)."""
    off = offsets(data)
    if not off:
        return ""
    return ("an offset dominates " + ", ".join(f"{n} (mean {m:.4g}, standard deviation "
                                               f"{sd:.3g})" for n, m, sd in off)
            + ": the search's least squares lose precision as an offset grows (its "
              "normal equations square the regressors' condition number); if its models "
              "are poor, subtract the offset (e.g. the mean or the first sample) before "
              "fitting")


#: an output value held at an extreme of the record on at least this share
#: of the samples (and :data:`HELD_MIN` of them) ...
HELD_SHARE = 0.005
HELD_MIN = 5
#: ... at least this many times as often as any other value of the output
HELD_RATIO = 3
#: ... in a run of at least this many consecutive samples
HELD_RUN = 3


def saturation(y, inputs=()) -> list:
    """``(side, value, count, longest run)`` of each extreme of ``y`` at which
    it sits far more often than at any other value while ``inputs`` (arrays
    like ``y``) move: a sensor or a system that saturates writes one value
    there. The extreme counts when it is held on at least
    :data:`HELD_SHARE` of the samples (and :data:`HELD_MIN`),
    :data:`HELD_RATIO` times as often as any other value (a quantised
    output repeats every level: its extremes are not singled out) and in a
    run of :data:`HELD_RUN` samples or more; runs of two samples or more
    during which no input changes (a held input the output settles at) do
    not count."""
    y = np.asarray(y, dtype=float)
    U = [np.asarray(x, dtype=float) for x in inputs]
    out = []
    for side, value in (("largest", float(np.max(y))), ("smallest", float(np.min(y)))):
        at = y == value
        if at.all():
            continue
        d = np.diff(np.r_[0, at.astype(np.int8), 0])
        runs = [(a, b) for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1))
                if b - a < 2 or not U or any(np.ptp(x[a:b]) > 0 for x in U)]
        count = sum(b - a for a, b in runs)
        if not runs or count < max(HELD_MIN, HELD_SHARE * y.size):
            continue
        others = int(np.unique(y[~at], return_counts=True)[1].max())
        run = int(max(b - a for a, b in runs))
        if count >= HELD_RATIO * others and run >= HELD_RUN:
            out.append((side, value, count, run))
    return out


def saturation_message(data) -> str:
    """A sentence when the output sits at an extreme value far more often
    than at any other (:func:`saturation`); '' otherwise."""
    held = saturation(data.y, [data.input(v) for v in data.inputs])
    if not held:
        return ""
    n = len(data.y)
    parts = [f"its {side} value, {value:.6g}, on {count} of {n} samples "
             f"({100 * count / n:.2g} %; runs of up to {run})"
             for side, value, count, run in held]
    return (f"{data.output} sits at " + " and at ".join(parts) + f", over {HELD_RATIO} "
            "times as often as at any other value: a sensor or the system saturates there. "
            "A polynomial model can only imitate a saturation with its other terms; if the "
            "sensor clipped, those samples do not show what the system did (fit a part of "
            "the record without them)")


def search_precision(scorer, terms, theta, start: Optional[int] = None) -> PrecisionCheck:
    """Fitness of ``terms`` with the search's θ and with ``theta`` (the
    refit), on the same scorer and the same simulation, from row ``start``
    (the refit model's first row; default the search's). The search fits
    every structure from the row its deepest reachable lag needs, so on a
    short record the refit model, which starts at its own largest lag,
    also simulates rows the search's θ was never fitted on: both are
    compared on those rows too."""
    terms = tuple(terms)
    theta_s, s = scorer.fitted(terms)
    if s is None:
        return PrecisionCheck(float("inf"), float("inf"))
    s = s if start is None else int(start)
    search = float("inf") if theta_s is None else scorer.simulated_mse(terms, theta_s, s)
    try:
        refit = scorer.simulated_mse(terms, np.asarray(theta, dtype=float), s)
    except (ValueError, np.linalg.LinAlgError):
        refit = float("inf")
    floor = error_floor(scorer.data) ** 2            # rounding of noise-free data
    return PrecisionCheck(float(search), float(refit), floor, theta_s)


def horizon_message(y, horizon: int, what: str, limit: float = 0.99) -> str:
    """A sentence when a simulation horizon (the MS window Δm or the ksa
    ``k``) sees little of the output's motion: the output's autocorrelation
    at that lag is above ``limit`` (e.g. Δm = 100 samples at 10 kHz is 10 ms),
    so the fitness is close to the one-step error; '' otherwise."""
    y = np.asarray(y, dtype=float)
    n = y.size
    if horizon >= n - 1 or n < 3:
        return ""
    d = y - y.mean()
    den = float(d @ d)
    if den == 0.0:
        return ""
    r = float(d[:-horizon] @ d[horizon:]) / den
    if r <= limit:
        return ""
    return (f"{what} = {horizon} samples covers little of the output's motion (its "
            f"autocorrelation at that lag is {r:.4f}): the fitness is close to the "
            f"one-step error and may choose models that drift in free run; a horizon "
            f"of several of the output's time constants is usual (try a longer one)")


def dead_time_message(data, reach: int, max_height: int, max_lag=None, scans=None) -> str:
    """A sentence for each input of :func:`narx.records.deadtime.late_inputs` (``reach``: what
    ``max_height`` reaches, 1 + 3 × height, capped by ``max_lag``), saying
    which ``max_height`` (or ``max_lag``) reaches it; '' when there is
    none (``scans``: :func:`narx.records.deadtime.onset_scans` of ``data``, when
    already computed)."""
    from narx.records.deadtime import SPAN, late_inputs, late_words
    from .choices import height_for
    from ..gp.primitives import MAX_HEIGHT, max_lag_for_height
    out = []
    for name, scan in late_inputs(data, reach, scans):
        last = scan.best + SPAN - 1             # the dead time lies in best..last
        h = height_for(scan, max_height)
        fix = []
        if max_lag is not None and max_lag < last:
            fix.append(f"raise max_lag to {last} or more (--max-lag)")
        if max_lag_for_height(max_height) < last:
            fix.append(f"raise max_height to {h} (--max-height {h})" if h is not None else
                       f"remove the dead time (shift {name} by {scan.best - 1} samples: "
                       f"trees reach lag {max_lag_for_height(MAX_HEIGHT)} at most)")
        out.append(f"{late_words(name, scan, reach)}, the largest this search reaches; "
                   f"{' and '.join(fix)}")
    return "; ".join(out)


def data_warnings(data, fitness: str, window: int, k: int, reach: Optional[int] = None,
                  max_height: int = HEIGHT, max_lag=None, scans=None) -> list:
    """``(message, category)`` of what in the data will mislead a search
    with this fitness: a dominating offset, an output that saturates, a
    horizon that sees little, an input that acts beyond the lags ``reach``
    (:func:`dead_time_message`, on ``scans`` when given; not checked when
    ``reach`` is None)."""
    out = []
    off = offset_message(data)
    if off:
        out.append((off, SearchPrecisionWarning))
    held = saturation_message(data)
    if held:
        out.append((held, UserWarning))
    if reach is not None:
        late = dead_time_message(data, reach, max_height, max_lag, scans)
        if late:
            out.append((late, UserWarning))
    if fitness in ("ms", "ksa"):
        h, name = (window, "window") if fitness == "ms" else (k, "k")
        msg = horizon_message(data.y, int(h), name)
        if msg:
            out.append((msg, UserWarning))
    return out
