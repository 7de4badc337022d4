"""Hysteresis compensation on the simulated piezo actuator (issue 7).

Typical use::

    python -m benchmarks.compensation --out report/compensation --json comp.json
    python -m benchmarks.compensation --quick --out /tmp/comp      # a smaller search
    python -m benchmarks.compensation --more     # + triangle, two sines, steps, slow ramp

Every compensator computes the actuator input ``m`` from a reference ``r``;
``m`` drives the simulated actuator (``narx.systems.piezo_bouc_wen``, RK4),
never the model, and the tracking error is ``y - r`` over the whole record.

Rows (``d`` = the model's smallest input lag):

* *uncompensated*: ``u = r / g`` with ``g`` the least-squares static gain of
  the actuator on the training record (``y ≈ g u``), the reference of the
  ratios (×); and, for scale, with the gain that minimises that reference's
  own tracking RMSE (found on the actuator, a 1-D search);
* *root, model (19)*: the published reference model with its published θ,
  inverted by :mod:`narx.analysis.compensate`, with preview ``lead = d`` and without
  (``lead = d - 1``: the model's one-sample input delay stands for the
  actuator's direct feed-through, so this aligns the actuator with ``r``);
* *root, model (19) terms, our CLS θ*: the same terms, θ estimated here by
  :meth:`narx.Model.fit` (CLS, continuum of steady states) on the training
  record;
* *root, MGGP model*: a forward model searched here by
  :class:`mggp.MGGPRegressor` (free-run fitness, lags <= 3, degree <= 3,
  LS and CLS refits; the best of ``--seeds`` searches by free-run MAPE on a
  validation record);
* *data-driven*: the inverse identified directly from the data by
  :func:`mggp.compensate.identify_inverse` (lead 1, multiple shooting with
  Δm = 500, lags <= 2, structure chosen by free-run error over the
  training record; the best of ``--seeds`` by the inverse's free-run input
  RMSE on the validation record);
* *PI alone*, *PI + root (19)* and *PI + data-driven*: a discrete PI loop
  (same gains) without and around a compensator.

Writes ``compensation.md`` (table), ``compensation.json`` and, per
reference, ``<name>.png`` (reference and outputs over time; r-y loops
uncompensated and compensated; tracking error over time) to ``--out``.
"""
from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
import time

import numpy as np
from scipy.optimize import minimize_scalar

from narx.atomic import atomic_write_text
from narx.analysis.compensate import RootCompensator
from narx.simulation.metrics import mape
from narx.systems import piezo_bouc_wen, sine_input, training_input
from mggp import MGGPRegressor
from mggp.fit.choices import AS_SEARCHED
from mggp.compensate import PiezoPlant, identify_inverse, pi_loop

from .casestudy import model19

RANGE = (-80.0, 80.0)


def references(quick: bool, amplitude: float):
    """The references: 0.5 Hz and 2 Hz sines, a band-limited random signal (±amplitude)."""
    dur = 0.5 if quick else 1.0
    out = {}
    for f, periods in ((0.5, 3), (2.0, 6)):
        _, r = sine_input(duration=periods / f * dur, amplitude=amplitude, freq=f)
        out[f"sine {f:g} Hz"] = r
    r = training_input(int(8000 * dur), amplitude=amplitude, bandwidth=1.0, seed=11)
    fade = 0.5 - 0.5 * np.cos(np.pi * np.minimum(1.0, np.arange(r.size) / 1000.0))
    out["random 1 Hz"] = r * fade               # from rest, like the sines (1 s fade-in)
    return out


def more_references(amplitude: float):
    """References the compensators were not designed around (``--more``): a
    0.5 Hz triangle, 0.5 Hz + 3 Hz sines, steps with 0.8 s holds, and a slow
    ramp up and down (30 s each way); all from rest, within ±amplitude."""
    t = np.arange(4000) * 1e-3
    out = {"triangle 0.5 Hz": amplitude * (2 / np.pi) * np.arcsin(np.sin(np.pi * t)),
           "0.5 + 3 Hz": amplitude * (0.7 * np.sin(np.pi * t) + 0.3 * np.sin(6 * np.pi * t))}
    levels = np.random.default_rng(5).uniform(-1, 1, 7) * amplitude
    out["steps, 0.8 s holds"] = np.concatenate([np.zeros(200)] + [np.full(800, v)
                                                                  for v in levels])
    ramp = np.linspace(0.0, amplitude, 30_000)
    out["ramp 30 s up and down"] = np.concatenate([ramp, ramp[::-1]])
    return out


def fit_forward(u, y, uv, yv, seeds, budget, jobs):
    """MGGP forward models; keep the best (LS or CLS) by validation free-run MAPE."""
    best = None
    for seed in range(seeds):
        est = MGGPRegressor(fitness="freerun", constraints="steady-state", max_lag=3,
                            max_degree=3, max_terms=10, random_state=seed, n_jobs=jobs,
                            # the compensators' measured setting: Φ primitives, no screen
                            use_phi=True, screen=None, select="fitness", **AS_SEARCHED,
                            **budget).fit(u, y)
        for m in (est.model_, est.model_cls_):
            if m is None:
                continue
            sim = m.simulate(uv, yv, mode="freerun")
            score = mape(yv, sim.y_hat) if not sim.diverged else np.inf
            if best is None or score < best[0]:
                best = (score, m, seed)
    return best


def fit_inverse(u, y, uv, yv, seeds, budget, jobs):
    """Data-driven inverses; keep the best by free-run input RMSE on validation."""
    best = None
    for seed in range(seeds):
        inv = identify_inverse(u, y, lead=1, fitness="ms", window=500, max_lag=2,
                               max_degree=3, max_terms=8, random_state=seed, n_jobs=jobs,
                               **budget)
        res = inv.run(yv, input_range=RANGE)
        score = float(np.sqrt(np.mean((res.m - uv) ** 2)))
        if best is None or score < best[0]:
            best = (score, inv, seed)
    return best


def _rmse(e):
    return float(np.sqrt(np.mean(np.square(e))))


def run(args):
    t0 = time.perf_counter()
    n = 10_000 if args.quick else 20_000
    u = training_input(n, seed=0)
    y = piezo_bouc_wen(u)
    uv = training_input(n // 2, amplitude=70.0, seed=1)
    yv = piezo_bouc_wen(uv)
    g = float(u @ y / (u @ u))
    budget = ({"population": 100, "generations": 10} if args.quick else
              {"population": args.population, "generations": args.generations})
    amplitude = 0.7 * min(-y.min(), y.max())
    m19 = model19()
    m19cls = model19().fit(u, y, constraints="steady-state")
    fwd_score, fwd, fwd_seed = fit_forward(u, y, uv, yv, args.seeds, budget, args.jobs)
    inv_score, inv, inv_seed = fit_inverse(u, y, uv, yv, args.seeds, budget, args.jobs)
    t_fit = time.perf_counter() - t0
    comps = {}
    for tag, model in (("model (19)", m19), ("model (19) terms, our CLS θ", m19cls),
                       ("MGGP model", fwd)):
        d = RootCompensator(model).delay
        for lead in sorted({d, max(0, d - 1)}):
            name = f"root, {tag}, lead {lead}" + (" (= d)" if lead == d else "")
            comps[name] = (model, lead)
    rows, traces = {}, {}
    refs = references(args.quick, amplitude)
    if args.more:
        refs.update(more_references(amplitude))
    for rname, r in refs.items():
        yb = piezo_bouc_wen(np.clip(r / g, *RANGE))
        base = _rmse(yb - r)
        out = {"uncompensated (u = r/g)": {"rmse": base, "max": float(np.max(np.abs(yb - r))),
                                           "fallbacks": None}}
        tr = {"t": np.arange(r.size) * 1e-3, "r": r, "uncompensated (u = r/g)": yb}
        gbest = minimize_scalar(lambda gg: _rmse(piezo_bouc_wen(np.clip(r / gg, *RANGE)) - r),
                                bounds=(0.5 * g, 2.0 * g), method="bounded").x
        yg = piezo_bouc_wen(np.clip(r / gbest, *RANGE))
        out["uncompensated, RMSE-best gain"] = {
            "rmse": _rmse(yg - r), "max": float(np.max(np.abs(yg - r))), "fallbacks": None,
            "gain": float(gbest)}
        for name, (model, lead) in comps.items():
            res = RootCompensator(model, input_range=RANGE, lead=lead).run(r)
            ya = piezo_bouc_wen(res.m)
            out[name] = {"rmse": _rmse(ya - r), "max": float(np.max(np.abs(ya - r))),
                         "fallbacks": res.fallbacks, "saturated": res.saturated}
            tr[name] = ya
        res = inv.run(r, input_range=RANGE)
        ya = piezo_bouc_wen(res.m)
        out["data-driven (MGGP inverse)"] = {"rmse": _rmse(ya - r),
                                             "max": float(np.max(np.abs(ya - r))),
                                             "fallbacks": None}
        tr["data-driven (MGGP inverse)"] = ya
        inv.reset()
        for name, comp in (("PI alone", None),
                           ("PI + root, model (19), lead 0",
                            RootCompensator(m19, input_range=RANGE, lead=0)),
                           ("PI + data-driven", inv)):
            lp = pi_loop(PiezoPlant(), r, compensator=comp, kp=args.kp, ki=args.ki,
                         gain=g, input_range=RANGE)
            out[name] = {"rmse": lp.rmse, "max": float(np.max(np.abs(lp.e))),
                         "fallbacks": None}
            tr[name] = lp.y
        for v in out.values():
            v["ratio"] = base / v["rmse"] if v["rmse"] > 0 else np.inf
        rows[rname], traces[rname] = out, tr
    info = {"command": "python -m benchmarks.compensation " + " ".join(
                shlex.quote(a) for a in sys.argv[1:]),
            "n_train": n, "static_gain": g, "reference_amplitude": amplitude,
            "input_range": RANGE, "kp": args.kp, "ki": args.ki, "budget": budget,
            "seeds": args.seeds,
            "model19": {"terms": m19.term_texts, "theta": m19.theta.tolist()},
            "model19_cls_theta": m19cls.theta.tolist(),
            "mggp_model": {"terms": fwd.term_texts, "theta": fwd.theta.tolist(),
                           "seed": fwd_seed, "estimation": fwd.meta.get("estimation"),
                           "val_mape": fwd_score, "equation": fwd.equation()},
            "inverse": {"terms": inv.model.term_texts, "theta": inv.model.theta.tolist(),
                        "seed": inv_seed, "lead": inv.lead, "val_rmse_u": inv_score,
                        "equation": inv.model.equation()},
            "fit_seconds": t_fit, "total_seconds": time.perf_counter() - t0}
    return rows, traces, info


def markdown(rows, info) -> str:
    refs = list(rows)
    names = list(rows[refs[0]])
    head = "| compensator | " + " | ".join(f"{r}: RMSE µm (×)" for r in refs) + \
        " | fallbacks |\n|---|" + "---:|" * (len(refs) + 1)
    lines = [head]
    for nm in names:
        cells = [f"{rows[r][nm]['rmse']:.3f} ({rows[r][nm]['ratio']:.1f}×)" for r in refs]
        fb = [rows[r][nm].get("fallbacks") for r in refs]
        lines.append(f"| {nm} | " + " | ".join(cells) + " | " +
                     ("–" if fb[0] is None else " / ".join(str(v) for v in fb)) + " |")
    return "\n".join(lines) + (
        f"\n\n(×) = uncompensated RMSE / RMSE. Static gain g = {info['static_gain']:.4f} µm/V; "
        f"references ±{info['reference_amplitude']:.1f} µm; input range ±80 V; "
        f"PI kp = {info['kp']}, ki = {info['ki']} per sample.\n\n"
        f"MGGP forward model (seed {info['mggp_model']['seed']}, "
        f"{info['mggp_model']['estimation']}, validation MAPE "
        f"{info['mggp_model']['val_mape']:.3f} %): `{info['mggp_model']['equation']}`\n\n"
        f"Data-driven inverse (seed {info['inverse']['seed']}, lead {info['inverse']['lead']}): "
        f"`{info['inverse']['equation']}`\n")


def figures(traces, rows, folder):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    paths = []
    for rname, tr in traces.items():
        t, r = tr["t"], tr["r"]
        show = ["uncompensated (u = r/g)", "root, model (19), lead 1 (= d)",
                "data-driven (MGGP inverse)", "PI alone", "PI + root, model (19), lead 0"]
        show = [s for s in show if s in tr]
        fig, ax = plt.subplots(1, 3, figsize=(16, 4.5))
        ax[0].plot(t, r, "k", lw=2, label="reference r")
        for s in show:
            ax[0].plot(t, tr[s], lw=0.9, label=s)
        ax[0].set(xlabel="t (s)", ylabel="µm", title=f"{rname}: reference and output")
        ax[0].legend(fontsize=7)
        for s in show[:3]:
            ax[1].plot(r, tr[s], lw=0.9, label=s)
        ax[1].plot([r.min(), r.max()], [r.min(), r.max()], "k:", lw=1)
        ax[1].set(xlabel="r (µm)", ylabel="y (µm)", title="loops: r against y")
        ax[1].legend(fontsize=7)
        for s in show:
            ax[2].plot(t, tr[s] - r, lw=0.9, label=f"{s}: {rows[rname][s]['rmse']:.3f}")
        ax[2].set(xlabel="t (s)", ylabel="y - r (µm)", title="tracking error (RMSE µm)")
        ax[2].legend(fontsize=7)
        fig.tight_layout()
        path = os.path.join(folder, rname.replace(" ", "_") + ".png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.compensation",
                                description=__doc__.split("\n")[0])
    p.add_argument("--out", default="report/compensation", help="output folder")
    p.add_argument("--json", default=None, help="also write the numbers here")
    p.add_argument("--quick", action="store_true", help="short records, tiny searches")
    p.add_argument("--seeds", type=int, default=3, help="MGGP searches per model (3)")
    p.add_argument("--population", type=int, default=500)
    p.add_argument("--generations", type=int, default=60)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--more", action="store_true",
                   help="also a triangle, two sines, steps and a slow ramp")
    p.add_argument("--kp", type=float, default=0.1)
    p.add_argument("--ki", type=float, default=0.2)
    args = p.parse_args(argv)
    if args.seeds < 1:
        p.error(f"--seeds must be >= 1, got {args.seeds}")
    os.makedirs(args.out, exist_ok=True)
    rows, traces, info = run(args)
    md = markdown(rows, info)
    doc = {"info": info, "rows": rows}
    text = json.dumps(doc, indent=2, default=float)
    atomic_write_text(os.path.join(args.out, "compensation.md"),
                      f"# Compensation\n\n`{info['command']}`\n\n{md}")
    atomic_write_text(os.path.join(args.out, "compensation.json"), text + "\n")
    if args.json:
        atomic_write_text(args.json, text + "\n")
    paths = figures(traces, rows, args.out)
    print(md)
    print(f"fits {info['fit_seconds']:.0f} s, total {info['total_seconds']:.0f} s; "
          f"figures: {', '.join(paths)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
