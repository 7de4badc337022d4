"""``mggp fit``: structure search on a CSV file.

Typical use::

    mggp fit train.csv --fitness ms --window 100 --population 200 \\
        --generations 50 --seed 1 --jobs 2 --constraints steady-state \\
        --out model.json --report report/ --checkpoint run.ckpt

A progress line shows the generation and the best fitness; ``--checkpoint``
writes the state atomically after a generation, as often as keeps the writes
within about 5 % of the run's time, and ``--resume`` continues
from it (the result equals an uninterrupted run with the same seed).
"""
from __future__ import annotations

import os
import shlex
import sys
import time
import warnings

from .app import CLIError, Files, check_refine_args, fmt, mode_option, refinement_line
from ..exceptions import CLSRejectedWarning
from ..fit.params import PATH, PARAMS, Bool, Param, add_options, check_params, options_given

__all__ = ["register", "FIT_OPTIONS"]

_CLI_ROWS = {
    "use_phi": Param("phi", None, Bool(), "Φ-functions allowed: one search, no comparison "
                     "with a search without them", "model class", "--phi", const=True,
                     default_text="chosen by held-out free-run error", estimator=False,
                     tier="common"),
    "constant": Param("no_constant", None, Bool(), "no constant term in any structure",
                      "model class", "--no-constant", const=True,
                      default_text="chosen by held-out free-run error", estimator=False),
}

#: options of ``mggp fit``: every parameter with a flag (--phi and
#: --no-constant beside the flag of the same parameter), and the outputs;
#: ``--help`` shows the common tier first (:data:`mggp.fit.params.TIERS`)
FIT_OPTIONS = tuple(r for p in PARAMS.values() for r in (p, _CLI_ROWS.get(p.name)) if r) + (
    Param("out", None, PATH, "write the model: with --constraints the CLS fit, unless its "
          "free run diverges on the training record or (unless --screen hold, or --select "
          "hold found a structure that holds) its RMSE there is over twice the LS fit's: "
          "then the LS fit, with a warning", "output", "--out", metavar="MODEL.json",
          default_text="not written", estimator=False, tier="common"),
    Param("report", None, PATH, "write figures and a Markdown summary to this folder",
          "output", "--report", metavar="DIR", default_text="none", estimator=False,
          tier="common"),
    Param("quiet", False, Bool(), "no progress line", "output", "--quiet", const=True,
          default_text="progress on stderr", estimator=False),
)


def register(sub):
    p = sub.add_parser("fit", help="search a model structure by MGGP",
                       description="Search the structure of a polynomial NARX model by "
                                   "multi-gene GP. Without options the search chooses for "
                                   "itself the model class (Φ-terms, memory operators) and "
                                   "the constant term by held-out free-run error, the size "
                                   "and, with --constraints, a structure whose constrained "
                                   "refit holds its output; each choice is printed and "
                                   "recorded in the model. An explicit option overrides it.")
    p.add_argument("data", metavar="DATA.csv", help="training record (columns u and y "
                   "unless --input/--output say otherwise)")
    add_options(p, FIT_OPTIONS, tiers=True)     # the common options first
    p.set_defaults(func=_cmd_fit, files=Files({"data": "DATA.csv"},
                                              {"out": "--out", "checkpoint": "--checkpoint"},
                                              {"report": "--report"}))


def _duration(seconds: float) -> str:
    """'42 s', '3 min 5 s' or '1 h 12 min'."""
    s = int(round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60} s"
    return f"{s // 3600} h {s % 3600 // 60} min"


class _Progress:
    """The progress line on ``stream``: which search runs (a model class's
    pilot or the full search, :meth:`phase`), its generation, the best
    fitness, the time since the start and, once the run's plan is known
    (:meth:`plan`: the generations of every search of the fit), the time
    left at the pace so far; without a terminal one line every twentieth of
    the full run's generations."""

    def __init__(self, total, stream, quiet):
        self.total, self.stream, self.quiet = total, stream, quiet
        self.every = max(1, total // 20)
        self.label = "search"
        self.t0 = time.perf_counter()
        self.tty = hasattr(stream, "isatty") and stream.isatty()
        self.planned, self.done, self.last = None, 0, None

    def plan(self, generations: int) -> None:
        """The generations of all the fit's searches together."""
        self.planned = generations

    def phase(self, label: str, generations: int) -> None:
        self.label, self.total, self.last = label, generations, None

    def left(self, elapsed: float) -> str:
        """' (about 3 min 5 s left)' at the pace so far, or ''."""
        if not self.planned or self.done < 3 or self.done >= self.planned:
            return ""
        return f" (about {_duration(elapsed / self.done * (self.planned - self.done))} left)"

    def __call__(self, state):
        g = state.generation
        self.done += 1 if self.last is None else max(g - self.last, 0)
        self.last = g
        if self.quiet:
            return
        rec = state.logbook[-1] if len(state.logbook) else {}
        best = rec.get("best", float("nan"))
        width = 24
        done = int(width * min(g, self.total) / max(self.total, 1))
        bar = "#" * done + "." * (width - done)
        elapsed = time.perf_counter() - self.t0
        msg = (f"{self.label}: gen {g:>4d}/{self.total} [{bar}] best {fmt(best)} "
               f"terms {rec.get('best_terms', '?')} {elapsed:6.1f}s{self.left(elapsed)}")
        if self.tty:
            self.stream.write("\r" + msg)
            if g >= self.total:
                self.stream.write("\n")
        elif g % self.every == 0 or g >= self.total:
            self.stream.write(msg + "\n")
        self.stream.flush()


def _cmd_fit(args) -> int:
    from narx.records.csvdata import read_csv
    from ..fit.estimator import MGGPRegressor
    from narx.atomic import check_writable
    # the rules of the options, alone and combined, come from the table
    # (mggp.fit.params); what follows combines options with modes and files
    est = MGGPRegressor(**options_given(args, [p for p in FIT_OPTIONS if p.estimator]))
    if args.phi:
        if est.use_phi is False:
            raise CLIError("--phi and --no-phi exclude each other: give one")
        est.set_params(use_phi=True)
    if args.no_constant:
        if est.constant is True:
            raise CLIError("--constant and --no-constant exclude each other: give one")
        est.set_params(constant=False)
    check_params(est, cli=True)
    mode_option(est.fitness, {"ksa": "k", "ms": "window"}, args, "--fitness")
    check_refine_args(args)
    if args.resume and not args.checkpoint:
        raise CLIError("--resume needs --checkpoint FILE")
    if args.resume and not os.path.exists(args.checkpoint):
        from ..gp.checkpoint import pilot_checkpoints
        pilots = pilot_checkpoints(args.checkpoint)
        print(f"note: no checkpoint at {args.checkpoint} yet: " + (
            f"the run continues from its {len(pilots)} pilot checkpoint(s) beside it"
            if pilots else "a new run starts (it is written there as the search goes)"),
            file=sys.stderr)
    if est.backend == "dask" and not args.scheduler:
        raise CLIError("--backend dask needs --scheduler ADDRESS")
    if args.scheduler and est.backend != "dask":
        raise CLIError(f"--scheduler {args.scheduler} needs --backend dask "
                       f"(got --backend {est.backend})")
    # every destination is checked before the search, so no run is lost to it
    for opt, path in (("--out", args.out), ("--checkpoint", args.checkpoint)):
        if path:
            check_writable(path, opt)           # a ValueError is one error: line
    if args.report and os.path.exists(args.report) and not os.path.isdir(args.report):
        raise CLIError(f"--report {args.report}: exists and is not a folder")
    est.set_params(inputs=est.inputs or ["u"], callbacks=[
        _Progress(est.generations, sys.stderr, args.quiet)])
    data = read_csv(args.data, inputs=est.inputs, output=est.output, varying_inputs=True)
    from narx.records.data import DataError
    from ..gp.evaluate import WorkerLostError
    try:
        with warnings.catch_warnings():       # said below, for the model written
            warnings.simplefilter("ignore", CLSRejectedWarning)
            warnings.filterwarnings("ignore", "select='hold': none of")   # a note below
            est.fit(data)
    except DataError as exc:                  # e.g. too few samples for the lags
        raise CLIError(f"{args.data}: {exc}") from None
    except WorkerLostError as exc:
        raise CLIError(str(exc)) from None
    m = est.model_
    final = m
    for c in est.choices_.values():
        print(f"auto: {c['why']}", file=sys.stderr)
    if est.local_search_:
        from ..fit.local_search import moves_text
        print(f"{moves_text(est.local_search_)} "
              f"({est.fitness} fitness {fmt(est.local_search_[-1]['fitness'])} after)",
              file=sys.stderr)
    if est.outliers_:                         # the record the models were fitted on
        from narx.records.outliers import repaired
        data = repaired(data, est.outliers_)
    fr_ls = m.simulate(data, mode="freerun")
    lines = [f"seed {est.seed_}; {est.n_evaluations_} structures evaluated in "
             f"{est.fit_time_:.1f} s; best {est.fitness} fitness {fmt(est.fitness_)}"
             + ("" if est.criterion == "mse" else
                f" ({est.criterion.upper()} of the {est.fitness} MSE)"),
             ("LS:  " if "refined" not in m.meta else
              f"LS refined ({m.meta['refined']['mode']}):  ") + m.equation(),
             _freerun_line(fr_ls)]
    if est.refinement_ is not None:
        lines.append("     " + refinement_line(est.refinement_))
    if str(m.meta.get("estimation", "")).startswith("ls-search"):
        lines.append(f"     θ from the search's fit: the QR refit of these terms simulates "
                     f"worse ({est.fitness} MSE {fmt(m.meta['qr_refit_fitness_value'])})")
    if est.constraints:
        if est.model_cls_ is None:
            lines.append(f"CLS: not possible: {getattr(est, 'cls_error_', 'unknown reason')}")
        else:
            c = est.model_cls_
            fr = c.simulate(data, mode="freerun")
            lines += ["CLS: " + c.equation(), _freerun_line(fr)]
            why = est.cls_rejected_                 # the estimator's verdict
            hold = est.choices_.get("select", {}).get("figures", {})
            if hold.get("candidates") and hold.get("holding") is None:
                print(f"note: none of the {hold['candidates']} candidate structures holds "
                      f"its output on a held input under the steady-state constraints; "
                      f"the {'LS' if why else 'CLS'} fit of the best-fitness structure is "
                      f"written", file=sys.stderr)
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
    else:
        lines.append("model not written: --out MODEL.json writes it (for mggp simulate, "
                     "diagnose and compensate)")
    print("\n".join(lines))
    if args.report:
        from ..report.summary import write_fit_report
        cmd = "mggp " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if sys.argv else None
        path = write_fit_report(args.report, est, data, os.path.basename(args.data), cmd)
        print(f"report written to {path}")
    return 0


def _freerun_line(fr) -> str:
    return (f"     free-run RMSE {fmt(fr.rmse)}, MAPE {fmt(fr.mape)} %"
            + ("  (free run diverged)" if fr.diverged else ""))
