"""Figures and Markdown report of the PEM-versus-MS study.

Typical use (from :mod:`benchmarks.pem_vs_ms`)::

    figs = write_figures("report", case_data, rows, extras, peers)
    write_report(args, summary, peers, checks, figs, damper, table_md, seconds)

Figures: hysteresis loops (u against y) of data and each model on the
validation sine, free-run outputs over time, the held-input responses with
the holds shaded, and the best fitness by generation for PEM and MS.
"""
from __future__ import annotations

import os
import platform

import numpy as np

from mggp.report import figure, plot_convergence, plot_freerun, plot_loop

__all__ = ["write_figures", "write_report"]

_ORDER = ("PEM-LS", "MS-LS", "MS-CLS", "model (19) CLS")


def _first(rows, name):
    return next((r for r in rows if r["name"] == name), None)


def _finite(a):
    return a is not None and np.all(np.isfinite(a))


def write_figures(folder, cs, rows, extras, peers):
    sims = {n: r["y_val"] for n in _ORDER if (r := _first(rows, n)) and _finite(r["y_val"])}
    for p in peers:
        if p.get("available") and _finite(p.get("y_val")):
            sims[p["name"]] = p["y_val"]
    figs = [plot_loop(os.path.join(folder, "loops.png"), cs.uv, cs.yv, sims,
                      title="Hysteresis loops on u = 40 sin(2πt) (free run)",
                      xlabel="u (V)", ylabel="y (µm)"),
            plot_freerun(os.path.join(folder, "freerun.png"), cs.tv, cs.yv, sims,
                         title="Free-run simulation, validation", ylabel="y (µm)")]
    fig, ax = figure(2, 1, figsize=(8, 6), sharex=True)
    th = np.arange(cs.held.u.size) * 1e-3
    ax[0].plot(th, cs.held.u, "k")
    ax[0].set_ylabel("u (V)")
    ax[1].plot(th, cs.yh, "k", lw=0.8, label="data", zorder=5)
    for n in _ORDER:
        r = _first(rows, n)
        if r is not None and _finite(r["y_held"]):
            ax[1].plot(th, r["y_held"], lw=1.0, ls="--", label=n)
    for a in ax:
        for sl in (cs.held.hold_rising, cs.held.hold_falling):
            a.axvspan(th[sl.start], th[sl.stop - 1], color="0.9")
    ax[1].set_ylabel("y (µm)")
    ax[1].set_xlabel("t (s)")
    ax[1].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    ax[0].set_title("Held-input sine: the input is frozen in the shaded intervals")
    path = os.path.join(folder, "held.png")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    figs.append(path)
    lbs = extras.get("logbooks", {})
    if lbs:
        seed = sorted(lbs)[0]
        figs.append(plot_convergence(os.path.join(folder, "convergence.png"), lbs[seed],
                                     title=f"Best fitness by generation (seed {seed})"))
    return figs


def write_report(args, summary, peers, checks, figs, damper, table_md, seconds):
    import numba
    import scipy
    mode = "full (published setup)" if args.full else "quick"
    lines = ["# PEM versus multiple shooting on the piezo actuator", "",
             f"Mode: **{mode}**; N = {args.n}, population {args.population}, "
             f"{args.generations} generations, seeds {args.seeds}, MS window Δm = "
             f"{args.window} samples, training input through a 1 Hz Butterworth low-pass "
             f"of order {getattr(args, 'filter_order', '?')} (data seed "
             f"{getattr(args, 'data_seed', 0)}), {args.jobs} jobs; "
             f"{seconds:.0f} s on "
             f"{os.cpu_count()} cores ({platform.processor() or platform.machine()}).",
             "", "Free-run figures; MAPE is range-normalised, 100·mean|y − ŷ| / (max y − min y), the metric of the published table (Abreu et al., Nonlinear Dynamics 2020). Drift is the "
             "range of the simulated output over each 1 s hold after 100 settling samples; "
             "the steady-state error is |ŷ − y| at the end of the hold against the true "
             "system. With several seeds: median (min–max).", "", table_md, ""]
    edges = [(s["name"], s.get("hold_edge_error")) for s in summary
             if s.get("hold_edge_error") is not None and np.isfinite(s["hold_edge_error"])]
    if edges:
        lines += ["Transients where the input stops or starts again (largest |ŷ − y| "
                  "within 20 samples after each hold edge of the held sine, µm; the "
                  "drift and end-of-hold error above do not see them, the spikes of "
                  "held.png are these): " + ", ".join(f"{n} {v:.3g}" for n, v in edges)
                  + ".", ""]
    lines += ["## Goals", ""]
    lines += [f"- [{'x' if ok else ' '}] {t}: {v:.4g}" + ("" if ok else " (short)")
              for t, ok, v in checks]
    lines += ["", "## Models", ""]
    for s in summary:
        lines.append(f"- **{s['name']}** ({int(s['n_terms'])} terms): "
                     + ", ".join(f"`{t}`" for t in s["terms"]))
    lines += ["", "## Peers", ""]
    for p in peers:
        if not p.get("available"):
            lines.append(f"- {p['name']}: missing ({p.get('reason')})")
            continue
        extra = ""
        if p.get("grid"):
            extra = "; grid: " + "; ".join(
                f"deg {g['degree']} lags {g['ylag']}/{g['xlag']}{' +Δu,sign Δu' if g['phi'] else ''}"
                f" → {g['val_mape']:.3g} %" for g in p["grid"])
        if p.get("time_limit"):
            extra += (f"; stopped by a {p['time_limit']:.0f} s limit after "
                      f"{p.get('generations_completed')} generations")
        lines.append(f"- {p['name']} {p.get('versions')}: val MAPE {p.get('val_mape')}, "
                     f"{p.get('n_terms')} terms, fit {p.get('fit_time')} s{extra}")
    if damper is not None:
        lines += ["", "## Second study: MR damper (shared data)", "", damper["markdown"]]
    lines += ["", "## Figures", ""] + [f"![{os.path.basename(f)}]({os.path.basename(f)})"
                                       for f in figs]
    from importlib.metadata import version
    lines += ["", f"Versions: deap {version('deap')}, numba {numba.__version__}, "
              f"numpy {np.__version__}, scipy {scipy.__version__}."]
    from narx.atomic import atomic_write_text
    atomic_write_text(os.path.join(args.out, "report.md"), "\n".join(lines) + "\n")
