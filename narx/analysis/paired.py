r"""Paired comparison of two models on the same samples: a circular block bootstrap.

Typical use::

    import numpy as np
    from narx.analysis.paired import paired_test, holm
    t = paired_test(e_simple, e_rich, np.random.default_rng(3))   # free-run errors
    t.p_value            # one-sided: the second model's loss is lower on average
    t.block              # the block length, from the data (Politis and White 2004)
    t.spread(np.sqrt)    # bootstrap standard deviation of RMSE_simple - RMSE_rich
    holm([0.01, 0.04, 0.3])                  # Holm-adjusted p-values

This is the one paired test of the project: the automatic choices of
``mggp fit`` (:mod:`mggp.fit.choices`, held-out squared errors, the two ends
of a record as two segments) and the verdict of ``mggp diagnose``
(:mod:`mggp.diagnose.verdict`, log loss on the selection samples) both call
:func:`paired_test`.

**Statistic.** Two models simulated over the same samples give errors
:math:`e^a_k, e^b_k` and losses :math:`L^a_k = L(e^a_k)`, :math:`L^b_k =
L(e^b_k)`: the squared error :math:`L(e) = e^2`, or with a ``floor`` δ the
log loss :math:`L(e) = \ln(e^2 + δ^2)`. With the differences :math:`d_k =
L^a_k - L^b_k` the null hypothesis is :math:`E[d] \le 0` (``b`` is no
better) against :math:`E[d] > 0` — the Diebold–Mariano comparison of
predictive accuracy [1]_. The log loss asks whether ``b`` is better at
*most* samples, errors below δ counting as equal; the squared loss of a
free run is dominated by its few largest excursions (on a play record
whose baseline error was two slow excursions, a candidate with a 20-fold
lower RMSE got p = 0.03 under the squared loss).

**Bootstrap.** A free-run error wanders slowly, so the :math:`d_k` are
serially dependent. The null distribution of :math:`\bar d` is taken from
a *circular block bootstrap* [2]_ [3]_ of the centred differences
:math:`c_k = d_k - \bar d_s` (:math:`\bar d_s` the mean of the segment
holding k): within each segment of :math:`m` samples, :math:`\lceil
m/\ell\rceil` blocks of :math:`\ell` consecutive samples (wrapping around
the segment's end; the last one cut to fill exactly :math:`m`) start at
points drawn uniformly from :math:`0, \dots, m-1`. Segments are parts of
the samples that are not contiguous in time (the two held-out ends of a
record); a resample keeps every segment's length. The bootstrap's own
variance of a segment's sum is :math:`m\,\overline{S^2}/\ell` (:math:`S`
the circular block sums of length :math:`\ell`): a Bartlett window, biased
low by :math:`O(1/\ell)` for correlated differences — it made the test
reject 9 % of true nulls at α = 0.05 for AR(1) errors with φ = 0.9 and
n = 500. Each segment's resampled sums are therefore rescaled to the
flat-top long-run variance estimate :math:`\hat g` of :func:`block_length`
when that is larger (Politis and Romano 1995 [4]_): the rate became
5.3 %, 4.0 %, 6.0 % for n = 500, 1000, 2000 (400 pairs each); for
differences correlated over a large share of the record (φ = 0.98,
n = 500) it remains liberal (14 %).

**p-value.** From :math:`B` resampled centred means :math:`\bar c^*_b`,

.. math::  p = \frac{1 + \#\{b : \bar c^*_b \ge \bar d\}}{1 + B},

the share of the resamples under the null that reach the observed mean
(Hall and Wilson 1991 [6]_); when fewer than :data:`TAIL_HITS` of them do
(p below the draws' resolution) it is the normal tail :math:`1 -
\Phi(\bar d / s^*)`, :math:`s^*` the standard deviation of the
:math:`\bar c^*_b`, capped at the count's value, so that small p-values
stay ordered for Holm's correction and small levels.

**Block length.** :func:`block_length`: the Politis–White automatic choice
for the circular block bootstrap [5]_ (with the correction of Patton,
Politis and White), computed from the differences themselves; with
segments, the largest of the segments' choices, at most the shortest
segment. It grows with the correlation time; for white differences it is
about :math:`n^{1/3}` or shorter.

**Several comparisons.** Several candidates against one baseline are
corrected for multiplicity by Holm's step-down procedure (:func:`holm`)
[7]_, which holds the family-wise error rate at α without assuming
independence.

The resampling uses only the generator passed in (``numpy.random.
default_rng(seed)``): a given generator state gives the same result, and
no global random state is read or changed.

References
----------
.. [1] F. X. Diebold and R. S. Mariano, "Comparing predictive accuracy",
   *J. Bus. Econ. Stat.* 13(3) (1995) 253-263.
.. [2] H. R. Künsch, "The jackknife and the bootstrap for general
   stationary observations", *Ann. Statist.* 17(3) (1989) 1217-1241.
.. [3] D. N. Politis and J. P. Romano, "A circular block-resampling
   procedure for stationary data", in *Exploring the Limits of
   Bootstrap*, Wiley, 1992, 263-270; "The stationary bootstrap",
   *J. Amer. Statist. Assoc.* 89 (1994) 1303-1313.
.. [4] D. N. Politis and J. P. Romano, "Bias-corrected nonparametric
   spectral estimation", *J. Time Series Anal.* 16(1) (1995) 67-103.
.. [5] D. N. Politis and H. White, "Automatic block-length selection for
   the dependent bootstrap", *Econometric Rev.* 23(1) (2004) 53-70;
   A. Patton, D. N. Politis and H. White, "Correction to ...",
   *Econometric Rev.* 28(4) (2009) 372-375.
.. [6] P. Hall and S. R. Wilson, "Two guidelines for bootstrap hypothesis
   testing", *Biometrics* 47 (1991) 757-762.
.. [7] S. Holm, "A simple sequentially rejective multiple test
   procedure", *Scand. J. Statist.* 6(2) (1979) 65-70.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional, Sequence

import numpy as np

__all__ = ["BOOTSTRAP_DRAWS", "TAIL_HITS", "PairedTest", "block_length", "paired_bootstrap",
           "paired_test", "holm"]

#: bootstrap replicates B of the paired test (p-values resolve to 1/1000)
BOOTSTRAP_DRAWS = 999
#: fewer resampled means than this at or beyond the observed one: the
#: p-value is the normal tail of the resampled means instead (small
#: p-values stay ordered, as a level below 10/B needs)
TAIL_HITS = 10


def _autocov(x: np.ndarray, maxlag: int) -> np.ndarray:
    """Sample autocovariances :math:`\\hat R(0..maxlag)` (divisor n)."""
    x = x - x.mean()
    n = x.size
    f = np.fft.rfft(x, 2 * n)
    return np.fft.irfft(f * np.conj(f))[:maxlag + 1] / n


def block_length(d) -> int:
    """Circular-block-bootstrap block length of the series ``d``
    (:func:`_block_and_variance`, which says how)."""
    return _block_and_variance(d)[0]


def _block_and_variance(d):
    r"""Politis–White block length of the circular block bootstrap of ``d``
    and the flat-top long-run variance.

    With :math:`\hat R(k)` the sample autocovariances of the n values and
    the flat-top lag window :math:`\lambda(t) = 1` for :math:`|t| \le 1/2`,
    :math:`2(1 - |t|)` for :math:`1/2 < |t| \le 1`, 0 beyond,

    .. math::  \hat G = \sum_{|k| \le M} \lambda(k/M)\,|k|\,\hat R(k),\quad
               \hat g = \sum_{|k| \le M} \lambda(k/M)\,\hat R(k),\quad
               \ell = \Bigl(\frac{2 \hat G^2}{\tfrac43 \hat g^2}\Bigr)^{1/3} n^{1/3},

    where :math:`M = 2\hat m` and :math:`\hat m` is the smallest lag after
    which :math:`K_n = \max(5, \lceil\sqrt{\log_{10} n}\rceil)` consecutive
    autocorrelations lie within :math:`\pm 2\sqrt{\log_{10} n / n}` (lags
    scanned up to :math:`\lceil\sqrt n\rceil + K_n`).

    Returns
    -------
    (int, float)
        ℓ rounded, within :math:`[1, n/4]` (1 for fewer than 8 values or
        none varying), and :math:`v = \max(\hat g, \hat R(0))`, the flat-top
        estimate of the long-run variance :math:`\sum_k R(k)` (Politis and
        Romano 1995, nearly unbiased).
    """
    d = np.asarray(d, dtype=float)
    n = d.size
    if n < 8:
        return 1, float(np.var(d)) if n else 0.0
    top = max(1, n // 4)
    mmax = min(n - 1, int(math.ceil(math.sqrt(n))) + max(5, int(math.sqrt(math.log10(n)))))
    R = _autocov(d, mmax)
    if not R[0] > 0:
        return 1, 0.0
    rho = R / R[0]
    kn = max(5, int(math.ceil(math.sqrt(math.log10(n)))))
    c = 2.0 * math.sqrt(math.log10(n) / n)
    small = np.abs(rho[1:]) < c                  # small[j] is lag j + 1
    m_hat = None
    for m in range(0, mmax - kn + 1):
        if np.all(small[m:m + kn]):
            m_hat = m
            break
    if m_hat is None:
        m_hat = mmax - kn
    M = min(2 * max(m_hat, 1), mmax)
    k = np.arange(-M, M + 1)
    t = np.abs(k) / M
    lam = np.where(t <= 0.5, 1.0, np.where(t <= 1.0, 2.0 * (1.0 - t), 0.0))
    Rk = R[np.abs(k)]
    G = float(np.sum(lam * np.abs(k) * Rk))
    g = float(np.sum(lam * Rk))
    D = 4.0 / 3.0 * g ** 2
    v = max(g, float(R[0]))
    if not (D > 0 and np.isfinite(G)):
        return 1, v
    b = (2.0 * G * G / D) ** (1.0 / 3.0) * n ** (1.0 / 3.0)
    return int(min(max(1, round(b)), top)), v


def _circular_sums(x: np.ndarray, length: int) -> np.ndarray:
    """``S[j] = x[j] + ... + x[j + length - 1]``, indices modulo ``x.size``."""
    m = x.size
    cs = np.concatenate([[0.0], np.cumsum(np.concatenate([x, x[:length]]))])
    return cs[length:length + m] - cs[:m]


@dataclass(frozen=True)
class PairedTest:
    """One paired comparison (:func:`paired_test`, :func:`paired_bootstrap`).

    Attributes
    ----------
    mean_difference : float
        :math:`\\bar d`, the mean of loss ``a`` − loss ``b`` (> 0: ``b`` is
        better on these samples; ±inf when one simulation diverged).
    p_value : float
        One-sided p-value of "``b`` has the lower mean loss".
    block : int
        Block length of the bootstrap (0 when no bootstrap was needed: a
        diverged simulation, fewer than 8 samples or equal losses decide).
    n : int
        Number of loss differences.
    se : float
        Bootstrap standard deviation of :math:`\\bar d` (NaN without a bootstrap).
    a_star, b_star : ndarray or None
        The resampled mean losses of ``a`` and ``b`` (the same blocks for
        both, not rescaled), None without a bootstrap.
    """

    mean_difference: float
    p_value: float
    block: int
    n: int
    se: float = float("nan")
    a_star: Optional[np.ndarray] = None
    b_star: Optional[np.ndarray] = None

    def spread(self, f: Callable = np.sqrt) -> float:
        """Bootstrap standard deviation of ``f(mean loss a) - f(mean loss b)``
        (``f = np.sqrt`` on squared errors: of the RMSE difference); NaN
        without a bootstrap."""
        if self.a_star is None or self.a_star.size < 2:
            return float("nan")
        return float(np.std(f(self.a_star) - f(self.b_star), ddof=1))


def _segments(n: int, segments) -> list:
    lengths = [n] if segments is None else [int(m) for m in segments]
    if not lengths or sum(lengths) != n or min(lengths) < 1:
        raise ValueError(f"segments must be positive lengths adding up to the {n} samples, "
                         f"got {list(segments)}")
    return lengths


def paired_bootstrap(loss_a, loss_b, rng: np.random.Generator, *,
                     draws: int = BOOTSTRAP_DRAWS, block: Optional[int] = None,
                     segments: Optional[Sequence[int]] = None) -> PairedTest:
    r"""Circular block bootstrap of the paired loss difference ``loss_a -
    loss_b`` (module doc: resampling, variance rescaling, p-value): is
    ``b``'s mean loss lower than ``a``'s beyond what the dependence of the
    samples lets chance make?

    Parameters
    ----------
    loss_a, loss_b : array_like, shape (n,)
        Per-sample losses of the two models on the same samples, finite.
    rng : numpy.random.Generator
        Source of the block starts (``numpy.random.default_rng(seed)``).
    draws : int
        Bootstrap replicates B, at least 19.
    block : int, optional
        Block length ℓ; default :func:`block_length` of the differences (with
        ``segments``: the largest of the segments', at most the shortest
        segment).
    segments : sequence of int, optional
        Lengths of consecutive parts of the samples that are not contiguous
        in time (e.g. the two ends of a record held out in turn); blocks are
        drawn within each. Default: one segment.

    Returns
    -------
    PairedTest
    """
    a = np.asarray(loss_a, dtype=float).ravel()
    b = np.asarray(loss_b, dtype=float).ravel()
    if a.shape != b.shape or a.size == 0:
        raise ValueError(f"loss_a and loss_b must be non-empty and of equal length, got "
                         f"{a.size} and {b.size}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("loss_a and loss_b must be finite")
    if int(draws) < 19:
        raise ValueError(f"draws must be at least 19, got {draws!r}")
    reps, n = int(draws), a.size
    lengths = _segments(n, segments)
    offsets = np.cumsum([0] + lengths[:-1])
    d = a - b
    dbar = float(d.mean())
    if n < 8 or not np.ptp(d) > 0:
        return PairedTest(dbar, 1.0 if dbar <= 0 else 1.0 / (reps + 1), 0, n,
                          0.0 if n >= 8 else float("nan"))
    parts = [(o, m, _block_and_variance(d[o:o + m])) for o, m in zip(offsets, lengths)]
    ell = max(bv[0] for _, _, bv in parts) if block is None else int(block)
    if block is None:
        ell = min(ell, min(lengths))
    elif not 1 <= ell <= min(lengths):
        raise ValueError(f"block must be within 1..{min(lengths)} (the samples of the "
                         f"shortest segment), got {block!r}")
    total = np.zeros(reps)
    a_tot, b_tot = np.zeros(reps), np.zeros(reps)
    for o, m, (_, lrv) in parts:
        ds, as_, bs = d[o:o + m], a[o:o + m], b[o:o + m]
        c = ds - float(ds.mean())
        S = _circular_sums(c, ell)
        # the bootstrap's own variance of n·mean is mean(S²)/ℓ (a Bartlett
        # window of width ℓ, biased low by O(1/ℓ)); rescaled to the flat-top
        # estimate of the long-run variance when that is larger
        boot = float(np.mean(S * S)) / ell
        scale = math.sqrt(lrv / boot) if boot > 0 and lrv > boot else 1.0
        nb = -(-m // ell)
        starts = rng.integers(0, m, size=(reps, nb))
        last = m - (nb - 1) * ell                  # the last block fills exactly m
        head, tail = starts[:, :-1], starts[:, -1]
        total += scale * (S[head].sum(axis=1) + _circular_sums(c, last)[tail])
        for x, acc in ((as_, a_tot), (bs, b_tot)):
            acc += _circular_sums(x, ell)[head].sum(axis=1) + _circular_sums(x, last)[tail]
    means = total / n
    hits = int(np.sum(means >= dbar))
    if hits >= TAIL_HITS:
        p = (1.0 + hits) / (reps + 1.0)
    else:                      # beyond the draws' resolution: the normal tail
        sd = float(np.std(means))
        p = float(0.5 * math.erfc(dbar / (sd * math.sqrt(2.0)))) if sd > 0 else 0.0
        p = min(p, (1.0 + hits) / (reps + 1.0))
    return PairedTest(dbar, p, ell, n, float(np.std(means, ddof=1)), a_tot / n, b_tot / n)


def paired_test(e_a, e_b, rng: np.random.Generator, draws: int = BOOTSTRAP_DRAWS,
                floor: Optional[float] = None,
                segments: Optional[Sequence[int]] = None) -> PairedTest:
    r"""One-sided test that the errors ``e_b`` have the smaller loss than
    ``e_a`` (module doc: statistic, bootstrap, references), by
    :func:`paired_bootstrap` of their losses.

    Parameters
    ----------
    e_a, e_b : array_like, shape (n,)
        Free-run errors of the two models on the same samples (``a`` the
        simpler, or the baseline); a non-finite value means that
        simulation diverged.
    rng : numpy.random.Generator
        Source of the bootstrap's block starts.
    draws : int
        Bootstrap replicates B, at least 19.
    floor : float, optional
        None: squared-error loss :math:`L(e) = e^2`. A value δ > 0: the log
        loss :math:`L(e) = \ln(e^2 + δ^2)` (errors below δ count as equal).
    segments : sequence of int, optional
        Lengths of parts of the samples not contiguous in time
        (:func:`paired_bootstrap`).

    Returns
    -------
    PairedTest
        A ``b`` that diverges where ``a`` does not has p = 1; an ``a`` that
        diverges where ``b`` does not gives p = 1/(B + 1).
    """
    a = np.asarray(e_a, dtype=float)
    b = np.asarray(e_b, dtype=float)
    if a.shape != b.shape or a.ndim != 1:
        raise ValueError(f"e_a and e_b must be 1-D of one length, got shapes "
                         f"{a.shape} and {b.shape}")
    if int(draws) < 19:
        raise ValueError(f"draws must be at least 19, got {draws!r}")
    n = a.size
    fa, fb = bool(np.all(np.isfinite(a))), bool(np.all(np.isfinite(b)))
    if not fb:
        return PairedTest(-math.inf if fa else math.nan, 1.0, 0, n)
    if not fa:
        return PairedTest(math.inf, 1.0 / (int(draws) + 1), 0, n)
    if floor is None:
        la, lb = a * a, b * b
    elif floor > 0:
        la, lb = np.log(a * a + floor * floor), np.log(b * b + floor * floor)
    else:
        raise ValueError(f"floor must be positive or None, got {floor!r}")
    return paired_bootstrap(la, lb, rng, draws=draws, segments=segments)


def holm(p_values: Sequence[float]) -> np.ndarray:
    r"""Holm step-down adjusted p-values (Holm 1979, module references).

    With the m p-values sorted, :math:`p_{(1)} \le \dots \le p_{(m)}`, the
    adjusted values are :math:`\tilde p_{(i)} = \max_{j \le i}
    \min(1, (m - j + 1)\, p_{(j)})`; rejecting where :math:`\tilde p \le α`
    holds the family-wise error rate at α. Returned in the input's order.
    """
    p = np.asarray(p_values, dtype=float)
    m = p.size
    if m == 0:
        return p.copy()
    order = np.argsort(p, kind="stable")
    adj = np.minimum(1.0, (m - np.arange(m)) * p[order])
    adj = np.maximum.accumulate(adj)
    out = np.empty(m)
    out[order] = adj
    return out
