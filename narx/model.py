"""The NARX model: terms, parameters θ, signal names; fit, simulate, save.

Typical use::

    from narx import Model
    m = Model(["y[k-1]", "Phi1(u[k-1],u[k-2])"]).fit(u, y)          # LS
    m = Model(terms).fit(u, y, constraints="steady-state")          # CLS
    r = m.simulate(u, y, mode="ms", window=50)
    m.save("model.json"); m2 = Model.load("model.json")

.. math::  y_k = \\sum_{i=1}^{n} \\theta_i\\, t_i(y_{k-1}, \\dots, u_{k}, \\dots)

Terms with noise lags ``e[k-j]`` (NARMAX) are estimated by extended least
squares: residuals of the previous iterate stand in for the noise [1]_.

References
----------
.. [1] Billings, S. A., "Nonlinear System Identification: NARMAX Methods in
   the Time, Frequency, and Spatio-Temporal Domains", Wiley, 2013, ch. 3.
"""
from __future__ import annotations

import contextlib
import json
import os
import warnings
from typing import Optional, Sequence

import numpy as np

from .records.data import Data, as_data
from .atomic import atomic_write_text
from .estimation.estimate import constrained_least_squares, least_squares
from .exceptions import EstimationError, ModelFileError, RankWarning, TermError
from .modelio import fail, model_fields, model_json, model_to_dict, read_model_json
from .language.phi import PhiRegistry, default_registry
from .records.ranges import signal_ranges
from .records.regressors import max_lag, regressor_matrix, term_column
from .simulation.simulate import SimulationResult, simulate
from .analysis.steady import cluster_sums, steady_state_constraints
from .language.terms import HasSignals, Signals, Term, parse_terms

__all__ = ["Model", "RankWarning", "ignore_rank_warnings", "load_model", "save_model",
           "model_from_dict", "model_to_dict", "ModelFileError"]


@contextlib.contextmanager
def ignore_rank_warnings():
    """No :class:`RankWarning` inside: for trial fits whose caller reports
    the rank itself (``fit_info_['rank']``)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RankWarning)
        yield


class Model(HasSignals):
    """A polynomial NARX(MAX) model.

    Parameters
    ----------
    terms : sequence of str or Term
        Model terms in the canonical term language.
    theta : array_like, optional
        Parameters, one per term (set by :meth:`fit` otherwise).
    inputs : sequence of str
        Input signal names (default ``('u',)``).
    output : str
        Output signal name (default ``'y'``).
    noise : str
        Name of the noise signal in NARMAX terms (default ``'e'``).
    meta : dict, optional
        Free metadata saved with the model (fitness, seed, versions...).
    """

    def __init__(self, terms, theta=None, *, inputs=("u",), output="y",
                 noise="e", meta=None, registry: Optional[PhiRegistry] = None):
        self.signals = Signals(output, inputs, noise)
        self.registry = registry or default_registry()
        self.terms = parse_terms(terms, self.signals, registry=self.registry)
        if not self.terms:
            raise ValueError("a model needs at least one term, got none")
        self.theta = None if theta is None else self._check_theta(theta)
        self.meta = dict(meta or {})
        self.fit_info_ = None

    # ------------------------------------------------------------ basics
    def _check_theta(self, theta):
        th = np.asarray(theta, dtype=np.float64).ravel()
        if th.shape[0] != len(self.terms):
            raise ValueError(f"theta has {th.shape[0]} values but the model has "
                             f"{len(self.terms)} terms")
        if not np.all(np.isfinite(th)):
            raise ValueError(f"theta has a non-finite value: {th[~np.isfinite(th)][0]}")
        return th

    @property
    def n_terms(self) -> int:
        return len(self.terms)

    @property
    def max_lag(self) -> int:
        return max_lag(self.terms)

    @property
    def term_texts(self):
        return [str(t) for t in self.terms]

    def _data(self, u, y=None) -> Data:
        d = as_data(u, y, inputs=self.inputs, output=self.output)
        if tuple(d.inputs) != tuple(self.inputs):
            raise ValueError(f"data inputs {list(d.inputs)} do not match the model's "
                             f"{list(self.inputs)}")
        return d

    def _need_theta(self):
        if self.theta is None:
            raise ValueError("the model has no parameters yet: call fit() or pass theta")
        return self.theta

    def __repr__(self):
        return (f"Model({self.term_texts!r}, "
                f"theta={None if self.theta is None else [float(f'{v:.6g}') for v in self.theta]}, "
                f"inputs={list(self.inputs)!r}, output={self.output!r})")

    # ------------------------------------------------------------ estimation
    def fit(self, u, y=None, *, constraints=None, noise_iterations: int = 20,
            tol: float = 1e-8) -> "Model":
        """Estimate θ by LS, or CLS under ``constraints``; returns ``self``.

        Parameters
        ----------
        u, y : arrays or a :class:`~narx.records.data.Data` record as ``u``.
        constraints : None, ``'steady-state'`` or ``(S, c)``
            ``'steady-state'`` derives the continuum-of-steady-states
            equalities from the terms (:mod:`narx.analysis.steady`).
        noise_iterations : int
            Extended-LS iterations when the model has noise terms.
        """
        d = self._data(u, y)
        S, c, labels = self._constraints(constraints)
        noise = None
        has_noise = any(t.has_noise for t in self.terms)
        iters = max(1, int(noise_iterations)) if has_noise else 1
        prev = None
        # ELS: only the columns of noise terms change between iterations
        refresh = [j for j, t in enumerate(self.terms) if t.has_noise]
        Psi = None
        for _ in range(iters):
            if Psi is None:
                Psi, target, start = regressor_matrix(self.terms, d, noise=noise,
                                                      registry=self.registry)
            else:
                for j in refresh:
                    Psi[:, j] = term_column(self.terms[j], d, d.y, noise,
                                            self.registry)[start:]
            if S is None:
                est = least_squares(Psi, target)
            else:
                est = constrained_least_squares(Psi, target, S, c, labels=labels)
            if not has_noise:
                break
            noise = np.zeros(d.n)
            noise[start:] = target - Psi @ est.theta
            if prev is not None and np.max(np.abs(est.theta - prev)) <= tol * (
                    1 + np.max(np.abs(prev))):
                break
            prev = est.theta
        self.theta = est.theta
        if est.rank < len(self.terms):
            warnings.warn(f"the regressors of the {len(self.terms)} terms have rank "
                          f"{est.rank} on this record: some terms cannot be told apart "
                          f"and θ is the minimum-norm solution", RankWarning, stacklevel=2)
        self.fit_info_ = {"method": est.method, "rank": est.rank,
                          "residuals": target - Psi @ est.theta,
                          "n_samples": int(Psi.shape[0]), "start": int(start),
                          "residual_ss": est.residual_ss,
                          "constraints": labels if S is not None else None}
        self.meta["estimation"] = est.method        # the latest fit's method
        # the training record's signal ranges: compensators and checks use
        # them for the scale of the signals (units, offsets), and
        # narx.records.ranges.range_warning names a record's inputs that leave them
        self.meta["ranges"] = signal_ranges(d)
        return self

    def _constraints(self, constraints):
        if constraints is None:
            return None, None, None
        if isinstance(constraints, str):
            if constraints not in ("steady-state", "steady_state"):
                raise ValueError(f"constraints must be None, 'steady-state' or (S, c), "
                                 f"got {constraints!r}")
            cons = steady_state_constraints(self.terms, self.registry)
            return cons.S, cons.c, list(cons.labels)
        try:
            S, c = constraints
        except (TypeError, ValueError):
            raise ValueError("constraints must be None, 'steady-state' or (S, c)") from None
        return np.atleast_2d(np.asarray(S, float)), np.asarray(c, float).ravel(), None

    # ------------------------------------------------------------ simulation
    def simulate(self, u, y=None, mode: str = "freerun", *, k=None, window=None,
                 y0=None, history=None) -> SimulationResult:
        """Simulate in ``mode`` ('osa', 'freerun', 'ksa', 'ms'), the memory
        operators started from ``history`` ('rest', 'rising', 'falling' or
        'estimate'; default the record's own); see
        :func:`narx.simulation.simulate.simulate`."""
        d = self._data(u, y)
        return simulate(self.terms, self._need_theta(), d, mode, k=k, window=window,
                        y0=y0, registry=self.registry, history=history)

    def predict(self, u, y=None, mode: str = "freerun", **kw) -> np.ndarray:
        return self.simulate(u, y, mode, **kw).y_hat

    # ------------------------------------------------------------ steady state
    def steady_state_constraints(self):
        return steady_state_constraints(self.terms, self.registry)

    def cluster_sums(self):
        return cluster_sums(self.terms, self._need_theta(), self.registry)

    # ------------------------------------------------------------ export
    def equation(self, precision: int = 4) -> str:
        th = self._need_theta()
        parts = []
        for i, (t, v) in enumerate(zip(self.terms, th)):
            sign = "-" if v < 0 else "+"
            body = f"{abs(v):.{precision}g}" + ("" if str(t) == "1" else f"*{t}")
            parts.append(f"{'' if sign == '+' else '-'}{body}" if i == 0 else f"{sign} {body}")
        return f"{self.output}[k] = " + " ".join(parts)

    def to_sympy(self):
        """The right-hand side as a sympy expression (symbols ``y[k-1]`` ...)."""
        from .export import to_sympy
        return to_sympy(self)

    def to_latex(self, precision: int = 4) -> str:
        from .export import to_latex
        return to_latex(self, precision)

    def to_dict(self) -> dict:
        """The dict of the model's file (:func:`narx.modelio.model_to_dict`)."""
        return model_to_dict(self)

    @classmethod
    def from_dict(cls, d: dict, source: str = "model", registry=None) -> "Model":
        """The model of a model file's dict, every field checked
        (:class:`ModelFileError` names ``source`` and the field)."""
        fields = model_fields(d, source, registry)
        try:
            return cls(**fields)
        except (TermError, ValueError, OverflowError) as exc:
            fail(source, str(exc))

    def save(self, path) -> None:
        """Write the model as JSON (atomically), after checking that
        :meth:`load` reads it back: a model the loader would refuse (too
        many terms or factors) raises :class:`ModelFileError`, nothing is
        written."""
        text = model_json(self)
        self.from_dict(json.loads(text), os.fspath(path), self.registry)
        atomic_write_text(path, text)

    @classmethod
    def load(cls, path, registry=None) -> "Model":
        """Read a model file; any problem raises :class:`ModelFileError`."""
        return cls.from_dict(read_model_json(path), os.fspath(path), registry)


def model_from_dict(d: dict, source: str = "model", registry=None) -> Model:
    """:meth:`Model.from_dict`."""
    return Model.from_dict(d, source, registry)


def save_model(model: Model, path) -> None:
    """:meth:`Model.save`."""
    model.save(path)


def load_model(path, registry=None) -> Model:
    """:meth:`Model.load`: read a model file; any problem raises
    :class:`ModelFileError`."""
    return Model.load(path, registry)
