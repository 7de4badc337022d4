"""Where the time of a first-pass MS evaluation goes (issue 3).

Typical call::

    python -m benchmarks.eval_phases                  # Δm = 100, 500 random individuals
    python -m benchmarks.eval_phases --window 1000 --individuals 200

A fresh :class:`narx.estimation.fitness.StructureScorer` scores the random individuals
of :mod:`benchmarks.evals` once (a generation 0: every column, Gram entry
and window-major copy is built on first sight), best of ``--repeats``
passes. The scorer's phases are timed by wrapping them:

* ``Gram entries``: ``narx.estimation.gram.fill_gram`` (one compiled pass: a 4-lane
  fixed-order dot product per new pair of columns, and per column with y);
* ``MS kernel``: the window-major multiple-shooting kernel ``_ms_sse``;
* ``columns``: building the regressor columns and input parts on first
  sight (``ColumnStore.get``, numpy);
* ``window-major copies``: ``WindowStore.permute_into``;
* ``LS solve``: the ``gelsy`` call on the normal equations;
* ``Python``: the rest (decoding keys, cache look-ups, array bookkeeping).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from .evals import START, random_term_sets
from .speed import piezo_record

#: (phase, owner, attribute); owners are resolved in :func:`run`
PHASES = (("Gram entries", "fitness", "_fill_gram"),
          ("MS kernel", "ms_kernel", "_ms_sse"),
          ("LS solve", "linalg", "_gelsy"),
          ("columns", "ColumnStore", "get"),
          ("window-major copies", "WindowStore", "permute_into"))


def _timed(acc, key, f):
    def g(*a, **k):
        t0 = time.perf_counter()
        try:
            return f(*a, **k)
        finally:
            acc[key] = acc.get(key, 0.0) + time.perf_counter() - t0
    return g


def run(n=50_000, individuals=500, window=100, repeats=3, seed=0) -> dict:
    import narx.simulation.ms_kernel as msk
    from narx.records.data import as_data
    from narx.estimation.fitness import StructureScorer
    u, y = piezo_record(n)
    sets = random_term_sets(individuals, seed)
    acc: dict = {}
    import narx.estimation.fitness as fit
    import narx.linalg as linalg
    owners = {"fitness": fit, "linalg": linalg, "ms_kernel": msk,
              "ColumnStore": fit.ColumnStore, "WindowStore": msk.WindowStore}
    saved = []
    for key, owner, attr in PHASES:
        obj = owners[owner]
        saved.append((obj, attr, getattr(obj, attr)))
        setattr(obj, attr, _timed(acc, key, getattr(obj, attr)))
    try:
        best = None
        for _ in range(max(1, repeats) + 1):            # the first loads kernels
            sc = StructureScorer(as_data(u, y), "ms", window=window, start=START)
            sc.score(())
            sc.shooting.mse((), np.empty(0), START, sc.bound, sc.input_column)
            acc.clear()
            t0 = time.perf_counter()
            for s in sets:
                sc.score(s)
            t = time.perf_counter() - t0
            if best is None or t < best[0]:
                best = (t, dict(acc))
    finally:
        for owner, attr, f in saved:
            setattr(owner, attr, f)
    t, phases = best
    per = {k: v / len(sets) for k, v in phases.items()}
    per["Python"] = t / len(sets) - sum(per.values())
    return {"n": n, "individuals": len(sets), "window": window,
            "seconds_per_eval": t / len(sets), "phases": per}


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m benchmarks.eval_phases")
    p.add_argument("--n", type=int, default=50_000)
    p.add_argument("--individuals", type=int, default=500)
    p.add_argument("--window", type=int, default=100)
    p.add_argument("--repeats", type=int, default=3)
    a = p.parse_args(argv)
    r = run(a.n, a.individuals, a.window, a.repeats)
    tot = r["seconds_per_eval"]
    print(f"First pass over {r['individuals']} random individuals, MS Δm = {r['window']}, "
          f"N = {r['n']:,}: {tot * 1e6:.0f} µs per evaluation ({1 / tot:,.0f} evals/s)\n")
    print("| phase | µs per evaluation | share |")
    print("|---|---:|---:|")
    for k, v in sorted(r["phases"].items(), key=lambda kv: -kv[1]):
        print(f"| {k} | {v * 1e6:.0f} | {100 * v / tot:.0f} % |")


if __name__ == "__main__":
    main()
