"""Simulation-error refinement of θ: the output-error step after least squares.

Typical use::

    import narx
    from narx.refine import refine
    m = narx.Model(terms).fit(u, y)                       # LS: one-step (equation) error
    r = refine(m, u, y, mode="ms", window=100)            # θ minimising the MS error
    r.model.simulate(u_val, y_val).mape, r.cost_before, r.cost_after

Least squares minimises the one-step (equation) error
:math:`\\sum_k (y_k - \\psi_k^\\top \\theta)^2` with regressors built from the
*measured* output. With noise on the measured output those regressors are
noisy, and the LS θ is biased [1]_: the model then simulates worse than its
structure allows, typically by a too-slow or too-fast output dynamics. The
refinement minimises the simulation error itself,

.. math::  J(\\theta) = \\sum_{k} \\big(y_k - \\hat y_k(\\theta)\\big)^2,

with :math:`\\hat y` the free run (``mode='freerun'``) or the multiple-shooting
simulation (``mode='ms'``, windows of Δm samples started from measured
data), by a trust-region Gauss-Newton method (``scipy.optimize.least_squares``)
started at the model's θ, with a finite-difference Jacobian (one simulation
per parameter; the simulation kernels are compiled, so a 50,000-sample
15-term model takes well under a second per iteration). A model fitted
under linear equality constraints (CLS, ``fit_info_['constraints']``, e.g.
the continuum of steady states) keeps them: θ moves in their null space.

The result is never worse than the start on the refinement record: if the
optimiser does not lower :math:`J`, θ is kept (``improved`` is False).

References
----------
.. [1] Ljung, L., *System Identification: Theory for the User*, 2nd ed.,
   Prentice Hall, 1999, §7.3 and §10.2 (output-error methods).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .linalg import null_space

__all__ = ["refine", "refine_both", "Refinement"]

#: simulated outputs beyond this many output ranges count as diverged
_SPREAD = 1e3


@dataclass
class Refinement:
    """Outcome of :func:`refine`.

    Attributes
    ----------
    model : narx.Model
        A copy of the model with the refined θ (``meta['refined']`` says how).
    cost_before, cost_after : float
        Mean squared simulation error at the start and at the end.
    improved : bool
        Whether θ changed (the error went down).
    nfev : int
        Evaluations of the simulation error by the optimiser (its
        finite-difference Jacobians not counted).
    message : str
        The optimiser's status.
    """
    model: object
    cost_before: float
    cost_after: float
    improved: bool
    nfev: int
    message: str


def _constraint_space(model):
    """(θ_p, Z): θ = θ_p + Z w spans the model's CLS constraints (or all θ)."""
    th = np.asarray(model.theta, dtype=float)
    info = model.fit_info_ or {}
    # a CLS model loaded from a file has no fit_info_, its meta says 'cls'
    if not (info.get("constraints") or str(model.meta.get("estimation", "")).startswith("cls")):
        return np.zeros_like(th), np.eye(th.size)
    from .analysis.steady import steady_state_constraints
    cons = steady_state_constraints(model.terms, model.registry)
    if np.max(np.abs(cons.S @ th - cons.c), initial=0.0) > 1e-8 * max(1.0, np.abs(th).max()):
        raise ValueError("the model was fitted under constraints other than the "
                         "continuum of steady states: refining it is not supported")
    z = null_space(cons.S)
    return th - z @ (z.T @ th), z


def refine(model, u, y=None, *, mode: str = "ms", window: Optional[int] = 100,
           max_nfev: Optional[int] = None) -> Refinement:
    """Refine ``model.theta`` by minimising its simulation error on a record.

    Parameters
    ----------
    model : narx.Model
        A fitted model (θ set); it is not modified.
    u, y : the record (arrays, or a :class:`~narx.records.data.Data` as ``u``).
    mode : {'ms', 'freerun'}
        Simulation whose error is minimised.
    window : int
        Δm for ``mode='ms'`` (ignored for ``'freerun'``).
    max_nfev : int, optional
        Most simulations (default 50 per parameter).

    Returns
    -------
    Refinement
    """
    from scipy.optimize import least_squares

    from .simulation.simulate import Plan, simulate
    if mode not in ("ms", "freerun"):
        raise ValueError(f"mode must be 'ms' or 'freerun', got {mode!r}")
    if mode == "ms" and (isinstance(window, bool) or not isinstance(window, (int, np.integer))
                         or window < 1):
        raise ValueError(f"window must be an integer >= 1 for mode 'ms', got {window!r}")
    if any(t.has_noise for t in model.terms):
        raise ValueError("a model with noise terms (NARMAX) is refined by its extended "
                         "least squares, not by simulation error")
    data = model._data(u, y)
    data.require_output("refining θ")
    theta0 = np.asarray(model._need_theta(), dtype=float)
    plan = Plan.from_terms(model.terms, data.inputs, model.registry)
    P = plan.input_parts(data, model.registry)
    kw = {"window": int(window)} if mode == "ms" else {}
    yr = float(np.ptp(data.y)) or 1.0
    penalty = _SPREAD * yr

    def errors(theta):
        """(simulation errors, with diverged samples set to ``penalty``;
        whether the simulation diverged)."""
        if not np.all(np.isfinite(theta)):
            return np.full(data.n - plan.maxlag, penalty), True
        r = simulate(model.terms, theta, data, mode, plan=plan, P=P,
                     registry=model.registry, **kw)
        e = (r.y_hat - data.y)[plan.maxlag:]
        bad = ~np.isfinite(e) | (np.abs(e) > penalty)
        if bad.any():
            e = np.where(bad, penalty, e)
        return e, bool(r.diverged or bad.any())

    tp, z = _constraint_space(model)
    w0 = z.T @ (theta0 - tp)
    e0, diverged0 = errors(theta0)
    cost0 = float(np.mean(e0 ** 2))
    if diverged0:
        raise ValueError(f"the model's {mode} simulation diverges on this record: there is "
                         f"no simulation error to refine from (refit it, or choose a "
                         f"stable structure first)")
    sol = least_squares(lambda w: errors(tp + z @ w)[0], w0, method="trf",
                        x_scale="jac", max_nfev=max_nfev or 50 * max(1, w0.size))
    theta1 = tp + z @ sol.x
    e1, diverged1 = errors(theta1)
    cost1 = float(np.mean(e1 ** 2))
    improved = bool(np.isfinite(cost1) and cost1 < cost0) and not diverged1
    if not improved:
        theta1, cost1 = theta0, cost0
    from .model import Model
    out = Model(model.term_texts, theta1, inputs=model.inputs, output=model.output,
                noise=model.signals.noise, meta=dict(model.meta), registry=model.registry)
    out.fit_info_ = dict(model.fit_info_ or {})
    out.meta["refined"] = {"mode": mode, **kw, "mse_before": cost0, "mse_after": cost1,
                           "improved": improved}
    if improved:
        out.meta["estimation"] = f"{model.meta.get('estimation', 'ls')}+refined-{mode}"
    return Refinement(out, cost0, cost1, improved, int(sol.nfev), str(sol.message))


def refine_both(model, model_cls, data, mode: str, window: int):
    """Refine a search's LS model and its CLS refit (``None`` allowed).

    Returns ``(refinement, model, model_cls, why)``: ``why`` is '' or the
    reason nothing was refined (noise terms, a diverging simulation), in
    which case both models come back unchanged and ``refinement`` is None.
    """
    if any(t.has_noise for t in model.terms):
        return None, model, model_cls, ("the model has noise terms, whose θ comes from "
                                        "extended least squares")
    w = window if mode == "ms" else None
    try:
        r = refine(model, data, mode=mode, window=w)
        cls = None if model_cls is None else refine(model_cls, data, mode=mode,
                                                    window=w).model
    except ValueError as exc:
        return None, model, model_cls, str(exc)
    return r, r.model, cls, ""
