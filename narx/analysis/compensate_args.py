"""Argument checks shared by the compensators (``narx.analysis.compensate`` and
``mggp.compensate``), each raising one ``ValueError`` that names the
argument, the rule and the value given, and the signal ranges a model was
fitted on (``meta['ranges']``). :func:`narx.analysis.steady.rest_actuator` is
importable from here too.

Typical use::

    from narx.analysis.compensate_args import check_range, past_values
    lo, hi = check_range((-80, 80))
    u_past = past_values("u_past", 0.0, 3)        # [0.0, 0.0, 0.0]
"""
from __future__ import annotations

import numpy as np

from ..records.ranges import recorded_ranges
from .steady import rest_actuator

__all__ = ["check_range", "check_count", "check_reference", "past_values",
           "training_ranges", "training_magnitudes", "rest_actuator"]


def check_range(input_range):
    """``None`` or a finite ``(low, high)`` with ``low < high``."""
    if input_range is None:
        return None
    try:
        lo, hi = (float(v) for v in input_range)
    except (TypeError, ValueError):
        lo = hi = np.nan
    if not -np.inf < lo < hi < np.inf:
        raise ValueError(f"input_range must be None or finite (low, high) with low < high, "
                         f"got {input_range!r}")
    return lo, hi


def check_count(name, value, minimum=0):
    """An integer (not bool) >= ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def check_reference(r):
    """A non-empty 1-D float array of finite values."""
    r = np.asarray(r, dtype=float).ravel()
    if r.size < 1 or not np.all(np.isfinite(r)):
        raise ValueError(f"r must be a non-empty 1-D array of finite numbers, got {r.size} "
                         f"value(s) with {int(np.sum(~np.isfinite(r)))} non-finite")
    return r


def past_values(name, value, n):
    """``n`` values before the record: a scalar repeated or an array's last ``n``."""
    a = np.atleast_1d(np.asarray(value, dtype=float)).ravel()
    if a.size == 1:
        a = np.full(n, a[0])
    if a.size < n or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be a finite number or at least {n} finite values "
                         f"(the model's largest lag), got {a.size} value(s)")
    return [float(v) for v in a[a.size - n:]] if n else []


def training_ranges(model) -> dict:
    """``{signal: (low, high)}`` of the ranges the model was fitted on
    (:func:`narx.records.ranges.recorded_ranges`)."""
    return recorded_ranges(model)


def training_magnitudes(model) -> list:
    """|ends| of the signal ranges the model was fitted on; ``[]`` if none."""
    return [abs(x) for lo_hi in training_ranges(model).values() for x in lo_hi]
