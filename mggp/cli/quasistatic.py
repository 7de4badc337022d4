"""``mggp quasistatic``: how a model forms its loop (Fig. 7 of Abreu et al. 2020).

Typical use::

    mggp quasistatic model.json data.csv --json qs.json --report qs/
    mggp quasistatic model.json --sine 70 1 --rate 1000 --periods 2 --units V µm

DATA.csv holds the input column(s) (the model's input names unless
``--input`` says otherwise); when it also holds the output column (the
model's output name, or ``--output``), the free run starts from its first
samples and the data are drawn. ``--sine AMPLITUDE FREQUENCY --rate HZ``
makes the input instead: u_k = AMPLITUDE sin(2π FREQUENCY k / HZ) for
``--periods`` periods (default 2), k = 0, 1, ….

The analysis is :func:`narx.quasistatic` (the rule is in its module doc).
``--json`` writes ``{"points": [{"k", "u", "branch", "roots", "attracting",
"solution", "y"}], "bounding": {...}, ...}`` with k the 0-based data row
(``roots`` is empty where ``solution`` is ``"continuum"``, ``"none"`` or
``"initial"``); ``--report DIR`` writes ``quasistatic.png`` and
``summary.md``, whose first paragraph is the conclusion. Errors: one
``error:`` line, exit code 2; files are written atomically after every check.
"""
from __future__ import annotations

import json
import os
import shlex
import sys

import numpy as np

from .app import CLIError, Files, add_signal_args

__all__ = ["register"]

#: largest record --sine makes
MAX_SAMPLES = 2_000_000


def register(sub):
    p = sub.add_parser("quasistatic", help="attracting and repelling sets, bounding "
                       "structure and free-run loop of a model")
    p.add_argument("model", metavar="MODEL.json", help="the model file to analyse")
    p.add_argument("data", metavar="DATA.csv", nargs="?", default=None,
                   help="the input record (or give --sine)")
    p.add_argument("--sine", nargs=2, type=float, metavar=("AMPLITUDE", "FREQUENCY"),
                   default=None, help="analyse AMPLITUDE sin(2π FREQUENCY t) (input units, Hz) instead "
                        "of DATA.csv (default: read DATA.csv)")
    p.add_argument("--rate", type=float, default=None, metavar="HZ",
                   help="sampling rate of --sine in samples per second (required with --sine)")
    p.add_argument("--periods", type=float, default=None,
                   help="duration of --sine in periods (default: 2)")
    p.add_argument("--bounding-step", type=float, default=0.0, metavar="DU",
                   help="input change per sample on the bounding structure's branches "
                        "(default 0: the rate at its limit, Phi1 = 0)")
    p.add_argument("--units", nargs=2, default=None, metavar=("INPUT_UNIT", "OUTPUT_UNIT"),
                   help="units for the figure's axes, e.g. V µm (default: none shown)")
    p.add_argument("--json", metavar="QS.json", default=None,
                   help="write every sample's roots, classes and the bounding structure "
                        "as JSON (default: not written)")
    p.add_argument("--report", metavar="DIR", default=None,
                   help="write summary.md and the figure to this folder (default: none)")
    add_signal_args(p, inputs="the model's input names", output="the model's output name")
    p.set_defaults(func=_cmd_quasistatic, files=Files(
        {"model": "MODEL.json", "data": "DATA.csv"}, {"json": "--json"}, {"report": "--report"}))


def _sine(args, model):
    amp, freq = args.sine
    rate = args.rate
    periods = 2.0 if args.periods is None else args.periods
    if rate is None:
        raise CLIError("--sine needs --rate HZ (samples per second)")
    if not (np.isfinite(amp) and amp > 0):
        raise CLIError(f"--sine AMPLITUDE must be a finite number > 0, got {amp:g}")
    if not (np.isfinite(rate) and rate > 0):
        raise CLIError(f"--rate must be a finite number > 0, got {rate:g}")
    if not (np.isfinite(freq) and 0 < freq < rate / 2):
        raise CLIError(f"--sine FREQUENCY must be > 0 and below half of --rate "
                       f"({rate / 2:g} Hz), got {freq:g}")
    if not (np.isfinite(periods) and periods > 0):
        raise CLIError(f"--periods must be a finite number > 0, got {periods:g}")
    n = periods * rate / freq
    if n > MAX_SAMPLES:
        raise CLIError(f"--sine with --periods {periods:g} at --rate {rate:g} makes "
                       f"{n:.0f} samples, more than {MAX_SAMPLES}")
    n = int(round(n))
    if n < model.max_lag + 2:
        raise CLIError(f"--sine makes {n} samples, too few for the model's largest lag "
                       f"{model.max_lag}: give more --periods")
    if len(model.inputs) != 1:
        raise CLIError(f"--sine makes one input; the model has {len(model.inputs)} "
                       f"{list(model.inputs)}: give DATA.csv")
    k = np.arange(n)
    return amp * np.sin(2 * np.pi * freq * k / rate), None, \
        f"u = {amp:g} sin(2π {freq:g} t), {rate:g} samples/s, {periods:g} periods"


def _record(args, model):
    from narx.records.csvdata import read_columns, read_csv
    inputs = args.input or list(model.inputs)
    if len(inputs) != len(model.inputs):
        raise CLIError(f"--input: the model has {len(model.inputs)} input(s) "
                       f"{list(model.inputs)}, got {len(inputs)} column name(s)")
    output = args.output or model.output
    _, header = read_columns(args.data, inputs)
    has_y = output in header
    data = read_csv(args.data, inputs=inputs, output=output if has_y else None,
                    min_samples=model.max_lag + 2,
                    purpose=f"for the model's largest lag {model.max_lag}")
    U = data.U.T
    return (U[:, 0] if U.shape[1] == 1 else U), (data.y if has_y else None), \
        os.path.basename(args.data)


def _cmd_quasistatic(args) -> int:
    from narx import load_model
    from narx.atomic import atomic_write_text, check_writable
    from narx.analysis.quasistatic import quasistatic
    from ..report.quasistatic import conclusion, plot_quasistatic, summary_markdown
    if (args.data is None) == (args.sine is None):
        raise CLIError("give DATA.csv or --sine AMPLITUDE FREQUENCY --rate HZ (one of them)")
    if args.sine is None:
        for opt, v in (("--rate", args.rate), ("--periods", args.periods)):
            if v is not None:
                raise CLIError(f"{opt} applies to --sine only, got {opt} {v:g} with "
                               f"{args.data}")
    elif args.input or args.output:
        raise CLIError("--input/--output name DATA.csv columns; --sine makes the input")
    if not (np.isfinite(args.bounding_step) and args.bounding_step >= 0):
        raise CLIError(f"--bounding-step must be a finite number >= 0, got "
                       f"{args.bounding_step:g}")
    if args.json:
        check_writable(args.json, "--json")
    if args.report and os.path.exists(args.report) and not os.path.isdir(args.report):
        raise CLIError(f"--report {args.report} is a file, not a folder")
    model = load_model(args.model)
    if model.theta is None:
        raise CLIError(f"{args.model}: the model has no θ")
    u, y, source = _sine(args, model) if args.sine is not None else _record(args, model)
    qs = quasistatic(model, u, y, bounding_step=args.bounding_step)
    c = qs.counts()
    print(f"{os.path.basename(args.model)} on {source}: {qs.k.size} samples, "
          f"{qs.method} frozen equation (output lags {list(qs.lags) or 'none'})")
    for b, v in c.items():
        if v["samples"]:
            print(f"  {b:<9s} {v['samples']:>7d} samples: attracting solution on "
                  f"{v['attracting']}, only repelling on {v['repelling_only']}, continuum "
                  f"on {v['continuum']}, none on {v['none']}")
    for line in conclusion(qs):
        print(line)
    if args.json:
        doc = {"model": str(args.model), "input": source, **qs.to_dict()}
        atomic_write_text(args.json, json.dumps(doc, allow_nan=False) + "\n")
        print(f"points written to {args.json}")
    if args.report:
        os.makedirs(args.report, exist_ok=True)
        units = args.units or (None, None)
        lab = [f"{n} ({s})" if s else n for n, s in zip((qs.inputs[0], qs.output), units)]
        fig = plot_quasistatic(os.path.join(args.report, "quasistatic.png"), qs,
                               f"Quasi-static analysis of {os.path.basename(args.model)}",
                               *lab)
        cmd = "mggp " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if sys.argv else None
        path = os.path.join(args.report, "summary.md")
        atomic_write_text(path, summary_markdown(
            qs, f"Quasi-static analysis: {os.path.basename(args.model)} on {source}",
            os.path.basename(fig), cmd))
        print(f"report written to {path}")
    return 0
