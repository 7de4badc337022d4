"""Figure and Markdown summary of a quasi-static analysis (Fig. 7 of [1]_).

Typical use::

    import narx
    from mggp.report.quasistatic import plot_quasistatic, summary_markdown
    qs = narx.quasistatic(model, u)
    plot_quasistatic("qs.png", qs, xlabel="u (V)", ylabel="y (µm)")
    print(summary_markdown(qs))
    model_figure("report/quasistatic.png", model, u_train)   # reports' hook

The figure draws, in the input-output plane, the model's free-run loop with
arrows for its orientation, the attracting and repelling solutions of the
frozen equation under loading (ŷ_L^a, ŷ_L^r) and unloading (ŷ_U^a, ŷ_U^r),
the bounding structure (equilibria over the input's range with the rate at
its limit, :mod:`narx.analysis.quasistatic`) and, on one loading and one unloading
sample, the output (A, C) and the attracting solution pulling it (B, D).

References
----------
.. [1] Abreu, P. E. O. G. B., Tavares, L. A., Teixeira, B. O. S., Aguirre,
   L. A., "Identification and nonlinearity compensation of hysteresis using
   NARX models", Nonlinear Dynamics, 2020 (Fig. 7).
"""
from __future__ import annotations

from typing import List, Optional

import numpy as np

from .plotting import figure

__all__ = ["plot_quasistatic", "summary_markdown", "conclusion", "loop_orientation",
           "pulls", "model_figure", "diagnosis_figure", "probe_sine"]

_COL = {"loading": "tab:red", "unloading": "tab:blue"}
_SUB = {"loading": "L", "unloading": "U"}


def loop_orientation(u, y) -> str:
    """``'counter-clockwise'`` or ``'clockwise'`` by the signed area
    ½ Σ (u_k y_{k+1} − u_{k+1} y_k) of the (u, y) path; ``'none'`` when 0
    or not finite."""
    u, y = np.asarray(u, float), np.asarray(y, float)
    ok = np.isfinite(u) & np.isfinite(y)
    u, y = u[ok], y[ok]
    if u.size < 3:
        return "none"
    a = 0.5 * float(np.sum(u[:-1] * y[1:] - u[1:] * y[:-1]))
    return "none" if not np.isfinite(a) or a == 0 else (
        "counter-clockwise" if a > 0 else "clockwise")


def pulls(qs, branch: str):
    """Per sample of ``branch`` with an attracting solution: (k, nearest
    attracting root, sign of root − output: +1 the output is pulled up)."""
    on = (qs.branch == branch) & np.isfinite(qs.y)
    R = np.where(qs.attracting, qs.roots, np.nan)
    has = on & np.any(np.isfinite(R), axis=1)
    k = np.flatnonzero(has)
    if not k.size:
        return k, np.zeros(0), np.zeros(0)
    dist = np.abs(R[k] - qs.y[k, None])
    j = np.nanargmin(np.where(np.isfinite(dist), dist, np.inf), axis=1)
    r = R[k, j]
    return k, r, np.sign(r - qs.y[k])


def _pct(a, b) -> str:
    return "0" if b == 0 else f"{100.0 * a / b:.0f}"


def conclusion(qs) -> List[str]:
    """Sentences that say how the loop forms (the summary's opening)."""
    c = qs.counts()
    out = []
    if qs.diverged:
        out.append("The model's free run diverges on this input: the analysis below "
                   "shows which solutions repel it.")
    else:
        out.append(f"The free-run loop runs {loop_orientation(qs.u, qs.y)} in the "
                   f"({qs.inputs[0]}, {qs.output}) plane.")
    parts = []
    for b, word in (("loading", "up"), ("unloading", "down")):
        n = c[b]["samples"]
        if not c[b]["attracting"]:
            continue
        k, r, s = pulls(qs, b)
        toward = int(np.sum(s > 0)) if b == "loading" else int(np.sum(s < 0))
        parts.append(f"under {b} {_pct(c[b]['attracting'], n)} % of the samples have an "
                     f"attracting solution ŷ_{_SUB[b]}^a, and on {_pct(toward, k.size)} % of "
                     f"those it lies {'above' if word == 'up' else 'below'} the output, "
                     f"which it pulls {word}")
    if parts:
        out.append("The loop forms as the output is pulled toward the attracting set of "
                   "the current branch: " + "; ".join(parts) + ".")
    elif c["loading"]["samples"] + c["unloading"]["samples"]:
        out.append("No sample of the moving input has an attracting solution: nothing "
                   "holds the output on either branch.")
    rep = sum(c[b]["repelling_only"] for b in ("loading", "unloading"))
    tot = sum(c[b]["samples"] for b in ("loading", "unloading"))
    if rep:
        out.append(f"On {_pct(rep, tot)} % of the moving samples the only solution repels "
                   f"(spectral radius of the linearised recursion ≥ 1): there the output "
                   f"is pushed away from it.")
    rest = qs.bounding.rest.solution
    if np.all(rest == "continuum"):
        out.append("With the input held (rest) the equation holds for every output: a "
                   "continuum of steady states, so the output stays where it stopped.")
    elif np.any(rest == "isolated"):
        att = np.any(qs.bounding.rest.attracting, axis=1)
        out.append(f"With the input held (rest) the output goes to isolated equilibria "
                   f"({'attracting' if att.all() else 'not all attracting'}), not a "
                   f"continuum of steady states.")
    lo, hi = qs.bounding.envelope()
    if np.isfinite(lo):
        y = qs.y[np.isfinite(qs.y)]
        tol = 1e-9 * max(abs(lo), abs(hi), 1.0)
        inside = np.mean((y >= lo - tol) & (y <= hi + tol)) if y.size else 0.0
        out.append(f"The bounding structure (attracting equilibria with the rate at its "
                   f"limit 0) spans {lo:.4g} .. {hi:.4g} and holds {100 * inside:.0f} % of "
                   f"the free run" + ("." if inside == 1 else
                                      ": it does not confine this loop."))
    return out


def summary_markdown(qs, title: str = "Quasi-static analysis",
                     figure: Optional[str] = None, command: Optional[str] = None) -> str:
    """Markdown: the conclusion first, then the counts and the rule."""
    L = [f"# {title}", "", "**Conclusion.** " + " ".join(conclusion(qs)), ""]
    if command:
        L += ["Command:", "", f"    {command}", ""]
    c = qs.counts()
    L += ["| branch | samples | attracting solution | only repelling | continuum | "
          "no solution |", "|---|---:|---:|---:|---:|---:|"]
    L += [f"| {b} | {v['samples']} | {v['attracting']} | {v['repelling_only']} | "
          f"{v['continuum']} | {v['none']} |" for b, v in c.items()]
    lo, hi = qs.bounding.envelope()
    L += ["", f"Method: {qs.method} (output lags {list(qs.lags) or 'none'}); "
          f"samples before the largest lag: {int(np.sum(qs.solution == 'initial'))}.",
          "", "Rule: at each sample every factor without an output keeps its value, "
          "every output lag is one unknown ỹ, and ỹ = F_k(ỹ) is solved; a solution "
          "attracts when the recursion linearised in the output lags is stable there "
          "(|∂ŷ_k/∂ŷ_{k-1}| < 1 for one lag). Branch: sign of the input's change. "
          "Bounding structure: the same equation with the input on a ramp through each "
          "ū, the rate (Phi1) held at its limit 0 and Phi2(u[k-a],u[k-b]), a < b, at +1 "
          "(loading), −1 (unloading), 0 (rest)" + (f"; step {qs.bounding.step:g} per sample"
                                     if qs.bounding.step else "") + "."]
    if figure:
        L += ["", f"![quasi-static analysis]({figure})", "", caption(qs)]
    return "\n".join(L) + "\n"


def _view(qs):
    """y-limits: the loop's range (the sets' 5-95 % range when the free run
    diverges; and the data's range), extended to the median of
    each attracting and repelling set and to the bounding structure's
    envelope, at most 3 loop spans from its centre, padded by 8 %."""
    y = qs.y[np.isfinite(qs.y)]
    if qs.diverged:                           # the sets, not the run that leaves them
        r = qs.roots[np.isfinite(qs.roots)]
        y = np.percentile(r, [5, 95]) if r.size else np.zeros(0)
    if qs.y_data is not None:
        y = np.concatenate([y, qs.y_data])
    if not y.size:
        return -1.0, 1.0
    lo, hi = float(y.min()), float(y.max())
    span = hi - lo or max(abs(lo), 1.0)
    mid = 0.5 * (lo + hi)
    marks = [float(np.median(r)) for b in ("loading", "unloading") for a in (True, False)
             for r in [qs.sets(b, a)[1]] if r.size]
    for m in marks + [v for v in qs.bounding.envelope() if np.isfinite(v)]:
        m = float(np.clip(m, mid - 3 * span, mid + 3 * span))
        lo, hi = min(lo, m), max(hi, m)
    pad = 0.08 * (hi - lo)
    return lo - pad, hi + pad


def _bounding_curves(qs, lo, hi):
    """The bounding structure's curves inside the plotted range ``lo..hi``:
    ``(branch, attracting, line style, word, roots)`` for each branch and
    kind that has a finite root there (the figure draws these, the caption
    names what is drawn)."""
    b = qs.bounding
    for name in ("loading", "unloading"):
        e = b.branch(name)
        for att, ls, word in ((True, "--", "attracting"), (False, ":", "repelling")):
            yb = np.where((e.roots > lo) & (e.roots < hi) & (e.attracting == att),
                          e.roots, np.nan)
            if np.any(np.isfinite(yb)):
                yield name, att, ls, word, yb


def caption(qs, clipped: int = None) -> str:
    """Caption of the figure: what is drawn, the bounding structure's
    curves only when there are some in the plotted range."""
    lo, hi = _view(qs)
    if clipped is None:
        r = qs.roots[np.isfinite(qs.roots)]
        clipped = int(np.sum((r < lo) | (r > hi)))
    kinds = {word for _, _, _, word, _ in _bounding_curves(qs, lo, hi)}
    style = {"attracting": "dashed", "repelling": "dotted"}
    bounding = ("; " + " and ".join(f"{style[w]}: the {w}" for w in
                                    ("attracting", "repelling") if w in kinds)
                + " bounding structure, the equilibria with the rate at its limit 0"
                if kinds else "")
    rest = ("; grey band: at rest every output is a steady state (a continuum)"
            if np.all(qs.bounding.rest.solution == "continuum") else "")
    return ("Quasi-static analysis: the model's free-run loop (black, arrows: its "
            "orientation) between the solutions of the frozen equation ỹ = F_k(ỹ) at each "
            "sample, attracting (dots) and repelling (crosses) under loading (red, "
            f"ŷ_L) and unloading (blue, ŷ_U){bounding}{rest}. A → B and C → D: the output "
            "and the attracting solution pulling it on one loading and one unloading "
            "sample. "
            + (f"{clipped} solutions lie outside the plotted range." if clipped else ""))


def _mark(ax, qs, branch, names, lo, hi):
    """Output (first name) and its attracting solution (second) on one
    sample of ``branch`` in the settled half of the run: the one nearest the
    middle of the input's range, or, when there the two are closer than 2 %
    of the plot's height, the one where they are farthest apart."""
    k, r, s = pulls(qs, branch)
    ok = (r > lo) & (r < hi) & (k >= qs.k.size // 2)
    if not ok.any():
        return
    k, r = k[ok], r[ok]
    gap = np.abs(r - qs.y[k])
    mid = 0.5 * (np.nanmin(qs.u) + np.nanmax(qs.u))
    i = int(np.argmin(np.abs(qs.u[k] - mid)))
    if gap[i] < 0.02 * (hi - lo):
        i = int(np.argmax(gap))
    x, ya, yb = qs.u[k[i]], qs.y[k[i]], r[i]
    col = _COL[branch]
    ax.annotate("", xy=(x, yb), xytext=(x, ya),
                arrowprops=dict(arrowstyle="->", color=col, lw=1.3, ls="--"))
    for yy, name, dx in ((ya, names[0], -18), (yb, names[1], 8)):
        ax.plot([x], [yy], "o", ms=5, mfc="white", mec=col, mew=1.3, zorder=6)
        ax.annotate(name, (x, yy), xytext=(dx, -5), textcoords="offset points",
                    fontsize=10, fontweight="bold", color=col, zorder=8,
                    bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.85))


def _arrows(ax, u, y, lo, hi, n=8):
    ok = np.flatnonzero(np.isfinite(y) & (y > lo) & (y < hi))
    if ok.size < 10:
        return
    half = ok[ok >= ok[0] + (ok.size // 2)]              # the settled half
    for i in np.linspace(0, half.size - 3, n).astype(int):
        a, b = half[i], half[i + 2]
        if u[a] == u[b] and y[a] == y[b]:
            continue
        ax.annotate("", xy=(u[b], y[b]), xytext=(u[a], y[a]),
                    arrowprops=dict(arrowstyle="-|>", color="k", lw=0, mutation_scale=14),
                    zorder=7)


def plot_quasistatic(path, qs, title: str = "Quasi-static analysis",
                     xlabel: Optional[str] = None, ylabel: Optional[str] = None) -> str:
    """Write the figure (PNG) of a :class:`narx.analysis.quasistatic.QuasiStaticResult`.

    Parameters
    ----------
    path : str or os.PathLike
        PNG file to write.
    qs : QuasiStaticResult
    title : str
    xlabel, ylabel : str, optional
        Axis labels with units, e.g. ``"u (V)"``, ``"y (µm)"`` (default: the
        signal names).

    Returns
    -------
    path
    """
    fig, ax = figure(figsize=(8.2, 6.4))
    lo, hi = _view(qs)
    b = qs.bounding
    for name in ("loading", "unloading"):
        col = _COL[name]
        ua, ya = qs.sets(name, True)
        ur, yr = qs.sets(name, False)
        sub = _SUB[name]
        if ua.size:
            ax.plot(ua, ya, ".", ms=2.5, color=col,
                    label=f"$\\hat y_{sub}^a$: attracting, {name}")
        if ur.size:
            ax.plot(ur, yr, "x", ms=3, mew=0.7, color=col, alpha=0.7,
                    label=f"$\\hat y_{sub}^r$: repelling, {name}")
    for name, _, ls, word, yb in _bounding_curves(qs, lo, hi):
        label = f"bounding structure, {name} ({word})"
        for j in range(yb.shape[1]):
            if np.any(np.isfinite(yb[:, j])):
                ax.plot(b.u, yb[:, j], ls, lw=1.2, color=_COL[name], label=label)
                label = None
    if np.all(b.rest.solution == "continuum"):
        ax.axvspan(b.u[0], b.u[-1], color="0.93", zorder=0,
                   label="rest: every point a steady state (continuum)")
    else:
        for j in range(b.rest.roots.shape[1]):
            yb = np.where((b.rest.roots[:, j] > lo) & (b.rest.roots[:, j] < hi),
                          b.rest.roots[:, j], np.nan)
            if np.any(np.isfinite(yb)):
                ax.plot(b.u, yb, ":", lw=1.0, color="0.4",
                        label="rest: steady states" if j == 0 else None)
    if qs.y_data is not None:
        ax.plot(qs.u, qs.y_data, color="0.55", lw=0.8, label="data")
    run = qs.solution != "initial"                 # from the end of the initial conditions
    yr = np.where(np.abs(qs.y) < 1e6 * (abs(lo) + abs(hi)), qs.y, np.nan)  # drawable
    ax.plot(qs.u[run], yr[run], "k", lw=1.1, label="free-run loop" + (
        " (diverges)" if qs.diverged else ""))
    _arrows(ax, qs.u[run], qs.y[run], lo, hi)
    _mark(ax, qs, "loading", ("A", "B"), lo, hi)
    _mark(ax, qs, "unloading", ("C", "D"), lo, hi)
    ax.set_ylim(lo, hi)
    ax.set_xlabel(xlabel or qs.inputs[0])
    ax.set_ylabel(ylabel or qs.output)
    ax.set_title(title)
    ax.legend(loc="upper left", fontsize=7.5, framealpha=0.9)
    import textwrap
    fig.text(0.01, 0.005, "\n".join(textwrap.wrap(caption(qs), 130)), fontsize=7,
             va="bottom", ha="left")
    fig.tight_layout(rect=(0, 0.09, 1, 1))
    fig.savefig(path, dpi=110)
    import matplotlib.pyplot as plt
    plt.close(fig)
    return path


def probe_sine(u_train, periods: float = 2.0):
    """A sine over the range of ``u_train``: centre ± 0.9 half-range, period
    the record's mean zero-crossing period (2N / crossings of u − mean,
    bounded to 100 .. N samples), ``periods`` periods."""
    u = np.asarray(u_train, float).ravel()
    c = 0.5 * (u.max() + u.min())
    a = 0.45 * (u.max() - u.min())
    x = np.sign(u - u.mean())
    cross = int(np.sum(x[1:] * x[:-1] < 0))
    period = int(np.clip(round(2 * u.size / max(cross, 1)), 100, max(u.size, 100)))
    n = int(round(periods * period))
    return c + a * np.sin(2 * np.pi * np.arange(n) / period), period


def model_figure(path, model, u_train, title: Optional[str] = None) -> Optional[str]:
    """The quasi-static figure of ``model`` on :func:`probe_sine` of its
    training input (first input; other inputs at their means); returns the
    path, or None when the analysis cannot be made (a model without output
    lags or inputs that are constant)."""
    import narx
    U = np.asarray(u_train, float)
    U = U[:, None] if U.ndim == 1 else U
    if np.ptp(U[:, 0]) == 0:
        return None
    s, period = probe_sine(U[:, 0], max(2.0, 2.0 * (model.max_lag + 2) / 100))
    cols = [s] + [np.full(s.size, float(np.mean(c))) for c in U[:, 1:].T]
    qs = narx.quasistatic(model, np.column_stack(cols) if len(cols) > 1 else s)
    return plot_quasistatic(path, qs, title or f"Quasi-static analysis (probe sine, period "
                            f"{period} samples)")


def diagnosis_figure(path, dx) -> Optional[str]:
    """:func:`model_figure` of the model a diagnosis recommends (the
    extension when it lowered the RMSE, else the baseline), probed over the
    range of the fitting samples' input."""
    scored = dx.extended if dx.gain.recommended == "extended" else dx.baseline
    return model_figure(path, scored.model, dx.fit_data.U.T,
                        f"Quasi-static analysis of the {dx.gain.recommended} model")
