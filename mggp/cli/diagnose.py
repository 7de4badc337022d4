"""``mggp diagnose``: what a model's simulation gets wrong, why, and the gain of fixing it.

Typical use::

    mggp diagnose train.csv --validation val.csv --json dx.json --report dx/ --seed 0 --jobs 2
    mggp diagnose train.csv --model pem.json --validation held.csv      # diagnose your model
    mggp diagnose train.csv --population 1000 --generations 200 --jobs 4  # spend more
    mggp diagnose train.csv --out best.json            # save the recommended model
    mggp diagnose train.csv --validation v.csv --validation-input volts --validation-output um

Without ``--model`` the baseline is an MGGP model with multiple-shooting
fitness and no Φ-functions. Without ``--validation`` the last
``--holdout`` fraction of TRAIN.csv measures the gain and the rest fits;
with it, the head of VAL.csv and every other block of its rest join the
selection samples, and the blocks between them measure.
The terminal shows a short summary; ``--json`` writes the findings,
both models and the gain (schema in :mod:`mggp.diagnose`); ``--report``
writes ``summary.md`` and figures; ``--out`` writes the recommended model
(the extension if it won the paired held-out test on the selection
samples, else the baseline; ``meta['diagnose']`` says which, why, and the
gain measured on the measuring samples).
The validation record's columns default to the training record's names;
``--validation-input``/``--validation-output`` name them otherwise. Each
MGGP search shows the generation line of ``mggp fit`` (``--quiet``: no
progress at all). Files are written after the diagnosis succeeded; the
data files are only read.
"""
from __future__ import annotations

import json
import os
import shlex
import sys

from .app import BEYOND, UNSCORED, CLIError, Files, add_signal_args
from ..fit.params import (DIAGNOSE_PARAMS, NAMES, PATH, Bool, Kind, Param, add_options,
                     check_options)

__all__ = ["register", "DIAGNOSE_OPTIONS"]

#: options of ``mggp diagnose``: the records and outputs, the search budget
#: and the tests' settings (rules and defaults from :mod:`mggp.fit.params`)
DIAGNOSE_OPTIONS = (
    Param("validation", None, PATH, "second record: its head and every other block "
          "join the selection samples, the blocks between measure the gain", "data",
          "--validation", metavar="VAL.csv", default_text="a tail of TRAIN.csv",
          estimator=False),
    Param("model", None, PATH, "the model to diagnose", "data", "--model",
          metavar="MODEL.json", default_text="an MGGP model, multiple-shooting fitness, "
          "no Φ", estimator=False),
    Param("json", None, PATH, "write the findings, both models and the gain as JSON",
          "output", "--json", metavar="REPORT.json", default_text="not written",
          estimator=False),
    Param("report", None, PATH, "write summary.md and figures to this folder", "output",
          "--report", metavar="DIR", default_text="none", estimator=False),
    Param("validation_input", None, NAMES, "input column name(s) of the validation record, "
          "in the order of the training record's inputs", "data", "--validation-input",
          nargs="+", metavar="NAME", default_text="the training record's", estimator=False),
    Param("validation_output", None, Kind("a name", lambda v: v is None or isinstance(v, str)),
          "output column name of the validation record", "data", "--validation-output",
          metavar="NAME", default_text="the training record's", estimator=False),
    Param("out", None, PATH, "write the recommended model (the extension if it won, else "
          "the baseline; its meta says which and why)", "output", "--out",
          metavar="MODEL.json", default_text="not written", estimator=False),
    Param("quiet", False, Bool(), "no progress lines", "output", "--quiet", const=True,
          default_text="progress on stderr, and each search's generation line",
          estimator=False),
) + tuple(DIAGNOSE_PARAMS.values())


#: what the default budget costs, as measured (the --help of the budget group)
BUDGET_TIME = ("defaults: about 30 s for 10,000 samples with --jobs 2 on an idle 2-core "
               "machine, most of it the baseline search")


def register(sub):
    p = sub.add_parser("diagnose", help="name what a model's simulation gets wrong, "
                       "extend the model, measure the gain")
    p.add_argument("train", metavar="TRAIN.csv", help="training record")
    groups = add_options(p, DIAGNOSE_OPTIONS)
    groups["budget"].description = BUDGET_TIME
    add_signal_args(groups["data"])
    p.set_defaults(func=_cmd_diagnose, files=Files(
        {"train": "TRAIN.csv", "validation": "--validation", "model": "--model"},
        {"out": "--out", "json": "--json"}, {"report": "--report"}))


def _check_args(args):
    check_options(args, DIAGNOSE_OPTIONS)       # each option's rule; defaults filled
    if args.json:
        if os.path.isdir(args.json):
            raise CLIError(f"--json {args.json} is a folder, not a file")
        folder = os.path.dirname(os.path.abspath(args.json))
        if not os.path.isdir(folder):
            raise CLIError(f"--json {args.json}: folder {folder} does not exist")
    if args.report and os.path.exists(args.report) and not os.path.isdir(args.report):
        raise CLIError(f"--report {args.report} is a file, not a folder")
    if args.out:
        from narx.atomic import check_writable
        check_writable(args.out, "--out")
    if (args.validation_input or args.validation_output) and not args.validation:
        raise CLIError("--validation-input/--validation-output name the columns of "
                       "--validation VAL.csv, which was not given")


def _command(args) -> str:
    """The command line that reproduces this run (options at their defaults left out)."""
    parts = ["mggp", "diagnose", args.train]
    for p in DIAGNOSE_OPTIONS + _SIGNALS:
        v = getattr(args, p.name)
        if v == p.default or p.name == "quiet" or (p.name == "holdout" and args.validation):
            continue
        parts.append(p.flag)
        parts += [str(x) for x in v] if isinstance(v, list) else [str(v)]
    return " ".join(shlex.quote(p) for p in parts)


#: ``--input``/``--output`` as :func:`_command` writes them
_SIGNALS = (Param("input", None, PATH, "", "data", "--input"),
            Param("output", None, PATH, "", "data", "--output"))


def _read_validation(args, inputs, output):
    """The validation record with the training record's signal names: its
    columns are ``--validation-input``/``--validation-output`` (default: the
    training record's names); a different number of inputs is an error."""
    from narx.records.csvdata import read_csv
    from narx.records.data import Data
    if not args.validation:
        return None
    v_inputs = args.validation_input or inputs
    if len(v_inputs) != len(inputs):
        raise CLIError(f"--validation-input: the training record has {len(inputs)} input(s) "
                       f"{list(inputs)}, got {len(v_inputs)} validation column name(s) "
                       f"{list(v_inputs)}")
    v_output = args.validation_output or output
    val = read_csv(args.validation, inputs=v_inputs, output=v_output, varying_output=UNSCORED)
    return Data(val.U.T, val.y, inputs=list(inputs), output=output)


def _say_ranges(args, model, train, val) -> None:
    """A warning line for each record whose inputs leave the training range
    (:func:`narx.records.ranges.range_line`): with ``--model`` both records against
    the ranges the model records, else the validation record against the
    training record's."""
    from narx.records.ranges import range_line, recorded_ranges, signal_ranges
    if model is not None:
        ranges, records = recorded_ranges(model), [(args.train, train),
                                                   (args.validation, val)]
    else:
        ranges, records = signal_ranges(train), [(args.validation, val)]
    for name, data in records:
        line = "" if data is None else range_line(ranges, data)
        if line:
            print(f"warning: {name}: {line}", file=sys.stderr)


def _cmd_diagnose(args) -> int:
    from narx import load_model
    from narx.records.csvdata import read_csv
    from ..diagnose import Budget, diagnose
    from ..diagnose.report import write_report
    _check_args(args)
    model = load_model(args.model) if args.model else None
    inputs = args.input or (list(model.inputs) if model else ["u"])
    output = args.output or (model.output if model else "y")
    if model is not None and len(inputs) != len(model.inputs):
        raise CLIError(f"--input: the model has {len(model.inputs)} input(s) "
                       f"{list(model.inputs)}, got {len(inputs)} column name(s)")
    train = read_csv(args.train, inputs=inputs, output=output,
                     varying_output="nothing can be identified")
    val = _read_validation(args, inputs, output)
    if model is not None and (list(model.inputs) != inputs or model.output != output):
        from narx.records.data import Data
        train = Data(train.U.T, train.y, inputs=model.inputs, output=model.output)
        if val is not None:
            val = Data(val.U.T, val.y, inputs=model.inputs, output=model.output)
    if model is not None:
        fr = model.simulate(train, mode="freerun")
        if fr.diverged:
            raise CLIError(f"the model {args.model} is unstable on {args.train}: its free "
                           f"run diverged (output {BEYOND} the data's magnitude); "
                           f"a model whose simulation diverges has no simulation to diagnose")
    _say_ranges(args, model, train, val)
    budget = Budget(population=args.population, generations=args.generations,
                    max_terms=args.max_terms, max_height=args.max_height,
                    max_degree=args.max_degree, window=args.window, shifts=args.shifts)
    say = None if args.quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    from .fit import _Progress
    search_progress = None if args.quiet else (
        lambda generations: [_Progress(generations, sys.stderr, False)])
    names = (os.path.basename(args.train),
             os.path.basename(args.validation) if args.validation else "")
    dx = diagnose(train, val, model, budget=budget, seed=args.random_state, jobs=args.n_jobs,
                  holdout=args.holdout, alpha=args.alpha, level=args.level, resolution=args.resolution,
                  names=names, model_name=os.path.basename(args.model or ""), progress=say,
                  search_callbacks=search_progress, outliers=args.outliers)
    print(dx.summary())
    command = _command(args)
    if args.out:                              # saved first: a closed pipe loses nothing
        rec = dx.recommended_model(command)
        rec.save(args.out)
        print(f"{dx.gain.recommended} model written to {args.out}")
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
