"""Measured benchmark records: cascaded tanks and a DC-DC buck converter.

Typical call::

    python -m benchmarks.real_data                   # 3 seeds, population 300, 60 generations
    python -m benchmarks.real_data --seeds 1 2 3 4 5 --jobs 2 --json real.json

Two records of the project's shared data (``../shared/data`` from the
project root, or the folder in ``$MGGP_SHARED_DATA``; a missing file stops
the study with one ``error:`` line and exit code 2), neither of them hysteretic, used as a newcomer would
use ``mggp fit``: the default search (the published setup: Φ-functions,
multiple shooting with Δm = 100), the search without Φ-functions
(``--no-phi``) and with a constant term as well (``--constant``); each model
simulated in free run on the validation record from its first measured
samples (as many as its largest lag), RMSE over the rest. Linear ARX models
fitted by LS on the same terms every time (orders 2/2, with and without a
constant) set a floor any search should beat.

* **Cascaded tanks** (nonlinearbenchmark.org; Schoukens, Mattsson, Wigren,
  Noël): measured water levels of two tanks with overflow, 1024 samples at
  Ts = 4 s, training ``uEst``→``yEst``, validation ``uVal``→``yVal``.
  Published simulation RMSE on ``yVal``: grey-box 0.191 V (best),
  CT-SUBNET 0.306 V, PNLSS 0.45 V [1]_ (those start from an estimated
  state; ours from the first measured samples).
* **Buck converter** (sysidentpy-data): duty-cycle input ``input``,
  output voltage ``y`` quantised in 0.2 V steps, 1001 training and 999
  validation samples; no published yardstick. Its static curve
  V = (4 − ū)·8 is affine: a model without a constant can only approximate
  the offset.

References
----------
.. [1] Schoukens, M., Mattsson, P., Wigren, T., Noël, J.-P., "Cascaded
   tanks benchmark combining soft and hard nonlinearities", Workshop on
   Nonlinear System Identification Benchmarks, 2016; published results as
   collected in the shared data's ``SOURCES.md``.
"""
from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from narx import Data, Model

from .mr_damper import data_path, shared_data_error

__all__ = ["RECORDS", "SETTINGS", "data_files", "load_record", "run"]

#: name -> (training file, validation file, training columns, validation
#: columns, published free-run RMSE on the validation record)
RECORDS = {
    "cascaded tanks": ("cascaded_tanks.csv", "cascaded_tanks.csv", ("uEst", "yEst"),
                       ("uVal", "yVal"), {"grey-box": 0.191, "CT-SUBNET": 0.306,
                                          "PNLSS": 0.45}),
    "buck converter": ("buck_id.csv", "buck_valid.csv", ("input", "y"), ("input", "y"), {}),
}
#: label -> MGGPRegressor keywords (the CLI option in the label)
SETTINGS = {"default (mggp fit)": {}, "--no-phi": {"use_phi": False},
            "--no-phi --constant": {"use_phi": False, "constant": True}}
ARX = ("y[k-1]", "y[k-2]", "u[k-1]", "u[k-2]")


def load_record(name):
    """(training Data, validation Data) of a record, signals named u and y;
    None when its files are not found."""
    from narx.records.csvdata import read_columns
    ftr, fva, ctr, cva, _ = RECORDS[name]
    ptr, pva = data_path(ftr), data_path(fva)
    if ptr is None or pva is None:
        return None
    out = []
    for path, cols in ((ptr, ctr), (pva, cva)):
        arr, _ = read_columns(path, list(cols))
        out.append(Data(arr[:, :1], arr[:, 1]))
    return tuple(out)


def data_files(names=None) -> list:
    """The shared data files of the records ``names`` (default: all)."""
    return [f for n in (RECORDS if names is None else names) if n in RECORDS
            for f in RECORDS[n][:2]]


def run(seeds=(1, 2, 3), population=300, generations=60, jobs=2, log=print) -> dict:
    from mggp import MGGPRegressor
    import warnings
    out = {}
    for name in RECORDS:
        pair = load_record(name)
        if pair is None:
            log(f"{name}: data files not found (set MGGP_SHARED_DATA)")
            continue
        tr, va = pair
        rows = []
        for label, terms in (("linear ARX(2,2), LS", ARX), ("linear ARX(2,2) + constant, LS",
                                                           ("1",) + ARX)):
            m = Model(list(terms)).fit(tr)
            rmse = m.simulate(va, mode="freerun").rmse           # inf: diverged
            rows.append({"setting": label, "rmse": [rmse], "terms": [len(terms)],
                         "seconds": [0.0]})
        for label, kw in SETTINGS.items():
            row = {"setting": label, "rmse": [], "terms": [], "seconds": []}
            for seed in seeds:
                t0 = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")     # the offset warning (buck)
                    est = MGGPRegressor(population=population, generations=generations,
                                        random_state=seed, n_jobs=jobs, **kw).fit(tr)
                row["seconds"].append(time.perf_counter() - t0)
                row["rmse"].append(est.model_.simulate(va, mode="freerun").rmse)   # inf: diverged
                row["terms"].append(est.model_.n_terms)
                log(f"{name} [{label}] seed {seed}: validation RMSE {row['rmse'][-1]:.4g} "
                    f"({row['terms'][-1]} terms, {row['seconds'][-1]:.1f} s)")
            rows.append(row)
        out[name] = {"rows": rows, "published": RECORDS[name][4]}
    return out


def markdown(res: dict, seeds) -> str:
    md = []
    for name, r in res.items():
        md += [f"**{name}** (validation free-run RMSE; seeds {', '.join(map(str, seeds))})", "",
               "| model | median | min | max | terms | fit s |", "|---|---:|---:|---:|---:|---:|"]
        for row in r["rows"]:
            v = np.array(row["rmse"])
            md.append(f"| {row['setting']} | {np.median(v):.4g} | {v.min():.4g} | "
                      f"{v.max():.4g} | {int(np.median(row['terms']))} | "
                      f"{np.mean(row['seconds']):.1f} |")
        for k, v in r["published"].items():
            md.append(f"| {k}, published | {v} | | | | |")
        md.append("")
    return "\n".join(md)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.real_data",
                                description=__doc__.split("\n")[0])
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3],
                   help="GP seeds, one search each (default 1 2 3)")
    p.add_argument("--population", type=int, default=300, help="(default 300)")
    p.add_argument("--generations", type=int, default=60, help="(default 60)")
    p.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    p.add_argument("--json", help="also write the figures here (default: not written)")
    a = p.parse_args(argv)
    err = shared_data_error(data_files())
    if err:
        print(err, file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    res = run(a.seeds, a.population, a.generations, a.jobs)
    print()
    print(markdown(res, a.seeds))
    print(f"({time.perf_counter() - t0:.0f} s)")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
