r"""The ``extend`` stage's choice: the diagnosis's catalogue of extensions
tried on the fit's structure.

Typical use (the ``extend`` stage of :mod:`mggp.fit.stages` does this)::

    from mggp.fit.extension import extension_choice
    ext = extension_choice(terms, data, registry, seed=0, level=0.05, resolution=0.005)
    ext.choice.why          # 'extended by plays (Prandtl–Ishlinskii) (hysteresis): ...'
    ext.terms, ext.theta    # the structure handed on; 'ls' or 'freerun'
    ext.to_dict()           # extension_ of the estimator

The structure the fit has chosen is the baseline of the candidate
extensions of ``mggp diagnose`` (:func:`mggp.diagnose.candidates.candidate_structures`:
plays and Prandtl–Ishlinskii operators, Bouc–Wen variables, Φ of the inputs
and of the output lags, linear dynamics driven by operators, operators of
y[k-1] inside the feedback, and the memory-free rivals: more lags, more
degree, rate terms). The record is split as the fit's other automatic
choices split it (:func:`mggp.fit.choices.heldout_errors`): every candidate
is built and estimated on the first ``1 - HOLDOUT`` of the record
(:func:`~mggp.diagnose.candidates.fit_structure`: its new terms by forward
selection, their number by the free-run error on the last 30 % of those
samples, θ by least squares or, for the forms that replace the baseline's
dynamics, by free-run simulation error when that simulates better), and
every model, the chosen structure with θ estimated the same way as in the
other choices, runs free over the whole record from its first samples;
their errors on the held-out tail are compared by the diagnosis's rule
(:func:`mggp.diagnose.verdict.decide`): the one-sided paired block
bootstrap of the log-loss differences (:func:`narx.analysis.paired.paired_test`,
losses floored at ``resolution`` of the output's range), Holm's adjustment
over the candidates, a memory candidate also beating the best memory-free
one's error by more than the resolution or :data:`EXTENSION_SHARE` of it
(:func:`~mggp.diagnose.verdict.worth_naming`) unless that
one is barred (then the memory candidate that beats the chosen structure
wins, its cause unnamed), at ``level``. The winner is
taken only when its free run stays bounded on the diagnosis's probe inputs
(:func:`~mggp.diagnose.candidates.stays_bounded`) and, with ``check``, on
the fit's stress inputs (:class:`mggp.fit.extrapolation.StressCheck`);
a winner refused there is barred and the test decided again. When no
extension wins, a form that replaces the structure (linear dynamics of
order up to 3 with operators, Bouc–Wen variables or products) is taken if
the held-out part cannot tell it from the chosen structure (within the
size tolerance) and its largest lag is smaller (:func:`shorter_memory`).
New terms
that the fit does not allow (``allowed``: ``max_lag``, ``max_degree``,
the power cap) are left out, and no candidate has more than
``max_terms`` terms. The CLS form of the catalogue is tested as a rival
but never taken (the fit's ``constraints`` decide that).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Callable, Optional, Tuple

import numpy as np

from narx import Model
from narx.records.data import Data
from narx.records.regressors import max_lag
from narx.language.terms import Signals, parse_term

from .choices import (HOLDOUT, Choice, _held_span, _sim_errors, heldout_errors, percent,
                      rmse_text, size_tolerance, terms_text)

__all__ = ["Extension", "extension_choice", "shorter_memory", "keeps_dead_time",
           "DEAD_TIME_FROM", "EXTENSION_SHARE"]

#: ρ of :func:`mggp.diagnose.verdict.worth_naming` in this choice: a memory
#: extension must cut the best memory-free candidate's held-out error by
#: more than the resolution or by this share. The zoo-fit, measured-panel,
#: friction and Maxwell-slip figures of ``benchmarks/RESULTS.md`` were
#: measured with 0.2 (and with a paired test of a memory extension against
#: the best memory-free one, since dropped: on the 44 development draws
#: of the zoo-fit study it decided no extension, every validation error
#: the same to the last digit); the diagnosis chose its own ρ
#: (:data:`mggp.diagnose.verdict.MEMORY_SHARE`) on its development
#: draws, which measure naming, not the fit.
EXTENSION_SHARE = 0.2


@dataclass(frozen=True)
class Extension:
    """What the ``extend`` stage decided: its :class:`Choice`, the structure
    handed on (the chosen one when no extension won), how the winner's θ
    was estimated ('ls', or 'freerun': refined by free-run simulation
    error), the test (:class:`mggp.diagnose.verdict.Verdict`, None when no
    test ran) and the stage's time in seconds."""

    choice: Choice
    terms: Tuple
    theta: str = "ls"
    verdict: object = None
    seconds: float = 0.0

    def to_dict(self) -> dict:
        """``extension_``: the choice's figures, the test of every candidate
        (:meth:`mggp.diagnose.verdict.Verdict.to_dict`) and the time."""
        out = {"winner": self.choice.figures.get("winner"), "theta": self.theta,
               "why": self.choice.why, "seconds": self.seconds}
        if self.verdict is not None:
            out["test"] = self.verdict.to_dict()
        return out


def _kept(why: str, terms, figures=None, seconds: float = 0.0, verdict=None) -> Extension:
    return Extension(Choice("extend", "none", why, dict(figures or {}, winner=None)),
                     tuple(terms), "ls", verdict, seconds)


def _allowed_structure(s, room: int, allowed, parse):
    """The candidate ``s`` with the new terms the fit allows (parsed by
    ``parse``, text -> Term), and how many it may keep (``room`` for a form
    that replaces the baseline, less the baseline's terms for one that adds
    to it)."""
    new = tuple(t for t in map(parse, s.new) if allowed(t))
    return replace(s, new=new), room - len(s.base)


def extension_choice(terms, data: Data, registry=None, seed=0, level: float = 0.05,
                     resolution: float = 0.005, theta: str = "ls", max_terms: int = 15,
                     allowed: Optional[Callable] = None, check=None,
                     scans=None) -> Extension:
    """Try the catalogue's extensions of the structure ``terms`` on ``data``
    and take the one the paired held-out test picks (module doc).

    Parameters
    ----------
    terms : sequence of Term
        The structure the fit chose.
    data : narx.Data
        The training record (the search's part of it).
    registry : PhiRegistry, optional
    seed : int
        Seeds the bootstrap (``numpy.random.default_rng(seed)``).
    level : float
        Family-wise level of the test (the diagnosis's ``level``).
    resolution : float
        Errors below this share of the output's range count as equal (the
        floor of the log loss; the diagnosis's ``resolution``).
    theta : str
        θ of the chosen structure on the fitting samples
        (:func:`mggp.fit.choices.heldout_theta`).
    max_terms : int
        Most terms of a candidate.
    allowed : callable, optional
        ``allowed(term)``: whether the fit may use a new term.
    check : StressCheck, optional
        The fit's stress test; a winner that fails it is barred.
    scans : dict, optional
        :func:`narx.records.deadtime.onset_scans` of the record, when the
        fit has them (the dead times the catalogue's lags reach; computed on
        the fitting samples otherwise).

    The solves and simulations run with the BLAS on one thread
    (:func:`narx.linalg.one_blas_thread`; tall, narrow matrices, as in the
    diagnosis).
    """
    from narx.linalg import one_blas_thread
    with one_blas_thread():
        return _extension(tuple(terms), data, registry, seed, level, resolution, theta,
                          max_terms, allowed or (lambda t: True), check, scans)


def _extension(terms, data, registry, seed, level, resolution, theta, max_terms, allowed,
               check, scans) -> Extension:
    from ..diagnose.candidates import (MIN_FIT, MIN_SELECT, candidate_structures, fit_structure,
                                       stays_bounded)
    from ..diagnose.verdict import decide, loss_floor
    t0 = time.perf_counter()
    lo, hi = _held_span(data.n, "tail")
    if lo < MIN_FIT or hi - lo < MIN_SELECT:
        return _kept(f"kept: no extension tried ({data.n} samples are too few: the catalogue "
                     f"needs {MIN_FIT} to fit and {MIN_SELECT} held out)", terms)
    fit = data.slice(0, lo)
    sig, parsed = Signals(data.output, data.inputs), {}

    def parse(text):                # each text once: the catalogue's forms share terms
        if text not in parsed:
            parsed[text] = parse_term(text, sig, registry=registry)
        return parsed[text]
    base = Model(terms, inputs=data.inputs, output=data.output, registry=registry)
    fitted = []
    # the diagnosis's linear-dynamics twin and its fitted histories are left
    # out: the figures of this stage (zoo fit, measured panel) were measured
    # without them; with the histories, zoo-fit development draws 16-59 came
    # within 1.5x of the oracle on 30 of 44 against 31
    # (benchmarks/results/zoo_fit/dev_16_59_histories.jsonl)
    for s in candidate_structures(base, fit, scans, linear_twin=False):
        s, room = _allowed_structure(s, max_terms, allowed, parse)
        model = None
        if s.new and room > 0 or not s.new:
            model = fit_structure(s, fit, registry, max_new=room, histories=False)[0]
        fitted.append((s, model))
    span = hi - lo

    def errors(model) -> np.ndarray:
        e = None if model is None else _sim_errors(model, data, lo, hi)
        return np.full(span, np.inf) if e is None else e
    got = heldout_errors(terms, data, registry, ends=("tail",), theta=theta)
    e_base = np.full(span, np.inf) if got is None else got[0]
    errs = [errors(m) for _, m in fitted]
    ok = ~np.isnan(e_base)                  # the samples every free run predicts
    for e in errs:
        ok &= ~np.isnan(e)
    e_base, errs = e_base[ok], [e[ok] for e in errs]
    cands = [(s, m, e, float("nan")) for (s, m), e in zip(fitted, errs)]
    eligible = [s.constraints is None and m is not None and stays_bounded(m, fit)
                for s, m in fitted]
    floor = loss_floor(fit.y, resolution)
    refused = {}
    while True:
        vd = decide(e_base, cands, level, np.random.default_rng(seed), floor, eligible,
                    share=EXTENSION_SHARE)
        w = vd.winner
        why = "" if w is None or check is None else check(tuple(w.model.terms))
        if not why:
            break
        refused[w.structure.name] = why
        eligible[[s for s, _ in fitted].index(w.structure)] = False
    seconds = time.perf_counter() - t0
    tried = [s.name for s, m in fitted if m is not None]
    figs = {"tried": tried, "heldout_rmse": vd.baseline_rmse, "level": level,
            "candidates": {t.structure.name: {"heldout_rmse": t.selection_rmse,
                                              "p_value": t.p_value}
                           for t in vd.tested if t.model is not None}}
    if refused:
        figs["stress_refused"] = refused
    said = (f"{len(tried)} catalogue extensions tried, θ on the first "
            f"{percent(1 - HOLDOUT)}, error on the last {percent(HOLDOUT)} of the record; "
            f"paired block bootstrap of the log-loss differences, Holm, level {level:g}, "
            f"a memory extension also below the best memory-free one by the resolution or "
            f"{percent(EXTENSION_SHARE)}")
    bar = "".join(f"; {n} refused on the stress inputs (its free run {r})"
                  for n, r in refused.items())
    if w is None:
        short = shorter_memory(vd, eligible, terms, int(np.count_nonzero(ok)), check)
        if short is not None:
            return _replaced(short, vd, terms, figs, said, bar, time.perf_counter() - t0)
        best = min((t for t in vd.tested if t.model is not None),
                   key=lambda t: t.selection_rmse, default=None)
        lead = ("" if best is None else
                f": the best, {best.structure.name}, held-out free-run RMSE "
                f"{rmse_text(best.selection_rmse)} against {rmse_text(vd.baseline_rmse)}, "
                f"p = {best.p_value:.2g}")
        return _kept(f"kept: no extension won{lead} ({said}{bar})", terms, figs, seconds, vd)
    how, theta_words = _estimation(w.model)
    new = tuple(w.model.terms)
    figs.update(winner=w.structure.name, effect=w.effect, heldout_rmse_extended=w.selection_rmse,
                p_value=w.p_value, theta=how, terms=len(new))
    why = (f"extended by {w.structure.name} ({w.effect}): held-out free-run RMSE "
           f"{rmse_text(w.selection_rmse)} against {rmse_text(vd.baseline_rmse)} for the chosen "
           f"structure, p = {w.p_value:.2g}; {terms_text(len(new))}, {theta_words} "
           f"({said}{bar})")
    return Extension(Choice("extend", w.structure.name, why, figs), new, how, vd, seconds)


def _estimation(model):
    """``(how, words)``: how a taken candidate's θ were estimated ('freerun'
    when its fit refined them by simulation error, else 'ls') and the
    choice line's words for the refit on the whole record."""
    if "refined" in model.meta:
        return "freerun", "θ by free-run simulation error, refitted so on the whole record"
    return "ls", "θ by least squares on the whole record"


def _input_lags(terms, inputs) -> dict:
    """``{input: [lags]}``: every lag of each input in ``terms``, inside
    Φ-calls and operators too (:attr:`narx.language.terms.Term.lags`)."""
    out = {n: [] for n in inputs}
    for a in (a for t in terms for a in t.lags):
        if a.signal in out:
            out[a.signal].append(a.lag)
    return out


#: a structure whose input acts only from this lag on states a dead time
#: (:func:`keeps_dead_time`): the catalogue's forms that replace a structure
#: offer the inputs at lags 0-2 (:func:`mggp.diagnose.candidates.candidate_structures`)
DEAD_TIME_FROM = 3


def keeps_dead_time(form, terms, inputs) -> bool:
    """Whether the structure ``form`` keeps the dead time that ``terms``
    states: for each input whose smallest lag in ``terms`` is
    :math:`d \\ge` :data:`DEAD_TIME_FROM` (the input acts only from lag
    :math:`d` on), ``form`` has that input at lag :math:`d` or later."""
    have, need = _input_lags(form, inputs), _input_lags(terms, inputs)
    return all(max(have[n], default=-1) >= min(lags) for n, lags in need.items()
               if lags and min(lags) >= DEAD_TIME_FROM)


def shorter_memory(vd, eligible, terms, n_heldout: int, check=None):
    """The catalogue form that replaces the chosen structure ``terms`` when
    no extension wins the test (:func:`extension_choice`), else None: of the
    eligible candidates that replace the structure (linear dynamics of
    order up to 3 with operators, Bouc–Wen variables, output operators or
    products: ``Structure.base`` empty), those whose held-out free-run
    RMSE is within the size tolerance
    :math:`\\tau` (:func:`mggp.fit.choices.size_tolerance` of the
    ``n_heldout`` scored samples) of the chosen structure's,

    .. math:: e_c \\le (1 + \\tau)\\, e_0,

    and whose largest lag is smaller than the chosen structure's while it
    reaches the structure's dead time (:func:`keeps_dead_time`); the one
    of least held-out error whose free run passes ``check`` (the fit's
    stress inputs). ``eligible``: per candidate of ``vd.tested``, fitted,
    unconstrained and bounded on the probe inputs.

    It is the size choice's rule (the simplest of the structures the
    held-out part cannot tell apart) applied to the memory of a structure.
    Under output noise, least squares in the search favours far lags that
    make up for its bias (regressors far from the noise they carry act as
    instruments; Söderström and Stoica, *System Identification*, 1989,
    ch. 8): such a structure fits the training record's spectrum and
    simulates the held-out part of it as well as the system's own
    low-order form, but not another input. Chosen on development draws
    16-159 of the zoo: within 1.5x of the oracle on 104 of 130 against 96
    (``benchmarks/RESULTS.md``, section Zoo fit)."""
    base_rmse = vd.baseline_rmse
    if not np.isfinite(base_rmse):
        return None
    limit = (1.0 + size_tolerance(n_heldout)) * base_rmse
    lag = max_lag(terms)
    pool = sorted((t for t, ok in zip(vd.tested, eligible)
                   if ok and not t.structure.base
                   and np.isfinite(t.selection_rmse) and t.selection_rmse <= limit
                   and t.model.max_lag < lag
                   and keeps_dead_time(t.model.terms, terms, t.model.inputs)),
                  key=lambda t: (t.selection_rmse, t.structure.name))
    for t in pool:
        if check is None or not check(tuple(t.model.terms)):
            return t
    return None


def _replaced(t, vd, terms, figs, said, bar, seconds) -> Extension:
    """The :class:`Extension` of a :func:`shorter_memory` replacement ``t``."""
    how, theta_words = _estimation(t.model)
    new = tuple(t.model.terms)
    figs.update(winner=t.structure.name, effect="shorter memory",
                heldout_rmse_extended=t.selection_rmse, p_value=t.p_value, theta=how,
                terms=len(new), largest_lag=max_lag(new), searched_largest_lag=max_lag(terms))
    why = (f"replaced by {t.structure.name} (shorter memory): held-out free-run RMSE "
           f"{rmse_text(t.selection_rmse)} against {rmse_text(vd.baseline_rmse)} for the chosen "
           f"structure, within the size tolerance, largest lag {max_lag(new)} against "
           f"{max_lag(terms)}; no extension won the test; {terms_text(len(new))}, "
           f"{theta_words} ({said}{bar})")
    return Extension(Choice("extend", t.structure.name, why, figs), new, how, vd, seconds)
