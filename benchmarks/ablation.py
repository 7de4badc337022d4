"""The default against itself with one automatic stage fixed at a time (issue 19).

Typical use::

    python -m benchmarks.ablation "cascaded tanks" --seeds 1 2 3 4 5 6 --jsonl tanks.jsonl
    python -m benchmarks.ablation "piezo (simulated)" --settings default "screen none"
    python -m benchmarks.ablation "piezo (simulated)" --settings default --seeds 3 6 --pilot 0.4
    python -m benchmarks.ablation "buck converter" --settings default --holdout-ends head tail

For one record of :data:`benchmarks.panel.RECORDS`, :class:`mggp.MGGPRegressor`
with its defaults and with each setting of :data:`SETTINGS` (one automatic
stage overridden toward the panel's best grid settings, and those grid
settings themselves), at the default budget and one job. Each row: the
validation free-run RMSE (as :mod:`benchmarks.panel` scores it), the number
of terms, the structure the selection took and the automatic choices made
(``choices_``). Prints one line per fit and a table of the RMSE per seed
with the median.
"""
from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np

__all__ = ["SETTINGS", "fit_row", "table"]

#: label -> MGGPRegressor keywords (the default's other parameters stay 'auto')
SETTINGS = {
    "default": {},
    "screen none": dict(screen=None),
    "select fitness": dict(select="fitness"),
    "select freerun": dict(select="freerun"),
    "size search": dict(size="search"),
    "no constant": dict(constant=False),
    "no local search": dict(local_search=False),
    "no phi": dict(use_phi=False),
    "no phi, no constant": dict(use_phi=False, constant=False),
    "phi": dict(use_phi=True),
    "best(no phi)": dict(use_phi=False, constant=False, screen=None, select="fitness",
                         size="search"),
    "best(phi)": dict(use_phi=True, constant=False, screen=None, select="fitness",
                      size="search"),
    "phi, size search": dict(use_phi=True, size="search"),
    "phi, no constant": dict(use_phi=True, constant=False),
    "phi, screen none": dict(use_phi=True, screen=None),
    "phi, no constant, size search": dict(use_phi=True, constant=False, size="search"),
    "max degree 3": dict(max_degree=3),
    "bic": dict(criterion="bic"),
}


def fit_row(tr, va, seed: int, kw: dict, budget: dict = None) -> dict:
    """One fit at one job: its validation free-run RMSE (inf: diverged), the
    held-out free-run RMSE of its structure on the training record
    (:func:`mggp.fit.choices.heldout_rmse`) and what it chose."""
    from mggp import MGGPRegressor
    from mggp.fit.choices import heldout_rmse
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est = MGGPRegressor(random_state=seed, n_jobs=1, **(budget or {}), **kw).fit(tr)
    m = est.get_best()
    held = heldout_rmse(tuple(est.terms_), tr, est.registry)
    sim = m.simulate(va, mode="freerun")
    rmse = float("inf") if sim.diverged or not np.isfinite(sim.rmse) else float(sim.rmse)
    return dict(seed=seed, rmse=rmse, heldout_rmse=held, terms=m.n_terms,
                search_terms=len(est.search_terms_),
                seconds=time.perf_counter() - t0, structure=[str(t) for t in est.terms_],
                local_search=len(est.local_search_ or []),
                screen_rejected=getattr(est, "screen_rejected_", None),
                choices=getattr(est, "choices_", {}))


def table(rows: dict) -> str:
    """Markdown: setting, RMSE per seed, median (``rows``: {label: [row per seed]})."""
    seeds = sorted({r["seed"] for rs in rows.values() for r in rs})
    md = ["| setting | " + " | ".join(f"seed {s}" for s in seeds) + " | median |",
          "|---|" + "---:|" * (len(seeds) + 1)]
    for label, rs in rows.items():
        by = {r["seed"]: r for r in rs}
        cells = [f"{by[s]['rmse']:.4g} ({by[s]['terms']})" if s in by else "" for s in seeds]
        med = float(np.median([r["rmse"] for r in rs]))
        md.append(f"| {label} | " + " | ".join(cells) + f" | {med:.4g} |")
    return "\n".join(md)


def main(argv=None) -> int:
    from .panel import RECORDS
    p = argparse.ArgumentParser(prog="python -m benchmarks.ablation")
    p.add_argument("record", choices=list(RECORDS))
    p.add_argument("--settings", nargs="+", choices=list(SETTINGS), default=list(SETTINGS))
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    p.add_argument("--population", type=int)
    p.add_argument("--generations", type=int)
    p.add_argument("--pilot", type=float, help="mggp.fit.choices.PILOT for these fits (a trial "
                   "of a longer or shorter class pilot; default: the module's)")
    p.add_argument("--holdout-ends", nargs="+", choices=["head", "tail"],
                   help="mggp.fit.choices.HOLDOUT_ENDS for these fits (a trial of held-out "
                   "errors at both ends of the record; default: the module's)")
    p.add_argument("--jsonl", help="append one JSON line per fit here")
    a = p.parse_args(argv)
    budget = {k: v for k, v in (("population", a.population),
                                ("generations", a.generations)) if v is not None}
    import mggp.fit.choices
    if a.pilot is not None:
        mggp.fit.choices.PILOT = a.pilot
    if a.holdout_ends:
        mggp.fit.choices.HOLDOUT_ENDS = tuple(a.holdout_ends)
    tr, va = RECORDS[a.record]()
    rows = {}
    for label in a.settings:
        for seed in a.seeds:
            r = fit_row(tr, va, seed, SETTINGS[label], budget)
            rows.setdefault(label, []).append(r)
            print(f"{a.record} [{label}] seed {seed}: RMSE {r['rmse']:.4g}, {r['terms']} terms "
                  f"(selected {r['search_terms']}), {r['seconds']:.0f} s", flush=True)
            if a.jsonl:
                with open(a.jsonl, "a") as f:
                    f.write(json.dumps(dict(record=a.record, setting=label, **r),
                                       default=str) + "\n")
    print()
    print(table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
