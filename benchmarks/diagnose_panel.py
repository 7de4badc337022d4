"""Diagnose panel: hysteresis behind dynamics and noise, controls, two shared records.

Run::

    python -m benchmarks.diagnose_panel                 # every record, jobs 2
    python -m benchmarks.diagnose_panel --only play     # records whose name has 'play'
    python -m benchmarks.diagnose_panel --population 100 --generations 15   # a smaller search

Each record is diagnosed by :func:`mggp.diagnose.diagnose` with the budget
:data:`BUDGET`, ``mggp diagnose``'s default (MGGP baseline, evidence,
extension, gain) and the table
lists the effects named against the truth, the gain (baseline / extended
free-run RMSE on the measuring samples), the share of the measuring
samples whose input lies outside the fitting samples' range (there the
gain measures extrapolation too) and the time.

Hysteretic records (truth ``hysteresis``): a play (backlash) operator of
half-width 0.2, a Prandtl–Ishlinskii sum of plays (:func:`narx.systems.prandtl_ishlinskii`)
and the piezo Bouc–Wen system (:func:`narx.systems.piezo_bouc_wen`), each
followed by a linear filter of order 1–3 with unit static gain and poles
0.9, 0.85, 0.8 (:func:`behind_dynamics`), white output noise at 30–45 dB
SNR; the training input is :func:`narx.systems.training_input` (4,000
samples, 4 Hz bandwidth at 1 ms), with or without three held segments of
300 samples, and with or without a validation record (a held sine,
:func:`narx.systems.held_sine`). Controls (truth: nothing to name):
:func:`mggp.diagnose.controls.control_record` of every kind, 4,000 samples,
40 dB. A white input (:func:`white`): a play behind first-order dynamics,
and a static saturation (tanh) as a control. The issue's own example: the piezo system on
20,000 samples of the case study's 1 Hz input, noise-free, no holds, tail
(:func:`clean_piezo`). Shared records: the MR damper (inputs v, E; rows 400–1999 fit,
2001–3599 validate) and the measured cascaded tanks (``uEst``/``yEst`` fit,
``uVal``/``yVal`` validate), whose truth is not known for certain
(``?``): the damper is Bouc–Wen, the tanks saturate and overflow.
"""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass, replace
from typing import Callable, Optional, Tuple

import numpy as np
from scipy.signal import lfilter

from narx.records.csvdata import read_csv
from narx.records.data import Data
from narx.systems import held_sine, piezo_bouc_wen, prandtl_ishlinskii, training_input

from mggp.diagnose import Budget, diagnose
from mggp.diagnose.controls import CONTROL_KINDS, control_record

from .mr_damper import data_path, shared_data_error

BUDGET = Budget()
POLES = (0.9, 0.85, 0.8)
N = 4000
#: shared data files the panel reads (found by :func:`benchmarks.mr_damper.data_path`)
SHARED_FILES = ("mr_damper.csv", "cascaded_tanks.csv")


def behind_dynamics(v, order: int) -> np.ndarray:
    """v through poles ``POLES[:order]`` with unit static gain, one sample of delay."""
    a = np.poly(POLES[:order])
    return lfilter([0.0, float(np.sum(a))], a, v)


def play(u, r: float = 0.2) -> np.ndarray:
    """Play (backlash) operator z_k = max(u_k − r, min(u_k + r, z_{k-1})), z_0 = u_0."""
    z = np.empty(u.size)
    z[0] = u[0]
    for k in range(1, u.size):
        z[k] = max(u[k] - r, min(u[k] + r, z[k - 1]))
    return z


KINDS = {"play": (play, 1.0),
         "PI": (lambda u: prandtl_ishlinskii(u), 80.0),
         "Bouc-Wen": (piezo_bouc_wen, 80.0)}


def with_holds(u, count=3, length=300):
    u = u.copy()
    for j in range(count):
        a = u.size * (j + 1) // (count + 1)
        u[a:a + length] = u[a]
    return u


def noisy(y, snr_db, rng):
    return y + np.std(y) * 10.0 ** (-snr_db / 20.0) * rng.standard_normal(y.size)


@dataclass(frozen=True)
class Record:
    name: str
    truth: str
    make: Callable[[], Tuple[Data, Optional[Data]]]


def hysteretic(kind, order, holds, validation, snr_db, seed):
    f, amp = KINDS[kind]

    def make():
        rng = np.random.default_rng(seed)
        u = training_input(N, amplitude=amp, bandwidth=4.0, seed=seed)
        u = with_holds(u) if holds else u
        train = Data(u, noisy(behind_dynamics(f(u), order), snr_db, rng))
        val = None
        if validation:
            uv = held_sine(amplitude=0.75 * amp, freq=2.0, hold=0.5).u
            val = Data(uv, noisy(behind_dynamics(f(uv), order), snr_db, rng))
        return train, val
    name = (f"{kind}, order {order}, {snr_db:g} dB, {'holds' if holds else 'no holds'}, "
            f"{'validation' if validation else 'tail'}")
    return Record(name, "hysteresis", make)


def clean_piezo(seed=1, n=20_000):
    """The issue's own example: the piezo Bouc–Wen system driven by the
    case study's 1 Hz training input at 1 kHz, no noise, no dynamics, no
    holds, no validation record (oversampled: one-step errors near 0)."""
    def make():
        u = training_input(n, seed=seed)
        return Data(u, piezo_bouc_wen(u)), None
    return Record(f"Bouc-Wen, clean, 1 Hz, {n:,} samples, no holds, tail", "hysteresis", make)


def white(kind, seed=0, n=3000):
    """A first-order record y[k] = 0.8 y[k-1] + v[k-1] driven by a white
    uniform input on [−1, 1] (it jumps across its range every sample),
    40 dB, tail: ``kind`` 'play' (v = a play of half-width 0.2 of u:
    hysteresis) or 'static tanh' (v = 0.5u + 0.4 tanh(3u): a static
    saturation, nothing with memory; the operators of a white input look
    like saturating functions of it, :func:`mggp.diagnose.augmentation.shuffled_operators`)."""
    def make():
        rng = np.random.default_rng(seed)
        u = rng.uniform(-1.0, 1.0, n)
        v = play(u) if kind == "play" else 0.5 * u + 0.4 * np.tanh(3.0 * u)
        return Data(u, noisy(lfilter([0.0, 1.0], [1.0, -0.8], v), 40.0, rng)), None
    if kind == "play":
        return Record("play, white input, order 1, 40 dB, no holds, tail", "hysteresis", make)
    return Record("control: static tanh, white input", "none", make)


def control(kind, seed=0):
    return Record(f"control: {kind}", "none",
                  lambda: (control_record(kind, seed, N, 40.0).data, None))


def mr_damper():
    def make():
        d = read_csv(data_path("mr_damper.csv"), inputs=["v", "E"], output="f")
        cut = lambda a, b: Data(d.U[:, a:b].T, d.y[a:b], inputs=d.inputs, output=d.output)
        return cut(400, 2000), cut(2001, 3600)
    return Record("MR damper (v, E -> f)", "hysteresis?", make)


def cascaded_tanks():
    def make():
        p = data_path("cascaded_tanks.csv")
        t = read_csv(p, inputs=["uEst"], output="yEst")
        v = read_csv(p, inputs=["uVal"], output="yVal")
        return t, Data(v.U.T, v.y, inputs=["uEst"], output="yEst")
    return Record("cascaded tanks (measured)", "none?", make)


RECORDS = (
    hysteretic("play", 1, False, False, 40.0, 1),
    hysteretic("play", 2, True, True, 35.0, 2),
    hysteretic("play", 3, False, True, 45.0, 3),
    hysteretic("PI", 1, True, False, 30.0, 4),
    hysteretic("PI", 2, False, True, 40.0, 5),
    hysteretic("PI", 3, False, False, 35.0, 6),
    hysteretic("Bouc-Wen", 1, False, True, 45.0, 7),
    hysteretic("Bouc-Wen", 2, True, False, 40.0, 8),
    hysteretic("Bouc-Wen", 3, False, False, 30.0, 9),
    clean_piezo(),
    white("play"),
) + tuple(control(k) for k in CONTROL_KINDS) + (white("static tanh"), mr_damper(),
                                               cascaded_tanks())


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--only", default="", help="records whose name contains this text")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", default="", help="write every record's checks and gain here")
    p.add_argument("--population", type=int, default=BUDGET.population)
    p.add_argument("--generations", type=int, default=BUDGET.generations)
    a = p.parse_args(argv)
    budget = replace(BUDGET, population=a.population, generations=a.generations)
    err = shared_data_error(SHARED_FILES)
    if err:
        print(err, file=sys.stderr)
        return 2
    doc = []
    print("| record | truth | named | hysteresis named | gain (RMSE ratio) | "
          "recommended | measured input outside the fitting range | s |")
    print("|---|---|---|---|---|---|---|---|", flush=True)
    rows = []
    for rec in RECORDS:
        if a.only and a.only not in rec.name:
            continue
        train, val = rec.make()
        t0 = time.perf_counter()
        dx = diagnose(train, val, budget=budget, seed=a.seed, jobs=a.jobs)
        secs = time.perf_counter() - t0
        hyst = "hysteresis" in dx.effects
        rows.append((rec, hyst, dx.gain.ratio, secs))
        if a.json:
            import json
            doc.append({"record": rec.name, "truth": rec.truth, "effects": dx.effects,
                        "seconds": secs, **dx.to_dict()})
            with open(a.json, "w") as fh:
                json.dump(doc, fh, indent=1, default=str)
        out = dx.settings["measure_outside_fit_range"]
        print(f"| {rec.name} | {rec.truth} | {', '.join(dx.effects) or 'none'} | "
              f"{'yes' if hyst else 'no'} | {dx.gain.ratio:.3g} | {dx.gain.recommended} | "
              f"{', '.join(f'{k} {100 * v:.0f} %' for k, v in out.items())} | "
              f"{secs:.0f} |", flush=True)
    hy = [r for r in rows if r[0].truth == "hysteresis"]
    ct = [r for r in rows if r[0].truth == "none"]
    print()
    print(f"hysteresis named on {sum(r[1] for r in hy)}/{len(hy)} hysteretic records; "
          f"gain >= 1.5 on {sum(r[2] >= 1.5 for r in hy)}/{len(hy)}; "
          f"hysteresis named on {sum(r[1] for r in ct)}/{len(ct)} controls; "
          f"records over 60 s: {sum(r[3] > 60 for r in rows)}/{len(rows)}")


if __name__ == "__main__":
    raise SystemExit(main())
