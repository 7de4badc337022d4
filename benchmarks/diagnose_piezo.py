"""Diagnosis of the published piezo models (PEM model (32), MS model (33) with LS).

Typical use::

    python -m benchmarks.diagnose_piezo --out dx_piezo --jobs 2 --strict   # N = 50,000
    python -m benchmarks.diagnose_piezo --n 10000 --population 60 --generations 10   # quick

Both published structures are fitted by LS on the training record of the
case study (:mod:`benchmarks.casestudy`), then ``mggp.diagnose`` is run
on each with the held-input sine as validation record (the input stops for
1 s while rising and while falling, which is what exposes drift). The
table gives the findings and the free-run RMSE/MAPE of the baseline and of
the extended model on the held sine (the gain) and, for reference, on the
published validation sine 40 sin(2πt). Each case writes its JSON document
and Markdown report under ``--out``. Expected at the default budget: the
PEM model is named ``hysteresis`` (the class of the candidate that wins
the paired test; no candidate names ``prediction-bias``), the MS-LS model
``steady-state-drift``; each case's last line says whether it was. The
exit code is 0 when the study ran; with ``--strict``, 1 when a case misses
an expected finding (a smaller budget or record may miss one).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

from narx import Model
from narx.records.data import Data

from benchmarks.casestudy import MODEL32_TERMS, MODEL33_TERMS, case_data

__all__ = ["run", "main"]

CASES = (("PEM (32), LS", MODEL32_TERMS, "pem", ["hysteresis"]),
         ("MS (33), LS", MODEL33_TERMS, "ms", ["steady-state-drift"]))


def run(n=50_000, seed=0, jobs=1, population=500, generations=100, out=None,
        progress=None):
    """Diagnose both published models; returns one row per case."""
    from mggp.diagnose import Budget, diagnose
    from mggp.diagnose.report import write_report
    cs = case_data(n=n, seed=seed)
    train = Data(cs.u, cs.y)
    held = Data(cs.held.u, cs.yh)
    sine = Data(cs.uv, cs.yv)
    budget = Budget(population=population, generations=generations)
    rows = []
    for name, terms, fitness, expected in CASES:
        model = Model(terms, meta={"fitness": fitness, "estimation": "ls"}).fit(train)
        t0 = time.perf_counter()
        dx = diagnose(train, held, model, budget=budget, seed=seed, jobs=jobs,
                      names=("piezo train", "held sine"), model_name=name, progress=progress)
        row = {"case": name, "expected": expected, "findings": dx.effects,
               "named_expected": all(e in dx.effects for e in expected),
               "evidence": [f.effect for f in dx.evidence_findings],
               "changes": list(dx.changes),
               "chosen": dx.verdict.winner.structure.name if dx.verdict.winner else "baseline",
               "gain": dx.gain.to_dict(),
               "baseline_mape": dx.baseline.mape, "extended_mape": dx.extended.mape,
               "seconds": time.perf_counter() - t0}
        for key, m in (("baseline", dx.baseline.model), ("extended", dx.extended.model)):
            r = m.simulate(sine, mode="freerun")
            row[f"{key}_sine_rmse"], row[f"{key}_sine_mape"] = r.rmse, r.mape
            row[f"{key}_terms"] = m.n_terms
        rows.append(row)
        if out:
            folder = os.path.join(out, "pem" if fitness == "pem" else "ms_ls")
            os.makedirs(folder, exist_ok=True)
            with open(os.path.join(folder, "diagnosis.json"), "w") as fh:
                json.dump(dx.to_dict(), fh, indent=2, allow_nan=False)
            write_report(folder, dx, title=f"piezo case study, {name}")
    return rows


def _fmt(v, spec=".4g"):
    return "diverged" if v is None or v != v or v == float("inf") else format(v, spec)


def table(rows) -> str:
    """Markdown table of the rows."""
    out = ["| baseline | findings | extension | held sine RMSE (MAPE %) baseline -> extended "
           "| ratio | sine 40 sin(2πt) MAPE % baseline -> extended |",
           "|---|---|---|---|---:|---|"]
    for r in rows:
        g = r["gain"]
        out.append(f"| {r['case']} | {', '.join(r['findings']) or 'none'} | {r['chosen']} "
                   f"({r['extended_terms']} terms) | {_fmt(g['baseline'])} "
                   f"({_fmt(r['baseline_mape'], '.3g')}) -> {_fmt(g['extended'])} "
                   f"({_fmt(r['extended_mape'], '.3g')}) | {_fmt(g['ratio'], '.3g')} | "
                   f"{_fmt(r['baseline_sine_mape'], '.3g')} -> "
                   f"{_fmt(r['extended_sine_mape'], '.3g')} |")
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--n", type=int, default=50_000,
                   help="samples of the training record (default 50000)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the record and of the diagnosis's searches (default 0)")
    p.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    p.add_argument("--population", type=int, default=500,
                   help="population of the diagnosis's searches (default 500)")
    p.add_argument("--generations", type=int, default=100,
                   help="generations of the diagnosis's searches (default 100)")
    p.add_argument("--strict", action="store_true",
                   help="exit 1 when a case misses an expected finding (default: exit 0 "
                        "once the study ran)")
    p.add_argument("--out", default=None,
                   help="folder for JSON documents and reports (default: none written)")
    p.add_argument("--json", default=None, help="write the rows here (default: not written)")
    a = p.parse_args(argv)
    say = lambda msg: print(msg, file=sys.stderr, flush=True)  # noqa: E731
    rows = run(a.n, a.seed, a.jobs, a.population, a.generations, a.out, say)
    print(table(rows))
    for r in rows:
        print(f"{r['case']}: expected {', '.join(r['expected'])} -> "
              f"{'named' if r['named_expected'] else 'NOT named'}; "
              f"{r['seconds']:.0f} s; changes: {'; '.join(r['changes'])}")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=2)
    return 1 if a.strict and not all(r["named_expected"] for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
