"""Gross isolated outliers (spikes) in a record's output, found and repaired.

Typical use (``MGGPRegressor(outliers='auto')``, the default, does this)::

    from narx.outliers import find_spikes, repaired
    spikes = find_spikes(data)            # [Spike(start=500, stop=501, ...), ...]
    data = repaired(data, spikes)         # each spike replaced by a line

A measured output can hold a glitch: one or two samples of a dropped or
corrupted reading, far from the signal around them. Least squares weighs
each error squared, so two such samples in a record of a thousand can
decide every θ and the structure a search takes (a second-order bilinear
system with an offset, 1,000 samples, two spikes 1.1 and 0.45 output
ranges out: ``mggp fit`` took 8 terms, 4 of them wrong, and a free-run
error 23 times the clean record's).

A run of ``w`` samples (``w`` at most :data:`SPIKE_WIDTH`) is a **spike**
when all three hold:

1. it is isolated: every sample of the run lies on the same side of both
   of its neighbours, :math:`y_{k-1}` and :math:`y_{k+w}`;
2. it leaves the rest of the record: with :math:`S` the samples of the
   isolated runs taken at that extreme and :math:`R_S` the range of the
   output without them, every sample of :math:`S` lies beyond that range
   by more than :data:`SPIKE_BAND` of it (at the top; the bottom alike),

   .. math:: \\min_{j \\in S} y_j > \\max_{i \\notin S} y_i + b\\,R_S ;

3. the inputs do not explain it: its residual from a linear ARX model of
   the record (orders :data:`ARX_ORDER`, θ by least squares on every row)
   exceeds :data:`ARX_SIGMAS` robust standard
   deviations of that model's residuals (1.4826 times their median
   absolute deviation). An output that answers an input pulse within one
   sample (an impulse test) passes the first two tests but not this one.

Candidates are taken from each extreme inward while they are isolated
runs, and the largest group of them that clears the band is taken (a
group, so that several equal glitches do not hide each other); a side
whose group would exceed :data:`MAX_SHARE` of the samples is not repaired
(glitches that many are the signal, not accidents).

The two thresholds were set on 758 records without glitches (Piroddi's
S1-S6 at 500 and 2,000 samples, with and without 20 dB output noise, 30
seeds each; the records of the defaults panel and of the diagnosis panel,
measured and simulated), where no sample passes both: the isolated
extremes furthest beyond the rest reach 0.41 of the range at 4 to 7
standard deviations, those furthest from the ARX prediction 24 standard
deviations at 0.26 of the range (S2's cubic terms). Glitches planted in a
white-input record lie 0.45 to 2.2 ranges out at 44 to 140 standard
deviations.

A spike is repaired by the straight line between its neighbours, the
usual repair of isolated outliers before identification (Pearson,
*Outliers in process modeling and identification*, IEEE Trans. Control
Syst. Technol. 10(1), 2002, 55-63; Ljung, *System Identification*, 2nd
ed., 1999, §14.2).

Only the output is repaired: an isolated sample of an input is as likely
to be a pulse the system received as a misread one.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List

import numpy as np

from .data import Data
from .regressors import regressor_matrix
from .terms import parse_terms

__all__ = ["ARX_ORDER", "ARX_SIGMAS", "MAX_SHARE", "SPIKE_BAND", "SPIKE_WIDTH", "Spike",
           "find_spikes", "repaired", "spikes_text"]

#: a spike's extreme lies beyond the rest of the output's range by more than this share of it
SPIKE_BAND = 0.4
#: longest run of samples taken as one spike
SPIKE_WIDTH = 2
#: orders (na = nb) of the linear ARX model whose residual must confirm a spike
ARX_ORDER = 4
#: a spike's ARX residual exceeds this many robust standard deviations
ARX_SIGMAS = 15.0
#: at most this share of the samples is flagged on each side (more are not glitches)
MAX_SHARE = 0.01


@dataclass(frozen=True)
class Spike:
    """Samples ``start:stop`` of the output, their measured ``values``, how
    far beyond the rest of the range they lie (``beyond``, in ranges) and
    their ARX residual in robust standard deviations (``sigmas``)."""

    start: int
    stop: int
    values: tuple
    beyond: float
    sigmas: float

    def to_dict(self) -> dict:
        return {"start": self.start, "stop": self.stop, "values": list(self.values),
                "beyond_ranges": self.beyond, "arx_sigmas": self.sigmas}

    @classmethod
    def from_dict(cls, d: dict) -> "Spike":
        """The spike :meth:`to_dict` wrote."""
        return cls(int(d["start"]), int(d["stop"]), tuple(float(v) for v in d["values"]),
                   float(d["beyond_ranges"]), float(d["arx_sigmas"]))


def _isolated_runs(y: np.ndarray, k: int, width: int):
    """The runs ``(start, stop)`` of at most ``width`` samples containing
    ``k`` whose samples all lie on ``k``'s side of both neighbours, shortest
    first (none touches an end of the record)."""
    n, out = len(y), []
    for w in range(1, width + 1):
        for a in range(k - w + 1, k + 1):
            b = a + w
            if a < 1 or b > n - 1:
                continue
            seg, lo, hi = y[a:b], y[a - 1], y[b]
            if (np.all(seg > max(lo, hi)) and y[k] > lo) or \
                    (np.all(seg < min(lo, hi)) and y[k] < lo):
                out.append((a, b))
    return out


def _arx_sigmas(data: Data, runs) -> np.ndarray:
    """Largest residual of each run's samples from a linear ARX model of
    ``data`` (θ by least squares on every row: an input that explains a run
    is learnt from it), in robust standard deviations of the residuals."""
    p = ARX_ORDER
    terms = parse_terms(["1"] + [f"{v}[k-{i}]" for v in (data.output, *data.inputs)
                                 for i in range(1, p + 1)], data.signals)
    X, t, _ = regressor_matrix(terms, data, start=p)
    e = t - X @ np.linalg.lstsq(X, t, rcond=None)[0]
    scale = 1.4826 * float(np.median(np.abs(e - np.median(e)))) or float(np.std(e))
    out = []
    for a, b in runs:
        worst = max((abs(e[k - p]) for k in range(a, b) if k >= p), default=np.inf)
        out.append(worst / scale if scale > 0 else np.inf)
    return np.asarray(out, dtype=float)


def _side(y: np.ndarray, side: int, excluded: np.ndarray, limit: int) -> np.ndarray:
    """Samples of the largest group of isolated runs at the ``side`` extreme
    of ``y`` (+1: the top, -1: the bottom) that lies beyond the rest of the
    range (without ``excluded``) by more than :data:`SPIKE_BAND` of it, the
    group at most ``limit`` samples; a boolean mask (all False: none). The
    runs are taken from the extreme inward until a sample belongs to none;
    a group, not one run at a time, so that equal glitches do not hide
    each other."""
    n = len(y)
    free = ~excluded
    if free.sum() < 2:
        return np.zeros(n, dtype=bool)
    far = float(np.min(y[free])) if side > 0 else float(np.max(y[free]))  # the rest's other end
    order = np.argsort(-side * y, kind="stable")
    taken = np.zeros(n, dtype=bool)
    idx, best, edge, pos = [], 0, None, 0
    for k in order:
        if excluded[k] or taken[k]:
            continue
        runs = _isolated_runs(y, int(k), SPIKE_WIDTH)
        if not runs:
            break
        a, b = runs[0]
        new = [j for j in range(a, b) if not taken[j]]
        taken[a:b] = True
        idx += new
        if len(idx) > limit:
            break
        inner = min(y[a:b]) if side > 0 else max(y[a:b])
        edge = inner if edge is None else (min(edge, inner) if side > 0 else max(edge, inner))
        while pos < n and (taken[order[pos]] or excluded[order[pos]]):
            pos += 1                            # the rest's extreme on this side
        if pos == n:
            break
        near = float(y[order[pos]])
        lo, hi = (far, near) if side > 0 else (near, far)
        if hi <= lo:
            continue
        gap = (edge - hi) if side > 0 else (lo - edge)
        if gap > SPIKE_BAND * (hi - lo):
            best = len(idx)
    out = np.zeros(n, dtype=bool)
    out[idx[:best]] = True
    return out


def _spans(mask: np.ndarray):
    """``(start, stop)`` of each run of True in ``mask``."""
    d = np.diff(np.r_[0, mask.astype(np.int8), 0])
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


def find_spikes(data: Data) -> List[Spike]:
    """The spikes of ``data``'s output (see the module), in sample order."""
    y = np.asarray(data.require_output("finding outliers"), dtype=float)
    n = len(y)
    limit = int(MAX_SHARE * n)
    if limit < 1 or n < 4 * (2 * ARX_ORDER + 1):
        return []
    top = bottom = np.zeros(n, dtype=bool)
    for _ in range(3):                          # each side's range without the other's
        new_top = _side(y, 1, bottom, limit)
        new_bottom = _side(y, -1, new_top, limit)
        if np.array_equal(new_top, top) and np.array_equal(new_bottom, bottom):
            break
        top, bottom = new_top, new_bottom
    flagged = top | bottom
    runs = [(a, b) for a, b in _spans(flagged) if b - a <= SPIKE_WIDTH]
    if not runs:
        return []
    rest = ~flagged
    lo, hi = float(np.min(y[rest])), float(np.max(y[rest]))
    sig = _arx_sigmas(data, runs)
    out = []
    for (a, b), s in zip(runs, sig):
        beyond = max(float(np.max(y[a:b])) - hi, lo - float(np.min(y[a:b]))) / (hi - lo)
        if s > ARX_SIGMAS:
            out.append(Spike(a, b, tuple(float(v) for v in y[a:b]), beyond, float(s)))
    return out


def repaired(data: Data, spikes) -> Data:
    """``data`` with each spike's samples on the straight line between its
    neighbours (the inputs and any other sample unchanged)."""
    if not spikes:
        return data
    y = np.array(data.y, dtype=float)
    for s in spikes:
        a, b = s.start, s.stop
        y[a:b] = y[a - 1] + (y[b] - y[a - 1]) * np.arange(1, b - a + 1) / (b - a + 1)
    return Data(data.U.T, y, inputs=data.inputs, output=data.output,
                noise=data.signals.noise)


def spikes_text(spikes, output: str = "y") -> str:
    """The spikes in words: 'y[500] = 13.71 (1.1 ranges beyond the rest,
    56 σ from a linear ARX prediction)'."""
    parts = []
    for s in spikes:
        where = (f"{output}[{s.start}]" if s.stop == s.start + 1
                 else f"{output}[{s.start}:{s.stop}]")
        vals = ", ".join(f"{v:.4g}" for v in s.values)
        parts.append(f"{where} = {vals} ({s.beyond:.2g} of the range beyond the rest, "
                     f"{s.sigmas:.3g} σ from a linear ARX prediction)")
    return "; ".join(parts)
