"""Gross isolated outliers (spikes) in a record's output and inputs, found and repaired.

Typical use (``MGGPRegressor(outliers='auto')``, the default, does this)::

    from narx.records.outliers import find_spikes, repaired
    spikes = find_spikes(data)            # [Spike(signal='y', start=500, stop=501, ...), ...]
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

An input can hold a glitch too: a misread sample of a *measured* input
that the system never received. It does more harm than an output glitch,
because every term built from that input carries it, squares and memory
operators included (the bilinear record above, white input in [-1, 1], one
sample 4 up and two 4 down: three small-budget fits validated at 1.06
to 7.7 times the clean record's error, two of them with Play operators, a
hysteresis the system does not have). An isolated input sample may also be
a pulse the system did receive, so an input run that passes tests 1 and 2
(on that input) must pass a third test of its own:

3'. the output does not answer it. An ARX model with the squares and
    cubes of the inputs and their products with :math:`y_{k-1}` (orders
    :data:`ARX_ORDER` in the output, :data:`INPUT_LAGS` in the inputs;
    linear in θ, θ by least squares on the record with
    every candidate input run drawn as a line, so that no candidate teaches
    the model its own answer) predicts the output one step ahead on the
    rows whose regressors hold the run (θ on the first :data:`FIT_ROWS`
    samples of a longer record). Its residuals :math:`e(v)` there
    depend on the values :math:`v` given to the run's samples: :math:`e_m`
    for the values measured, :math:`\\hat v` the values on a grid
    (:data:`GRID` points a sample) across the rest of the input's range
    that fit best. With σ the robust standard deviation of the model's
    residuals, the run is a glitch when

    a. :math:`\\sqrt{\\sum e_m^2 - \\sum e(\\hat v)^2} >` :data:`ARX_SIGMAS` σ:
       the values measured would have moved the output, by the model;
    b. :math:`\\max |e(\\hat v)| \\le` :data:`QUIET_SIGMAS` σ: the
       output moved as some values inside the range would have moved it;
    c. the values within :data:`EDGE_SHARE` of the range from its edge (on
       the run's side) fit worse than :math:`\\hat v` by over
       :data:`EDGE_SIGMAS` σ (the root of the difference of the sums of
       squares): the output says the input was inside its range, not at
       its edge. A system that saturates answers an extreme input as it
       answers the edge, so such a pulse is kept.

    On the pulses that five systems received in ``benchmarks.outliers``
    (bilinear, Hammerstein, linear, a dead time of 6, a tanh saturation)
    none passes all three; the closest are Hammerstein pulses near
    u = 3.1, where its static curve folds back towards the values of the
    range (b at 4.3 to 4.5 σ). An input that acts beyond lag
    :data:`INPUT_LAGS`, or not at all, fails a, and its run is left as
    measured; so does a glitch the output cannot place inside the range
    (c: most of the misses at 20 dB output noise; b: a few, where the
    model fits the output less well).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List

import numpy as np

from .data import Data
from .regressors import regressor_matrix
from ..language.terms import parse_terms

__all__ = ["ARX_ORDER", "ARX_SIGMAS", "EDGE_SHARE", "EDGE_SIGMAS", "FIT_ROWS", "GRID",
           "INPUT_LAGS", "MAX_SHARE", "QUIET_SIGMAS", "SPIKE_BAND", "SPIKE_WIDTH", "Spike",
           "find_spikes", "repaired", "spikes_text"]

#: a spike's extreme lies beyond the rest of the output's range by more than this share of it
SPIKE_BAND = 0.4
#: longest run of samples taken as one spike
SPIKE_WIDTH = 2
#: orders (na = nb) of the linear ARX model whose residual must confirm a spike
ARX_ORDER = 4
#: a spike's ARX residual exceeds this many robust standard deviations (an
#: input run's values as measured predict the output this much worse, test 3'a)
ARX_SIGMAS = 15.0
#: input lags of the ARX model that tests whether the output answers an input run
INPUT_LAGS = 8
#: test 3'b: the residuals with the best values inside the range stay within
#: this many robust standard deviations
QUIET_SIGMAS = 3.5
#: test 3'c: values within this share of the range from its edge ...
EDGE_SHARE = 0.1
#: ... fit the output worse than the best values by over this many robust
#: standard deviations
EDGE_SIGMAS = 3.0
#: values of an input sample tried across the rest of its range
GRID = 41
#: the ARX model of test 3' is estimated on at most this many first samples
FIT_ROWS = 50_000
#: at most this share of the samples is flagged on each side (more are not glitches)
MAX_SHARE = 0.01


@dataclass(frozen=True)
class Spike:
    """Samples ``start:stop`` of the signal ``signal`` (the output or an
    input), their measured ``values``, how far beyond the rest of the
    signal's range they lie (``beyond``, in ranges) and the ARX evidence in
    robust standard deviations (``sigmas``): for the output the run's
    residual, for an input how much worse the output is predicted with the
    run than without it (see the module)."""

    start: int
    stop: int
    values: tuple
    beyond: float
    sigmas: float
    signal: str = "y"

    def to_dict(self) -> dict:
        return {"signal": self.signal, "start": self.start, "stop": self.stop,
                "values": list(self.values), "beyond_ranges": self.beyond,
                "arx_sigmas": self.sigmas}

    @classmethod
    def from_dict(cls, d: dict) -> "Spike":
        """The spike :meth:`to_dict` wrote."""
        return cls(int(d["start"]), int(d["stop"]), tuple(float(v) for v in d["values"]),
                   float(d["beyond_ranges"]), float(d["arx_sigmas"]), str(d.get("signal", "y")))

    @property
    def span(self) -> list:
        """``[signal, start, stop]``: where the spike is, as a model's meta holds it."""
        return [self.signal, self.start, self.stop]


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


def _robust_scale(e: np.ndarray) -> float:
    """Robust standard deviation of residuals ``e``: 1.4826 times their median
    absolute deviation (the standard deviation when that is 0)."""
    return 1.4826 * float(np.median(np.abs(e - np.median(e)))) or float(np.std(e))


def _arx_sigmas(data: Data, runs) -> np.ndarray:
    """Largest residual of each run's samples from a linear ARX model of
    ``data`` (θ by least squares on every row: an input that explains a run
    is learnt from it), in robust standard deviations of the residuals."""
    p = ARX_ORDER
    terms = parse_terms(["1"] + [f"{v}[k-{i}]" for v in (data.output, *data.inputs)
                                 for i in range(1, p + 1)], data.signals)
    X, t, _ = regressor_matrix(terms, data, start=p)
    e = t - X @ np.linalg.lstsq(X, t, rcond=None)[0]
    scale = _robust_scale(e)
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
    key = -side * y
    m = 2 * limit + 4 * SPIKE_WIDTH + 16        # the walk below stays near the extreme
    if m < n:                                   # the m most extreme samples, in stable order
        part = np.argpartition(key, m)[:m]
        idx = _walk(y, side, excluded, limit, far, part[np.lexsort((part, key[part]))])
        if idx is not None:
            return idx
    return _walk(y, side, excluded, limit, far, np.argsort(key, kind="stable"), True)


def _walk(y, side, excluded, limit, far, order, whole=False):
    """The mask of :func:`_side`, walking ``order`` (the samples from the
    ``side`` extreme inward); None when ``order`` is not ``whole`` and the
    walk reaches its end (then the whole order is needed)."""
    n, end = len(y), len(order)
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
        while pos < end and (taken[order[pos]] or excluded[order[pos]]):
            pos += 1                            # the rest's extreme on this side
        if pos == end:
            if not whole:
                return None
            break
        near = float(y[order[pos]])
        lo, hi = (far, near) if side > 0 else (near, far)
        if hi <= lo:
            continue
        gap = (edge - hi) if side > 0 else (lo - edge)
        if gap > SPIKE_BAND * (hi - lo):
            best = len(idx)
    else:
        if not whole:
            return None
    out = np.zeros(n, dtype=bool)
    out[idx[:best]] = True
    return out


def _spans(mask: np.ndarray):
    """``(start, stop)`` of each run of True in ``mask``."""
    d = np.diff(np.r_[0, mask.astype(np.int8), 0])
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


def _candidates(x: np.ndarray, limit: int):
    """Runs ``(start, stop)`` of ``x`` that pass tests 1 and 2 (see the
    module), each side's range taken without the other side's runs, and
    the range ``(lo, hi)`` of the rest."""
    n = len(x)
    top = bottom = np.zeros(n, dtype=bool)
    for _ in range(3):                          # each side's range without the other's
        new_top = _side(x, 1, bottom, limit)
        new_bottom = _side(x, -1, new_top, limit)
        if np.array_equal(new_top, top) and np.array_equal(new_bottom, bottom):
            break
        top, bottom = new_top, new_bottom
    flagged = top | bottom
    runs = [(a, b) for a, b in _spans(flagged) if b - a <= SPIKE_WIDTH]
    rest = ~flagged
    return runs, (float(np.min(x[rest])), float(np.max(x[rest])))


def _beyond(x: np.ndarray, a: int, b: int, lo: float, hi: float) -> float:
    """How far samples ``a:b`` of ``x`` lie beyond ``[lo, hi]``, in ranges."""
    return max(float(np.max(x[a:b])) - hi, lo - float(np.min(x[a:b]))) / (hi - lo)


def _rebuilt(data: Data, U: np.ndarray, y=None) -> Data:
    """``data`` with the inputs ``U`` (one row each) and the output ``y``
    (default: ``data``'s)."""
    return Data(U.T, data.y if y is None else y, inputs=data.inputs, output=data.output,
                noise=data.signals.noise)


def _interpolated(x: np.ndarray, a: int, b: int) -> None:
    """Samples ``a:b`` of ``x`` set, in place, on the line between ``x[a-1]`` and ``x[b]``."""
    x[a:b] = x[a - 1] + (x[b] - x[a - 1]) * np.arange(1, b - a + 1) / (b - a + 1)


def _answer(data: Data, candidates: dict) -> dict:
    """Test 3' of the module for each input run ``(j, a, b)`` (run ``a:b``
    of input ``j``) of ``candidates``, which maps it to the range ``(lo,
    hi)`` of the rest of that input: ``{(j, a, b): (worse, quiet,
    inside)}``, in robust standard deviations σ: how much worse the values
    measured predict than the best values :math:`\\hat v` (3'a, signed),
    :math:`\\max_k |e_k(\\hat v)|` (3'b) and how much worse the best values
    near the edge predict than :math:`\\hat v` (3'c)."""
    p, q = ARX_ORDER, INPUT_LAGS
    names = ["1"] + [f"{data.output}[k-{i}]" for i in range(1, p + 1)]
    out1 = f"{data.output}[k-1]"
    for v in data.inputs:           # per input: q lags, their squares, cubes, times y[k-1]
        names += [f"{v}[k-{i}]" for i in range(1, q + 1)]
        names += [f"{v}[k-{i}]*{v}[k-{i}]" for i in range(1, q + 1)]
        names += [f"{v}[k-{i}]*{v}[k-{i}]*{v}[k-{i}]" for i in range(1, q + 1)]
        names += [f"{out1}*{v}[k-{i}]" for i in range(1, q + 1)]
    start = max(p, q)
    U = np.array(data.U, dtype=float)
    for j, a, b in candidates:
        _interpolated(U[j], a, b)
    terms = parse_terms(names, data.signals)
    lined = _rebuilt(data, U)
    X, t, _ = regressor_matrix(terms, lined.slice(0, FIT_ROWS) if data.n > FIT_ROWS
                               else lined, start=start)
    theta = np.linalg.lstsq(X, t, rcond=None)[0]
    e = t - X @ theta
    scale = _robust_scale(e)
    out = {}
    for (j, a, b), (lo, hi) in candidates.items():
        k = np.arange(max(a + 1, start), min(b + q, data.n))   # rows that hold the run
        if not scale > 0 or not len(k):
            out[(j, a, b)] = (0.0, np.inf, 0.0)
            continue
        base = 1 + p + 4 * q * j
        lin, sq, cub, byy = (theta[base + m * q: base + (m + 1) * q] for m in range(4))
        Xw, tw, _ = regressor_matrix(terms, lined.slice(k[0] - start, k[-1] + 1), start=start)
        er = tw - Xw @ theta                    # residuals there with the run drawn as a line
        y1 = np.asarray(data.y, dtype=float)[k - 1]
        grid = np.linspace(lo, hi, GRID)
        shift = []                              # per sample: (values, rows) change of ŷ
        for i in range(a, b):
            lag = k - i
            on = (lag >= 1) & (lag <= q)
            li = np.clip(lag - 1, 0, q - 1)

            def g(v, on=on, li=li):
                v = np.asarray(v, dtype=float)[..., None]
                return on * ((lin[li] + byy[li] * y1) * v + sq[li] * v ** 2 + cub[li] * v ** 3)
            line = g(U[j, i])
            shift.append((g(data.U[j, i]) - line, g(grid) - line))
        em = er - sum(m for m, _ in shift)      # residuals with the run as measured
        eg = er                                 # residuals on the grid of values
        for _, c in shift:
            eg = eg[..., None, :] - c
        sse = np.sum(eg ** 2, axis=-1)
        best = np.unravel_index(int(np.argmin(sse)), sse.shape)
        d = float(np.sum(em ** 2) - sse[best])
        side = 1.0 if np.max(data.U[j, a:b]) > hi else -1.0
        at_edge = side * ((hi if side > 0 else lo) - grid) <= EDGE_SHARE * (hi - lo)
        edge_sse = sse[np.ix_(*[at_edge] * (b - a))].min()
        out[(j, a, b)] = (float(np.sign(d) * np.sqrt(abs(d)) / scale),
                          float(np.max(np.abs(eg[best]))) / scale,
                          float(np.sqrt(max(edge_sse - sse[best], 0.0))) / scale)
    return out


def find_spikes(data: Data) -> List[Spike]:
    """The spikes of ``data``'s output and inputs (see the module): the
    output's in sample order, then each input's."""
    y = np.asarray(data.require_output("finding outliers"), dtype=float)
    n = len(y)
    limit = int(MAX_SHARE * n)
    if limit < 1 or n < 4 * (2 * ARX_ORDER + 1):
        return []
    out = []
    runs, (lo, hi) = _candidates(y, limit)
    if runs:
        for (a, b), s in zip(runs, _arx_sigmas(data, runs)):
            if s > ARX_SIGMAS:
                out.append(Spike(a, b, tuple(float(v) for v in y[a:b]),
                                 _beyond(y, a, b, lo, hi), float(s), data.output))
    if n < 4 * (ARX_ORDER + 4 * INPUT_LAGS * len(data.inputs) + 1):    # rows per column
        return out
    found = {}
    for j in range(len(data.inputs)):
        x = np.asarray(data.U[j], dtype=float)
        runs, rng = _candidates(x, limit)
        found.update({(j, a, b): rng for a, b in runs})
    if not found:
        return out
    if out:                                     # the output's spikes are drawn as lines first
        data = repaired(data, out)
    for (j, a, b), (s, quiet, inside) in _answer(data, found).items():
        if s > ARX_SIGMAS and quiet <= QUIET_SIGMAS and inside > EDGE_SIGMAS:
            x = data.U[j]
            out.append(Spike(a, b, tuple(float(v) for v in x[a:b]),
                             _beyond(x, a, b, *found[(j, a, b)]), float(s), data.inputs[j]))
    return out


def repaired(data: Data, spikes) -> Data:
    """``data`` with each spike's samples, of the output or of an input, on
    the straight line between its neighbours (every other sample unchanged)."""
    if not spikes:
        return data
    y = np.array(data.y, dtype=float)
    U = np.array(data.U, dtype=float)
    for s in spikes:
        x = y if s.signal == data.output else U[data.inputs.index(s.signal)]
        _interpolated(x, s.start, s.stop)
    return _rebuilt(data, U, y)


def spikes_text(spikes, output: str = "y") -> str:
    """The spikes in words: 'y[500] = 13.71 (1.1 of the range beyond the
    rest, 56 σ from a linear ARX prediction)'; for an input 'u[300] = 4.5
    (2 of the range beyond the rest, the output does not answer it: an ARX
    prediction 80 σ worse with it than with values inside the range)';
    ``output`` names the output."""
    parts = []
    for s in spikes:
        where = (f"{s.signal}[{s.start}]" if s.stop == s.start + 1
                 else f"{s.signal}[{s.start}:{s.stop}]")
        vals = ", ".join(f"{v:.4g}" for v in s.values)
        if s.signal == output:
            why = f"{s.sigmas:.3g} σ from a linear ARX prediction"
        else:
            why = (f"the output does not answer it: an ARX prediction {s.sigmas:.3g} σ "
                   f"worse with it than with values inside the range")
        parts.append(f"{where} = {vals} ({s.beyond:.2g} of the range beyond the rest, {why})")
    return "; ".join(parts)
