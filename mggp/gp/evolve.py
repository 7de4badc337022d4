"""The MGGP generational loop (DEAP toolbox, explicit RNG, batch fitness).

Typical use::

    from mggp.gp.primitives import make_pset
    from mggp.gp.evolve import evolve

    pset = make_pset()                       # y[k-1], u[k-1], ×, Φ1, Φ2, q⁻¹..q⁻³
    def evaluate_batch(term_sets):           # list of tuples of narx Terms
        return [my_mse(terms) for terms in term_sets]   # floats, inf allowed
    res = evolve(pset, evaluate_batch, seed=1, population_size=500,
                 generations=200, checkpoint="run.ckpt.json", resume=True)
    res.best.terms, res.best.fitness, res.pareto, res.logbook

One generation: ``n_elite = round(elite_fraction * population_size)`` best
individuals (at least one if the fraction is positive) are copied
unchanged; the rest are tournament winners (``tournament_size`` aspirants,
with replacement), cloned, paired (1st with 2nd, ...) and crossed with
probability ``cxpb`` (high-level gene exchange with probability
``high_level_cx_rate``, else low-level subtree crossover), then each is
mutated with probability ``mutpb`` (high-level with probability
``high_level_mut_rate``, else subtree mutation). Individuals whose fitness
was invalidated are decoded to their distinct terms and scored through ONE
call of ``evaluate_batch`` per generation.

Fitness cache: the key is the sorted tuple of distinct term texts. It
assumes ``evaluate_batch`` is a pure function of the term *set* (same data,
same settings; LS fitting does not depend on term order), so a structure is
scored once per run and never re-sent, within or across generations. A
generation with nothing new makes no call.

Determinism: every random draw comes from one ``random.Random(seed)``;
``evaluate_batch`` receives the full ordered list and returns results in
that order, so how the caller parallelises it cannot change the run.
Checkpoints store the RNG state and the cache, so a resumed run ends
exactly as an uninterrupted one.
"""
from __future__ import annotations

import dataclasses
import json
import math
import os
import random
from dataclasses import dataclass
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np
from deap import base, tools

from narx.language.terms import Term

from .checkpoint import (CHECKPOINT_SHARE, CheckpointWriter, EvolutionState,
                         checkpoint_settings, load_checkpoint, settings_fingerprint)
from ..exceptions import CheckpointError
from .individual import Individual, ParetoArchive, ParetoRow
from .operators import (cx_high_level, cx_low_level, mut_high_level,
                        mut_low_level, random_individual, sel_tournament)
from ..fit.params import PARAMS, Int
from .primitives import Decoder, tree_to_tokens

__all__ = ["check_context", "EvolutionSettings", "EvolutionResult", "make_toolbox", "evolve",
           "structure_key"]

LOG_FIELDS = ["gen", "nevals", "cache_hits", "best", "median", "best_terms"]

#: rules of the settings: the estimator parameters' (:data:`mggp.fit.params.PARAMS`)
_RULES = tuple((name, PARAMS[row].rule) for name, row in (
    ("cxpb", "cxpb"), ("mutpb", "mutpb"), ("high_level_cx_rate", "high_level_cx_rate"),
    ("high_level_mut_rate", "high_level_mut_rate"), ("elite_fraction", "elite_fraction"),
    ("population_size", "population"), ("generations", "generations"),
    ("tournament_size", "tournament_size"), ("max_terms", "max_terms"),
    ("min_terms", "max_terms"))) + (("max_height", Int(0)),)


@dataclass
class EvolutionSettings:
    """Parameters of a run (defaults: the published setup).

    Attributes
    ----------
    population_size : int
        500.
    generations : int
        200 (generation 0 is the initial population).
    cxpb, mutpb : float
        Crossover (0.8) and mutation (0.2) probabilities.
    high_level_cx_rate, high_level_mut_rate : float
        Share of high-level operators (0.5 each).
    tournament_size : int
        2.
    elite_fraction : float
        0.1.
    max_terms : int
        15 genes at most per individual.
    max_height : int
        5 (DEAP height; largest lag 1 + 3·5 = 16).
    init_max_height : int or None
        Height range of initial genes (None: ``max_height``).
    min_terms : int
        1.
    seed : int or None
        None draws one from the OS (recorded in the result).
    """

    population_size: int = 500
    generations: int = 200
    cxpb: float = 0.8
    mutpb: float = 0.2
    high_level_cx_rate: float = 0.5
    high_level_mut_rate: float = 0.5
    tournament_size: int = 2
    elite_fraction: float = 0.1
    max_terms: int = 15
    max_height: int = 5
    init_max_height: Optional[int] = None
    min_terms: int = 1
    seed: Optional[int] = None

    def __post_init__(self):
        # the estimator's rules (mggp.fit.params); a tree of height 0 is a terminal
        for name, rule in _RULES:
            rule.check(name, getattr(self, name))
        for name in ("population_size", "generations", "tournament_size", "max_terms",
                     "max_height", "min_terms"):
            setattr(self, name, int(getattr(self, name)))   # JSON-able (numpy ints are not)
        if self.min_terms > self.max_terms:
            raise ValueError(f"min_terms ({self.min_terms}) > max_terms ({self.max_terms})")
        if self.init_max_height is not None and not 0 <= self.init_max_height <= self.max_height:
            raise ValueError(f"init_max_height must be in [0, max_height], "
                             f"got {self.init_max_height!r}")
        if self.seed is not None and (not isinstance(self.seed, (int, np.integer))
                                      or isinstance(self.seed, bool)):
            raise ValueError(f"seed must be an integer or None, got {self.seed!r}")
        if self.seed is not None:
            self.seed = int(self.seed)
        if self.init_max_height is not None:
            self.init_max_height = int(self.init_max_height)
        for name in ("cxpb", "mutpb", "high_level_cx_rate", "high_level_mut_rate",
                     "elite_fraction"):
            setattr(self, name, float(getattr(self, name)))

    @property
    def n_elite(self) -> int:
        if self.elite_fraction <= 0:
            return 0
        return min(self.population_size, max(1, int(round(self.elite_fraction *
                                                          self.population_size))))


@dataclass
class EvolutionResult:
    """Outcome of :func:`evolve`.

    Attributes
    ----------
    best : ParetoRow
        Lowest fitness over the whole run (fewest terms on ties):
        ``best.terms``, ``best.fitness``, ``best.genes``.
    population : list of Individual
        Final population (evaluated).
    logbook : deap.tools.Logbook
        One record per generation: gen, nevals, cache_hits, best, median,
        best_terms.
    pareto : list of ParetoRow
        Non-dominated (complexity = distinct terms, fitness) over the run.
    evaluations : int
        Structures sent to ``evaluate_batch``.
    generations : int
        Last generation completed.
    settings : EvolutionSettings
        With the seed actually used.
    """

    best: ParetoRow
    population: List[Individual]
    logbook: tools.Logbook
    pareto: List[ParetoRow]
    evaluations: int
    generations: int
    settings: EvolutionSettings


def structure_key(terms: Sequence[Term]) -> Tuple[str, ...]:
    """Cache key of a term set: sorted distinct term texts."""
    return tuple(sorted({t.text for t in terms}))


def make_toolbox(pset, settings: EvolutionSettings) -> base.Toolbox:
    """Toolbox with the run's operators; each alias takes ``rng=`` at call.

    Aliases: ``individual(rng=)``, ``mate_high(a, b, rng=)``,
    ``mate_low(a, b, rng=)``, ``mutate_high(ind, rng=)``,
    ``mutate_low(ind, rng=)``, ``select(pop, k, rng=)``, ``clone(ind)``;
    ``map`` is the builtin ``map`` (used for decoding).
    """
    s = settings
    init_h = s.max_height if s.init_max_height is None else s.init_max_height
    tb = base.Toolbox()
    tb.register("individual", random_individual, pset, max_terms=s.max_terms,
                max_height=init_h, min_terms=s.min_terms)
    tb.register("mate_high", cx_high_level, max_terms=s.max_terms)
    tb.register("mate_low", cx_low_level, max_height=s.max_height)
    tb.register("mutate_high", mut_high_level, pset=pset, max_terms=s.max_terms,
                max_height=s.max_height)
    tb.register("mutate_low", mut_low_level, pset=pset, max_height=s.max_height)
    tb.register("select", sel_tournament, tournsize=s.tournament_size)
    tb.register("clone", Individual.clone)
    return tb


def _as_fitness(v, i) -> float:
    if isinstance(v, (tuple, list, np.ndarray)):
        if len(v) != 1:
            raise ValueError(f"evaluate_batch result {i} must be one number, got {v!r}")
        v = v[0]
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise ValueError(f"evaluate_batch result {i} is not a number: {v!r}") from None
    return math.inf if math.isnan(f) else f


def _evaluate(pop, toolbox, decoder, state: EvolutionState, evaluate_batch):
    """Score invalid individuals (cache first, then one batch call)."""
    invalid = [ind for ind in pop if not ind.fitness.valid]
    terms_list = list(toolbox.map(decoder.decode_individual, invalid))
    pending = {}
    hits = 0
    for ind, terms in zip(invalid, terms_list):
        key = structure_key(terms)
        if key in state.cache:
            ind.fitness.values = (state.cache[key],)
            hits += 1
        else:
            pending.setdefault(key, (terms, ind, []))[2].append(ind)
    if pending:
        keys = list(pending)
        results = list(evaluate_batch([pending[k][0] for k in keys]))
        if len(results) != len(keys):
            raise ValueError(f"evaluate_batch returned {len(results)} results "
                             f"for {len(keys)} term sets")
        for i, (k, r) in enumerate(zip(keys, results)):
            f = _as_fitness(r, i)
            terms, first, inds = pending[k]
            state.cache[k] = f
            for ind in inds:
                ind.fitness.values = (f,)
            state.archive.update(terms, f, [tree_to_tokens(g) for g in first])
        state.evaluations += len(keys)
    return len(pending), hits


def _record(state: EvolutionState, decoder, nevals, hits, structure=None):
    fits = [ind.fitness.values[0] for ind in state.population]
    ibest = min(range(len(fits)), key=lambda i: (fits[i], i))
    terms = decoder.decode_individual(state.population[ibest])
    state.logbook.record(gen=state.generation, nevals=nevals, cache_hits=hits,
                         best=fits[ibest], median=float(np.median(fits)),
                         best_terms=len(terms if structure is None else structure(terms)))


def _step(state: EvolutionState, toolbox, s: EvolutionSettings):
    """Build the next population (not yet evaluated)."""
    rng, pop = state.rng, state.population
    n_elite = s.n_elite
    order = sorted(range(len(pop)), key=lambda i: (pop[i].fitness.values[0], i))
    elites = [toolbox.clone(pop[i]) for i in order[:n_elite]]
    offspring = [toolbox.clone(ind) for ind in
                 toolbox.select(pop, s.population_size - n_elite, rng=rng)]
    for i in range(1, len(offspring), 2):
        if rng.random() < s.cxpb:
            mate = toolbox.mate_high if rng.random() < s.high_level_cx_rate \
                else toolbox.mate_low
            mate(offspring[i - 1], offspring[i], rng=rng)
    for ind in offspring:
        if rng.random() < s.mutpb:
            mutate = toolbox.mutate_high if rng.random() < s.high_level_mut_rate \
                else toolbox.mutate_low
            mutate(ind, rng=rng)
    return elites + offspring


def _differences(old: dict, new: dict, prefix: str = "") -> str:
    """``key (checkpoint A, this run B)`` for every differing setting."""
    out = []
    for k in sorted(set(old) | set(new)):
        a, b = old.get(k), new.get(k)
        if k == "generations" or a == b:
            continue
        if isinstance(a, dict) and isinstance(b, dict):
            out.append(_differences(a, b, f"{prefix}{k}."))
        else:
            out.append(f"{prefix}{k} (checkpoint {a!r}, this run {b!r})")
    return ", ".join(o for o in out if o)


def _mismatch(checkpoint, diff: str) -> CheckpointError:
    return CheckpointError(f"checkpoint {os.fspath(checkpoint)}: written by a run with other "
                           f"settings or primitives (differs in: {diff}); remove it or run "
                           f"without resume")


def check_context(checkpoint, context: dict) -> None:
    """Raise :class:`CheckpointError` naming the settings in which the
    context stored in ``checkpoint`` differs from ``context`` (a fit with
    pilots checks this before its first pilot, not after them); the entry
    ``search`` (which pilot's search a file holds) is not compared."""
    stored = checkpoint_settings(checkpoint).get("context")
    if not isinstance(stored, dict):
        return
    ours = json.loads(json.dumps(context, default=str))
    diff = _differences({k: v for k, v in stored.items() if k != "search"},
                        {k: v for k, v in ours.items() if k != "search"}, "context.")
    if diff:
        raise _mismatch(checkpoint, diff)


def evolve(pset, evaluate_batch: Callable[[List[Tuple[Term, ...]]], Sequence[float]],
           settings: Optional[EvolutionSettings] = None, *,
           decoder: Optional[Decoder] = None,
           toolbox: Optional[base.Toolbox] = None,
           on_generation: Optional[Callable[[EvolutionState], None]] = None,
           checkpoint=None, resume: bool = False, checkpoint_every: Optional[int] = None,
           context: Optional[dict] = None,
           structure: Optional[Callable[[Tuple[Term, ...]], Tuple[Term, ...]]] = None,
           **params) -> EvolutionResult:
    """Run MGGP structure search.

    Parameters
    ----------
    pset : deap.gp.PrimitiveSetTyped
        From :func:`mggp.gp.primitives.make_pset`.
    evaluate_batch : callable
        ``evaluate_batch(list_of_term_tuples) -> list of float`` (MSE to
        minimise; ``inf``/``nan`` mean a diverging model and rank last).
        Called at most once per generation, only with structures never
        scored before in this run.
    settings : EvolutionSettings, optional
        Defaults to the published setup; ``**params`` override fields
        (``evolve(pset, f, seed=1, generations=50)``).
    decoder : Decoder, optional
        Tree -> term cache (default: a new one for ``pset.signals``).
    toolbox : deap.base.Toolbox, optional
        Replaces :func:`make_toolbox` (same aliases, ``rng=`` keyword).
    on_generation : callable, optional
        ``on_generation(state)`` after every generation (0 included), after
        the checkpoint is written; for progress bars and logging.
    checkpoint : path, optional
        Written after the initial population, then every
        ``checkpoint_every`` generations, and at the end; with
        ``checkpoint_every=None`` (default) whenever the writes so far leave
        it within :data:`mggp.gp.checkpoint.CHECKPOINT_SHARE` (5 %) of the
        wall time (:class:`mggp.gp.checkpoint.CheckpointWriter`), which is every
        generation while a write is cheap beside a generation.
    resume : bool
        Continue from ``checkpoint`` if the file exists (its settings, the
        number of generations aside, must match); otherwise start anew.
    context : dict, optional
        What else the fitness values depend on (JSON-able: a digest of the
        data, the fitness mode and its settings...); stored with the
        settings, so a checkpoint is resumed only by a run that scores
        structures the same way.
    structure : callable, optional
        ``structure(terms)``: the structure actually scored for an
        individual's decoded terms (terms dropped, a constant added); the
        logbook's ``best_terms`` counts its terms (default: the decoded
        terms as they are).

    Returns
    -------
    EvolutionResult

    Raises
    ------
    ValueError
        Invalid settings, a checkpoint of another run, or an
        ``evaluate_batch`` returning the wrong number of results.
    """
    s = dataclasses.replace(settings or EvolutionSettings(), **params)
    if checkpoint_every is not None and (not isinstance(checkpoint_every, int)
                                         or checkpoint_every < 1):
        raise ValueError(f"checkpoint_every must be an integer >= 1, got {checkpoint_every!r}")
    if s.seed is None:
        s = dataclasses.replace(s, seed=random.SystemRandom().randrange(2 ** 32))
    decoder = decoder if decoder is not None else Decoder(getattr(pset, "signals", None))
    toolbox = toolbox if toolbox is not None else make_toolbox(pset, s)
    sdict = dataclasses.asdict(s)
    if context:
        sdict["context"] = dict(context)
    fingerprint = settings_fingerprint(sdict, pset)

    writer = None if checkpoint is None else CheckpointWriter(
        checkpoint, share=1.0 if checkpoint_every else CHECKPOINT_SHARE)

    def save(state, force=False):
        if writer is not None:
            writer(state, force=force)

    if resume and checkpoint is not None and os.path.exists(checkpoint):
        try:
            state = load_checkpoint(checkpoint, pset, decoder)
        except ValueError as exc:
            # genes of another primitive set (use_phi, phi_names, phi_outputs
            # changed) do not parse in this one: name the settings first
            stored = checkpoint_settings(checkpoint)
            diff = _differences(stored, sdict) if stored else ""
            if not diff:
                raise
            raise CheckpointError(f"{_mismatch(checkpoint, diff)} ({exc})") from None
        if state.fingerprint != fingerprint:
            raise _mismatch(checkpoint, _differences(state.settings, sdict) or "primitive set")
        state.settings = sdict
    else:
        rng = random.Random(s.seed)
        state = EvolutionState(0, rng, [toolbox.individual(rng=rng)
                                        for _ in range(s.population_size)],
                               tools.Logbook(), ParetoArchive(), {}, 0, sdict,
                               fingerprint)
        state.logbook.header = list(LOG_FIELDS)
        nevals, hits = _evaluate(state.population, toolbox, decoder, state,
                                 evaluate_batch)
        _record(state, decoder, nevals, hits, structure)
        save(state)
        if on_generation is not None:
            on_generation(state)

    while state.generation < s.generations:
        state.population = _step(state, toolbox, s)
        state.generation += 1
        nevals, hits = _evaluate(state.population, toolbox, decoder, state,
                                 evaluate_batch)
        _record(state, decoder, nevals, hits, structure)
        last = state.generation == s.generations
        if checkpoint_every is None or last or state.generation % checkpoint_every == 0:
            save(state, force=last)
        if on_generation is not None:
            on_generation(state)

    best = state.archive.best()
    if best is None:  # nothing finite was ever found
        ind = min(state.population, key=lambda i: i.fitness.values[0])
        best = ParetoRow(len(decoder.decode_individual(ind)), ind.fitness.values[0],
                         decoder.decode_individual(ind),
                         tuple(tuple(tree_to_tokens(g)) for g in ind))
    return EvolutionResult(best, state.population, state.logbook,
                           state.archive.rows(), state.evaluations,
                           state.generation, s)
