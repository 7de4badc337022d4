"""The ``mggp`` command line.

Typical use::

    mggp estimate data.csv --terms "y[k-1]" "Phi1(u[k-1],u[k-2])" --out m.json
    mggp simulate m.json data.csv --mode freerun --out pred.csv
    mggp fit data.csv --fitness ms --generations 50 --out m.json --report rep/

Every subcommand reads CSV files with a header row (input column ``u``,
output ``y`` unless ``--input``/``--output`` say otherwise). Any problem
with the input prints one line ``error: ...`` on stderr and exits with code
2; outputs are written atomically and only after every check has passed,
so nothing already written is lost or half-overwritten. An output path that
is also an input (or another output) is refused before any work
(:func:`check_files`).
"""
from __future__ import annotations

import argparse
import fnmatch
import os
import sys
import warnings
from dataclasses import dataclass, field
from typing import Dict, List, Optional

import numpy as np

from narx.linalg import DIVERGENCE_FACTOR
from narx.language.memory import HISTORIES

from ..exceptions import CLIError

__all__ = ["main", "CLIError", "build_parser", "Files", "check_files"]


class _Parser(argparse.ArgumentParser):
    """One ``error:`` line instead of a usage dump; positionals written
    after an option with values, which argparse gives to that option
    (``fit --input E v data.csv``, ``quasistatic m.json --units V um
    data.csv``), go back to the positionals left without a value.

    A list option (``nargs='+'``) may say which of its values it owns: an
    ``owns`` attribute on its action, a test of one value (a column name is
    an identifier, a term has a lagged signal ``x[k-i]``,
    :func:`is_term_text`). Its trailing values it does not own, and the
    values argparse left over (after an option of fixed arity), fill the
    missing positionals in command-line order. A required positional still
    missing then takes the last values of the list option given last.
    """

    def error(self, message):                      # no usage dump, one line
        raise CLIError(f"{self.prog.split()[-1]}: {message}")

    def parse_known_args(self, args=None, namespace=None):
        args = sys.argv[1:] if args is None else list(args)
        pos = [a for a in self._actions if not a.option_strings and a.nargs in (None, "?")]
        required = [a for a in pos if a.nargs is None and a.required]
        for a in required:                         # checked below, after the give-back
            a.required = False
        try:
            ns, rest = super().parse_known_args(args, namespace)
        finally:
            for a in required:
                a.required = True
        missing = [a for a in pos if getattr(ns, a.dest, None) is None]
        if missing:
            rest = self._give_back(args, ns, missing, rest)
        missing = [a for a in required if getattr(ns, a.dest, None) is None]
        if missing:
            self.error("the following arguments are required: "
                       + ", ".join(a.metavar or a.dest for a in missing))
        return ns, rest

    def _give_back(self, args, ns, missing, rest):
        """Fill the ``missing`` positionals from the values a list option does
        not own and from ``rest``; returns what is left of ``rest``."""
        lists = [(max(i for i, t in enumerate(args) if t in a.option_strings), a)
                 for a in self._actions if a.nargs in ("+", "*") and a.option_strings
                 and any(t in a.option_strings for t in args)]
        found = []                                 # (index in args, value, source)
        for i, a in lists:
            values = getattr(ns, a.dest)
            owns = getattr(a, "owns", None)
            if owns is None or not isinstance(values, list) \
                    or args[i + 1:i + 1 + len(values)] != values:
                continue
            keep = len(values)
            while keep > 1 and not owns(values[keep - 1]):
                keep -= 1
            found += [(i + 1 + j, values[j], a) for j in range(keep, len(values))]
        at = 0
        for v in rest:                             # left over after a fixed-arity option
            if v in args[at:] and not v.startswith("-"):
                at = args.index(v, at) + 1
                found.append((at - 1, v, None))
        found.sort(key=lambda f: f[0])
        for a, (_, v, src) in zip(missing, found):
            setattr(ns, a.dest, v)
            if src is None:
                rest = [t for t in rest if t is not v]
            else:
                setattr(ns, src.dest, [t for t in getattr(ns, src.dest) if t is not v])
        still = [a for a in missing if a.nargs is None and getattr(ns, a.dest) is None]
        if still and lists:                        # by count: the list option given last
            last = max(lists, key=lambda r: r[0])[1]
            values = getattr(ns, last.dest)
            if isinstance(values, list) and len(values) > len(still):
                setattr(ns, last.dest, values[:-len(still)])
                for a, v in zip(still, values[-len(still):]):
                    setattr(ns, a.dest, v)
        return rest


def is_term_text(v: str) -> bool:
    """Whether a command-line value is a term rather than a file name: it
    has a lagged signal (``x[k-i]``, every term but the constant) or is the
    constant ``1``."""
    return "[" in v or v.strip() == "1"


#: files a report folder gets (mggp.report.summary, mggp.diagnose.report,
#: mggp.report.quasistatic): an input there of such a name would be replaced
REPORT_FILES = ("summary.md", "*.png")


@dataclass(frozen=True)
class Files:
    """The files a subcommand reads and writes, each an argparse ``dest``
    mapped to how messages name it (``{"data": "DATA.csv"}``,
    ``{"out": "--out"}``); ``folders`` are outputs that are folders
    (``--report``). A subcommand sets it with ``set_defaults(files=...)``
    and :func:`check_files` checks it before the command runs."""

    inputs: Dict[str, str]
    outputs: Dict[str, str]
    folders: Dict[str, str] = field(default_factory=dict)


def _same_path(a, b) -> bool:
    """Whether two paths name one file: equal real paths, or (both existing)
    the same file by :func:`os.path.samefile` (hard links)."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_files(args) -> None:
    """Refuse (``CLIError``) a destination that would replace a file the
    command reads or writes otherwise: an output path that is also an input
    file (or a ``--phi-module`` file), two outputs on one path, or a report
    folder holding an input or output of a name the report writes
    (:data:`REPORT_FILES`). Called for every subcommand before any work."""
    files = getattr(args, "files", None)
    if files is None:
        return
    ins = [(label, v) for dest, label in files.inputs.items()
           if (v := getattr(args, dest, None)) is not None]
    ins += [("--phi-module", m) for m in getattr(args, "phi_module", []) if m.endswith(".py")]
    outs = [(label, v) for dest, label in {**files.outputs, **files.folders}.items()
            if (v := getattr(args, dest, None)) is not None]
    for n, (opt, path) in enumerate(outs):
        for label, src in ins:
            if _same_path(path, src):
                raise CLIError(f"{opt} {path} is also an input file ({label}); choose "
                               f"another path")
        for other, path2 in outs[:n]:
            if _same_path(path, path2):
                raise CLIError(f"{other} {path2} and {opt} {path} name the same path; "
                               f"choose another path")
    for dest, opt in files.folders.items():
        folder = getattr(args, dest, None)
        if folder is None:
            continue
        for label, src in ins + [o for o in outs if o[0] != opt]:
            name = os.path.basename(src)
            if any(fnmatch.fnmatch(name, pat) for pat in REPORT_FILES) and \
                    _same_path(os.path.dirname(os.path.abspath(src)), folder):
                raise CLIError(f"{opt} {folder} would replace the file {src} ({label}): the "
                               f"report writes {', '.join(REPORT_FILES)} there; choose "
                               f"another folder")


#: why a record of constant output cannot score a simulation
UNSCORED = ("the simulation error cannot be scored (range-normalised MAPE divides by "
            "the output range)")


#: how far a diverged simulation went, in the words of the error messages
BEYOND = f"beyond {DIVERGENCE_FACTOR:.0e}".replace("e+0", "e") + " times"


def add_signal_args(p, inputs: str = "u", output: str = "y"):
    """``--input NAME [NAME ...]`` and ``--output NAME``; ``inputs`` and
    ``output`` describe the defaults in the help."""
    p.add_argument("--input", nargs="+", metavar="NAME", default=None,
                   help=f"input column name(s) in the CSV files (default: {inputs})"
                   ).owns = str.isidentifier              # not a file name: _Parser
    p.add_argument("--output", metavar="NAME", default=None,
                   help=f"output column name in the CSV files (default: {output})")


def fmt(v: float) -> str:
    return "inf" if not np.isfinite(v) else f"{v:.6g}"


# ------------------------------------------------------------------ estimate
def _cmd_estimate(args) -> int:
    from narx import Model
    from narx.records.csvdata import read_csv
    inputs = args.input or ["u"]
    output = args.output or "y"
    data = read_csv(args.data, inputs=inputs, output=output, varying_inputs=True,
                    varying_output="nothing can be identified")
    from ..fit.params import PARAMS, check_options
    check_options(args, [PARAMS["outliers"]])   # not given: fit's default
    spikes = []
    if args.outliers == "auto":                 # the rule of fit: narx.records.outliers
        from narx.records.outliers import find_spikes, repaired
        from ..fit.choices import outliers_choice
        spikes = find_spikes(data)
        data = repaired(data, spikes)
        if spikes:
            print(f"auto: {outliers_choice(spikes, output, inputs).why}", file=sys.stderr)
    model = Model(args.terms, inputs=inputs, output=output)
    need = model.max_lag + model.n_terms
    if data.n <= need:
        raise CLIError(f"{args.data}: {data.n} samples are too few for {model.n_terms} "
                       f"terms with largest lag {model.max_lag} (need more than {need})")
    cons = "steady-state" if args.constraints == "steady-state" else None
    if args.out:
        from narx.atomic import check_writable
        check_writable(args.out, "--out")
    model.fit(data, constraints=cons)
    refined = None
    check_refine_args(args)
    if args.refine:
        from narx.refine import refine
        try:
            refined = refine(model, data, mode=args.refine,
                             window=args.refine_window or 100)
        except ValueError as exc:
            raise CLIError(f"--refine {args.refine}: {exc}") from None
        model = refined.model
    osa = model.simulate(data, mode="osa")
    fr = model.simulate(data, mode="freerun")
    if args.outliers == "auto":
        model.meta["outliers"] = [sp.span for sp in spikes]
    model.meta.update({"command": "estimate", "data": str(args.data), "n_samples": data.n,
                       "constraints": args.constraints,
                       "train": {"osa_rmse": osa.rmse, "freerun_rmse": fr.rmse,
                                 "freerun_mape": fr.mape}})
    if fr.diverged:
        warnings.warn(f"the estimated model's free run diverges on {args.data} (it may "
                      f"still serve one step ahead)")
    if args.out:                              # saved first: a closed pipe loses nothing
        model.save(args.out)
    print(model.equation())
    width = max(len(t) for t in model.term_texts)
    for i, (t, v) in enumerate(zip(model.term_texts, model.theta)):
        print(f"  θ{i + 1:<3d} {t:<{width}s}  {v: .8g}")
    if cons:
        sums = model.cluster_sums()
        print("steady-state clusters: " + ", ".join(f"Σ_{k} = {v:.3g}" for k, v in sums.items()))
    print(f"one-step-ahead RMSE {fmt(osa.rmse)}; free-run RMSE {fmt(fr.rmse)}, "
          f"MAPE {fmt(fr.mape)} %" + ("  (free run diverged)" if fr.diverged else ""))
    if refined is not None:
        print(refinement_line(refined))
    if args.out:
        print(f"model written to {args.out}")
    return 0


# ------------------------------------------------------------------ simulate
def _cmd_simulate(args) -> int:
    from narx import load_model
    from narx.records.csvdata import read_csv, write_with_column
    model = load_model(args.model)
    inputs = args.input or list(model.inputs)
    output = args.output or model.output
    if len(inputs) != len(model.inputs):
        raise CLIError(f"--input: the model has {len(model.inputs)} input(s) "
                       f"{list(model.inputs)}, got {len(inputs)} column name(s)")
    column = f"{output}_hat"
    if args.out:
        from narx.atomic import check_writable
        check_writable(args.out, "--out")
        _check_new_column(args.data, column)
    data = read_csv(args.data, inputs=inputs, output=output, varying_output=UNSCORED)
    if data.n <= model.max_lag + 1:
        raise CLIError(f"{args.data}: {data.n} samples are too few for the model's "
                       f"largest lag {model.max_lag}")
    from narx.records.data import Data
    d = Data(data.U.T, data.y, inputs=model.inputs, output=model.output)
    mode_option(args.mode, {"ksa": "k", "ms": "window"}, args)
    kw = {}
    if args.mode == "ksa":
        kw["k"] = 10 if args.k is None else args.k
    elif args.mode == "ms":
        kw["window"] = 100 if args.window is None else args.window
    from narx.records.ranges import range_warning
    outside = range_warning(model, d)
    if outside:
        print(f"warning: {outside}", file=sys.stderr)
    res = model.simulate(d, mode=args.mode, history=args.history, **kw)
    if res.diverged:
        raise CLIError(f"the model is unstable on {args.data}: its {args.mode} simulation "
                       f"diverged (output {BEYOND} the data's magnitude)")
    if args.out:
        write_with_column(args.data, args.out, column,     # empty where not simulated
                          np.where(res.valid, res.y_hat, np.nan))
    scored = int(res.valid.sum())
    why = ("initial conditions" if args.mode != "ksa" else
           f"initial conditions and the first {kw['k']}-step horizon")
    print(f"{args.mode}: RMSE {fmt(res.rmse)}  MAPE {fmt(res.mape)} %  "
          f"({scored} samples scored; the first {d.n - scored} are not: {why})")
    if res.history != "rest":
        how = "estimated on the first samples" if args.history == "estimate" else "--history"
        print(f"memory operators started as if the signals arrived {res.history} "
              f"({how})")
    if args.out:
        print(f"prediction written to {args.out}")
    return 0


def _check_new_column(path, column: str) -> None:
    """Refuse to add ``column`` to a CSV file whose header already has it."""
    from narx.records.csvdata import delimiter, iter_rows
    try:
        _, header = next(iter_rows(path, delimiter(path)))
    except StopIteration:
        return                                 # read_csv names the empty file
    if column in [h.strip() for h in header]:
        raise CLIError(f"{path}: already has a column {column!r}, the name of the "
                       f"prediction --out would add; rename it")


def build_parser() -> argparse.ArgumentParser:
    from ..version import __version__
    p = _Parser(prog="mggp", description="NARX models of hysteretic systems by "
                "multi-gene genetic programming.")
    p.add_argument("--version", action="version", version=f"mggp {__version__}")
    p.add_argument("--phi-module", action="append", default=[], metavar="MODULE",
                   help="import MODULE (a dotted name, or a .py file) before the command; "
                        "it registers your Φ-functions with narx.register_phi "
                        "(repeatable; model files never run code)")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    e = sub.add_parser("estimate", help="fit θ of given terms by LS or CLS")
    e.add_argument("data", metavar="DATA.csv",
                   help="training record: CSV with a header row, one column per signal")
    e.add_argument("--terms", nargs="+", required=True, metavar="TERM",
                   help="the model's terms in the term language, e.g. \"y[k-1]\" "
                        "\"Phi1(u[k-1],u[k-2])\" (required); DATA.csv may follow them: "
                        "a value without '[' other than the constant 1 is no term "
                        "(every other term has a lagged signal x[k-i]) and is taken as "
                        "DATA.csv").owns = is_term_text
    e.add_argument("--constraints", choices=["steady-state"], default=None,
                   help="steady-state: constrained LS (CLS) under the continuum-of-steady-"
                        "states conditions (Σ_y = 1, other cluster sums 0) derived from the "
                        "terms (default: none, plain LS)")
    add_refine_args(e, "100")
    from ..fit.params import PARAMS, add_options
    add_options(e, [PARAMS["outliers"]])      # fit's row: its rule, help and default
    e.add_argument("--out", metavar="MODEL.json",
                   help="write the fitted model here (default: not written, only printed)")
    add_signal_args(e)
    e.set_defaults(func=_cmd_estimate, files=Files({"data": "DATA.csv"}, {"out": "--out"}))

    s = sub.add_parser("simulate", help="simulate a model file on data")
    s.add_argument("model", metavar="MODEL.json", help="a model written by fit or estimate")
    s.add_argument("data", metavar="DATA.csv",
                   help="record to simulate on: CSV with a header row holding the model's "
                        "input and output columns (the output gives the initial conditions "
                        "and the error)")
    s.add_argument("--mode", choices=["freerun", "osa", "ksa", "ms"], default="freerun",
                   help="freerun: the whole record recursively from its first samples; "
                        "osa: one step ahead from measured outputs; ksa: K steps ahead "
                        "from every sample; ms: free runs over windows of W samples, each "
                        "from measured initial conditions (default freerun)")
    s.add_argument("--k", type=int, default=None, help="horizon K for --mode ksa (default 10)")
    s.add_argument("--window", type=int, default=None, metavar="W",
                   help="window Δm for --mode ms (default 100, as for fit)")
    s.add_argument("--history", choices=["estimate", *HISTORIES], default="estimate",
                   help="the path the record's signals arrived by, which starts the model's "
                        "memory operators (plays, Bouc-Wen variables): rest, rising (from "
                        "the record's minimum after its maximum), falling, or estimate: the "
                        "one whose free run fits the record's first samples best (default "
                        "estimate; a record that starts in motion leaves the state unknown)")
    s.add_argument("--out", metavar="PRED.csv",
                   help="copy DATA.csv here with one more column, the prediction, named "
                        "after the model's output (y_hat for output y, f_hat for f; empty "
                        "where not simulated) (default: not written, only the scores are "
                        "printed)")
    add_signal_args(s, inputs="the model's input names", output="the model's output name")
    s.set_defaults(func=_cmd_simulate, files=Files({"model": "MODEL.json", "data": "DATA.csv"},
                                                   {"out": "--out"}))

    for name in ("fit", "diagnose", "compensate", "quasistatic"):
        try:
            mod = __import__(f"mggp.cli.{name}", fromlist=["register"])
        except ModuleNotFoundError as exc:
            if exc.name != f"mggp.cli.{name}":
                raise
            continue
        mod.register(sub)
    return p


def _import_plugin(spec: str) -> None:
    """Import a module that registers Φ-functions: ``pkg.mod`` or ``file.py``."""
    import importlib
    import importlib.util
    try:
        if spec.endswith(".py"):
            if not os.path.isfile(spec):
                raise CLIError(f"--phi-module {spec}: no such file")
            name = "mggp_plugin_" + os.path.splitext(os.path.basename(spec))[0]
            loader = importlib.util.spec_from_file_location(name, spec)
            module = importlib.util.module_from_spec(loader)
            loader.loader.exec_module(module)
        else:
            if os.getcwd() not in sys.path:
                sys.path.insert(0, os.getcwd())
            importlib.import_module(spec)
    except CLIError:
        raise
    except Exception as exc:                   # the user's module: report, no traceback
        raise CLIError(f"--phi-module {spec}: cannot import it "
                       f"({type(exc).__name__}: {exc})") from None


def main(argv: Optional[List[str]] = None) -> int:
    """Run the command ``argv``; its warnings (``warnings.warn`` from the
    library: a gap in a time column, inputs beyond the training range)
    are held, one line each, and printed when the command ends, unless it
    ends in an error: bad input then gets its one ``error:`` line alone
    (exit code 2), and the warnings come with the rerun."""
    held: List[str] = []

    def hold(message, category, filename, lineno, file=None, line=None):
        held.append("warning: " + " ".join(str(message).split()))
    with warnings.catch_warnings():             # restores showwarning on return
        warnings.showwarning = hold
        code = _main(argv)
    if code != 2:
        for text in held:
            print(text, file=sys.stderr)
    return code


def add_refine_args(p, window_default: str) -> None:
    """``--refine ms|freerun`` and ``--refine-window W`` (see narx.refine)."""
    p.add_argument("--refine", choices=["ms", "freerun"], default=None,
                   help="refine θ by minimising the simulation error (ms: windows of "
                        "--refine-window samples) instead of the one-step error of LS, "
                        "which is biased by output noise (default: none, θ as LS or CLS "
                        "gives it)")
    p.add_argument("--refine-window", type=int, default=None, metavar="W",
                   help=f"Δm for --refine ms (default {window_default})")


def check_refine_args(args) -> None:
    """Refuse ``--refine-window`` without ``--refine ms``."""
    if args.refine_window is not None and args.refine != "ms":
        raise CLIError(f"--refine-window applies to --refine ms only, got --refine "
                       f"{args.refine}")


def refinement_line(r) -> str:
    """One line on a :class:`narx.refine.Refinement`."""
    how = r.model.meta["refined"]["mode"]
    if not r.improved:
        return (f"refinement ({how}): no lower simulation error found, θ kept "
                f"(MSE {fmt(r.cost_before)})")
    return (f"refined by {how} simulation error: MSE {fmt(r.cost_before)} -> "
            f"{fmt(r.cost_after)} ({r.nfev} optimiser steps)")


def mode_option(mode: str, uses: dict, args, flag: str = "--mode") -> None:
    """Refuse ``--k``/``--window`` given for a mode that does not use them
    (``uses``: mode -> the option it takes)."""
    for name in ("k", "window"):
        if getattr(args, name, None) is not None and uses.get(mode) != name:
            need = [m for m, o in uses.items() if o == name]
            raise CLIError(f"--{name} applies to {flag} {' or '.join(need)} only, got "
                           f"{flag} {mode}")


def _column_hint(exc, args) -> str:
    """How to name a column the CSV lacks when its name was not given but
    the default (``u``/``y``, or the model's signal names): the option
    that names it."""
    role = getattr(exc, "role", None)
    if role is None or args is None:
        return ""
    given = getattr(args, "inputs", getattr(args, "input", False))
    if role == "input" and given is None:
        return "; name the input columns with --input NAME [NAME ...]"
    if role == "output" and getattr(args, "output", False) is None:
        return "; name the output column with --output NAME"
    return ""


def _main(argv: Optional[List[str]]) -> int:
    args = None
    try:
        args = build_parser().parse_args(argv)
        check_files(args)                      # before any file is read or written
        for mod in args.phi_module:
            _import_plugin(mod)
        from ..fit.params import PARAMS
        for name in ("k", "window"):           # shared by every subcommand
            v = getattr(args, name, None)
            if v is not None:
                PARAMS[name].check(v, cli=True)
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:                   # e.g. `mggp ... | head -1`
        try:                                  # no second error at interpreter exit
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 0
    except (CLIError, ValueError, KeyError, OSError) as exc:
        msg = str(exc.args[0]) if isinstance(exc, KeyError) and exc.args else str(exc)
        if isinstance(exc, OSError) and exc.filename:
            msg = f"{exc.filename}: {exc.strerror}"
        msg += _column_hint(exc, args)
        print("error: " + " ".join(msg.split()), file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
