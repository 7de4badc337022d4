"""NARMAX noise models for a searched structure (``noise_lags``).

Typical use (inside :meth:`mggp.MGGPRegressor.fit`)::

    from mggp.fit.noise import select_noise, prune_process
    terms = prune_process(data, terms, full_ma(data, 2, registry), start, registry, 3.6)
    terms = terms + select_noise(data, terms, start, registry, q=2, crit=3.6)

Candidates are ``e[k-j]`` and ``x*e[k-j]`` (x a lag 1..q of an input or the
output), j = 1..q. They are added one at a time by extended least squares
(ELS: the residuals of the previous fit stand in for the noise [1]_) while
the best has |t| >= ``crit``; each step ranks the candidates with the
noise estimate held (one projection each) and fits the ``SCREEN_TOP`` best
by ELS to convergence. With coloured noise a one-step search also
picks process terms that only predict the noise; once the noise model is
in, :func:`prune_process` drops process terms whose ELS t-statistic falls
below ``crit`` (least significant first, refitting each time), with the
full MA(q) model ``e[k-1] .. e[k-q]`` in the fit, before the noise terms
are selected for what remains.

References
----------
.. [1] Billings, S. A., "Nonlinear System Identification: NARMAX Methods in
   the Time, Frequency, and Spatio-Temporal Domains", Wiley, 2013, ch. 3.
"""
from __future__ import annotations

from typing import Optional, Tuple

import numpy as np

from narx import Model
from narx.estimation.estimate import t_statistics
from narx.linalg import added_column_t
from narx.model import ignore_rank_warnings
from narx.records.regressors import regressor_matrix
from narx.language.terms import parse_term

from .pruning import prune_by_t

__all__ = ["select_noise", "prune_process", "els_t", "full_ma"]

#: candidates fitted by ELS at each step of :func:`select_noise`
SCREEN_TOP = 3


def _els(data, terms, start, registry):
    """ELS fit of ``terms``: (|t| of every term, the converged noise
    estimate: the residuals, 0 before the fit's first row)."""
    with ignore_rank_warnings():                 # a trial, not a result
        m = Model(terms, inputs=data.inputs, output=data.output,
                  registry=registry).fit(data)
    noise = np.zeros(data.n)
    noise[m.fit_info_["start"]:] = m.fit_info_["residuals"]
    Psi, target, _ = regressor_matrix(terms, data, noise=noise, start=start,
                                      registry=registry)
    return t_statistics(Psi, target, m.theta), noise


def els_t(data, terms, start, registry) -> np.ndarray:
    """|t| of every term of an ELS fit of ``terms`` (noise terms included)."""
    return _els(data, terms, start, registry)[0]


def _screen(data, terms, cands, noise, start, registry) -> np.ndarray:
    """|t| of each candidate added alone to ``terms``, the noise held at
    ``noise`` (one LS each, by projection on the fitted regressors:
    :func:`narx.linalg.added_column_t`)."""
    Psi, target, _ = regressor_matrix(terms, data, noise=noise, start=start,
                                      registry=registry)
    C, _, _ = regressor_matrix(cands, data, noise=noise, start=start, registry=registry)
    return added_column_t(Psi, target, C)


def full_ma(data, q: int, registry) -> Tuple:
    """The plain MA(q) noise terms ``e[k-1] .. e[k-q]``."""
    sig = data.signals
    return tuple(parse_term(f"{sig.noise}[k-{j}]", sig, registry=registry)
                 for j in range(1, q + 1))


def select_noise(data, terms, start, registry, q: int, crit: float,
                 limit: Optional[int] = None) -> Tuple:
    """Forward selection of MA noise terms by ELS t-statistics, at most
    ``limit`` of them (None: no limit).

    Each step ranks the remaining candidates by their t-statistic with the
    noise estimate held at the current model's (one projection each), fits
    the ``SCREEN_TOP`` best by ELS to convergence, and adds the one with
    the largest converged |t| if it reaches ``crit`` (an ELS fit of every
    candidate at every step takes minutes on 30,000 samples)."""
    sig = data.signals
    cands = []
    for j in range(1, q + 1):
        e = f"{sig.noise}[k-{j}]"
        cands.append(e)
        for name in (sig.output,) + tuple(sig.inputs):
            cands += [f"{name}[k-{i}]*{e}" for i in range(1, q + 1)]
    cands = [parse_term(c, sig, registry=registry) for c in cands]
    chosen = ()
    # the noise of the current model: its ELS residuals (plain LS at first)
    noise = _els(data, terms, start, registry)[1]
    while True:
        rest = [c for c in cands if c not in chosen]
        if not rest or (limit is not None and len(chosen) >= limit):
            return chosen
        # rank the candidates with the noise held, then fit the most
        # promising ones by ELS to convergence and keep the best of those
        screen = _screen(data, terms + chosen, rest, noise, start, registry)
        best = None
        for i in np.argsort(-screen, kind="stable")[:SCREEN_TOP]:
            t, nz = _els(data, terms + chosen + (rest[i],), start, registry)
            if best is None or t[-1] > best[0]:
                best = (t[-1], rest[i], nz)
        if best[0] < crit:
            return chosen
        chosen, noise = chosen + (best[1],), best[2]


def prune_process(data, terms, noise, start, registry, crit: float) -> Tuple:
    """Process ``terms`` whose ELS t-statistic, with the ``noise`` terms in
    the model, is at least ``crit`` (the least significant dropped first)."""
    if not noise:
        return tuple(terms)
    noise = tuple(noise)
    return prune_by_t(terms, lambda ts: els_t(data, ts + noise, start, registry)[:len(ts)],
                      crit)
