"""Backward elimination of the terms of a chosen structure.

Typical use (``MGGPRegressor(prune=...)`` calls these)::

    from mggp.fit.pruning import prune_by_criterion, prune_by_t, t_threshold_of
    terms = prune_by_criterion(scorer, terms, n)                  # prune='bic'
    terms = prune_by_t(terms, t_of, t_threshold_of(est, 1))       # prune='t'

* :func:`prune_by_criterion` drops, one at a time, the term whose removal
  lowers the information criterion of the search fitness most, while one
  does (BIC: :math:`n \\ln J + p \\ln n` [1]_).
* :func:`prune_by_t` drops the least significant term while its
  :math:`|t|` is below a threshold, refitting each time; the default
  threshold (:func:`t_threshold_of`) shares a two-sided 5 % level among
  every candidate monomial the search can build (Bonferroni).

References
----------
.. [1] Schwarz, G., "Estimating the dimension of a model", Annals of
   Statistics 6(2), 1978.
"""
from __future__ import annotations

from typing import Callable, Iterator, Tuple

import numpy as np

from narx.language.terms import Term

from ..gp.evaluate import criterion_value
from .local_search import improve

__all__ = ["drops", "prune_by_criterion", "prune_by_t", "bonferroni_t", "t_threshold_of"]


def drops(terms: Tuple[Term, ...]) -> Iterator[Tuple[Term, ...]]:
    """Every structure with one term of ``terms`` fewer (none below one term)."""
    if len(terms) > 1:
        for i in range(len(terms)):
            yield terms[:i] + terms[i + 1:]


def prune_by_criterion(scorer, terms: Tuple[Term, ...], n: int, criterion: str = "bic"):
    """Backward elimination: drop the term whose removal lowers the
    information criterion (of the scorer's fitness, ``n`` samples) most,
    while one does; the drop-only case of :func:`mggp.fit.local_search.improve`."""
    def value(ts):
        return criterion_value(scorer.score(ts), len(ts), n, criterion)
    return improve(tuple(terms), value, drops, max_steps=len(terms))[0]


def prune_by_t(terms, t_of: Callable, crit: float) -> Tuple:
    """Backward elimination: while the least significant of ``terms`` has
    |t| < ``crit`` (``t_of(terms)``, refitted each time), drop it; at least
    one term stays."""
    terms = tuple(terms)
    while len(terms) > 1:
        t = t_of(terms)
        i = int(np.argmin(t))
        if t[i] >= crit:
            break
        terms = terms[:i] + terms[i + 1:]
    return terms


def bonferroni_t(n_inputs: int, max_lag: int, max_degree: int, alpha: float = 0.05) -> float:
    """Two-sided t threshold at level ``alpha`` shared among the
    :math:`m = \\binom{(n_u + 1)L + d}{d} - 1` candidate monomials of
    lags up to ``L`` and degree up to ``d`` (Bonferroni)."""
    from math import comb
    from scipy.stats import norm
    m = comb((n_inputs + 1) * max_lag + max_degree, max_degree) - 1
    return float(norm.ppf(1 - alpha / (2 * m)))


def t_threshold_of(est, n_inputs: int) -> float:
    """An estimator's ``t_threshold``, or by default :func:`bonferroni_t`
    over the monomials its trees can build (lags up to ``max_lag`` but no
    longer than ``max_height`` trees reach: a larger ``max_lag`` has no
    effect; degree up to ``max_degree``, else 3)."""
    if est.t_threshold is not None:
        return float(est.t_threshold)
    from ..gp.primitives import reachable_lag
    return bonferroni_t(n_inputs, reachable_lag(est.max_height_, est.max_lag),
                        est.max_degree or 3)
