r"""The verdict: which candidate extension wins a paired held-out test, and
the effect it names.

Typical use::

    import numpy as np
    from mggp.diagnose.verdict import decide, separation_note
    v = decide(e_base, [(structure, model, e_cand), ...], alpha=0.05,
               rng=np.random.default_rng(0))
    v.named, v.winner, v.p_values              # e.g. ('hysteresis',), ..., {...}
    separation_note(train)                      # None, or one line

Rule. Within each class (``hysteresis``: the memory candidates; lags;
degree; CLS) the *representative* is the candidate with the smallest
hold-out score on the fitting samples (:func:`~.candidates.fit_structure`);
the selection samples play no part in that choice. Each representative's
free-run errors on the selection samples are compared with the baseline's
by the one-sided paired block-bootstrap test of :mod:`.paired`, and the
p-values are adjusted over the representatives by Holm's procedure. A
representative *wins* when its adjusted p-value is at most the level α.
``hysteresis`` needs more: the memory representative must also beat the
best memory-free representative (lags, degree, CLS: the one with the
smallest hold-out score), by the same one-sided test — so a baseline too
weak for a memoryless system (a Wiener saturation, say) that more degree
fixes as well is not read as hysteresis. Its p-value is the larger of the
two (intersection–union: both nulls must be rejected, each at α). Every
other effect's p-value is its representative's adjusted p-value.

Testing one representative per class instead of every candidate keeps
the multiplicity at the number of classes (4) rather than the number of
candidates (11); on a play record with a random-walk input whose
baseline error is a few slow excursions, the multiplicity of 11 alone
kept a 20-fold lower free-run RMSE from significance.

The effect named is ``hysteresis`` when its p-value is at most α and
the memory representative's free-run RMSE on the selection samples is
below the baseline's and the best memory-free representative's; otherwise
that of the winning memory-free representative (p-value at most α, RMSE
below the baseline's) with the smallest selection RMSE; otherwise nothing.
The winner is then the extension. The tests use the log loss with the
diagnosis's resolution floor (:mod:`.paired`), robust to a few large
excursions; the RMSE conditions make the winner better in the measured
metric too.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from narx import Model
from narx.data import Data

from .candidates import MEMORY, MEMORY_FREE, Structure
from .findings import json_number, number_text
from .paired import PairedTest, holm, paired_test

__all__ = ["Tested", "Verdict", "decide", "separation_note", "reversal_levels"]


def _rmse(e) -> float:
    e = np.asarray(e, dtype=float)
    return float(np.sqrt(np.mean(e * e))) if e.size and np.all(np.isfinite(e)) else np.inf


@dataclass(frozen=True)
class Tested:
    """A candidate and its tests: the structure, the model fitted on the
    fitting samples (None: it could not be fitted), its free-run RMSE on
    the selection samples, the paired test against the baseline and its
    Holm-adjusted p-value, and (memory candidates) the test against the
    best memory-free representative and its p-value (NaN otherwise); a
    candidate that did not represent its class was not tested (NaN
    p-values)."""

    structure: Structure
    model: Optional[Model]
    selection_rmse: float
    test: PairedTest
    p_adjusted: float
    versus_free: Optional[PairedTest] = None
    p_free_adjusted: float = float("nan")

    @property
    def effect(self) -> str:
        return self.structure.effect

    @property
    def p_value(self) -> float:
        """The p-value that decides this candidate (for memory candidates
        the larger of the two adjusted p-values)."""
        if self.effect == MEMORY and self.versus_free is not None:
            return float(max(self.p_adjusted, self.p_free_adjusted))
        return float(self.p_adjusted)

    @property
    def represents(self) -> bool:
        """True when this candidate represented its class in the test."""
        return self.p_adjusted == self.p_adjusted

    def to_dict(self) -> dict:
        d = {"effect": self.effect, "name": self.structure.name,
             "changes": [self.structure.changes],
             "terms": [] if self.model is None else self.model.term_texts,
             "selection_rmse": json_number(self.selection_rmse),
             "p_value": json_number(self.p_value),
             "p_versus_baseline": json_number(self.p_adjusted),
             "represents_class": self.represents, "block": self.test.block}
        if self.effect == MEMORY and self.represents:
            d["p_versus_memory_free"] = json_number(self.p_free_adjusted)
        return d


@dataclass(frozen=True)
class Verdict:
    """The outcome of :func:`decide` (module doc)."""

    level: float
    tested: Tuple[Tested, ...]
    named: Tuple[str, ...]
    winner: Optional[Tested]
    best_free: Optional[Tested]
    baseline_rmse: float
    p_values: Dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"level": self.level, "candidates": [t.to_dict() for t in self.tested],
                "p_values": {k: json_number(v) for k, v in self.p_values.items()},
                "baseline_selection_rmse": json_number(self.baseline_rmse),
                "winner": None if self.winner is None else self.winner.structure.name}

    def lines(self) -> List[str]:
        """The tests in words, one line per candidate."""
        out = []
        for t in sorted(self.tested, key=lambda t: (t.selection_rmse, t.structure.name)):
            mark = "*" if t is self.winner else " "
            if not t.represents:
                p = "(not its class's representative)"
            else:
                p = f"p {number_text(t.p_adjusted)}" + (
                    f", vs best memory-free p {number_text(t.p_free_adjusted)}"
                    if t.effect == MEMORY else "")
            out.append(f"{mark} {t.effect:<24s} {t.structure.name:<28s} RMSE "
                       f"{number_text(t.selection_rmse):>9s}  {p}")
        return out


def decide(e_base, candidates: Sequence[Tuple[Structure, Optional[Model], np.ndarray, float]],
           alpha: float, rng: np.random.Generator, floor: Optional[float] = None) -> Verdict:
    """Test each class's representative against the baseline and name the effect.

    Parameters
    ----------
    e_base : array
        The baseline's free-run errors on the selection samples.
    candidates : sequence of (Structure, Model or None, errors, score)
        Each candidate with its free-run errors on the same samples (a
        candidate that could not be fitted: model None, errors inf) and its
        hold-out score on the fitting samples (picks the representatives).
    alpha : float
        Level of the tests (family-wise over the classes, by Holm).
    rng : numpy.random.Generator
        Source of the bootstrap draws.
    floor : float, optional
        The loss of the tests (:func:`~.paired.paired_test`): None squared
        error, else the log loss with this floor.
    """
    e_base = np.asarray(e_base, dtype=float)
    rm = [_rmse(e) for _, _, e, _ in candidates]
    reps: Dict[str, int] = {}
    for i, (st, m, _, score) in enumerate(candidates):
        if m is None:
            continue
        j = reps.get(st.effect)
        if j is None or (score, rm[i]) < (candidates[j][3], rm[j]):
            reps[st.effect] = i
    order = list(reps.values())
    tests = {i: paired_test(e_base, candidates[i][2], rng, floor=floor) for i in order}
    adj = dict(zip(order, holm([tests[i].p_value for i in order])))
    free = [i for e, i in reps.items() if e in MEMORY_FREE]
    best_free = min(free, key=lambda i: (candidates[i][3], rm[i])) if free else None
    vs = None
    if MEMORY in reps:
        i = reps[MEMORY]
        vs = (PairedTest(float("nan"), 0.0, 0, e_base.size) if best_free is None
              else paired_test(candidates[best_free][2], candidates[i][2], rng, floor=floor))
    nan = PairedTest(float("nan"), float("nan"), 0, e_base.size)
    tested = []
    for i, (st, m, _, _) in enumerate(candidates):
        if i in adj and st.effect == MEMORY:
            tested.append(Tested(st, m, rm[i], tests[i], adj[i], vs, vs.p_value))
        elif i in adj:
            tested.append(Tested(st, m, rm[i], tests[i], adj[i]))
        else:
            tested.append(Tested(st, m, rm[i], nan, float("nan")))
    p_values = {tested[i].effect: tested[i].p_value for i in order}
    winner = None
    base_rmse = _rmse(e_base)
    m = reps.get(MEMORY)
    if m is not None and tested[m].p_value <= alpha and rm[m] < base_rmse and (
            best_free is None or rm[m] < rm[best_free]):
        winner = tested[m]
    else:
        ok = [tested[i] for i in free if tested[i].p_value <= alpha and rm[i] < base_rmse]
        if ok:
            winner = min(ok, key=lambda t: t.selection_rmse)
    return Verdict(float(alpha), tuple(tested), (winner.effect,) if winner else (), winner,
                   tested[best_free] if best_free is not None else None, base_rmse,
                   p_values)


def reversal_levels(u, tol: float) -> Tuple[np.ndarray, np.ndarray]:
    """The input's values at its reversals, ``(peaks, troughs)``, a reversal
    counted when the input has moved back by more than ``tol`` from its
    running extreme (small wiggles and noise are not reversals)."""
    u = np.asarray(u, dtype=float)
    peaks, troughs = [], []
    hi = lo = ext = float(u[0])
    direction = 0
    for x in map(float, u[1:]):
        if direction == 0:                  # the first move past tol sets the direction
            hi, lo = max(hi, x), min(lo, x)
            if x - lo > tol:
                direction, ext = 1, x
            elif hi - x > tol:
                direction, ext = -1, x
        elif direction > 0:
            if x > ext:
                ext = x
            elif ext - x > tol:
                peaks.append(ext)
                direction, ext = -1, x
        else:
            if x < ext:
                ext = x
            elif x - ext > tol:
                troughs.append(ext)
                direction, ext = 1, x
    return np.asarray(peaks), np.asarray(troughs)


#: share of an input's range: reversals past it count, and peaks (troughs)
#: that all lie within twice it of each other count as one level
LEVEL_TOLERANCE = 0.05


def separation_note(data: Data) -> Optional[str]:
    """One line when the record cannot tell memory from dynamics: for some
    input, its reversal points (:func:`reversal_levels`, a reversal counted
    past :data:`LEVEL_TOLERANCE` of its range) take essentially one value
    at the peaks and one at the troughs (each set spans at most twice that
    tolerance): the loop is traced at one amplitude only, and a lag or a
    memoryless term can mimic it; None otherwise."""
    for name in data.inputs:
        u = data.input(name)
        span = float(np.ptp(u))
        if not span > 0:
            continue
        tol = LEVEL_TOLERANCE * span
        peaks, troughs = reversal_levels(u, tol)
        if peaks.size + troughs.size < 2:
            continue
        if all(v.size == 0 or np.ptp(v) <= 2 * tol for v in (peaks, troughs)):
            lv = [f"{np.median(v):.3g}" for v in (troughs, peaks) if v.size]
            return (f"this record cannot separate memory from dynamics: the input {name} "
                    f"reverses only at {' and '.join(lv)} (one amplitude), so a lag can "
                    f"mimic the loop; a record with several amplitudes, or holds, would")
    return None
