"""Held-input segments in the data and the model's drift in them.

Typical use::

    from mggp.diagnose.holds import find_holds, hold_responses
    segs = find_holds(data, min_len=40)                  # [(start, stop), ...]
    resp = hold_responses(model, data, "val.csv", min_len=40)
    [(r.start, r.data_move, r.model_move, r.noise_se) for r in resp]

A *hold* is a run of at least ``min_len`` samples in which every input
stays constant (within ``rtol`` of its range). In a hold starting at
sample a, the model is simulated free from the measured outputs before a
(so drift is not confused with error accumulated earlier). After the
model's largest lag L every Φ of inputs is 0, and from sample a + L + 1
on the *movement* of a signal is

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
sum is 0 (a continuum of steady states, :mod:`narx.steady`).

Two holds at the same input where the data rest at different levels are
direct evidence of hysteresis (memory at rest); a model restarted at each
hold that does not rest at levels as far apart cannot express it
(:mod:`mggp.diagnose.findings`, rest-level check).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Tuple

import numpy as np

from narx import Model
from narx.data import Data

__all__ = ["find_holds", "HoldResponse", "hold_responses", "steady_rate",
           "continuum_violations", "probe_holds"]


def find_holds(data: Data, min_len: int = 20, rtol: float = 1e-9) -> List[Tuple[int, int]]:
    """Segments ``[start, stop)`` where every input is constant."""
    U = data.U
    n = data.n
    moving = np.zeros(n, dtype=bool)
    for row in U:
        tol = rtol * (float(np.ptp(row)) or 1.0)
        moving[1:] |= np.abs(np.diff(row)) > tol
    out, a = [], 0
    for k in range(1, n + 1):
        if k == n or moving[k]:
            if k - a >= min_len:
                out.append((a, k))
            a = k
    return out


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
        Input value during the hold (first input).
    data_move, model_move : float
        Movement d of data and of the model started from measured data at
        ``start``.
    data_end, model_end : float
        Their mean over the last quarter of the comparison (the level they
        rest at).
    noise_se : float
        Standard error of ``data_move``.
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

    @property
    def excess(self) -> float:
        return abs(self.model_move - self.data_move)


def _move(x, q):
    return float(np.mean(x[-q:]) - np.mean(x[:q]))


def _noise_se(y, q):
    d = np.diff(y)
    if d.size < 2:
        return 0.0
    sd = 1.4826 * float(np.median(np.abs(d - np.median(d)))) / np.sqrt(2.0)
    return sd * np.sqrt(2.0 / q)


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
        sub = Data(data.U[:, a - L:b].T, y[a - L:b], inputs=data.inputs, output=data.output)
        r = model.simulate(sub, mode="freerun")
        yh = np.where(np.isfinite(r.y_hat), r.y_hat, np.nan)
        q = max(2, (b - c) // 4)
        seg_y, seg_m = y[c:b], yh[c - a + L:]
        finite = bool(np.all(np.isfinite(seg_m)))
        model_move = _move(seg_m, q) if finite else np.inf
        model_end = float(np.mean(seg_m[-q:])) if finite else np.inf
        y_bar = float(np.mean(seg_y[:q]))
        try:
            rate = steady_rate(model, y_bar, data.U[:, a])
        except (ValueError, FloatingPointError):
            rate = float("nan")
        pre = min(a, max(L, (b - a) // 4))
        t = np.arange(a - pre, b)
        y_hat = np.full(t.size, np.nan)
        y_hat[pre:] = yh[L:]
        out.append(HoldResponse(record, a + offset, b + offset, c + offset,
                                float(data.U[0, a]), _move(seg_y, q), model_move,
                                float(np.mean(seg_y[-q:])), model_end, _noise_se(seg_y, q),
                                rate, t + offset, y[a - pre:b].copy(), y_hat))
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
