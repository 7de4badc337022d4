"""The default search against a grid of expert options, record by record.

Typical use::

    python -m benchmarks.panel --seeds 1 --population 60 --generations 10 --jobs 2
    python -m benchmarks.panel --seeds 1 2 3 --jobs 2 --json panel.json   # default budget
    python -m benchmarks.panel --from-json panel.json panel456.json       # tabulate, seeds pooled
    python -m benchmarks.panel --seeds 1 2 3 --grid-from panel.json --json panel.json
                                         # the default row again, the grid's rows kept

For every record, :class:`mggp.MGGPRegressor` with its defaults (what
``mggp fit DATA.csv --seed S --jobs J`` runs; the budget of ``--population``
and ``--generations`` applies to every setting alike) and with each setting
of :data:`GRID`, the expert flag combinations the studies set by hand. Each
model runs free on the record's validation part from its first measured
samples; the figure is the RMSE there (``inf``: diverged). Goals: the
default's median over the seeds within 10 % of the best grid setting's
median, and no default model diverging. The grid settings fix every
automatic choice, so a change of the defaults leaves their rows as they
are: ``--grid-from`` fits the default row only and takes the grid's rows of
the same seeds from a saved run.

Records (:data:`RECORDS`): the shared measured records (cascaded tanks, buck
converter, MR damper; :mod:`benchmarks.real_data`,
:mod:`benchmarks.mr_damper`), and simulated ones: the piezo actuator of the
case study (5,000 training samples; validation u = 40 sin(2πt)), a
Prandtl–Ishlinskii operator, a Bouc–Wen oscillator (:func:`bouc_wen_oscillator`,
validation by a sine sweep) and Piroddi's S1–S6 (validation: a record of
another noise seed).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
import warnings

import numpy as np

from narx import Data

__all__ = ["GRID", "GOAL", "RECORDS", "bouc_wen_oscillator", "run", "markdown", "merge",
           "verdict_spread"]

#: label (the flags of ``mggp fit``) -> MGGPRegressor keywords: the settings
#: the studies choose by hand (the model class, the constant term, the screen
#: and the selection), each fixed (no automatic choice left)
GRID = {
    "--phi --no-constant --screen none --select fitness --size search": dict(
        use_phi=True, constant=False, screen=None, select="fitness", size="search"),
    "--no-phi --no-constant --screen none --select fitness --size search": dict(
        use_phi=False, constant=False, screen=None, select="fitness", size="search"),
    "--phi --no-constant --select freerun": dict(use_phi=True, constant=False,
                                                 select="freerun"),
    "--no-phi --no-constant --select freerun": dict(use_phi=False, constant=False,
                                                    select="freerun"),
    "--no-phi --constant": dict(use_phi=False, constant=True),
    "--no-phi --operators play,dengtan --no-constant": dict(
        use_phi=False, operators="play,dengtan", constant=False),
    "--no-phi --operators play,dengtan,boucwen --operator-entry search --no-constant": dict(
        use_phi=False, operators="play,dengtan,boucwen", operator_entry="search",
        constant=False),
}


def bouc_wen_oscillator(u, fs=750.0, substeps=20):
    """Displacement (mm) of the Bouc–Wen oscillator of Noël and Schoukens
    (Workshop on Nonlinear System Identification Benchmarks, 2016),

    .. math:: m\\ddot y + c\\dot y + k y + z = u, \\qquad
              \\dot z = \\alpha \\dot y - \\beta(\\gamma |\\dot y| z
              + \\delta \\dot y |z|)

    m = 2 kg, c = 10 Ns/m, k = 5e4 N/m, α = 5e4 N/m, β = 1e3 m⁻¹, γ = 0.8,
    δ = −1.1, force ``u`` (N) held over each sample of 1/``fs`` s, RK4 with
    ``substeps`` steps per sample."""
    m, c, k, a, b, g, d = 2.0, 10.0, 5e4, 5e4, 1e3, 0.8, -1.1
    h = 1.0 / fs / substeps

    def f(s, uk):
        y, v, z = s
        return np.array([v, (uk - c * v - k * y - z) / m,
                         a * v - b * (g * abs(v) * z + d * v * abs(z))])
    s = np.zeros(3)
    out = np.empty(len(u))
    for i, uk in enumerate(np.asarray(u, dtype=float)):
        out[i] = s[0]
        for _ in range(substeps):
            k1 = f(s, uk)
            k2 = f(s + 0.5 * h * k1, uk)
            k3 = f(s + 0.5 * h * k2, uk)
            k4 = f(s + h * k3, uk)
            s = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return 1e3 * out


def multisine(n: int, rng, rms: float = 50.0, fs: float = 750.0) -> np.ndarray:
    """A random-phase multisine of ``n`` samples at ``fs`` Hz: every integer
    frequency from 5 to 149 Hz, phases drawn from ``rng``, scaled to
    ``rms`` (N) (the oscillator's force)."""
    t = np.arange(n) / fs
    u = sum(np.cos(2 * np.pi * fq * t + rng.uniform(0, 2 * np.pi))
            for fq in np.arange(5.0, 150.0, 1.0))
    u *= rms / np.std(u)
    return u


def sweep(n: int, f1: float, amplitude: float = 40.0, f0: float = 5.0,
          fs: float = 750.0) -> np.ndarray:
    """A linear sine sweep of ``n`` samples from ``f0`` to ``f1`` Hz, from rest."""
    t = np.arange(n) / fs
    return amplitude * np.sin(2 * np.pi * (f0 * t + 0.5 * ((f1 - f0) / t[-1]) * t ** 2))


def _oscillator():
    rng = np.random.default_rng(0)
    u = multisine(3000, rng)                       # 50 N rms, 5-150 Hz
    uv = sweep(2000, 100.0)                        # 5 -> 100 Hz, 40 N
    return Data(u, bouc_wen_oscillator(u)), Data(uv, bouc_wen_oscillator(uv))


def _piezo():
    from .casestudy import case_data
    cs = case_data(n=5000)
    return Data(cs.u, cs.y), Data(cs.uv, cs.yv)


def _pi():
    from narx.systems import prandtl_ishlinskii, sine_input, training_input
    u = training_input(3000, dt=1e-2, seed=0)
    _, uv = sine_input(duration=10.0, dt=1e-2)
    return Data(u, prandtl_ishlinskii(u)), Data(uv, prandtl_ishlinskii(uv))


def _shared(name):
    from .real_data import load_record
    return load_record(name)


def _damper():
    from .mr_damper import damper_path, load_damper
    path = damper_path()
    if path is None:
        return None
    tr, te = load_damper(path)
    names = dict(inputs=["E", "v"], output="f")
    return Data(tr[:, :2], tr[:, 2], **names), Data(te[:, :2], te[:, 2], **names)


def _piroddi(name):
    from narx.systems.testsystems import system_by_name
    d, v = system_by_name(name, n=500, seed=0), system_by_name(name, n=500, seed=100)
    return Data(d.u, d.y), Data(v.u, v.y)


#: record name -> () -> (training Data, validation Data) or None (files missing)
RECORDS = {
    "cascaded tanks": lambda: _shared("cascaded tanks"),
    "buck converter": lambda: _shared("buck converter"),
    "MR damper": _damper,
    "piezo (simulated)": _piezo,
    "Prandtl-Ishlinskii": _pi,
    "Bouc-Wen oscillator": _oscillator,
    **{f"Piroddi {s}": (lambda s=s: _piroddi(s)) for s in
       ("S1", "S2", "S3", "S4", "S5", "S6")},
}


def _fit(tr, va, seed, kw, budget, jobs):
    from mggp import MGGPRegressor
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est = MGGPRegressor(random_state=seed, n_jobs=jobs, **budget, **kw).fit(tr)
    sim = est.get_best().simulate(va, mode="freerun")
    rmse = float("inf") if sim.diverged or not np.isfinite(sim.rmse) else float(sim.rmse)
    return {"rmse": rmse, "terms": est.get_best().n_terms,
            "seconds": time.perf_counter() - t0,
            "choices": {k: v["why"] for k, v in getattr(est, "choices_", {}).items()}}


def run(records, seeds, budget, jobs, log=print, grid=None) -> dict:
    """``{record: {setting: [row per seed]}}``; with ``grid`` (a saved run
    of the same seeds) only the default is fitted, the grid's rows are
    ``grid``'s."""
    out = {}
    for name in records:
        pair = RECORDS[name]()
        if pair is None:
            log(f"{name}: data files not found (set MGGP_SHARED_DATA)")
            continue
        tr, va = pair
        out[name] = {}
        if grid is not None:
            out[name].update({k: v for k, v in grid[name].items() if k != "default"})
        for label, kw in (("default", {}),) + (() if grid is not None else tuple(GRID.items())):
            rows = out[name][label] = []
            for seed in seeds:
                rows.append(_fit(tr, va, seed, kw, budget, jobs))
                r = rows[-1]
                log(f"{name} [{label}] seed {seed}: RMSE {r['rmse']:.4g}, {r['terms']} terms, "
                    f"{r['seconds']:.1f} s" + "".join(f"; {w}" for w in r["choices"].values()))
    return out


#: the goal: the default's median within this factor of the best grid setting's
GOAL = 1.1


def _medians(rows: dict, idx) -> dict:
    """Each setting's median validation RMSE over the seeds ``idx``."""
    return {k: float(np.median([v[i]["rmse"] for i in idx])) for k, v in rows.items()}


def _ratio(med: dict) -> float:
    """The default's median / the least grid median (``med``: :func:`_medians`)."""
    best = min(v for k, v in med.items() if k != "default")
    return med["default"] / best if best > 0 else float("nan")


def verdict_spread(rows: dict, draws: int = 4000, seed: int = 0) -> dict:
    """How firm one record's verdict is over its seeds. The seeds are drawn
    again with replacement (``draws`` times, the same seeds for every
    setting), and each draw's ratio of the default's median to the least
    grid median is taken (a bootstrap of the verdict; Efron and Tibshirani,
    *An Introduction to the Bootstrap*, Chapman & Hall 1993, ch. 13):

    .. math:: r^* = \\frac{\\operatorname{med}_{s \\in S^*} e_{\\mathrm{def}}(s)}
                          {\\min_g \\operatorname{med}_{s \\in S^*} e_g(s)}

    The best setting is chosen again in each draw, so the interval carries
    the "lowest of seven noisy medians" too. Returns the 5th and 95th
    percentiles of :math:`r^*` (``low``, ``high``) and the share of draws
    within :data:`GOAL` (``within``)."""
    n = len(rows["default"])
    if any(len(v) != n for v in rows.values()):
        raise ValueError(f"every setting needs the same seeds: {n} default rows, "
                         f"{sorted({len(v) for v in rows.values()})} in the grid")
    rng = np.random.default_rng(seed)
    r = np.array([_ratio(_medians(rows, rng.integers(0, n, n))) for _ in range(draws)])
    return {"low": float(np.percentile(r, 5, method="lower")),      # no interpolation:
            "high": float(np.percentile(r, 95, method="higher")),   # a draw may be inf
            "within": float(np.mean(r <= GOAL))}


def markdown(res: dict) -> str:
    """One table: the default's median RMSE, the best grid setting's, their
    ratio, and how firm that verdict is over the seeds (:func:`verdict_spread`)."""
    md = ["| record | default (median) | diverged | best grid setting | its median | "
          "its diverged | default / best | within 10 % | ratio, seeds redrawn (5–95 %) | "
          "draws within 10 % |", "|---|---:|---:|---|---:|---:|---:|---|---|---:|"]
    for name, rows in res.items():
        sp = verdict_spread(rows)                 # first: it checks the seeds agree
        n = len(rows["default"])
        med = _medians(rows, range(n))
        grid = {k: v for k, v in med.items() if k != "default"}
        best = min(grid, key=grid.get)
        div, bdiv = (sum(not np.isfinite(r["rmse"]) for r in rows[k]) for k in ("default", best))
        ratio = _ratio(med)
        md.append(f"| {name} | {med['default']:.4g} | {div}/{n} | "
                  f"`{best}` | {grid[best]:.4g} | {bdiv}/{n} | {ratio:.3f} | "
                  f"{'yes' if ratio <= GOAL and div == 0 else 'NO'} | "
                  f"{sp['low']:.2f}–{sp['high']:.2f} | {sp['within']:.0%} |")
    return "\n".join(md)


def merge(runs) -> dict:
    """The rows of several saved runs (``--json`` files of other seeds) as
    one: each setting's rows of every run, in order."""
    out = {}
    for res in runs:
        for name, rows in res.items():
            for label, v in rows.items():
                out.setdefault(name, {}).setdefault(label, []).extend(v)
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.panel")
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    p.add_argument("--population", type=int, help="every setting's (default: mggp fit's)")
    p.add_argument("--generations", type=int, help="every setting's (default: mggp fit's)")
    p.add_argument("--records", nargs="+", choices=list(RECORDS), default=list(RECORDS),
                   metavar="NAME")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--json", help="also write the figures here")
    p.add_argument("--from-json", nargs="+", metavar="FILE",
                   help="no fits: tabulate the runs saved by --json (several files: "
                   "their seeds pooled, e.g. seeds 1-3 and 4-6)")
    p.add_argument("--grid-from", metavar="FILE",
                   help="fit the default only; the grid settings' rows are this saved "
                   "run's (the same seeds and budget)")
    a = p.parse_args(argv)
    if a.from_json:
        try:
            runs = []
            for path in a.from_json:
                with open(path) as f:
                    runs.append(json.load(f))
            print(markdown(merge(runs)))
        except (OSError, ValueError, KeyError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        return 0
    from .mr_damper import shared_data_error
    from .real_data import data_files
    err = shared_data_error(data_files(a.records)
                            + (["mr_damper.csv"] if "MR damper" in a.records else []))
    if err:
        print(err, file=sys.stderr)
        return 2
    budget = {k: v for k, v in (("population", a.population),
                                ("generations", a.generations)) if v is not None}
    grid = None
    if a.grid_from:
        try:
            with open(a.grid_from) as f:
                grid = json.load(f)
            for name in a.records:
                held = {len(v) for k, v in grid[name].items() if k != "default"}
                if held != {len(a.seeds)} or set(grid[name]) - {"default"} != set(GRID):
                    raise ValueError(f"record {name!r} holds {sorted(held)} rows per grid "
                                     f"setting, {len(a.seeds)} seeds asked for, or other "
                                     f"settings than the grid's")
        except (OSError, ValueError) as exc:
            print(f"error: --grid-from {a.grid_from}: {exc}", file=sys.stderr)
            return 2
        except KeyError as exc:
            print(f"error: --grid-from {a.grid_from}: no record {exc}", file=sys.stderr)
            return 2
    t0 = time.perf_counter()
    res = run(a.records, a.seeds, budget, a.jobs, grid=grid)
    print()
    print(markdown(res))
    print(f"({time.perf_counter() - t0:.0f} s)")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
