"""Isolated glitches of the output and inputs: false alarms, planted glitches
found, and what the repair does to a fit (:mod:`narx.records.outliers`).

Typical use::

    python -m benchmarks.outliers                 # about a minute
    python -m benchmarks.outliers --fits 0        # the detection tables only

Five parts, each printed as a Markdown table:

1. **False alarms**: :func:`narx.records.outliers.find_spikes` (output and inputs)
   on records without glitches: Piroddi's S1-S6 at 500 and 2,000 samples,
   noise-free and with white output noise at 20 dB, 30 data seeds each,
   and the training and validation records of :mod:`benchmarks.panel` and
   :mod:`benchmarks.diagnose_panel` (the measured ones when the shared data
   are found).
2. **Pulses the system received** (the input rule's control): five systems
   (:data:`RECEIVERS`: bilinear, Hammerstein, second-order linear, a dead
   time of 6 samples, a saturating tanh), 1,000 samples of a white uniform
   input in [-1, 1] with three real pulses of one or two samples, 1 to 2
   input ranges up or down, *before* the system is simulated; output noise
   0.02; 30 seeds each. Every pulse passes the isolation and range tests;
   the rule must leave it as measured, because the output answers it.
3. **Planted glitches**: the S1-S6 records at 2,000 samples and 20 dB, one
   glitch of one sample and one of two samples at random places (at least
   50 samples apart and from the ends), each ``a`` ranges up or down
   (random sign), for ``a`` = 0.5, 1 and 2, in the output and, in a second
   table, in the input (added after the system is simulated: misread
   samples the system never received); each glitch found exactly, in part
   (one of its two samples) or missed, and the samples taken outside the
   glitches. A glitch that lands where the signal sits at the other
   extreme stays inside the range and is not a glitch by the rule: the
   small amplitudes are missed by design, not by accident.
4. **Fits**: the bilinear record of :func:`bilinear_record` (600
   samples, white input, output noise 0.02) with one output sample 10 up
   and a run of two 8 down, fitted by :class:`mggp.MGGPRegressor` with
   ``outliers='auto'`` (the default) and ``'keep'``, and the clean record,
   at a small budget (population 100, 20 generations, height 2: the
   glitches, not the budget, decide the fit); the true structure found and
   the free-run RMSE on a clean validation record.
5. **Fits with a glitched input**: the same record with one input sample
   4 up and a run of two 4 down (the input's range is 2) and a clean output.
"""
from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from narx import Data
from narx.records.outliers import find_spikes
from narx.systems.testsystems import system_by_name

SYSTEMS = ("S1", "S2", "S3", "S4", "S5", "S6")
TRUE = {"y[k-1]", "y[k-2]", "u[k-1]", "y[k-1]*u[k-1]"}


def _piroddi(name, n, snr, seed):
    try:
        with np.errstate(over="ignore", invalid="ignore"):
            d = system_by_name(name, n=n, seed=seed, output_snr=snr)
    except FloatingPointError:                  # a draw whose noise-free output diverges
        return None
    return Data(d.u, d.y)


def clean_records(seeds: int = 30):
    """``(label, Data)`` of every record without glitches (see the module)."""
    out = []
    for name in SYSTEMS:
        for n in (500, 2000):
            for snr in (None, 20.0):
                for s in range(seeds):
                    d = _piroddi(name, n, snr, s)
                    if d is not None:
                        out.append((f"Piroddi {name}", d))
    from .panel import RECORDS
    for name, make in RECORDS.items():
        rec = make()
        for part in rec or ():
            out.append((f"panel: {name}", part))
    from .diagnose_panel import RECORDS as DIAG
    for rec in DIAG:
        try:
            parts = rec.make()
        except (FileNotFoundError, OSError, SystemExit):
            continue                            # shared data not found
        for part in parts if isinstance(parts, (tuple, list)) else (parts,):
            if isinstance(part, Data) and part.y is not None:
                out.append((f"diagnosis: {rec.name}", part))
    return out


def group_table(records, flags, what: str) -> str:
    """Markdown: per group of ``records`` (the label before its colon) the
    records and how many ``flags(data)`` is true on, with a total row."""
    rows = {}
    for label, d in records:
        r = rows.setdefault(label.split(":")[0], [0, 0])
        r[0] += 1
        r[1] += bool(flags(d))
    md = [f"| records | count | {what} |", "|---|---:|---:|"]
    md += [f"| {g} | {n} | {k} |" for g, (n, k) in rows.items()]
    md.append(f"| **all** | **{sum(n for n, _ in rows.values())}** | "
              f"**{sum(k for _, k in rows.values())}** |")
    return "\n".join(md)


def validation_cell(est, val: Data) -> str:
    """The free-run RMSE of ``est``'s model on ``val``, or 'diverges'."""
    sim = est.simulate(val)
    return "diverges" if sim.diverged else f"{sim.rmse:.4g}"


def false_alarms(records) -> str:
    return group_table(records, find_spikes, "with a sample taken for a glitch")


def plant(y, amplitude, rng):
    """``y`` with a one-sample and a two-sample glitch ``amplitude`` ranges
    of ``y`` out (random signs), and their spans."""
    n, r = len(y), float(np.ptp(y))
    while True:
        a, b = sorted(rng.integers(50, n - 52, size=2))
        if b - a >= 50:
            break
    ys = y.copy()
    ys[a] += rng.choice([-1, 1]) * amplitude * r
    ys[b:b + 2] += rng.choice([-1, 1]) * amplitude * r
    return ys, [(int(a), int(a) + 1), (int(b), int(b) + 2)]


def planted(seeds: int = 30, amplitudes=(0.5, 1.0, 2.0), where: str = "output") -> str:
    """Markdown: glitches planted in the ``where`` ('output' or 'input') of
    the S1-S6 records, found exactly, in part or missed."""
    rng = np.random.default_rng(2026)
    md = [f"| glitch amplitude ({where} ranges) | glitches planted | found exactly | found in "
          "part | missed | samples taken outside them |", "|---:|---:|---:|---:|---:|---:|"]
    for amp in amplitudes:
        n = exact = part = missed = outside = 0
        for name in SYSTEMS:
            for s in range(seeds):
                d = _piroddi(name, 2000, 20.0, s)
                if d is None:
                    continue
                if where == "output":
                    ys, spans = plant(d.y, amp, rng)
                    rec = Data(d.U.T, ys)
                else:
                    us, spans = plant(np.asarray(d.U[0], dtype=float), amp, rng)
                    rec = Data(us, d.y)
                got = [(sp.start, sp.stop) for sp in find_spikes(rec)]
                taken = {k for a, b in got for k in range(a, b)}
                for a, b in spans:
                    n += 1
                    exact += (a, b) in got
                    hit = taken & set(range(a, b))
                    part += bool(hit) and (a, b) not in got
                    missed += not hit
                    taken -= set(range(a, b))
                outside += len(taken)
        md.append(f"| {amp:g} | {n} | {exact} | {part} | {missed} | {outside} |")
    return "\n".join(md)


#: systems driven through real input pulses (part 2): y[k] from the past
#: outputs ``y`` and inputs ``u`` (arrays, index k)
RECEIVERS = {
    "bilinear": lambda y, u, k: 0.6 * y[k - 1] - 0.1 * y[k - 2] + 0.8 * u[k - 1]
    + 0.3 * u[k - 1] * y[k - 1],
    "Hammerstein": lambda y, u, k: y[k - 1] - 0.3 * y[k - 2] + 0.5 * _hv(u[k - 1])
    + 0.3 * _hv(u[k - 2]),
    "second-order linear": lambda y, u, k: 1.2 * y[k - 1] - 0.5 * y[k - 2] + u[k - 1]
    + 0.5 * u[k - 2],
    "dead time 6": lambda y, u, k: 0.7 * y[k - 1] + 0.5 * u[k - 6],
    "saturating": lambda y, u, k: 0.8 * y[k - 1] + np.tanh(2.0 * u[k - 1]),
}


def _hv(u):
    return u + 0.5 * u ** 2 - 0.3 * u ** 3


def received(name: str, seed: int, n: int = 1000, noise: float = 0.02) -> Data:
    """System ``name`` of :data:`RECEIVERS` driven by a white uniform input
    in [-1, 1] with three real pulses (one or two samples, 1 to 2 input
    ranges up or down, placed before the simulation), output noise ``noise``."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, n)
    for a in rng.choice(np.arange(60, n - 60, 60), size=3, replace=False):
        w = int(rng.integers(1, 3))
        u[a:a + w] = rng.choice([-1, 1]) * (1.0 + 2.0 * rng.uniform(1.0, 2.0))
    f, y = RECEIVERS[name], np.zeros(n)
    for k in range(6, n):
        y[k] = f(y, u, k)
    return Data(u, y + noise * rng.standard_normal(n))


def received_pulses(seeds: int = 30) -> str:
    return group_table([(name, received(name, s)) for name in RECEIVERS
                        for s in range(seeds)],
                       lambda d: [sp for sp in find_spikes(d) if sp.signal != d.output],
                       "with a received pulse taken for a glitch")


def bilinear_record(seed=3, n=600, noise=0.02):
    """``(u, y)``: y[k] = 0.6 y[k-1] - 0.1 y[k-2] + 0.8 u[k-1] + 0.3 u[k-1] y[k-1]
    on a white uniform input in [-1, 1], white output noise of standard
    deviation ``noise``."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, n)
    y = np.zeros(n)
    for k in range(2, n):
        y[k] = 0.6 * y[k - 1] - 0.1 * y[k - 2] + 0.8 * u[k - 1] + 0.3 * u[k - 1] * y[k - 1]
    return u, y + noise * rng.standard_normal(n)


def glitched(y):
    """``y`` with sample 300 up by 10 and samples 431-432 down by 8 (the
    bilinear record's output range is about 2.5)."""
    ys = y.copy()
    ys[300] += 10.0
    ys[431:433] -= 8.0
    return ys


def glitched_input(u):
    """``u`` with sample 300 up by 4 and samples 431-432 down by 4 (the
    bilinear record's input range is 2)."""
    us = u.copy()
    us[300] += 4.0
    us[431:433] -= 4.0
    return us


def fits(seeds, where: str = "output") -> str:
    """Markdown: fits of the bilinear record, clean and with glitches in
    its ``where`` ('output' or 'input'), with the repair and without."""
    from mggp import MGGPRegressor
    u, y = bilinear_record(3)
    uv, yv = bilinear_record(4)
    bad = (u, glitched(y)) if where == "output" else (glitched_input(u), y)
    val = Data(uv, yv)
    md = ["| record | `outliers` | seed | true terms found | terms | validation free-run RMSE |",
          "|---|---|---:|---|---:|---:|"]
    for label, (uu, yy), how in (("clean", (u, y), "auto"), (f"{where} glitched", bad, "auto"),
                                 (f"{where} glitched", bad, "keep")):
        for s in seeds:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                est = MGGPRegressor(population=100, generations=20, max_height=2,
                                    random_state=s, outliers=how).fit(uu, yy)
            terms = {str(t) for t in est.terms_}
            md.append(f"| {label} | {how} | {s} | {len(TRUE & terms)} of 4"
                      f"{' (exact)' if terms == TRUE else ''} | {len(terms)} | "
                      f"{validation_cell(est, val)} |")
    return "\n".join(md)


def run_study(prog: str, doc: str, report, argv, seeds: int, fits: int,
              seeds_help: str) -> int:
    """The command line both data-check studies share: ``--seeds`` (data
    seeds) and ``--fits`` (fit seeds of the last part, 0: none); prints
    ``report(seeds, fit_seeds)`` and the time it took."""
    p = argparse.ArgumentParser(prog=prog, description=doc.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=seeds, help=seeds_help)
    p.add_argument("--fits", type=int, default=fits, help="fit seeds of the last part "
                   "(0: none)")
    a = p.parse_args(argv)
    t0 = time.perf_counter()
    print(report(a.seeds, range(1, a.fits + 1)))
    print(f"\n({time.perf_counter() - t0:.0f} s)")
    return 0


def sections(parts, seeds: int, last=None, fit_seeds=()) -> str:
    """Markdown sections: ``## title`` and ``make(seeds)`` for each
    ``(title, make)`` of ``parts``, then ``last`` on ``fit_seeds`` (when
    there are any)."""
    done = [(title, make(seeds)) for title, make in parts]
    if last is not None and fit_seeds:
        done.append((last[0], last[1](fit_seeds)))
    return "\n\n".join(f"## {title}\n\n{md}" for title, md in done)


def report(seeds: int = 30, fit_seeds=(1, 2, 3)) -> str:
    """The five parts as Markdown sections (the fits only with ``fit_seeds``)."""
    md = sections([("False alarms on records without glitches",
                    lambda n: false_alarms(clean_records(n))),
                   ("Pulses the system received (five systems, 1,000 samples)",
                    received_pulses),
                   ("Planted glitches in the output (S1-S6, 2,000 samples, 20 dB)", planted),
                   ("Planted glitches in the input (S1-S6, 2,000 samples, 20 dB)",
                    lambda n: planted(n, where="input"))], seeds,
                  ("Fits of a bilinear record with three glitched output samples", fits),
                  fit_seeds)
    if fit_seeds:
        md += ("\n\n## Fits of the bilinear record with three glitched input samples\n\n"
               + fits(fit_seeds, "input"))
    return md


def main(argv=None) -> int:
    return run_study("python -m benchmarks.outliers", __doc__, report, argv, 30, 3,
                     "data seeds per Piroddi setting")


if __name__ == "__main__":
    raise SystemExit(main())
