"""Can a model be inverted step by step? The zeros of its linear input part.

Typical use::

    import narx
    from narx.analysis.inverse_check import inverse_stability
    model = narx.Model(["y[k-1]", "u[k-1]", "u[k-2]"], theta=[0.5, 1.0, -2.0])
    chk = inverse_stability(model)
    chk.minimum_phase       # False: B(q⁻¹) = q⁻¹ - 2q⁻² has the zero z = 2
    chk.unstable_zeros      # array([2.+0.j])
    print(chk.describe())

The model-based compensator (:mod:`narx.analysis.compensate`) solves the model for
its most recent input at every step: it runs the model *backwards*, from
output to input. The terms linear in the input, :math:`\\theta\\,u[k-i]` and
:math:`\\theta\\,\\Phi_1(u[k-a], u[k-b]) = \\theta\\,(u[k-a] - u[k-b])`, form
the polynomial :math:`B(q^{-1}) = \\sum_i b_i q^{-i}`; the inverse's input
recursion has the zeros of :math:`B` as its poles. A zero outside the unit
circle (a *non-minimum-phase* model) makes the exact inverse unstable, however
good the model: the input grows until it saturates or diverges, and most
steps fall back. Other terms that depend on the input (products, ``Phi2``
signs, other Φ-functions) are left out: the verdict is then that of the
model *linearised* about rest, an approximation, which :attr:`linearised`
says. Zeros on the unit circle (``Phi1`` differences always give
:math:`z = 1`) are not counted as unstable.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Optional, Tuple

import numpy as np

from ..exceptions import NonMinimumPhaseWarning
from ..language.phi import builtin
from ..language.terms import Lag

__all__ = ["InverseStability", "NonMinimumPhaseWarning", "inverse_stability",
           "uninvertible_reason"]


def active_terms(model):
    """``(term, θ)`` of the terms that act: nonzero θ, no noise factor (all
    terms, θ = 1, while the model has no parameters)."""
    theta = model.theta if model.theta is not None else [1.0] * len(model.terms)
    return [(t, float(th)) for t, th in zip(model.terms, theta)
            if th != 0.0 and not t.has_noise]


def _form(factor):
    """Form of a Φ-call's function (:data:`narx.language.phi.BUILTINS`); None for
    a plug-in, which has no known form."""
    row = builtin(factor.name)
    return None if row is None else row.form


def input_lags(term):
    """Lags of the input in ``term``, in its factors and their arguments."""
    return [a.lag for a in term.lags if a.role == "u"]


def _fmt(v: float) -> str:
    return f"{v:.4g}"


def _fmt_zero(z: complex) -> str:
    if abs(z.imag) <= 1e-9 * max(1.0, abs(z)):
        return _fmt(z.real)
    return f"{_fmt(z.real)}{'+' if z.imag >= 0 else '-'}{_fmt(abs(z.imag))}j"


@dataclass(frozen=True)
class InverseStability:
    """Verdict of :func:`inverse_stability` on a model's exact inverse.

    Attributes
    ----------
    coefficients : dict of int to float
        :math:`b_i` of the linear input part :math:`B(q^{-1}) = \\sum_i b_i q^{-i}`
        (lag ``i`` to coefficient; lags whose coefficients cancel are left out).
    zeros : ndarray of complex
        Zeros of :math:`B` in :math:`z` (``q⁻¹ = z⁻¹``); empty without a
        linear input part.
    unstable_zeros : ndarray of complex
        The zeros with :math:`|z| > 1 + \\text{tol}`.
    linearised : bool
        True when other terms depend on the input (listed in
        ``nonlinear_terms``): the verdict is then approximate.
    nonlinear_terms : tuple of str
        Input-dependent terms left out of :math:`B`.
    tol : float
        Tolerance on :math:`|z| = 1`.
    """

    coefficients: Dict[int, float]
    zeros: np.ndarray
    unstable_zeros: np.ndarray
    linearised: bool
    nonlinear_terms: Tuple[str, ...]
    tol: float

    @property
    def minimum_phase(self) -> bool:
        """True when no zero lies outside the unit circle (within ``tol``)."""
        return self.unstable_zeros.size == 0

    def polynomial(self) -> str:
        """:math:`B(q^{-1})` as text, e.g. ``'3.301q⁻¹ - 5.638q⁻²'``."""
        sup = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")
        out = ""
        for i, b in sorted(self.coefficients.items()):
            sign = "-" if b < 0 else "+"
            out += (f" {sign} " if out else ("-" if b < 0 else ""))
            out += "" if abs(b) == 1.0 and i else _fmt(abs(b))
            out += f"q⁻{str(i).translate(sup)}" if i else ""
        return out or "0"

    def describe(self) -> str:
        """One sentence: the polynomial, the zeros outside the unit circle, the verdict."""
        kind = (f"linearised (leaving out {len(self.nonlinear_terms)} nonlinear input "
                f"term(s)), " if self.linearised else "")
        if not self.coefficients:
            return "the model has no term linear in the input: no zeros to check"
        if self.minimum_phase:
            return (f"{kind}the linear input part B(q⁻¹) = {self.polynomial()} has no zero "
                    f"outside the unit circle (minimum-phase)")
        zs = ", ".join(f"{_fmt_zero(z)} (|z| = {_fmt(abs(z))})" for z in self.unstable_zeros)
        if self.linearised:
            return (f"the model may be non-minimum-phase: {kind}its linear input part "
                    f"B(q⁻¹) = {self.polynomial()} has zeros outside the unit circle at "
                    f"z = {zs}, so an exact step-by-step inverse may be unstable (the "
                    f"nonlinear terms left out can change that: watch the fallbacks and "
                    f"the input's range)")
        return (f"the model is non-minimum-phase: {kind}its linear input part "
                f"B(q⁻¹) = {self.polynomial()} has zeros outside the unit circle at z = "
                f"{zs}, so an exact step-by-step inverse is unstable")


def inverse_stability(model, tol: float = 1e-6) -> InverseStability:
    """Zeros of a one-input model's linear input part, and whether its inverse is stable.

    Parameters
    ----------
    model : narx.Model
        Model with parameters (``theta``).
    tol : float, optional
        A zero counts as outside the unit circle when :math:`|z| > 1 + \\text{tol}`
        (a double zero at 1 is computed only to about 1e-8).

    Returns
    -------
    InverseStability
        ``minimum_phase`` is False when a zero lies outside the unit circle.

    Raises
    ------
    ValueError
        If the model has no parameters, or more than one input.
    """
    if model.theta is None:
        raise ValueError("the model has no parameters yet: fit it or pass theta")
    if len(model.inputs) != 1:
        raise ValueError(f"the inverse check is for one-input models, got inputs "
                         f"{list(model.inputs)}")
    coef: Dict[int, float] = {}
    nonlinear = []
    for term, th in active_terms(model):
        fs = term.factors
        if len(fs) == 1 and isinstance(fs[0], Lag):
            if fs[0].role == "u":
                coef[fs[0].lag] = coef.get(fs[0].lag, 0.0) + th
        elif len(fs) == 1 and _form(fs[0]) == "difference" and len(fs[0].args) == 2:
            for a, s in zip(fs[0].args, (1.0, -1.0)):
                if a.role == "u":
                    coef[a.lag] = coef.get(a.lag, 0.0) + s * th
        elif input_lags(term):
            nonlinear.append(str(term))
    scale = max((abs(v) for v in coef.values()), default=0.0)
    coef = {k: v for k, v in sorted(coef.items()) if abs(v) > 1e-12 * scale}
    if coef:
        lo, hi = min(coef), max(coef)
        zeros = np.roots([coef.get(i, 0.0) for i in range(lo, hi + 1)]).astype(complex)
    else:
        zeros = np.zeros(0, dtype=complex)
    zeros = zeros[np.argsort(-np.abs(zeros), kind="stable")]
    return InverseStability(coefficients=coef, zeros=zeros,
                            unstable_zeros=zeros[np.abs(zeros) > 1.0 + tol],
                            linearised=bool(nonlinear), nonlinear_terms=tuple(nonlinear),
                            tol=float(tol))


def uninvertible_reason(model, lag: int) -> Optional[str]:
    """Why the model cannot be solved for ``u[k-lag]``, or None if it can.

    The compensator solves for the most recent input the model uses; it needs
    a term with nonzero θ in which that input enters polynomially (as a
    factor or inside ``Phi1``). Inside ``Phi2`` it enters only through a
    sign, constant on each side of its breakpoint, which has no inverse.

    Parameters
    ----------
    model : narx.Model
        Model with parameters.
    lag : int
        The input lag to solve for.

    Returns
    -------
    str or None
        The reason (the sign terms and the first input lag that enters
        polynomially, if any), or None when ``u[k-lag]`` enters polynomially.
    """
    def poly_lags(term):
        return [a.lag for f in term.factors if isinstance(f, Lag) or _form(f) == "difference"
                for a in ((f,) if isinstance(f, Lag) else f.args) if a.role == "u"]

    active = active_terms(model)
    if any(lag in poly_lags(t) for t, _ in active):
        return None
    signs = [f"{t} (θ = {th:.2g})" for t, th in active if lag in input_lags(t)]
    first = min(((la, str(t)) for t, _ in active for la in poly_lags(t) if la > lag),
                default=None)
    then = (f"the first input lag that enters polynomially is u[k-{first[0]}] (in "
            f"{first[1]}), but the compensator must solve for the most recent input the "
            f"model uses; drop the sign term(s) of u[k-{lag}] and refit, or"
            if first else "no input lag enters polynomially:")
    return (f"u[k-{lag}], the most recent input the model uses (the one the compensator "
            f"solves for), enters it only through a sign (Phi2) in "
            f"{', '.join(signs)}: a sign is constant on each side of its breakpoint and "
            f"cannot be inverted; {then} use a data-driven compensator "
            f"(mggp.compensate.identify_inverse): there is nothing to invert")
