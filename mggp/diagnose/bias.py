"""Prediction-bias test: one-step fit good, free run poor.

Typical use::

    from mggp.diagnose.bias import prediction_bias_test
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

As the diagnose test :data:`PREDICTION_BIAS` (effect
``prediction-bias``), one check, ``free-run excess``, whose threshold is
the largest of the null's excess, the resolution floor and the free-run
RMSE the noise alone causes (the null's median), so that noisy data do not
turn a small misfit into a finding.

References
----------
.. [1] Efron, B., Tibshirani, R. J., "An Introduction to the Bootstrap",
   Chapman & Hall, 1993, ch. 6 (parametric bootstrap).
"""
from __future__ import annotations

from dataclasses import dataclass
import numpy as np

from narx import Model
from narx.records.data import Data

from .findings import Check, number_text as _g
from .registry import DiagnosticTest, Outcome
from .simulation import fresh_name

__all__ = ["BiasTest", "prediction_bias_test", "bias_check", "PREDICTION_BIAS"]


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
    w = fresh_name({model.output, *model.inputs, model.signals.noise}, "w")
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


def bias_check(b: BiasTest, alpha: float, floor: float) -> Check:
    """``b``'s excess against max(null excess, floor, noise-driven RMSE)."""
    thr = max(b.excess_null, floor, b.null_median_rmse)
    fr = "diverged" if b.diverged else _g(b.freerun_rmse)
    detail = (f"one-step RMSE {_g(b.osa_rmse)}, free-run RMSE {fr}; driven by its own "
              f"resampled one-step residuals ({b.n_boot} runs) the model's free-run RMSE "
              f"would be {_g(b.null_median_rmse)} (median), {_g(b.null_quantile_rmse)} "
              f"({100 * (1 - alpha):g} % quantile): excess free-run error "
              f"{_g(b.excess)} against {_g(b.excess_null)} by chance; materiality: at "
              f"least the noise-driven RMSE {_g(b.null_median_rmse)} and the resolution "
              f"floor {_g(floor)}")
    return Check("free-run excess", "prediction-bias", b.excess, thr, detail)


def _run(ctx) -> Outcome:
    b = prediction_bias_test(ctx.model, ctx.fit, n_boot=ctx.budget.bootstrap,
                             alpha=ctx.alpha, seed=ctx.seed + 7)
    return Outcome([bias_check(b, ctx.alpha, ctx.floor)], b)


#: The prediction-bias bootstrap (seed: the diagnosis's seed + 7).
PREDICTION_BIAS = DiagnosticTest("prediction bias", ("prediction-bias",), _run)
