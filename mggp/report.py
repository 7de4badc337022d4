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

__all__ = ["write_fit_report", "plot_freerun", "plot_loop", "plot_convergence", "figure"]


def figure(*args, **kw):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt.subplots(*args, **kw)


def _save(fig, path):
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    import matplotlib.pyplot as plt
    plt.close(fig)
    return path


def plot_freerun(path, t, y, sims: dict, title="Free-run simulation", ylabel="y"):
    fig, ax = figure(figsize=(8, 3.6))
    ax.plot(t, y, "k", lw=1.2, label="data")
    for name, yh in sims.items():
        ax.plot(t, yh, lw=0.9, label=name)
    ax.set_xlabel("sample" if t is None else "t")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    return _save(fig, path)


def plot_loop(path, u, y, sims: dict, title="Input-output loop", xlabel="u", ylabel="y"):
    fig, ax = figure(figsize=(5, 4.5))
    ax.plot(u, y, "k", lw=1.2, label="data")
    for name, yh in sims.items():
        ax.plot(u, yh, lw=0.9, ls="--", label=name)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    return _save(fig, path)


def plot_convergence(path, logbooks: dict, title="Convergence of the best fitness"):
    fig, ax = figure(figsize=(6, 3.6))
    for name, lb in logbooks.items():
        gens = lb.select("gen")
        best = np.asarray(lb.select("best"), dtype=float)
        ok = np.isfinite(best) & (best > 0)
        if ok.any():
            ax.semilogy(np.asarray(gens)[ok], best[ok], label=name)
        else:
            ax.plot(gens, best, label=name)
    ax.set_xlabel("generation")
    ax.set_ylabel("best fitness")
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
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
    t = np.arange(data.n)
    figs = [plot_freerun(os.path.join(folder, "freerun.png"), t, data.y, sims,
                         ylabel=data.output),
            plot_loop(os.path.join(folder, "loop.png"), u0, data.y, sims,
                      xlabel=data.inputs[0], ylabel=data.output),
            plot_convergence(os.path.join(folder, "convergence.png"),
                             {est.fitness: est.logbook_})]
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
    if est.model_cls_ is not None:
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
