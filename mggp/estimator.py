"""scikit-learn-style estimator: MGGP structure search for NARX models.

Typical use::

    from mggp import MGGPRegressor
    est = MGGPRegressor(fitness="ms", window=100, population=200, generations=50,
                        constraints="steady-state", random_state=0, n_jobs=2).fit(u, y)
    est.model_                      # narx.Model, θ by LS (QR) on all data
    est.model_cls_                  # its CLS refit (continuum of steady states)
    print(est.pareto_front_)        # complexity, loss, score, equation (mggp.pareto)
    est.simulate(u_val, y_val, mode="freerun").mape

The search (``mggp.evolve``) proposes term sets; each is scored by LS and
the chosen simulation (``mggp.evaluate``); the best structure is refitted
by QR least squares on the full record, and with
``constraints='steady-state'`` also by constrained LS under the
continuum-of-steady-states equalities derived from its terms [1]_.

References
----------
.. [1] Abreu, P. E. O. G. B., Tavares, L. A., Teixeira, B. O. S., Aguirre,
   L. A., "Identification and nonlinearity compensation of hysteresis using
   NARX models", Nonlinear Dynamics, 2020.
"""
from __future__ import annotations

import json
import random
import time
import warnings
from typing import List, Optional

import numpy as np

from narx import Model
from narx.model import ignore_rank_warnings
from narx.data import Data, DataError, as_data
from narx.fitness import StructureScorer
from narx.phi import default_registry
from narx.terms import Term

from .evaluate import Evaluator, criterion_value
from . import versions
from .checkpoint import checkpoint_seed, data_digest
from .evolve import evolve
from .noise import full_ma, prune_by_t, prune_process, select_noise
from .params import check_params
from .precision import data_warnings, search_precision
from .pareto import ParetoFront, front_rows
from .primitives import identically_zero, make_pset, max_lag_for_height
from .screen import StabilityScreen
from .selection import (CLSRejectedWarning, cls_rejection, prune_by_criterion, run_candidates,
                        select_freerun, select_hold, t_threshold_of)

__all__ = ["MGGPRegressor", "ParetoFront"]

#: the constant term ``1`` (the empty product) added by ``constant=True``
CONSTANT = Term(())


class MGGPRegressor:
    """Multi-gene GP structure search for polynomial NARX models.

    Parameters (all keyword; defaults are the published setup)
    ----------
    fitness : {'ms', 'pem', 'freerun', 'ksa'}
        Simulation whose MSE scores a structure.
    window : int
        Δm of multiple shooting (100).
    k : int
        Horizon of ``ksa`` (10).
    criterion : {'mse', 'bic', 'aic'}
        Fitness: the MSE, or an information criterion penalising terms.
    constraints : None or 'steady-state'
        Refit the best structure by CLS as well (``model_cls_``).
    search_constraints : None or 'steady-state'
        Use CLS inside the search too.
    population, generations, cxpb, mutpb, high_level_cx_rate,
    high_level_mut_rate, tournament_size, elite_fraction, max_terms,
    max_height : evolution parameters (500, 200, 0.8, 0.2, 0.5, 0.5, 2, 0.1,
        15, 5).
    use_phi : bool
        Include Φ-functions in the primitive set (``--no-phi`` = False).
    phi_names : list of str, optional
        Φ-functions to use (default: all registered).
    phi_outputs : bool
        Φ-terms of output lags too (``Phi1(y[k-1],y[k-2])``; default False).
    constant : bool
        Every structure also holds the constant term ``1`` (an intercept):
        for records whose output rests at an offset the lag terms cannot
        express, e.g. an affine static curve (default False).
    max_lag, max_degree : int, optional
        Genes decoding to a term with a larger lag or more factors
        contribute no term (e.g. lags up to 4, degree up to 3).
    select : {'fitness', 'freerun', 'hold'}
        How the final structure is chosen: the best search fitness, or,
        among the ``select_candidates`` best distinct structures of the run
        (archive and final population), the one with the lowest free-run
        MSE over the whole training record — multiple shooting never sees
        an instability longer than its window.
        ``'hold'``: the best search fitness among those candidates whose
        free run stays in the screen's band and whose CLS refit holds its
        output on held inputs (see ``screen``); the best structure if none
        does (``selection_`` lists the verdicts).
    select_candidates : int
        Candidates for ``select='freerun'`` and ``'hold'`` (20).
    screen : None, 'freerun' or 'hold'
        Stability screen during the search (:mod:`mggp.screen`): in each
        generation the ``screen_top`` best new structures are simulated in
        free run over the whole training record, and those whose output
        leaves ``[min y, max y]`` widened by ``screen_band * range(y)`` on
        each side get the fitness ``inf``;
        so the elites, and the result, never diverge over the record.
        ``'hold'`` also requires the structure's CLS refit to hold its
        output when the input is frozen (stretches of the training record
        followed by held inputs; no movement above 1e-6 of the output range
        after 100 samples).
    screen_top : int, optional
        Leaders screened per generation (default: the elite size).
    screen_band : float
        Widening of the allowed band beyond ``[min y, max y]``, in output
        ranges (1).
    prune : False, 'bic' or 't'
        Backward elimination of the best structure: by the BIC of the
        search fitness, or by LS t-statistics (drop the least significant
        term while its |t| < ``t_threshold``).
    noise_lags : int
        With q > 0, a moving-average noise model is selected after the
        search (NARMAX): candidates ``e[k-j]`` and ``x*e[k-j]`` (x a lag
        1..q of an input or the output), j = 1..q, are added one at a time
        by extended least squares (each step ranks them with the noise held
        and fits the 3 best by ELS) while the best has |t| >= ``t_threshold``,
        and the process parameters are re-estimated with it. The search
        scores with the plain one-step error, so strong coloured noise can
        lead it to extra lags that only predict the noise; with
        ``prune='t'`` those are pruned by their ELS t-statistics with the
        full MA(q) model in the fit first (:mod:`mggp.noise`).
    refine : None, 'ms' or 'freerun'
        Refine θ of the result (and of its CLS refit, keeping the
        constraints) by minimising its simulation error instead of the
        one-step error of least squares (:mod:`narx.refine`): LS is biased
        when the measured output is noisy (``refinement_`` holds the errors
        before and after). ``refine_window``: Δm for ``'ms'`` (default
        ``window``).
    t_threshold : float, optional
        Default: Bonferroni, Φ⁻¹(1 − 0.05/(2M)) with M the number of
        candidate monomials allowed by ``max_lag`` (at most the lag
        ``max_height`` trees reach, 1 + 3 × height) and ``max_degree``.
    random_state : int, optional
        Seed; the result does not depend on ``n_jobs`` or ``backend``.
    n_jobs : int
        Worker processes for evaluation.
    backend : {'loky', 'threading', 'sequential', 'dask'}
    scheduler : str or dask Client, optional
    inputs, output : sequence of str, str
        Signal names when ``fit`` gets arrays. With several inputs every
        Φ-term searched takes lags of one input only.
    checkpoint : path, optional;  resume : bool
    callbacks : list of callables ``f(state)`` called every generation.

    After ``fit``, besides ``model_``, ``model_cls_``, ``pareto_front_`` and
    ``logbook_``: ``cls_rejected_`` says why the CLS refit is not used by
    ``get_best``/``simulate``/``predict`` (it diverges in free run on the
    training record or its RMSE is over twice the LS fit's; None: it is);
    ``precision_`` (:class:`mggp.precision.PrecisionCheck`) holds
    the chosen structure's fitness with the search's normal-equation fit and
    with the QR refit; when the refit simulates more than 1.25× worse (nearly
    collinear terms: the exact LS θ has large cancelling coefficients)
    ``model_`` keeps the search's θ, which is what was scored
    (``model_.meta['estimation'] == 'ls-search'``). A
    :class:`mggp.precision.SearchPrecisionWarning` names an offset that
    dominates a signal before the search (its normal equations lose
    precision on such data).
    """

    def __init__(self, *, fitness="ms", window=100, k=10, criterion="mse",
                 constraints=None, search_constraints=None, population=500,
                 generations=200, cxpb=0.8, mutpb=0.2, high_level_cx_rate=0.5,
                 high_level_mut_rate=0.5, tournament_size=2, elite_fraction=0.1,
                 max_terms=15, max_height=5, use_phi=True, phi_names=None,
                 phi_outputs=False, constant=False, max_lag=None, max_degree=None,
                 select="fitness", select_candidates=20,
                 screen=None, screen_top=None, screen_band=1.0, prune=False, noise_lags=0,
                 t_threshold=None, refine=None, refine_window=None,
                 random_state=None, n_jobs=1, backend="loky",
                 scheduler=None, inputs=None, output="y", checkpoint=None,
                 resume=False, callbacks=None, registry=None):
        self.fitness = fitness
        self.window = window
        self.k = k
        self.criterion = criterion
        self.constraints = constraints
        self.search_constraints = search_constraints
        self.population = population
        self.generations = generations
        self.cxpb = cxpb
        self.mutpb = mutpb
        self.high_level_cx_rate = high_level_cx_rate
        self.high_level_mut_rate = high_level_mut_rate
        self.tournament_size = tournament_size
        self.elite_fraction = elite_fraction
        self.max_terms = max_terms
        self.max_height = max_height
        self.use_phi = use_phi
        self.phi_names = phi_names
        self.phi_outputs = phi_outputs
        self.constant = constant
        self.max_lag = max_lag
        self.max_degree = max_degree
        self.select = select
        self.select_candidates = select_candidates
        self.screen = screen
        self.screen_top = screen_top
        self.screen_band = screen_band
        self.prune = prune
        self.noise_lags = noise_lags
        self.refine = refine
        self.refine_window = refine_window
        self.t_threshold = t_threshold
        self.random_state = random_state
        self.n_jobs = n_jobs
        self.backend = backend
        self.scheduler = scheduler
        self.inputs = inputs
        self.output = output
        self.checkpoint = checkpoint
        self.resume = resume
        self.callbacks = callbacks
        self.registry = registry

    # -------------------------------------------------------------- sklearn
    def get_params(self, deep=True):
        import inspect
        names = [p for p in inspect.signature(type(self).__init__).parameters if p != "self"]
        return {n: getattr(self, n) for n in names}

    def set_params(self, **params):
        valid = self.get_params()
        for k, v in params.items():
            if k not in valid:
                raise ValueError(f"invalid parameter {k!r} for MGGPRegressor")
            setattr(self, k, v)
        return self

    def __repr__(self):
        """Parameters that differ from the defaults, as scikit-learn shows them."""
        import inspect
        defaults = {k: p.default for k, p in
                    inspect.signature(type(self).__init__).parameters.items() if k != "self"}
        changed = [f"{k}={v!r}" for k, v in self.get_params().items()
                   if not (v is defaults[k] or (type(v) is type(defaults[k])
                                                and v == defaults[k]))]
        return f"{type(self).__name__}({', '.join(changed)})"

    # -------------------------------------------------------------- fit
    def _validate(self, data: Data):
        check_params(self)
        start = max_lag_for_height(self.max_height)
        if data.n < start + max(4 * self.max_terms, 20):
            raise DataError(f"{data.n} samples are too few: the search needs at least "
                            f"{start + max(4 * self.max_terms, 20)} (largest lag {start} "
                            f"for max_height={self.max_height})")
        for name in data.inputs:
            if np.ptp(data.input(name)) == 0:
                raise DataError(f"input {name!r} is constant: nothing can be identified")
        if self.fitness == "ksa" and self.k >= data.n - start:
            raise DataError(f"k={self.k} steps ahead do not fit in the {data.n - start} "
                            f"scored samples (k must be below that)")
        if np.ptp(data.y) == 0:
            raise DataError(f"output {data.output!r} is constant (every sample "
                            f"{float(data.y[0])!r}): nothing can be identified")
        return start

    def _seed(self) -> int:
        rs = self.random_state
        if rs is None:
            return random.SystemRandom().randrange(2**31)
        if isinstance(rs, np.random.Generator):
            return int(rs.integers(2**31))
        if isinstance(rs, (int, np.integer)) and not isinstance(rs, bool):
            return int(rs)
        raise ValueError(f"random_state must be None, an int or a numpy Generator, got {rs!r}")

    def fit(self, u, y=None):
        """Search a structure on ``(u, y)`` (arrays or a narx.Data); returns self."""
        t0 = time.perf_counter()
        for name in [a for a in vars(self) if a.endswith("_") and not a.startswith("_")]:
            delattr(self, name)                 # nothing from an earlier fit survives
        inputs = self.inputs
        data = as_data(u, y, inputs=inputs, output=self.output)
        data.require_output("fit")
        start = self._validate(data)
        for msg, kind in data_warnings(data, self.fitness, self.window, self.k):
            warnings.warn(msg, kind, stacklevel=2)
        if self.max_lag is not None and self.max_lag > start:
            warnings.warn(f"max_lag={self.max_lag} has no effect: trees of max_height="
                          f"{self.max_height} reach lags up to {start} only (1 + 3 × "
                          f"height); raise max_height to reach longer lags",
                          UserWarning, stacklevel=2)
        registry = self.registry or default_registry()
        pset = make_pset(data.signals, registry, use_phi=self.use_phi, phi_names=self.phi_names,
                         phi_outputs=bool(self.phi_outputs))
        evaluator = Evaluator(data, self.fitness, window=self.window, k=self.k,
                              constraints=self.search_constraints, start=start,
                              criterion=self.criterion, n_jobs=self.n_jobs,
                              backend=self.backend, scheduler=self.scheduler,
                              registry=registry)
        callbacks = list(self.callbacks or [])
        shape = self._structure
        screen = self._make_screen(data, start, registry)

        def evaluate_batch(term_sets):
            sets = [shape(ts) for ts in term_sets]
            values = evaluator(sets)
            return values if screen is None else screen(sets, values)

        def on_generation(state):
            for cb in callbacks:
                cb(state)
        seed = self._seed()
        if self.resume and self.checkpoint is not None and self.random_state is None:
            seed = checkpoint_seed(self.checkpoint) or seed   # continue its run
        context = {"data": data_digest(data), **{k: getattr(self, k) for k in _CONTEXT}}
        for name in ("phi_outputs", "constant"):
            if not context[name]:      # absent: checkpoints written before it resume
                del context[name]
        try:
            res = evolve(pset, evaluate_batch, seed=seed, population_size=self.population,
                         generations=self.generations, cxpb=self.cxpb, mutpb=self.mutpb,
                         high_level_cx_rate=self.high_level_cx_rate,
                         high_level_mut_rate=self.high_level_mut_rate,
                         tournament_size=self.tournament_size,
                         elite_fraction=self.elite_fraction, max_terms=self.max_terms,
                         max_height=self.max_height, on_generation=on_generation,
                         checkpoint=self.checkpoint, resume=self.resume,
                         context=json.loads(json.dumps(context, default=str)),
                         structure=shape)
        finally:
            evaluator.close()
        if res.best is None or not np.isfinite(res.best.fitness):
            raise ValueError("no structure with a finite fitness was found: every "
                             "candidate diverged; try fitness='pem' or a shorter window")
        terms = shape(res.best.terms)
        if self.select in ("freerun", "hold"):
            cands = run_candidates(res, data.signals, shape, self.select_candidates)
        if self.select == "freerun":
            chosen, self.selection_ = select_freerun(cands, data, start, registry)
            terms = chosen or terms
        elif self.select == "hold":
            chosen, self.selection_ = select_hold(cands, data, start, registry,
                                                  self.screen_band)
            if not chosen:
                warnings.warn(f"select='hold': none of the {len(self.selection_)} "
                              f"candidates holds its output on a held input; model_ is "
                              f"the best-fitness structure (see selection_)",
                              UserWarning, stacklevel=2)
            terms = chosen or terms
        self.search_terms_ = terms
        scorer = StructureScorer(data, self.fitness, window=self.window, k=self.k,
                                 constraints=self.search_constraints, start=start,
                                 registry=registry)
        if self.prune == "bic":
            terms = prune_by_criterion(scorer, terms, data.n - start)
        elif self.prune == "t":
            terms = self._prune_t(data, terms, start)
        if self.noise_lags:
            crit = t_threshold_of(self, len(data.inputs))
            if self.prune == "t":               # terms that only predicted the noise
                terms = prune_process(data, terms, full_ma(data, int(self.noise_lags),
                                                           registry), start, registry, crit)
            terms = terms + select_noise(data, terms, start, registry,
                                         int(self.noise_lags), crit)
        self.terms_ = terms
        self.fitness_ = res.best.fitness if terms == self.search_terms_ else \
            criterion_value(scorer.score(terms), len(terms), data.n - start, self.criterion)
        meta = {name: getattr(self, name) for name in _META}
        meta.update(seed=seed, phi_outputs=bool(self.phi_outputs), constant=bool(self.constant),
                    cls_refit=self.constraints == "steady-state",
                    search_fitness_value=self.fitness_, versions=versions())
        # a searched structure may hold terms the record cannot tell apart
        # (``rank_`` < number of terms): θ is then the minimum-norm solution
        with ignore_rank_warnings():
            self.model_ = Model(terms, inputs=data.inputs, output=data.output,
                                meta=dict(meta, estimation="ls"), registry=registry).fit(data)
            self.rank_ = int(self.model_.fit_info_["rank"])
            # ELS fits of noise terms, and CLS fits of a constrained search, are
            # not what model_ (LS) is: not compared
            self.precision_ = check = None if (any(t.has_noise for t in terms)
                                               or self.search_constraints) else \
                search_precision(scorer, terms, self.model_.theta)
            if check is not None and check.refit_worse:   # keep what the search scored
                self.model_ = Model(terms, check.search_theta, inputs=data.inputs,
                                    output=data.output,
                                    meta=dict(meta, estimation="ls-search",
                                              qr_refit_fitness_value=check.refit_mse),
                                    registry=registry)
            self.model_cls_ = None
            if self.constraints == "steady-state":
                try:
                    self.model_cls_ = Model(terms, inputs=data.inputs, output=data.output,
                                            meta=dict(meta, estimation="cls"),
                                            registry=registry).fit(data,
                                                                   constraints="steady-state")
                except ValueError as exc:
                    self.cls_error_ = str(exc)
        self.refinement_ = None
        if self.refine:
            from narx.refine import refine_both
            self.refinement_, self.model_, self.model_cls_, why = refine_both(
                self.model_, self.model_cls_, data, self.refine,
                self.refine_window or self.window)
            if why:
                warnings.warn(f"refine={self.refine!r} is not applied: {why}", UserWarning,
                              stacklevel=2)
        self._check_cls(data)
        self.pareto_front_ = ParetoFront(front_rows(res.pareto, scorer, shape),
                                         inputs=data.inputs, output=data.output,
                                         registry=registry)
        self.logbook_ = res.logbook
        self.screen_rejected_ = None if screen is None else screen.rejected
        self.screen_rejected_hold_ = None if screen is None else screen.rejected_hold
        self.n_evaluations_ = res.evaluations
        self.seed_ = seed
        self.result_ = res
        self.fit_time_ = time.perf_counter() - t0
        return self

    def _check_cls(self, data):
        # a structure chosen for its CLS refit's holding keeps it (not when
        # select='hold' found no candidate that holds)
        held = self.screen == "hold" or (self.select == "hold" and any(
            ok for ok, _ in getattr(self, "selection_", ())))
        self.cls_rejected_ = None if self.model_cls_ is None else cls_rejection(
            self.model_, self.model_cls_, data, held)
        if self.cls_rejected_:
            warnings.warn(f"the CLS refit {self.cls_rejected_}: get_best(), simulate() and "
                          f"predict() use the LS model (constrained=True for the CLS one)",
                          CLSRejectedWarning, stacklevel=3)

    def _make_screen(self, data, start, registry):
        if self.screen is None:
            return None
        top = self.screen_top
        if top is None:
            top = max(1, int(round(self.elite_fraction * self.population)))
        return StabilityScreen(data, start, top, band=self.screen_band,
                               constraints=self.search_constraints, registry=registry,
                               hold=self.screen == "hold")

    def _structure(self, terms) -> tuple:
        """The scored structure of decoded terms: the allowed ones, after
        the constant term when ``constant``."""
        kept = tuple(t for t in terms if self._allowed(t))
        return (CONSTANT,) + kept if self.constant else kept

    def _allowed(self, term) -> bool:
        if identically_zero(term, self.registry or default_registry()):
            return False
        if self.max_lag is not None and term.max_lag > self.max_lag:
            return False
        if self.max_degree is not None and term.degree > self.max_degree:
            return False
        return True

    def _prune_t(self, data, terms, start):
        from narx.estimate import t_statistics
        from narx.regressors import regressor_matrix
        crit = self.t_threshold_ = t_threshold_of(self, len(data.inputs))
        return prune_by_t(terms, lambda ts: t_statistics(
            *regressor_matrix(ts, data, start=start)[:2]), crit)

    # -------------------------------------------------------------- use
    def _check_fitted(self):
        if not hasattr(self, "model_"):
            raise ValueError("this MGGPRegressor is not fitted yet: call fit(u, y) first")

    def get_best(self, constrained: Optional[bool] = None) -> Model:
        """The best model: the CLS refit if one was made, unless False or
        it was rejected (``cls_rejected_``: it diverges in free run on the
        training record, or its RMSE there is over twice the LS fit's)."""
        self._check_fitted()
        if constrained is None:
            constrained = self.model_cls_ is not None and not self.cls_rejected_
        if constrained and self.model_cls_ is None:
            raise ValueError("no CLS refit: fit with constraints='steady-state'")
        return self.model_cls_ if constrained else self.model_

    def simulate(self, u, y=None, mode="freerun", constrained=None, **kw):
        return self.get_best(constrained).simulate(u, y, mode, **kw)

    def predict(self, u, y=None, mode="freerun", constrained=None, **kw):
        return self.simulate(u, y, mode, constrained, **kw).y_hat


#: parameters besides the evolution settings that fitness values depend on
_CONTEXT = ("fitness", "window", "k", "criterion", "search_constraints", "use_phi",
            "phi_names", "phi_outputs", "constant", "max_lag", "max_degree", "screen",
            "screen_top", "screen_band")
#: parameters recorded in a result's ``meta`` (with the seed and the fitness)
_META = ("fitness", "window", "k", "criterion", "population", "generations", "max_terms",
         "max_height", "use_phi", "phi_names", "screen", "select", "prune", "noise_lags",
         "max_lag", "refine", "max_degree", "search_constraints")
