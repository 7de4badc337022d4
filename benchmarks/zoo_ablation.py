"""Does each registered diagnose check change an outcome of the zoo's evaluation table?

Run::

    python -m benchmarks.zoo ablate --seeds 0-149 --json ablate.jsonl      # development seeds
    python -m benchmarks.zoo_ablation ablate.jsonl                          # the table

For each draw of :mod:`narx.systems.zoo` (the study's 4,000 training
samples and validation record, the study budget of :mod:`benchmarks.zoo`),
:func:`ablate_one` runs :func:`mggp.diagnose.diagnose` once with every
registered check (:func:`mggp.diagnose.registry.registered`), timing each,
then once without each check and once without any, and records for every
run the outcomes the evaluation table is made of: the named effects, the
gain (validation RMSE ratio), the recommended model and the separation
note (one amplitude only). The reruns reuse what does not depend on the
checks: the baseline search, the candidates' fits and the outcomes of the
checks still registered (each a function of the baseline and the data
only, computed once in the first run), so a rerun costs the paired test
and the gain. A check that changes no outcome on any draw has not earned
its place in the diagnosis's decision.

The seeds are development seeds only (the ablation decides what the
diagnosis keeps): :func:`narx.systems.zoo.guard` refuses an evaluation seed
before anything runs. One JSON line per draw, appended as it finishes (a
killed run keeps its records; a new run skips the seeds already there).
"""
from __future__ import annotations

import contextlib
import json
import math
import os
import sys
import time
import warnings
from dataclasses import replace
from typing import Dict, List, Sequence

__all__ = ["ablate_one", "ablate", "table", "OUTCOMES"]

#: the outcomes of the evaluation table a check could change
OUTCOMES = ("named", "gain", "recommended", "note")


@contextlib.contextmanager
def _registered_only(tests: Sequence):
    """The diagnose registry holding exactly ``tests`` (in order) inside the
    block; the registry as it was afterwards."""
    from mggp.diagnose.registry import register, registered, unregister
    before = registered()
    for t in before:
        unregister(t.name)
    try:
        for t in tests:
            register(t)
        yield
    finally:
        for t in registered():
            unregister(t.name)
        for t in before:
            register(t)


@contextlib.contextmanager
def _reused_fits():
    """Inside the block, :func:`mggp.diagnose.run.diagnose` computes its
    baseline and each candidate's fit once and reuses them (they depend on
    the data, the budget and the seed, none on the checks)."""
    from mggp.diagnose import run
    base_search, fit_structure = run.baseline_search, run.fit_structure
    memo: Dict[object, object] = {}

    def baseline(*args, **kw):
        if "baseline" not in memo:
            memo["baseline"] = base_search(*args, **kw)
        return memo["baseline"]

    def fitted(st, *args, **kw):
        key = ("candidate", st.name)
        if key not in memo:
            memo[key] = fit_structure(st, *args, **kw)
        return memo[key]

    run.baseline_search, run.fit_structure = baseline, fitted
    try:
        yield
    finally:
        run.baseline_search, run.fit_structure = base_search, fit_structure


def _outcome(dx) -> dict:
    return {"named": list(dx.effects), "gain": _num(dx.gain.ratio),
            "recommended": dx.gain.recommended, "note": dx.separation}


def _num(x):
    return None if x is None or not math.isfinite(x) else float(x)


def changed(a: dict, b: dict) -> List[str]:
    """The outcomes of :data:`OUTCOMES` that differ between two runs (gains
    equal to 1e-9 relative count as equal)."""
    out = []
    for k in OUTCOMES:
        x, y = a.get(k), b.get(k)
        if k == "gain" and x is not None and y is not None:
            if abs(x - y) > 1e-9 * max(abs(x), abs(y), 1.0):
                out.append(k)
        elif x != y:
            out.append(k)
    return out


def ablate_one(seed: int, population: int, generations: int, jobs: int = 1) -> dict:
    """The diagnosis of the draw of ``seed`` with every check, without each,
    and without any (module doc): one record."""
    from benchmarks.zoo import STUDY_N
    from mggp.diagnose import Budget, diagnose
    from mggp.diagnose.registry import registered
    from narx.systems import zoo
    t0 = time.perf_counter()
    d = zoo.draw(seed, n=STUDY_N)
    rec = {"seed": seed, "family": d.family, "hysteretic": d.hysteretic,
           "placement": d.placement, "input_kind": d.input_kind}
    tests = registered()
    seconds: Dict[str, float] = {t.name: 0.0 for t in tests}
    outcomes: Dict[str, object] = {}

    def timed(t):
        def run(ctx):
            if t.name not in outcomes:             # first run: measure and keep
                t1 = time.perf_counter()
                outcomes[t.name] = t.run(ctx)
                seconds[t.name] += time.perf_counter() - t1
            return outcomes[t.name]
        return replace(t, run=run)

    wrapped = [timed(t) for t in tests]
    budget = Budget(population=population, generations=generations)
    runs = {}
    try:
        with warnings.catch_warnings(), _reused_fits():
            warnings.simplefilter("ignore")
            variants = [("all", wrapped)] + [
                (t.name, [w for w in wrapped if w.name != t.name]) for t in tests] + [
                ("none", [])]
            for label, keep in variants:
                t1 = time.perf_counter()
                with _registered_only(keep):
                    dx = diagnose(d.train, validation=d.validation, budget=budget,
                                  seed=seed, jobs=jobs)
                runs[label] = dict(_outcome(dx), seconds=time.perf_counter() - t1)
                if label == "all":
                    rec["evidence"] = [f.effect for f in dx.evidence_findings]
                    rec["timings"] = {k: float(v) for k, v in dx.timings.items()}
    except Exception as exc:                   # a failure is a finding of the study
        rec.update(error=f"{type(exc).__name__}: {exc}", seconds=time.perf_counter() - t0)
        return rec
    base = runs["all"]
    rec.update(runs=runs, check_seconds=seconds,
               changes={k: changed(base, r) for k, r in runs.items() if k != "all"},
               seconds=time.perf_counter() - t0)
    return rec


def ablate(seeds, path, population: int, generations: int, jobs: int = 1,
           say=print) -> List[dict]:
    """:func:`ablate_one` for each development seed not yet in ``path``,
    appending its record there; an evaluation seed raises
    :class:`~narx.systems.zoo.SeedLeak` before anything runs."""
    from benchmarks.zoo import records
    from narx.atomic import atomic_write_text
    from narx.systems import zoo
    with zoo.tuning():
        for s in seeds:
            zoo.guard(s)
        done = records(path)
        have = {r["seed"] for r in done}
        if os.path.exists(path):
            atomic_write_text(path, "".join(json.dumps(r) + "\n" for r in done))
        out = list(done)
        for seed in seeds:
            if seed in have:
                continue
            rec = ablate_one(seed, population, generations, jobs)
            with open(path, "a", encoding="utf-8") as fh:
                fh.write(json.dumps(rec) + "\n")
                fh.flush()
                os.fsync(fh.fileno())
            out.append(rec)
            moved = {k: v for k, v in rec.get("changes", {}).items() if v}
            say(f"seed {seed}: {rec['family']}, named "
                f"{rec.get('runs', {}).get('all', {}).get('named', rec.get('error'))}, "
                f"changed by {moved or 'no check'}, {rec['seconds']:.0f} s")
    return out


def table(recs: List[dict]) -> str:
    """Markdown: per variant (a check removed, or all of them), the draws
    whose outcome changes and which outcome; the check's time per draw."""
    ok = [r for r in recs if "runs" in r]
    names = list(ok[0]["changes"]) if ok else []
    lines = [f"{len(ok)} draws ({len(recs) - len(ok)} failed), seeds "
             f"{min((r['seed'] for r in recs), default='-')}-"
             f"{max((r['seed'] for r in recs), default='-')}.", "",
             "| removed | draws changed | named | gain | recommended | note | "
             "check s/draw (mean) | share of diagnosis time |",
             "|---|---|---|---|---|---|---|---|"]
    total = sum(r["timings"].get("total", 0.0) for r in ok)
    for name in names:
        ch = [r["changes"].get(name, []) for r in ok]
        secs = ([r["check_seconds"].get(name, 0.0) for r in ok] if name != "none" else
                [sum(r["check_seconds"].values()) for r in ok])
        s = sum(secs)
        lines.append(f"| {name} | {sum(bool(c) for c in ch)} | "
                     + " | ".join(str(sum(k in c for c in ch)) for k in OUTCOMES)
                     + f" | {s / max(len(ok), 1):.2f} | "
                     f"{100.0 * s / total if total else float('nan'):.1f} % |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    import argparse
    from benchmarks.zoo import records
    p = argparse.ArgumentParser(prog="python -m benchmarks.zoo_ablation",
                                description="the table of a records file of "
                                            "python -m benchmarks.zoo ablate")
    p.add_argument("file", help="JSON-lines file written by python -m benchmarks.zoo ablate")
    args = p.parse_args(argv)
    recs = records(args.file)
    if not recs:
        print(f"error: {args.file}: no records", file=sys.stderr)
        return 2
    print(table(recs), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
