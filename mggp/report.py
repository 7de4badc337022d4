"""Figures and a Markdown summary of a fitted model.

Typical use::

    from mggp.report import write_fit_report
    write_fit_report("report/", est, data)          # PNGs + summary.md

Figures: free-run simulation against data, the input-output loop (u
against y) of data and model, and the convergence of the best fitness by
generation. Matplotlib runs headless (Agg).
"""
from __future__ import annotations

import os
from typing import Optional

import numpy as np

from .plotting import figure, save as _save

__all__ = ["write_fit_report", "plot_freerun", "plot_loop", "plot_convergence", "figure"]


def _band(y):
    """Plot limits: the data's range widened by half of it on each side, so a
    diverging simulation cannot squeeze the data into a flat line."""
    lo, hi = float(np.min(y)), float(np.max(y))
    pad = 0.5 * (hi - lo) or 1.0
    return lo - pad, hi + pad


def _label(name, yh, lims):
    out = not np.all(np.isfinite(yh)) or np.any((yh < lims[0]) | (yh > lims[1]))
    return f"{name} (leaves the plot)" if out else name


def plot_freerun(path, t, y, sims: dict, title="Free-run simulation", ylabel="y",
                 xlabel="t (s)"):
    """Data and free runs (top) and each simulation's error ŷ − y (bottom);
    ``t=None`` plots against the sample index."""
    fig, ax = figure(2, 1, figsize=(8, 5.2), sharex=True,
                     gridspec_kw={"height_ratios": [2, 1]})
    x = np.arange(len(y)) if t is None else t
    lims = _band(y)
    for name, yh in sims.items():
        ax[0].plot(x, yh, lw=1.0, ls="--", label=_label(name, yh, lims))
        ax[1].plot(x, yh - y, lw=0.8, label=name)
    ax[0].plot(x, y, "k", lw=0.8, label="data", zorder=5)
    ax[0].set_ylim(*lims)
    ax[0].set_ylabel(ylabel)
    ax[0].set_title(title)
    ax[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    err = np.concatenate([np.abs(yh - y)[np.isfinite(yh)] for yh in sims.values()]
                         or [np.zeros(1)])
    top = float(np.quantile(err, 0.999)) if err.size else 1.0
    ax[1].set_ylim(-1.1 * top or -1, 1.1 * top or 1)
    ax[1].axhline(0.0, color="k", lw=0.6)
    ax[1].set_ylabel(f"error ŷ − {ylabel}")
    ax[1].set_xlabel("sample" if t is None else xlabel)
    return _save(fig, path)


def plot_loop(path, u, y, sims: dict, title="Input-output loop", xlabel="u", ylabel="y"):
    fig, ax = figure(figsize=(6.2, 4.5))
    lims = _band(y)
    for name, yh in sims.items():
        ax.plot(u, yh, lw=0.9, ls="--", label=_label(name, yh, lims))
    ax.plot(u, y, "k", lw=0.8, label="data", zorder=5)
    ax.set_ylim(*lims)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    return _save(fig, path)


def plot_convergence(path, logbooks: dict, title="Convergence of the best fitness"):
    """Best fitness by generation, one panel per search: fitness values of
    different kinds (one-step against multiple-shooting MSE) are not on one
    scale."""
    names = list(logbooks)
    fig, ax = figure(len(names), 1, figsize=(6, 2.4 + 1.6 * len(names)), sharex=True,
                     squeeze=False)
    for a, name in zip(ax[:, 0], names):
        lb = logbooks[name]
        gens = np.asarray(lb.select("gen"))
        best = np.asarray(lb.select("best"), dtype=float)
        ok = np.isfinite(best) & (best > 0)
        if ok.any():
            a.semilogy(gens[ok], best[ok], color="C0")
        else:
            a.plot(gens, best, color="C0")
        a.set_ylabel(f"best {name}\nfitness")
        a.grid(True, which="both", lw=0.3)
    ax[0, 0].set_title(title)
    ax[-1, 0].set_xlabel("generation")
    return _save(fig, path)


def write_fit_report(folder, est, data, data_name: str = "data",
                     command: Optional[str] = None) -> str:
    """Write figures and ``summary.md`` for a fitted MGGPRegressor."""
    os.makedirs(folder, exist_ok=True)
    models = {"LS": est.model_}
    if est.model_cls_ is not None:
        models["CLS"] = est.model_cls_
    sims, rows = {}, []
    for name, m in models.items():
        r = m.simulate(data, mode="freerun")
        o = m.simulate(data, mode="osa")
        sims[name] = r.y_hat
        rows.append((name, r.rmse, r.mape, o.rmse, r.diverged))
    u0 = data.U[0]
    figs = [plot_freerun(os.path.join(folder, "freerun.png"), None, data.y, sims,
                         ylabel=data.output),
            plot_loop(os.path.join(folder, "loop.png"), u0, data.y, sims,
                      xlabel=data.inputs[0], ylabel=data.output),
            plot_convergence(os.path.join(folder, "convergence.png"),
                             {est.fitness: est.logbook_})]
    from .quasistatic_report import model_figure          # the model written, on a probe sine
    figs += [f for f in [model_figure(os.path.join(folder, "quasistatic.png"),
                                      est.get_best(), data.U.T)] if f]
    lines = [f"# mggp fit: {data_name}", ""]
    if command:
        lines += ["Command:", "", f"    {command}", ""]
    lines += [f"- samples: {data.n}; inputs: {', '.join(data.inputs)}; output: {data.output}",
              f"- fitness: `{est.fitness}` (criterion `{est.criterion}`), seed {est.seed_}, "
              f"population {est.population}, generations {est.generations}, "
              f"{est.n_evaluations_} structures evaluated in {est.fit_time_:.1f} s", "",
              "| fit | free-run RMSE | free-run MAPE % | one-step RMSE |",
              "|---|---:|---:|---:|"]
    for name, rm, mp, orm, div in rows:
        lines.append(f"| {name} | {'diverged' if div else f'{rm:.6g}'} | "
                     f"{'diverged' if div else f'{mp:.4g}'} | {orm:.6g} |")
    lines += ["", "## Model", ""]
    for name, m in models.items():
        lines += [f"**{name}**", "", "| term | θ |", "|---|---:|"]
        lines += [f"| `{tt}` | {v:.6g} |" for tt, v in zip(m.term_texts, m.theta)]
        lines.append("")
    why = getattr(est, "cls_rejected_", None)
    if est.model_cls_ is not None:
        lines += [f"The CLS refit {why}: the LS fit is the model used (and the one "
                  f"`mggp fit --out` writes)." if why else
                  "The CLS fit is the model used (and the one `mggp fit --out` writes).", ""]
        sums = est.model_.cluster_sums()
        lines += ["Cluster sums of the LS fit (a continuum of steady states needs "
                  "Σ_y = 1 and the others 0): " +
                  ", ".join(f"Σ_{k} = {v:.4g}" for k, v in sums.items()), ""]
    lines += ["## Pareto front (complexity = number of terms)", "",
              est.pareto_front_.to_markdown(), "", "## Figures", ""]
    lines += [f"![{os.path.basename(f)}]({os.path.basename(f)})" for f in figs]
    path = os.path.join(folder, "summary.md")
    from narx.atomic import atomic_write_text
    atomic_write_text(path, "\n".join(lines) + "\n")
    return path
