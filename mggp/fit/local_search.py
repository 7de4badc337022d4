"""Local search on a chosen structure: one-term moves while the fitness improves.

Typical use (``MGGPRegressor(local_search=True)``, the default, does this)::

    from mggp.fit.local_search import improve, term_moves
    moves = term_moves(signals, lags=range(1, 5), max_degree=3, allowed=est._allowed)
    terms, steps = improve(terms, score, moves, passes=screen_ok)

The genetic search recombines whole trees; a structure it ends on can be
one small edit away from a better one (a term ``y[k-1]*y[k-1]*y[k-3]``
where the system has ``y[k-1]**3``) that crossover and mutation of random
subtrees find only by chance. :func:`improve` climbs from the chosen
structure :math:`\\mathcal{T}` to its best neighbour while that lowers the
search's own fitness :math:`J` (the simulation MSE, or the BIC/AIC
:math:`n \\ln J + p \\ln n` of it),

.. math:: \\mathcal{T}_{i+1} = \\arg\\min_{\\mathcal{T}' \\in N(\\mathcal{T}_i)}
          J(\\mathcal{T}'), \\qquad \\text{while } J(\\mathcal{T}_{i+1}) < J(\\mathcal{T}_i),

the neighbourhood :math:`N` (:func:`term_moves`) being every structure
that differs in one term: the term dropped, one of its lagged-signal
factors replaced by another lagged signal, dropped or joined by one more
(new factors: any signal at a lag within :data:`LAG_STEP` samples of the
term's own lags, which keeps a step's cost linear in the number of lags).
When dropping a term improves :math:`J` (or leaves it equal, as on a
noise-free record whose errors the caller floors at rounding), the best
such drop is taken before any replacement, so that a spurious term leaves
the model instead of being traded for the one that fits the noise best.
Φ-calls and memory operators stay as the search built them: their term may
be dropped or joined by a lagged signal, the call itself is not changed.
This is the hybrid of evolutionary and local search called memetic
(Moscato, "On evolution, search, optimization, genetic algorithms and
martial arts", Caltech C3P report 826, 1989); for term
selection in NARX models compare the forward-backward moves of Piroddi and
Spinelli (Int. J. Control 76(17), 2003).
"""
from __future__ import annotations

from typing import Callable, Iterable, Iterator, List, Optional, Sequence, Tuple

from narx.language.terms import Lag, Term

__all__ = ["improve", "term_moves", "LocalStep", "moves_text"]

#: neighbours of a step that are checked by ``passes`` (best first) before
#: the search stops
CHECKED = 5

#: a replaced or added factor is a signal at a lag within this many samples
#: of the term's own lags
LAG_STEP = 2


class LocalStep(tuple):
    """One accepted move: ``(removed, added, fitness)`` (a term text or
    None for each side)."""

    __slots__ = ()

    def to_dict(self) -> dict:
        return {"removed": self[0], "added": self[1], "fitness": self[2]}


def term_moves(signals, lags: Iterable[int], max_degree: int,
               allowed: Callable[[Term], bool] = lambda t: True) -> Callable:
    """The neighbourhood of a structure: a function ``terms -> iterator of
    structures`` differing from ``terms`` in one term (see the module).

    Parameters
    ----------
    signals : Signals
        The record's output and inputs; factors are lags of these.
    lags : iterable of int
        The lags a new factor may take (those near the term's own are used).
    max_degree : int
        Largest number of factors of a changed term.
    allowed : callable
        Whether a changed term may enter a structure (the search's rule).
    """
    names = [(signals.output, "y")] + [(u, "u") for u in signals.inputs]
    lags = sorted(set(int(k) for k in lags))

    def near(ks) -> List[Lag]:
        """Every signal at the lags within :data:`LAG_STEP` of ``ks``."""
        keep = {k for k in lags if any(abs(k - j) <= LAG_STEP for j in ks)}
        return [Lag(s, k, role) for s, role in names for k in sorted(keep)]

    def variants(t: Term) -> List[Term]:
        out = set()
        own = [f.lag for f in t.factors if isinstance(f, Lag)] or lags[:1]
        for j, f in enumerate(t.factors):
            if not isinstance(f, Lag) or f.role == "e":
                continue
            others = t.factors[:j] + t.factors[j + 1:]
            if others:
                out.add(Term(others))
            out.update(Term(others + (g,)) for g in near([f.lag]) if g != f)
        if t.degree < max_degree:
            out.update(Term(t.factors + (g,)) for g in near(own))
        out.discard(t)
        return sorted(out, key=str)

    def moves(terms: Tuple[Term, ...]) -> Iterator[Tuple[Term, ...]]:
        present = set(terms)
        for i, t in enumerate(terms):
            if not t.factors:                           # the constant stays
                continue
            rest = terms[:i] + terms[i + 1:]
            if rest:
                yield rest
            if t.has_noise:
                continue
            for v in variants(t):
                if v not in present and allowed(v):
                    yield terms[:i] + (v,) + terms[i + 1:]
    return moves


def moves_text(steps, term=str) -> str:
    """The moves of ``steps`` (:meth:`LocalStep.to_dict` rows) in one line,
    ``local search: N one-term move(s): ...``: ``old -> new`` for a
    replacement, ``+new`` for an addition, ``-old`` for a drop; ``term``
    formats each term's text (e.g. as Markdown code)."""
    moves = ", ".join(f"{term(s['removed'])} -> {term(s['added'])}" if s["added"] and s["removed"]
                      else f"+{term(s['added'])}" if s["added"] else f"-{term(s['removed'])}"
                      for s in steps)
    return f"local search: {len(steps)} one-term move(s): {moves}"


def _change(old: Sequence[Term], new: Sequence[Term]) -> Tuple[Optional[str], Optional[str]]:
    a, b = set(old), set(new)
    gone, came = sorted(map(str, a - b)), sorted(map(str, b - a))
    return (gone[0] if gone else None), (came[0] if came else None)


def improve(terms: Sequence[Term], score: Callable[[Tuple[Term, ...]], float],
            moves: Callable, passes: Optional[Callable] = None,
            max_steps: int = 50, max_evals: Optional[int] = None
            ) -> Tuple[Tuple[Term, ...], List[LocalStep]]:
    """Best-improvement hill climbing from ``terms`` (see the module).

    Parameters
    ----------
    terms : sequence of Term
        The starting structure.
    score : callable
        Structure -> fitness to minimise (``inf``: cannot be fitted).
    moves : callable
        Structure -> iterator of neighbouring structures (:func:`term_moves`).
    passes : callable, optional
        Structure -> bool: a neighbour is accepted only if it passes (e.g.
        the search's stability screen); the best :data:`CHECKED` improving
        neighbours are tried in order.
    max_steps : int
        Most moves accepted.
    max_evals : int, optional
        No step starts once this many structures have been scored.

    Returns
    -------
    terms : tuple of Term
        The structure where no neighbour improves (or after ``max_steps``).
    steps : list of LocalStep
        The accepted moves, in order.
    """
    terms = tuple(terms)
    cur = score(terms)
    steps: List[LocalStep] = []
    evals = 1
    while len(steps) < max_steps and (max_evals is None or evals < max_evals):
        cands = list(moves(terms))
        # drops are scored first: one that keeps or improves J is taken before
        # any replacement, so a spurious term leaves the model instead of being
        # traded for the spurious term that fits the noise best (and the many
        # replacements are scored only when no drop will do)
        better = []
        for is_drop in (True, False):
            trials = sorted((score(ts), k, ts) for k, ts in enumerate(cands)
                            if (len(ts) < len(terms)) == is_drop)
            evals += len(trials)
            better = [(v, ts) for v, _, ts in trials
                      if v < cur or (is_drop and v == cur)][:CHECKED]
            if better:
                break
        nxt = next(((v, ts) for v, ts in better if passes is None or passes(ts)), None)
        if nxt is None:
            break
        cur = nxt[0]
        steps.append(LocalStep(_change(terms, nxt[1]) + (float(cur),)))
        terms = nxt[1]
    return terms, steps
