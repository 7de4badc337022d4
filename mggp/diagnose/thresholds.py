"""How a diagnose test's threshold is made.

Typical use::

    from mggp.diagnose.thresholds import bonferroni_z
    band = bonferroni_z(0.01, m=21) / np.sqrt(n)      # two-sided, over 21 lags

A test's threshold is a statistical bound at false-alarm probability α
(here: the Bonferroni-corrected normal quantile of tests that take the
largest of m statistics) combined with the resolution floor of
:mod:`mggp.diagnose.findings`.
"""
from __future__ import annotations

from scipy.stats import norm

__all__ = ["bonferroni_z"]


def bonferroni_z(alpha: float, m: int) -> float:
    """Two-sided normal quantile :math:`z_{1-\\alpha/(2m)}` with a Bonferroni
    correction over ``m`` tests: the probability that any of m standard
    normal statistics leaves ±z is at most α (Bonferroni's inequality)."""
    return float(norm.ppf(1.0 - alpha / (2.0 * max(int(m), 1))))
