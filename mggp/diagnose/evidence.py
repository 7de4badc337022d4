"""Evidence from simulations: bounded simulation residual and prediction bias.

Typical use::

    from mggp.diagnose.evidence import simulation_residual, prediction_bias_test
    e, source = simulation_residual(model, data)        # free-run residual
    b = prediction_bias_test(model, data, seed=0)       # one-step good, free run poor?
    b.excess, b.excess_null

**Prediction-bias test.** If the model were right and its one-step
residuals :math:`\\varepsilon_k` were the noise, data would be the model
driven by that noise, and the free-run error would be the noise propagated
through the model. A parametric bootstrap [1]_ simulates this: the model
is run free with the measured input plus resampled residuals as equation
noise, B times, giving replicas y* of the data. The discrepancy of a
record z from the deterministic free run ŷ is scale-free,

.. math::  T(z) = \\frac{\\mathrm{mean}_k (z_k - \\hat y_k)^2}{\\mathrm{var}(z)},

so that a model whose replicas blow up (and would not look like bounded
data) is not excused by its own blow-up. The statistic is the excess
free-run error

.. math::  X = \\sqrt{\\max(0,\\ \\mathrm{MSE}_{fr} - \\mathrm{var}(y)\\,\\mathrm{med}\\,T(y^*))},

compared with the same quantity at the null's (1 − α) quantile. Replicas
that diverge are left out of the null (had the data come from such a
model, they would have diverged); a free run that itself diverges on
finite data is an excess of ``inf``.

References
----------
.. [1] Efron, B., Tibshirani, R. J., "An Introduction to the Bootstrap",
   Chapman & Hall, 1993, ch. 6 (parametric bootstrap).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Tuple

import numpy as np

from narx import Model
from narx.data import Data

__all__ = ["BiasTest", "bounded_mode", "simulation_residual", "prediction_bias_test",
           "direction_of_change"]


def direction_of_change(u) -> np.ndarray:
    """sign(u_k − u_{k−1}); 0 at k = 0 and where the input does not move."""
    u = np.asarray(u, dtype=float)
    s = np.zeros(u.size)
    s[1:] = np.sign(np.diff(u))
    return s


def bounded_mode(model: Model, data: Data):
    """The longest simulation of ``model`` that stays in the data's range.

    The free run is used when it stays bounded (RMSE at most the output's
    standard deviation); otherwise multiple shooting with the largest window
    N/2, N/4, ... (down to 10·maxlag) that does. Returns ``(kwargs, result,
    description)`` where ``kwargs`` are the ``simulate`` arguments.
    """
    sd = float(np.std(data.y)) or 1.0
    r = model.simulate(data, mode="freerun")
    if not r.diverged and r.rmse <= sd:
        return {"mode": "freerun"}, r, "free run"
    w = (data.n - model.max_lag) // 2
    while w >= max(10 * model.max_lag, 20):
        kw = {"mode": "ms", "window": int(w)}
        rw = model.simulate(data, **kw)
        if not rw.diverged and rw.rmse <= sd:
            return kw, rw, (f"multiple shooting, windows of {int(w)} samples (the free run "
                            f"left the data's range)")
        w //= 2
    return {"mode": "freerun"}, r, "free run (unbounded)"


def simulation_residual(model: Model, data: Data) -> Tuple[np.ndarray, str]:
    """Residual of :func:`bounded_mode`'s simulation (NaN where there is no
    prediction) and its description."""
    _, r, text = bounded_mode(model, data)
    return _full(r), text


def _full(r) -> np.ndarray:
    e = np.full(r.y.shape, np.nan)
    with np.errstate(all="ignore"):
        e[r.valid] = (r.y - r.y_hat)[r.valid]
    e[~np.isfinite(e)] = np.nan
    return e


@dataclass(frozen=True)
class BiasTest:
    """One-step against free-run error, with a bootstrap null.

    Attributes
    ----------
    osa_rmse, freerun_rmse : float
        Errors of the one-step prediction and the free run (``inf`` if the
        free run diverged).
    null_median_rmse, null_quantile_rmse : float
        Median and (1 − α) quantile of the free-run RMSE when the model is
        driven by its own resampled one-step residuals.
    excess, excess_null : float
        X of the data and of the null quantile (output units).
    n_boot : int
    null_diverged : float
        Fraction of bootstrap runs that diverged.
    """

    osa_rmse: float
    freerun_rmse: float
    null_median_rmse: float
    null_quantile_rmse: float
    excess: float
    excess_null: float
    n_boot: int
    null_diverged: float

    @property
    def diverged(self) -> bool:
        return not np.isfinite(self.freerun_rmse)


def _noise_name(model: Model) -> str:
    taken = {model.output, *model.inputs, model.signals.noise}
    name = "w"
    while name in taken:
        name += "w"
    return name


def prediction_bias_test(model: Model, data: Data, *, n_boot: int = 199,
                         alpha: float = 0.01, seed=0) -> BiasTest:
    """Free-run error against the error the model's own noise would cause."""
    osa = model.simulate(data, mode="osa")
    fr = model.simulate(data, mode="freerun")
    eps = osa.residual
    eps = eps[np.isfinite(eps)]
    eps = eps - eps.mean() if eps.size else np.zeros(1)
    valid = fr.valid
    mse_fr = fr.mse if np.isfinite(fr.mse) else np.inf
    w = _noise_name(model)
    aug = Model(model.term_texts + [f"{w}[k]"], list(model.theta) + [1.0],
                inputs=tuple(model.inputs) + (w,), output=model.output,
                registry=model.registry)
    if fr.diverged:
        return BiasTest(osa.rmse, float("inf"), 0.0, 0.0, float("inf"), 0.0, 0, 0.0)
    rng = np.random.default_rng(seed)
    ml = model.max_lag
    null = np.full(int(n_boot), np.nan)
    base = fr.y_hat
    for i in range(null.size):
        noise = rng.choice(eps, size=data.n)
        noise[:ml] = 0.0
        d = Data(np.column_stack([data.U.T, noise]), data.y, inputs=aug.inputs,
                 output=model.output)
        r = aug.simulate(d, mode="freerun")
        if r.diverged:
            continue
        ys = r.y_hat[valid]
        with np.errstate(all="ignore"):
            t = float(np.mean((ys - base[valid]) ** 2) / np.var(ys))
        if np.isfinite(t):
            null[i] = t
    kept = null[np.isfinite(null)]
    scale = float(np.var(data.y[valid])) or 1.0
    med = float(np.quantile(kept, 0.5, method="higher")) * scale if kept.size else 0.0
    q = float(np.quantile(kept, 1.0 - alpha, method="higher")) * scale if kept.size else 0.0
    excess = np.sqrt(max(0.0, mse_fr - med))
    excess_null = np.sqrt(max(0.0, q - med))
    return BiasTest(osa.rmse, float(np.sqrt(mse_fr)), float(np.sqrt(med)), float(np.sqrt(q)),
                    float(excess), float(excess_null), int(null.size),
                    float(1.0 - kept.size / max(null.size, 1)))
