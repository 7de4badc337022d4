"""The findings vocabulary and the rules that name a finding from evidence.

Typical use::

    from mggp.diagnose.findings import VOCABULARY, name_findings
    findings, checks = name_findings(evidence)       # evidence: an Evidence
    [f.effect for f in findings]           # e.g. ['hysteresis', 'prediction-bias']

Vocabulary (the causes a diagnosis can name, and the extension each calls for):

===========================  =================================================  ========================
effect                       meaning, and the evidence that names it            extension
===========================  =================================================  ========================
``hysteresis``               the output depends on the direction or history     Φ-functions in the
                             of the input beyond what the model's terms         search, and the
                             express: at equal input the residual differs       Bouc–Wen direction
                             between falling and rising input (loop-gap         terms as candidates
                             test), or direction terms remove simulation
                             error that placebo terms do not
                             (Φ-augmentation test), or the data rest at
                             different levels in two holds at the same
                             input and the model does not (rest levels)
``steady-state-drift``       the model does not hold its output at a constant   CLS with the derived
                             input where the system does: movement in a         continuum constraints
                             held-input segment of the data (hold test),        (``constraints=
                             explained by cluster sums that break Σ_y = 1,      'steady-state'``)
                             Σ_other = 0, or, started when the input stops,
                             the model rests at another level than the data
                             (rest-error test)
``prediction-bias``          one-step fit good, free run poor: the free-run     multiple-shooting
                             error exceeds what the model's own one-step        fitness (longer windows
                             residuals cause when propagated (bootstrap)        if already used)
``unmodelled-nonlinearity``  φ_u²'e or φ_u²'e² outside its band: the one-step   one more degree, more
                             residual depends on the square of past inputs      terms
``unmodelled-dynamics``      φ_ue (or φ_ee, where the residual is large         longer lags (taller
                             enough for its colour to matter) outside its       trees), more terms
                             band
===========================  =================================================  ========================

**Thresholds.** Every statistic is compared with a threshold made of a
statistical bound at false-alarm probability α per test (Bonferroni band,
t-bound, placebo or bootstrap quantile, noise bound of a hold) and a
*resolution floor*, ``resolution`` × the output's range in that record
(default 0.5 %): effects smaller than the floor are not worth a model
change, and on noise-free data — where every imperfect model is
"significant" — the floor is what decides. For the correlation tests the
floor is expressed in correlation units, floor / RMS(ε): a correlation
must explain at least the floor of the one-step residual. The free-run
excess of ``prediction-bias`` must also reach the free-run RMSE that the
noise alone causes (the free run at least √2 times worse than the noise
explains), so that noisy data do not turn a small misfit into a finding.
Thresholds are in the statistic's units; a finding is named only when its
statistic is strictly above its threshold. A correlation test whose
threshold is 1 or more has *no power* (:attr:`Check.power` is False): no
correlation can beat it, so it measured nothing, and reports say so. An effect with several tests
(``hysteresis``: two; the correlation effects: one per function and input)
is named when any of them beats its threshold, so its false-alarm
probability is at most α times the number of its tests.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from .correlation import CorrelationTest, bonferroni_z
from .evidence import BiasTest
from .holds import HoldResponse
from .hysteresis import AugmentationTest, LoopGapTest

__all__ = ["VOCABULARY", "EXTENSIONS", "Finding", "Check", "Evidence", "name_findings"]

VOCABULARY: Dict[str, str] = {
    "hysteresis": "the output depends on the direction or history of the input beyond "
                  "what the model's terms express",
    "steady-state-drift": "the model does not hold its output at a constant input where "
                          "the system does (it moves, or rests at another level)",
    "prediction-bias": "one-step fit good, free run poor (a structure chosen for "
                       "one-step prediction)",
    "unmodelled-nonlinearity": "the one-step residual depends on a nonlinear function of "
                               "past inputs (Billings-Voon φ_u²'e, φ_u²'e²)",
    "unmodelled-dynamics": "the one-step residual depends on past inputs or on itself "
                           "(Billings-Voon φ_ue, φ_ee)",
}

EXTENSIONS: Dict[str, str] = {
    "hysteresis": "Φ-functions in the structure search, Bouc–Wen direction terms as "
                  "candidates",
    "steady-state-drift": "CLS with the derived continuum-of-steady-states constraints",
    "prediction-bias": "multiple-shooting fitness",
    "unmodelled-nonlinearity": "one more degree and more terms",
    "unmodelled-dynamics": "longer lags and more terms",
}


@dataclass(frozen=True)
class Finding:
    """A named cause: ``effect`` (from :data:`VOCABULARY`), the evidence in
    words, and the statistic that beat its threshold."""

    effect: str
    evidence: str
    statistic: float
    threshold: float

    def to_dict(self) -> dict:
        return {"effect": self.effect, "evidence": self.evidence,
                "statistic": _num(self.statistic), "threshold": _num(self.threshold)}


@dataclass(frozen=True)
class Check:
    """One statistic against its threshold, named or not (for reports).

    ``ceiling`` is the largest value the statistic can take (1 for a
    correlation); a check whose threshold reaches it has no power: it
    could not fire whatever the data, so it measured nothing. ``why`` says
    what made the threshold that high.
    """

    test: str
    effect: str
    statistic: float
    threshold: float
    detail: str
    ceiling: float = float("inf")
    why: str = ""

    @property
    def beats(self) -> bool:
        return bool(np.isfinite(self.threshold) and self.statistic > self.threshold)

    @property
    def power(self) -> bool:
        """False when the threshold is at or above the statistic's ceiling."""
        return bool(self.threshold < self.ceiling)

    def to_dict(self) -> dict:
        return {"test": self.test, "effect": self.effect, "statistic": _num(self.statistic),
                "threshold": _num(self.threshold), "beats_threshold": self.beats,
                "power": self.power, "detail": self.detail}


@dataclass(frozen=True)
class Evidence:
    """Everything measured on the baseline.

    ``floor`` is the resolution floor (output units) of the fitting record;
    hold responses carry their own record and use that record's floor
    (``hold_floors[record]``); holds whose inputs differ by at most
    ``input_tolerance`` count as holds at the same input.
    ``holds_found`` counts the held-input segments of at least
    ``hold_min_len`` samples found in each record (usable or not).
    """

    correlation: Sequence[CorrelationTest]
    osa_rms: float
    loop_gap: Sequence[LoopGapTest]
    augmentation: Optional[AugmentationTest]
    bias: Optional[BiasTest]
    holds: Sequence[HoldResponse]
    floor: float
    hold_floors: Dict[str, float]
    cluster_violations: Sequence[Tuple[str, float, float]]
    alpha: float
    resolution: float
    output: str = "y"
    input_tolerance: float = 0.0
    holds_found: Dict[str, int] = field(default_factory=dict)
    hold_min_len: int = 0


def _num(v):
    v = float(v)
    return v if np.isfinite(v) else None


def _g(v) -> str:
    if np.isnan(v):
        return "undefined"
    return ("inf" if v > 0 else "-inf") if not np.isfinite(v) else f"{v:.3g}"


def _hysteresis_checks(ev: Evidence) -> List[Check]:
    out = []
    pct = f"{100 * (1 - ev.alpha):g} %"
    for g in ev.loop_gap:
        thr = max(g.bound, ev.floor)
        detail = (f"at equal {g.signal}, the residual of simulations restarted before each "
                  f"reversal differs by {_g(g.statistic)} on average between falling and "
                  f"rising {g.signal} ({g.gaps.size} reversals, t-test p = {g.p_value:.3g}, "
                  f"{pct} bound {_g(g.bound)}); resolution floor {_g(ev.floor)}")
        out.append(Check(f"loop gap ({g.signal})", "hysteresis", g.statistic, thr, detail))
    a = ev.augmentation
    if a is not None:
        thr = max(a.null_quantile, ev.floor)
        if np.isfinite(a.augmented_rmse):
            effect = (f"lower the {a.mode} RMSE of the baseline's terms (refitted by LS) "
                      f"from {_g(a.reference_rmse)} to {_g(a.augmented_rmse)} ({a.form}, "
                      f"{len(a.terms)} terms), a drop of {_g(a.statistic)}")
        else:
            effect = (f"make the {a.mode} simulation of the baseline's terms (refitted by "
                      f"LS; RMSE {_g(a.reference_rmse)}) diverge ({a.form}, "
                      f"{len(a.terms)} terms): no evidence for hysteresis from them")
        detail = (f"the Bouc–Wen direction terms |Δu|, {ev.output}[k-1]·|Δu|, u[k-1]·|Δu| "
                  f"(|Δu| = Phi1·Phi2 of u[k-1], u[k-2]) {effect}; placebo terms from the input shifted in time "
                  f"({a.n_shifts} shifts) drop it by at most {_g(a.null_quantile)} "
                  f"({pct} quantile); resolution floor {_g(ev.floor)}")
        out.append(Check("Φ-augmentation", "hysteresis", a.statistic, thr, detail))
    return out


def _bias_check(ev: Evidence) -> List[Check]:
    b = ev.bias
    if b is None:
        return []
    thr = max(b.excess_null, ev.floor, b.null_median_rmse)
    fr = "diverged" if b.diverged else _g(b.freerun_rmse)
    detail = (f"one-step RMSE {_g(b.osa_rmse)}, free-run RMSE {fr}; driven by its own "
              f"resampled one-step residuals ({b.n_boot} runs) the model's free-run RMSE "
              f"would be {_g(b.null_median_rmse)} (median), {_g(b.null_quantile_rmse)} "
              f"({100 * (1 - ev.alpha):g} % quantile): excess free-run error "
              f"{_g(b.excess)} against {_g(b.excess_null)} by chance; materiality: at "
              f"least the noise-driven RMSE {_g(b.null_median_rmse)} and the resolution "
              f"floor {_g(ev.floor)}")
    return [Check("free-run excess", "prediction-bias", b.excess, thr, detail)]


def _held(ev: Evidence):
    """Every usable hold with its bound and whether the data keep still."""
    held = [h for h in ev.holds if np.isfinite(h.data_move)]
    z = bonferroni_z(ev.alpha, max(len(held), 1))
    out = []
    for h in held:
        bound = max(z * h.noise_se, ev.hold_floors.get(h.record, ev.floor))
        out.append((h, bound, z, abs(h.data_move) <= bound))
    return out


def _hold_checks(ev: Evidence) -> List[Check]:
    out = []
    viol = ", ".join(f"{lab} = {v:.6g} (continuum needs {c:g})"
                     for lab, v, c in ev.cluster_violations) or "none"
    for h, bound, z, still in _held(ev):
        if not still:
            why = (f"the data do not hold (move {_g(h.data_move)}, bound {_g(bound)}), so "
                   f"this segment says nothing about drift or the level at rest")
            detail = f"{h.record} samples {h.start}-{h.stop - 1}: {why}"
            out.append(Check(f"hold {h.record}:{h.start}", "steady-state-drift", 0.0,
                             float("inf"), detail, why=why))
            continue
        moves = (f"moves {_g(h.model_move)}" if np.isfinite(h.model_move) else "diverges")
        detail = (f"input held at {h.level:.4g} in {h.record} samples {h.start}-{h.stop - 1}: "
                  f"the data move {_g(h.data_move)}, the model started from the measured "
                  f"state {moves} (compared from sample {h.compare_from}); bound "
                  f"max(z·se = {_g(z * h.noise_se)}, resolution floor "
                  f"{_g(ev.hold_floors.get(h.record, ev.floor))}); "
                  f"the model's steady-state equation moves {_g(h.rate)} per sample at this "
                  f"level; cluster sums off the continuum: {viol}")
        out.append(Check(f"hold {h.record}:{h.start}", "steady-state-drift", h.excess,
                         bound, detail))
        out.append(_rest_error_check(ev, h, z, viol))
    return out


def _rest_error_check(ev: Evidence, h: HoldResponse, z: float, viol: str) -> Check:
    """Does the model, started when the input stops, rest at the data's level?

    The movement test compares each signal with itself, so a model that
    jumps to a wrong level just after the input stops and keeps still
    there passes it; this check compares the model's level with the
    data's, just after its transient and at the hold's end
    (:attr:`HoldResponse.rest_error`), against max(z·se, resolution floor).

    Parameters
    ----------
    ev : Evidence
        The evidence (resolution floors).
    h : HoldResponse
        A hold in which the data keep still.
    z : float
        Bonferroni z of the hold tests.
    viol : str
        The model's cluster sums off the continuum, in words.

    Returns
    -------
    Check
        Test ``rest error <record>:<start>`` of ``steady-state-drift``.
    """
    floor = ev.hold_floors.get(h.record, ev.floor)
    bound = max(z * h.level_se, floor)
    if np.isfinite(h.rest_error):
        rests = (f"lands at {_g(h.model_settled)} once the input's last move has passed "
                 f"through its lags (samples {h.compare_from}-) and rests at "
                 f"{_g(h.model_end)} at the end")
    else:
        rests = "diverges"
    detail = (f"input held at {h.level:.4g} in {h.record} samples {h.start}-{h.stop - 1}: "
              f"the model, started from the measured state when the input stops (sample "
              f"{h.start}), {rests}; the data rest at {_g(h.data_settled)} and "
              f"{_g(h.data_end)}: error at rest {_g(h.rest_error)}; bound max(z·se = "
              f"{_g(z * h.level_se)}, resolution floor {_g(floor)}); the model's "
              f"steady-state equation moves {_g(h.rate)} per sample at this level; cluster "
              f"sums off the continuum: {viol}")
    return Check(f"rest error {h.record}:{h.start}", "steady-state-drift", h.rest_error,
                 bound, detail)


def _rest_level_checks(ev: Evidence) -> List[Check]:
    """Pairs of holds at the same input: the data rest apart; does the model?"""
    still = [(h, b) for h, b, _, ok in _held(ev) if ok]
    pairs = [(a, b) for i, a in enumerate(still) for b in still[i + 1:]
             if abs(a[0].level - b[0].level) <= ev.input_tolerance]
    z = bonferroni_z(ev.alpha, max(len(pairs), 1))
    out = []
    for (h1, _), (h2, _) in pairs:
        gap = h2.data_end - h1.data_end
        mgap = h2.model_end - h1.model_end
        floor = max(ev.hold_floors.get(h1.record, ev.floor),
                    ev.hold_floors.get(h2.record, ev.floor))
        thr = max(z * float(np.hypot(h1.noise_se, h2.noise_se)), floor)
        stat = abs(gap - mgap) if np.isfinite(mgap) else float("inf")
        if not abs(gap) > thr:
            # the data show no memory here; a model that rests apart anyway
            # is not evidence of hysteresis (drift is the hold checks' part)
            stat = min(stat, abs(gap))
        rests = f"{_g(mgap)} apart" if np.isfinite(mgap) else "nowhere (it diverges)"
        detail = (f"with the input held at {h1.level:.4g}, the data rest at "
                  f"{_g(h1.data_end)} ({h1.record} samples {h1.start}-{h1.stop - 1}) and at "
                  f"{_g(h2.data_end)} ({h2.record} samples {h2.start}-{h2.stop - 1}), "
                  f"{_g(gap)} apart: a memory of the way the input came; the model, started "
                  f"from the measured state at each hold, rests {rests}; bound "
                  f"max(z·se, resolution floor {_g(floor)})")
        out.append(Check(f"rest levels {h1.record}:{h1.start}/{h2.start}", "hysteresis",
                         stat, thr, detail))
    return out


_CORR_EFFECT = {"ee": "unmodelled-dynamics", "ue": "unmodelled-dynamics",
                "u2e": "unmodelled-nonlinearity", "u2e2": "unmodelled-nonlinearity"}


def _correlation_checks(ev: Evidence) -> List[Check]:
    out = []
    rms = ev.osa_rms
    for t in ev.correlation:
        r_rms = rms if t.rms is None else t.rms          # of the residual tested
        floor_r = ev.floor / r_rms if r_rms > 0 else float("inf")
        thr = max(t.band, floor_r)
        detail = (t.describe() + f"; resolution floor {_g(floor_r)} in correlation units "
                  f"(floor {_g(ev.floor)} / RMS {_g(r_rms)} of the residual tested)")
        why = ""
        if thr >= 1.0:
            why = (f"the residual tested, RMS {_g(r_rms)}, is no larger than the resolution "
                   f"floor {_g(ev.floor)}" if floor_r >= 1.0 else
                   f"the Bonferroni band of {t.n} samples is that wide")
            detail += (f"; no power: the threshold {_g(thr)} is at least 1, the largest "
                       f"correlation there is, because {why}: this test could not fire")
        out.append(Check(t.label, _CORR_EFFECT[t.key], t.max_abs, thr, detail, 1.0, why))
    return out


def _ratio(c: Check) -> float:
    if not np.isfinite(c.statistic):
        return float("inf")
    return c.statistic / c.threshold if c.threshold > 0 else float("inf")


def name_findings(ev: Evidence) -> Tuple[List[Finding], List[Check]]:
    """Apply the rules: a finding per effect whose strongest check beats its
    threshold (its evidence lists every check of that effect that does)."""
    checks = (_hysteresis_checks(ev) + _rest_level_checks(ev) + _bias_check(ev)
              + _hold_checks(ev) + _correlation_checks(ev))
    findings = []
    for effect in VOCABULARY:
        hits = [c for c in checks if c.effect == effect and c.beats]
        if not hits:
            continue
        best = max(hits, key=_ratio)
        text = best.detail
        if len(hits) > 1:
            text += "; also " + "; ".join(
                f"{c.test}: {_g(c.statistic)} > {_g(c.threshold)}" for c in hits if c is not best)
        findings.append(Finding(effect, text, best.statistic, best.threshold))
    return findings, checks
