"""Least squares on one BLAS thread against the BLAS library's default, side by side.

Typical call::

    python -m benchmarks.blas_threads                  # idle, then one busy process
    python -m benchmarks.blas_threads --repeats 50 --json blas.json

Every LS and CLS solve of :mod:`narx.linalg` runs inside
:func:`narx.linalg.one_blas_thread`. This study times the solve
(:func:`narx.linalg.lstsq`, LAPACK ``gelsy``) on the regressor shapes the
project meets — 2,800 × 20 (a diagnosis candidate on its fitting samples),
50,000 × 15 (the case study), 1,000,000 × 15 (a long record) — in one
process, alternating the two settings call by call so that a change of the
machine's speed hits both alike, and reports the median time of each and
their ratio (default / one thread; > 1: one thread is faster). It runs
on an otherwise idle machine, then with 1, 2, … competing processes
(up to the number of cores) that solve small LS problems in a loop on
their BLAS's default threads (a second fit, another job): there the BLAS
threads of the processes wait for each other's cores.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import multiprocessing as mp
import time

import numpy as np

SHAPES = ((2_800, 20), (50_000, 15), (1_000_000, 15))


def _spin(stop):
    """Another process doing small solves on its BLAS's default threads (a
    second fit, a worker of another job) until ``stop`` is set."""
    rng = np.random.default_rng(1)
    A, b = rng.standard_normal((2_800, 20)), rng.standard_normal(2_800)
    while not stop.is_set():
        np.linalg.lstsq(A, b, rcond=None)


def _ms(fn) -> float:
    """Milliseconds one call of ``fn`` takes."""
    t = time.perf_counter()
    fn()
    return 1e3 * (time.perf_counter() - t)


def measure(repeats: int, seed: int = 0) -> list:
    """Rows (rows, cols, default ms, one-thread ms, ratio) for :data:`SHAPES`."""
    from narx.linalg import _gelsy, one_blas_thread
    rng = np.random.default_rng(seed)
    out = []
    for m, n in SHAPES:
        A = np.asfortranarray(rng.standard_normal((m, n)))
        b = rng.standard_normal(m)
        reps = max(3, repeats // (10 if m >= 1_000_000 else 1))
        runs = {"default": [], "one": []}
        for _ in range(reps):           # alternate: drift hits both alike
            for key, ctx in (("default", contextlib.nullcontext), ("one", one_blas_thread)):
                def solve():
                    with ctx():
                        _gelsy(A, b, max(m, n) * np.finfo(float).eps)
                runs[key].append(_ms(solve))
        d, o = float(np.median(runs["default"])), float(np.median(runs["one"]))
        out.append({"rows": m, "cols": n, "default_ms": d, "one_thread_ms": o,
                    "ratio": d / o})
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=30)
    p.add_argument("--json", help="also write the rows here")
    a = p.parse_args(argv)
    from threadpoolctl import threadpool_info
    blas = [(i["internal_api"], i["num_threads"]) for i in threadpool_info()
            if i["user_api"] == "blas"]
    print(f"BLAS libraries (name, default threads): {blas}; cores: {mp.cpu_count()}")
    doc = {}
    for busy in range(mp.cpu_count() + 1):
        label = "idle" if busy == 0 else f"{busy} busy process{'es' if busy > 1 else ''}"
        stop = mp.Event()
        procs = [mp.Process(target=_spin, args=(stop,), daemon=True) for _ in range(busy)]
        for q in procs:
            q.start()
        time.sleep(0.5 if procs else 0.0)
        try:
            rows = measure(a.repeats)
        finally:
            stop.set()
            for q in procs:
                q.join()
        doc[label] = rows
        print(f"\n{label}:\n| rows x cols | default threads (ms) | one thread (ms) | "
              f"default / one |\n|---|---:|---:|---:|")
        for r in rows:
            print(f"| {r['rows']:,} x {r['cols']} | {r['default_ms']:.3g} | "
                  f"{r['one_thread_ms']:.3g} | {r['ratio']:.2f} |")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(doc, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
