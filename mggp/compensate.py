"""Data-driven hysteresis compensation by MGGP, and PI feedback loops.

Typical use::

    from mggp.compensate import identify_inverse, pi_loop, PiezoPlant
    from narx.analysis.compensate import RootCompensator
    inv = identify_inverse(u, y, lead=1, fitness="ms", window=500, max_lag=2,
                           random_state=0, n_jobs=2)      # actuator data (u -> y)
    res = inv.run(r, input_range=(-80, 80))               # res.m: actuator input
    y = piezo_bouc_wen(res.m)                             # apply to the actuator
    loop = pi_loop(PiezoPlant(), r, compensator=RootCompensator(model), kp=0.1, ki=0.2)
    loop.rmse

*Data-driven compensator* [1]_. Instead of inverting an identified model
step by step, the inverse is identified directly from the actuator's data:
the compensator's input is the actuator's output and its output is the
actuator's input. Causality needs the output one step ahead: with
``lead`` :math:`\\ell` the compensator's input signal is
:math:`\\rho_k = y_{k+\\ell}` (at run time :math:`\\rho_k = r_{k+\\ell}`), and
MGGP searches

.. math::  m_k = \\sum_i \\theta_i\\, t_i(m_{k-1}, \\dots, \\rho_{k-1}, \\dots),

so with :math:`\\ell = 1` the term :math:`\\rho_{k-1} = r_k` is the present
reference. The structure search, the LS/CLS estimation and the
continuum-of-steady-states constraints are those of
:class:`~mggp.fit.estimator.MGGPRegressor` (an inverse that holds its output
when the reference holds is refitted by CLS). At run time the inverse model
runs in free run, one sample at a time (so it can sit inside a loop), with
its output clipped to the actuator's input range.

*PI loop.* A discrete PI acts on the last measured error,
:math:`e_{k-1} = r_{k-1} - y_{k-1}` (the actuator feeds its input through,
so :math:`y_k` is not known when :math:`m_k` is chosen):

.. math::  I_k = I_{k-1} + k_i e_{k-1}, \\qquad v_k = k_p e_{k-1} + I_k,

alone :math:`m_k = v_k / g` (``gain`` normalises the actuator), or around a
compensator :math:`m_k = C(r_{k+\\ell} + v_k)`: the compensator cancels the
hysteresis, the PI removes what its model misses. Integration stops while
the input is at a bound of ``input_range`` (anti-windup).

References
----------
.. [1] Abreu, P. E. O. G. B., Tavares, L. A., Teixeira, B. O. S., Aguirre,
   L. A., "Identification and nonlinearity compensation of hysteresis using
   NARX models", Nonlinear Dynamics, 2020.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from narx import Model
from narx.analysis.compensate import (CompensationResult, TermPlan, check_count, check_range,
                             check_reference, past_values)
from narx.records.data import Data
from narx.systems import piezo_bouc_wen

from .exceptions import CLSRejectedWarning

__all__ = ["InverseCompensator", "identify_inverse", "pi_loop", "LoopResult",
           "PiezoPlant", "INVERSE_KIND"]

#: ``meta["compensator"]["kind"]`` of a saved data-driven compensator
INVERSE_KIND = "inverse"


class InverseCompensator:
    """A data-driven compensator: a NARX model from reference to actuator input.

    Parameters
    ----------
    model : narx.Model
        One input (the shifted reference :math:`\\rho`), output the actuator
        input.
    lead : int
        :math:`\\rho_k = r_{k+\\ell}` (see the module docstring).
    input_range : (low, high), optional
        Clip the compensator's output (inside the recursion).
    """

    def __init__(self, model: Model, lead: int = 1, input_range=None):
        if len(model.inputs) != 1:
            raise ValueError(f"an inverse model has exactly one input (the reference), "
                             f"got inputs {list(model.inputs)}")
        self.model, self._plan = model, TermPlan(model, None)
        self.lead = check_count("lead", lead)
        self.input_range = check_range(input_range)
        self.delay = 0
        self.reset()

    @classmethod
    def from_model(cls, model: Model, input_range=None) -> "InverseCompensator":
        """Rebuild from a model saved by :meth:`save` (its ``meta`` holds the lead)."""
        info = model.meta.get("compensator")
        if not isinstance(info, dict) or info.get("kind") != INVERSE_KIND:
            raise ValueError("the model is not a data-driven compensator: its meta has no "
                             f"'compensator': {{'kind': '{INVERSE_KIND}', ...}}")
        return cls(model, info.get("lead", 1), input_range)

    def save(self, path) -> None:
        self.model.meta["compensator"] = {"kind": INVERSE_KIND, "lead": self.lead}
        self.model.save(path)

    def reset(self, u_past=0.0, r_past=0.0):
        """Restart from actuator inputs ``u_past`` and references before the record."""
        ml = self.model.max_lag
        self._r = past_values("r_past", r_past, ml)
        self._m = past_values("u_past", u_past, ml)

    def step(self, target) -> float:
        """The actuator input for ``target`` = :math:`\\rho_k = r_{k+\\ell}`."""
        self._r.append(float(target))
        m = sum(p[0] for p in self._plan.parts(self._r, self._m, len(self._r) - 1,
                                               len(self._m)))
        self.clipped_ = False
        if self.input_range is not None:
            c = min(max(m, self.input_range[0]), self.input_range[1])
            self.clipped_ = c != m
            m = c
        self._m.append(float(m))
        return float(m)

    def run(self, r, input_range=None, u_past=0.0, r_past=0.0) -> CompensationResult:
        """Compensate a whole reference (restarting from ``u_past``/``r_past``)."""
        r = check_reference(r)
        if input_range is not None:
            self.input_range = check_range(input_range)
        self.reset(u_past, r_past)
        n = r.size
        target = r[np.minimum(np.arange(n) + self.lead, n - 1)]
        m, clipped = np.empty(n), np.zeros(n, dtype=bool)
        for j, t in enumerate(target):
            m[j] = self.step(t)
            clipped[j] = self.clipped_
        # ``saturated``: steps whose input was clipped to the input range
        return CompensationResult(m=m, r=r, target=target, y_model=None, lead=self.lead,
                                  delay=0, fallback=np.zeros(n, bool), fallbacks=0,
                                  saturated=int(clipped.sum()), n_roots=np.ones(n, dtype=int))


def identify_inverse(u, y, *, lead=1, reference="r", constrained=True, estimator=None,
                     **params) -> InverseCompensator:
    """Identify a data-driven compensator from actuator data by MGGP.

    Parameters
    ----------
    u, y : array_like (N,)
        Actuator input and output (noise-free or measured).
    lead : int
        The compensator sees :math:`\\rho_k = y_{k+\\ell}` (default 1).
    reference : str
        Name of the compensator's input signal in its terms (default ``r``).
    constrained : bool
        Use the CLS refit when it exists (``constraints='steady-state'``).
    estimator : MGGPRegressor, optional
        A configured estimator; otherwise one is built from ``params``
        (e.g. ``population``, ``generations``, ``fitness``, ``random_state``,
        ``n_jobs``).

    Returns
    -------
    InverseCompensator
        ``.estimator_`` holds the fitted :class:`~mggp.fit.estimator.MGGPRegressor`.

    Notes
    -----
    An inverse runs free in use (its input is the reference, its recursion
    on its own past outputs), so unless ``select`` is given the structure is
    chosen among the search's best by free-run error over the whole
    training record (``select="freerun"``): searches with multiple-shooting
    fitness alone also return inverses that integrate reference increments
    (``u[k] = u[k-1] + f(Δr)``) and drift over a long record, which
    windows of Δm samples never see. On the piezo actuator
    (``benchmarks/compensation.py``), ``fitness="ms", window=500,
    max_lag=2`` with that selection gave a good inverse for one seed of
    three and drifting ones for the other two; ``fitness="freerun"`` gave
    some with a ``u[k-2]`` recursion that oscillates at half the sampling
    rate. Check an inverse on a validation record before use. Unless
    ``operators`` is given the search has no memory operators: the
    compensator evaluates polynomial and Φ-terms only.
    """
    from .fit.estimator import MGGPRegressor
    lead = check_count("lead", lead)
    u = np.asarray(u, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if u.shape != y.shape:
        raise ValueError(f"u and y must have the same length, got {u.size} and {y.size}")
    if u.size <= lead + 2:
        raise ValueError(f"u and y must have more than lead + 2 = {lead + 2} samples, "
                         f"got {u.size}")
    name = "u" if reference != "u" else "m"
    data = Data(y[lead:], u[:u.size - lead], inputs=(reference,), output=name)
    if estimator is None:
        params.setdefault("constraints", "steady-state" if constrained else None)
        params.setdefault("select", "freerun")
        params.setdefault("screen", "freerun")      # leaders that run away in free run
        params.setdefault("operators", None)        # the inversion takes no memory operators
        estimator = MGGPRegressor(**params)
    with warnings.catch_warnings():           # the model is chosen here, explicitly
        warnings.simplefilter("ignore", CLSRejectedWarning)
        estimator.fit(data)
    model = estimator.get_best(bool(constrained and estimator.model_cls_ is not None))
    inv = InverseCompensator(model, lead)
    inv.estimator_ = estimator
    return inv


# ------------------------------------------------------------------ loops
class PiezoPlant:
    """The piezo actuator of :func:`narx.systems.piezo_bouc_wen`, one sample at a time.

    ``step(m)`` returns :math:`y_k` for :math:`u_k = m`; the state is the
    hysteretic variable :math:`h = d_p u - y`, so a run of steps equals the
    batch simulation of the same input (the first sample has
    ``y_0 = d_p u_0 - h_0``, as there).
    """

    def __init__(self, **params):
        self.params = dict(params)
        self.d_p = float(self.params.get("d_p", 1.6))
        self.reset()

    def reset(self):
        self._u = None
        self._h = float(self.params.get("h0", 0.0))

    def step(self, m) -> float:
        m = float(m)
        if self._u is None:
            y = self.d_p * m - self._h
        else:
            p = dict(self.params, h0=self._h)
            y = float(piezo_bouc_wen(np.array([self._u, m]), **p)[1])
        self._u, self._h = m, self.d_p * m - y
        return y


@dataclass(frozen=True)
class LoopResult:
    """A closed-loop run: reference, output, input, error ``r - y``, PI output."""

    r: np.ndarray
    y: np.ndarray
    m: np.ndarray
    v: np.ndarray

    @property
    def e(self) -> np.ndarray:
        return self.r - self.y

    @property
    def rmse(self) -> float:
        return float(np.sqrt(np.mean(self.e ** 2)))


def pi_loop(plant, r, *, compensator=None, kp=0.1, ki=0.2, gain=1.0, lead=None,
            input_range=None) -> LoopResult:
    """Run a discrete PI loop around ``plant``, optionally through a compensator.

    Parameters
    ----------
    plant : object with ``reset()`` and ``step(m) -> y``
        E.g. :class:`PiezoPlant`.
    r : array_like (N,)
        Reference.
    compensator : object with ``step(target) -> m``, optional
        A :class:`narx.analysis.compensate.RootCompensator` or
        :class:`InverseCompensator` (reset it before the call); ``None``
        runs the PI loop alone.
    kp, ki : float
        Proportional and integral gains per sample, >= 0.
    gain : float
        Static gain of the actuator, divides the PI output when alone, > 0.
    lead : int, optional
        Preview of the feedforward target ``r[k + lead]`` (default: the
        compensator's ``lead``).
    input_range : (low, high), optional
        Actuator input bounds (clip and anti-windup).
    """
    r = check_reference(r)
    for name, v in (("kp", kp), ("ki", ki)):
        if not (isinstance(v, (int, float)) and np.isfinite(v) and v >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {v!r}")
    if not (isinstance(gain, (int, float)) and np.isfinite(gain) and gain > 0):
        raise ValueError(f"gain must be a finite number > 0, got {gain!r}")
    rng = check_range(input_range)
    if compensator is not None:
        lead = getattr(compensator, "lead", 0) if lead is None else check_count("lead", lead)
    n = r.size
    y, m, v = np.zeros(n), np.zeros(n), np.zeros(n)
    plant.reset()
    integ, e_prev, held = 0.0, 0.0, False
    for k in range(n):
        if not held:
            integ += ki * e_prev
        v[k] = kp * e_prev + integ
        if compensator is None:
            mk = v[k] / gain
        else:
            mk = compensator.step(r[min(k + lead, n - 1)] + v[k])
        if rng is not None:
            held = not rng[0] < mk < rng[1]
            mk = min(max(mk, rng[0]), rng[1])
        m[k] = mk
        y[k] = plant.step(mk)
        e_prev = r[k] - y[k]
    return LoopResult(r=r, y=y, m=m, v=v)

