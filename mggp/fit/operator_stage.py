r"""Memory-operator terms added to a searched structure, stepwise.

Typical use (``MGGPRegressor(operators="play,dengtan")`` does this after
the search)::

    from narx.estimation.fitness import StructureScorer
    from mggp.fit.operator_stage import operator_candidates, add_operators
    scorer = StructureScorer(data, "ms", window=100, start=16)
    cands = operator_candidates(data, ("play", "dengtan"))
    terms, steps = add_operators(scorer, terms, cands, max_terms=15)

With ``operator_entry='stage'`` (the default) the memory operators of
:mod:`narx.language.memory` do not join the primitive set of the search: the search
runs on the set it would have without them, and this stage then offers the
operator columns to the structure it chose.

1. *Forward*: among the candidates (:func:`operator_candidates`: a play of
   each radius of :func:`mggp.gp.primitives.play_radii`, the Deng-Tan operator
   and a Bouc-Wen variable of each shape of
   :func:`mggp.gp.primitives.bouc_wen_shapes`, as named, of each input at
   :math:`k-1`), the one that lowers the search fitness :math:`J`
   most is added while it lowers it by at least :data:`OPERATOR_GAIN`
   (:math:`J_{new} \le (1 - 0.05) J`).
2. *Backward*, only if an operator was added: the term whose removal raises
   :math:`J` least is dropped while that raise is at most
   :data:`OPERATOR_KEEP` (1 %), and while the structure has more than
   ``max_terms`` terms; terms the operators made redundant go.

Why a stage and not the search: an operator column is an exact memory
signal of the input, so random individuals that hold one score far better
than those that do not, even where it is not the system's mechanism. On a
Bouc-Wen record (the piezo case study) a search with operators in its
primitive set converges on operator structures before the lag and Φ terms
are assembled and ends at a worse fitness than the same search without
them; drawing operators only by mutation leaves a smaller handicap, and
still a worse validation error. Offered to the finished structure, an
operator enters only where it lowers the fitness by 5 %; where it does not
the result is exactly that of the search without operators. Forward
selection of regressors by their reduction of a fitting error is the
classical stepwise construction of NARX models [1]_.

References
----------
.. [1] S. A. Billings, *Nonlinear System Identification: NARMAX Methods in
   the Time, Frequency, and Spatio-Temporal Domains*, Wiley, 2013, ch. 3.
"""
from __future__ import annotations

from typing import List, Sequence, Tuple

from narx.language.terms import Term, format_param, parse_term

__all__ = ["OPERATOR_GAIN", "OPERATOR_KEEP", "operator_candidates", "add_operators"]

#: an operator term is added when it lowers the fitness by at least this share
OPERATOR_GAIN = 0.05
#: after additions, a term is dropped when removing it raises the fitness by at most this share
OPERATOR_KEEP = 0.01


def operator_candidates(data, names) -> List[Term]:
    """Operator terms offered to a structure: for each input ``n`` of
    ``data``, the operators of the search on that input alone
    (:func:`mggp.gp.primitives.search_operators`) at lag 1, in the order of
    ``names``: ``Play(n[k-1],r)`` for each radius of
    :func:`mggp.gp.primitives.play_radii` (``play``), ``DengTan(n[k-1])``
    (``dengtan``), ``BoucWen(n[k-1],β,γ)`` for each shape of
    :func:`mggp.gp.primitives.bouc_wen_shapes` (``boucwen``)."""
    from ..gp.primitives import search_operators
    out = []
    for n in data.inputs:
        for op, params in search_operators(names, data.input(n)).items():
            out += [parse_term(f"{op}({n}[k-1]" + "".join("," + format_param(x) for x in p)
                               + ")", data.signals) for p in params]
    return out


def add_operators(scorer, terms: Sequence[Term], candidates: Sequence[Term], max_terms: int,
                  keep: Sequence[Term] = ()) -> Tuple[Tuple[Term, ...], List[dict]]:
    """Forward addition of operator terms, then backward removal (module notes).

    Parameters
    ----------
    scorer : narx.estimation.fitness.StructureScorer
        ``scorer.score(terms)`` is the fitness :math:`J` (lower is better).
    terms : sequence of Term
        The searched structure.
    candidates : sequence of Term
        Operator terms that may be added (:func:`operator_candidates`).
    max_terms : int
        The backward step removes terms while there are more than this.
    keep : sequence of Term
        Terms never removed (the constant term of ``constant=True``).

    Returns
    -------
    (tuple of Term, list of dict)
        The structure, and one ``{"step": "add"|"drop", "term", "fitness"}``
        per change (empty: ``terms`` unchanged).
    """
    cur = list(terms)
    fit = scorer.score(cur)
    steps: List[dict] = []
    while True:
        trials = [(scorer.score(cur + [c]), i) for i, c in enumerate(candidates)
                  if c not in cur]
        if not trials:
            break
        best, i = min(trials)
        if not best <= (1.0 - OPERATOR_GAIN) * fit:
            break
        cur.append(candidates[i])
        fit = best
        steps.append({"step": "add", "term": candidates[i].text, "fitness": best})
    while steps and len(cur) > 1:
        trials = [(scorer.score(cur[:j] + cur[j + 1:]), j) for j, t in enumerate(cur)
                  if t not in keep]
        if not trials:
            break
        worse, j = min(trials)
        if not (worse <= (1.0 + OPERATOR_KEEP) * fit or len(cur) > max_terms):
            break
        steps.append({"step": "drop", "term": cur[j].text, "fitness": worse})
        del cur[j]
        fit = worse
    return tuple(cur), steps
