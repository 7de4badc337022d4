"""Paired comparison of two models' losses on the same samples: a moving-block bootstrap.

Typical use::

    from narx.analysis.paired import paired_bootstrap
    t = paired_bootstrap(err_simple ** 2, err_rich ** 2, seed=3)   # per-sample losses
    t.p_value           # one-sided: the second loss is lower on average
    t.spread(np.sqrt)   # bootstrap standard deviation of RMSE_simple - RMSE_rich
    t.block             # the block length, from the data (Politis and White 2004)

Two models scored on the same samples give losses :math:`a_k` and
:math:`b_k` (e.g. squared free-run errors on a held-out part). Their
difference :math:`d_k = a_k - b_k` is serially dependent (a free-run error
wanders slowly), so its mean's uncertainty is not that of independent
samples. The moving-block bootstrap (Künsch 1989) resamples the *pairs*
:math:`(a_k, b_k)` in blocks of :math:`\\ell` consecutive samples, which
keeps the dependence within a block and the pairing of the two models:
:math:`\\lceil n/\\ell \\rceil` block starts drawn uniformly from
:math:`0, \\dots, n-\\ell`, the blocks concatenated and cut to :math:`n`.
From :math:`B` such resamples, with means :math:`\\bar a^*_b, \\bar b^*_b`
and :math:`\\bar d^*_b = \\bar a^*_b - \\bar b^*_b`, the one-sided p-value
of "b is not lower on average" (:math:`H_0: E\\,d \\le 0`) is

.. math:: p = \\frac{1 + \\#\\{b : \\bar d^*_b - \\bar d \\ge \\bar d\\}}{B + 1},

the share of the resamples centred on the null that reach the observed
mean difference (Hall and Wilson, *Biometrics* 47, 1991). The block
length :math:`\\ell` comes from the data (:func:`block_length`).

References
----------
H. R. Künsch, "The jackknife and the bootstrap for general stationary
observations", *Annals of Statistics* 17 (1989) 1217-1241.
D. N. Politis and H. White, "Automatic block-length selection for the
dependent bootstrap", *Econometric Reviews* 23 (2004) 53-70; correction:
A. Patton, D. N. Politis and H. White, *Econometric Reviews* 28 (2009) 372-375.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

__all__ = ["REPLICATES", "PairedBootstrap", "block_length", "paired_bootstrap"]

#: bootstrap resamples :func:`paired_bootstrap` draws unless told
REPLICATES = 999


def _flat_top(t: np.ndarray) -> np.ndarray:
    """The trapezoidal flat-top lag window of Politis and Romano:
    1 for |t| <= 1/2, 2 (1 - |t|) up to |t| = 1, 0 beyond."""
    t = np.abs(t)
    return np.where(t <= 0.5, 1.0, np.where(t <= 1.0, 2.0 * (1.0 - t), 0.0))


def block_length(d) -> int:
    """Moving-block bootstrap block length of the series ``d`` (Politis and
    White 2004, with the correction of Patton, Politis and White 2009).

    With :math:`\\hat R(k)` the sample autocovariances and :math:`\\hat\\rho(k)`
    the autocorrelations of ``d`` (n samples), :math:`\\hat m` is the least
    lag after which :math:`K_n = \\max(5, \\lceil\\sqrt{\\log_{10} n}\\rceil)`
    consecutive autocorrelations are below :math:`2\\sqrt{\\log_{10} n / n}`,
    :math:`M = 2\\hat m`, and with the flat-top window :math:`\\lambda`

    .. math:: \\hat G = \\sum_{|k| \\le M} \\lambda(k/M)\\,|k|\\,\\hat R(k), \\qquad
              \\hat g = \\sum_{|k| \\le M} \\lambda(k/M)\\,\\hat R(k), \\qquad
              \\ell = \\Bigl(\\frac{2 \\hat G^2}{\\tfrac43 \\hat g^2}\\Bigr)^{1/3} n^{1/3},

    rounded up and kept within ``[1, n // 2]`` (1 for a series without
    dependence or without variance).

    Parameters
    ----------
    d : array_like, shape (n,)
        The series (e.g. a paired loss difference).

    Returns
    -------
    int
    """
    d = np.asarray(d, dtype=float).ravel()
    n = d.size
    if n < 4:
        return 1
    x = d - d.mean()
    var = float(x @ x) / n
    if not var > 0.0:
        return 1
    top = n // 2                               # lags scanned
    f = np.fft.rfft(x, 2 * n)
    cov = np.fft.irfft(f * np.conj(f), 2 * n)[:top + 1] / n
    rho = cov / var
    kn = max(5, int(np.ceil(np.sqrt(np.log10(n)))))
    band = 2.0 * np.sqrt(np.log10(n) / n)
    small = np.abs(rho[1:]) < band            # small[j]: lag j + 1
    m_hat = None
    for m in range(0, top - kn + 1):
        if np.all(small[m:m + kn]):
            m_hat = m
            break
    if m_hat is None:                          # dependence over the whole range scanned
        m_hat = top // 2
    M = min(2 * max(m_hat, 1), top)
    k = np.arange(1, M + 1)
    w = _flat_top(k / M)
    G = 2.0 * float(np.sum(w * k * cov[1:M + 1]))
    g = cov[0] + 2.0 * float(np.sum(w * cov[1:M + 1]))
    if not g > 0.0 or G == 0.0:
        return 1
    ell = (2.0 * G * G / (4.0 / 3.0 * g * g)) ** (1.0 / 3.0) * n ** (1.0 / 3.0)
    return int(min(max(np.ceil(ell), 1), max(n // 2, 1)))


@dataclass(frozen=True)
class PairedBootstrap:
    """The outcome of :func:`paired_bootstrap`.

    Attributes
    ----------
    mean_a, mean_b : float
        The mean losses of the two models.
    p_value : float
        One-sided p-value of :math:`H_0`: the mean of ``b`` is not below
        that of ``a``.
    se : float
        Bootstrap standard deviation of the mean difference ``mean_a - mean_b``.
    block : int
        The block length used.
    a_star, b_star : ndarray, shape (replicates,)
        The resampled means (same blocks for both).
    """

    mean_a: float
    mean_b: float
    p_value: float
    se: float
    block: int
    a_star: np.ndarray
    b_star: np.ndarray

    @property
    def diff(self) -> float:
        """``mean_a - mean_b`` (positive: ``b`` has the lower loss)."""
        return self.mean_a - self.mean_b

    def spread(self, f: Callable = np.sqrt) -> float:
        """Bootstrap standard deviation of ``f(mean_a) - f(mean_b)``
        (``f = np.sqrt`` on squared errors: of the RMSE difference)."""
        return float(np.std(f(self.a_star) - f(self.b_star), ddof=1))


def paired_bootstrap(loss_a, loss_b, *, seed=0, replicates: int = REPLICATES,
                     block: Optional[int] = None, segments=None) -> PairedBootstrap:
    """Moving-block bootstrap of the paired loss difference ``loss_a - loss_b``
    (module docstring): is ``b``'s mean loss lower than ``a``'s beyond what
    the dependence of the samples lets chance make?

    Parameters
    ----------
    loss_a, loss_b : array_like, shape (n,)
        Per-sample losses of the two models on the same samples, finite.
    seed : int or numpy.random.Generator
        Seeds the resampling (``numpy.random.default_rng(seed)``); a given
        seed gives the same result.
    replicates : int
        Bootstrap resamples B, >= 1.
    block : int, optional
        Block length; default :func:`block_length` of the difference (with
        ``segments``: the largest of the segments').
    segments : sequence of int, optional
        Lengths of consecutive segments of the samples that are not
        contiguous in time (e.g. the two ends of a record held out in
        turn); blocks are drawn within each segment and each resample keeps
        every segment's length. Default: one segment.

    Returns
    -------
    PairedBootstrap
    """
    a = np.asarray(loss_a, dtype=float).ravel()
    b = np.asarray(loss_b, dtype=float).ravel()
    if a.shape != b.shape or a.size == 0:
        raise ValueError(f"loss_a and loss_b must be non-empty and of equal length, got "
                         f"{a.size} and {b.size}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("loss_a and loss_b must be finite")
    if int(replicates) < 1:
        raise ValueError(f"replicates must be >= 1, got {replicates!r}")
    n, reps = a.size, int(replicates)
    d = a - b
    lengths = [n] if segments is None else [int(m) for m in segments]
    if sum(lengths) != n or min(lengths) < 1:
        raise ValueError(f"segments must be positive lengths adding up to the {n} samples, "
                         f"got {list(segments)}")
    offsets = np.cumsum([0] + lengths[:-1])
    ell = (max(block_length(d[o:o + m]) for o, m in zip(offsets, lengths)) if block is None
           else int(block))
    if not 1 <= ell <= min(lengths):
        raise ValueError(f"block must be within 1..{min(lengths)} (the samples of the "
                         f"shortest segment), got {block!r}")
    rng = np.random.default_rng(seed)
    parts = []
    for o, m in zip(offsets, lengths):
        starts = o + rng.integers(0, m - ell + 1, size=(reps, -(-m // ell)))
        parts.append((starts[:, :, None] + np.arange(ell)).reshape(reps, -1)[:, :m])
    idx = np.concatenate(parts, axis=1)
    a_star, b_star = a[idx].mean(axis=1), b[idx].mean(axis=1)
    mean_a, mean_b = float(a.mean()), float(b.mean())
    dbar = mean_a - mean_b
    d_star = a_star - b_star
    p = (1.0 + float(np.sum(d_star - dbar >= dbar))) / (reps + 1.0)
    se = float(np.std(d_star, ddof=1)) if reps > 1 else 0.0
    return PairedBootstrap(mean_a, mean_b, p, se, ell, a_star, b_star)
