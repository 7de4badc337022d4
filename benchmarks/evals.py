"""Evaluations per second of random individuals with MS fitness (issue 3).

Typical call::

    python -m benchmarks.evals                          # 500 individuals, toolbox on 20
    python -m benchmarks.evals --individuals 500 --sample 20 --window 1000 \\
        --toolbox-k 1000 100 10 --repeats 3 --json evals.json
    python -m benchmarks.evals --no-peers --individuals 100   # ours only

Individuals: ``mggp.gp.operators.random_individual`` with our primitive set
(×, Φ1, Φ2, q⁻¹..q⁻³ over y[k-1], u[k-1]), up to 15 genes of height <= 5,
decoded to distinct terms; terms that vanish identically (``Phi1(a,a)``)
are dropped, as ``MGGPRegressor`` does. Record: the 50,000-sample piezo
training set. Fitness: LS on rows ``start = 16`` onwards (the largest lag of
height 5), then the MSE of multiple shooting with windows of Δm samples.

Measured in the same run:

* ours, sequential (``narx.estimation.fitness.StructureScorer``): *cold* = a fresh
  scorer's first pass (every term's columns and Gram entries built on
  first sight; best of repeats; the scorer's construction, once per worker
  and run, timed apart), *warm* = later passes (all cached, as in a GP
  run once the population's terms have been seen); with the window-major MS kernel
  (:mod:`narx.simulation.ms_kernel`, the default) and with the general kernel;
* ours, ``mggp.gp.evaluate.Evaluator`` with ``n_jobs=2`` (loky processes; pool
  start-up timed apart), cold and warm; its values must equal the
  sequential ones bit for bit;
* the published toolbox (``compile_model`` + ``ls`` + ``score_ksa``, its own
  timer inside its venv) on the first ``--sample`` individuals, against ours
  on exactly those individuals: cold = every cache emptied before each
  individual (``StructureScorer.clear_cache``: nothing reused, like the
  toolbox), warm = best of repeats on a warm scorer.
  The toolbox's ``score_ksa`` windows hold lagMax+1+k samples of which k are
  simulated, so ``k = Δm`` is the like-for-like setting. Individuals whose
  regressors the toolbox rejects (its ``ls`` raises ``LinAlgError`` when
  cond < 1e-10) are counted and left out of the ratio. The same comparison
  is made on the 15-term published MS model (33), the size of the
  individuals a GP run converges to (random ones average ~5 terms).
"""
from __future__ import annotations

import argparse
import random
import sys
import time

import numpy as np

from .speed import MODEL33, _fmt_s, finish, load_note, piezo_record

START = 16          # max_lag_for_height(5)


def random_term_sets(count: int, seed: int = 0, max_terms: int = 15, max_height: int = 5):
    """``count`` random individuals decoded to non-empty tuples of terms."""
    from mggp.gp.primitives import identically_zero
    from mggp.gp.operators import random_individual
    from mggp.gp.primitives import Decoder, make_pset
    from narx.language.phi import default_registry
    pset, rng = make_pset(), random.Random(seed)
    dec, reg = Decoder(pset.signals), default_registry()
    sets = []
    while len(sets) < count:
        ind = random_individual(pset, rng, max_terms=max_terms, max_height=max_height)
        terms = tuple(t for t in dec.decode_individual(ind) if not identically_zero(t, reg))
        if terms:
            sets.append(terms)
    return sets


def _pass(score, sets):
    t0 = time.perf_counter()
    vals = [score(s) for s in sets]
    return time.perf_counter() - t0, vals


def sequential(u, y, sets, window: int, repeats: int, fast: bool) -> dict:
    """Cold and warm throughput of a StructureScorer. Cold: best of
    ``repeats`` first passes, each on a fresh scorer and a fresh record
    (``narx.Data`` caches input parts, so a reused one would not be cold),
    the scorer's construction (allocating and writing its column stores,
    once per worker and run) timed apart. Warm: best of ``repeats`` further
    passes."""
    import narx.simulation.ms_kernel as msk
    from narx.records.data import as_data
    from narx.estimation.fitness import StructureScorer
    old = msk.ENABLED
    msk.ENABLED = fast
    try:
        cold = setup = float("inf")
        for _ in range(max(1, repeats)):
            t0 = time.perf_counter()
            sc = StructureScorer(as_data(u, y), "ms", window=window, start=START)
            sc.score(())                                 # empty set: no column built
            # the window store
            sc.shooting.mse((), np.empty(0), START, sc.bound, sc.input_column)
            setup = min(setup, time.perf_counter() - t0)
            t, vals = _pass(sc.score, sets)
            cold = min(cold, t)
        warm = min(_pass(sc.score, sets)[0] for _ in range(max(1, repeats)))
    finally:
        msk.ENABLED = old
    return {"cold_seconds": cold, "warm_seconds": warm, "cold_eps": len(sets) / cold,
            "warm_eps": len(sets) / warm, "setup_seconds": setup, "values": vals}


def parallel(u, y, sets, window: int, repeats: int, n_jobs: int) -> dict:
    """Cold and warm throughput of the Evaluator (fresh scorers in the workers)."""
    from mggp.gp.evaluate import Evaluator
    from narx.records.data import as_data
    data = as_data(u, y)
    t0 = time.perf_counter()
    spin = Evaluator(data, "ms", window=window, start=START + 1, n_jobs=n_jobs)
    spin(sets[:4 * n_jobs])                     # start the pool, load kernels
    startup = time.perf_counter() - t0
    ev = Evaluator(data, "ms", window=window, start=START, n_jobs=n_jobs)
    cold, vals = _pass(lambda batch: ev(batch), [sets])
    warm = min(_pass(lambda batch: ev(batch), [sets])[0] for _ in range(max(1, repeats)))
    ev.close()
    spin.close()
    return {"n_jobs": n_jobs, "startup_seconds": startup, "cold_seconds": cold,
            "warm_seconds": warm, "cold_eps": len(sets) / cold, "warm_eps": len(sets) / warm,
            "values": vals[0]}


def versus_toolbox(u, y, sets, ks, repeats: int) -> dict:
    """Per-individual times, toolbox against ours, on the same individuals."""
    from benchmarks import peers as pe
    from narx.records.data import as_data
    from narx.estimation.fitness import StructureScorer
    out = {}
    for k in ks:
        rows, rejected, reason = [], 0, None
        warm_sc = StructureScorer(as_data(u, y), "ms", window=k, start=START)
        for terms in sets:
            texts = [str(t) for t in terms]
            try:
                r = pe.toolbox_ls_ms_score(texts, u, y, k=k, fitness="ms", repeats=repeats)
            except pe.PeerError as exc:
                if "LinAlgError" not in str(exc):
                    raise
                rejected += 1
                continue
            if not r.get("available"):
                reason = r.get("reason", "unavailable")
                break
            cold = float("inf")
            for _ in range(max(1, repeats)):
                warm_sc.clear_cache()               # nothing cached, like the toolbox
                t0 = time.perf_counter()
                ours = warm_sc.score(terms)
                cold = min(cold, time.perf_counter() - t0)
            warm = min(_pass(warm_sc.score, [terms])[0] for _ in range(max(1, repeats)))
            rows.append({"terms": texts, "toolbox_seconds": r["seconds"],
                         "toolbox_ls": r["ls_seconds"], "toolbox_score": r["score_seconds"],
                         "toolbox_mse": r["score"], "ours_cold": cold, "ours_warm": warm,
                         "ours_mse": ours})
        if reason:
            out[str(k)] = {"available": False, "reason": reason}
            continue
        res = {"available": True, "k": k, "scored": len(rows), "rejected": rejected,
               "rows": rows}
        if rows:
            tb = np.array([r["toolbox_seconds"] for r in rows])
            oc = np.array([r["ours_cold"] for r in rows])
            ow = np.array([r["ours_warm"] for r in rows])
            res.update(toolbox_mean=float(tb.mean()), ours_cold_mean=float(oc.mean()),
                       ours_warm_mean=float(ow.mean()),
                       ratio_cold=float(tb.sum() / oc.sum()),
                       ratio_warm=float(tb.sum() / ow.sum()),
                       median_ratio_cold=float(np.median(tb / oc)),
                       median_ratio_warm=float(np.median(tb / ow)),
                       mean_terms=float(np.mean([len(r["terms"]) for r in rows])))
        out[str(k)] = res
    return out


def run(n=50_000, individuals=500, sample=20, window=1000, ks=(1000, 100, 10), repeats=3,
        n_jobs=2, seed=0, peers=True) -> dict:
    from narx import parse_terms
    u, y = piezo_record(n)
    sets = random_term_sets(individuals, seed)
    ks = tuple(dict.fromkeys(ks if peers else (window,)))
    res = {"n": n, "individuals": len(sets), "window": window, "start": START,
           "repeats": repeats, "seed": seed, "load_before": load_note(),
           "mean_terms": float(np.mean([len(s) for s in sets])),
           "max_terms": int(max(len(s) for s in sets)),
           "distinct_terms": len({t for s in sets for t in s})}
    sequential(u, y, sets[:5], window, 1, True)          # load compiled kernels
    sequential(u, y, sets[:5], window, 1, False)
    fast = sequential(u, y, sets, window, repeats, True)
    gen = sequential(u, y, sets, window, repeats, False)
    res["identical_fast_vs_general"] = fast["values"] == gen["values"]
    par = parallel(u, y, sets, window, repeats, n_jobs)
    res["identical_sequential_vs_parallel"] = par["values"] == fast["values"]
    res["finite"] = int(np.isfinite(fast["values"]).sum())
    for d in (fast, gen, par):
        d.pop("values")
    res.update(sequential_fast=fast, sequential_general=gen, parallel=par)
    # throughput over all individuals at every compared Δm
    res["throughput"] = {str(window): fast}
    for k in ks:
        if str(k) not in res["throughput"]:
            d = sequential(u, y, sets, k, repeats, True)
            d.pop("values")
            res["throughput"][str(k)] = d
    if peers:
        res["toolbox"] = versus_toolbox(u, y, sets[:sample], ks, repeats)
        # a GP-sized individual: the published 15-term MS model (33)
        res["toolbox_model33"] = versus_toolbox(u, y, [tuple(parse_terms(MODEL33))], ks,
                                                repeats)
    res["load_after"] = load_note()
    return res


def _summary(res: dict) -> list:
    """The goal's table: per Δm, toolbox against ours in evaluations/s."""
    tb = {k: t for k, t in (res.get("toolbox") or {}).items()
          if t.get("available") and t["scored"]}
    if not tb:
        return []
    lines = ["", "**Evaluations per second, toolbox against ours** (toolbox: mean over "
             "the sampled individuals; ours on the same individuals, and over all "
             f"{res['individuals']} random individuals):", "",
             "| k = Δm | toolbox | ours, nothing cached | ours, first pass over all "
             "(fresh scorer) | ours, warm | first pass / toolbox | warm / toolbox | "
             "nothing cached / toolbox |", "|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for k, t in tb.items():
        th = res["throughput"].get(k)
        tb_eps = 1.0 / t["toolbox_mean"]
        first = th["cold_eps"] if th else float("nan")
        warm = th["warm_eps"] if th else float("nan")
        lines.append(f"| {k} | {tb_eps:,.1f} | {1.0 / t['ours_cold_mean']:,.0f} | {first:,.0f} "
                     f"| {warm:,.0f} | {first / tb_eps:,.0f}x | {warm / tb_eps:,.0f}x | "
                     f"{t['ratio_cold']:,.0f}x |")
    return lines


def markdown(res: dict) -> str:
    f, g, p = res["sequential_fast"], res["sequential_general"], res["parallel"]
    lines = [f"Random individuals: {res['individuals']} (mean {res['mean_terms']:.1f} terms, "
             f"max {res['max_terms']}, {res['distinct_terms']} distinct terms), MS Δm = "
             f"{res['window']}, N = {res['n']:,}, {res['finite']} finite fitnesses "
             f"({res['load_before']}):", "",
             "| ours | cold: evals/s | warm: evals/s (best of %d) |" % res["repeats"],
             "|---|---:|---:|",
             f"| StructureScorer, window-major MS kernel (default) | {f['cold_eps']:,.0f} | "
             f"{f['warm_eps']:,.0f} |",
             f"| StructureScorer, general kernel (before) | {g['cold_eps']:,.0f} | "
             f"{g['warm_eps']:,.0f} |",
             f"| Evaluator, n_jobs={p['n_jobs']} (pool start-up {_fmt_s(p['startup_seconds'])} "
             f"apart) | {p['cold_eps']:,.0f} | {p['warm_eps']:,.0f} |", "",
             f"Identical values: window-major vs general kernel "
             f"{res['identical_fast_vs_general']}; sequential vs n_jobs={p['n_jobs']} "
             f"{res['identical_sequential_vs_parallel']}. A scorer's construction "
             f"(allocating and writing its stores, once per worker and run): "
             f"{_fmt_s(f['setup_seconds'])}."]
    for k, t in (res.get("toolbox") or {}).items():
        if not t.get("available"):
            lines += ["", f"Toolbox k={k}: {t['reason']}"]
            continue
        if not t["scored"]:
            lines += ["", f"Toolbox k={k}: every sampled individual rejected by its LS"]
            continue
        lines += ["", f"Toolbox `ls` + `score_ksa` (k = {t['k']}) against ours (Δm = {t['k']}) "
                  f"on the same {t['scored']} individuals (mean {t['mean_terms']:.1f} terms; "
                  f"{t['rejected']} more rejected by the toolbox's LS):", "",
                  "| per evaluation | mean time | toolbox / ours (sum) | median ratio |",
                  "|---|---:|---:|---:|",
                  f"| toolbox | {_fmt_s(t['toolbox_mean'])} | | |",
                  f"| ours, cold (caches emptied before each) | {_fmt_s(t['ours_cold_mean'])} | "
                  f"{t['ratio_cold']:,.0f}x | {t['median_ratio_cold']:,.0f}x |",
                  f"| ours, warm (terms cached) | {_fmt_s(t['ours_warm_mean'])} | "
                  f"{t['ratio_warm']:,.0f}x | {t['median_ratio_warm']:,.0f}x |"]
    m33 = {k: t for k, t in (res.get("toolbox_model33") or {}).items()
           if t.get("available") and t["scored"]}
    if m33:
        lines += ["", "The same on the 15-term MS model (33) (a GP-sized individual):", "",
                  "| k = Δm | toolbox | ours cold | ours warm | toolbox / ours cold | "
                  "toolbox / ours warm |", "|---:|---:|---:|---:|---:|---:|"]
        for k, t in m33.items():
            lines.append(f"| {k} | {_fmt_s(t['toolbox_mean'])} | {_fmt_s(t['ours_cold_mean'])} "
                         f"| {_fmt_s(t['ours_warm_mean'])} | {t['ratio_cold']:,.0f}x | "
                         f"{t['ratio_warm']:,.0f}x |")
    return "\n".join(lines + _summary(res))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.evals",
                                 description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=50_000)
    ap.add_argument("--individuals", type=int, default=500)
    ap.add_argument("--sample", type=int, default=20, help="individuals sent to the toolbox")
    ap.add_argument("--window", type=int, default=1000,
                    help="MS window Δm for the throughput (the case study's: 1000)")
    ap.add_argument("--toolbox-k", type=int, nargs="+", default=[1000, 100, 10])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-peers", action="store_true")
    ap.add_argument("--json", metavar="F")
    a = ap.parse_args(argv)
    res = run(a.n, a.individuals, a.sample, a.window, tuple(a.toolbox_k), a.repeats,
              a.jobs, a.seed, not a.no_peers)
    finish(res, markdown(res), "benchmarks.evals", argv, a.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
