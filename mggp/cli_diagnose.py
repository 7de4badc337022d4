"""``mggp diagnose``: what a model's simulation gets wrong, why, and the gain of fixing it.

Typical use::

    mggp diagnose train.csv --validation val.csv --json dx.json --report dx/ --seed 0 --jobs 2
    mggp diagnose train.csv --model pem.json --validation held.csv      # diagnose your model
    mggp diagnose train.csv --population 1000 --generations 200 --jobs 4  # spend more

Without ``--model`` the baseline is an MGGP model with multiple-shooting
fitness and no Φ-functions. Without ``--validation`` the last
``--holdout`` fraction of TRAIN.csv measures the gain and the rest fits.
The terminal shows a short summary; ``--json`` writes the findings,
both models and the gain (schema in :mod:`mggp.diagnose`); ``--report``
writes ``summary.md`` and figures. Files are written atomically after the
diagnosis succeeded; the data files are only read.
"""
from __future__ import annotations

import json
import os
import shlex
import sys

from .cli import CLIError, add_signal_args

__all__ = ["register"]


def register(sub):
    p = sub.add_parser("diagnose", help="name what a model's simulation gets wrong, "
                       "extend the model, measure the gain")
    p.add_argument("train", metavar="TRAIN.csv")
    p.add_argument("--validation", metavar="VAL.csv", default=None,
                   help="record that measures the gain (default: a tail of TRAIN.csv)")
    p.add_argument("--model", metavar="MODEL.json", default=None,
                   help="the model to diagnose (default: MGGP, MS fitness, no Φ)")
    p.add_argument("--json", metavar="REPORT.json", default=None)
    p.add_argument("--report", metavar="DIR", default=None)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--jobs", type=int, default=1)
    g = p.add_argument_group("budget (defaults: about 40 s for 10,000 samples with --jobs 2)")
    g.add_argument("--population", type=int, default=500)
    g.add_argument("--generations", type=int, default=100)
    g.add_argument("--max-terms", type=int, default=15)
    g.add_argument("--max-height", type=int, default=5)
    g.add_argument("--max-degree", type=int, default=3)
    g.add_argument("--window", type=int, default=100, help="Δm of multiple shooting")
    g.add_argument("--shifts", type=int, default=99,
                   help="placebo shifts of the Φ-augmentation test")
    g.add_argument("--bootstrap", type=int, default=199,
                   help="replicas of the prediction-bias bootstrap")
    t = p.add_argument_group("tests")
    t.add_argument("--holdout", type=float, default=0.3,
                   help="tail fraction measuring the gain without --validation (0.3)")
    t.add_argument("--alpha", type=float, default=0.01,
                   help="false-alarm probability of each test (0.01)")
    t.add_argument("--resolution", type=float, default=0.005,
                   help="smallest effect named, fraction of the output range (0.005)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    add_signal_args(p)
    p.set_defaults(func=_cmd_diagnose)


def _check_args(args):
    for name in ("population", "max_terms", "max_height", "max_degree", "window",
                 "shifts", "bootstrap"):
        v, low = getattr(args, name), 2 if name == "population" else 1
        if v < low:
            raise CLIError(f"--{name.replace('_', '-')} must be >= {low}, got {v}")
    if args.generations < 0:
        raise CLIError(f"--generations must be >= 0, got {args.generations}")
    if args.jobs == 0 or args.jobs < -1:
        raise CLIError(f"--jobs must be >= 1 or -1, got {args.jobs}")
    if args.seed < 0:
        raise CLIError(f"--seed must be >= 0, got {args.seed}")
    if not 0.0 < args.holdout < 1.0:
        raise CLIError(f"--holdout must be a fraction between 0 and 1, got {args.holdout}")
    if not 0.0 < args.alpha < 0.5:
        raise CLIError(f"--alpha must be between 0 and 0.5, got {args.alpha}")
    if not 0.0 <= args.resolution < 1.0:
        raise CLIError(f"--resolution must be in [0, 1), got {args.resolution}")
    if args.json:
        if os.path.isdir(args.json):
            raise CLIError(f"--json {args.json} is a folder, not a file")
        folder = os.path.dirname(os.path.abspath(args.json))
        if not os.path.isdir(folder):
            raise CLIError(f"--json {args.json}: folder {folder} does not exist")
    if args.report and os.path.exists(args.report) and not os.path.isdir(args.report):
        raise CLIError(f"--report {args.report} is a file, not a folder")


_DEFAULTS = {"validation": None, "model": None, "json": None, "report": None, "seed": 0,
             "jobs": 1, "population": 500, "generations": 100, "max_terms": 15,
             "max_height": 5, "max_degree": 3, "window": 100, "shifts": 99,
             "bootstrap": 199, "holdout": 0.3, "alpha": 0.01, "resolution": 0.005,
             "input": None, "output": None}


def _command(args) -> str:
    """The command line that reproduces this run (options at their defaults left out)."""
    parts = ["mggp", "diagnose", args.train]
    for name, default in _DEFAULTS.items():
        v = getattr(args, name)
        if v == default or (name == "holdout" and args.validation):
            continue
        parts.append("--" + name.replace("_", "-"))
        parts += [str(x) for x in v] if isinstance(v, list) else [str(v)]
    return " ".join(shlex.quote(p) for p in parts)


def _cmd_diagnose(args) -> int:
    from narx import load_model
    from narx.csvdata import read_csv
    from .diagnose import Budget, diagnose
    from .diagnose.report import write_report
    _check_args(args)
    model = load_model(args.model) if args.model else None
    inputs = args.input or (list(model.inputs) if model else ["u"])
    output = args.output or (model.output if model else "y")
    if model is not None and len(inputs) != len(model.inputs):
        raise CLIError(f"--input: the model has {len(model.inputs)} input(s) "
                       f"{list(model.inputs)}, got {len(inputs)} column name(s)")
    train = read_csv(args.train, inputs=inputs, output=output)
    val = read_csv(args.validation, inputs=inputs, output=output) if args.validation else None
    if model is not None and (list(model.inputs) != inputs or model.output != output):
        from narx.data import Data
        train = Data(train.U.T, train.y, inputs=model.inputs, output=model.output)
        if val is not None:
            val = Data(val.U.T, val.y, inputs=model.inputs, output=model.output)
    if model is not None:
        fr = model.simulate(train, mode="freerun")
        if fr.diverged:
            raise CLIError(f"the model {args.model} is unstable on {args.train}: its free "
                           f"run diverged (output beyond 1e4 times the data's magnitude); "
                           f"a model whose simulation diverges has no simulation to diagnose")
    budget = Budget(population=args.population, generations=args.generations,
                    max_terms=args.max_terms, max_height=args.max_height,
                    max_degree=args.max_degree, window=args.window, shifts=args.shifts,
                    bootstrap=args.bootstrap)
    say = None if args.quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    names = (os.path.basename(args.train),
             os.path.basename(args.validation) if args.validation else "")
    dx = diagnose(train, val, model, budget=budget, seed=args.seed, jobs=args.jobs,
                  holdout=args.holdout, alpha=args.alpha, resolution=args.resolution,
                  names=names, model_name=os.path.basename(args.model or ""), progress=say)
    print(dx.summary())
    command = _command(args)
    if args.json:
        from narx.atomic import atomic_write_text
        doc = dx.to_dict()
        doc["settings"]["command"] = command
        atomic_write_text(args.json, json.dumps(doc, indent=2, allow_nan=False) + "\n")
        print(f"report written to {args.json}")
    if args.report:
        path = write_report(args.report, dx, command, os.path.basename(args.train))
        print(f"report written to {path}")
    return 0
