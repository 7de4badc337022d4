"""Control records: simulated systems with nothing for a diagnosis to name.

Typical use::

    from mggp.diagnose.controls import CONTROL_KINDS, control_record
    rec = control_record("dead zone", seed=3)        # rec.data, rec.terms
    model = narx.Model(rec.terms).fit(rec.data)      # a model with nothing missing

Every kind shares one input: white Gaussian noise through a second-order
Butterworth low-pass filter (cut-off 0.05 of the Nyquist frequency),
scaled to standard deviation 0.5, so the input reverses often enough for
the loop-gap test. The output carries white Gaussian noise at ``snr_db``
(its standard deviation is std(y) · 10^(−SNR/20)). None of the systems has
memory beyond its dynamics (no hysteresis), none drifts at a held input
(``holds`` puts held segments into the input), and each is simulated from
rest for 200 samples before the record starts.

================  ========================================================================
kind              system (v: input after the static part, x: state)
================  ========================================================================
linear            y = 1.5 y[k-1] − 0.7 y[k-2] + 0.5 u[k-1] + 0.25 u[k-2]
polynomial NARX   y = 0.5 y[k-1] + 0.3 u[k-1] + 0.1 u[k-1]² − 0.05 y[k-1] u[k-1]
Hammerstein       v = u + 0.5 u² − 0.3 u³, y = y[k-1] − 0.3 y[k-2] + 0.5 v[k-1] + 0.3 v[k-2]
Wiener            x = 0.8 x[k-1] + 0.2 u[k-1], y = x + 0.5 x² − 0.4 x³
saturation        v = clip(u, −0.5, 0.5), y = 0.7 y[k-1] + 0.3 v[k-1]
dead zone         v = sign(u) max(|u| − 0.2, 0), y = 0.7 y[k-1] + 0.3 v[k-1]
================  ========================================================================

:attr:`ControlRecord.terms` is the system's own structure where it is a
polynomial NARX model (linear, polynomial NARX, Hammerstein), and a
degree-3 polynomial of the last two samples otherwise
(:data:`APPROXIMATION`): a model with no missing *kind* of term, whose
only error is the approximation of a smooth static function.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Tuple

import numpy as np
from scipy.signal import butter, lfilter

from narx.records.data import Data

__all__ = ["CONTROL_KINDS", "APPROXIMATION", "ControlRecord", "control_record"]

CONTROL_KINDS: Tuple[str, ...] = ("linear", "polynomial NARX", "Hammerstein", "Wiener",
                                  "saturation", "dead zone")

#: Terms of the model of a control that is not a polynomial NARX system.
APPROXIMATION: Tuple[str, ...] = ("y[k-1]", "y[k-2]", "u[k-1]", "u[k-2]", "u[k-1]*u[k-1]",
                                  "u[k-1]*u[k-1]*u[k-1]", "y[k-1]*y[k-1]",
                                  "y[k-1]*y[k-1]*y[k-1]", "y[k-1]*u[k-1]")

_WARMUP = 200


@dataclass(frozen=True)
class ControlRecord:
    """A control record: its ``kind``, ``seed``, the data, and the terms of a
    model of it with nothing missing."""

    kind: str
    seed: int
    data: Data
    terms: Tuple[str, ...]


def _filter(u, a1, a2=0.0, b1=1.0, b2=0.0):
    """y[k] = a1 y[k-1] + a2 y[k-2] + b1 u[k-1] + b2 u[k-2] (from rest)."""
    return lfilter([0.0, b1, b2], [1.0, -a1, -a2], u)


def _system(kind: str, u: np.ndarray) -> Tuple[np.ndarray, Tuple[str, ...]]:
    if kind == "linear":
        return (_filter(u, 1.5, -0.7, 0.5, 0.25),
                ("y[k-1]", "y[k-2]", "u[k-1]", "u[k-2]"))
    if kind == "polynomial NARX":
        y = np.zeros(u.size)
        for k in range(1, u.size):
            y[k] = (0.5 * y[k - 1] + 0.3 * u[k - 1] + 0.1 * u[k - 1] ** 2
                    - 0.05 * y[k - 1] * u[k - 1])
        return y, ("y[k-1]", "u[k-1]", "u[k-1]*u[k-1]", "y[k-1]*u[k-1]")
    if kind == "Hammerstein":
        v = u + 0.5 * u ** 2 - 0.3 * u ** 3
        return (_filter(v, 1.0, -0.3, 0.5, 0.3),
                ("y[k-1]", "y[k-2]", "u[k-1]", "u[k-1]*u[k-1]", "u[k-1]*u[k-1]*u[k-1]",
                 "u[k-2]", "u[k-2]*u[k-2]", "u[k-2]*u[k-2]*u[k-2]"))
    if kind == "Wiener":
        x = _filter(u, 0.8, 0.0, 0.2)
        return x + 0.5 * x ** 2 - 0.4 * x ** 3, APPROXIMATION
    if kind == "saturation":
        return _filter(np.clip(u, -0.5, 0.5), 0.7, 0.0, 0.3), APPROXIMATION
    if kind == "dead zone":
        v = np.sign(u) * np.maximum(np.abs(u) - 0.2, 0.0)
        return _filter(v, 0.7, 0.0, 0.3), APPROXIMATION
    raise ValueError(f"kind must be one of {list(CONTROL_KINDS)}, got {kind!r}")


def control_record(kind: str, seed: int = 0, n: int = 2000, snr_db: float = 40.0,
                   holds: int = 0, hold_len: int = 150) -> ControlRecord:
    """One realisation of the control ``kind`` (see the module doc).

    Parameters
    ----------
    kind : str
        One of :data:`CONTROL_KINDS`.
    seed : int
        Seed of the input and the noise; each kind draws from its own
        stream (``numpy.random.default_rng([seed, index of kind])``).
    n : int
        Samples in the record.
    snr_db : float
        Output signal-to-noise ratio in dB (``inf``: no noise).
    holds, hold_len : int
        Held-input segments of ``hold_len`` samples put at evenly spaced
        samples of the record (the input keeps its value there, then
        steps back to the filtered noise), for the tests that need holds.

    Returns
    -------
    ControlRecord
    """
    if kind not in CONTROL_KINDS:
        raise ValueError(f"kind must be one of {list(CONTROL_KINDS)}, got {kind!r}")
    if int(n) < 100:
        raise ValueError(f"n must be at least 100, got {n!r}")
    if int(holds) < 0 or int(holds) * int(hold_len) > int(n) // 2:
        raise ValueError(f"holds x hold_len must be between 0 and n/2 = {int(n) // 2} "
                         f"samples, got {holds!r} x {hold_len!r}")
    rng = np.random.default_rng([int(seed), CONTROL_KINDS.index(kind)])
    b, a = butter(2, 0.05)
    w = lfilter(b, a, rng.standard_normal(int(n) + _WARMUP))
    u = 0.5 * w / np.std(w)
    for j in range(int(holds)):
        a = _WARMUP + int(n) * (j + 1) // (int(holds) + 1)
        u[a:a + int(hold_len)] = u[a]
    y, terms = _system(kind, u)
    u, y = u[_WARMUP:], y[_WARMUP:]
    sd = float(np.std(y)) * 10.0 ** (-float(snr_db) / 20.0)
    y = y + sd * rng.standard_normal(y.size)
    return ControlRecord(kind, int(seed), Data(u, y), tuple(terms))
