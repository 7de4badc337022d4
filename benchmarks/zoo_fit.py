"""The zoo fit study: the default ``mggp fit`` on draws of :mod:`narx.systems.zoo`, against the oracle.

Run::

    python -m benchmarks.zoo_fit fit --seeds 1000-1099 --json zoo_fit.jsonl --jobs 1
    python -m benchmarks.zoo_fit table zoo_fit.jsonl
    python -m benchmarks.zoo_fit calibrate --seeds 0-19 --json dev_fit.jsonl  # dev seeds only

For each draw (4,000 training samples, :data:`benchmarks.zoo.STUDY_N`),
``fit`` runs the default :class:`mggp.MGGPRegressor` (``random_state`` the
draw's seed, every other parameter its default: what ``mggp fit DATA.csv
--seed S`` runs) on the training record, simulates its model in free run on
the validation record, and compares that RMSE with the oracle's
(:func:`benchmarks.zoo.oracle`: the truth's terms fitted by the better of
LS and free-run θ). One JSON line per draw is appended as it finishes (a
killed run keeps its records; a new run skips the seeds already there).
Fields: ``seed, split, family, hysteretic, placement, snr_db, fit_rmse,
oracle_rmse, ratio, exploded, choices, model_class, class_errors, stress, terms,
truth, extension, extend_seconds, seconds`` (``class_errors``: each class pilot's
held-out free-run RMSE by class key; ``stress``: the stress rule's verdicts
by choice, e.g. ``{"size": {"all_fail": 3}}``; ``error`` when the fit failed; ``extension``: the
catalogue extension the ``extend`` stage took, None for none; ``extend``
when ``--extend`` set the parameter). ``exploded``: the free run is not finite or leaves the
band of three times the validation output's range
(:func:`benchmarks.measured.explodes`). ``ratio`` = fit / oracle validation
RMSE; a draw *holds* when ``ratio <= GOAL`` (issue 35, must-show 6).

``table`` prints the share within :data:`GOAL` of the oracle over the
identifiable hysteretic draws (oracle gain ≥ 1.5 in the diagnosis study's
records when given with ``--zoo``; else every hysteretic draw), over the
controls and over both, the explosions, the non-identifiable hysteretic
draws on their own, and the same by family and (with ``--zoo``) by the
kind of training input.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from typing import List, Optional

import numpy as np

from .zoo import IDENTIFIABLE, STUDY_N, oracle, parse_seeds, records, resume

__all__ = ["GOAL", "fit_one", "fit_study", "fit_table", "main"]

#: a draw holds when the default's validation RMSE is within this factor of the oracle's
GOAL = 1.5


def _num(x) -> Optional[float]:
    return None if x is None or not math.isfinite(x) else float(x)


def fit_one(seed: int, jobs: int = 1, extend: Optional[str] = None) -> dict:
    """Fit the draw of ``seed`` by default (``extend``: that parameter
    instead of its default) and score it against the oracle (one record)."""
    from mggp import MGGPRegressor
    from narx.systems import zoo

    from .measured import explodes
    t0 = time.perf_counter()
    d = zoo.draw(seed, n=STUDY_N)
    rec = {"seed": seed, "split": d.split, "family": d.family, "hysteretic": d.hysteretic,
           "placement": d.placement, "snr_db": d.noise["snr_db"]}
    kw = {} if extend is None else {"extend": extend}
    if extend is not None:
        rec["extend"] = extend
    try:
        orc = oracle(d).rmse
    except Exception as exc:               # recorded: the draw still measures the fit
        orc = math.nan
        rec["oracle_error"] = f"{type(exc).__name__}: {exc}"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            est = MGGPRegressor(random_state=seed, n_jobs=jobs, **kw).fit(d.train)
            model = est.get_best()
            with np.errstate(all="ignore"):
                sim = model.simulate(d.validation, mode="freerun")
    except Exception as exc:               # a failure is a finding of the study
        rec.update(oracle_rmse=_num(orc), error=f"{type(exc).__name__}: {exc}",
                   seconds=time.perf_counter() - t0)
        return rec
    y_hat = np.asarray(sim.y_hat, float)
    ok = np.asarray(sim.valid, bool)
    diverged = bool(sim.diverged) or not np.isfinite(sim.rmse)
    rmse = math.inf if diverged else float(sim.rmse)
    rec.update(fit_rmse=_num(rmse), oracle_rmse=_num(orc),
               ratio=_num(rmse / orc) if orc and math.isfinite(orc) else None,
               exploded=bool(diverged or explodes(y_hat[ok], np.asarray(d.validation.y)[ok])),
               choices={k: v["value"] for k, v in est.choices_.items()},
               model_class=est.choices_.get("use_phi", {}).get("figures", {}).get("class"),
               class_errors={k.removeprefix("heldout_rmse_"): _num(v) for k, v in
                             est.choices_.get("use_phi", {}).get("figures", {}).items()
                             if k.startswith("heldout_rmse_")},
               terms=list(model.term_texts), truth=list(d.truth.terms),
               stress=_stress(est.choices_),
               extension=(est.extension_ or {}).get("winner"),
               extend_seconds=(est.extension_ or {}).get("seconds"),
               seconds=time.perf_counter() - t0)
    return rec


def _stress(choices) -> dict:
    """The stress rule's verdicts in the fit's choices: for each choice
    whose figures hold them, how many structures it refused
    (``refused``) or, when every one within the tolerance failed and none
    was refused, how many failed (``all_fail``); ``beyond_tolerance`` when
    the size choice took a bounded structure beyond its tolerance
    (:data:`mggp.fit.extrapolation.STRESS_BEYOND`)."""
    out = {}
    for name, c in choices.items():
        figs = c.get("figures") or {}
        said = {k: len(figs[f"stress_{k}"]) if isinstance(figs[f"stress_{k}"], (list, dict))
                else 1 for k in ("refused", "all_fail") if figs.get(f"stress_{k}")}
        if figs.get("beyond_tolerance"):
            said["beyond_tolerance"] = True
        if said:
            out[name] = said
    return out


def fit_study(seeds, path, jobs: int = 1, say=print, extend: Optional[str] = None) -> List[dict]:
    """:func:`fit_one` for each seed not yet in ``path``, appending its record there."""
    return resume(seeds, path, lambda seed: fit_one(seed, jobs, extend),
                  lambda rec: say(f"seed {rec['seed']}: {rec['family']}, fit "
                                  f"{rec.get('fit_rmse')}, oracle {rec.get('oracle_rmse')}, "
                                  f"ratio {rec.get('ratio')}, "
                                  f"{'EXPLODED, ' if rec.get('exploded') else ''}"
                                  f"{rec['seconds']:.0f} s"))


def _holds(r) -> bool:
    """Within :data:`GOAL` of the oracle and not exploded (a diverged oracle:
    any bounded fit holds)."""
    if "error" in r or r.get("exploded"):
        return False
    if r.get("oracle_rmse") is None:
        return r.get("fit_rmse") is not None
    return r.get("ratio") is not None and r["ratio"] <= GOAL


def _rate(k: int, n: int) -> str:
    return f"{k}/{n} ({100.0 * k / n:.0f} %)" if n else "0/0 (–)"


def fit_table(recs: List[dict], zoo_recs: Optional[List[dict]] = None) -> str:
    """The Markdown report of the fit study's records ``recs``; ``zoo_recs``
    (the diagnosis study's) say which hysteretic draws are identifiable."""
    from narx.systems.zoo import FAMILIES
    zoo = {r["seed"]: r for r in zoo_recs or []}
    ident = {k: r.get("identifiable") for k, r in zoo.items()}
    hy = [r for r in recs if r["hysteretic"] and ident.get(r["seed"], True)]
    ctrl = [r for r in recs if not r["hysteretic"]]
    rest = [r for r in recs if r["hysteretic"] and not ident.get(r["seed"], True)]
    boom = [r for r in recs if r.get("exploded") or "error" in r]
    seeds = sorted(r["seed"] for r in recs)
    which = ("identifiable hysteretic (oracle gain ≥ "
             f"{IDENTIFIABLE} in the diagnosis records)" if zoo_recs else "hysteretic")
    lines = [f"**Default fit against the oracle.** Seeds {seeds[0]}–{seeds[-1]}, "
             f"{len(recs)} draws. Within {GOAL}× of the oracle's validation RMSE: "
             f"{_rate(sum(map(_holds, hy)), len(hy))} {which} draws, "
             f"{_rate(sum(map(_holds, ctrl)), len(ctrl))} controls, "
             f"{_rate(sum(map(_holds, hy + ctrl)), len(hy + ctrl))} of both together; "
             f"exploded or failed: {_rate(len(boom), len(recs))}."]
    if rest:
        lines.append(f"Hysteretic draws that are not identifiable, on their own: "
                     f"{_rate(sum(map(_holds, rest)), len(rest))} within {GOAL}×.")
    lines += ["", "| family | draws | within 1.5× | exploded | median ratio |",
              "|---|---|---|---|---|"]
    for fam in FAMILIES:
        rows = [r for r in recs if r["family"] == fam]
        if rows:
            ratios = [r["ratio"] if r.get("ratio") is not None else math.inf for r in rows]
            lines.append(f"| {fam} | {len(rows)} | {sum(map(_holds, rows))} | "
                         f"{sum(bool(r.get('exploded') or 'error' in r) for r in rows)} | "
                         f"{np.median(ratios):.2f} |")
    kinds = sorted({zoo[r["seed"]].get("input_kind") for r in hy + ctrl
                    if r["seed"] in zoo} - {None})
    if kinds:
        lines += ["", f"| training input | identifiable hysteretic within {GOAL}× | "
                  f"controls within {GOAL}× |", "|---|---|---|"]
        for kind in kinds:
            def of(group):
                return [r for r in group if zoo.get(r["seed"], {}).get("input_kind") == kind]
            lines.append(f"| {kind} | {sum(map(_holds, of(hy)))}/{len(of(hy))} | "
                         f"{sum(map(_holds, of(ctrl)))}/{len(of(ctrl))} |")
    secs = [r["seconds"] for r in recs]
    lines += ["", f"Seconds per draw (fit and oracle): median {np.median(secs):.0f}, "
              f"max {np.max(secs):.0f}."]
    return "\n".join(lines) + "\n"


def _parser():
    p = argparse.ArgumentParser(prog="python -m benchmarks.zoo_fit",
                                description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    for name, helptext in (("fit", "fit draws by default and append their records"),
                           ("calibrate", "fit development seeds (inside zoo.tuning())")):
        e = sub.add_parser(name, help=helptext)
        e.add_argument("--seeds", nargs="+", required=True, help="seeds or ranges A-B")
        e.add_argument("--json", required=True, help="JSON-lines file (appended, resumed)")
        e.add_argument("--jobs", type=int, default=1)
        e.add_argument("--extend", choices=("auto", "none"),
                       help="the fit's extend parameter (default: its default)")
    t = sub.add_parser("table", help="Markdown table of a records file")
    t.add_argument("file")
    t.add_argument("--zoo", nargs="+", metavar="FILE",
                   help="the diagnosis study's records (identifiable draws); several files "
                        "are read as one")
    return p


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    try:
        if args.command in ("fit", "calibrate"):
            if args.jobs < 1:
                raise ValueError(f"--jobs must be >= 1, got {args.jobs}")
            seeds = parse_seeds(args.seeds)
            if args.command == "calibrate":
                from narx.systems import zoo
                with zoo.tuning():
                    for s in seeds:
                        zoo.guard(s)
                    fit_study(seeds, args.json, args.jobs, extend=args.extend)
            else:
                fit_study(seeds, args.json, args.jobs, extend=args.extend)
        else:
            recs = records(args.file)
            if not recs:
                raise ValueError(f"{args.file}: no records")
            zoo = [r for f in args.zoo for r in records(f)] if args.zoo else None
            print(fit_table(recs, zoo), end="")
    except (ValueError, OSError, RuntimeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
