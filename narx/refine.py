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

from dataclasses import dataclass, replace
from typing import Dict, List, Optional, Tuple

import numpy as np

from .linalg import null_space

__all__ = ["refine", "refine_both", "Refinement", "refine_operators", "OperatorRefinement",
           "operator_groups"]

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


# ------------------------------------------------------------ operator parameters
#: the parameters of :func:`refine_operators` stay within this factor of
#: their start (a play radius from the search's grid reaches any radius
#: between its neighbours' on the grid, and a decade beyond)
OPERATOR_RANGE = 10.0
#: significant digits of a refined parameter
PARAM_DIGITS = 4
#: first step of the simplex on the log scale (exp(0.3) = 1.35: a move
#: between the search's neighbouring radii)
OPERATOR_STEP = 0.3


@dataclass
class OperatorRefinement:
    """Outcome of :func:`refine_operators`.

    Attributes
    ----------
    model : narx.Model
        A copy of the model with the refined operator parameters and θ by
        least squares at them (``meta['operators_refined']`` says how).
    moved : dict
        ``{old operator text: new operator text}`` of the groups that moved,
        e.g. ``{'Play(u,0.017)': 'Play(u,0.01291)'}`` (lags left out: one
        group is every lag of an operator of one signal with one parameter
        set).
    cost_before, cost_after : float
        Mean squared free-run error at the start and at the end.
    improved : bool
        Whether the parameters moved (the error went down).
    nfev : int
        Evaluations (one least-squares fit and one free run each).
    """
    model: object
    moved: Dict[str, str]
    cost_before: float
    cost_after: float
    improved: bool
    nfev: int


def operator_groups(terms) -> List[Tuple[str, str, Tuple[float, ...]]]:
    """The distinct ``(operator, signal, parameters)`` of the memory-operator
    factors of ``terms`` that have a positive parameter, in order of
    appearance: each is one group of :func:`refine_operators` (its lags
    share the parameters)."""
    out = []
    for t in terms:
        for f in t.operator_factors:
            key = (f.name, f.arg.signal, tuple(f.params))
            if key not in out and any(p > 0 for p in f.params):
                out.append(key)
    return out


def _with_params(terms, mapping):
    """``terms`` with each operator factor of a group of ``mapping``
    (group -> parameters) given the group's new parameters."""
    from .language.terms import OpCall, Term
    out = []
    for t in terms:
        fs = []
        for f in t.factors:
            if isinstance(f, OpCall):
                new = mapping.get((f.name, f.arg.signal, tuple(f.params)))
                if new is not None:
                    f = replace(f, params=tuple(float(v) for v in new))
            fs.append(f)
        out.append(Term(fs))
    return out


def refine_operators(model, u, y=None, *, max_nfev: Optional[int] = None,
                     history: str = "rest") -> OperatorRefinement:
    r"""Estimate the memory operators' parameters of ``model`` (play radii,
    Bouc–Wen β and γ, a plug-in's positive parameters) by the free-run error
    on a record, θ by least squares at each trial: variable projection.

    The structure search offers operators on a grid of parameters (a play's
    radius at a few fractions of the input's range); the true radius lies
    between. With :math:`p` the operators' positive parameters and
    :math:`\hat\theta(p)` the least-squares θ of the regressors built with
    them, the refinement minimises

    .. math::  J(p) = \frac{1}{N}\sum_k \big(y_k - \hat y_k(p, \hat\theta(p))\big)^2,

    :math:`\hat y` the free run, over :math:`\log p` by the Nelder–Mead
    simplex (derivative-free: a play's output is not differentiable in its
    radius where the input reverses), each parameter within a factor
    :data:`OPERATOR_RANGE` of its start. The parameters of the factors
    of one operator on one signal with one parameter set move together
    (a play of u[k] and of u[k-1] of one radius stay one play, delayed).
    Parameters at zero or below stay (γ = 0 keeps a Dahl-type Bouc–Wen
    variable Dahl's); a trial outside an operator's domain counts as
    diverged. The separable least-squares problem is Golub and Pereyra's
    [1]_; the θ stay least-squares estimates, as for every model with
    operators in the fit.

    The result is never worse than the start on the record: if no trial
    lowers :math:`J`, the model is kept (``improved`` False).

    Parameters
    ----------
    model : narx.Model
        A model whose terms hold memory operators (θ not needed).
    u, y : the record (arrays, or a :class:`~narx.records.data.Data` as ``u``).
    max_nfev : int, optional
        Most evaluations (default 40 + 40 per parameter).
    history : str
        Where the operators start (:data:`narx.language.memory.HISTORIES`;
        'rest' for a training record that starts at rest).

    Raises
    ------
    ValueError
        The model has no operator with a positive parameter, has noise
        terms, or its free run diverges at the start.

    References
    ----------
    .. [1] Golub, G. and Pereyra, V., "Separable nonlinear least squares:
       the variable projection method and its applications", *Inverse
       Problems* 19 (2003), R1–R26.
    """
    import math
    import warnings

    from scipy.optimize import minimize

    from .model import Model, ignore_rank_warnings
    groups = operator_groups(model.terms)
    if not groups:
        raise ValueError("the model has no memory operator with a positive parameter "
                         "to refine")
    if any(t.has_noise for t in model.terms):
        raise ValueError("a model with noise terms (NARMAX) is refined by its extended "
                         "least squares, not by simulation error")
    data = model._data(u, y)
    data.require_output("refining operator parameters")
    free = [(g, i) for g in groups for i, p in enumerate(g[2]) if p > 0]
    x0 = np.array([math.log(g[2][i]) for g, i in free])
    span = math.log(OPERATOR_RANGE)
    yr = float(np.ptp(data.y)) or 1.0
    penalty = (_SPREAD * yr) ** 2

    def mapping(x, digits=None):
        new = {g: list(g[2]) for g in groups}
        for v, (g, i) in zip(x, free):
            new[g][i] = math.exp(v) if digits is None else float(f"{math.exp(v):.{digits}g}")
        return new

    def fitted(x, digits=None):
        m = Model(_with_params(model.terms, mapping(x, digits)), inputs=model.inputs,
                  output=model.output, noise=model.signals.noise, meta=dict(model.meta),
                  registry=model.registry)
        with ignore_rank_warnings(), warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            m.fit(data)
            r = m.simulate(data, mode="freerun", history=history)
        e = (r.y_hat - data.y)[r.start:]
        if r.diverged or not e.size or not np.all(np.isfinite(e)):
            return m, penalty
        return m, min(float(np.mean(e * e)), penalty)

    def cost(x):
        try:
            return fitted(x)[1]
        except (ValueError, np.linalg.LinAlgError, FloatingPointError):
            return penalty              # outside an operator's domain, or singular
    start, cost0 = fitted(x0)
    if cost0 >= penalty:
        raise ValueError("the model's free run diverges on this record: there is no "
                         "simulation error to refine the operators from")
    simplex = np.vstack([x0] + [x0 + OPERATOR_STEP * np.eye(x0.size)[j]
                                for j in range(x0.size)])
    sol = minimize(cost, x0, method="Nelder-Mead",
                   bounds=list(zip(x0 - span, x0 + span)),
                   options={"maxfev": max_nfev or 40 + 40 * x0.size, "xatol": 1e-3,
                            "fatol": 1e-12 * cost0, "initial_simplex": simplex})
    out, moved = start, {}
    cost1 = float(sol.fun)
    if np.isfinite(cost1) and cost1 < cost0:
        out, cost1 = fitted(sol.x, PARAM_DIGITS)      # the parameters as the model prints them
    improved = bool(cost1 < cost0)
    if improved:
        new = mapping(sol.x, PARAM_DIGITS)
        for g in groups:
            if tuple(new[g]) != g[2]:
                moved[_group_text(g[0], g[1], g[2])] = _group_text(g[0], g[1], new[g])
        out.meta["estimation"] = f"{model.meta.get('estimation', 'ls')}+operators-freerun"
    else:
        out, cost1 = start, cost0
    out.meta["operators_refined"] = {"mse_before": cost0, "mse_after": cost1,
                                     "improved": improved, "moved": moved}
    return OperatorRefinement(out, moved, cost0, cost1, improved, int(sol.nfev))


def _group_text(name, signal, params) -> str:
    """``Play(u,0.017)``: an operator group without its lags."""
    from .language.terms import format_param
    return f"{name}({signal}{''.join(',' + format_param(p) for p in params)})"
