"""A dead time beyond the search's reach: found before the search, the tree
height raised to reach it, and what that gives (:mod:`narx.records.deadtime`,
:func:`mggp.fit.choices.height_choice`, ``mggp.fit.precision``).

Typical use::

    python -m benchmarks.dead_time                # about two minutes
    python -m benchmarks.dead_time --fits 0       # the detection tables only

Three parts, each a Markdown table:

1. **Detection**: y[k] = 0.8 y[k-1] + 0.5 u[k-d] + 0.2 u[k-d]² on a held
   random input (a step every 10 samples), output noise 0.01, 2,000
   samples, for dead times d from 3 to 60 and 10 data seeds each: the lag
   the scan finds, whether a search at the fixed height 5 (lags up to 16)
   warns (it should exactly when d lies beyond 16), and the height
   ``max_height='auto'`` (the default) takes (5, or the least that
   reaches d).
2. **False warnings** on records whose input acts at once: Piroddi's
   S1-S6 (500 and 2,000 samples, with and without 20 dB output noise, 10
   seeds each) and both panels' records (:func:`benchmarks.outliers.clean_records`).
3. **Fits** of the d = 25 record at the default budget: the default
   (``max_height='auto'``, which takes 9) against the fixed height 5 (which
   warns); the free-run RMSE on a validation record of the same system
   (another input draw).
"""
from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from narx import Data
from narx.records.deadtime import onset_scan
from mggp.fit.precision import dead_time_message

DELAYS = (3, 10, 16, 20, 25, 40, 60)
REACH, HEIGHT = 16, 5


def delayed(d: int, seed: int, n: int = 2000) -> Data:
    """The record of part 1 with dead time ``d``."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-1, 1, n // 10), 10)
    y = np.zeros(n)
    for k in range(d + 1, n):
        y[k] = 0.8 * y[k - 1] + 0.5 * u[k - d] + 0.2 * u[k - d] ** 2
    return Data(u, y + 0.01 * rng.standard_normal(n))


def detection(seeds: int = 10) -> str:
    from mggp.fit.choices import height_choice
    md = ["| dead time d | records | lag found (scan window contains d) | warned at a fixed "
          "height 5 (reach 16) | heights `max_height='auto'` takes |",
          "|---:|---:|---:|---:|---|"]
    for d in DELAYS:
        found = warned = 0
        heights = {}
        for s in range(seeds):
            rec = delayed(d, 100 + s)
            b = onset_scan(rec, "u").best
            found += b <= d <= b + 3
            warned += bool(dead_time_message(rec, REACH, HEIGHT))
            h = height_choice(rec).value
            heights[h] = heights.get(h, 0) + 1
        said = ", ".join(f"{h} ({k}×)" for h, k in sorted(heights.items()))
        md.append(f"| {d} | {seeds} | {found} | {warned} | {said} |")
    return "\n".join(md)


def false_warnings(seeds: int = 10) -> str:
    from .outliers import clean_records, group_table
    return group_table(clean_records(seeds),
                       lambda rec: dead_time_message(rec, REACH, HEIGHT), "warned")


def fits(seeds) -> str:
    from mggp import MGGPRegressor
    from .outliers import validation_cell
    train, val = delayed(25, 1), delayed(25, 2)
    md = ["| setting | seed | height | warned | terms | validation free-run RMSE | fit (s) |",
          "|---|---:|---:|---|---:|---:|---:|"]
    for label, kw in (("default (`max_height='auto'`)", {}),
                      ("`max_height=5`, fixed", dict(max_height=5))):
        for s in seeds:
            t0 = time.perf_counter()
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                est = MGGPRegressor(random_state=s, n_jobs=1, **kw).fit(train)
            said = any("acts on the output" in str(w.message) for w in caught)
            md.append(f"| {label} | {s} | {est.max_height_} | {'yes' if said else 'no'} | "
                      f"{len(est.terms_)} | {validation_cell(est, val)} | "
                      f"{time.perf_counter() - t0:.0f} |")
    return "\n".join(md)


def report(seeds: int = 10, fit_seeds=(1, 2)) -> str:
    """The three parts as Markdown sections (part 3 only with ``fit_seeds``)."""
    from .outliers import sections
    return sections([("Dead times found and named", detection),
                     ("False warnings on records whose input acts at once", false_warnings)],
                    seeds, ("Fits of the record with a 25-sample dead time (default budget)",
                            fits), fit_seeds)


def main(argv=None) -> int:
    from .outliers import run_study
    return run_study("python -m benchmarks.dead_time", __doc__, report, argv, 10, 2,
                     "data seeds of parts 1 and 2")


if __name__ == "__main__":
    raise SystemExit(main())
