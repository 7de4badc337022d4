"""Terminal summary, Markdown report and figures of a diagnosis.

Typical use::

    from mggp.diagnose.report import write_report, terminal_summary
    print(terminal_summary(dx))
    write_report("report/", dx, command="mggp diagnose train.csv ...")

Figures (PNG, headless): the measuring record against both models in free
run (time and u–y loop); the baseline's simulation residual against the
input in the u–e plane, rising and falling input apart (and the
extension's residual beside it); the responses in every held-input
segment (data, baseline and extension, each model started from the
measured state when the input stops).
"""
from __future__ import annotations

import os
from typing import List, Optional

import numpy as np

from narx.atomic import atomic_write_text
from narx.records.outliers import Spike, spikes_text

from ..report.plotting import figure, save as _save
from ..report.quasistatic import diagnosis_figure
from ..report.summary import figure_lines
from .findings import EXTENSIONS, VOCABULARY
from .holds import hold_responses
from .verdict import MEMORY_SHARE, UNSEPARATED_SHARE
from .simulation import direction_of_change, simulation_residual

__all__ = ["terminal_summary", "write_report", "verdict"]


def _nothing_why(v) -> str:
    """Why the verdict named nothing, in words."""
    rival = v.unnamed_rival()
    if rival is not None:
        w, name = v.winner, rival.structure.name
        won = (f"{w.structure.name} beats the baseline (RMSE {_g(w.selection_rmse)} against "
               f"{_g(v.baseline_rmse)}, p {_g(w.p_adjusted)}) and is the extension, but ")
        if not v.separates and name not in v.barred:
            return (won + f"this record cannot separate memory from dynamics and it beats the "
                    f"memory-free {name} (RMSE {_g(rival.selection_rmse)}) by less than "
                    f"{UNSEPARATED_SHARE:.0%}: memory is not told from a lag")
        why = (v.bar_reason(name) if name in v.barred else
               "loses a part of the selection samples to the baseline")
        fits = ("as well or better" if rival.selection_rmse <= w.selection_rmse else
                "nearly as well, within the margin a memory candidate must clear to be named")
        return (won + f"the memory-free {name} fits the selection samples {fits} "
                f"(RMSE {_g(rival.selection_rmse)}) and is ruled out only because it {why}: "
                f"memory is not told from a memoryless nonlinearity")
    barred = v.barred_winners()
    if not barred:
        return (f"no candidate extension beat the baseline at level {v.level:g}, "
                "Holm-corrected")
    names = "; ".join(f"{t.structure.name} {v.bar_reason(t.structure.name)}" for t in barred)
    return (f"the candidates that beat the baseline at level {v.level:g} cannot win ({names}), "
            "and no other candidate qualified (a memory candidate must also beat the best "
            "candidate without memory by a margin)")


def _g(v) -> str:
    if v is None or np.isnan(v):
        return "undefined"
    return ("inf" if v > 0 else "-inf") if not np.isfinite(v) else f"{v:.4g}"


def _rm(v) -> str:
    """An RMSE, or 'diverges'."""
    return "diverges" if v is None or not np.isfinite(v) else f"{v:.4g}"


def untested(ev, checks=()) -> list:
    """The kinds of evidence that could not be measured on this record.

    Parameters
    ----------
    ev : Evidence
        The evidence of the diagnosis (what each test could not measure,
        :attr:`Evidence.missing`).
    checks : sequence of Check
        The diagnosis's checks. A check without power whose statistic has
        a ceiling (its threshold reaches it) is listed with what made its
        threshold that wide; any other check without power could not run
        and is listed with its own reason (:attr:`Check.why`, else its
        detail).

    Returns
    -------
    list of str
        One phrase per kind of evidence not measured.
    """
    out = list(ev.missing)
    weak = {}
    for c in checks:
        if c.power:
            continue
        if np.isfinite(c.ceiling):          # its threshold reaches the ceiling
            weak.setdefault(c.why, []).append(c.test)
        else:                               # a test that could not run: its own reason
            out.append(f"{c.test}: could not run ({c.why or c.detail})")
    for why, tests in weak.items():
        out.append(f"{', '.join(tests)}: no power ({why or 'its bound is that wide'}, so "
                   f"the threshold reaches the largest value the statistic can take, and "
                   f"{'these tests' if len(tests) > 1 else 'this test'} could not fire)")
    return out


def terminal_summary(dx) -> str:
    """A short readable summary (the CLI prints it)."""
    b, e, g = dx.baseline, dx.extended, dx.gain
    v = dx.verdict
    lines = [f"baseline: {b.source}, {b.model.n_terms} terms",
             f"samples:  {dx.split.describe()}"]
    if dx.findings:
        lines.append("named:")
        for f in dx.findings:
            lines.append(f"  {f.effect:<24s} p {_g(f.statistic)} <= level {_g(f.threshold)}")
    else:
        lines.append(f"named: nothing ({_nothing_why(v)})")
    lines.append("candidates (free-run RMSE on the selection samples, baseline "
                 f"{_g(v.baseline_rmse)}; one-sided p against the baseline, Holm):")
    lines += ["  " + t for t in v.lines()]
    if dx.separation:
        lines.append(f"note: {dx.separation}")
    if dx.evidence.outcomes:                # registered residual tests (none by default)
        if dx.evidence_findings:
            lines.append("evidence (residual statistics, explanation only):")
            for f in dx.evidence_findings:
                lines.append(f"  {f.effect:<24s} {_g(f.statistic)} > threshold "
                             f"{_g(f.threshold)}")
        else:
            lines.append("evidence (residual statistics): no statistic beat its threshold")
        missing = untested(dx.evidence, dx.checks)
        if missing:
            lines.append("not tested: " + "; ".join(missing))
        if not dx.evidence_findings:
            lines += [f"{'closest' if k == 0 else 'also below'}: {t}"
                      for k, t in enumerate(closest_misses(dx))]
    if v.winner is not None:
        lines.append(f"extension ({v.winner.structure.name}, {e.model.n_terms} terms"
                     + ("" if v.named else "; its cause not named") + "):")
        lines += [f"  {c}" for c in dx.changes]
        if dx.operator_params:
            lines.append(f"  {dx.operator_params['words']}")
    if not np.isfinite(g.baseline):
        lines.append("warning: the baseline's free run diverges on the measuring samples, "
                     "so no gain can be measured against it")
    late = dx.settings.get("dead_time")
    if late:
        lines.append(f"note: {late['why']}; the searches' trees have height {late['height']} "
                     f"to reach it")
    glitches = dx.settings.get("outliers")
    if isinstance(glitches, dict) and any(glitches.values()):
        lines.append("note: isolated glitches repaired before the diagnosis "
                     "(--outliers keep: none): " + "; ".join(
                         f"{label}: " + spikes_text([Spike.from_dict(d) for d in found],
                                                    dx.fit_data.output)
                         for label, found in glitches.items() if found))
    out = {k: v for k, v in dx.settings.get("measure_outside_fit_range", {}).items() if v > 0}
    if out:
        lines.append("note: " + ", ".join(f"{100 * v:.3g} % of the measuring samples' {k}"
                                          for k, v in out.items())
                     + " lie outside the range of the fitting samples: the gain includes "
                       "extrapolation")
    lines.append(f"gain: free-run RMSE {_rm(g.baseline)} (baseline) -> {_rm(g.extended)} "
                 f"(extended), ratio {_g(g.ratio)}; MAPE {_rm(b.mape)} % -> {_rm(e.mape)} %")
    lines.append(f"recommended: {verdict(dx)}")
    return "\n".join(lines)


def closest_misses(dx, least: float = 0.25) -> List[str]:
    """In words, the check closest to its threshold that did not beat it, and
    every other such check whose threshold the resolution floor set (what
    the floor hides, and the option that moves it); only checks whose
    statistic reaches ``least`` of their threshold."""
    from .thresholds import applied_factor
    miss = sorted((c for c in dx.checks if c.power and not c.beats
                   and np.isfinite(c.threshold) and c.threshold > 0
                   and c.statistic >= least * c.threshold),
                  key=lambda c: -c.statistic / c.threshold)
    floor, out = dx.evidence.floor, []
    for k, c in enumerate(miss):
        f = applied_factor(c.test)
        at_floor = floor > 0 and abs(c.threshold - f * floor) <= 1e-9 * c.threshold
        if k and not at_floor:
            continue
        text = f"{c.test} ({c.effect}) {_g(c.statistic)} against its threshold {_g(c.threshold)}"
        if at_floor:
            text += (f", the resolution floor ({dx.evidence.resolution:g} of the output range"
                     f"{f' × the calibration factor {f:.3g}' if f > 1 else ''}): an effect "
                     f"this small is not named; --resolution sets the floor")
        out.append(text)
    return out


def _rmse(v) -> str:
    return "diverges" if v is None or not np.isfinite(v) else f"RMSE {v:.4g}"


def verdict(dx) -> str:
    """Which model to use, and why, in one sentence (``dx.gain.recommended``)."""
    g = dx.gain
    if g.recommended == "baseline":
        return "the baseline (no candidate extension won the test, so nothing was changed)" + (
            "; its free run diverges on the measuring samples, so it is no usable model of "
            "them either: fit with other settings or more data" if not np.isfinite(g.baseline)
            else "")
    if not (np.isfinite(g.baseline) or np.isfinite(g.extended)):
        how = "both models diverge there"
    elif g.ratio > 1:
        how = f"its free-run RMSE there is {_g(g.ratio)} times lower than the baseline's"
    else:
        how = (f"it {'is no better' if g.ratio == 1 else 'is worse'}, though: "
               f"{_rmse(g.extended)} against {_rmse(g.baseline)} for the baseline")
    return (f"the extended model (it won the test on the selection samples; on the "
            f"measuring samples {how})")


def _plot_models(path, dx, inputs):
    d = dx.measure_data
    first = dx.split.measure[0]
    t = np.arange(d.n) + first
    scored = dx.split.measure_mask(first + d.n)[first:]
    n = len(inputs)
    fig, axes = figure(1, 1 + n, figsize=(7.5 + 3.5 * n, 3.8),
                       gridspec_kw={"width_ratios": [2] + [1] * n}, squeeze=False)
    axes = axes[0]
    for i, (ax, x) in enumerate(zip(axes, [t] + [d.input(name) for name in inputs])):
        # the loops show the scored samples only; the time axis shows the
        # selection blocks between them too, shaded
        keep = (lambda v: v) if i == 0 else (lambda v: np.where(scored, v, np.nan))
        ax.plot(x, keep(d.y), "k", lw=1.2, label="data")
        ax.plot(x, keep(dx.baseline.y_hat), lw=0.9,
                label=f"baseline (RMSE {_g(dx.baseline.rmse)})")
        ax.plot(x, keep(dx.extended.y_hat), lw=0.9, ls="--",
                label=f"extended (RMSE {_g(dx.extended.rmse)})")
    for a, b in dx.split.validation_select:
        if b > first:
            axes[0].axvspan(max(a, first), b - 1, color="grey", alpha=0.15, lw=0)
    axes[0].axvline(dx.split.scored_from, color="grey", lw=0.6, ls=":")
    axes[0].set_xlabel(f"sample of {dx.split.measure_record}")
    axes[0].set_ylabel(d.output)
    axes[0].set_title("Free run on the measuring samples" + (
        " (shaded: selection blocks, not scored)" if dx.split.validation_select else ""))
    for ax, name in zip(axes[1:], inputs):
        ax.set_xlabel(name)
        ax.set_title(f"Loop: {d.output} against {name}")
    axes[0].legend(loc="best", fontsize=7)
    for ax in axes:
        lo, hi = np.nanmin(d.y), np.nanmax(d.y)
        pad = 0.25 * (hi - lo or 1.0)
        ax.set_ylim(lo - pad, hi + pad)
    return _save(fig, path)


def _plot_direction(path, dx, inputs):
    d = dx.fit_data
    n = len(inputs)
    fig, axes = figure(n, 2, figsize=(11, 4 * n), sharey=True, squeeze=False)
    residuals = [(name, *simulation_residual(m, d)) for name, m in
                 (("baseline", dx.baseline.model), ("extended", dx.extended.model))]
    for row, signal in zip(axes, inputs):
        u = d.input(signal)
        s = direction_of_change(u)
        for ax, (name, e, source) in zip(row, residuals):
            for sign, col, lab in ((1, "tab:red", "rising"), (-1, "tab:blue", "falling")):
                k = (s == sign) & np.isfinite(e)
                ax.plot(u[k], e[k], ".", ms=1.5, color=col, alpha=0.35, label=f"{lab} {signal}")
            ax.axhline(0, color="k", lw=0.5)
            ax.set_title(f"{name}: {source.split(' (')[0]} residual against {signal}",
                         fontsize=9)
            ax.set_xlabel(signal)
            ax.legend(loc="best", fontsize=7, markerscale=6)
        row[0].set_ylabel(f"e = {d.output} - ŷ  (fitting samples)")
    return _save(fig, path)


def _plot_holds(path, dx) -> Optional[str]:
    hs = [h for h in dx.evidence.holds]
    if not hs:
        return None
    ext = {}
    min_len = max(20, 2 * dx.baseline.model.max_lag + 12)
    second = ((dx.second_data, dx.second_offset) if dx.second_data is not None
              else (dx.measure_data, dx.split.measure[0]))
    for data, rec, off in ((dx.fit_data, dx.records[0], dx.split.fit[0]),
                           (second[0], dx.records[1], second[1])):
        for h in hold_responses(dx.extended.model, data, rec, min_len, offset=off):
            ext[(h.record, h.start)] = h
    hs = hs[:6]
    span = float(np.ptp(dx.measure_data.y)) or 1.0
    fig, axes = figure(1, len(hs), figsize=(4 * len(hs), 3.4), squeeze=False)
    for ax, h in zip(axes[0], hs):
        ax.plot(h.t, h.y, "k", lw=1.2, label="data")
        ax.plot(h.t, h.y_hat, lw=1.0, label="baseline")
        he = ext.get((h.record, h.start))
        if he is not None:
            ax.plot(he.t, he.y_hat, lw=1.0, ls="--", label="extended")
        ax.axvspan(h.start, h.stop - 1, color="0.9", zorder=0)
        lo, hi = float(np.min(h.y)), float(np.max(h.y))
        pad = max(0.5 * (hi - lo), 0.05 * span, 1e-9)
        ax.set_ylim(lo - pad, hi + pad)
        ax.set_title(f"{h.record}: hold at {h.level:.3g}", fontsize=9)
        ax.set_xlabel("sample")
    axes[0][0].legend(loc="best", fontsize=7)
    return _save(fig, path)


def _table(rows: List[List[str]], header: List[str]) -> List[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(c.replace("|", "\\|") for c in r) + " |" for r in rows]
    return out


def _model_lines(scored, title) -> List[str]:
    m = scored.model
    lines = [f"### {title}", "", scored.source, "",
             f"Free run on the measuring samples: RMSE {_g(scored.rmse)}, "
             f"MAPE {_g(scored.mape)} %", ""]
    lines += _table([[f"`{t}`", f"{v:.6g}"] for t, v in zip(m.term_texts, m.theta)],
                    ["term", "θ"])
    return lines + [""]


def _inputs(dx, inputs) -> list:
    """The inputs to plot: all of the data's, or those named (checked)."""
    have = list(dx.fit_data.inputs)
    if inputs is None:
        return have
    inputs = [inputs] if isinstance(inputs, str) else list(inputs)
    bad = [n for n in inputs if n not in have]
    if bad or not inputs:
        raise ValueError(f"inputs: the data's inputs are {have}, got {inputs}")
    return inputs


def _evidence_lines(dx) -> List[str]:
    """The report's lines on the registered residual tests: what they point
    to, what they could not measure, and every check."""
    L = ["", "Evidence from the residual statistics (explanation, not the gate): "
         + ("; ".join(f"`{f.effect}` ({_g(f.statistic)} > {_g(f.threshold)})"
                      for f in dx.evidence_findings) or "none") + "."]
    if untested(dx.evidence, dx.checks):
        L += ["", "Not tested (a finding of these kinds could not be made): "
              + "; ".join(untested(dx.evidence, dx.checks)) + "."]
    L += ["", "## Every test", "", f"False-alarm probability α = {dx.evidence.alpha:g} per "
          f"test; resolution floor {dx.evidence.resolution:g} × output range. A statistic "
          f"above its threshold is evidence for its effect; what is named comes from the "
          f"paired test of the candidates.", ""]
    L += _table([[c.test, c.effect, _g(c.statistic), _g(c.threshold),
                  "**yes**" if c.beats else "no" if c.power else
                  "no power" if np.isfinite(c.ceiling) else "could not run"]
                 for c in dx.checks],
                ["test", "effect", "statistic", "threshold", "beats"])
    if any(np.isfinite(c.ceiling) and not c.power for c in dx.checks):
        L += ["", "A check whose threshold reaches the largest value its statistic can take "
              "has no power (\"no power\" above): it measured nothing.", ""]
    return L


def write_report(folder, dx, command: Optional[str] = None, title: str = "data",
                 inputs=None) -> str:
    """Write ``summary.md`` and the figures into ``folder``; returns the path.

    ``inputs`` names the inputs whose loops and residual planes are plotted
    (default: every input of the data).
    """
    inputs = _inputs(dx, inputs)
    os.makedirs(folder, exist_ok=True)
    j = os.path.join
    out, names = dx.measure_data.output, ", ".join(inputs)
    figs = [(f"Data against both models. Left: the output {out} against the sample index "
             f"of the measuring record, data and the free run of the baseline and of the "
             f"extended model (the dotted line: scoring starts there; shaded: the "
             f"validation record's selection blocks between the measuring ones, not scored). "
             f"Right: the loop of {out} against each input ({names}), on the scored "
             f"samples.",
             _plot_models(j(folder, "models.png"), dx, inputs)),
            (f"The free-run residual e = {out} − ŷ on the fitting samples against each input "
             f"({names}), red where that input rises, blue where it falls, for the baseline "
             f"(left) and the extended model (right). Two separate bands at equal input "
             f"mean the residual depends on the direction of input change: hysteresis the "
             f"model misses.", _plot_direction(j(folder, "residual_direction.png"), dx,
                                               inputs)),
            (f"Held-input responses: each segment where the input stops (shaded), data, "
             f"baseline and extended model started from the measured state; {out} against "
             f"the sample index. A model with a continuum of steady states stays flat.",
             _plot_holds(j(folder, "holds.png"), dx)),
            ("Quasi-static analysis of the recommended model on a probe sine over the "
             "fitting input's range: its free-run loop between the attracting and repelling "
             "solutions of the frozen equation under loading and unloading.",
             diagnosis_figure(j(folder, "quasistatic.png"), dx))]
    L = [f"# mggp diagnose: {title}", ""]
    if command:
        L += ["Command:", "", f"    {command}", ""]
    L += ["## Samples", "", dx.split.describe() + ". Held-input segments are searched in "
          "both records (nothing is fitted on the measuring record). The data files are "
          "read, never modified.", ""]
    if dx.settings.get("user_model") and dx.split.measure_record == dx.split.fit_record:
        L += ["The baseline's θ come from the model file: whether the data it was fitted "
              "on overlap the measuring samples is not known to this diagnosis.", ""]
    L += ["## Named", ""]
    if dx.findings:
        L += _table([[f"`{f.effect}`", _g(f.statistic), _g(f.threshold), f.evidence]
                     for f in dx.findings], ["effect", "p-value", "level", "why"])
    else:
        L.append(f"Nothing: {_nothing_why(dx.verdict)}"
                 + ("." if dx.verdict.winner is not None else ", so nothing was changed."))
    if dx.separation:
        L += ["", f"Note: {dx.separation}."]
    if dx.evidence.outcomes:                # registered residual tests (none by default)
        L += _evidence_lines(dx)
    L += ["", "## Models", ""]
    L += _model_lines(dx.baseline, "Baseline")
    L += _model_lines(dx.extended, "Extended")
    v = dx.verdict
    L += [f"Candidates, each fitted on the fitting samples and simulated in free run on the "
          f"selection samples; p: one-sided paired block-bootstrap p-value that it beats "
          f"the baseline (log loss, Holm-adjusted over the candidates); a memory candidate "
          f"is named when its RMSE is also below the best memory-free one's by more than "
          f"the resolution or {MEMORY_SHARE:.0%} of it. "
          f"Level {v.level:g}; baseline RMSE {_g(v.baseline_rmse)}.", ""]
    L += _table([[t.effect, t.structure.name, str(0 if t.model is None else t.model.n_terms),
                  _g(t.selection_rmse), _g(t.p_adjusted), "**yes**" if t is v.winner else ""]
                 for t in sorted(v.tested, key=lambda t: t.selection_rmse)],
                ["effect", "candidate", "terms", "selection RMSE", "p vs baseline", "winner"])
    L.append("")
    if dx.separation:
        L += [f"Note: {dx.separation}.", ""]
    g = dx.gain
    L += ["## Gain", "", f"Free-run RMSE on the measuring samples: baseline {_g(g.baseline)}, "
          f"extended {_g(g.extended)}, ratio baseline/extended {_g(g.ratio)}.", "",
          f"Recommended: {verdict(dx)}.", ""]
    L += ["## Figures", ""]
    L += figure_lines([(p, cap) for cap, p in figs if p])
    if not figs[2][1]:
        L += ["(No held-input figure: no held-input segment in the data.)", ""]
    L += ["## Vocabulary", ""]
    L += _table([[f"`{k}`", v, EXTENSIONS[k]] for k, v in VOCABULARY.items()],
                ["effect", "meaning", "extension"])
    path = j(folder, "summary.md")
    atomic_write_text(path, "\n".join(L) + "\n")
    return path
