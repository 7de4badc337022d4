"""``mggp fit``: structure search on a CSV file.

Typical use::

    mggp fit train.csv --fitness ms --window 100 --population 200 \\
        --generations 50 --seed 1 --jobs 2 --constraints steady-state \\
        --out model.json --report report/ --checkpoint run.ckpt

A progress line shows the generation and the best fitness; ``--checkpoint``
writes the state atomically every generation and ``--resume`` continues
from it (the result equals an uninterrupted run with the same seed).
"""
from __future__ import annotations

import os
import shlex
import sys
import time
import warnings

from .cli import (CLIError, add_refine_args, add_signal_args, check_refine_args, fmt,
                  mode_option, refinement_line)
from .selection import CLSRejectedWarning

__all__ = ["register"]


def register(sub):
    p = sub.add_parser("fit", help="search a model structure by MGGP",
                       description="Search the structure of a polynomial NARX model by "
                                   "multi-gene GP; defaults are the published setup.")
    p.add_argument("data", metavar="DATA.csv")
    p.add_argument("--fitness", choices=["pem", "freerun", "ksa", "ms"], default="ms",
                   help="simulation whose MSE scores a structure: one-step-ahead, free "
                        "run, k steps ahead or multiple shooting (default ms)")
    p.add_argument("--window", type=int, default=None, help="Δm for ms (default 100)")
    p.add_argument("--k", type=int, default=None, help="horizon for ksa (default 10)")
    p.add_argument("--criterion", choices=["mse", "bic", "aic"], default="mse",
                   help="fitness: the MSE or an information criterion penalising terms "
                        "(default mse)")
    p.add_argument("--population", type=int, default=500, help="(default 500)")
    p.add_argument("--generations", type=int, default=200, help="(default 200)")
    p.add_argument("--seed", type=int, default=None,
                   help="fixes the run whatever --jobs is (default: drawn, and reported)")
    p.add_argument("--jobs", type=int, default=1,
                   help="worker processes, -1 for all cores (default 1)")
    p.add_argument("--backend", choices=["loky", "threading", "sequential", "dask"],
                   default="loky", help="joblib backend of the evaluator (default loky)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="dask scheduler address for --backend dask")
    p.add_argument("--max-terms", type=int, default=15,
                   help="genes (model terms) per individual (default 15)")
    p.add_argument("--max-height", type=int, default=5, help="tree height (default 5)")
    p.add_argument("--max-lag", type=int, default=None,
                   help="largest lag a term may use (default: what --max-height allows)")
    p.add_argument("--max-degree", type=int, default=None,
                   help="largest polynomial degree of a term (default: none)")
    p.add_argument("--prune", choices=["bic", "t"], default=None,
                   help="drop terms of the best structure by BIC or by t-statistics "
                        "(default: keep all)")
    p.add_argument("--select", choices=["fitness", "freerun", "hold"], default="fitness",
                   help="the result among the best distinct structures: best fitness, "
                        "least free-run error over the record, or (hold) the best whose "
                        "CLS refit holds its output on a held input (default fitness)")
    p.add_argument("--noise-lags", type=int, default=0, metavar="Q",
                   help="select moving-average noise terms e[k-1]..e[k-Q] by extended LS "
                        "after the search (NARMAX; for coloured noise; default 0)")
    add_refine_args(p, "the search's --window, 100")
    p.add_argument("--constraints", choices=["steady-state"], default=None,
                   help="also refit the best structure by CLS with the derived "
                        "continuum-of-steady-states constraints")
    p.add_argument("--search-constraints", choices=["steady-state"], default=None,
                   help="score every structure of the search by its CLS fit (the "
                        "continuum of steady states) instead of LS")
    p.add_argument("--no-phi", action="store_true", help="plain polynomial terms only")
    p.add_argument("--phi-outputs", action="store_true",
                   help="Φ-terms of output lags too, e.g. Phi1(y[k-1],y[k-2]) (hysteresis "
                        "driven by the output's velocity; default: inputs only)")
    p.add_argument("--constant", action="store_true",
                   help="every structure also holds the constant term 1 (an intercept), "
                        "for an output that rests at an offset the lag terms cannot "
                        "express, e.g. an affine static curve")
    p.add_argument("--screen", choices=["freerun", "hold"], default=None,
                   help="reject each generation's leaders whose free run over the "
                        "record leaves the output band ('hold': or whose CLS refit "
                        "does not hold its output on a held input)")
    p.add_argument("--out", metavar="MODEL.json",
                   help="write the model: with --constraints the CLS fit, unless its free "
                        "run diverges on the training record or (unless --screen hold, or "
                        "--select hold found a structure that holds) its RMSE there is "
                        "over twice the LS fit's: then the LS fit, with a warning")
    p.add_argument("--report", metavar="DIR", help="write figures and a Markdown summary")
    p.add_argument("--checkpoint", metavar="FILE", help="save the state every generation")
    p.add_argument("--resume", action="store_true",
                   help="continue the run saved in --checkpoint")
    p.add_argument("--quiet", action="store_true", help="no progress line")
    add_signal_args(p)
    p.set_defaults(func=_cmd_fit)


class _Progress:
    def __init__(self, total, stream, quiet):
        self.total, self.stream, self.quiet = total, stream, quiet
        self.t0 = time.perf_counter()
        self.tty = hasattr(stream, "isatty") and stream.isatty()

    def __call__(self, state):
        if self.quiet:
            return
        g = state.generation
        rec = state.logbook[-1] if len(state.logbook) else {}
        best = rec.get("best", float("nan"))
        width = 24
        done = int(width * min(g, self.total) / max(self.total, 1))
        bar = "#" * done + "." * (width - done)
        msg = (f"gen {g:>4d}/{self.total} [{bar}] best {fmt(best)} "
               f"terms {rec.get('best_terms', '?')} {time.perf_counter() - self.t0:6.1f}s")
        if self.tty:
            self.stream.write("\r" + msg)
            if g >= self.total:
                self.stream.write("\n")
        elif g % max(1, self.total // 20) == 0 or g >= self.total:
            self.stream.write(msg + "\n")
        self.stream.flush()


def _cmd_fit(args) -> int:
    from narx.csvdata import read_csv
    from .estimator import MGGPRegressor
    from narx.atomic import check_writable
    mode_option(args.fitness, {"ksa": "k", "ms": "window"}, args, "--fitness")
    check_refine_args(args)
    if args.phi_outputs and args.no_phi:
        raise CLIError("--phi-outputs needs Φ-functions in the search: drop --no-phi")
    window = 100 if args.window is None else args.window
    k = 10 if args.k is None else args.k
    lows = {"population": 2, "generations": 0, "max_terms": 1, "max_height": 1,
            "max_lag": 1, "max_degree": 1, "seed": 0, "noise_lags": 0}
    for name, lo in lows.items():
        v = getattr(args, name)
        if v is not None and v < lo:
            raise CLIError(f"--{name.replace('_', '-')} must be >= {lo}, got {v}")
    if args.jobs == 0 or args.jobs < -1:
        raise CLIError(f"--jobs must be >= 1 or -1, got {args.jobs}")
    if args.resume and not args.checkpoint:
        raise CLIError("--resume needs --checkpoint FILE")
    if args.resume and not os.path.exists(args.checkpoint):
        print(f"note: no checkpoint at {args.checkpoint} yet: a new run starts (it is "
              f"written there every generation)", file=sys.stderr)
    if args.backend == "dask" and not args.scheduler:
        raise CLIError("--backend dask needs --scheduler ADDRESS")
    if args.scheduler and args.backend != "dask":
        raise CLIError(f"--scheduler {args.scheduler} needs --backend dask "
                       f"(got --backend {args.backend})")
    # every destination is checked before the search, so no run is lost to it
    for opt, path in (("--out", args.out), ("--checkpoint", args.checkpoint)):
        if path:
            check_writable(path, opt)           # a ValueError is one error: line
    if args.report and os.path.exists(args.report) and not os.path.isdir(args.report):
        raise CLIError(f"--report {args.report}: exists and is not a folder")
    if args.report and args.out and os.path.abspath(args.report) == os.path.abspath(args.out):
        raise CLIError(f"--report and --out name the same path {args.out}")
    inputs = args.input or ["u"]
    output = args.output or "y"
    data = read_csv(args.data, inputs=inputs, output=output, varying_inputs=True)
    est = MGGPRegressor(fitness=args.fitness, window=window, k=k,
                        criterion=args.criterion, constraints=args.constraints,
                        search_constraints=args.search_constraints,
                        population=args.population, generations=args.generations,
                        max_terms=args.max_terms, max_height=args.max_height,
                        max_lag=args.max_lag, max_degree=args.max_degree,
                        prune=args.prune or False, use_phi=not args.no_phi,
                        phi_outputs=args.phi_outputs, constant=args.constant,
                        select=args.select, noise_lags=args.noise_lags,
                        refine=args.refine, refine_window=args.refine_window,
                        screen=args.screen,
                        random_state=args.seed, n_jobs=args.jobs, backend=args.backend,
                        scheduler=args.scheduler, inputs=inputs, output=output,
                        checkpoint=args.checkpoint, resume=args.resume,
                        callbacks=[_Progress(args.generations, sys.stderr, args.quiet)])
    from narx.data import DataError
    from .evaluate import WorkerLostError
    try:
        with warnings.catch_warnings():       # said below, for the model written
            warnings.simplefilter("ignore", CLSRejectedWarning)
            est.fit(data)
    except DataError as exc:                  # e.g. too few samples for the lags
        raise CLIError(f"{args.data}: {exc}") from None
    except WorkerLostError as exc:
        raise CLIError(str(exc)) from None
    m = est.model_
    final = m
    fr_ls = m.simulate(data, mode="freerun")
    lines = [f"seed {est.seed_}; {est.n_evaluations_} structures evaluated in "
             f"{est.fit_time_:.1f} s; best {args.fitness} fitness {fmt(est.fitness_)}"
             + ("" if args.criterion == "mse" else
                f" ({args.criterion.upper()} of the {args.fitness} MSE)"),
             ("LS:  " if "refined" not in m.meta else
              f"LS refined ({m.meta['refined']['mode']}):  ") + m.equation(),
             _freerun_line(fr_ls)]
    if est.refinement_ is not None:
        lines.append("     " + refinement_line(est.refinement_))
    if str(m.meta.get("estimation", "")).startswith("ls-search"):
        lines.append(f"     θ from the search's fit: the QR refit of these terms simulates "
                     f"worse ({args.fitness} MSE {fmt(m.meta['qr_refit_fitness_value'])})")
    if args.constraints:
        if est.model_cls_ is None:
            lines.append(f"CLS: not possible: {getattr(est, 'cls_error_', 'unknown reason')}")
        else:
            c = est.model_cls_
            fr = c.simulate(data, mode="freerun")
            lines += ["CLS: " + c.equation(), _freerun_line(fr)]
            why = est.cls_rejected_                 # the estimator's verdict
            if why:
                print(f"warning: the CLS refit {why}; the LS model is written instead "
                      f"(`mggp estimate DATA --terms ... --constraints steady-state` "
                      f"writes the CLS fit of these terms)", file=sys.stderr)
            else:
                c.meta["ls_theta"] = [float(v) for v in m.theta]
                final = c
    final.meta.update({"command": "fit", "data": str(args.data), "n_samples": data.n})
    if args.out:                              # saved first: a closed pipe loses nothing
        final.save(args.out)
        lines.append(f"model written to {args.out}" + (" (CLS fit)" if final is not m else ""))
    print("\n".join(lines))
    if args.report:
        from .report import write_fit_report
        cmd = "mggp " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if sys.argv else None
        path = write_fit_report(args.report, est, data, os.path.basename(args.data), cmd)
        print(f"report written to {path}")
    return 0


def _freerun_line(fr) -> str:
    return (f"     free-run RMSE {fmt(fr.rmse)}, MAPE {fmt(fr.mape)} %"
            + ("  (free run diverged)" if fr.diverged else ""))
