"""Time and peak memory against record length N: is cost per sample constant?

Typical call::

    python -m benchmarks.scaling                          # N = 1e4, 1e5, 1e6, best of 3
    python -m benchmarks.scaling --n 10000 100000 --stages csv ls freerun
    python -m benchmarks.scaling --json scaling.json --markdown

Each (stage, N) runs in fresh subprocesses, so one stage's caches and
allocations never count for another. Each loads the record (``.npy``) and
warms every compiled kernel on a 2,000-sample record. ``--repeats`` of
them time one call (the fastest counts) and take its peak RSS increase
(the peak counter is reset through ``/proc/self/clear_refs``; without it
the lifetime ``ru_maxrss`` is used); one more takes the peak of the memory
traced by ``tracemalloc`` during the call. The traced peak is the figure to
compare across N: the RSS increase under-states small runs, whose arrays
fit in memory the allocator already holds (``tracemalloc`` in turn misses
numba's own few arrays).
The call is:

``csv``      ``narx.records.csvdata.read_csv`` of the N-row file (columns t, u, y)
``ls``       ``Model(MODEL33).fit`` — LS of the 15-term MS model (33)
``freerun``  ``Model.simulate(..., mode='freerun')`` of that fitted model
``ms``       ``StructureScorer(fitness='ms', window=100).evaluate`` — LS from
             cached Gram entries + the multiple-shooting simulation, columns
             built from scratch (the first score of a structure in a search)
``mggp``     ``MGGPRegressor(fitness='ms', population=20, generations=2,
             max_terms=15, random_state=1, n_jobs=1).fit`` — a short search

Reported per row: wall time, time per sample (per structure and sample
for ``mggp``), the peak RSS increase, the traced peak and the traced peak
per sample. The record is the piezo Bouc-Wen training signal
(``training_input(N, seed=1)``), written once per N to a temporary folder.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

from .casestudy import MODEL33_TERMS as MODEL33      # the published MS model (33)

STAGES = ("csv", "ls", "freerun", "ms", "mggp")
MGGP = dict(fitness="ms", window=100, population=20, generations=2, max_terms=15,
            random_state=1, n_jobs=1)


# ------------------------------------------------------------------ worker side
def _rss_kb() -> tuple:
    """(current RSS, peak RSS) in kB from /proc, or ru_maxrss twice."""
    try:
        cur = peak = None
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmRSS:"):
                    cur = int(line.split()[1])
                elif line.startswith("VmHWM:"):
                    peak = int(line.split()[1])
        return cur, peak
    except OSError:                                     # pragma: no cover
        m = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        return m, m


def _reset_peak() -> bool:
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        return True
    except OSError:                                     # pragma: no cover
        return False


def _warm():
    """Compile/load every kernel on a small record (not measured)."""
    import narx
    from mggp import MGGPRegressor
    from narx.estimation.fitness import StructureScorer
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(2000, seed=2)
    y = piezo_bouc_wen(u)
    m = narx.Model(MODEL33).fit(u, y)
    m.simulate(u, y, mode="freerun")
    StructureScorer(narx.Data(u, y), "ms", window=100, start=16).evaluate(m.terms)
    MGGPRegressor(**dict(MGGP, population=6, generations=1)).fit(u, y)


def worker(stage: str, folder: str, n: int, trace: bool = False) -> dict:
    import narx
    from narx.records.csvdata import read_csv
    _warm()
    ud = np.load(os.path.join(folder, f"uy_{n}.npy"))
    u, y = np.ascontiguousarray(ud[:, 0]), np.ascontiguousarray(ud[:, 1])
    theta = None
    if stage == "freerun":
        theta = narx.Model(MODEL33).fit(u, y).theta
    data = narx.Data(u, y)
    if trace:
        import tracemalloc
        tracemalloc.start()
    exact = _reset_peak()
    before, _ = _rss_kb()
    t0 = time.perf_counter()
    info = {}
    if stage == "csv":
        d = read_csv(os.path.join(folder, f"rec_{n}.csv"))
        info["rows"] = d.n
    elif stage == "ls":
        m = narx.Model(MODEL33).fit(data)
        info["rank"] = m.fit_info_["rank"]
    elif stage == "freerun":
        r = narx.Model(MODEL33, theta).simulate(data, mode="freerun")
        info["mape"] = r.mape
    elif stage == "ms":
        from narx.estimation.fitness import StructureScorer
        sc = StructureScorer(data, "ms", window=100, start=16)
        mse, _ = sc.evaluate(narx.Model(MODEL33).terms)
        info["mse"] = mse
    elif stage == "mggp":
        from mggp import MGGPRegressor
        est = MGGPRegressor(**MGGP).fit(data)
        info["evaluations"] = est.n_evaluations_
        info["terms"] = len(est.model_.terms)
    else:
        raise ValueError(f"unknown stage {stage!r}")
    dt = time.perf_counter() - t0
    _, peak = _rss_kb()
    if trace:
        info["traced_peak_mb"] = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
    return {"stage": stage, "n": n, "seconds": dt, "rss_before_mb": before / 1024,
            "peak_mb": peak / 1024, "delta_mb": max(peak - before, 0) / 1024,
            "peak_exact": exact, **info}


# ------------------------------------------------------------------ driver side
def make_records(folder: str, sizes) -> None:
    from narx.systems import piezo_bouc_wen, training_input
    for n in sizes:
        u = training_input(n, seed=1)
        y = piezo_bouc_wen(u)
        np.save(os.path.join(folder, f"uy_{n}.npy"), np.c_[u, y])
        t = np.arange(n) * 1e-3
        np.savetxt(os.path.join(folder, f"rec_{n}.csv"), np.c_[t, u, y], delimiter=",",
                   header="t,u,y", comments="", fmt="%.17g")


def _spawn(stage, folder, n, trace) -> dict:
    cmd = [sys.executable, "-m", "benchmarks.scaling", "--worker", stage, "--dir", folder,
           "--n", str(n)] + (["--trace"] if trace else [])
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{stage} at N={n} failed:\n{r.stderr[-2000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def run(stages, sizes, folder, repeats=1) -> list:
    rows = []
    for stage in stages:
        for n in sizes:
            timed = [_spawn(stage, folder, n, False) for _ in range(repeats)]
            row = min(timed, key=lambda r: r["seconds"])
            row["traced_peak_mb"] = _spawn(stage, folder, n, True)["traced_peak_mb"]
            work = n * row.get("evaluations", 1)
            row["us_per_sample"] = 1e6 * row["seconds"] / work
            row["bytes_per_sample"] = row["traced_peak_mb"] * 2**20 / n
            rows.append(row)
            print(f"{stage:>8s} N={n:>9,d}  {row['seconds']:8.3f} s  "
                  f"{row['us_per_sample']:8.4f} µs/sample  RSS +{row['delta_mb']:7.1f} MB  "
                  f"traced {row['traced_peak_mb']:7.1f} MB "
                  f"({row['bytes_per_sample']:5.0f} B/sample)", flush=True)
    return rows


def markdown(rows) -> str:
    what = {"csv": "CSV load (`read_csv`)", "ls": "LS fit, 15 terms (model 33)",
            "freerun": "free-run simulation, 15 terms", "ms": "MS score (LS + Δm=100)",
            "mggp": "MGGP, pop 20, 2 generations"}
    out = ["| stage | N | time (s) | µs per sample | peak RSS increase (MB) | "
           "traced peak (MB) | traced bytes per sample |", "|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        per = f"{r['us_per_sample']:.3f}"
        if r["stage"] == "mggp":
            per += f" (per structure; {r['evaluations']} structures)"
        out.append(f"| {what[r['stage']]} | {r['n']:,} | {r['seconds']:.3f} | {per} | "
                   f"{r['delta_mb']:.1f} | {r['traced_peak_mb']:.1f} | "
                   f"{r['bytes_per_sample']:.0f} |")
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, nargs="+", default=[10_000, 100_000, 1_000_000])
    p.add_argument("--stages", nargs="+", choices=STAGES, default=list(STAGES))
    p.add_argument("--repeats", type=int, default=3,
                   help="timing subprocesses per row; the fastest counts (default 3)")
    p.add_argument("--json", metavar="FILE", help="write the rows as JSON")
    p.add_argument("--markdown", action="store_true", help="print a Markdown table")
    p.add_argument("--worker", choices=STAGES, help=argparse.SUPPRESS)
    p.add_argument("--dir", help=argparse.SUPPRESS)
    p.add_argument("--trace", action="store_true", help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.worker:
        print(json.dumps(worker(a.worker, a.dir, a.n[0], a.trace)))
        return 0
    with tempfile.TemporaryDirectory(prefix="mggp-scaling-") as folder:
        t0 = time.perf_counter()
        make_records(folder, a.n)
        print(f"records written in {time.perf_counter() - t0:.1f} s "
              f"({platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
              f"Python {platform.python_version()})", flush=True)
        rows = run(a.stages, a.n, folder, a.repeats)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=2)
    if a.markdown:
        print(markdown(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
