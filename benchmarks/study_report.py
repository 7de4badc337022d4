"""Figures and Markdown report of the PEM-versus-MS study.

Typical use (from :mod:`benchmarks.pem_vs_ms`)::

    figs = write_figures("report", case_data, rows, extras, peers)   # (path, caption)
    write_report(args, summary, peers, checks, figs, damper, table_md, seconds)

Figures: hysteresis loops (u against y) of data and each model on the
validation sine, free-run outputs over time, the held-input responses with
the holds shaded, and the best fitness by generation for PEM and MS; each
with a caption under it. The report opens with a one-paragraph conclusion
(:func:`conclusion`); peers are a table (:func:`peer_table`).
"""
from __future__ import annotations

import os
import platform

import numpy as np

from mggp.report.summary import (error_groups, figure, figure_lines, plot_convergence, plot_errors,
                         plot_freerun, plot_loop)

from .casestudy import PUBLISHED

__all__ = ["write_figures", "write_report", "conclusion", "peer_table", "fmt"]

_ORDER = ("PEM-LS", "MS-LS", "MS-CLS", "model (19) CLS")


def _first(rows, name):
    return next((r for r in rows if r["name"] == name), None)


def _finite(a):
    return a is not None and np.all(np.isfinite(a))


def _held_figure(path, cs, sims):
    """Input, output and errors on the held-input sine, holds shaded."""
    th = np.arange(cs.held.u.size) * 1e-3
    groups = error_groups(cs.yh, sims) if sims else []
    fig, ax = figure(2 + len(groups), 1, figsize=(8, 5.2 + 1.6 * len(groups)), sharex=True,
                     squeeze=False, gridspec_kw={"height_ratios": [1, 2] + [1] * len(groups)})
    ax = ax[:, 0]
    ax[0].plot(th, cs.held.u, "k")
    ax[0].set_ylabel("u (V)")
    colour = {n: f"C{i}" for i, n in enumerate(sims)}
    for n, yh in sims.items():
        ax[1].plot(th, yh, lw=1.0, ls="--", color=colour[n], label=n)
    ax[1].plot(th, cs.yh, "k", lw=0.8, label="data", zorder=5)
    ax[1].set_ylabel("y (µm)")
    ax[1].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    plot_errors(ax[2:], th, cs.yh, sims, groups, "error ŷ − y (µm)")
    for a in ax:
        for sl in (cs.held.hold_rising, cs.held.hold_falling):
            a.axvspan(th[sl.start], th[sl.stop - 1], color="0.9")
    ax[-1].set_xlabel("t (s)")
    ax[0].set_title("Held-input sine: the input is frozen in the shaded intervals")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    import matplotlib.pyplot as plt
    plt.close(fig)
    return path


def _overlap(sims, a, b) -> str:
    """A caption sentence when two simulations lie within a line width."""
    if a not in sims or b not in sims:
        return ""
    gap = float(np.max(np.abs(np.asarray(sims[a]) - np.asarray(sims[b]))))
    return (f" {a} and {b} lie within {gap:.2g} µm of each other on this sine, so one "
            f"curve hides the other.")


def write_figures(folder, cs, rows, extras, peers):
    """Write the study's PNGs; returns ``(path, caption)`` pairs."""
    sims = {n: r["y_val"] for n in _ORDER if (r := _first(rows, n)) and _finite(r["y_val"])}
    for p in peers:
        if p.get("available") and _finite(p.get("y_val")):
            sims[p["name"]] = p["y_val"]
    j = os.path.join
    figs = [(plot_loop(j(folder, "loops.png"), cs.uv, cs.yv, sims,
                       title="Hysteresis loops on u = 40 sin(2πt) (free run)",
                       xlabel="u (V)", ylabel="y (µm)"),
             "Hysteresis loops on the validation sine u = 40 sin(2πt): the actuator's "
             "displacement y (µm) against its input voltage u (V), data (black) and the free "
             "run of each model. A model whose loop lies on the black one reproduces the "
             "hysteresis; models within a fraction of a µm of the data hide under it."),
            (plot_freerun(j(folder, "freerun.png"), cs.tv, cs.yv, sims,
                          title="Free-run simulation, validation sine", ylabel="y (µm)",
                          error_label="error ŷ − y (µm)"),
             "Free-run simulation on the validation sine (top) and the error ŷ − y in µm "
             "below; models whose errors differ by more than ten times are drawn in "
             "separate error panels, each scaled to its own largest error, so that errors "
             "of a few tenths of a µm stay visible beside errors of tens of µm."
             + _overlap(sims, "MS-LS", "MS-CLS"))]
    held = {n: r["y_held"] for n in _ORDER
            if (r := _first(rows, n)) is not None and _finite(r["y_held"])}
    figs.append((_held_figure(j(folder, "held.png"), cs, held),
                 "Held-input sine: the input (top, V) stops for 1 s while rising and 1 s "
                 "while falling (shaded); the true actuator then holds its displacement. "
                 "The output (µm) and the errors ŷ − y (µm, one panel per error size) show "
                 "which models hold too: a model without a continuum of steady states "
                 "drifts (its error ramps) or oscillates in the shaded intervals."))
    lbs = extras.get("logbooks", {})
    if lbs:
        seed = sorted(lbs)[0]
        names = {"PEM": "one-step-ahead (PEM)", "MS": "multiple-shooting (MS)"}
        figs.append((plot_convergence(
            j(folder, "convergence.png"), lbs[seed],
            title=f"Best fitness by generation (seed {seed})",
            ylabels={k: f"best {k} fitness\nMSE (µm², log)" for k in lbs[seed]}),
            "Best fitness of each generation of the two searches (log scale; lower is "
            "better). Fitness is the mean squared error, in µm², between the data and the "
            "search's prediction on the training record: " + "; ".join(
                f"{k}: the {names.get(k, k)} " + ("prediction, one sample ahead of "
                                                  "measured outputs" if k == "PEM" else
                                                  f"simulation, free runs of Δm samples "
                                                  f"from measured initial conditions")
                for k in lbs[seed]) + ". The two are not on one scale: a one-step error "
            "is far smaller than a simulation error, and a low one-step error does not "
            "make a good free run (the PEM model above)."))
    return figs


def fmt(v, digits=3):
    """A figure of the study's tables: ``digits`` decimals (significant
    digits below 1e-3), ``diverged`` for inf, ``—`` when missing."""
    if v is None or (isinstance(v, float) and np.isnan(v)):
        return "—"
    if isinstance(v, float) and not np.isfinite(v):
        return "diverged"
    return f"{v:.{digits}g}" if abs(v) < 1e-3 and v != 0 else f"{v:.{digits}f}"


def _f(v, d=3):
    """A figure in running text: ``d`` significant digits, or ``diverged``."""
    if v is None or (isinstance(v, float) and np.isnan(v)):
        return "—"
    if not np.isfinite(v):
        return "diverged"
    return f"{v:.{d}g}"


def _pct(v) -> str:
    return _f(v) + (" %" if v is not None and np.isfinite(v) else "")


def conclusion(summary, peers) -> str:
    """The report's first paragraph: what won, by how much, what to do."""
    g = {s["name"]: s for s in summary}
    ours = [g[n] for n in ("MS-CLS", "MS-LS", "PEM-LS") if n in g]
    if not ours:
        return "**Conclusion.** No model was identified in this run."
    best = min(ours, key=lambda s: s["val_mape"])
    pem, cls, ms = g.get("PEM-LS"), g.get("MS-CLS"), g.get("MS-LS")
    out = ["**Conclusion.**"]
    if best["name"] != "PEM-LS" and pem is not None:
        ratio = pem["val_mape"] / best["val_mape"]
        out.append(f"Multiple-shooting (MS) fitness won: the {best['name']} model reproduces "
                   f"the validation sine in free run with a MAPE of {fmt(best['val_mape'])} %, "
                   f"{ratio:.0f} times lower than the one-step-ahead (PEM-LS) model's "
                   f"{fmt(pem['val_mape'])} %.")
    else:
        out.append(f"In this run the best model is {best['name']}, validation MAPE "
                   f"{_f(best['val_mape'])} %.")
    if cls is not None:
        drift = max(cls["drift_loading"], cls["drift_unloading"])
        line = (f"Refitted by CLS, the MS structure holds its output when the input stops "
                f"(drift {drift:.2g} µm")
        if pem is not None:
            line += (f", against {_f(max(pem['drift_loading'], pem['drift_unloading']))} µm "
                     f"for PEM-LS")
        out.append(line + f") at a validation MAPE of {fmt(cls['val_mape'])} % "
                          f"(published MS-CLS: {PUBLISHED['MS-CLS']['val']} %).")
    avail = [p for p in peers if p.get("available") and p.get("val_mape") is not None]
    if avail:
        out.append("Peer tools on the same data, validation MAPE: " + ", ".join(
            f"{p['name']} {_pct(p['val_mape'])}" for p in avail) + ".")
    out.append("What to do: identify a hysteretic actuator with multiple-shooting fitness and "
               "steady-state constraints (`mggp fit DATA.csv --fitness ms --window W "
               "--constraints steady-state`, the MS-CLS row), and judge a model by its free "
               "run, never by its one-step-ahead error.")
    if ms is not None and cls is not None:
        d = cls["val_mape"] - ms["val_mape"]
        out.append(f"The constraints change the validation MAPE by {d:+.2g} percentage "
                   f"points (MS-LS {_f(ms['val_mape'])} %) and remove the drift of the "
                   f"held input.")
    return " ".join(out)


def _pem_gap(summary) -> list:
    pem = next((s for s in summary if s["name"] == "PEM-LS"), None)
    if pem is None or not np.isfinite(pem["val_mape"]):
        return []
    pub = PUBLISHED["PEM-LS"]["val"]
    return [f"PEM-LS's validation MAPE ({_f(pem['val_mape'])} %) is "
            f"{pem['val_mape'] / pub:.1f} times the published {pub} %. A one-step-ahead "
            f"fitness scores an error the free run never sees, so how well the chosen "
            f"structure simulates is left to chance: it changes with the GP seed and the "
            f"training record (benchmarks/RESULTS.md lists runs of both), and the "
            f"published figure is one run on the authors' record. What carries over is "
            f"the gap to MS, many times in every run.", ""]


def _versions(v) -> str:
    v = dict(v or {})
    py = v.pop("python", None)
    return ", ".join(f"{k} {x}" for k, x in v.items()) + (f" (Python {py})" if py else "")


def peer_table(peers) -> list:
    """Markdown lines: one row per peer, rounded like the study's rows."""
    if not peers:
        return []
    lines = ["| peer | versions | val MAPE % | val RMSE µm | terms | fit s | notes |",
             "|---|---|---:|---:|---:|---:|---|"]
    for p in peers:
        if not p.get("available"):
            lines.append(f"| {p['name']} | — | — | — | — | — | not run: {p.get('reason')} |")
            continue
        notes = []
        finite = [q for q in p.get("grid") or [] if np.isfinite(q["val_mape"])]
        if p.get("grid") and not finite:
            notes.append("every setting of its grid diverged in free run")
        elif p.get("settings"):
            st = p["settings"]
            notes.append(f"best of a grid: degree {st['degree']}, lags {st['ylag']}/"
                         f"{st['xlag']}" + (", inputs Δu and sign Δu" if st["phi"] else ""))
        if p.get("grid"):
            notes.append("grid val MAPE %: " + "; ".join(
                f"deg {q['degree']} lags {q['ylag']}/{q['xlag']}"
                f"{' +Δu, sign Δu' if q['phi'] else ''} {_f(q['val_mape'])}"
                for q in p["grid"]))
        if p.get("time_limit"):
            notes.append(f"stopped by its {p['time_limit']:.0f} s limit after "
                         f"{p.get('generations_completed')} generations"
                         if p.get("timed_out") else
                         f"{p.get('generations_completed')} generations within its "
                         f"{p['time_limit']:.0f} s limit")
        lines.append(f"| {p['name']} | {_versions(p.get('versions'))} | {fmt(p.get('val_mape'))} "
                     f"| {fmt(p.get('val_rmse'))} | {p.get('n_terms', '—')} "
                     f"| {fmt(p.get('fit_time'), 1)} | {'; '.join(notes)} |")
    return lines


def write_report(args, summary, peers, checks, figs, damper, table_md, seconds):
    import numba
    import scipy
    mode = "full (published setup)" if args.full else "quick"
    lines = ["# PEM versus multiple shooting on the piezo actuator", "",
             conclusion(summary, peers), "",
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
    lines += _pem_gap(summary)
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
    lines += ["", "## Peers", "", "Peer tools run on the same records in the same run, "
              "each in its own virtual environment under benchmarks/.peers/.", ""]
    lines += peer_table(peers)
    if damper is not None:
        lines += ["", "## Second study: MR damper (shared data)", "", damper["markdown"]]
    lines += ["", "## Figures", ""] + figure_lines(figs)
    from importlib.metadata import version
    lines += ["", f"Versions: deap {version('deap')}, numba {numba.__version__}, "
              f"numpy {np.__version__}, scipy {scipy.__version__}."]
    from narx.atomic import atomic_write_text
    atomic_write_text(os.path.join(args.out, "report.md"), "\n".join(lines) + "\n")
