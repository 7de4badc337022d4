"""Calibrate the diagnose thresholds and measure their false-alarm rates.

Run::

    python -m benchmarks.diagnose_calibration            # factors + rates
    python -m benchmarks.diagnose_calibration --check    # rates only
    python -m benchmarks.diagnose_calibration --test Φ-augmentation   # one test only

The tests are the registered ones, else (none runs by default) the
registrable augmentation tests of :mod:`mggp.diagnose.augmentation`.
Step 1 (skipped by ``--check``): the raw checks of every such test on
the calibration realisations (:mod:`mggp.diagnose.controls`: six kinds ×
40 seeds, 2,000 samples, output SNR 30, 40 and 45 dB, two held-input
segments) give the factors of each test's check families for a false-alarm
rate of :data:`~mggp.diagnose.thresholds.CALIBRATION_RATE` per test
(:func:`mggp.diagnose.calibration.threshold_factors`); paste them into
:data:`mggp.diagnose.thresholds.CALIBRATION`. Step 2: the false-alarm rate
of each test at its calibrated threshold on *other* seeds (the
realisations the factors were not measured on), six kinds × 20 seeds at
the same output SNRs, printed as a Markdown table.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from mggp.diagnose import registered
from mggp.diagnose.calibration import (FalseAlarmRate, control_checks, false_alarm_rate,
                                      threshold_factors)
from mggp.diagnose.thresholds import CALIBRATION_RATE

#: (snr_db, first seed, realisations per kind) of the calibration set
CALIBRATION_SET = ((30.0, 0, 7), (40.0, 100, 6), (45.0, 200, 7),
                   (30.0, 1000, 7), (40.0, 1100, 6), (45.0, 1200, 7))
#: the verification set: the same kinds and output SNRs, other seeds
CHECK_SET = ((30.0, 2000, 7), (40.0, 2100, 6), (45.0, 2200, 7))


def _tests(names=None):
    from mggp.diagnose import augmentation
    tests = registered() or (augmentation.AUGMENTATION, augmentation.HELD_OUT_AUGMENTATION,
                             augmentation.OPERATOR_AUGMENTATION)
    if names:
        unknown = sorted(set(names) - {t.name for t in tests})
        if unknown:
            raise ValueError(f"--test must name tests "
                             f"{[t.name for t in tests]}, got {unknown}")
        tests = [t for t in tests if t.name in names]
    return tests


def factors(names=None):
    """Each test's family factors for a false-alarm rate of
    :data:`CALIBRATION_RATE` per test (only the tests ``names``, when
    given); returns (factors, realisations)."""
    out, n = {}, 0
    for test in _tests(names):
        rows = [checks for snr, seed, per in CALIBRATION_SET
                for _, _, checks in control_checks(test, per_kind=per, snr_db=snr, seed=seed,
                                                   holds=2, calibrated=False)]
        out.update(threshold_factors(rows, CALIBRATION_RATE))
        n = len(rows)
    return out, n


def rates(names=None):
    out = []
    for test in _tests(names):
        t0 = time.perf_counter()
        parts = [false_alarm_rate(test, holds=2, snr_db=snr, seed=seed, per_kind=per)
                 for snr, seed, per in CHECK_SET]
        fa = FalseAlarmRate(test.name, *(sum((getattr(p, f) for p in parts), ())
                                         for f in ("kinds", "seeds", "alarms", "ratios")))
        out.append((fa, time.perf_counter() - t0))
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--check", action="store_true", help="rates only")
    p.add_argument("--test", action="append", metavar="NAME",
                   help="only this registered test (repeatable)")
    a = p.parse_args(argv)
    try:
        _tests(a.test)
    except ValueError as e:
        p.error(str(e))
    if not a.check:
        f, n = factors(a.test)
        print(f"CALIBRATION_REALISATIONS = {n}")
        print("CALIBRATION = {" + ", ".join(f"{k!r}: {v:.4g}" for k, v in f.items()) + "}")
    print(f"| test | false alarms | realisations | rate | 95 % interval | stated "
          f"{CALIBRATION_RATE:g} in it or below | without power | by kind |")
    print("|---|---|---|---|---|---|---|---|")
    for fa, secs in rates(a.test):
        lo, hi = fa.interval()
        kinds = ", ".join(f"{k} {x}/{m}" for k, (x, m) in fa.by_kind.items())
        print(f"| {fa.test} | {int(np.sum(fa.alarms))} | {fa.realisations} | {fa.rate:.3g} | "
              f"{lo:.3g}-{hi:.3g} | {'yes' if lo <= CALIBRATION_RATE else 'no'} | "
              f"{fa.without_power} | {kinds} |", flush=True)


if __name__ == "__main__":
    main()
