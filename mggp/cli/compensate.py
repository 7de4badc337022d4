"""``mggp compensate``: the actuator input that makes it follow a reference.

Typical use::

    mggp compensate model.json reference.csv --out input.csv --input-range -80 80

MODEL.json is an identified actuator model (``mggp fit``/``estimate``),
inverted step by step by polynomial roots (:mod:`narx.analysis.compensate`), or a
data-driven compensator saved by
:meth:`mggp.compensate.InverseCompensator.save` (its ``meta`` says so), run
in free run. REFERENCE.csv has a header row and the desired output in column
``r`` (``--reference NAME`` otherwise). INPUT.csv gets the columns ``r``, the
model's input name (the actuator input to apply), ``y_model`` (the model's
output under it; empty for a data-driven compensator) and ``fallback`` (1
where no root was admissible). Errors: one ``error:`` line, exit code 2; the
output is written atomically, after every check. A model-based input of
which more than half of the steps fell back is refused unless
``--allow-fallbacks``; a non-minimum-phase model (a zero of its linear input
part outside the unit circle, :func:`narx.analysis.inverse_check.inverse_stability`)
is named in one ``warning:`` line (or in the error).
"""
from __future__ import annotations

import csv
import os
import warnings

import numpy as np

from .app import BEYOND, CLIError, Files, fmt

__all__ = ["register"]


def register(sub):
    p = sub.add_parser("compensate", help="compute the actuator input that tracks a reference")
    p.add_argument("model", metavar="MODEL.json",
                   help="an identified actuator model (fit or estimate), or a data-driven "
                        "compensator saved by InverseCompensator.save")
    p.add_argument("reference", metavar="REFERENCE.csv",
                   help="CSV with a header row and the desired output in a column")
    p.add_argument("--out", metavar="INPUT.csv",
                   help="write the columns: the reference, the model's input (the actuator input to "
                        "apply), y_model and fallback here (default: not written, only "
                        "the summary is printed)")
    p.add_argument("--reference-column", "--reference", dest="column", default="r",
                   metavar="NAME", help="column of the reference (default r)")
    p.add_argument("--input-range", nargs=2, type=float, metavar=("LOW", "HIGH"),
                   default=None, help="bounds of the actuator input; roots outside are "
                                      "not admissible (default: unbounded)")
    p.add_argument("--lead", type=int, default=None, metavar="L",
                   help="samples of reference preview (default: the model's input delay d)")
    p.add_argument("--fallback", choices=["minimise", "hold"], default="minimise",
                   help="input when no root is admissible: minimise: the input that "
                        "minimises |y - r|; hold: the last input (default minimise)")
    p.add_argument("--max-step", type=float, default=None, metavar="DU",
                   help="largest input change per sample, a slew limit (default: none)")
    p.add_argument("--u-past", type=float, default=None, metavar="U",
                   help="actuator input before the record (default: where the model "
                        "rests with its output at --y-past, within the input range it was "
                        "fitted on; the middle of that range when any or no input rests "
                        "there; 0 without a recorded range)")
    p.add_argument("--y-past", type=float, default=None, metavar="Y",
                   help="model output before the record (default: the reference's first "
                        "value, at rest on it)")
    p.add_argument("--allow-fallbacks", action="store_true",
                   help="write the input even when more than half of the steps fall back "
                        "(refused by default: the tracking is then usually worse than with "
                        "no compensation)")
    p.set_defaults(func=_cmd_compensate, files=Files(
        {"model": "MODEL.json", "reference": "REFERENCE.csv"}, {"out": "--out"}))


def _cmd_compensate(args) -> int:
    from narx import load_model
    from narx.analysis.compensate import NonMinimumPhaseWarning, RootCompensator, operator_refusal
    from narx.records.csvdata import read_columns
    from narx.atomic import atomic_writer
    from ..compensate import INVERSE_KIND, InverseCompensator
    if args.lead is not None and args.lead < 0:
        raise CLIError(f"--lead must be >= 0, got {args.lead}")
    if args.input_range is not None:
        lo, hi = args.input_range
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise CLIError(f"--input-range must be finite LOW HIGH with LOW < HIGH, "
                           f"got {lo:g} {hi:g}")
    if args.max_step is not None and not 0 < args.max_step < np.inf:
        raise CLIError(f"--max-step must be a finite number > 0, got {args.max_step:g}")
    for opt in ("u_past", "y_past"):
        v = getattr(args, opt, None)
        if v is not None and not np.isfinite(v):
            raise CLIError(f"--{opt.replace('_', '-')} must be a finite number, got {v}")
    if args.out and os.path.isdir(args.out):
        raise CLIError(f"--out {args.out} is a folder, not a file")
    model = load_model(args.model)
    arr, _ = read_columns(args.reference, [args.column])
    r = arr[:, 0]
    if args.y_past is None:
        args.y_past = float(r[0])
    info = model.meta.get("compensator")
    inverse = isinstance(info, dict) and info.get("kind") == INVERSE_KIND
    if not inverse and operator_refusal(model):
        raise CLIError(f"{args.model}: {operator_refusal(model)}")
    if args.u_past is None:
        args.u_past = _rest_input(model, args.y_past, inverse)
    if inverse:
        for opt, v, default in (("--max-step", args.max_step, None),
                                ("--fallback", args.fallback, "minimise")):
            if v != default:
                raise CLIError(f"{opt} {v} applies to model-based compensators only; "
                               f"{args.model} is a data-driven compensator")
        comp = InverseCompensator.from_model(model, args.input_range)
        if args.lead is not None:
            comp.lead = args.lead
        res = comp.run(r, u_past=args.u_past, r_past=args.y_past)
        name = model.output
        clip = (f"; {res.saturated} clipped to the input range {args.input_range[0]:g} .. "
                f"{args.input_range[1]:g}" if args.input_range is not None else "")
        print(f"data-driven compensator, lead {comp.lead}: {r.size} samples{clip}")
    else:
        try:
            with warnings.catch_warnings():      # said below, once, with the outcome
                warnings.simplefilter("ignore", NonMinimumPhaseWarning)
                comp = RootCompensator(model, input_range=args.input_range, lead=args.lead,
                                       fallback=args.fallback, max_step=args.max_step,
                                       u_past=args.u_past, y_past=args.y_past)
        except ValueError as exc:
            raise CLIError(f"{args.model}: {exc}") from None
        chk = comp.inverse_check
        nmp = ("" if chk.minimum_phase else
               f"{chk.describe()}; use a data-driven compensator "
               f"(mggp.compensate.identify_inverse) or a PI loop (mggp.compensate.pi_loop)")
        res = comp.run(r)
        if res.diverged:
            raise CLIError(f"the inverse of {args.model} diverges on {args.reference} at "
                           f"sample {res.diverged_at} (input or model output {BEYOND} "
                           f"the signals' magnitude): the model cannot be inverted "
                           f"stably there; " + (nmp or
                           f"give --input-range LOW HIGH, --max-step, the "
                           f"state before the record (--u-past, --y-past), or a model "
                           f"whose inverse is stable"))
        name = model.inputs[0]
        d, n = res.delay, r.size
        hit = ~res.fallback[: max(0, n - d)]        # y_model[j + d] answers target[j]
        err = np.abs(res.y_model[d:] - res.target[: n - d])[hit] if n > d else np.zeros(0)
        print(f"root compensator: input delay d = {d}, lead {res.lead}: {n} samples; "
              f"fallbacks {res.fallbacks} ({100 * res.fallback_rate:.2f} %), "
              f"{res.saturated} whose exact root lay outside the input range or "
              f"beyond --max-step (the target was not reachable in one step); "
              + (f"max |y_model - target| at the other steps {fmt(float(err.max()))}"
                 if err.size else "no step had an admissible root"))
        _fallback_verdict(res.fallback_rate, nmp, args.allow_fallbacks)
    if name in (args.column, "y_model", "fallback"):
        name = name + "_input"
    print(f"actuator input spans {fmt(float(res.m.min()))} .. {fmt(float(res.m.max()))}")
    if args.out:
        ym = res.y_model
        with atomic_writer(args.out, newline="") as fh:
            w = csv.writer(fh)
            w.writerow([args.column, name, "y_model", "fallback"])
            for j in range(r.size):
                w.writerow([repr(float(r[j])), repr(float(res.m[j])),
                            "" if ym is None else repr(float(ym[j])),
                            int(res.fallback[j])])
        print(f"input written to {args.out}")
    return 0


def _fallback_verdict(rate, nmp, allow):
    """Refuse when more than half of the steps fell back (unless ``allow``), else
    warn in one line: about the fallbacks (> 5 %) and the non-minimum-phase
    model ``nmp`` (its description, or '' when minimum-phase).

    Parameters
    ----------
    rate : float
        Fraction of the steps that fell back.
    nmp : str
        Why the model's inverse is unstable, or '' when it is minimum-phase.
    allow : bool
        ``--allow-fallbacks``: warn instead of refusing.
    """
    fb = f"{100 * rate:.0f} % of the steps had no admissible root: " + (
        nmp or "the model cannot reach the reference there in one step (the reference "
               "jumps, leaves the model's range, or the model itself cannot be inverted "
               "there)")
    if rate > 0.5 and not allow:
        raise CLIError(f"{fb}; the tracking would likely be worse than with no compensation: "
                       f"nothing written (--allow-fallbacks writes it anyway)")
    if rate > 0.05:
        warnings.warn(f"{fb}; the tracking may be worse than with no compensation "
                      f"(benchmarks/RESULTS.md, compensation --more)"
                      + ("" if nmp else "; check the model, smooth the reference, or use a "
                                        "PI loop"))
    elif nmp:
        warnings.warn(nmp)


def _rest_input(model, level: float, inverse: bool) -> float:
    """Default actuator input before the record: where the model rests with
    the output (or, for a data-driven compensator, the reference) at
    ``level``, within the training range of the actuator input; the middle
    of that range when every value rests there (a continuum of steady
    states) or none does; 0 without recorded ranges."""
    from narx.analysis.compensate_args import rest_actuator, training_ranges
    actuator = model.output if inverse else model.inputs[0]
    rng = training_ranges(model).get(actuator)
    if not rng:
        return 0.0
    try:
        a = rest_actuator(model, level, actuator, *rng)
    except (ValueError, ArithmeticError):
        a = None
    return 0.5 * (rng[0] + rng[1]) if a is None else a
