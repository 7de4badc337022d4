"""Held-input segments in the data and the model's drift in them.

Typical use::

    from mggp.diagnose.holds import find_holds, hold_responses
    segs = find_holds(data, min_len=40)                  # [(start, stop), ...]
    resp = hold_responses(model, data, "val.csv", min_len=40)
    [(r.start, r.data_move, r.model_move, r.noise_se) for r in resp]

A *hold* is a run of at least ``min_len`` samples in which every input
stays within a few noise standard deviations of one level and does not
move (:func:`find_holds`; the input's noise is estimated from its
differences, :func:`input_noise`, so a measured input with noise on it
is found held). In a hold starting at sample a, the model is simulated
free from the measured outputs before a (so drift is not confused with
error accumulated earlier), with the input at the hold's level (its
median over the hold) from a on, so that noise on a measured input does
not drive the model's Φ-terms. After the model's largest lag L every Φ
of inputs is 0, and from sample a + L + 1 on the *movement* of a signal
is

.. math:: d = \\bar x_{\\text{last quarter}} - \\bar x_{\\text{first quarter}} .

The data *hold* when :math:`|d_y|` is within their noise,
:math:`z\\,\\mathrm{se}(d_y)`, or the resolution floor; the noise standard
deviation is estimated robustly from first differences,
:math:`\\hat\\sigma = 1.4826\\,\\mathrm{MAD}(\\Delta y)/\\sqrt 2`, and
:math:`\\mathrm{se}(d_y) = \\hat\\sigma\\sqrt{2/q}` for quarters of q
samples. The model *drifts* there when :math:`|d_{\\hat y} - d_y|`
exceeds the same bound. The model's steady-state equation at the hold's
level gives the cause: with lags held at (ȳ, ū), one step of the model
moves the output by

.. math:: r(\\bar y, \\bar u) = \\sum_c \\Sigma_c\\, m_c(\\bar y, \\bar u) - \\bar y,

which is 0 for every (ȳ, ū) exactly when Σ_y = 1 and every other cluster
sum is 0 (a continuum of steady states, :mod:`narx.analysis.steady`).

The hold responses are what the report's holds figure draws
(:mod:`mggp.diagnose.report`); probe holds (:func:`probe_holds`) rank the
candidate extensions that do not keep still (:mod:`mggp.diagnose.extend`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Tuple

import numpy as np

from narx import Model
from narx.records.data import Data


__all__ = ["find_holds", "input_noise", "difference_noise", "HoldResponse", "hold_responses",
           "hold_motion", "self_motion", "record_holds",
           "steady_rate", "continuum_violations", "probe_holds"]


def difference_noise(x, k: int) -> float:
    """Robust standard deviation of white noise on ``x`` from its k-th
    differences: :math:`1.4826\\,\\mathrm{MAD}(\\Delta^k x) / \\sqrt{\\binom{2k}{k}}`
    (the k-th difference of white noise of standard deviation σ has standard
    deviation :math:`\\sigma\\sqrt{\\binom{2k}{k}}`; MAD, the median absolute
    deviation, is unaffected by the few large differences at steps of the
    signal). 0 when there are fewer than 2 differences."""
    d = np.diff(np.asarray(x, dtype=float), k)
    if d.size < 2:
        return 0.0
    return (1.4826 * float(np.median(np.abs(d - np.median(d))))
            / math.sqrt(math.comb(2 * k, k)))


def input_noise(x) -> float:
    """Robust standard deviation of white noise on a sampled signal.

    A smooth signal's share of the k-th difference shrinks with every
    difference; the estimate is the smallest :func:`difference_noise` over
    k = 2, 3, 4.

    Parameters
    ----------
    x : array_like (N,)
        The signal.

    Returns
    -------
    float
        The estimate (0 for a noise-free piecewise-constant signal, or when
        fewer than 6 samples are given).
    """
    x = np.asarray(x, dtype=float)
    if x.size < 6:
        return 0.0
    return min(difference_noise(x, k) for k in (2, 3, 4))


def _extend(cols, a, b, half) -> int:
    """First sample from ``b`` on at which some input strays more than
    ``half[i]`` from the mean of its samples ``a``.. so far (or the end)."""
    n = len(cols[0])
    sums = [float(sum(c[a:b])) for c in cols]
    while b < n:
        count = b - a
        if any(abs(c[b] - t / count) > h for c, t, h in zip(cols, sums, half)):
            break
        sums = [t + c[b] for c, t in zip(cols, sums)]
        b += 1
    return b


def _runs(U, half, min_len):
    """Runs, left to right, that start with ``min_len`` samples spanning at
    most ``2 half[i]`` in every input ``i`` and go on while every new sample
    stays within ``half[i]`` of the run's mean."""
    n = U.shape[1]
    if n < min_len:
        return
    flat = np.ones(n - min_len + 1, dtype=bool)
    for row, h in zip(U, half):
        w = np.lib.stride_tricks.sliding_window_view(row, min_len)
        flat &= (w.max(axis=1) - w.min(axis=1)) <= 2.0 * h
    starts = np.flatnonzero(flat)
    cols = [row.tolist() for row in U]
    a = 0
    while True:
        i = int(np.searchsorted(starts, a))
        if i == starts.size:
            return
        a = int(starts[i])
        b = _extend(cols, a, a + min_len, half)
        yield a, b
        a = b


def find_holds(data: Data, min_len: int = 20, rtol: float = 1e-9, n_sigma: float = 5.0,
               z: float = 3.5, max_rtol: float = 1e-2) -> List[Tuple[int, int]]:
    """Segments ``[start, stop)`` in which every input is held.

    Parameters
    ----------
    data : narx.Data
        The record.
    min_len : int
        Shortest hold (samples).
    rtol : float
        Tolerance of a noise-free input, as a fraction of its range.
    n_sigma : float
        How many noise standard deviations (:func:`input_noise`) a held
        input may stray from its level.
    z : float
        How many standard errors the slope or bend of a held input may
        reach (the test that the input does not move).
    max_rtol : float
        Largest tolerance, as a fraction of the input's range (guards
        against a noise estimate inflated by the signal itself).

    Returns
    -------
    list of (int, int)
        Disjoint segments in increasing order.

    Notes
    -----
    Each input gets the half-width
    :math:`h = \\min(\\max(n_\\sigma\\hat\\sigma,\\ \\mathrm{rtol}\\cdot R),\\
    \\mathrm{max\\_rtol}\\cdot R)`, with :math:`\\hat\\sigma` its noise level and
    R its range. Runs in which every input stays within ±h of one level
    (max − min ≤ 2h) for at least ``min_len`` samples are found left to
    right. A run is a hold only if no input moves in it: the slope and the
    bend of the run (the coefficients of the orthogonal linear and quadratic
    polynomials fitted to it) are within z standard errors of 0, computed
    with the noise level :math:`\\max(\\hat\\sigma,\\ \\mathrm{rtol}\\cdot R)`. A
    slow ramp, or the top of a slow sine, hidden in the noise fails this; a
    held input with white noise on it does not (noise that is not white —
    hum, a drifting source — can hide a hold). A run that fails is dropped.
    """
    U = data.U
    ranges = [float(np.ptp(row)) or 1.0 for row in U]
    sigma = [input_noise(row) for row in U]
    half = [min(max(n_sigma * s, rtol * r), max_rtol * r) for s, r in zip(sigma, ranges)]
    scale = [max(sd, rtol * r) for sd, r in zip(sigma, ranges)]
    return [(a, b) for a, b in _runs(U, half, min_len)
            if all(_level(row[a:b], sd, z) for row, sd in zip(U, scale))]


def _level(x, sigma, z) -> bool:
    """Whether ``x`` is a level with white noise of standard deviation
    ``sigma``: neither its slope nor its bend (the coefficients of the
    orthogonal linear and quadratic polynomials fitted to it) is more than
    ``z`` standard errors from 0."""
    t = np.arange(x.size, dtype=float)
    t -= t.mean()
    for p in (t, t * t - np.mean(t * t)):
        norm = math.sqrt(float(p @ p))
        if norm > 0 and abs(float(p @ x)) > z * sigma * norm:
            return False
    return True


@dataclass(frozen=True)
class HoldResponse:
    """Data and model during one hold.

    Attributes
    ----------
    record : str
        Name of the record (file) holding the segment.
    start, stop : int
        The hold is samples ``start..stop-1`` of the record.
    compare_from : int
        First sample of the comparison (``start + L + 1``).
    level : float
        Input level during the hold (first input; median over the hold).
    data_move, model_move : float
        Movement d of data and of the model started from measured data at
        ``start``.
    data_end, model_end : float
        Their mean over the last quarter of the comparison (the level they
        rest at).
    data_settled, model_settled : float
        Their mean over the first quarter of the comparison (the level they
        land at once every Φ of inputs is 0, i.e. just after the input stops
        and the model's transient from the last move is over).
    noise_se : float
        Standard error of ``data_move``.
    level_se : float
        Standard error of the model's error at rest (``model_end -
        data_end`` or ``model_settled - data_settled``) caused by noise:
        :math:`\\hat\\sigma\\sqrt{1 + 1/q}` (the noise of the measured
        output the model starts from, which a model with a continuum of
        steady states keeps, and of the data's mean over q samples).
    rate : float
        r(ȳ, ū): per-sample move of the model's steady-state equation at the
        hold's level.
    t, y, y_hat : ndarray
        Sample indices (from before the hold to ``stop``), data, and the
        model (NaN before ``start``), for plotting.
    """

    record: str
    start: int
    stop: int
    compare_from: int
    level: float
    data_move: float
    model_move: float
    data_end: float
    model_end: float
    noise_se: float
    rate: float
    t: np.ndarray
    y: np.ndarray
    y_hat: np.ndarray
    data_settled: float = float("nan")
    model_settled: float = float("nan")
    level_se: float = 0.0

    @property
    def excess(self) -> float:
        return abs(self.model_move - self.data_move)

    @property
    def rest_error(self) -> float:
        """Error of the model's resting level against the data's:
        ``max(|model_settled - data_settled|, |model_end - data_end|)``, the
        larger of the errors just after the input stops (once the model's
        transient is over) and at the hold's end (``inf`` if the model
        diverges)."""
        pairs = [(self.model_end, self.data_end)]
        if not np.isnan(self.model_settled):            # NaN: not measured
            pairs.append((self.model_settled, self.data_settled))
        if not all(np.isfinite(m) for m, _ in pairs):
            return float("inf")
        return max(abs(m - d) for m, d in pairs)


def _move(x, q):
    return float(np.mean(x[-q:]) - np.mean(x[:q]))


def _noise_se(y, q):
    return difference_noise(y, 1) * np.sqrt(2.0 / q)


def steady_rate(model: Model, y_bar: float, u_bar) -> float:
    """One step of the model with every lag held at (ȳ, ū), minus ȳ."""
    L = max(model.max_lag, 1)
    u_bar = np.atleast_1d(np.asarray(u_bar, dtype=float))
    U = np.tile(u_bar, (L + 2, 1))
    d = Data(U, np.full(L + 2, float(y_bar)), inputs=model.inputs, output=model.output)
    r = model.simulate(d, mode="osa")
    return float(r.y_hat[-1] - y_bar)


def continuum_violations(model: Model, tol: float = 1e-9):
    """Cluster sums that break the continuum conditions: [(label, value, target)]."""
    try:
        cons = model.steady_state_constraints()
    except ValueError:
        return [("Σ_y", 0.0, 1.0)]
    res = cons.residual(model.theta)
    return [(lab.split(" = ")[0], float(r + c), float(c))
            for lab, r, c in zip(cons.labels, res, cons.c) if abs(r) > tol]


def hold_responses(model: Model, data: Data, record: str = "data",
                   min_len: int = 20, segments=None, offset: int = 0) -> List[HoldResponse]:
    """The model's and the data's movement in every usable hold of ``data``.

    A hold is usable when it starts at least L samples into the record and
    leaves at least 8 samples after ``start + L + 1``. Reported sample
    numbers (``start``, ``stop``, ``compare_from``, ``t``) are those of
    ``data`` plus ``offset`` (the numbering of the file ``data`` came from).
    """
    L = model.max_lag
    segs = find_holds(data, min_len) if segments is None else segments
    out = []
    y = data.y
    for a, b in segs:
        c = a + L + 1
        if a < L or b - c < 8:
            continue
        level = np.median(data.U[:, a:b], axis=1)
        U = data.U[:, a - L:b].copy()
        U[:, L:] = level[:, None]            # the held input without its noise
        sub = Data(U.T, y[a - L:b], inputs=data.inputs, output=data.output)
        r = model.simulate(sub, mode="freerun")
        yh = np.where(np.isfinite(r.y_hat), r.y_hat, np.nan)
        q = max(2, (b - c) // 4)
        seg_y, seg_m = y[c:b], yh[c - a + L:]
        finite = bool(np.all(np.isfinite(seg_m)))
        model_move = _move(seg_m, q) if finite else np.inf
        model_end = float(np.mean(seg_m[-q:])) if finite else np.inf
        model_settled = float(np.mean(seg_m[:q])) if finite else np.inf
        y_bar = float(np.mean(seg_y[:q]))
        try:
            rate = steady_rate(model, y_bar, level)
        except (ValueError, FloatingPointError):
            rate = float("nan")
        pre = min(a, max(L, (b - a) // 4))
        t = np.arange(a - pre, b)
        y_hat = np.full(t.size, np.nan)
        y_hat[pre:] = yh[L:]
        out.append(HoldResponse(record, a + offset, b + offset, c + offset,
                                float(level[0]), _move(seg_y, q), model_move,
                                float(np.mean(seg_y[-q:])), model_end, _noise_se(seg_y, q),
                                rate, t + offset, y[a - pre:b].copy(), y_hat,
                                y_bar, model_settled,
                                difference_noise(seg_y, 1) * float(np.sqrt(1.0 + 1.0 / q))))
    return out


def probe_holds(model: Model, data: Data, n_holds: int = 4, length: Optional[int] = None
                ) -> float:
    """Largest movement of ``model`` in holds inserted into ``data``'s input.

    A probe input is made (a new array; ``data`` is not touched): the
    record's input with ``n_holds`` holds of ``length`` samples (default
    max(200, 10 L)) inserted at evenly spaced samples. The model runs free
    on it from the record's first L outputs; the result is the largest
    max − min of its output over a hold, after the first L + 1 samples of
    the hold (``inf`` if it diverges). Used to reject extensions that, once
    the input stops, do not keep still (e.g. a continuum of steady states
    whose other roots are unstable) — a property the fitting record,
    without holds, cannot show.
    """
    L = max(model.max_lag, 1)
    length = int(length or max(200, 10 * L))
    n = data.n
    at = [int(n * (i + 1) / (n_holds + 1)) for i in range(n_holds)]
    pieces, spans, pos, prev = [], [], 0, 0
    for a in at:
        pieces += [data.U[:, prev:a], np.repeat(data.U[:, a - 1:a], length, axis=1)]
        pos += a - prev
        spans.append((pos + L + 1, pos + length))
        pos += length
        prev = a
    pieces.append(data.U[:, prev:])
    U = np.concatenate(pieces, axis=1)
    probe = Data(U.T, None, inputs=data.inputs, output=data.output)
    r = model.simulate(probe, mode="freerun", y0=data.y[:L])
    if r.diverged or not np.all(np.isfinite(r.y_hat)):
        return float("inf")
    return float(max(np.ptp(r.y_hat[a:b]) for a, b in spans))


def hold_motion(model: Optional[Model], data: Data, segments, history: Optional[str] = None,
                lag: int = 0) -> np.ndarray:
    r"""How far ``model``'s free run moves early and late in each hold.

    The free run covers the whole of ``data`` from its first sample
    (:func:`~.simulation.freerun_after`, ``history`` starting its memory
    operators), each input inside a hold ``[a, b)`` of ``segments`` set
    to its median there (noise on a measured input must not drive the
    model's Φ-terms). After L samples (the larger of ``lag`` and the
    model's largest lag), the hold's
    remaining samples ``a + L + 1 .. b - 1`` are cut in halves; the
    result has one row per hold long enough for two halves of 8 samples
    or more: ``(early, late)``, the range (max − min) of the free run over
    each half (``inf`` when it diverges).

    Under a held input a stable system's deviation from its rest decays
    (first-order creep and second-order ringing alike move less in the
    second half than in the first): late motion beyond the early motion
    is the model's own, a self-excited mode.
    """
    from .simulation import freerun_after
    if model is None:
        return np.full((sum(b - a - lag - 1 >= 16 for a, b in segments), 2), np.inf)
    L = max(model.max_lag, lag)
    U = data.U.copy()
    for a, b in segments:
        U[:, a:b] = np.median(data.U[:, a:b], axis=1)[:, None]
    probe = Data(U.T, data.y, inputs=data.inputs, output=data.output)
    r = freerun_after(model, probe, 0, model.meta.get("history") if history == "own"
                      else history)
    yh = np.where(np.isfinite(r.y_hat), r.y_hat, np.inf)
    rows = []
    for a, b in segments:
        c = a + L + 1
        if b - c < 16:
            continue
        m = (c + b) // 2
        rows.append((float(np.ptp(yh[c:m])) if np.all(np.isfinite(yh[c:m])) else np.inf,
                     float(np.ptp(yh[m:b])) if np.all(np.isfinite(yh[m:b])) else np.inf))
    return np.array(rows, dtype=float).reshape(-1, 2)


def self_motion(model: Optional[Model], reference: Model, records) -> float:
    r"""The largest motion of ``model`` late in a hold of ``records`` that
    neither its own early motion in that hold nor ``reference`` (the
    baseline) late in it shows:

    .. math:: \max_h \left( m^{\text{late}}_h - \max(m^{\text{early}}_h,\
              m^{\text{late, ref}}_h) \right)^+ ,

    with :func:`hold_motion`'s ranges of the free runs; ``records`` are
    ``(data, history, segments)`` triples (segments: :func:`find_holds`
    of the record; history ``'own'``: each model's ``meta['history']``,
    as the training record's selection samples are run). 0 when no
    record has a usable hold; ``inf`` when the model diverges in one."""
    worst = 0.0
    for data, history, segs in records:
        if not segs:
            continue
        lag = max(reference.max_lag, 0 if model is None else model.max_lag)
        own = hold_motion(model, data, segs, history, lag)
        ref = hold_motion(reference, data, segs, history, lag)
        if own.size == 0:
            continue
        ref = np.where(np.isfinite(ref), ref, 0.0)
        with np.errstate(invalid="ignore"):            # inf - inf: diverged in the hold
            excess = own[:, 1] - np.maximum(own[:, 0], ref[:, 1])
        worst = max(worst, float(np.max(np.where(np.isnan(excess), np.inf, excess))))
    return worst


def record_holds(train: Data, validation: Optional[Data], lag: int):
    """The ``records`` of :func:`self_motion` for a diagnosis: the training
    record (each model's own history) and the validation record (history
    estimated), each with its holds of at least max(20, 2 ``lag`` + 12)
    samples (:func:`find_holds`; ``lag`` the baseline's largest lag)."""
    min_len = max(20, 2 * lag + 12)
    return [(d, h, find_holds(d, min_len)) for d, h in
            ((train, "own"), (validation, "estimate")) if d is not None]
