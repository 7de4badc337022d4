"""Typed tree generation, MGGP crossover/mutation and selection, all driven
by an explicit ``random.Random`` (never the global ``random`` state).

Typical use::

    import random
    from mggp.gp.primitives import make_pset
    from mggp.gp.operators import (random_individual, cx_high_level,
                                cx_low_level, mut_high_level, mut_low_level)
    pset, rng = make_pset(), random.Random(1)
    a = random_individual(pset, rng, max_terms=15, max_height=5)
    b = random_individual(pset, rng, max_terms=15, max_height=5)
    a, b = cx_high_level(a, b, rng, max_terms=15)
    (a,) = mut_low_level(a, pset, rng, max_height=5)

Conventions (DEAP style): crossovers return the pair, mutations a 1-tuple;
an individual that changed has its fitness deleted and decoded terms
dropped. Genes received from another individual are copied, so no two
individuals share a gene list. Heights are DEAP heights (a lone terminal
is 0); every operator keeps genes at or below ``max_height`` (a child over
the limit is replaced by its parent gene: static limit) and individuals
between 1 and ``max_terms`` genes. Types are respected everywhere, so Φ
arguments remain lagged inputs, all of one input (with several inputs each
has its own lagged-input type, see :mod:`mggp.gp.primitives`): a crossover
only exchanges, and a mutation only regrows, a subtree of the same type.
"""
from __future__ import annotations

import math
import random
from typing import Dict, List, Optional, Sequence

from deap import gp

from .individual import Individual

__all__ = ["gen_tree", "random_individual", "cx_high_level", "cx_low_level",
           "mut_high_level", "mut_low_level", "remove_duplicate_genes",
           "sel_tournament", "node_depths"]


def _min_heights(pset) -> Dict[type, float]:
    """Smallest height of a complete subtree of each type (inf: impossible)."""
    types = set(pset.primitives) | set(pset.terminals)
    h = {t: (0 if pset.terminals.get(t) else math.inf) for t in types}
    changed = True
    while changed:
        changed = False
        for t in types:
            for p in pset.primitives.get(t, ()):
                v = 1 + max(h.get(a, math.inf) for a in p.args)
                if v < h[t]:
                    h[t], changed = v, True
    return h


def _choices(pset, minh) -> Dict[type, List[tuple]]:
    """Per type, ``(room needed, primitives)`` with the primitives of one
    name and need grouped, in order of first appearance: the variants of a
    Φ-function over several inputs, and of an operator over its parameters
    (the part of the name before ``@``), form one choice."""
    table = {}
    for t, prims in pset.primitives.items():
        groups: Dict[tuple, list] = {}
        for p in prims:
            need = 1 + max(minh.get(a, math.inf) for a in p.args)
            # an operator's parameter variants (Play@0.1, Play@0.2) are one choice
            groups.setdefault((p.name.split("@")[0], need), []).append(p)
        table[t] = [(need, g) for (_, need), g in groups.items()]
    return table


def _tables(pset):
    """``(_min_heights, _choices)`` of a set, cached on it until a node is added."""
    key = (pset.prims_count, pset.terms_count)
    cached = getattr(pset, "_gen_tables", None)
    if cached is None or cached[0] != key:
        minh = _min_heights(pset)
        cached = pset._gen_tables = (key, minh, _choices(pset, minh))
    return cached[1], cached[2]


def gen_tree(pset, rng: random.Random, min_height: int, max_height: int,
             type_=None, method: Optional[str] = None) -> gp.PrimitiveTree:
    """Ramped half-and-half tree generation for a typed set.

    A target height is drawn in ``[min_height, max_height]`` and the method
    ("full" or "grow") with probability 1/2 each, unless ``method`` is given.
    Full puts terminals only at the target depth; grow may stop a branch
    after ``min_height`` with probability equal to the share of terminals
    among the candidates of that type. A primitive is only chosen if all its
    arguments can still be completed within the target height; otherwise a
    terminal of the right type is used. The result never exceeds
    ``max_height``.

    Primitives of one name count as one candidate: a Φ-function registered
    once per input (several inputs, see :mod:`mggp.gp.primitives`) is drawn
    like any other primitive, then its input uniformly. So the share of
    Φ-calls does not grow with the number of inputs, and with one input
    (one primitive per name) the draws are those of a plain uniform choice.

    Parameters
    ----------
    pset : deap.gp.PrimitiveSetTyped
    rng : random.Random
    min_height, max_height : int
    type_ : type, optional
        Root type (default ``pset.ret``).
    method : {"full", "grow"}, optional

    Raises
    ------
    ValueError
        If no tree of ``type_`` fits in ``max_height``.
    """
    type_ = pset.ret if type_ is None else type_
    max_height = max(0, int(max_height))
    min_height = min(max(0, int(min_height)), max_height)
    height = rng.randint(min_height, max_height)
    if method is None:
        method = "full" if rng.random() < 0.5 else "grow"
    elif method not in ("full", "grow"):
        raise ValueError(f"method must be 'full' or 'grow', got {method!r}")
    minh, choices = _tables(pset)
    if minh.get(type_, math.inf) > max_height:
        raise ValueError(f"no tree of type {type_.__name__} fits in height {max_height}")
    height = max(height, int(minh[type_]))
    nodes: List = []
    stack = [(0, type_)]
    while stack:
        depth, t = stack.pop()
        room = height - depth
        prims = [g for need, g in choices.get(t, ()) if need <= room]
        terms = pset.terminals.get(t, ())
        if not prims:
            use_term = True
        elif not terms:
            use_term = False
        elif method == "full":
            use_term = False
        else:
            use_term = depth >= min_height and \
                rng.random() < len(terms) / (len(terms) + len(prims))
        if use_term:
            if not terms:
                raise ValueError(f"cannot complete a {t.__name__} branch at depth {depth}")
            nodes.append(terms[rng.randrange(len(terms))])
        else:
            alike = prims[rng.randrange(len(prims))]
            p = alike[0] if len(alike) == 1 else alike[rng.randrange(len(alike))]
            nodes.append(p)
            for a in reversed(p.args):
                stack.append((depth + 1, a))
    return gp.PrimitiveTree(nodes)


def random_individual(pset, rng: random.Random, max_terms: int, max_height: int,
                      min_terms: int = 1, min_height: int = 0) -> Individual:
    """An individual of ``randint(min_terms, max_terms)`` genes, each from
    :func:`gen_tree` with heights ramped over ``[min_height, max_height]``."""
    if not 1 <= min_terms <= max_terms:
        raise ValueError(f"need 1 <= min_terms <= max_terms, got {min_terms}, {max_terms}")
    n = rng.randint(min_terms, max_terms)
    return Individual(gen_tree(pset, rng, min_height, max_height) for _ in range(n))


def _copy(gene) -> gp.PrimitiveTree:
    return gp.PrimitiveTree(gene)


def _truncate(genes: list, max_terms: int, rng: random.Random) -> list:
    while len(genes) > max_terms:
        del genes[rng.randrange(len(genes))]
    return genes


def cx_high_level(ind1: Individual, ind2: Individual, rng: random.Random,
                  max_terms: int):
    """High-level (gene) crossover, two-point style.

    In each parent a non-empty run of consecutive genes is chosen with its
    own cut points; the runs are exchanged, so sizes change. A child longer
    than ``max_terms`` loses random genes; each child keeps at least one.

    Returns
    -------
    (Individual, Individual)
    """
    def segment(n):
        i, j = sorted(rng.sample(range(n + 1), 2))
        return i, j

    a1, b1 = segment(len(ind1))
    a2, b2 = segment(len(ind2))
    c1 = list(ind1[:a1]) + [_copy(g) for g in ind2[a2:b2]] + list(ind1[b1:])
    c2 = list(ind2[:a2]) + [_copy(g) for g in ind1[a1:b1]] + list(ind2[b2:])
    ind1[:] = _truncate(c1, max_terms, rng)
    ind2[:] = _truncate(c2, max_terms, rng)
    ind1.invalidate()
    ind2.invalidate()
    return ind1, ind2


def node_depths(tree) -> List[int]:
    """Depth of every node of a prefix-ordered tree (root 0)."""
    depths, stack = [], [0]
    for node in tree:
        d = stack.pop()
        depths.append(d)
        stack.extend([d + 1] * node.arity)
    return depths


def cx_low_level(ind1: Individual, ind2: Individual, rng: random.Random,
                 max_height: int):
    """Low-level (subtree) crossover between one random gene of each parent.

    The crossing point of the first gene is drawn among its non-root nodes
    whose type occurs in the second gene (the root if it is a lone
    terminal), the point of the second among its nodes of that type. A
    child gene higher than ``max_height`` is dropped and the parent gene
    kept.

    Returns
    -------
    (Individual, Individual)
    """
    i, j = rng.randrange(len(ind1)), rng.randrange(len(ind2))
    g1, g2 = ind1[i], ind2[j]
    types2 = {node.ret for node in g2}
    pts1 = [k for k in range(1, len(g1)) if g1[k].ret in types2] or [0]
    p1 = pts1[rng.randrange(len(pts1))]
    t = g1[p1].ret
    pts2 = [k for k in range(len(g2)) if g2[k].ret is t]
    p2 = pts2[rng.randrange(len(pts2))]
    s1, s2 = g1.searchSubtree(p1), g2.searchSubtree(p2)
    n1 = gp.PrimitiveTree(g1[:s1.start] + g2[s2] + g1[s1.stop:])
    n2 = gp.PrimitiveTree(g2[:s2.start] + g1[s1] + g2[s2.stop:])
    if n1.height <= max_height and list(n1) != list(g1):
        ind1[i] = n1
        ind1.invalidate()
    if n2.height <= max_height and list(n2) != list(g2):
        ind2[j] = n2
        ind2.invalidate()
    return ind1, ind2


def mut_high_level(ind: Individual, pset, rng: random.Random, max_terms: int,
                   max_height: int):
    """High-level mutation: replace a random gene by a new random one, add a
    new gene (if fewer than ``max_terms``) or remove one (if more than one),
    the action drawn uniformly among those allowed.

    Returns
    -------
    (Individual,)
    """
    actions = ["replace"]
    if len(ind) < max_terms:
        actions.append("add")
    if len(ind) > 1:
        actions.append("remove")
    action = actions[rng.randrange(len(actions))]
    if action == "replace":
        ind[rng.randrange(len(ind))] = gen_tree(pset, rng, 0, max_height)
    elif action == "add":
        ind.insert(rng.randint(0, len(ind)), gen_tree(pset, rng, 0, max_height))
    else:
        del ind[rng.randrange(len(ind))]
    ind.invalidate()
    return (ind,)


def mut_low_level(ind: Individual, pset, rng: random.Random, max_height: int):
    """Low-level (subtree) mutation of one random gene.

    A node is drawn uniformly and its subtree replaced by a random tree of
    the same type whose height fits the room left under ``max_height``.

    Returns
    -------
    (Individual,)
    """
    i = rng.randrange(len(ind))
    gene = ind[i]
    depths = node_depths(gene)
    pts = [k for k, d in enumerate(depths) if d <= max_height] or [0]
    p = pts[rng.randrange(len(pts))]
    room = max(0, max_height - depths[p])
    sub = gen_tree(pset, rng, 0, room, type_=gene[p].ret)
    s = gene.searchSubtree(p)
    new = gp.PrimitiveTree(gene[:s.start] + list(sub) + gene[s.stop:])
    if new.height <= max_height and list(new) != list(gene):
        ind[i] = new
        ind.invalidate()
    return (ind,)


def remove_duplicate_genes(ind: Individual, decoder) -> Individual:
    """Drop genes whose term already appears earlier in ``ind``.

    The set of distinct terms (hence the fitness) is unchanged, so the
    fitness is kept. Returns ``ind``.
    """
    keep = [g for _, g in decoder.first_genes(ind)]
    if len(keep) != len(ind):
        values = ind.fitness.values if ind.fitness.valid else None
        ind[:] = keep
        if values is not None:
            ind.fitness.values = values
    return ind


def sel_tournament(individuals: Sequence[Individual], k: int, tournsize: int,
                   rng: random.Random) -> List[Individual]:
    """``k`` tournament winners (aspirants drawn with replacement; the
    lowest fitness wins, the first drawn on ties). Returns references."""
    n = len(individuals)
    chosen = []
    for _ in range(k):
        best = individuals[rng.randrange(n)]
        for _ in range(tournsize - 1):
            a = individuals[rng.randrange(n)]
            if a.fitness.values[0] < best.fitness.values[0]:
                best = a
        chosen.append(best)
    return chosen
