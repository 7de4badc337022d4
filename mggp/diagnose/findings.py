"""The findings vocabulary and the rules that name a finding from evidence.

Typical use::

    from mggp.diagnose.findings import VOCABULARY, Check, name_findings
    findings = name_findings(checks)       # checks: the Checks every test returned
    [f.effect for f in findings]           # e.g. ['hysteresis', 'prediction-bias']

The effect a diagnosis *names* is the class of the candidate extension
that wins the paired held-out test (:mod:`mggp.diagnose.candidates`,
:mod:`mggp.diagnose.verdict`). Residual tests registered in
:mod:`mggp.diagnose.registry` (none by default, :mod:`.catalogue`) each
return :class:`Check` s, and :func:`name_findings` turns them into
*evidence* by one rule: an effect is pointed to when one of its checks
beats its threshold. The evidence explains; it does not name.

Vocabulary (the causes a diagnosis can name, and the extension each calls for):

===========================  =================================================  ========================
effect                       meaning                                            extension
===========================  =================================================  ========================
``hysteresis``               the output depends on the direction or history     Φ-functions, plays,
                             of the input beyond what the model's terms         Deng–Tan, Bouc–Wen
                             express                                            variables, Φ of output
                                                                                lags, operator dynamics
``steady-state-drift``       the model does not hold its output at a constant   CLS with the derived
                             input where the system does                        continuum constraints
                                                                                (``constraints=
                                                                                'steady-state'``)
``prediction-bias``          one-step fit good, free run poor                   multiple-shooting
                                                                                fitness (no candidate
                                                                                of the verdict)
``unmodelled-nonlinearity``  the residual depends on a nonlinear function of    one more degree, more
                             past inputs                                        terms
``unmodelled-dynamics``      the residual depends on past inputs or on itself   longer lags (taller
                                                                                trees), more terms
===========================  =================================================  ========================

**Thresholds** (of registered residual tests). A check's statistic is
compared with a threshold made of a statistical bound at false-alarm
probability α per test and a *resolution floor*, ``resolution`` × the
output's range in that record (default 0.5 %): effects smaller than the
floor are not worth a model change, and on noise-free data — where every
imperfect model is "significant" — the floor is what decides. A finding
is pointed to only when its statistic is strictly above its threshold. A
check whose threshold reaches the largest value its statistic can take
(:attr:`Check.ceiling`) has *no power* (:attr:`Check.power` is False), and
reports say so. An effect with several checks is pointed to when any of
them beats its threshold, so its false-alarm probability is at most α
times the number of its checks.
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
                               "past inputs that the model's terms miss",
    "unmodelled-dynamics": "the one-step residual depends on past inputs or on itself "
                           "at lags that the model's terms miss",
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
        Name of the check (unique within a diagnosis, e.g. ``'held-out Φ-augmentation (u)'``).
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
