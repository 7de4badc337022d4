"""The zoo study: ``mggp diagnose`` on draws of :mod:`narx.systems.zoo`, against an oracle.

Run::

    python -m benchmarks.zoo evaluate --seeds 1000-1149 --json zoo.jsonl --jobs 2
    python -m benchmarks.zoo table zoo.jsonl --figure zoo_power.png
    python -m benchmarks.zoo show 7
    python -m benchmarks.zoo calibrate --seeds 0-99 --json dev.jsonl    # tuning: dev seeds only
    python -m benchmarks.zoo ablate --seeds 0-149 --json ablate.jsonl   # each check's effect
    python -m benchmarks.zoo replay dev.jsonl --shares 0 0.1 0.2        # the naming margin
    python -m benchmarks.zoo replay dev.jsonl --shares 0.15 --part-shares 0 0.8 0.85 0.9

For each draw (4,000 training samples, the validation record of the draw),
``evaluate`` runs :func:`mggp.diagnose.diagnose` at the **study budget**
(:data:`STUDY_BUDGET`: population 100, 20 generations, everything else
the :class:`~mggp.diagnose.Budget` defaults, so the statistics are the
product's; see the measurement below) and the
:func:`oracle`, and appends one JSON line per draw to the file as it
finishes (a killed run keeps its records; a new run skips the seeds
already there). Fields: ``seed, split, family, hysteretic, placement,
input_kind, validation_kind, snr_db, colour, n, exact, identifiable,
oracle_gain, oracle_rmse, oracle_method, baseline_rmse, extended_rmse,
named, gain, recommended, p_values, winner, candidates,
baseline_selection_rmse, resolution_floor, diagnose_seconds, seconds`` (``error``
instead of the diagnosis fields when it failed, ``oracle_error`` when the
oracle did; ``seconds`` counts the draw, the oracle and the diagnosis).

**Oracle.** The truth's terms (:attr:`narx.systems.zoo.Draw.truth`) are
fitted on the first 75 % of the training record by least squares and by
simulation-error θ (:func:`narx.refine` in free run, from the LS θ); the
one with the smaller free-run RMSE on the last 25 % (the memory operators
carrying their state from the samples before) is chosen, then *refitted on
every training sample* by the same method, and its free-run RMSE on the
validation record is the oracle's error — on the samples the diagnosis
measures its gain on (the validation record's measuring blocks,
:func:`mggp.diagnose.run.validation_blocks`, in one free run over the
whole record;
``oracle_rmse_whole`` keeps the error on the whole record). ``oracle_gain`` = the RMSE of the
best model without memory at the study budget (the diagnosis's baseline:
MGGP, multiple-shooting fitness, no Φ, no operators; its validation RMSE
from the diagnosis, or :func:`baseline_rmse` standalone) / the oracle's.
A hysteretic draw is *identifiable* when ``oracle_gain >= 1.5``: knowing
the structure buys at least that much, so a diagnosis could.

**Study budget.** Population 100 and 20 generations make the baseline
search a small share of a diagnosis: on the 150 evaluation draws 1150-1299
(4,000 samples, ``--jobs 2`` on 2 cores) one diagnosis took 3.8 s in
median, 6.2 s at the 90th percentile and at most 9.3 s, besides the run's
first draw (61 s, the numba kernels compiling). The default budget
(population 500, 100 generations) spends most of its time in the search:
47 s of the 57 s that the measured piezo record's diagnosis takes
on one job.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
import warnings
from dataclasses import dataclass
from typing import Dict, Iterable, List, Optional, Tuple

import numpy as np

from mggp.fit.params import DIAGNOSE_PARAMS

#: the study budget of :func:`evaluate` (the rest: Budget defaults)
STUDY_BUDGET = {"population": 100, "generations": 20}
#: samples of each training record in the study
STUDY_N = 4000
#: oracle_gain from which a hysteretic draw is identifiable
IDENTIFIABLE = 1.5
#: the tail of the training record that chooses the oracle's method
ORACLE_HOLDOUT = 0.25
#: the level of the diagnosis's paired test (``mggp diagnose --level``'s
#: default), marked on the figure
ALPHA = DIAGNOSE_PARAMS["level"].default

__all__ = ["Oracle", "oracle", "oracle_gain", "baseline_rmse", "evaluate", "records",
           "table", "parse_seeds", "calibrate", "STUDY_BUDGET", "IDENTIFIABLE"]


# ------------------------------------------------------------------ oracle
@dataclass(frozen=True)
class Oracle:
    """The truth's terms fitted by the better of LS and simulation-error θ.

    Attributes
    ----------
    method : {'ls', 'freerun'}
        The method chosen on the training tail.
    holdout_rmse : dict
        Free-run RMSE on the last 25 % of the training record of each
        method fitted on the first 75 %.
    rmse : float
        Free-run RMSE on the validation record of the chosen method refitted
        on all training samples (``inf``: diverged).
    model : narx.Model
        That refitted model.
    """

    method: str
    holdout_rmse: Dict[str, float]
    rmse: float
    model: object

    def to_dict(self) -> dict:
        return {"method": self.method, "holdout_rmse": dict(self.holdout_rmse),
                "rmse": self.rmse, "terms": self.model.term_texts,
                "theta": [float(v) for v in self.model.theta]}


def _freerun_error(model, record, first: int = 0, history="estimate") -> float:
    """Free-run RMSE on ``record`` from ``first``, the free run started at
    the record's first sample (:func:`mggp.diagnose.simulation.freerun_after`,
    as the diagnosis measures its gain; ``history``: its memory operators'
    start, estimated on a validation record, None at rest for the training
    record as the fit assumes), scored after the model's largest lag."""
    from mggp.diagnose.simulation import freerun_after
    with np.errstate(all="ignore"):
        r = freerun_after(model, record, first, history)
        if r.diverged:
            return math.inf
        e = (r.y - r.y_hat)[r.valid]
    return float(np.sqrt(np.mean(e * e))) if e.size and np.all(np.isfinite(e)) else math.inf


def _fit(terms, data, method: str):
    import narx
    from narx.model import ignore_rank_warnings
    with ignore_rank_warnings(), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = narx.Model(list(terms)).fit(data)
        if method == "freerun":
            model = narx.refine(model, data, mode="freerun").model
    return model


def oracle(draw, holdout: float = ORACLE_HOLDOUT) -> Oracle:
    """Fit the truth of ``draw`` (see the module doc) and score it.

    Parameters
    ----------
    draw : narx.systems.zoo.Draw
        With a validation record.
    holdout : float
        Tail of the training record that chooses the method, in (0, 0.5].
    """
    from mggp.diagnose.run import slice_data
    if draw.validation is None:
        raise ValueError("draw must have a validation record (zoo.draw(..., validation=True))")
    if not 0.0 < holdout <= 0.5:
        raise ValueError(f"holdout must be in (0, 0.5], got {holdout!r}")
    train, terms = draw.train, draw.truth.terms
    cut = int(round(train.n * (1.0 - holdout)))
    head = slice_data(train, 0, cut)
    scores = {m: _freerun_error(_fit(terms, head, m), train, cut, None) for m in ("ls", "freerun")}
    method = min(scores, key=lambda m: (scores[m], m != "ls"))
    model = _fit(terms, train, method)
    return Oracle(method, scores, _freerun_error(model, draw.validation), model)


def oracle_gain(baseline: float, truth: float) -> float:
    """``baseline / truth`` validation RMSE: inf for a perfect truth, 0 when
    only the truth diverges, NaN when both do."""
    if not math.isfinite(truth):
        return math.nan if not math.isfinite(baseline) else 0.0
    if truth == 0:
        return math.inf
    return baseline / truth


def baseline_rmse(draw, population: int = STUDY_BUDGET["population"],
                  generations: int = STUDY_BUDGET["generations"], seed: int = 0,
                  jobs: int = 1) -> float:
    """Validation free-run RMSE of the best model without memory at a budget,
    searched standalone: the diagnosis's baseline
    (:func:`mggp.diagnose.extend.baseline_search`: MGGP, multiple-shooting
    fitness, no Φ, no operators) on the training record."""
    from mggp.diagnose import Budget
    from mggp.diagnose.extend import baseline_search
    model, _ = baseline_search(draw.train, Budget(population=population,
                                                  generations=generations), seed, jobs)
    return _freerun_error(model, draw.validation)


# ------------------------------------------------------------------ evaluate
def parse_seeds(tokens: Iterable[str]) -> List[int]:
    """``['3', '10-12']`` -> ``[3, 10, 11, 12]`` (ranges inclusive, order kept)."""
    out = []
    for tok in tokens:
        a, sep, b = str(tok).partition("-")
        try:
            lo, hi = int(a), int(b) if sep else int(a)
        except ValueError:
            raise ValueError(f"--seeds takes integers or ranges A-B, got {tok!r}") from None
        if lo < 0 or hi < lo:
            raise ValueError(f"--seeds ranges need 0 <= A <= B, got {tok!r}")
        out.extend(s for s in range(lo, hi + 1) if s not in out)
    return out


def _num(x):
    return None if x is None or not math.isfinite(x) else float(x)


def _winner(dx) -> Optional[dict]:
    """The winning candidate: its name, effect and selection-sample gain
    (baseline / candidate free-run RMSE there; None when the baseline diverges)."""
    w = dx.verdict.winner
    if w is None:
        return None
    b, e = float(dx.verdict.baseline_rmse), float(w.selection_rmse)
    return {"name": w.structure.name, "effect": w.effect, "p_value": _num(w.p_value),
            "selection_gain": _num(b / e) if e > 0 else None}


def evaluate_one(seed: int, population: int, generations: int, jobs: int) -> dict:
    """Diagnose the draw of ``seed`` at the budget and score it (one record)."""
    from mggp.diagnose import Budget, diagnose
    from mggp.diagnose.verdict import loss_floor
    from narx.systems import zoo
    t0 = time.perf_counter()
    d = zoo.draw(seed, n=STUDY_N)
    rec = {"seed": seed, "split": d.split, "family": d.family, "hysteretic": d.hysteretic,
           "placement": d.placement, "input_kind": d.input_kind,
           "validation_kind": d.params["validation_input"]["kind"],
           "snr_db": d.noise["snr_db"], "colour": d.noise["colour"], "n": d.train.n,
           "exact": d.truth.exact}
    try:
        orc = oracle(d)
    except Exception as exc:               # recorded: the draw still measures diagnose
        orc = Oracle("failed", {}, math.nan, None)
        rec["oracle_error"] = f"{type(exc).__name__}: {exc}"
    rec.update(oracle_rmse=_num(orc.rmse), oracle_method=orc.method)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            dx = diagnose(d.train, validation=d.validation,
                          budget=Budget(population=population, generations=generations),
                          seed=seed, jobs=jobs)
    except Exception as exc:               # a failure is a finding of the study
        rec.update(error=f"{type(exc).__name__}: {exc}",
                   seconds=time.perf_counter() - t0)
        return rec
    doc = dx.to_dict()
    base = doc["baseline"]["validation"]["rmse"]
    base = math.inf if base is None else float(base)
    if dx.split.measure[0] and orc.model is not None:  # scored where the diagnosis measures
        rec.update(oracle_rmse_whole=rec["oracle_rmse"],
                   oracle_rmse=_measured(orc.model, dx, d.validation)[0])
    o_rmse = math.nan if rec["oracle_rmse"] is None else float(rec["oracle_rmse"])
    og = oracle_gain(base, o_rmse)
    rec.update(baseline_rmse=_num(base),
               extended_rmse=_num(doc["extended"]["validation"]["rmse"]),
               oracle_gain=_num(og), identifiable=bool(og >= IDENTIFIABLE),  # NaN: False
               named=list(dx.effects), gain=_num(dx.gain.ratio),
               recommended=dx.gain.recommended,
               p_values=doc.get("verdict", {}).get("p_values", {}),
               separates=dx.separation is None, winner=_winner(dx),
               operator_params=_operator_params(dx, d.validation),
               candidates=_candidates(dx, d.train, d.validation),
               baseline_part_rmse=[_num(v) for v in dx.verdict.baseline_part_rmse],
               baseline_measure_block_rmse=_measured(dx.baseline.model, dx, d.validation)[1],
               baseline_selection_rmse=_num(dx.verdict.baseline_rmse),
               resolution_floor=_num(loss_floor(dx.fit_data.y, dx.settings["resolution"])),
               diagnose_seconds=float(dx.timings.get("total", math.nan)),
               seconds=time.perf_counter() - t0)
    return rec


def _operator_params(dx, validation) -> Optional[dict]:
    """The estimate of the winner's operator parameters
    (:func:`mggp.diagnose.run._estimated_operators`): whether it was kept,
    the selection RMSE with the grid's and the estimated parameters, and
    the grid model's RMSE on the measuring samples (``grid_rmse``, beside
    ``extended_rmse``; None when the winner has no operator)."""
    note = dx.operator_params
    if note is None:
        return None
    return {"kept": note["kept"], "barred": note["barred"],
            "selection_rmse_grid": note["selection_rmse_grid"],
            "selection_rmse_estimated": note["selection_rmse_estimated"],
            "grid_rmse": _measured(dx.verdict.winner.model, dx, validation)[0]}


def _candidates(dx, train, validation) -> List[dict]:
    """Each tested candidate's effect, selection RMSE (whole and per part),
    adjusted p-values, whether it may win, and its free-run RMSE on the
    measuring samples (whole and per block; None: not fitted or
    diverged): what :func:`replay` needs to rename the draw under another
    naming rule without running it again."""
    from mggp.diagnose.holds import record_holds, self_motion
    out = []
    held = record_holds(train, validation, dx.baseline.model.max_lag)
    span = float(np.ptp(dx.fit_data.y)) or 1.0
    for t in dx.verdict.tested:
        meas, blocks = _measured(t.model, dx, validation)
        out.append({"name": t.structure.name, "effect": t.effect,
                    "selection_rmse": _num(t.selection_rmse), "p": _num(t.p_adjusted),
                    "fitted": t.model is not None,
                    "eligible": t.structure.name not in dx.verdict.barred,
                    "part_rmse": [_num(v) for v in t.part_rmse],
                    "measure_rmse": meas, "measure_block_rmse": blocks,
                    "bar_reason": (dx.verdict.bar_reason(t.structure.name)
                                   if t.structure.name in dx.verdict.barred else None),
                    "hold_motion": _num(self_motion(t.model, dx.baseline.model, held) / span)})
    return out


def _measured(model, dx, validation) -> Tuple[Optional[float], List[Optional[float]]]:
    """Free-run RMSE of ``model`` on the diagnosis's measuring samples of
    ``validation``, whole and per measuring block (None: no model, or it
    diverged there), from one free run over the record (as
    :func:`mggp.diagnose.run._score` scores them)."""
    from mggp.diagnose.run import block_mask
    from mggp.diagnose.simulation import freerun_after
    if model is None:
        return None, []
    sp = dx.split
    r = freerun_after(model, validation, 0, "estimate")
    e = np.full(validation.n, np.inf) if r.diverged else r.y - r.y_hat

    def rmse(mask) -> Optional[float]:
        x = e[mask]
        return _num(float(np.sqrt(np.mean(x * x)))) if np.all(np.isfinite(x)) else None
    return (rmse(sp.measure_mask(validation.n)),
            [rmse(block_mask(validation.n, [b], sp.scored_from)) for b in sp.blocks])


def replay(recs: List[dict], shares, part_shares=None, carry=(False,),
           hold_motions=(None,), rest_margins=None,
           unseparated_shares=None, part_floors=None) -> str:
    """The headline rates of ``recs`` (records with ``candidates``) renamed
    by :func:`mggp.diagnose.verdict.choose` for each memory share ρ of
    :func:`~mggp.diagnose.verdict.worth_naming` and each share s of
    :func:`~mggp.diagnose.verdict.holds_up` (default: the code's), with
    and without its clause on one part carrying the gain (``carry``), and
    for each hold-motion
    threshold (``hold_motions``, shares of the output's range; None: the
    eligibility as recorded; :data:`~mggp.diagnose.candidates.HOLD_MOTION`)
    and each margin m of the part rule (``rest_margins``; default the
    code's :data:`~mggp.diagnose.verdict.REST_MARGIN`) and each share ρ₁
    of :func:`~mggp.diagnose.verdict.separated_worth` on records that
    cannot separate memory from dynamics (``unseparated_shares``; default
    the code's :data:`~mggp.diagnose.verdict.UNSEPARATED_SHARE`), and with
    and without the parts' RMSEs floored at the resolution (``part_floors``;
    default the code's :data:`~mggp.diagnose.verdict.PART_FLOOR`),
    in a Markdown table: how the study chose
    :data:`~mggp.diagnose.verdict.MEMORY_SHARE` and
    :data:`~mggp.diagnose.verdict.PART_SHARE` on development draws
    (records without per-part RMSEs replay without the part rule)."""
    from mggp.diagnose.candidates import MEMORY
    from mggp.diagnose.run import Gain
    from mggp.diagnose.verdict import PART_FLOOR, PART_SHARE, REST_MARGIN, UNSEPARATED_SHARE
    level = ALPHA
    recs = [r for r in recs if "candidates" in r]
    if not recs:
        raise ValueError("no records with a candidates table (run evaluate on this code)")
    rows = ["| memory share ρ | part share s | one part may carry | "
            "hold motion | margin without the best part | ρ₁ (records that cannot separate) | "
            "parts floored | named / identifiable | false alarms | gain ≥ 1.5 | gain < 0.95 |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    ident = [r for r in recs if r["hysteretic"] and r["identifiable"]]
    ctrl = [r for r in recs if not r["hysteretic"]]
    for share, part, one, hm, mg, us, pf in (
            (a, b, c, h, g, n, fl) for a in shares for b in (part_shares or [PART_SHARE])
            for c in carry for h in hold_motions
            for g in (rest_margins or [REST_MARGIN])
            for n in (unseparated_shares or [UNSEPARATED_SHARE])
            for fl in (part_floors or [PART_FLOOR])):
        named, gains = {}, {}
        for r in recs:
            cs = r["candidates"]
            tested = _tested(r)
            eff, w = _choose(r, tested, level, hm, share=share, part_share=part, carry=one,
                             rest_margin=mg, unseparated_share=us, part_floor=pf)
            named[r["seed"]] = eff
            gains[r["seed"]] = 1.0 if w is None else Gain(
                _inf(r["baseline_rmse"]), _inf(cs[tested.index(w)]["measure_rmse"])).ratio
        h = lambda r: MEMORY in named[r["seed"]]                  # noqa: E731
        rows.append(f"| {share:g} | {part:g} | {'yes' if one else 'no'} | "
                    f"{'as run' if hm is None else f'{hm:g}'} | "
                    f"{mg:g} | {us:g} | {'yes' if pf else 'no'} | "
                    f"{_rate(sum(map(h, ident)), len(ident))} | "
                    f"{_rate(sum(map(h, ctrl)), len(ctrl))} | "
                    f"{_rate(sum(gains[r['seed']] >= 1.5 for r in ident), len(ident))} | "
                    f"{_rate(sum(gains[r['seed']] < 0.95 for r in recs), len(recs))} |")
    return (f"{len(recs)} draws, seeds {min(r['seed'] for r in recs)}–"
            f"{max(r['seed'] for r in recs)}; level {level:g}.\n\n" + "\n".join(rows) + "\n")


def _inf(v) -> float:
    """A recorded number; None (not finite when recorded) as inf."""
    return math.inf if v is None else float(v)


def _tested(r: dict) -> list:
    """The recorded candidates of ``r`` as :class:`~mggp.diagnose.verdict.Tested`
    (model: the name, or None when not fitted). A record of a code that
    also tested memory candidates against the best memory-free one
    (``p_free``) is renamed without that test."""
    from mggp.diagnose.candidates import Structure
    from mggp.diagnose.verdict import Tested
    return [Tested(Structure(c["effect"], c["name"], "", (), ()),
                   c["name"] if c["fitted"] else None, _inf(c["selection_rmse"]), None,
                   _inf(c["p"]), tuple(map(_inf, c.get("part_rmse", ()))))
            for c in r["candidates"]]


def _choose(r: dict, tested: list, alpha: float, hold_motion: Optional[float] = None,
            **rule):
    """:func:`mggp.diagnose.verdict.choose` on the record ``r`` (its
    candidates ``tested`` by :func:`_tested`) at level ``alpha``, each
    candidate's eligibility by :func:`_eligible` at ``hold_motion``, and
    ``rule`` the keyword parameters of the rule that differ from the
    code's (``share``, ``part_share``, ...)."""
    from mggp.diagnose.verdict import choose
    return choose(tested, _inf(r["baseline_selection_rmse"]), alpha, r["resolution_floor"],
                  [_eligible(c, hold_motion) for c in r["candidates"]],
                  base_parts=tuple(map(_inf, r.get("baseline_part_rmse", ()))),
                  separates=bool(r.get("separates", True)), **rule)


def naming_level(r: dict) -> float:
    """The smallest test level α at which the naming rule of the code
    (:func:`mggp.diagnose.verdict.choose`, every other condition as the
    code has it) names hysteresis on the record ``r`` — NaN when it names
    it at no level; for a record without a candidates table, the p-value
    of hysteresis it recorded. Naming can only start as α grows (a larger
    α admits more memory candidates), so the record is named at α exactly
    when α is at least this level."""
    from mggp.diagnose.candidates import MEMORY
    if "candidates" not in r:
        p = (r.get("p_values") or {}).get("hysteresis")
        return math.nan if p is None else float(p)
    tested = _tested(r)
    for a in sorted({t.p_value for t in tested if t.effect == MEMORY
                     and math.isfinite(t.p_value)}):
        named, _ = _choose(r, tested, a)
        if MEMORY in named:
            return float(a)
    return math.nan


def _eligible(c: dict, hold_motion: Optional[float]) -> bool:
    """Whether the recorded candidate ``c`` may win with the hold-motion
    threshold ``hold_motion`` (None: as recorded): not barred for leaving
    the range, and its recorded hold motion within the threshold."""
    from mggp.diagnose.candidates import BAR_RANGE
    if hold_motion is None or "hold_motion" not in c:
        return bool(c["eligible"])
    motion = math.inf if c["hold_motion"] is None else float(c["hold_motion"])
    return c.get("bar_reason") != BAR_RANGE and motion <= hold_motion


def records(path) -> List[dict]:
    """The records of a JSON-lines file (a torn last line is left out)."""
    if not os.path.exists(path):
        return []
    out = []
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            try:
                out.append(json.loads(line))
            except json.JSONDecodeError:
                continue
    return out


def evaluate(seeds, path, population=STUDY_BUDGET["population"],
             generations=STUDY_BUDGET["generations"], jobs=1, say=print) -> List[dict]:
    """Evaluate each seed not yet in ``path``, appending its record there."""
    return resume(seeds, path, lambda seed: evaluate_one(seed, population, generations, jobs),
                  lambda rec: say(f"seed {rec['seed']}: {rec['family']} ({rec['placement']}), "
                                  f"named {rec.get('named', rec.get('error'))}, gain "
                                  f"{rec.get('gain')}, oracle gain {rec.get('oracle_gain')}, "
                                  f"{rec['seconds']:.0f} s"))


def resume(seeds, path, one, report) -> List[dict]:
    """The records of ``path`` plus ``one(seed)`` for each seed not yet
    there, each appended to ``path`` (flushed and synced) as it finishes and
    passed to ``report``; a torn last line of ``path`` is dropped first, so
    a killed run resumes where it stopped."""
    from narx.atomic import atomic_write_text
    done = records(path)
    have = {r["seed"] for r in done}
    if os.path.exists(path):              # drop a torn last line before appending
        atomic_write_text(path, "".join(json.dumps(r) + "\n" for r in done))
    out = list(done)
    for seed in seeds:
        if seed in have:
            continue
        rec = one(seed)
        with open(path, "a", encoding="utf-8") as fh:
            fh.write(json.dumps(rec) + "\n")
            fh.flush()
            os.fsync(fh.fileno())
        out.append(rec)
        report(rec)
    return out


def calibrate(seeds, path, **kw) -> List[dict]:
    """:func:`evaluate` inside :func:`narx.systems.zoo.tuning`: the tuning
    entry; an evaluation seed raises :class:`~narx.systems.zoo.SeedLeak`
    before anything is run."""
    from narx.systems import zoo
    with zoo.tuning():
        for s in seeds:                    # refuse before the first long run
            zoo.guard(s)
        return evaluate(seeds, path, **kw)


# ------------------------------------------------------------------ table
def _rate(k: int, n: int) -> str:
    return f"{k}/{n} ({100.0 * k / n:.0f} %)" if n else "0/0 (–)"


def _gain(r) -> float:
    """The record's gain; null (JSON of an infinite or undefined ratio) is
    read back from the RMSEs, null where a simulation diverged: inf when
    only the baseline diverged, 0 when only the extension did, NaN when both."""
    g = r.get("gain")
    if g is not None:
        return float(g)
    b, e = r.get("baseline_rmse"), r.get("extended_rmse")
    if b is None and e is not None:
        return math.inf
    return 0.0 if e is None and b is not None else math.nan


def _faithful(r: dict, within: float = 1.5) -> bool:
    """Whether the recommended model's RMSE on the measuring samples is
    within ``within`` times the oracle's (the truth's structure fitted)."""
    rec = r.get("extended_rmse" if r.get("recommended") == "extended" else "baseline_rmse")
    o = r.get("oracle_rmse")
    return bool(rec is not None and o is not None and np.isfinite(o) and rec <= within * o)


def table(recs: List[dict], figure: Optional[str] = None) -> str:
    """The Markdown report of ``recs`` (conclusion, confusion table by family,
    headline rates, non-identifiable draws) and the power figure."""
    from narx.systems.zoo import FAMILIES
    ok = [r for r in recs if "error" not in r]
    failed = [r for r in recs if "error" in r]
    hy = [r for r in ok if r["hysteretic"]]
    ident = [r for r in hy if r["identifiable"]]
    ctrl = [r for r in ok if not r["hysteretic"]]
    named_h = lambda r: "hysteresis" in r["named"]           # noqa: E731
    power = sum(map(named_h, ident))
    alarms = sum(map(named_h, ctrl))
    good = sum(_gain(r) >= 1.5 for r in ident)
    worse = sum(_gain(r) < 0.95 for r in ok)
    lines = [f"**Conclusion.** On {len(ok)} draws, `mggp diagnose` named hysteresis on "
             f"{_rate(power, len(ident))} identifiable hysteretic draws and on "
             f"{_rate(alarms, len(ctrl))} controls; its extension gained ≥ 1.5× (and was "
             f"recommended) on {_rate(good, len(ident))} identifiable hysteretic draws, and "
             f"the recommended model was worse than the baseline (gain < 0.95) on "
             f"{_rate(worse, len(ok))} draws.", ""]
    seeds = sorted(r["seed"] for r in recs)
    splits = sorted({r["split"] for r in recs})
    lines += [f"Seeds {seeds[0]}–{seeds[-1]} ({', '.join(splits)}), {len(recs)} draws"
              + (f", {len(failed)} failed" if failed else "") + ".", ""]
    head = ["family", "draws", "identifiable", "hysteresis named", "other effects named",
            "gain ≥ 1.5", "gain < 0.95"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for fam in FAMILIES:
        rows = [r for r in ok if r["family"] == fam]
        if not rows:
            continue
        lines.append("| " + " | ".join(str(v) for v in (
            fam, len(rows), sum(r["identifiable"] for r in rows), sum(map(named_h, rows)),
            sum(bool(set(r["named"]) - {"hysteresis"}) for r in rows),
            sum(_gain(r) >= 1.5 for r in rows), sum(_gain(r) < 0.95 for r in rows))) + " |")
    lines += ["", "Identifiable: the truth's structure, fitted, beats the best model without "
              f"memory at the study budget by ≥ {IDENTIFIABLE}× on the validation record "
              "(oracle gain). Gain: baseline / extended validation RMSE of the diagnosis "
              "(< 1: the extension is worse, and the baseline is recommended).", ""]
    lines += ["**Headline rates**", "",
              f"- hysteresis named on identifiable hysteretic draws: {_rate(power, len(ident))}",
              f"- hysteresis named on controls: {_rate(alarms, len(ctrl))}",
              f"- recommended gain ≥ 1.5 on identifiable hysteretic draws: "
              f"{_rate(good, len(ident))}",
              f"- any gain < 0.95 (all draws): {_rate(worse, len(ok))}",
              f"- the recommended model within 1.5× of the oracle's RMSE on identifiable "
              f"hysteretic draws: {_rate(sum(_faithful(r) for r in ident), len(ident))}", ""]
    if all("separates" in r for r in ok):
        lines += ["**By what the training record can show** (the summary's separation line, "
                  "`mggp.diagnose.verdict.separation_note`):", ""]
        for label, want in (("records that separate memory from dynamics", True),
                            ("records that cannot (one amplitude, one rate, no holds)", False)):
            part = [r for r in ok if r["separates"] == want]
            pi = [r for r in part if r["hysteretic"] and r["identifiable"]]
            pc = [r for r in part if not r["hysteretic"]]
            lines.append(f"- {label}: {len(part)} draws; hysteresis named on "
                         f"{_rate(sum(map(named_h, pi)), len(pi))} identifiable hysteretic "
                         f"draws and on {_rate(sum(map(named_h, pc)), len(pc))} controls; gain "
                         f"≥ 1.5 on {_rate(sum(_gain(r) >= 1.5 for r in pi), len(pi))}; gain "
                         f"< 0.95 on {_rate(sum(_gain(r) < 0.95 for r in part), len(part))}")
        unnamed = [r for r in ok if r.get("winner") and not r["named"]]
        lines += [f"- an extension recommended with its cause not named (a memory candidate "
                  f"whose memory-free rival leaves the range on the probes, or, on a record "
                  f"that cannot separate, beats that rival by less than the share "
                  f"`UNSEPARATED_SHARE`): {len(unnamed)} draws "
                  f"({sum(not r['separates'] for r in unnamed)} on records that cannot "
                  f"separate)", ""]
    non = [r for r in hy if not r["identifiable"]]
    lines += [f"**Non-identifiable hysteretic draws** (oracle gain < {IDENTIFIABLE}): "
              f"{len(non)}; hysteresis named on {_rate(sum(map(named_h, non)), len(non))}.", ""]
    if non:
        lines += ["| seed | family | placement | input | oracle gain | named | gain |",
                  "|---|---|---|---|---|---|---|"]
        lines += [f"| {r['seed']} | {r['family']} | {r['placement']} | {r['input_kind']} | "
                  f"{_fmt(r['oracle_gain'])} | {', '.join(r['named']) or '–'} | "
                  f"{_fmt(r['gain'])} |" for r in non]
        lines.append("")
    if failed:
        lines += ["**Failed draws**", ""] + [f"- seed {r['seed']} ({r['family']}): "
                                              f"{r['error']}" for r in failed] + [""]
    div_b = sum(r.get("baseline_rmse") is None for r in ok)
    div_e = sum(r.get("extended_rmse") is None for r in ok)
    if div_b or div_e:
        lines += [f"Diverged free runs on the validation record: baseline {div_b}, extended "
                  f"{div_e} draws (a diverged baseline with a finite extension counts as "
                  f"gain ∞, the reverse as gain 0, both as neither).", ""]
    secs = [r["seconds"] for r in recs]
    lines.append(f"Seconds per draw (diagnosis and oracle): median {np.median(secs):.0f}, "
                 f"max {np.max(secs):.0f}.")
    if figure:
        lines += ["", _figure(ident, ctrl, figure)]
    return "\n".join(lines) + "\n"


def _fmt(x) -> str:
    return "–" if x is None else f"{x:.2f}"


def _figure(ident, ctrl, path) -> str:
    """Power against false-alarm rate as α varies; returns the caption."""
    from mggp.report.plotting import figure, save
    ph = np.array([naming_level(r) for r in ident])
    pc = np.array([naming_level(r) for r in ctrl])
    if not (np.isfinite(ph).any() and np.isfinite(pc).any()):
        return ("No figure: hysteresis is named at no level α on either the identifiable "
                "hysteretic draws or the controls.")
    alphas = np.unique(np.r_[np.logspace(-6, 0, 200), ph[np.isfinite(ph)],
                             pc[np.isfinite(pc)]])
    pw = np.array([np.mean(ph <= a) for a in alphas])          # NaN p: never named
    fa = np.array([np.mean(pc <= a) for a in alphas])
    fig, ax = figure(figsize=(5, 4.2))
    ax.step(fa, pw, where="post", label="α from 1e-6 to 1")
    a0 = np.searchsorted(alphas, ALPHA, side="right") - 1
    ax.plot(fa[a0], pw[a0], "o", label=f"α = {ALPHA:g} (default)")
    ax.plot([0, 1], [0, 1], ":", color="grey", label="chance")
    ax.set_xlabel(f"false-alarm rate on controls (fraction of {len(pc)} draws)")
    ax.set_ylabel(f"power on identifiable hysteretic draws\n(fraction of {len(ph)} draws)")
    ax.set_xlim(-0.02, 1.02)
    ax.set_ylim(-0.02, 1.02)
    ax.legend(loc="lower right", fontsize=8)
    save(fig, path)
    return (f"![power against false-alarm rate]({os.path.basename(path)})\n\n*Figure: share "
            f"of the {len(ph)} identifiable hysteretic draws on which hysteresis is named at "
            f"test level α (power) against the share of the {len(pc)} controls on which it "
            f"is (false-alarm rate), as α varies and the naming rule's other conditions stay "
            f"(`benchmarks.zoo.naming_level`); the dot is the default α = {ALPHA:g}, the "
            f"table's rates.*")


# ------------------------------------------------------------------ show
def show(seed: int) -> str:
    """A draw's family, parameters, truth and oracle, as text."""
    from narx.systems import zoo
    d = zoo.draw(seed, n=STUDY_N)
    orc = oracle(d)
    return "\n".join([
        f"seed {seed} ({d.split}): {d.family}, placement {d.placement}, input {d.input_kind}, "
        f"noise {d.noise['colour']} at {d.noise['snr_db']:.1f} dB",
        f"truth ({'exact' if d.truth.exact else 'expert structure'}): {d.truth.description}",
        "  " + "\n  ".join(d.truth.terms),
        f"oracle: {orc.method} (hold-out RMSE ls {orc.holdout_rmse['ls']:.4g}, freerun "
        f"{orc.holdout_rmse['freerun']:.4g}); validation free-run RMSE {orc.rmse:.4g} "
        f"(output std {np.std(d.validation.y):.4g})",
        "  " + orc.model.equation(),
        "parameters: " + json.dumps(d.params, indent=1)])


# ------------------------------------------------------------------ CLI
def _parser():
    p = argparse.ArgumentParser(prog="python -m benchmarks.zoo", description=__doc__.split(
        "\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    for name, helptext in (("evaluate", "diagnose draws and append their records"),
                           ("calibrate", "evaluate development seeds (inside zoo.tuning())"),
                           ("ablate", "diagnose development draws with and without each "
                                      "check (benchmarks.zoo_ablation)")):
        e = sub.add_parser(name, help=helptext)
        e.add_argument("--seeds", nargs="+", required=True, help="seeds or ranges A-B")
        e.add_argument("--json", required=True, help="JSON-lines file (appended, resumed)")
        e.add_argument("--population", type=int, default=STUDY_BUDGET["population"])
        e.add_argument("--generations", type=int, default=STUDY_BUDGET["generations"])
        e.add_argument("--jobs", type=int, default=1)
    r = sub.add_parser("replay", help="headline rates renamed under other memory shares "
                                      "(records with a candidates table)")
    r.add_argument("files", nargs="+")
    r.add_argument("--shares", nargs="+", type=float, default=[1.0, 0.33, 0.25, 0.2, 0.1, 0.0],
                   help="ρ values (1: the resolution alone; 0: no margin)")
    r.add_argument("--part-shares", nargs="+", type=float, default=None,
                   help="s values of the part rule (default: the code's PART_SHARE; "
                        "0: no part rule)")
    r.add_argument("--carry", action="store_true",
                   help="also replay the part rule without its clause on one part "
                        "carrying the gain")
    r.add_argument("--hold-motions", nargs="+", type=float, default=None,
                   help="hold-motion thresholds (shares of the output's range) to replay "
                        "(default: the eligibility as run)")
    r.add_argument("--rest-margins", nargs="+", type=float, default=None,
                   help="margins m of the part rule without the best part (default: the "
                        "code's REST_MARGIN)")
    r.add_argument("--unseparated-shares", nargs="+", type=float, default=None,
                   help="shares ρ₁ a memory winner must beat the best memory-free "
                        "candidate by to be named on records that cannot separate memory "
                        "from dynamics (default: the code's UNSEPARATED_SHARE)")
    r.add_argument("--part-floors", nargs="+", type=int, choices=(0, 1), default=None,
                   help="1: the parts' RMSEs floored at the resolution in the part rule, "
                        "0: not (default: the code's PART_FLOOR)")
    t = sub.add_parser("table", help="Markdown table of a records file")
    t.add_argument("file")
    t.add_argument("--figure", help="PNG of power against false-alarm rate")
    s = sub.add_parser("show", help="a draw's family, parameters, truth and oracle")
    s.add_argument("seed", type=int)
    return p


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    try:
        if args.command in ("evaluate", "calibrate", "ablate"):
            for name in ("population", "generations", "jobs"):
                if getattr(args, name) < 1:
                    raise ValueError(f"--{name} must be >= 1, got {getattr(args, name)}")
            if args.command == "ablate":
                from benchmarks.zoo_ablation import ablate as run
            else:
                run = evaluate if args.command == "evaluate" else calibrate
            run(parse_seeds(args.seeds), args.json, population=args.population,
                generations=args.generations, jobs=args.jobs)
        elif args.command == "replay":
            recs = [rec for f in args.files for rec in records(f)]
            print(replay(recs, args.shares, args.part_shares,
                         (False, True) if args.carry else (False,),
                         args.hold_motions or (None,), args.rest_margins,
                         args.unseparated_shares,
                         None if args.part_floors is None
                         else [bool(v) for v in args.part_floors]), end="")
        elif args.command == "table":
            recs = records(args.file)
            if not recs:
                raise ValueError(f"{args.file}: no records")
            print(table(recs, args.figure), end="")
        else:
            print(show(args.seed))
    except (ValueError, OSError, RuntimeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
