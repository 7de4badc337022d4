"""Figures and a Markdown summary of a fitted model.

Typical use::

    from mggp.report.summary import write_fit_report
    write_fit_report("report/", est, data)          # PNGs + summary.md

Figures: free-run simulation against data, the input-output loop (u
against y) of data and model, and the convergence of the best fitness by
generation. Matplotlib runs headless (Agg).
"""
from __future__ import annotations

import os
from typing import Optional

import numpy as np

from narx.simulation.simulate import mode_name

from .plotting import figure, save as _save

__all__ = ["write_fit_report", "plot_freerun", "plot_loop", "plot_convergence", "figure",
           "error_groups", "plot_errors", "fitness_words", "figure_lines"]

#: canonical mode name (:data:`narx.simulation.simulate.MODE_TABLE`; aliases such as ``pem``
#: resolved by :func:`narx.simulation.simulate.mode_name`) -> the simulation its fitness scores
FITNESS_WORDS = {"osa": "one-step-ahead prediction", "freerun": "free-run simulation",
                 "ksa": "k-steps-ahead prediction", "ms": "multiple-shooting simulation"}


def fitness_words(fitness: str, criterion: str = "mse", unit: str = "output units") -> str:
    """What a fitness value is, in words, with its unit."""
    what = FITNESS_WORDS[mode_name(fitness, "fitness")]
    mse = f"the mean squared error J of the {what} over the training record ({unit}²)"
    if criterion == "bic":
        return f"BIC = N ln J + p ln N (dimensionless; J is {mse}, p the number of terms)"
    if criterion == "aic":
        return f"AIC = N ln J + 2p (dimensionless; J is {mse}, p the number of terms)"
    return mse


def _band(y):
    """Plot limits: the data's range widened by half of it on each side, so a
    diverging simulation cannot squeeze the data into a flat line."""
    lo, hi = float(np.min(y)), float(np.max(y))
    pad = 0.5 * (hi - lo) or 1.0
    return lo - pad, hi + pad


def _label(name, yh, lims):
    out = not np.all(np.isfinite(yh)) or np.any((yh < lims[0]) | (yh > lims[1]))
    return f"{name} (leaves the plot)" if out else name


def error_groups(y, sims: dict, ratio: float = 10.0) -> list:
    """The simulations split into groups of similar error size, largest first.

    The size of a simulation's error is the 99.9 % quantile of
    :math:`|\\hat y - y|`; a new group starts at the first size more than
    ``ratio`` times smaller than the largest of the current group, so that
    errors of 0.2 and 20 are never drawn on one axis (the small ones would
    look like zero).
    """
    size = {}
    for name, yh in sims.items():
        e = np.abs(np.asarray(yh, dtype=float) - y)
        e = e[np.isfinite(e)]
        size[name] = float(np.quantile(e, 0.999)) if e.size else np.inf
    order = sorted(size, key=lambda n: -size[n] if np.isfinite(size[n]) else -np.inf)
    groups = []
    for name in order:
        if groups and size[name] * ratio >= size[groups[-1][0]]:
            groups[-1].append(name)
        else:
            groups.append([name])
    return groups


def plot_errors(axes, x, y, sims: dict, groups: list, ylabel: str) -> None:
    """One error panel per group of :func:`error_groups`, each scaled to its
    own largest error (colours kept from the order of ``sims``)."""
    colour = {n: f"C{i}" for i, n in enumerate(sims)}
    for ax, names in zip(axes, groups):
        top = 0.0
        for n in names:
            e = sims[n] - y
            ax.plot(x, e, lw=0.8, color=colour[n], label=n)
            fin = np.abs(e[np.isfinite(e)])
            top = max(top, float(np.quantile(fin, 0.999)) if fin.size else 0.0)
        top = top or 1.0
        ax.set_ylim(-1.1 * top, 1.1 * top)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylabel(ylabel)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)


def plot_freerun(path, t, y, sims: dict, title="Free-run simulation", ylabel="y",
                 xlabel="t (s)", error_label=None):
    """Data and free runs (top) and each simulation's error ŷ − y below, one
    panel per group of similar error size (:func:`error_groups`), so that
    small errors are not flattened by large ones; ``t=None`` plots against
    the sample index."""
    groups = error_groups(y, sims) if sims else []
    n = 1 + len(groups)
    fig, ax = figure(n, 1, figsize=(8, 3.4 + 1.8 * len(groups)), sharex=True, squeeze=False,
                     gridspec_kw={"height_ratios": [2] + [1] * len(groups)})
    ax = ax[:, 0]
    x = np.arange(len(y)) if t is None else t
    lims = _band(y)
    colour = {nm: f"C{i}" for i, nm in enumerate(sims)}
    for name, yh in sims.items():
        ax[0].plot(x, yh, lw=1.0, ls="--", color=colour[name], label=_label(name, yh, lims))
    ax[0].plot(x, y, "k", lw=0.8, label="data", zorder=5)
    ax[0].set_ylim(*lims)
    ax[0].set_ylabel(ylabel)
    ax[0].set_title(title)
    ax[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    plot_errors(ax[1:], x, y, sims, groups, error_label or f"error ŷ − {ylabel}")
    ax[-1].set_xlabel("sample" if t is None else xlabel)
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


def plot_convergence(path, logbooks: dict, title="Convergence of the best fitness",
                     ylabels: Optional[dict] = None):
    """Best fitness by generation, one panel per search: fitness values of
    different kinds (one-step against multiple-shooting MSE) are not on one
    scale. ``ylabels`` maps a search's name to its axis label (default
    ``best NAME fitness``)."""
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
        a.set_ylabel((ylabels or {}).get(name, f"best {name}\nfitness"))
        a.grid(True, which="both", lw=0.3)
    ax[0, 0].set_title(title)
    ax[-1, 0].set_xlabel("generation")
    return _save(fig, path)


def figure_lines(figs) -> list:
    """Markdown for ``(path, caption)`` pairs: each image with its caption
    in italics on the line below it."""
    lines = []
    for i, (path, caption) in enumerate(figs, 1):
        name = os.path.basename(path)
        lines += [f"![{name}]({name})", "", f"*Figure {i}. {caption}*", ""]
    return lines


def _conclusion(est, rows, models) -> list:
    """The report's opening paragraph: the model used, how it simulates the
    training record, and what the report does not measure."""
    used = est.get_best()
    name = next(k for k, m in models.items() if m is used)
    _, rm, mp, _, div = next(r for r in rows if r[0] == name)
    fit = ("its free run over the training record **diverges**" if div else
           f"its free run over the training record has RMSE {rm:.4g} (MAPE {mp:.3g} %)")
    return [f"**Conclusion.** The model used is the {name} fit of {used.n_terms} terms; "
            f"{fit}. That is how it fits the record it was searched on, not how it "
            f"predicts fresh data: `mggp simulate MODEL.json VALIDATION.csv` measures "
            f"that, and `mggp diagnose` names what a model misses.", ""]


def _choice_lines(est) -> list:
    """The automatic choices (``choices_``) and the local search's moves, one
    line each, as ``mggp fit`` printed them."""
    out = [f"- {c['why']}" for c in getattr(est, "choices_", {}).values()]
    steps = getattr(est, "local_search_", None) or []
    if steps:
        from ..fit.local_search import moves_text
        out.append("- " + moves_text(steps, lambda t: f"`{t}`"))
    return ["## Automatic choices", ""] + out + [""] if out else []


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
    j = os.path.join
    out = data.output
    words = fitness_words(est.fitness, est.criterion, f"{out} units")
    figs = [(plot_freerun(j(folder, "freerun.png"), None, data.y, sims, ylabel=out,
                          title=f"Free run on {data_name}"),
             f"Free-run simulation of each fit against the data ({out} against the sample "
             f"index), and below the error ŷ − {out}; fits whose errors differ by more "
             f"than ten times get their own error panel, scaled to them.")]
    for i, name in enumerate(data.inputs):
        file = "loop.png" if len(data.inputs) == 1 else f"loop_{name}.png"
        figs.append((plot_loop(j(folder, file), data.U[i], data.y, sims, xlabel=name,
                               ylabel=out, title=f"Input-output loop: {out} against {name}"),
                     f"The input-output loop: {out} against the input {name}, data and "
                     f"the free run of each fit; a hysteretic system traces a loop, "
                     f"and a good model's loop lies on the data's."))
    figs.append((plot_convergence(j(folder, "convergence.png"), {est.fitness: est.logbook_},
                                  ylabels={est.fitness: f"best {est.fitness} fitness\n" + (
                                      f"MSE ({out} units², log)" if est.criterion == "mse"
                                      else est.criterion.upper())}),
                 f"The best fitness of each generation of the search (lower is better): "
                 f"{words}. A flat tail means more generations would not have helped."))
    from .quasistatic import model_figure          # the model written, on a probe sine
    qs = model_figure(j(folder, "quasistatic.png"), est.get_best(), data.U.T)
    if qs:
        figs.append((qs, "Quasi-static analysis of the model written (on a probe sine over "
                         "the training input's range): its free-run loop between the "
                         "attracting and repelling solutions of the frozen equation under "
                         "loading and unloading (narx.quasistatic)."))
    lines = [f"# mggp fit: {data_name}", ""] + _conclusion(est, rows, models)
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
    lines += _choice_lines(est)
    lines += ["## Pareto front (complexity = number of terms)", "",
              est.pareto_front_.to_markdown(), "", "## Figures", ""]
    lines += figure_lines(figs)
    path = os.path.join(folder, "summary.md")
    from narx.atomic import atomic_write_text
    atomic_write_text(path, "\n".join(lines) + "\n")
    return path
