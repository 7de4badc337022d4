"""Error metrics of simulations against data.

Typical use::

    from narx.simulation.metrics import rmse, mape, rrse
    mape(y, y_hat)     # range-normalised MAPE in %, the published metric

.. math::

    \\mathrm{MAPE} = 100\\,\\frac{\\tfrac1N\\sum_k |y_k - \\hat y_k|}
                              {\\max_k y_k - \\min_k y_k},\\qquad
    \\mathrm{RRSE} = \\sqrt{\\frac{\\sum_k (y_k-\\hat y_k)^2}{\\sum_k (y_k-\\bar y)^2}}.

Diverged (non-finite) simulations give ``inf``; NaN samples (no
prediction) must be removed by the caller (see ``SimulationResult.valid``).
"""
from __future__ import annotations

import numpy as np

__all__ = ["mse", "rmse", "mape", "rrse", "nrmse", "r2"]


def _pair(y, y_hat):
    y = np.asarray(y, dtype=float).ravel()
    y_hat = np.asarray(y_hat, dtype=float).ravel()
    if y.shape != y_hat.shape:
        raise ValueError(f"y and y_hat lengths differ: {y.shape[0]} vs {y_hat.shape[0]}")
    if y.size == 0:
        raise ValueError("no samples to compare")
    return y, y_hat


def mse(y, y_hat) -> float:
    y, y_hat = _pair(y, y_hat)
    if not np.all(np.isfinite(y_hat)):
        return float("inf")
    r = y - y_hat
    return float(np.dot(r, r) / r.size)


def rmse(y, y_hat) -> float:
    return float(np.sqrt(mse(y, y_hat)))


def mape(y, y_hat) -> float:
    """Range-normalised mean absolute percentage error, in %."""
    y, y_hat = _pair(y, y_hat)
    if not np.all(np.isfinite(y_hat)):
        return float("inf")
    rng = float(np.max(y) - np.min(y))
    if rng <= 0:
        raise ValueError("the output range is zero: range-normalised MAPE is undefined")
    return float(100.0 * np.mean(np.abs(y - y_hat)) / rng)


def rrse(y, y_hat) -> float:
    """Root relative squared error (1 = as good as the mean)."""
    y, y_hat = _pair(y, y_hat)
    if not np.all(np.isfinite(y_hat)):
        return float("inf")
    den = float(np.sum((y - y.mean()) ** 2))
    if den <= 0:
        raise ValueError("the output is constant: RRSE is undefined")
    return float(np.sqrt(np.sum((y - y_hat) ** 2) / den))


def nrmse(y, y_hat) -> float:
    """RMSE divided by the output's standard deviation."""
    y, _ = _pair(y, y_hat)
    return rmse(y, y_hat) / float(np.std(y))


def r2(y, y_hat, weights=None) -> float:
    """Coefficient of determination,
    :math:`1 - \\sum_k w_k (y_k - \\hat y_k)^2 / \\sum_k w_k (y_k - \\bar y)^2`
    with :math:`\\bar y` the weighted mean (``weights`` default 1): 1 is a
    perfect prediction, 0 as good as the mean, ``-inf`` for a non-finite
    prediction (a diverged simulation)."""
    y, y_hat = _pair(y, y_hat)
    w = np.ones_like(y) if weights is None else np.asarray(weights, dtype=float).ravel()
    if w.shape != y.shape or not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ValueError(f"weights must be {y.size} finite values >= 0 that are not all 0")
    if not np.all(np.isfinite(y_hat)):
        return float("-inf")
    mean = float(np.dot(w, y) / w.sum())
    den = float(np.dot(w, (y - mean) ** 2))
    if den <= 0:
        raise ValueError("the output is constant: R² is undefined")
    return float(1.0 - np.dot(w, (y - y_hat) ** 2) / den)
