"""Dead time of an input: the lag from which it acts on the output, found by
a scan of linear ARX models.

Typical use::

    from narx.records.deadtime import onset_scan
    scan = onset_scan(data, "u")      # OnsetScan(lags=..., rmse=...)
    scan.best                         # the lag d whose model predicts best
    scan.best_within(16)              # the best RMSE of a model starting within 16

For each candidate dead time :math:`d = 1, \\dots, D` the model

.. math:: y_k = a_1 y_{k-1} + a_2 y_{k-2} + \\sum_{j=0}^{3}
          \\left(b_j u_{k-d-j} + c_j u_{k-d-j}^2\\right)
          + \\sum_{v \\ne u} \\sum_{i=1}^{4} e_{v,i} v_{k-i} + f

is fitted by least squares on the same rows and scored by its one-step
RMSE; the squares let an even nonlinearity show its lag too. The input
acts from about the lag whose model scores best (within the four lags
that model spans). The classic use is choosing the delay of an ARX model
by the loss over a range of delays (Ljung, *System Identification*, 2nd
ed., Prentice Hall 1999, §16.4 and ``delayest`` of its toolbox).

A record longer than :data:`ROWS` samples is scanned on its first
:data:`ROWS` (the scan costs ``D`` least-squares fits).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .data import Data
from .regressors import regressor_matrix
from ..language.terms import parse_terms

__all__ = ["GAIN", "MAX_DELAY", "ROWS", "SPAN", "OnsetScan", "late_inputs", "late_words",
           "onset_scan", "onset_scans"]

#: largest dead time scanned (at most a tenth of the rows scanned)
MAX_DELAY = 200
#: rows of a long record that the scan uses
ROWS = 20_000
#: input lags of each candidate model: d, d+1, ..., d+SPAN-1
SPAN = 4
#: an input is late when its best dead time predicts over this factor better than
#: any within reach and than the model just before it
GAIN = 1.25


@dataclass(frozen=True)
class OnsetScan:
    """One-step RMSE ``rmse[i]`` of the model whose input lags start at
    ``lags[i]`` (see the module)."""

    input: str
    lags: np.ndarray
    rmse: np.ndarray

    @property
    def best(self) -> int:
        """The dead time whose model predicts best."""
        return int(self.lags[int(np.argmin(self.rmse))])

    @property
    def best_rmse(self) -> float:
        return float(np.min(self.rmse))

    def best_within(self, reach: int) -> float:
        """The least RMSE of the models whose input lags start within
        ``reach`` (``inf`` when none does)."""
        ok = self.lags <= reach
        return float(np.min(self.rmse[ok])) if np.any(ok) else float("inf")

    def onset_gain(self) -> float:
        """How much better the best model predicts than the one whose lags
        end just before it (starting :data:`SPAN` lags earlier): large at
        a dead time, where the input's effect starts; near 1 where the
        error only drifts with the lag (``inf``: no earlier model)."""
        i = int(np.argmin(self.rmse)) - SPAN
        return float(self.rmse[i] / self.best_rmse) if i >= 0 and self.best_rmse > 0 \
            else float("inf")

    def periodic(self, u, limit: float = 0.95) -> bool:
        """Whether the input ``u`` (the scanned one) nearly repeats itself at
        the best model's lags: its autocorrelation there exceeds ``limit``.
        A periodic input gives every lag a period back the information of
        the lags before it, so the scan cannot tell a dead time."""
        u = np.asarray(u, dtype=float)[:ROWS]
        x = u - u.mean()
        den = float(x @ x)
        if den == 0.0:
            return False
        return any(float(x[:-k] @ x[k:]) / den > limit
                   for k in range(self.best, self.best + SPAN) if k < x.size)


def onset_scan(data: Data, name: str, max_delay: int = MAX_DELAY) -> OnsetScan:
    """The scan of input ``name`` of ``data`` (see the module)."""
    data.require_output("scanning dead times")
    rec = data.slice(0, ROWS) if data.n > ROWS else data
    n = rec.n
    top = max(1, min(int(max_delay), n // 10))
    p0 = top + SPAN
    if n - p0 < 4 * (2 + 2 * SPAN + SPAN * len(data.inputs)):
        return OnsetScan(name, np.arange(1, 1), np.zeros(0))
    base = ["1", f"{data.output}[k-1]", f"{data.output}[k-2]"] + [
        f"{v}[k-{i}]" for v in data.inputs if v != name for i in range(1, SPAN + 1)]
    rmse = np.empty(top)
    for d in range(1, top + 1):
        lagged = [f"{name}[k-{d + j}]" for j in range(SPAN)]
        terms = parse_terms(base + lagged + [f"{x}*{x}" for x in lagged], rec.signals)
        X, t, _ = regressor_matrix(terms, rec, start=p0)
        r = t - X @ np.linalg.lstsq(X, t, rcond=None)[0]
        rmse[d - 1] = np.sqrt(np.mean(r * r))
    return OnsetScan(name, np.arange(1, top + 1), rmse)


def onset_scans(data: Data) -> dict:
    """``{input name: OnsetScan}`` of every input of ``data``: the scans of a
    record, computed once for each check that uses them."""
    return {name: onset_scan(data, name) for name in data.inputs}


def late_inputs(data: Data, reach: int, scans=None) -> list:
    """``(name, scan)`` of each input that acts on the output only beyond
    the lags ``reach``: the best dead time ``d`` of :func:`onset_scan` lies
    beyond ``reach`` and predicts over :data:`GAIN` times better than any
    dead time within it and than the model just before it
    (:meth:`OnsetScan.onset_gain`: the effect starts there, the error does
    not only drift with the lag). Not an input that nearly repeats itself
    at that lag (:meth:`OnsetScan.periodic`: a period, not a dead time,
    would give the gain). ``scans``: :func:`onset_scans` of ``data``, when
    already computed."""
    scans = onset_scans(data) if scans is None else scans
    out = []
    for name in data.inputs:
        scan = scans[name]
        if scan.rmse.size == 0:
            continue
        if (scan.best > reach and scan.best_within(reach) > GAIN * scan.best_rmse
                and scan.onset_gain() > GAIN and not scan.periodic(data.input(name))):
            out.append((name, scan))
    return out


def late_words(name: str, scan: OnsetScan, reach: int) -> str:
    """What :func:`late_inputs` found for one input, in words."""
    d = scan.best
    return (f"input {name!r} acts on the output from about lag {d}: a linear ARX model "
            f"predicts one step ahead with RMSE {scan.best_rmse:.4g} from its lags "
            f"{d}-{d + SPAN - 1}, {scan.best_within(reach) / scan.best_rmse:.3g} times better "
            f"than from any lags starting within {reach}")
