"""Term clusters, cluster sums and continuum-of-steady-states constraints.

Typical use::

    from narx.analysis.steady import clusters, steady_state_constraints
    cons = steady_state_constraints(terms)
    cons.labels          # ['Σ_y = 1', 'Σ_u = 0', 'Σ_u^3 = 0', ...]
    cons.S, cons.c       # S θ = c, for constrained least squares

With every input held at ū and the output at ȳ, a lagged signal takes its
held value and a Φ-function takes its value at equal arguments (0 for Phi1
and Phi2, so those terms vanish). Each remaining term is a coefficient times
a monomial in (ȳ, ū); terms with the same monomial form a *cluster* [1]_.
The steady-state equation is

.. math::  \\bar y = \\sum_{c} \\Sigma_c\\, m_c(\\bar y, \\bar u),

and it holds for every (ū, ȳ) — a continuum of steady states, the hallmark
of rate-independent hysteresis — exactly when Σ_y = 1 and every other
cluster sum is 0. Noise terms are zero at steady state.

:func:`rest_actuator` solves the other way, numerically: the actuator value
at which a given model rests with its other signal held (the rest point a
compensator aims at).

Memory operators (:mod:`narx.language.memory`). With its argument held, an operator
holds a value fixed by the history, not by the held signal alone: a play of
radius r rests anywhere in :math:`[\\bar x - r, \\bar x + r]`. The cluster
analysis therefore treats an operator factor as a *held state symbol* of its
own, keyed by operator, signal and parameters (``Play(u,0.3)``), like a
further held signal: ``u[k-1]*Play(u[k-2],0.3)`` belongs to the cluster
``u*Play(u,0.3)``. An operator whose rest set is the single point
:math:`\\bar x` (a play of radius 0) is its argument. The derived
constraints keep their meaning: with Σ_y = 1 and every other cluster sum
0 — operator clusters included — the recursion holds any output for every
input and every operator state. A model whose memory is in its operators
(e.g. :math:`y_k = a y_{k-1} + b\\,P_r(u)_{k-1}`, :math:`a \\ne 1`) has a
continuum of steady states without those constraints, through the
operator's rest set: :func:`held_outputs` gives its ends.

References
----------
.. [1] Aguirre, L. A., Billings, S. A., "Dynamical effects of
   overparametrization in nonlinear models", Physica D, 1995.
"""
from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..exceptions import EstimationError
from ..language.phi import PhiRegistry, default_registry
from ..language.memory import default_operators
from ..language.terms import Lag, OpCall, PhiCall, Term, parse_term

__all__ = ["Cluster", "SteadyStateConstraints", "clusters", "cluster_sums",
           "steady_state_constraints", "rest_actuator", "held_outputs"]


@dataclass(frozen=True)
class Cluster:
    """Terms sharing one steady-state monomial.

    ``members`` are (term index, multiplier) pairs: the term contributes
    ``multiplier * θ_i`` to the cluster sum (the multiplier is the product
    of constant Φ steady values, 1 for Φ-free terms).
    """

    key: str
    members: Tuple[Tuple[int, float], ...]

    @property
    def label(self) -> str:
        return f"Σ_{self.key}"

    def row(self, n_terms: int) -> np.ndarray:
        r = np.zeros(n_terms)
        for i, m in self.members:
            r[i] += m
        return r


def _monomial(term: Term, reg: PhiRegistry):
    """(key, multiplier) of a term at steady state; key None if it vanishes."""
    powers: Dict[Tuple[int, str], int] = {}
    symbols: List[str] = []
    mult = 1.0
    for f in term.factors:
        if isinstance(f, Lag):
            if f.role == "e":
                return None, 0.0
            k = (0 if f.role == "y" else 1, f.signal)
            powers[k] = powers.get(k, 0) + 1
            continue
        if isinstance(f, OpCall):
            if _is_identity_at_rest(f):
                k = (0 if f.arg.role == "y" else 1, f.arg.signal)
                powers[k] = powers.get(k, 0) + 1
            else:
                symbols.append(_op_symbol(f))
            continue
        fn = reg.get(f.name)
        if any(a.role == "e" for a in f.args):
            return None, 0.0
        same = len({a.signal for a in f.args}) == 1
        if same and fn.steady_is_constant:
            v = fn.steady_value()
            if v == 0.0:
                return None, 0.0
            mult *= v
        else:
            sig = sorted({a.signal for a in f.args},
                         key=lambda s: (0 if s == f.args[0].signal else 1, s))
            symbols.append(f"{f.name}({','.join(sig)})")
    parts = []
    for (_, name), p in sorted(powers.items()):
        parts.append(name if p == 1 else f"{name}^{p}")
    parts.extend(sorted(symbols))
    return ("*".join(parts) if parts else "1"), mult


def _op_symbol(f: OpCall) -> str:
    """Cluster symbol of an operator at rest, e.g. ``Play(u,0.3)``."""
    return str(f).replace(str(f.arg), f.arg.signal, 1)


def _is_identity_at_rest(f: OpCall) -> bool:
    """True when the operator's rest set is the single point x̄ (probed at
    x̄ = 0 and 1), e.g. a play of radius 0."""
    op = default_operators().get(f.name)
    return all(op.steady_set(x, f.params) == (x, x) for x in (0.0, 1.0))


def _as_terms(terms, registry) -> Tuple[Term, ...]:
    """Terms, parsed from text where given as text (signals y, u and e;
    a model of other signal names gives its parsed ``Model.terms``)."""
    return tuple(parse_term(t, registry=registry) if isinstance(t, str) else t
                 for t in terms)


def clusters(terms: Sequence[Term], registry: Optional[PhiRegistry] = None
             ) -> List[Cluster]:
    """Clusters of a term set (terms vanishing at steady state are omitted)."""
    reg = registry or default_registry()
    acc: "OrderedDict[str, list]" = OrderedDict()
    for i, t in enumerate(_as_terms(terms, reg)):
        key, mult = _monomial(t, reg)
        if key is not None:
            acc.setdefault(key, []).append((i, mult))
    return [Cluster(k, tuple(v)) for k, v in acc.items()]


def cluster_sums(terms: Sequence[Term], theta,
                 registry: Optional[PhiRegistry] = None) -> "OrderedDict[str, float]":
    """Σ_c for every cluster, e.g. ``{'y': 1.0, 'u': 0.0, ...}``."""
    theta = np.asarray(theta, dtype=float)
    return OrderedDict((c.key, float(c.row(len(terms)) @ theta))
                       for c in clusters(terms, registry))


@dataclass(frozen=True)
class SteadyStateConstraints:
    """Linear equalities S θ = c for a continuum of steady states."""

    S: np.ndarray
    c: np.ndarray
    labels: Tuple[str, ...]
    clusters: Tuple[Cluster, ...]

    def residual(self, theta) -> np.ndarray:
        return self.S @ np.asarray(theta, dtype=float) - self.c

    def satisfied(self, theta, tol: float = 1e-8) -> bool:
        return bool(np.all(np.abs(self.residual(theta)) <= tol))

    def describe(self, terms: Sequence[Term]) -> List[str]:
        """Readable rows, e.g. 'Σ_u = θ2 + θ15 = 0'."""
        out = []
        for lab, cl, ci in zip(self.labels, self.clusters, self.c):
            ths = " + ".join((f"θ{i + 1}" if m == 1 else f"{m:g}·θ{i + 1}")
                             for i, m in cl.members)
            out.append(f"{cl.label} = {ths} = {ci:g}")
        return out


def steady_state_constraints(terms: Sequence[Term],
                             registry: Optional[PhiRegistry] = None
                             ) -> SteadyStateConstraints:
    """Derive the continuum-of-steady-states constraints of a term set.

    Raises
    ------
    EstimationError
        When no linear output term survives at steady state (Σ_y = 1 is
        then impossible).
    """
    terms = _as_terms(terms, registry)
    cls = clusters(terms, registry)
    out_names = {f.signal for t in terms for f in t.factors
                 if isinstance(f, Lag) and f.role == "y"}
    out_names |= {a.signal for t in terms for f in t.factors
                  if isinstance(f, (PhiCall, OpCall)) for a in f.args if a.role == "y"}
    ykey = next((c.key for c in cls if c.key in out_names), None)
    if ykey is None:
        raise EstimationError("no continuum of steady states is possible: the model "
                              "has no linear output term (like y[k-1]) that survives "
                              "at steady state, so Σ_y = 1 cannot hold")
    rows, cs, labels = [], [], []
    for c in cls:
        target = 1.0 if c.key == ykey else 0.0
        rows.append(c.row(len(terms)))
        cs.append(target)
        labels.append(f"{c.label} = {target:g}")
    return SteadyStateConstraints(np.array(rows), np.array(cs), tuple(labels), tuple(cls))


def rest_actuator(model, level: float, actuator: str, low: float, high: float,
                  grid: int = 201):
    r"""The actuator value in ``[low, high]`` at which the model rests with
    its other signal held at ``level``, or None when any value rests there
    (a continuum of steady states) or none in the range does.

    ``actuator`` is ``model.inputs[0]`` for a forward model
    (:math:`\bar y = f(\bar u, \bar y)` with :math:`\bar y` = ``level``,
    solved for :math:`\bar u`) or ``model.output`` for an inverse one
    (:math:`\bar m = f(\bar r, \bar m)` with :math:`\bar r` = ``level``).
    The one-step map is evaluated with every lag at the rest values on a
    grid of ``grid`` points; a sign change of its rest error is
    interpolated linearly, the root nearest the middle of the range kept.
    """
    ml = max(int(model.max_lag), 1)
    a = np.linspace(low, high, grid)
    held = np.repeat(a, ml + 1)                      # one constant block per grid point
    other = np.full(held.size, float(level))
    inverse = actuator == model.output
    u, y = (other, held) if inverse else (held, other)
    pred = model.simulate(u, y, mode="osa").y_hat[ml::ml + 1]
    g = pred - (a if inverse else level)
    if not np.all(np.isfinite(g)):
        return None
    scale = max(1.0, abs(level), abs(low), abs(high))
    if np.max(np.abs(g)) <= 1e-9 * scale:            # every value rests: a continuum
        return None
    roots = [a[i] for i in np.flatnonzero(g == 0.0)]
    for i in np.flatnonzero(g[:-1] * g[1:] < 0):
        roots.append(a[i] - g[i] * (a[i + 1] - a[i]) / (g[i + 1] - g[i]))
    if not roots:
        return None
    mid = 0.5 * (low + high)
    return float(min(roots, key=lambda x: abs(x - mid)))


def held_outputs(terms: Sequence[Term], theta, u_bar: float,
                 registry: Optional[PhiRegistry] = None) -> Tuple[float, float]:
    r"""Rest outputs of a model whose memory is in plays of its input.

    With the input held at ``u_bar`` after a monotone approach from below
    every play of the input rests at :math:`\bar u - r` (the loading end),
    from above at :math:`\bar u + r` (the unloading end). For a model whose
    only output cluster is ``y`` with Σ_y ≠ 1, the rest output is

    .. math::  \bar y = \frac{\sum_{c \ne y} \Sigma_c\,
               m_c(\bar u, w)}{1 - \Sigma_y},

    evaluated at those two operator states; every history gives a rest
    state w of the plays, so the output can rest at a continuum of values.

    Returns
    -------
    (y_below, y_above) : tuple of float

    Raises
    ------
    ValueError
        When the model has output clusters other than ``y``, Σ_y = 1, more
        than one input, or operators other than plays of the input.
    """
    reg = registry or default_registry()
    terms = _as_terms(terms, registry)
    theta = np.asarray(theta, dtype=float)
    ins = {f.signal for t in terms for f in t.factors if isinstance(f, Lag) and f.role == "u"}
    ops = {f for t in terms for f in t.operator_factors}
    if len(ins | {f.arg.signal for f in ops if f.arg.role == "u"}) > 1 or any(
            f.name != "Play" or f.arg.role != "u" for f in ops):
        raise ValueError("held_outputs needs a single-input model whose operators are "
                         "plays of the input")
    sums = cluster_sums(terms, theta, reg)
    outs = {f.signal for t in terms for f in t.factors if isinstance(f, Lag) and f.role == "y"}
    ys = [k for k in sums if any(p.partition("^")[0] in outs for p in k.split("*"))]
    if len(ys) > 1 or (ys and ys[0] not in outs):
        raise ValueError(f"held_outputs needs the output alone as the only output "
                         f"cluster, got {ys}")
    sy = sums[ys[0]] if ys else 0.0
    if sy == 1.0:
        raise ValueError("held_outputs needs Σ_y != 1 (with Σ_y = 1 the rest output "
                         "is not fixed by the operator states)")
    out = []
    for side in (-1.0, 1.0):
        values = {}
        for f in ops:
            values[_op_symbol(f)] = u_bar + side * f.params[0]
        for name in ins:
            values[name] = u_bar
        acc = 0.0
        for key, total in sums.items():
            if key in ys:
                continue
            m = 1.0
            for part in ([] if key == "1" else key.split("*")):
                base, _, p = part.partition("^")
                m *= values[base] ** (int(p) if p else 1)
            acc += total * m
        out.append(acc / (1.0 - sy))
    return tuple(out)
