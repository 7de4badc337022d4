"""The training range of a model's signals, and how far a record leaves it.

Typical use::

    from narx.records.ranges import signal_ranges, range_warning
    model.meta["ranges"] = signal_ranges(train)   # Model.fit does this
    line = range_warning(model, record)           # '' when every input stays inside
    if line:
        print("warning: " + line)

A polynomial NARX model is fitted on the values its signals took in the
training record; outside that range its terms extrapolate, and a power
such as ``v[k-1]^7`` grows by 1.5⁷ ≈ 17 when ``v`` exceeds its range by
half its width. A model file records the range ``[min, max]`` of every
input and of the output of its training record (``meta['ranges']``,
checked on loading by :mod:`narx.modelio`); :func:`range_warning` says in
one line on how many samples, and how far, a record's inputs leave it.
How far is measured from the middle of the range in half-widths,

.. math:: r = \\max_k \\frac{|u_k - c|}{h}, \\qquad c = \\tfrac{1}{2}(u_{max} + u_{min}),
          \\quad h = \\tfrac{1}{2}(u_{max} - u_{min}),

so ``r = 1`` at the range's ends and ``r = 1.6`` for an input reaching
1.6 times as far from the middle as the training record did. An input
that reaches no further than :data:`MARGIN` beyond the ends (``r`` up to
1.02) is not named: a new realisation of the training record's own kind
of input passes its extremes by a hair, and the model's terms are then
evaluated where it was fitted.
"""
from __future__ import annotations

from typing import Dict, List, NamedTuple, Tuple

import numpy as np

from ..exceptions import ExtrapolationWarning

__all__ = ["MARGIN", "signal_ranges", "recorded_ranges", "Excursion", "excursions",
           "range_warning", "range_line", "range_text", "ExtrapolationWarning"]


def signal_ranges(data) -> Dict[str, List[float]]:
    """``{name: [min, max]}`` of every input and of the output of ``data``
    (a :class:`narx.records.data.Data`), as a model file records them."""
    pairs = [(n, data.input(n)) for n in data.inputs] + [(data.output, data.y)]
    return {name: [float(np.min(x)), float(np.max(x))] for name, x in pairs}


def recorded_ranges(model) -> Dict[str, Tuple[float, float]]:
    """``{signal: (low, high)}`` of the ranges ``model`` was fitted on
    (``meta['ranges']``); ``{}`` for a model without them (an old file, or
    a model written by hand), and malformed entries are left out."""
    ranges = getattr(model, "meta", {}).get("ranges")
    out = {}
    if isinstance(ranges, dict):
        for name, v in ranges.items():
            if (isinstance(v, (list, tuple)) and len(v) == 2
                    and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                            and np.isfinite(x) for x in v) and v[0] <= v[1]):
                out[name] = (float(v[0]), float(v[1]))
    return out


#: excursions up to this share of the half-width beyond the range's ends
#: are not named (:func:`excursions`)
MARGIN = 0.02


class Excursion(NamedTuple):
    """An input of a record outside its training range ``[low, high]``:
    on ``count`` of ``n`` samples, reaching ``reach`` half-widths from the
    range's middle (:func:`excursions`)."""

    signal: str
    low: float
    high: float
    count: int
    n: int
    reach: float


def range_text(low: float, high: float) -> str:
    """'[-0.21, 0.2]': a range with three significant digits."""
    return f"[{low:.3g}, {high:.3g}]"


def excursions(ranges, data) -> List[Excursion]:
    """The inputs of ``data`` that leave their range of ``ranges``
    (``{name: (low, high)}``, :func:`recorded_ranges`), in input order;
    inputs without a recorded range are not judged, and an input that
    reaches no further than :data:`MARGIN` half-widths beyond an end is
    not named. A constant training input (zero half-width) counts every
    other value as infinitely far."""
    out = []
    for name in data.inputs:
        if name not in ranges:
            continue
        lo, hi = ranges[name]
        x = np.asarray(data.input(name), dtype=float)
        outside = (x < lo) | (x > hi)
        count = int(np.count_nonzero(outside))
        if not count:
            continue
        mid, half = 0.5 * (hi + lo), 0.5 * (hi - lo)
        far = float(np.max(np.abs(x[outside] - mid)))
        reach = far / half if half > 0 else float("inf")
        if reach <= 1.0 + MARGIN:
            continue
        out.append(Excursion(name, lo, hi, count, int(x.size), reach))
    return out


def range_warning(model, data) -> str:
    """One line on the inputs of ``data`` that leave the training ranges of
    ``model`` (:func:`recorded_ranges`; :func:`range_line`); '' when every
    input stays inside or the model records no ranges."""
    return range_line(recorded_ranges(model), data)


def range_line(ranges, data) -> str:
    """One line on the inputs of ``data`` that leave ``ranges``
    (``{name: (low, high)}``; :func:`excursions`), e.g. ``input v leaves the
    training range [-0.21, 0.2] on 12 of 3600 samples (up to 1.6× its
    half-width from the middle): the model extrapolates there``; '' when
    every input stays inside."""
    found = excursions(ranges, data)
    if not found:
        return ""
    parts = [f"{e.signal} {range_text(e.low, e.high)} on {e.count} of {e.n} samples (up to "
             f"{e.reach:.3g}× its half-width from the middle)" for e in found]
    if len(found) == 1:
        said = "input " + parts[0].replace(" [", " leaves the training range [", 1)
    else:
        said = "inputs leave their training ranges: " + "; ".join(parts)
    return said + ": the model extrapolates there"
