"""Quasi-static analysis of the published models (Abreu et al. 2020, section 4).

Typical use::

    python -m benchmarks.quasistatic                       # -> benchmarks/results/quasistatic/
    python -m benchmarks.quasistatic --out /tmp/qs

* **Model (19)** with its published θ under u = 70 sin(2πt) V, Ts = 1 ms,
  two periods from rest (y = 0): the free-run loop, the attracting and
  repelling solutions ŷ_L^a, ŷ_L^r, ŷ_U^a, ŷ_U^r of the frozen equation
  (eq. 20, class by eq. 21) and the bounding structure (Fig. 7 of the
  paper), ``model19.png``.
* **Model (16)**, y_k = 0.9 y_{k-1} + 0.5 Φ2_{k-1}, u_k = sin(ω t_k),
  Ts = 0.05 s, ω = 0.1, 1 and 5 rad/s: the bounding structure ±5 (eq. 17)
  and each free run's extremes, ``model16.png`` (ω = 1).
* **The asymmetric variant** with regressor (18) as a plug-in Φ-function
  (u_k when rising, −1 when falling, 0 at rest), ω = 1: ``model18.png``.

Prints a summary and writes ``summary.md`` (conclusions of each analysis)
and ``quasistatic.json`` (counts and bounds) to ``--out``.
"""
from __future__ import annotations

import argparse
import json
import os

import numpy as np

import narx
from benchmarks.casestudy import MODEL19
from mggp.report.quasistatic import conclusion, plot_quasistatic, summary_markdown

__all__ = ["run", "main", "model16", "regressor18"]

OUT = os.path.join(os.path.dirname(__file__), "results", "quasistatic")


def regressor18(a, b):
    """Regressor (18): ``a`` when a > b (rising input), −1 when a < b, 0 when equal."""
    return np.where(a > b, a, np.where(a < b, -1.0, 0.0))


def model16(asymmetric: bool = False) -> narx.Model:
    """Model (16), or its variant with regressor (18) (in its own registry)."""
    if not asymmetric:
        return narx.Model(["y[k-1]", "Phi2(u[k-1],u[k-2])"], [0.9, 0.5])
    reg = narx.PhiRegistry()
    reg.register("R18", 2, regressor18, steady=0.0, doc="regressor (18)")
    return narx.Model(["y[k-1]", "R18(u[k-1],u[k-2])"], [0.9, 0.5], registry=reg)


def _sine16(omega, periods=3.0, ts=0.05):
    t = np.arange(int(round(periods * 2 * np.pi / omega / ts))) * ts
    return np.sin(omega * t)


def run(out: str = OUT) -> dict:
    os.makedirs(out, exist_ok=True)
    doc, md = {}, []
    t = np.arange(2000) * 1e-3
    u19 = 70.0 * np.sin(2 * np.pi * t)
    qs = narx.quasistatic(narx.Model(MODEL19["terms"], MODEL19["theta"]), u19)
    plot_quasistatic(os.path.join(out, "model19.png"), qs,
                     "Model (19), u = 70 sin(2πt) V, Ts = 1 ms: loop, attracting and "
                     "repelling sets", "u (V)", "y (µm)")
    md.append(summary_markdown(qs, "Model (19), u = 70 sin(2πt) V, Ts = 1 ms",
                               "model19.png", "python -m benchmarks.quasistatic"))
    doc["model19"] = {"counts": qs.counts(), "conclusion": conclusion(qs),
                      "y_range": [float(np.min(qs.y)), float(np.max(qs.y))]}
    for name, asym in (("model16", False), ("model18", True)):
        m = model16(asym)
        rows = []
        for omega in (0.1, 1.0, 5.0):
            q = narx.quasistatic(m, _sine16(omega))
            lo, hi = q.bounding.envelope()
            rows.append({"omega": omega, "y_min": float(q.y.min()),
                         "y_max": float(q.y.max()), "bound": [lo, hi],
                         "inside": bool(q.y.min() >= lo - 1e-9 and q.y.max() <= hi + 1e-9)})
            if omega == 1.0:
                what = ("Model (16)" if not asym else "Model (16) with regressor (18)")
                plot_quasistatic(os.path.join(out, f"{name}.png"), q,
                                 f"{what}, u = sin(t), Ts = 0.05 s", "u", "y")
                md.append(summary_markdown(q, f"{what}, u = sin(t), Ts = 0.05 s",
                                           f"{name}.png"))
        doc[name] = rows
        md.append("| ω (rad/s) | free-run min | max | bounding structure | inside |\n"
                  "|---:|---:|---:|---|---|\n" + "".join(
                      f"| {r['omega']:g} | {r['y_min']:.4g} | {r['y_max']:.4g} | "
                      f"{r['bound'][0]:.4g} .. {r['bound'][1]:.4g} | "
                      f"{'yes' if r['inside'] else 'no'} |\n" for r in rows))
    from narx.atomic import atomic_write_text
    atomic_write_text(os.path.join(out, "summary.md"), "\n".join(md))
    atomic_write_text(os.path.join(out, "quasistatic.json"), json.dumps(doc, indent=1) + "\n")
    return doc


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.quasistatic",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default=OUT, help=f"output folder (default {OUT})")
    args = p.parse_args(argv)
    doc = run(args.out)
    print("Model (19), u = 70 sin(2πt) V, Ts = 1 ms:")
    for b, c in doc["model19"]["counts"].items():
        if c["samples"]:
            print(f"  {b:<9s} {c['samples']} samples: attracting {c['attracting']}, "
                  f"only repelling {c['repelling_only']}")
    for line in doc["model19"]["conclusion"]:
        print("  " + line)
    for name in ("model16", "model18"):
        print(f"{'Model (16)' if name == 'model16' else 'Model (16) + regressor (18)'}:")
        for r in doc[name]:
            print(f"  ω = {r['omega']:<4g} free run {r['y_min']:.4g} .. {r['y_max']:.4g}, "
                  f"bounding structure {r['bound'][0]:.4g} .. {r['bound'][1]:.4g}, "
                  f"inside: {r['inside']}")
    print(f"figures and summary.md written to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
