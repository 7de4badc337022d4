"""Wall time of the full published MGGP setup on 2 cores (issue 3).

Typical call::

    python -m benchmarks.full_setup                         # the published setup
    python -m benchmarks.full_setup --seed 1 --jobs 2 --json full.json
    NARX_MS_KERNEL=0 python -m benchmarks.full_setup        # general MS kernel
    python -m benchmarks.full_setup --population 50 --generations 5   # a quick look

Setup (the published one, Abreu et al. 2020): the 50,000-sample piezo training record, population 500,
200 generations, crossover 0.8, mutation 0.2, max tree height 5, at most 15
terms, elite 10 %, primitives {×, Φ1, Φ2, q⁻¹..q⁻³}, terminals {y[k-1],
u[k-1]}, MS fitness (Δm = 100), no screen, best-fitness selection, ``n_jobs=2``. Recorded: wall
time of ``fit`` (pool start-up included) and per generation, evaluations
(distinct structures scored; repeats come from the search's cache), the
best fitness, the model, and its free-run MAPE on the training record and
on the validation input u = 40 sin(2πt) (5 s), LS and CLS.
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings

from .speed import _fmt_s, finish, load_note, piezo_record


def run(n=50_000, population=500, generations=200, jobs=2, seed=0, window=100,
        max_terms=15, max_height=5, backend="loky") -> dict:
    import narx.simulation.ms_kernel as msk
    from mggp import MGGPRegressor
    from mggp.fit.choices import AS_SEARCHED
    from narx.systems import piezo_bouc_wen, sine_input
    u, y = piezo_record(n)
    _, uv = sine_input()
    yv = piezo_bouc_wen(uv)
    marks = []
    t_start = [0.0]

    def on_generation(state):
        marks.append((state.generation, time.perf_counter() - t_start[0], state.evaluations))
    est = MGGPRegressor(fitness="ms", window=window, population=population,
                        generations=generations, max_terms=max_terms, max_height=max_height,
                        constraints="steady-state", random_state=seed, n_jobs=jobs,
                        backend=backend, callbacks=[on_generation], use_phi=True,
                        screen=None, select="fitness", **AS_SEARCHED)
    load0 = load_note()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        t_start[0] = time.perf_counter()
        est.fit(u, y)
        wall = time.perf_counter() - t_start[0]
    # loky restarts a worker whose memory grew by > 300 MB ("memory leak"
    # guard); its caches are then lost: count those restarts
    stops = sum("worker stopped" in str(w.message) for w in caught)
    res = {"n": n, "population": population, "generations": generations, "jobs": jobs,
           "backend": backend if jobs > 1 else "sequential",
           "seed": seed, "window": window, "max_terms": max_terms, "max_height": max_height,
           "ms_kernel": "window-major" if msk.ENABLED else "general",
           "load_before": load0, "load_after": load_note(),
           "wall_seconds": wall, "fit_seconds": est.fit_time_,
           "evaluations": int(est.n_evaluations_),
           "evals_per_second": est.n_evaluations_ / wall, "worker_stops": stops,
           "best_fitness": float(est.fitness_), "terms": [str(t) for t in est.model_.terms],
           "theta": est.model_.theta.tolist(),
           "generation_marks": marks}
    if len(marks) > 1:
        res["generation0_seconds"] = marks[0][1]
        res["later_generations_seconds"] = marks[-1][1] - marks[0][1]
        res["later_evals_per_second"] = (marks[-1][2] - marks[0][2]) / max(
            marks[-1][1] - marks[0][1], 1e-9)
    for name, m in (("ls", est.model_), ("cls", est.model_cls_)):
        if m is None:
            res[f"{name}_error"] = getattr(est, "cls_error_", "no model")
            continue
        tr = m.simulate(u, y, mode="freerun")
        va = m.simulate(uv, yv, mode="freerun")
        res[f"{name}_train_mape"] = float(tr.mape)
        res[f"{name}_val_mape"] = float(va.mape)
    return res


def markdown(r: dict) -> str:
    head = (f"Population {r['population']}, {r['generations']} generations, MS Δm = "
            f"{r['window']}, N = {r['n']:,}, max {r['max_terms']} terms, height "
            f"{r['max_height']}, n_jobs = {r['jobs']} ({r.get('backend', 'loky')}), seed {r['seed']}, "
            f"{r['ms_kernel']} MS kernel ({r['load_before']} before, {r['load_after']} after):")
    rows = ["| quantity | value |", "|---|---:|",
            f"| wall time of `fit` | {_fmt_s(r['wall_seconds'])} |",
            f"| evaluations (distinct structures) | {r['evaluations']:,} |",
            f"| evaluations per second, whole run | {r['evals_per_second']:,.0f} |"]
    if "later_evals_per_second" in r:
        rows += [f"| generation 0 (pool start-up, cold columns) | "
                 f"{_fmt_s(r['generation0_seconds'])} |",
                 f"| evaluations per second, generations 1.. | "
                 f"{r['later_evals_per_second']:,.0f} |"]
    rows.append(f"| loky workers stopped mid-run (memory guard) | {r.get('worker_stops', 0)} |")
    rows.append(f"| best fitness (MS MSE, µm²) | {r['best_fitness']:.4g} |")
    for name in ("ls", "cls"):
        if f"{name}_val_mape" in r:
            rows.append(f"| free-run MAPE {name.upper()}, training / validation (%) | "
                        f"{r[f'{name}_train_mape']:.3f} / {r[f'{name}_val_mape']:.3f} |")
        elif f"{name}_error" in r:
            rows.append(f"| {name.upper()} refit | {r[f'{name}_error']} |")
    terms = ", ".join(f"`{t}`" for t in r["terms"])
    return "\n".join([head, ""] + rows + ["", f"Model ({len(r['terms'])} terms): {terms}"])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.full_setup",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=50_000)
    ap.add_argument("--population", type=int, default=500)
    ap.add_argument("--generations", type=int, default=200)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--window", type=int, default=100)
    ap.add_argument("--backend", default="loky", choices=["loky", "threading", "sequential"])
    ap.add_argument("--json", metavar="F")
    a = ap.parse_args(argv)
    res = run(a.n, a.population, a.generations, a.jobs, a.seed, a.window,
              backend=a.backend)
    finish(res, markdown(res), "benchmarks.full_setup", argv, a.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
