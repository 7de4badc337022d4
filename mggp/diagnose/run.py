"""Run a diagnosis: baseline, evidence, findings, extension, gain.

Typical use::

    from mggp.diagnose import diagnose, Budget
    dx = diagnose(train, validation=val, model=None, budget=Budget(), seed=0, jobs=2,
                  level=0.05)
    print(dx.summary())
    dx.verdict.p_values, dx.split.describe()
    json.dump(dx.to_dict(), fh)          # the --json schema

Sample bookkeeping (never modifies the data): three sets of samples, each
with one job. With a validation record, the baseline and the candidates
are fitted on the first ``1 − SELECT`` of the training record, the paired
test that names the effect and picks the extension uses the rest of the
training record and the selection blocks of the validation record (its
head, then every other block of its rest: :func:`validation_blocks`; the
*selection* samples, :func:`_selection_errors`), and the gain is measured
on the validation record's other blocks; without one, the last
``holdout`` of the training record measures and the samples before it are
cut the same way. The
models measured are those fitted on the fitting samples (no refit: the
model recommended is the one the test chose). The selection samples are
scored on a free run of the training record from its first sample (every
state of a model, the memory operators of the output included, is its
own when the selection samples begin; :func:`_errors`), and so are the
measuring samples, on a free run of their record from its first sample
(:func:`~.simulation.freerun_after`), from the first L samples on
(L = the largest lag of the models compared), the same samples for every
model. A validation record, whose
head selects (or which is measured whole when too short to split), may
start in motion: its operators start from the history that fits its head
best (:func:`narx.simulation.simulate.estimate_history`). The
evidence comes from the fitting samples; held-input segments are
searched in both records; nothing is fitted or chosen on the measuring
samples, so the gain there is an out-of-sample measurement of the
choice.
"""
from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from narx import Model
from narx.records.data import Data, DataError
from narx.simulation.metrics import mape
from narx.records.outliers import find_spikes, repaired

from .context import Context
from .candidates import (MIN_FIT, MIN_SELECT, candidate_structures, estimate_operators,
                         fit_structure, why_barred)
from .holds import record_holds
from .extend import SEARCH_MODEL_KEPT, Budget, baseline_search, user_setting
from .findings import Check, Finding, json_number as _num, name_findings, number_text
from .registry import Evidence, registered, run_tests
from .simulation import freerun_after
from .verdict import Verdict, decide, loss_floor, rmse_of, separation_note

__all__ = ["diagnose", "Diagnosis", "Split", "Scored", "Gain", "slice_data",
           "outside_fit_range"]


def slice_data(data: Data, a: int, b: int) -> Data:
    """Samples a..b-1 as a new record (copies; the original is untouched)."""
    return Data(data.U[:, a:b].T.copy(), None if data.y is None else data.y[a:b].copy(),
                inputs=data.inputs, output=data.output)


@dataclass(frozen=True)
class Split:
    """Which samples fitted the models, which tested and selected the
    candidates, and which measured the gain (ranges are 0-based, ``stop``
    exclusive, in each record's own numbering). The selection samples are
    those of the fitting record right after the fitting samples
    (``select``) and, with a validation record, the head of that record
    (``validation_select``, before the measuring samples; (0, 0): none)."""

    fit_record: str
    fit: Tuple[int, int]
    measure_record: str
    measure: Tuple[int, int]
    scored_from: int
    select: Tuple[int, int] = (0, 0)
    select_scored_from: int = 0
    validation_select: Tuple[Tuple[int, int], ...] = ()
    validation_select_scored_from: int = 0
    measure_blocks: Tuple[Tuple[int, int], ...] = ()

    @property
    def blocks(self) -> Tuple[Tuple[int, int], ...]:
        """The measuring samples, ``(start, stop)`` blocks of the measuring
        record (the whole measure range when none are given)."""
        return self.measure_blocks or (self.measure,)

    def measure_mask(self, n: int) -> np.ndarray:
        """The scored measuring samples as a mask over the ``n`` samples of
        the measuring record."""
        return block_mask(n, self.blocks, self.scored_from)

    def describe(self) -> str:
        def spans(blocks, scored_from):
            return ", ".join(f"{max(a, scored_from)}-{b - 1}" for a, b in blocks
                             if b > max(a, scored_from))
        sel = ""
        if self.select[1] > self.select[0]:
            sel = (f"candidates tested and selected by free run on samples {self.select[0]}-"
                   f"{self.select[1] - 1} of {self.fit_record} ({self.select_scored_from}-"
                   f"{self.select[1] - 1} scored)")
            if self.validation_select:
                sel += (f" and {spans(self.validation_select, self.validation_select_scored_from)}"
                        f" of {self.measure_record}")
            sel += "; "
        return (f"fitted on samples {self.fit[0]}-{self.fit[1] - 1} of {self.fit_record}; "
                + sel + f"gain measured on samples {spans(self.blocks, self.scored_from)} of "
                f"{self.measure_record}, in a free run from the record's first sample")

    def to_dict(self) -> dict:
        d = {"fit": {"record": self.fit_record, "first": self.fit[0],
                     "last": self.fit[1] - 1},
             "select": {"record": self.fit_record, "first": self.select[0],
                        "last": self.select[1] - 1, "scored_from": self.select_scored_from},
             "measure": {"record": self.measure_record, "first": self.measure[0],
                         "last": self.measure[1] - 1, "scored_from": self.scored_from,
                         "blocks": [[a, b - 1] for a, b in self.blocks]}}
        if self.validation_select:
            d["select_validation"] = {"record": self.measure_record,
                                      "blocks": [[a, b - 1] for a, b in self.validation_select],
                                      "scored_from": self.validation_select_scored_from}
        return d


@dataclass(frozen=True)
class Scored:
    """A model, where it came from, and its free run on the measuring samples."""

    model: Model
    source: str
    rmse: float
    mape: float
    y_hat: np.ndarray

    def to_dict(self, changes: Optional[Sequence[str]] = None) -> dict:
        d = {"terms": self.model.term_texts, "theta": [float(v) for v in self.model.theta],
             "validation": {"rmse": _num(self.rmse), "mape": _num(self.mape)}}
        if changes is not None:
            d["changes"] = list(changes)
        return d


@dataclass(frozen=True)
class Gain:
    """RMSE of both models on the measuring samples; ratio = baseline / extended
    (> 1: the extension is better). ``recommended`` is ``'extended'`` only
    when the extension won the paired test on the selection samples
    (``won``); otherwise the baseline is kept. The measuring samples play
    no part in that choice, so the ratio is an honest out-of-sample gain."""

    baseline: float
    extended: float
    metric: str = "rmse"
    won: bool = False

    @property
    def ratio(self) -> float:
        """baseline / extended; NaN when both diverge (undefined)."""
        b, e = float(self.baseline), float(self.extended)
        if not (np.isfinite(b) or np.isfinite(e)):
            return float("nan")
        if e == 0:
            return 1.0 if b == 0 else float("inf")
        return b / e

    @property
    def recommended(self) -> str:
        """``'extended'`` if the extension won the paired test, else ``'baseline'``."""
        return "extended" if self.won else "baseline"

    def to_dict(self) -> dict:
        return {"metric": self.metric, "baseline": _num(self.baseline),
                "extended": _num(self.extended), "ratio": _num(self.ratio),
                "recommended": self.recommended}


@dataclass
class Diagnosis:
    """Result of :func:`diagnose` (every field named; see ``to_dict`` for JSON).

    ``findings`` are the named effects (from ``verdict``, each with its
    p-value against the level); ``evidence_findings`` the effects the
    residual statistics point to (explanation, not the gate);
    ``separation`` one line when the record cannot separate memory from
    dynamics (else None)."""

    findings: List[Finding]
    checks: List[Check]
    evidence: Evidence
    baseline: Scored
    extended: Scored
    verdict: Verdict
    gain: Gain
    split: Split
    fit_data: Data
    measure_data: Data
    measure_holds: List[Tuple[int, int]]
    records: Tuple[str, str]
    settings: Dict[str, object]
    timings: Dict[str, float] = field(default_factory=dict)
    evidence_findings: List[Finding] = field(default_factory=list)
    separation: Optional[str] = None
    #: the whole second record whose held-input segments are evidence
    #: (``measure_holds``, in its own numbering from ``second_offset``)
    second_data: Optional[Data] = None
    second_offset: int = 0
    #: the estimate of the winner's memory-operator parameters
    #: (:func:`_estimated_operators`; None when the winner has none)
    operator_params: Optional[dict] = None

    @property
    def effects(self) -> List[str]:
        """The named effects (the class of the candidate that won the test)."""
        return list(self.verdict.named)

    @property
    def changes(self) -> Tuple[str, ...]:
        w = self.verdict.winner
        return (w.structure.changes,) if w is not None else ()

    def to_dict(self) -> dict:
        return {"findings": [f.to_dict() for f in self.findings],
                "baseline": self.baseline.to_dict(),
                "extended": self.extended.to_dict(self.changes),
                "gain": self.gain.to_dict(),
                "samples": self.split.to_dict(),
                "tests": [c.to_dict() for c in self.checks],
                "evidence": [f.to_dict() for f in self.evidence_findings],
                "verdict": self.verdict.to_dict(),
                "separation": self.separation,
                "operator_params": self.operator_params,
                "settings": self.settings}

    def recommended_model(self, command: str = "") -> Model:
        """The recommended model (:attr:`Gain.recommended`), a copy whose
        ``meta['diagnose']`` says which one it is, why, and the gain.

        Parameters
        ----------
        command : str
            The command line that produced the diagnosis (stored in the meta).
        """
        which = self.gain.recommended
        chosen = self.extended if which == "extended" else self.baseline
        g = self.gain
        w = self.verdict.winner
        if which == "extended":
            why = (f"the extension ({w.structure.name}) beat the baseline in free run on the "
                   f"selection samples (p {number_text(w.p_value)} <= {self.verdict.level:g}); "
                   f"on the measuring samples its RMSE is {number_text(g.extended)} against "
                   f"the baseline's {number_text(g.baseline)} (gain {number_text(g.ratio)}x)")
        else:
            why = ("no candidate extension beat the baseline significantly on the selection "
                   "samples, so the baseline was not changed")
        m = Model(chosen.model.term_texts, theta=np.array(chosen.model.theta, dtype=float),
                  inputs=chosen.model.inputs, output=chosen.model.output,
                  registry=chosen.model.registry)
        m.meta.update({k: v for k, v in chosen.model.meta.items()})
        m.meta["diagnose"] = {"recommended": which, "why": why, "source": chosen.source,
                              "effects": self.effects, "gain": g.to_dict(),
                              "samples": self.split.to_dict(), "command": command}
        return m

    def summary(self) -> str:
        from .report import terminal_summary
        return terminal_summary(self)


def _check_records(train: Data, validation: Optional[Data], model: Optional[Model]):
    train.require_output("diagnose")
    if validation is not None:
        validation.require_output("diagnose")
        if tuple(validation.inputs) != tuple(train.inputs) or validation.output != train.output:
            raise DataError(f"the validation record has signals {list(validation.inputs)} -> "
                            f"{validation.output}, the training record "
                            f"{list(train.inputs)} -> {train.output}")
    if model is not None:
        if model.theta is None:
            raise ValueError("the model has no parameters (theta)")
        if tuple(model.inputs) != tuple(train.inputs) or model.output != train.output:
            raise DataError(f"the model's signals {list(model.inputs)} -> {model.output} do "
                            f"not match the data's {list(train.inputs)} -> {train.output}")
    for name in train.inputs:
        if np.ptp(train.input(name)) == 0:
            raise DataError(f"input {name!r} is constant in the training record: nothing can "
                            f"be diagnosed")


#: share of the samples before the measuring ones that tests and selects the
#: candidates (the rest, before it, fits them)
SELECT = 0.3
#: the validation record's rest after its head (:func:`validation_blocks`)
#: is cut into twice this many blocks that measure and select in turn
MEASURE_BLOCKS = 3


def validation_blocks(n: int) -> Tuple[Tuple[Tuple[int, int], ...], Tuple[Tuple[int, int], ...]]:
    r"""``(selection blocks, measuring blocks)`` of a validation record of
    ``n`` samples, each block ``(start, stop)``.

    The head, the first :math:`\lceil h n\rceil` samples (h =
    :data:`narx.simulation.simulate.HISTORY_HEAD`, the samples that choose
    where the memory operators start), selects; the rest is cut into
    2 :data:`MEASURE_BLOCKS` equal blocks that measure and select in turn,
    a measuring block first. Selection and measurement so see the same
    conditions wherever the record changes them along its length (a chirp's
    frequency, the amplitudes of a sweep): with the head selecting and the
    tail measuring, on development draws (zoo seeds 0-749 and 850-999) five
    of the eight extensions worse than the baseline out of sample were on
    chirps, chosen on the low frequencies of the head and measured on the
    high frequencies of the tail, where the baseline's error was 20 to 60
    times smaller. A record too short to give each block
    :data:`~.candidates.MIN_SELECT` samples measures whole: ``((), ((0, n),))``.
    """
    from narx.simulation.simulate import HISTORY_HEAD
    head = int(np.ceil(HISTORY_HEAD * n))
    edges = [int(round(x)) for x in np.linspace(head, n, 2 * MEASURE_BLOCKS + 1)]
    blocks = list(zip(edges[:-1], edges[1:]))
    if head < MIN_SELECT or min(b - a for a, b in blocks) < MIN_SELECT:
        return (), ((0, n),)
    return ((0, head),) + tuple(blocks[1::2]), tuple(blocks[0::2])


def block_mask(n: int, blocks, start: int = 0) -> np.ndarray:
    """Boolean mask of ``n`` samples, True on the ``blocks`` (``(start,
    stop)`` pairs) from sample ``start`` on."""
    m = np.zeros(n, dtype=bool)
    for a, b in blocks:
        m[max(a, start):b] = True
    return m


def _split(train: Data, validation: Optional[Data], holdout: float, names):
    """``(fit, measure, n_fit, n_select_stop, validation blocks, fit range,
    measure range)``: the training record is cut into fit (head) and
    selection (tail, :data:`SELECT`) samples; a validation record is cut
    into selection and measuring blocks (:func:`validation_blocks`, a pair
    of tuples; the measure range spans the measuring blocks, from the
    first one's start to the record's end); without one, the last
    ``holdout`` of the training record measures, the samples before are
    cut the same way and the blocks are ``((), ((n_pre, n),))``."""
    if validation is None and not 0.0 < holdout < 1.0:
        raise ValueError(f"holdout must be a fraction in (0, 1), got {holdout!r}")
    n_pre = train.n if validation is not None else int(round(train.n * (1.0 - holdout)))
    n_fit = int(round(n_pre * (1.0 - SELECT)))
    if n_fit < MIN_FIT or n_pre - n_fit < MIN_SELECT or (validation is None
                                                         and train.n - n_pre < MIN_SELECT):
        need = f"{MIN_FIT} to fit, {MIN_SELECT} to select" + (
            "" if validation is not None else f" and {MIN_SELECT} to measure")
        raise DataError(f"{names[0]}: {train.n} samples are too few to split (need at least "
                        f"{need})" + ("" if validation is not None else "; give --validation"))
    fit = slice_data(train, 0, n_fit)
    if validation is not None:
        blocks = validation_blocks(validation.n)
        v = blocks[1][0][0]
        return (fit, slice_data(validation, v, validation.n), n_fit, n_pre, blocks,
                (names[0], (0, n_fit)), (names[1], (v, validation.n)))
    return (fit, slice_data(train, n_pre, train.n), n_fit, n_pre, ((), ((n_pre, train.n),)),
            (names[0], (0, n_fit)), (names[0], (n_pre, train.n)))


def _errors(model: Optional[Model], record: Data, first: int, start: int,
            stop: int, history: Optional[str] = None) -> np.ndarray:
    """Free-run errors y − ŷ of ``model`` on samples ``first + start`` ..
    ``stop - 1`` of ``record``, the free run started at the record's first
    sample and run over all of it, so that ``history`` is estimated on the
    same samples wherever the record is scored
    (:func:`~.simulation.freerun_after`: every state of the model at
    ``first``, the memory operators of the output included, is its own;
    started there from the measured outputs, on development draws with
    hysteresis inside the feedback, the selection RMSE of the true
    structure was 1.8 to 1.9 times that of the same model run from the
    start); all ``inf`` when it diverges or there is no model. ``history``
    starts the memory operators of a record that may begin in motion
    (``'estimate'``); default the record's own, at rest. The contiguous
    case of :func:`_masked_errors`."""
    return _masked_errors(model, record, block_mask(record.n, [(first + start, stop)]), history)


def _masked_errors(model: Optional[Model], record: Data, mask: np.ndarray,
                   history: Optional[str]) -> np.ndarray:
    """Free-run errors y − ŷ of ``model`` on the samples of ``record`` where
    ``mask`` is True, the free run started at the record's first sample
    (:func:`~.simulation.freerun_after`); all ``inf`` when it diverges or
    there is no model."""
    n = int(np.count_nonzero(mask))
    if model is None:
        return np.full(n, np.inf)
    r = freerun_after(model, record, 0, history)
    e = (r.y - r.y_hat)[mask]
    if r.diverged or not np.all(np.isfinite(e)):
        return np.full(n, np.inf)
    return e


def _selection_errors(model: Optional[Model], pre: Data, n_fit: int,
                      validation: Optional[Data], vsel, start: int) -> np.ndarray:
    """The free-run errors of ``model`` on the selection samples: the
    training record's samples ``n_fit + start`` .. end of ``pre``
    (:func:`_errors`), then, when the validation record has selection
    blocks ``vsel`` (:func:`validation_blocks`), its samples in them from
    ``start`` on (its own free run from its first sample, the memory
    operators started from the history that fits its first samples best:
    a validation record may begin in motion, and at rest a play would
    start a loop's width away from its state).

    Why the validation record selects too: the training record's tail
    comes from the same experiment as the fitting samples, and where that
    experiment traces the loop at one amplitude, one rate or one kind of
    input, a lag or a memoryless term mimics the memory there and every
    candidate ties with the baseline; the validation record is the user's
    other experiment (other amplitudes, rates, holds), the conditions
    under which memory and dynamics part. On development draws (zoo seeds
    350-549) 9 of the 14 identifiable hysteretic draws left unnamed had
    every candidate within the noise of the baseline on the training tail
    (p-values near 1), while a memory candidate beat it by 1.2 to 11 times
    on the validation record; and 4 of the 5 extensions worse than the
    baseline out of sample had won on the training tail and lost on the
    validation record.
    The gain is then measured on the validation record's other blocks
    only, so it stays out of sample."""
    e = _errors(model, pre, n_fit, start, pre.n,
                None if model is None else model.meta.get("history"))
    if validation is None or not vsel:
        return e
    return np.concatenate([e, _masked_errors(model, validation,
                                             block_mask(validation.n, vsel, start),
                                             "estimate")])


#: most moved operators the summary line lists (the JSON has them all)
SHOWN_MOVES = 3


def _estimated_operators(winner, fit: Data, base: Model, held, selection_rmse):
    """``(model, note)``: the extension, with its memory operators'
    parameters estimated (:func:`~.candidates.estimate_operators`, on
    the fitting samples) when that lowers its free-run RMSE on the
    selection samples (``selection_rmse(model)``) and it may still be the
    extension (:func:`~.candidates.why_barred`); else the winner's model
    as tested. The two are estimates of one structure, so the lower
    selection error decides with no margin, as for the θ of the
    candidates (:func:`~.candidates.fit_structure`) and the
    ``operator_params`` choice of ``mggp fit``. The test and the named
    effect are the grid model's; the measuring samples take no part.
    ``note`` is None when the winner has no operator with a parameter,
    else a dict: ``kept``, ``moved`` (old → new operator), the selection
    RMSE with the grid's and with the estimated parameters, ``words``."""
    r = estimate_operators(winner.model, fit)
    if r is None:
        return winner.model, None
    grid, est = float(winner.selection_rmse), selection_rmse(r.model)
    barred = why_barred(r.model, base, fit, held)
    kept = bool(est < grid and barred is None)
    pairs = [f"{k} -> {v}" for k, v in r.moved.items()]
    moved = ", ".join(pairs[:SHOWN_MOVES]) + (f" and {len(pairs) - SHOWN_MOVES} more"
                                              if len(pairs) > SHOWN_MOVES else "")
    words = (f"operator parameters estimated by free-run error ({moved}): selection RMSE "
             f"{number_text(est)} against {number_text(grid)} on the grid")
    if not kept:
        words = (f"the grid's operator parameters kept: with them estimated by free-run "
                 f"error ({moved}) the model " + (
                     barred if barred is not None else
                     f"simulates the selection samples at RMSE {number_text(est)} against "
                     f"{number_text(grid)}"))
    note = {"kept": kept, "moved": dict(r.moved), "selection_rmse_grid": _num(grid),
            "selection_rmse_estimated": _num(est), "barred": barred, "words": words}
    return (r.model if kept else winner.model), note


def _score(model: Model, record: Data, first: int, mask: np.ndarray,
           history: Optional[str]) -> Tuple[float, float, np.ndarray]:
    """Free-run RMSE and MAPE of ``model`` on the samples of ``record``
    where ``mask`` is True, and its simulation from ``first`` on
    (:func:`~mggp.diagnose.simulation.freerun_after`: the free run starts
    at the record's first sample, as the selection samples' does, so that
    the states of the model, those of the memory operators of the output
    included, are its own; ``history`` starts its memory operators)."""
    r = freerun_after(model, record, 0, history)
    if r.diverged:
        return float("inf"), float("inf"), r.y_hat[first:]
    y, yh = r.y[mask], r.y_hat[mask]
    err = y - yh
    if not np.all(np.isfinite(err)):
        return float("inf"), float("inf"), r.y_hat[first:]
    return float(np.sqrt(np.mean(err * err))), mape(y, yh), r.y_hat[first:]


def outside_fit_range(fit: Data, measure: Data, start: int = 0,
                      mask: Optional[np.ndarray] = None) -> Dict[str, float]:
    """Share of the measuring samples (those of ``measure`` from ``start``
    on, or where ``mask`` is True) whose input lies outside the range the
    fitting samples span, per input: where it is not 0 the gain measures
    extrapolation too (a model is identified only on the range it was
    fitted on)."""
    out = {}
    for name in fit.inputs:
        v = measure.input(name)
        u, v = fit.input(name), (v[start:] if mask is None else v[mask])
        out[name] = float(np.mean((v < u.min()) | (v > u.max()))) if v.size else 0.0
    return out


def _reach_dead_time(fit: Data, budget: Budget, scans=None):
    """``(budget, said)``: the budget with its tree height raised to the
    least that reaches every input acting on the output only beyond the
    lags its height reaches (:func:`mggp.fit.choices.dead_time_height`, the
    rule of ``max_height='auto'``), and what was found in words (None: no
    such input). A baseline that cannot reach a dead time misses dynamics
    that no hysteresis term supplies, and the tests would name the wrong
    cause. A dead time beyond what :data:`mggp.gp.primitives.MAX_HEIGHT`
    reaches leaves the height. ``scans``: :func:`narx.records.deadtime.onset_scans`
    of ``fit`` when already computed."""
    from dataclasses import replace
    from narx.records.deadtime import late_words
    from ..fit.choices import dead_time_height
    h, late, reach = dead_time_height(fit, budget.max_height, scans=scans)
    if not late:
        return budget, None
    said = "; ".join(late_words(name, scan, reach) for name, scan in late)
    if h == budget.max_height:
        return budget, {"height": h, "why": said + ": beyond what the highest trees "
                        "reach; remove the dead time (shift the input)"}
    return replace(budget, max_height=h), {"height": h, "why": said}


def _one_blas_thread(f):
    """``f`` run with the BLAS on one thread (:func:`narx.linalg.one_blas_thread`:
    the diagnosis's solves are tall and narrow, and on a busy machine a
    second BLAS thread made the dead-time scan alone 20 times slower)."""
    @functools.wraps(f)
    def run(*args, **kwargs):
        from narx.linalg import one_blas_thread
        with one_blas_thread():
            return f(*args, **kwargs)
    return run


@_one_blas_thread
def diagnose(train: Data, validation: Optional[Data] = None, model: Optional[Model] = None,
             *, budget: Budget = Budget(), seed: int = 0, jobs: int = 1,
             holdout: float = 0.3, alpha: float = 0.01, level: float = 0.05,
             resolution: float = 0.005,
             names: Tuple[str, str] = ("train", "validation"), model_name: str = "model",
             progress: Optional[Callable[[str], None]] = None,
             search_callbacks: Optional[Callable[[int], list]] = None,
             outliers: str = "auto") -> Diagnosis:
    """Diagnose a model (or an MGGP baseline) on ``train``; see the module doc.

    Parameters
    ----------
    train, validation : narx.Data
        Records with the output; ``validation`` optional.
    model : narx.Model, optional
        The user's model (θ as given); default: MGGP, MS fitness, no Φ.
    budget : Budget
        Search effort and statistics' sample sizes.
    seed, jobs : int
        Seed of every random choice; worker processes of the searches.
    holdout : float
        Tail fraction measuring the gain when there is no validation record.
    alpha : float
        False-alarm probability of each residual test (the evidence).
    level : float
        Level α of the paired test that names an effect (family-wise over
        the candidates, by Holm's procedure; :mod:`.verdict`).
    resolution : float
        Smallest effect worth naming, as a fraction of the output's range.
    progress : callable, optional
        ``progress(message)`` at the start of each step.
    search_callbacks : callable, optional
        ``search_callbacks(generations)`` returns the per-generation
        callbacks of each MGGP search (e.g. the progress line of ``mggp fit``).
    outliers : {'auto', 'keep'}
        'auto': isolated glitches of each record's output and inputs are repaired
        first (:mod:`narx.records.outliers`, the rule of ``mggp fit``; listed in
        ``settings['outliers']`` and the summary); 'keep': every sample as
        measured.
    """
    say = progress or (lambda msg: None)
    if not 0.0 < alpha < 0.5:
        raise ValueError(f"alpha must be in (0, 0.5), got {alpha!r}")
    if not 0.0 < level < 0.5:
        raise ValueError(f"level must be in (0, 0.5), got {level!r}")
    if not 0.0 <= resolution < 1.0:
        raise ValueError(f"resolution must be in [0, 1), got {resolution!r}")
    _check_records(train, validation, model)
    if outliers not in ("auto", "keep"):
        raise ValueError(f"outliers must be 'auto' or 'keep', got {outliers!r}")
    glitches = {}
    if outliers == "auto":
        for label, rec in zip(names, (train, validation)):
            if rec is not None:
                glitches[label] = find_spikes(rec)
        train = repaired(train, glitches[names[0]])
        if validation is not None:
            validation = repaired(validation, glitches[names[1]])
    fit, measure, n_fit, n_pre, (vsel, mblocks), (fit_name, fit_rng), (meas_name, meas_rng) = _split(
        train, validation, holdout, names)
    rec_names = (fit_name, meas_name if validation is not None else f"{fit_name} (tail)")
    from narx.records.deadtime import onset_scans
    scans = onset_scans(fit)
    budget, dead_time = _reach_dead_time(fit, budget, scans)
    timings, t0 = {}, time.perf_counter()
    if model is None:
        say(f"baseline: MGGP search, MS fitness, no Φ (population {budget.population}, "
            f"{budget.generations} generations)")
        runs_on = [(names[0], train)] + ([(names[1], validation)] if validation is not None
                                         else [])
        base, base_setting = baseline_search(fit, budget, seed, jobs, search_callbacks, runs_on)
        base_source = "MGGP baseline (" + base_setting.describe() + ")"
        if base.meta.get("bounded", SEARCH_MODEL_KEPT) != SEARCH_MODEL_KEPT:
            base_source += "; " + base.meta["bounded"]
    else:
        base, base_setting = model, user_setting(model, budget)
        base_source = f"user model {model_name}"
    timings["baseline"] = time.perf_counter() - t0
    if measure.n <= base.max_lag + 10:
        raise DataError(f"{rec_names[1]}: {measure.n} samples are too few for the model's "
                        f"largest lag {base.max_lag}")
    say("evidence: " + ", ".join(t.name for t in registered()))
    t1 = time.perf_counter()
    # the evidence reads the holds of the whole second record (the validation
    # record, its selection head included: evidence explains, it does not decide)
    second, second_at = (measure, meas_rng[0]) if validation is None else (validation, 0)
    ctx = Context(base, fit, second, rec_names, second_at, budget, alpha, resolution, seed)
    ev = run_tests(ctx)
    checks = ev.checks
    evidence_findings = name_findings(checks)
    timings["evidence"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    structures = candidate_structures(base, fit, scans)
    say("candidates: " + ", ".join(st.name for st in structures))
    fitted = [(st, *fit_structure(st, fit, base.registry)) for st in structures]
    timings["candidates"] = time.perf_counter() - t2
    t3 = time.perf_counter()
    pre = train.slice(0, n_pre)
    s_start = max([base.max_lag] + [m.max_lag for _, m, _ in fitted if m is not None])
    if n_pre - n_fit <= s_start + 20:
        raise DataError(f"{rec_names[0]}: {n_pre - n_fit} selection samples are too few for "
                        f"models with largest lag {s_start}")
    if vsel and vsel[0][1] <= s_start + 20:
        vsel = ()
    e_base = _selection_errors(base, pre, n_fit, validation, vsel, s_start)
    cands = [(st, m, _selection_errors(m, pre, n_fit, validation, vsel, s_start), score)
             for st, m, score in fitted]
    # a candidate whose free run leaves the output's range on probe inputs
    # (:func:`~.candidates.stays_bounded`), or moves by itself while the
    # inputs of either record are held, cannot win (:func:`~.candidates.why_barred`)
    held = record_holds(train, validation, base.max_lag)
    bars = [why_barred(m, base, fit, held) for _, m, _ in fitted]
    eligible = [b is None for b in bars]
    floor = loss_floor(fit.y, resolution)
    segments = [n_pre - n_fit - s_start] + [b - max(a, s_start) for a, b in vsel
                                            if b > max(a, s_start)]
    # on a record that cannot separate memory from dynamics a memory winner
    # must win by a wider margin to be named (:func:`~.verdict.choose`)
    separation = separation_note(pre)
    vd = decide(e_base, cands, level, np.random.default_rng([int(seed), 29]), floor,
                eligible, segments=segments, bar_reasons=bars, separates=separation is None)
    timings["test"] = time.perf_counter() - t3
    winner = vd.winner
    ext_model = winner.model if winner is not None else base
    operators = None
    if winner is not None and winner.structure.constraints is None:
        ext_model, operators = _estimated_operators(
            winner, fit, base, held,
            lambda m: rmse_of(_selection_errors(m, pre, n_fit, validation, vsel, s_start)))
    estimated = bool(operators and operators["kept"])
    if winner is not None:
        say(f"verdict: {winner.effect if vd.named else 'effect not named'} "
            f"({winner.structure.name})")
        ext_model.meta.update({"source": "mggp diagnose extension",
                               "estimation": "cls" if winner.structure.constraints else (
                                   "ls+operators-freerun" if estimated else "ls"),
                               "changes": [winner.structure.changes]})
    start = max(base.max_lag, ext_model.max_lag)
    if measure.n <= start + 10:
        raise DataError(f"{rec_names[1]}: {measure.n} samples are too few to measure models "
                        f"with largest lag {start}")
    # the measuring samples are simulated by a free run from their record's
    # start (every state of the model its own there); a validation record
    # starts from its estimated history, as in the selection samples
    record, first, history = ((train, meas_rng[0], None) if validation is None
                              else (validation, meas_rng[0], "estimate"))
    split = Split(fit_name, fit_rng, meas_name, meas_rng,
                  first + start if validation is None else max(first, start),
                  (n_fit, n_pre), n_fit + s_start, tuple(vsel), s_start if vsel else 0,
                  tuple(mblocks))
    mask = split.measure_mask(record.n)
    b_rmse, b_mape, b_hat = _score(base, record, first, mask, history)
    e_rmse, e_mape, e_hat = _score(ext_model, record, first, mask,
                                   history or ext_model.meta.get("history"))
    ext_source = ("the baseline (no candidate won the test, nothing changed)" if winner is None
                  else f"{winner.structure.name}: {winner.structure.changes}"
                  + (f"; {operators['words']}" if estimated else ""))
    findings = [Finding(t.effect, f"{t.structure.name}: {t.structure.changes}; free-run RMSE "
                        f"on the selection samples {number_text(vd.baseline_rmse)} (baseline) "
                        f"-> {number_text(t.selection_rmse)}, one-sided p-value "
                        f"{number_text(t.p_value)} (paired block bootstrap of the log-loss differences, "
                        f"Holm) <= level "
                        f"{level:g}", t.p_value, level) for t in ([winner] if vd.named else [])]
    settings = {"seed": int(seed), "jobs": int(jobs), "alpha": alpha, "level": level,
                "user_model": model is not None,
                "resolution": resolution, "holdout": None if validation is not None
                else holdout, "select": SELECT, "budget": dict(budget.__dict__),
                "baseline": base_source,
                "measure_outside_fit_range": outside_fit_range(fit, record, mask=mask),
                "dead_time": dead_time,
                "outliers": {label: [sp.to_dict() for sp in found]
                             for label, found in glitches.items()} if outliers == "auto"
                else "keep"}
    timings["total"] = time.perf_counter() - t0
    return Diagnosis(findings, checks, ev,
                     Scored(base, base_source, b_rmse, b_mape, b_hat),
                     Scored(ext_model, ext_source, e_rmse, e_mape, e_hat), vd,
                     Gain(b_rmse, e_rmse, won=winner is not None), split, fit, measure,
                     ctx.measure_holds, rec_names, settings, timings, evidence_findings,
                     separation, second, second_at, operators)
