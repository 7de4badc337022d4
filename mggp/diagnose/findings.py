"""The findings vocabulary and the rules that name a finding from evidence.

Typical use::

    from mggp.diagnose.findings import VOCABULARY, Check, name_findings
    findings = name_findings(checks)       # checks: the Checks every test returned
    [f.effect for f in findings]           # e.g. ['hysteresis', 'prediction-bias']

Each diagnose test (:mod:`mggp.diagnose.registry`) returns its
:class:`Check` s; :func:`name_findings` turns them into *evidence* by one
rule: an effect is pointed to when one of its checks beats its threshold.
The effect a diagnosis *names* comes from the paired test of the candidate
extensions (:mod:`mggp.diagnose.verdict`); the evidence explains it.

Vocabulary (the causes a diagnosis can name, and the extension each calls for):

===========================  =================================================  ========================
effect                       meaning, and the evidence that names it            extension
===========================  =================================================  ========================
``hysteresis``               the output depends on the direction or history     Φ-functions and
                             of the input beyond what the model's terms         plays, Deng–Tan in the
                             express: at equal input the residual differs       search; Bouc–Wen
                             between falling and rising input (loop-gap         direction terms,
                             test), or direction terms remove simulation        play and Bouc–Wen
                             error that placebo terms do not, in sample         operator dynamics as
                             or held out (Φ-augmentation tests), or the         candidates
                             memory-operator terms (plays, Bouc–Wen
                             variables) do (operator
                             augmentation), or the data rest at
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
floor is expressed in correlation units, floor / (RMS(ε) s), with s the
model's free-run/one-step error ratio (:mod:`.correlation`): a correlation
must explain a part of the residual that the free run makes as large as
the floor. The free-run
excess of ``prediction-bias`` must also reach the free-run RMSE that the
noise alone causes (the free run at least √2 times worse than the noise
explains), so that noisy data do not turn a small misfit into a finding.
Thresholds are in the statistic's units; a finding is named only when its
statistic is strictly above its threshold. A correlation test whose
threshold is 1 or more has *no power* (:attr:`Check.power` is False): no
correlation can beat it, so it measured nothing, and reports say so. An
effect with several checks (``hysteresis``: loop gap per input,
Φ-augmentation in sample and held out, operator augmentation, rest levels;
the correlation effects: one per function and
input) is named when any of them beats its threshold, so its false-alarm
probability is at most α times the number of its checks.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Sequence

import numpy as np

__all__ = ["VOCABULARY", "EXTENSIONS", "Finding", "Check", "name_findings", "number_text",
           "json_number"]

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


def json_number(v):
    """``v`` as a float for JSON; ``None`` for an infinite or undefined value."""
    v = float(v)
    return v if np.isfinite(v) else None


def number_text(v) -> str:
    """A statistic in words: 3 significant digits, ``inf``/``-inf``, ``undefined``."""
    if np.isnan(v):
        return "undefined"
    return ("inf" if v > 0 else "-inf") if not np.isfinite(v) else f"{v:.3g}"


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
                "statistic": json_number(self.statistic), "threshold": json_number(self.threshold)}


@dataclass(frozen=True)
class Check:
    """One statistic of a diagnose test against its threshold.

    Attributes
    ----------
    test : str
        Name of the check (unique within a diagnosis, e.g. ``'loop gap (u)'``).
    effect : str
        The effect of :data:`VOCABULARY` it is evidence for.
    statistic, threshold : float
        The check *beats* its threshold (:attr:`beats`: the test fires, the
        model fails it) when the statistic is strictly above a finite
        threshold.
    detail : str
        What was measured, in words, with every number the threshold is made of.
    ceiling : float
        The largest value the statistic can take (1 for a correlation); a
        check whose threshold reaches it has no power (:attr:`power`): it
        could not fire whatever the data, so it measured nothing.
    why : str
        One line saying why a check without power has none (what made its
        threshold that high, or why the test could not run).
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
        """True when the statistic is strictly above a finite threshold."""
        return bool(np.isfinite(self.threshold) and self.statistic > self.threshold)

    @property
    def power(self) -> bool:
        """False when the threshold is at or above the statistic's ceiling."""
        return bool(self.threshold < self.ceiling)

    def to_dict(self) -> dict:
        return {"test": self.test, "effect": self.effect, "statistic": json_number(self.statistic),
                "threshold": json_number(self.threshold), "beats_threshold": self.beats,
                "power": self.power, "detail": self.detail}


def _ratio(c: Check) -> float:
    if not np.isfinite(c.statistic):
        return float("inf")
    return c.statistic / c.threshold if c.threshold > 0 else float("inf")


def name_findings(checks: Sequence[Check]) -> List[Finding]:
    """Apply the rule: a finding per effect of :data:`VOCABULARY` (in its
    order) one of whose checks beats its threshold; the finding carries the
    check with the largest statistic/threshold ratio (the first of equals),
    and its evidence lists every other check of that effect that beats."""
    findings = []
    for effect in VOCABULARY:
        hits = [c for c in checks if c.effect == effect and c.beats]
        if not hits:
            continue
        best = max(hits, key=_ratio)
        text = best.detail
        if len(hits) > 1:
            text += "; also " + "; ".join(
                f"{c.test}: {number_text(c.statistic)} > {number_text(c.threshold)}"
                for c in hits if c is not best)
        findings.append(Finding(effect, text, best.statistic, best.threshold))
    return findings
