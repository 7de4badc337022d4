"""Individuals (lists of gene trees), their fitness, and the Pareto archive.

Typical use::

    from mggp.gp.individual import Individual, ParetoArchive
    ind = Individual([tree1, tree2])      # deap.gp.PrimitiveTree genes
    ind.fitness.values = (0.25,)          # MSE, minimised
    child = ind.clone()                   # genes copied, fitness kept

No DEAP ``creator`` is used: :class:`FitnessMin` and :class:`Individual` are
ordinary classes, so they pickle by reference and several runs with
different settings can share a process.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

from deap import base, gp

from narx.language.terms import Term

__all__ = ["FitnessMin", "Individual", "ParetoRow", "ParetoArchive",
           "fitness_of"]


class FitnessMin(base.Fitness):
    """Single objective, minimised (the MSE of the chosen simulation)."""

    weights = (-1.0,)


class Individual(list):
    """A multi-gene individual: a list of :class:`deap.gp.PrimitiveTree`.

    Attributes
    ----------
    fitness : FitnessMin
    _terms : tuple of narx.language.terms.Term or None
        Decoded distinct terms, filled by
        :meth:`mggp.gp.primitives.Decoder.decode_individual`; cleared by every
        list mutation and by :meth:`invalidate`. Genes are replaced, never
        edited in place (the operators build new trees); code that edits a
        gene in place must call :meth:`invalidate`.
    """

    def __init__(self, genes=()):
        super().__init__(genes)
        self.fitness = FitnessMin()
        self._terms: Optional[Tuple[Term, ...]] = None

    # every in-place change of the gene list drops the decoded terms
    def _touch(self):
        self._terms = None

    def __setitem__(self, key, value):
        super().__setitem__(key, value)
        self._touch()

    def __delitem__(self, key):
        super().__delitem__(key)
        self._touch()

    def __iadd__(self, other):
        r = super().__iadd__(other)
        self._touch()
        return r

    def append(self, gene):
        super().append(gene)
        self._touch()

    def insert(self, i, gene):
        super().insert(i, gene)
        self._touch()

    def extend(self, genes):
        super().extend(genes)
        self._touch()

    def pop(self, i=-1):
        g = super().pop(i)
        self._touch()
        return g

    def remove(self, gene):
        super().remove(gene)
        self._touch()

    def clear(self):
        super().clear()
        self._touch()

    def sort(self, *args, **kwargs):
        super().sort(*args, **kwargs)
        self._touch()

    def reverse(self):
        super().reverse()
        self._touch()

    def invalidate(self) -> None:
        """Forget decoded terms and fitness (after a genetic operator)."""
        self._terms = None
        if self.fitness.valid:
            del self.fitness.values

    def clone(self) -> "Individual":
        """Copy with new gene lists (nodes are immutable and shared)."""
        new = Individual(gp.PrimitiveTree(g) for g in self)
        if self.fitness.valid:
            new.fitness.values = self.fitness.values
        new._terms = self._terms
        return new

    def __deepcopy__(self, memo):
        return self.clone()

    def __reduce__(self):
        return (_rebuild, (list(map(list, self)), self.fitness.values))

    def __repr__(self):
        fit = self.fitness.values[0] if self.fitness.valid else None
        return f"Individual({[str(g) for g in self]!r}, fitness={fit!r})"


def _rebuild(genes, values):
    ind = Individual(gp.PrimitiveTree(g) for g in genes)
    if values:
        ind.fitness.values = values
    return ind


def fitness_of(ind) -> float:
    """The (minimised) fitness of an evaluated individual."""
    return ind.fitness.values[0]


@dataclass(frozen=True)
class ParetoRow:
    """One model of the archive.

    Attributes
    ----------
    complexity : int
        Number of distinct terms.
    fitness : float
    terms : tuple of narx.language.terms.Term
    genes : tuple of tuple of str
        Node names of the genes of the first individual with these terms.
    """

    complexity: int
    fitness: float
    terms: Tuple[Term, ...]
    genes: Tuple[Tuple[str, ...], ...] = ()

    @property
    def term_texts(self) -> List[str]:
        return [t.text for t in self.terms]


class ParetoArchive:
    """Best model per complexity over a whole run; :meth:`rows` is the
    non-dominated front (fewer terms or lower fitness).

    Ties keep the first model seen, so the archive is deterministic for a
    given order of updates. Non-finite fitness is never archived.
    """

    def __init__(self):
        self._best: Dict[int, ParetoRow] = {}

    def update(self, terms: Sequence[Term], fitness: float,
               genes: Sequence[Sequence[str]] = ()) -> bool:
        """Offer a model; returns True if it became the best of its size."""
        if not math.isfinite(fitness):
            return False
        c = len(terms)
        old = self._best.get(c)
        if old is not None and old.fitness <= fitness:
            return False
        self._best[c] = ParetoRow(c, float(fitness), tuple(terms),
                                  tuple(tuple(g) for g in genes))
        return True

    def best_per_complexity(self) -> List[ParetoRow]:
        return [self._best[c] for c in sorted(self._best)]

    def rows(self) -> List[ParetoRow]:
        """Non-dominated rows by increasing complexity (decreasing fitness)."""
        out, best = [], math.inf
        for row in self.best_per_complexity():
            if row.fitness < best:
                out.append(row)
                best = row.fitness
        return out

    def best(self) -> Optional[ParetoRow]:
        """Lowest fitness (fewest terms on ties), or None if empty."""
        rows = self.rows()
        return rows[-1] if rows else None

    def __len__(self):
        return len(self._best)

    def restore(self, rows: Sequence[ParetoRow]) -> None:
        """Replace the content (used when resuming from a checkpoint)."""
        self._best = {r.complexity: r for r in rows}
