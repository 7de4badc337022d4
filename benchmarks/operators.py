"""Memory operators as regressors: Φ-only, operators only, both.

Typical use::

    python -m benchmarks.operators                      # 3 seeds, default budget
    python -m benchmarks.operators --cases pi backlash --seeds 1 --generations 5

Cases (training output with 40 dB white noise, validation against the
noise-free response):

``pi``
    A Prandtl-Ishlinskii operator of five radii before first-order dynamics
    (:func:`narx.systems.pi_first_order`), :func:`narx.systems.operator_record`.
``backlash``
    A backlash between two first-order stages (second-order dynamics,
    :func:`narx.systems.backlash_second_order`).
``piezo``
    The piezo Bouc-Wen case study (:func:`benchmarks.casestudy.case_data`,
    ``--piezo-n`` training samples), validated on the held sine.
``damper``
    The shared MR damper record (:mod:`benchmarks.mr_damper`: inputs E, v;
    test part, free-run RRSE instead of RMSE).

Each case is searched at the same budget with three sets:
``phi`` (×, q, Φ1, Φ2: the default), ``ops`` (×, q and the operators
``play,dengtan``, ``--no-phi``) and ``both``; the operators enter as
:class:`mggp.MGGPRegressor` puts them by default (``operator_entry``:
added stepwise after the search, :mod:`mggp.fit.operator_stage`). The table gives, per case and
set, the median over seeds of the validation free-run error and of the
search time, and the ratios to ``phi``. Goals: on pi and backlash the
``ops`` or ``both`` error at most 1/3 of ``phi``; on piezo no worse; search
time with operators at most 1.5× ``phi``.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from narx import Data, rrse
from narx.systems import operator_record

__all__ = ["CASES", "SETS", "case_records", "run"]

CASES = ("pi", "backlash", "piezo", "damper")

#: primitive sets compared: (use_phi, operators)
SETS = {"phi": (True, None), "ops": (False, ("play", "dengtan")),
        "both": (True, ("play", "dengtan"))}


def _noisy(y, snr_db, rng):
    return y + np.std(y) * 10.0 ** (-snr_db / 20.0) * rng.standard_normal(y.size)


def case_records(case, piezo_n=10_000):
    """``(train Data, validation Data, metric name, fitness)`` of a case;
    the validation output is noise-free (the damper's test part is the
    record's)."""
    if case in ("pi", "backlash"):
        r = operator_record(case, n=3000, seed=0, snr_db=40)
        return Data(r.u, r.y), Data(r.u_val, r.y_val_clean), "RMSE", "ms"
    if case == "piezo":
        from benchmarks.casestudy import case_data
        cs = case_data(n=piezo_n, seed=0)
        y = _noisy(cs.y, 40.0, np.random.default_rng(0))
        return Data(cs.u, y), Data(cs.held.u, cs.yh), "RMSE", "ms"
    if case == "damper":
        from benchmarks.mr_damper import damper_path, load_damper
        path = damper_path()
        if path is None:
            return None
        tr, te = load_damper(path)
        ins = ("E", "v")
        return (Data(tr[:, :2], tr[:, 2], inputs=ins, output="f"),
                Data(te[:, :2], te[:, 2], inputs=ins, output="f"), "RRSE", "freerun")
    raise ValueError(f"case must be one of {', '.join(CASES)}, got {case!r}")


def _val_error(model, val, metric):
    r = model.simulate(val, mode="freerun")
    if r.diverged:
        return float("inf")
    y, yh = val.y[r.start:], r.y_hat[r.start:]
    if metric == "RRSE":
        return float(rrse(y, yh))
    return float(np.sqrt(np.mean((y - yh) ** 2)))


def run(cases=CASES, seeds=(1, 2, 3), population=100, generations=20, max_terms=10,
        max_height=4, jobs=1, piezo_n=10_000, select="fitness", log=print):
    """Run the comparison; returns ``{"rows": [...], "markdown": str}``."""
    from mggp import MGGPRegressor
    rows = []
    for case in cases:
        rec = case_records(case, piezo_n)
        if rec is None:
            log(f"{case}: data not found, skipped")
            continue
        train, val, metric, fitness = rec
        for name, (use_phi, ops) in SETS.items():
            for seed in seeds:
                est = MGGPRegressor(fitness=fitness, population=population,
                                    generations=generations, max_terms=max_terms,
                                    max_height=max_height, use_phi=use_phi, operators=ops,
                                    inputs=train.inputs, output=train.output,
                                    select=select, random_state=seed, n_jobs=jobs)
                t0 = time.perf_counter()
                est.fit(train)
                dt = time.perf_counter() - t0
                err = _val_error(est.model_, val, metric)
                rows.append({"case": case, "set": name, "seed": seed, "metric": metric,
                             "val_error": err, "fit_time": dt,
                             "terms": est.model_.term_texts})
                log(f"{case:8s} {name:4s} seed {seed}: validation {metric} {err:.4g} "
                    f"({dt:.1f} s, {est.model_.n_terms} terms)")
    return {"rows": rows, "markdown": _table(rows)}


def _median(rows, case, name, key):
    v = [r[key] for r in rows if r["case"] == case and r["set"] == name]
    return float(np.median(v)) if v else float("nan")


def _table(rows):
    md = ["| case | metric | Φ-only | operators | both | ops/Φ | both/Φ | time Φ s "
          "| time ops/Φ | time both/Φ |", "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for case in dict.fromkeys(r["case"] for r in rows):
        e = {n: _median(rows, case, n, "val_error") for n in SETS}
        t = {n: _median(rows, case, n, "fit_time") for n in SETS}
        metric = next(r["metric"] for r in rows if r["case"] == case)
        md.append(f"| {case} | {metric} | {e['phi']:.4g} | {e['ops']:.4g} | {e['both']:.4g} "
                  f"| {e['ops'] / e['phi']:.2f} | {e['both'] / e['phi']:.2f} "
                  f"| {t['phi']:.1f} | {t['ops'] / t['phi']:.2f} | {t['both'] / t['phi']:.2f} |")
    return "\n".join(md)


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m benchmarks.operators", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    p.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3])
    p.add_argument("--population", type=int, default=100)
    p.add_argument("--generations", type=int, default=20)
    p.add_argument("--max-terms", type=int, default=10)
    p.add_argument("--max-height", type=int, default=4)
    p.add_argument("--piezo-n", type=int, default=10_000)
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--select", choices=["fitness", "freerun", "hold"], default="fitness",
                   help="final structure among the best of each run (MGGPRegressor select)")
    p.add_argument("--json", metavar="PATH", help="write the rows as JSON")
    a = p.parse_args(argv)
    res = run(a.cases, a.seeds, a.population, a.generations, a.max_terms, a.max_height,
              a.jobs, a.piezo_n, a.select)
    print()
    print(res["markdown"])
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(res["rows"], fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
