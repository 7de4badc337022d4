"""Measured-record panel: what ``mggp fit DATA.csv`` gives on records from other labs.

Typical call::

    python -m benchmarks.measured --jobs 2 --json measured.json      # default budget, seed 1
    python -m benchmarks.measured --population 60 --generations 10    # a smoke run

Each record is fitted the way a newcomer would fit it, with
:class:`mggp.MGGPRegressor`'s defaults (what ``mggp fit DATA.csv --seed S``
runs), and its model simulated in free run on the record's validation part
from its first measured samples, its memory operators started from the
history that fits those first samples best (``history='estimate'``, what
``mggp simulate`` and ``MGGPRegressor.simulate`` do by default). The table gives, per record, the
validation RMSE beside the best published figure where one exists (in the
record's units), the automatic choices the fit made, and whether the free
run *explodes*: leaves the band of three times the validation output's
range centred on that range (:func:`explodes`), or diverges.

Records (:data:`RECORDS`; files from the project's shared data, see
``SOURCES.md`` there; a missing file skips the record with one line):

- **cascaded tanks** (measured; nonlinearbenchmark.org): ``uEst → yEst``
  training, ``uVal → yVal`` validation, V. Best published simulation RMSE:
  grey-box 0.191 V.
- **buck converter** (probably measured; sysidentpy-data): ``input → y``,
  1,001 training and 999 validation samples, V; no published figure.
- **MR damper** (simulated Bouc–Wen damper of the shared data): inputs
  displacement ``x``, velocity ``v`` and voltage ``E``, output force
  ``f``, unscaled; training rows 400–1999, validation rows 2001–3599 (the
  published protocol's split). The published figure (FROLS with sign(v),
  RRSE 0.0451) is on max-scaled signals and is given as RRSE beside ours.
- **piezo (measured)**: ``voltage → displacement`` of
  ``piezo_150V_1Hz.csv`` taken every 10th sample (2 ms steps, as a user
  with a 500 Hz logger would), fitted on t = 3–7 s and validated on
  t = 7–10 s, µm. Sensor noise about 0.06 µm; the paper's sparse ODE model
  reaches 0.092 µm in sample (no held-out figure published).
- **Bouc–Wen oscillator, sweep** (Noël–Schoukens equations,
  :func:`benchmarks.panel.bouc_wen_oscillator`, simulated here): trained on
  a multisine of 8,192 samples, validated on a 5 → 150 Hz sweep from rest,
  mm; the benchmark's published figures are on its own multisine test, so
  none is given beside the sweep.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
import warnings

import numpy as np

from narx import Data

from .budget import add_budget_args, budget

__all__ = ["RECORDS", "explodes", "run", "markdown", "main"]

#: the band a free run must stay in: this many times the validation
#: output's range, centred on that range
EXPLODE_FACTOR = 3.0


def explodes(y_hat, y) -> bool:
    """True when the free run ``y_hat`` is not finite or leaves the band of
    :data:`EXPLODE_FACTOR` times the range of the measured ``y``, centred on
    that range: :math:`|\\hat y_k - m| > \\tfrac{3}{2} R` for some k, with
    :math:`m` the middle and :math:`R` the width of ``y``'s range."""
    y_hat, y = np.asarray(y_hat, float), np.asarray(y, float)
    if not np.all(np.isfinite(y_hat)):
        return True
    lo, hi = float(np.min(y)), float(np.max(y))
    mid, half = (lo + hi) / 2, EXPLODE_FACTOR * (hi - lo) / 2
    return bool(np.any(np.abs(y_hat - mid) > half))


def _columns(name, cols):
    from narx.records.csvdata import read_columns

    from .mr_damper import data_path
    path = data_path(name)
    if path is None:
        return None
    arr, _ = read_columns(path, list(cols))
    return arr


def _tanks():
    from .real_data import load_record
    return load_record("cascaded tanks")


def _buck():
    from .real_data import load_record
    return load_record("buck converter")


def _damper():
    arr = _columns("mr_damper.csv", ("x", "v", "E", "f"))
    if arr is None:
        return None
    names = dict(inputs=["x", "v", "E"], output="f")
    tr, va = arr[400:2000], arr[2001:3600]
    return Data(tr[:, :3], tr[:, 3], **names), Data(va[:, :3], va[:, 3], **names)


def _piezo():
    arr = _columns("piezo_150V_1Hz.csv", ("t", "voltage", "displacement"))
    if arr is None:
        return None
    arr = arr[::10]
    t = arr[:, 0]
    names = dict(inputs=["voltage"], output="displacement")
    fit, val = (t >= 3.0) & (t < 7.0), (t >= 7.0) & (t <= 10.0)
    return (Data(arr[fit, 1:2], arr[fit, 2], **names),
            Data(arr[val, 1:2], arr[val, 2], **names))


def _oscillator():
    from .oscillator import records
    train, _, sweep = records(n_train=8_192, n_multisine=8, n_sweep=16_384)
    return train, sweep


#: name -> (loader, unit, {published model: validation RMSE in the unit})
RECORDS = {
    "cascaded tanks": (_tanks, "V", {"grey-box": 0.191, "CT-SUBNET": 0.306}),
    "buck converter": (_buck, "V", {}),
    "MR damper": (_damper, "N", {}),
    "piezo (measured)": (_piezo, "µm", {}),
    "Bouc-Wen oscillator, sweep": (_oscillator, "mm", {}),
}
#: published RRSE (not RMSE) where that is the figure the source gives
PUBLISHED_RRSE = {"MR damper": {"FROLS with sign(v), max-scaled signals": 0.0451}}


def _fit(train: Data, val: Data, seed: int, budget: dict, jobs: int) -> dict:
    from mggp import MGGPRegressor
    from narx.simulation.metrics import rrse
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est = MGGPRegressor(random_state=seed, n_jobs=jobs, **budget).fit(train)
        model = est.get_best()
        sim = model.simulate(val, mode="freerun", history="estimate")
    y_hat = np.asarray(sim.y_hat, float)
    ok = np.asarray(sim.valid, bool) if getattr(sim, "valid", None) is not None else \
        np.ones(len(y_hat), bool)
    diverged = bool(sim.diverged) or not np.isfinite(sim.rmse)
    y = np.asarray(val.y, float)
    return {"rmse": float("inf") if diverged else float(sim.rmse),
            "rrse": float("inf") if diverged else float(rrse(y[ok], y_hat[ok])),
            "explodes": diverged or explodes(y_hat[ok], y[ok]),
            "terms": model.n_terms, "equation": model.equation(), "history": sim.history,
            "seconds": time.perf_counter() - t0,
            "choices": {k: v["value"] for k, v in getattr(est, "choices_", {}).items()},
            "why": {k: v["why"] for k, v in getattr(est, "choices_", {}).items()}}


def run(names, seeds, budget: dict, jobs: int, log=print) -> dict:
    """``{record: {"unit", "published", "rows": [row per seed]}}``."""
    out = {}
    for name in names:
        loader, unit, published = RECORDS[name]
        pair = loader()
        if pair is None:
            log(f"{name}: data files not found (set MGGP_SHARED_DATA)")
            continue
        rows = []
        for seed in seeds:
            r = _fit(*pair, seed, budget, jobs)
            rows.append(r)
            log(f"{name} seed {seed}: RMSE {r['rmse']:.4g} {unit}, {r['terms']} terms, "
                f"{'EXPLODES, ' if r['explodes'] else ''}{r['seconds']:.0f} s")
        out[name] = {"unit": unit, "published": published,
                     "published_rrse": PUBLISHED_RRSE.get(name, {}), "rows": rows}
    return out


def markdown(res: dict) -> str:
    """The panel's table: median validation RMSE of the default fit over the
    seeds, the best published figure, whether any free run exploded, and
    the first seed's choices."""
    n_exploded = sum(r["explodes"] for v in res.values() for r in v["rows"])
    n_rows = sum(len(v["rows"]) for v in res.values())
    md = [f"The default `mggp fit` exploded on {n_exploded} of {n_rows} validation runs "
          f"(free run outside {EXPLODE_FACTOR:g}× the output's range).", "",
          "| record | default RMSE (median) | RRSE | best published | explodes | terms | "
          "automatic choices (first seed; their reasons are in the JSON) |",
          "|---|---:|---:|---|---|---:|---|"]
    for name, v in res.items():
        rows, unit = v["rows"], v["unit"]
        med = float(np.median([r["rmse"] for r in rows]))
        rr = float(np.median([r["rrse"] for r in rows]))
        pub = "; ".join(f"{k} {x:g} {unit}" for k, x in v["published"].items())
        pub_rr = "; ".join(f"{k}: RRSE {x:g}" for k, x in v["published_rrse"].items())
        pub = "; ".join(p for p in (pub, pub_rr) if p) or "—"
        exp = sum(r["explodes"] for r in rows)
        choices = ", ".join(f"{k} {c}" for k, c in rows[0]["choices"].items()
                            if k not in ("outliers",)).replace("|", "/")
        md.append(f"| {name} | {med:.4g} {unit} | {rr:.3g} | {pub} | {exp}/{len(rows)} | "
                  f"{rows[0]['terms']} | {choices} |")
    return "\n".join(md)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.measured",
                                description=__doc__.split("\n")[0])
    add_budget_args(p, seeds=[1])
    p.add_argument("--records", nargs="+", choices=list(RECORDS), default=list(RECORDS),
                   metavar="NAME")
    p.add_argument("--json", help="also write the rows here")
    a = p.parse_args(argv)
    res = run(a.records, a.seeds, budget(a), a.jobs, log=lambda s: print(s, flush=True))
    if not res:
        print("error: no record's data found (set MGGP_SHARED_DATA)", file=sys.stderr)
        return 2
    print(markdown(res))
    if a.json:
        from narx.atomic import atomic_write_text
        atomic_write_text(a.json, json.dumps(res, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
