"""scikit-learn-style estimator: MGGP structure search for NARX models.

Typical use::

    from mggp import MGGPRegressor
    est = MGGPRegressor(fitness="ms", window=100, population=200, generations=50,
                        constraints="steady-state", random_state=0, n_jobs=2).fit(u, y)
    est.model_                      # narx.Model, θ by LS (QR) on all data
    est.model_cls_                  # its CLS refit (continuum of steady states)
    print(est.pareto_front_)        # complexity, loss, score, equation (mggp.gp.pareto)
    est.simulate(u_val, y_val, mode="freerun").mape
    est.predict(u_val, y0=y_val[:10])   # free run from initial outputs (None: from rest)
    est.score(u_val, y_val)             # R² of the free run (scikit-learn's score)

``fit`` is the search (:mod:`mggp.gp.evolve`: term sets proposed by GP, each
scored by LS and the chosen simulation, :mod:`mggp.gp.evaluate`) followed by
the stages of :mod:`mggp.fit.stages`: the choice of a structure, pruning, a
noise model, the QR refit on the full record, the precision check, with
``constraints='steady-state'`` the constrained refit under the
continuum-of-steady-states equalities derived from the terms [1]_, the
refinement, the verdict on the CLS refit and the Pareto front. The
parameters, their rules, defaults and tiers are the table
:data:`mggp.fit.params.PARAMS`; the scikit-learn conventions (tags, feature
names, the estimator checks a time series cannot pass) are
:mod:`mggp.fit.sklearn_api`.

References
----------
.. [1] Abreu, P. E. O. G. B., Tavares, L. A., Teixeira, B. O. S., Aguirre,
   L. A., "Identification and nonlinearity compensation of hysteresis using
   NARX models", Nonlinear Dynamics, 2020.
"""
from __future__ import annotations

import json
import os
import random
import tempfile
import time
import warnings
from functools import partial, wraps
from typing import NamedTuple, Optional, Tuple

import numpy as np

from narx import Model
from narx.records.data import Data, DataError, as_data
from narx.estimation.fitness import StructureScorer
from narx.records.deadtime import onset_scans
from narx.records.outliers import find_spikes, repaired
from narx.simulation.metrics import r2
from narx.language.phi import default_registry
from narx.simulation.simulate import mode_name
from narx.records.ranges import ExtrapolationWarning, range_warning

from ..gp.checkpoint import (checkpoint_search, checkpoint_seed, copy_checkpoint, data_digest,
                         pilot_checkpoint)
from .choices import (CONSTANT, CONSTANT_ENDS, GAIN, HEIGHT, Choice, class_choice, power_choice,
                      constant_pilot_choice, constant_searched, fewest_terms,
                      front_rows_heldout, heldout_gain, heldout_rmse,
                      height_choice, holdout_message, outliers_choice, pilot_generations,
                      heldout_samples, heldout_theta, THETA_WORDS, resolve_screen,
                      resolve_select, search_classes,
                      search_part_choice, size_tolerance, without_constant)
from .extrapolation import POWER_CAP, StressCheck, bounded_first, signal_power
from .selection import run_candidates, select_hold
from ..gp.evaluate import Evaluator
from ..gp.evolve import check_context, evolve
from ..exceptions import CheckpointError
from .params import PARAMS, check_params, context_of, params_doc, unknown_keyword
from ..gp.pareto import ParetoFront
from .precision import data_warnings
from ..gp.primitives import (identically_zero, make_pset, max_lag_for_height, reachable_lag,
                         search_operators)
from .screen import StabilityScreen
from .sklearn_api import (EXPECTED_FAILED_CHECKS, fit_inputs, fit_output, not_fitted,
                          predict_inputs, sklearn_tags)
from .stages import FitContext, run_stages, screened

__all__ = ["MGGPRegressor", "ParetoFront"]

#: what ``fit`` says when no structure of the search has a finite fitness
NO_FINITE = ("no structure with a finite fitness was found: every candidate diverged; "
             "try fitness='pem' or a shorter window")


def _keywords_checked(init):
    """``init`` refusing a keyword that is no parameter with a ``TypeError``
    that names it and the closest parameter (``MGGPRegressor(populaton=40)``:
    "did you mean 'population'?"); the signature stays ``init``'s."""
    @wraps(init)
    def checked(self, *args, **kwargs):
        for name in kwargs:
            if name not in PARAMS:
                raise TypeError(unknown_keyword(name, type(self).__name__))
        init(self, *args, **kwargs)
    return checked


def _warn_outside(model, u) -> None:
    """Warn (:class:`narx.records.ranges.ExtrapolationWarning`) when the inputs ``u``
    (a narx.Data or an array, as :func:`predict_inputs` returns them) leave
    the training ranges ``model`` records."""
    data = u if isinstance(u, Data) else Data(u, None, inputs=model.inputs,
                                              output=model.output)
    outside = range_warning(model, data)
    if outside:
        warnings.warn(outside, ExtrapolationWarning, stacklevel=3)


class PilotRun(NamedTuple):
    """One pilot search of :meth:`MGGPRegressor._searches`: its ``result``
    (None when no structure of the class has a finite fitness), ``screen``,
    checkpoint ``path`` and search ``tag``; ``rows``, ``(n_terms, held-out
    free-run error, terms)`` of the structures weighed: the one the hold
    selection takes (``holds`` True/False), or the pilot's best structure
    and the smaller ones of its Pareto front (``holds`` None;
    :func:`mggp.fit.choices.front_rows_heldout`); none without a result.
    ``error`` and ``terms``: the least error of the rows (``inf`` without
    any) and its structure. Rows whose free run is unbounded on the stress
    inputs are left out when a bounded one is within the size tolerance
    (:func:`mggp.fit.extrapolation.bounded_first`); ``unbounded`` says why the
    pilot's least-error structure fails them when none is ('' otherwise)."""

    result: object
    screen: object
    path: str
    holds: Optional[bool]
    tag: str
    rows: Tuple[tuple, ...] = ()
    unbounded: str = ""

    @property
    def _least(self) -> tuple:
        return min(self.rows, key=lambda r: r[1], default=(0, float("inf"), ()))

    @property
    def error(self) -> float:
        return self._least[1]

    @property
    def terms(self) -> tuple:
        return tuple(self._least[2])


class MGGPRegressor:
    """Multi-gene GP structure search for polynomial NARX models.

    Every parameter is keyword-only; the defaults are the published setup
    except where they are 'auto', which the fit chooses for itself
    (:mod:`mggp.fit.choices`). *Parameters* below are the ten that most runs
    set, *Other Parameters* the expert options; both lists are generated
    from :data:`mggp.fit.params.PARAMS`, which also holds each rule and tier.
    A keyword that is no parameter raises a ``TypeError`` naming the
    closest one.

    A scikit-learn regressor (scikit-learn itself is optional): ``fit(u,
    y)``, ``predict(u, y0=None)`` (free run from the initial outputs y0,
    or from rest: zeros), ``score(u, y)`` (R² of the free run), tags,
    ``n_features_in_`` and, from a pandas DataFrame, ``feature_names_in_``
    (the columns name the inputs); ``get_params``/``set_params`` for
    ``clone``, ``Pipeline`` and ``cross_val_score`` (with
    ``TimeSeriesSplit``: the rows are samples of a time series, in order).
    :meth:`expected_failed_checks` lists the estimator checks a time-series
    model cannot pass, with the reasons.

    Notes
    -----
    Automatic choices (``choices_``, and ``meta['choices']`` of every model,
    each with the figures it was taken on): ``screen`` and ``select`` are
    'hold' with ``constraints='steady-state'``, else 'freerun' and
    'fitness'; ``use_phi`` runs a pilot search of each model class (no Φ,
    Φ, and with ``operators='auto'`` plays with Deng–Tan, then Bouc–Wen
    variables, each without Φ) at the
    full population for a fifth of the generations, takes the class whose
    pilot's structure has the least held-out free-run RMSE (θ by LS on the
    first 70 % of the record, error on the last 30 %; a richer class only
    when over 15 % lower, the Bouc–Wen class over 50 %; with the hold
    selection, classes that have a structure whose CLS refit holds first),
    and continues that pilot to the
    full generations; ``constant`` runs one more pilot of the chosen class
    (or of the one class asked for) without the constant term and searches
    with the constant offered to every structure when that pilot's
    held-out error, and that of the other pilot's structure refitted without
    its constant, are over 5 % higher and the gains significant at p < 0.05
    (a circular block bootstrap of the paired held-out errors,
    :func:`mggp.fit.choices.heldout_gain`; the tail and the head of the record
    held out in turn), or when the
    pilots tie and the simplest structure that ties holds the constant and
    needs it (never with the steady-state constraints, which it would
    break), then keeps it in the result only when it lowers the held-out
    free-run RMSE by over 5 % at p < 0.05; ``size`` takes the fewest terms
    of the run's Pareto front within 5 % of the least held-out free-run
    RMSE (2/√n on n held-out samples when larger:
    :func:`mggp.fit.choices.size_tolerance`); ``extend`` tries the candidate
    extensions of ``mggp diagnose`` on the chosen structure and takes the
    one that wins the diagnosis's paired held-out test and stays bounded on
    probe and stress inputs (:mod:`mggp.fit.extension`; ``extension_``);
    ``operator_params`` estimates the final structure's play radii and
    Bouc–Wen β, γ by free-run error when that simulates the held-out part
    better (:func:`mggp.fit.choices.operator_params_choice`). An
    explicit value of a parameter disables its choice; the level is
    :data:`mggp.fit.choices.LEVEL`.

    Extrapolation (:mod:`mggp.fit.extrapolation`): with ``max_power='auto'``
    no term holds a power above 3 of one signal (``v[k-1]^7``, or
    ``v[k-1]^2*v[k-2]^2``: 4) unless one more pilot, of the chosen class
    and constant choice with the cap lifted, has a held-out free-run error
    lower by more than the size tolerance (``max_power_`` is the cap
    used; ``choices_['max_power']`` says why). With ``stress`` each
    structure the final choices compare is run free, θ by LS on the
    training record, on stress inputs made from it (inputs scaled 1.5×
    about their means, reversed in time, held at their last values, maxima
    and minima); one that diverges or leaves the training output's mean ±
    3 ranges is refused when one that stays inside has a held-out error
    within the size tolerance of the least (the choice lines say which;
    when all within the tolerance fail, none is refused and the line says
    so). ``simulate`` and ``predict`` warn
    (:class:`narx.records.ranges.ExtrapolationWarning`) when the inputs leave the
    training range every model records in ``meta['ranges']``.

    ``select``: ``'freerun'`` takes, among the ``select_candidates`` best
    distinct structures of the run (archive and final population), the one
    with the lowest free-run MSE over the whole training record — multiple
    shooting never sees an instability longer than its window. ``'hold'``
    takes the best search fitness among those candidates whose free run
    stays in the screen's band and whose CLS refit holds its output on held
    inputs; the best structure if none does (``selection_`` lists the
    verdicts).

    ``screen`` (:mod:`mggp.fit.screen`): in each generation the ``screen_top``
    best new structures are simulated in free run over the whole training
    record, and those whose output leaves ``[min y, max y]`` widened by
    ``screen_band * range(y)`` on each side get the fitness ``inf``; so the
    elites, and the result, never diverge over the record. ``'hold'`` also
    requires the structure's CLS refit to hold its output when the input is
    frozen (stretches of the training record followed by held inputs; no
    movement above 1e-6 of the output range after 100 samples).

    ``prune``: backward elimination of the chosen structure by the BIC of
    the search fitness, or by LS t-statistics (drop the least significant
    term while its |t| < ``t_threshold``; default Bonferroni,
    Φ⁻¹(1 − 0.05/(2M)) with M the number of candidate monomials allowed by
    ``max_lag``, at most the lag ``max_height`` trees reach, 1 + 3 × height,
    and ``max_degree``; :mod:`mggp.fit.pruning`).

    ``noise_lags`` = q > 0: a moving-average noise model is selected after
    the search (NARMAX): candidates ``e[k-j]`` and ``x*e[k-j]`` (x a lag
    1..q of an input or the output), j = 1..q, are added one at a time by
    extended least squares while the best has |t| >= ``t_threshold``, and
    the process parameters are re-estimated with it. The search scores with
    the plain one-step error, so strong coloured noise can lead it to extra
    lags that only predict the noise; with ``prune='t'`` those are pruned by
    their ELS t-statistics with the full MA(q) model in the fit first
    (:mod:`mggp.fit.noise`).

    ``refine``: θ of the result (and of its CLS refit, keeping the
    constraints) minimises its simulation error instead of the one-step
    error of least squares (:mod:`narx.refine`), which is biased when the
    measured output is noisy (``refinement_`` holds the errors before and
    after).

    ``random_state`` fixes the run whatever ``n_jobs`` and ``backend``. With
    several inputs every Φ-term searched takes lags of one input only.

    After ``fit``, besides ``model_``, ``model_cls_``, ``pareto_front_`` and
    ``logbook_``: ``cls_rejected_`` says why the CLS refit is not used by
    ``get_best``/``simulate``/``predict`` (it diverges in free run on the
    training record or its RMSE is over twice the LS fit's; None: it is);
    ``precision_`` (:class:`mggp.fit.precision.PrecisionCheck`) holds
    the chosen structure's fitness with the search's normal-equation fit and
    with the QR refit; when the refit simulates more than 1.25× worse (nearly
    collinear terms: the exact LS θ has large cancelling coefficients)
    ``model_`` keeps the search's θ, which is what was scored
    (``model_.meta['estimation'] == 'ls-search'``). A
    :class:`mggp.SearchPrecisionWarning` names an offset that dominates a
    signal before the search (its normal equations lose precision on such
    data). ``outliers_`` holds the isolated glitches of the output and the
    inputs that ``outliers='auto'`` repaired before the search
    (:class:`narx.records.outliers.Spike`; the models are fitted on the repaired
    record). ``search_samples_`` is ``(start, stop)``, the samples the
    search, every automatic choice and every θ used: with ``search_samples``
    an integer, a longer record is searched on the part of that length
    whose signals cover most of their range
    (:func:`mggp.fit.choices.search_span`); the default 'all' searches it whole.
    """

    @_keywords_checked
    def __init__(self, *, fitness="ms", constraints=None, population=500, generations=200,
                 max_terms=15, use_phi="auto", random_state=None, n_jobs=1, inputs=None,
                 output="y",
                 # expert options (the docstring's Other Parameters)
                 window=100, k=10, criterion="mse", search_constraints=None,
                 search_samples="all", cxpb=0.8, mutpb=0.2, high_level_cx_rate=0.5,
                 high_level_mut_rate=0.5, tournament_size=2, elite_fraction=0.1,
                 max_height="auto", phi_names=None, phi_outputs=False, operators="auto",
                 operator_entry="stage", constant="auto", max_lag=None, max_degree=None,
                 max_power="auto", select="auto", size="auto", stress=True, local_search=True,
                 extend="auto", operator_params="auto", select_candidates=50,
                 screen="auto", screen_top=None, screen_band=1.0, prune=False, noise_lags=0,
                 t_threshold=None, estimator="ls", refine="auto", refine_window=None,
                 backend="loky", scheduler=None, outliers="auto", checkpoint=None,
                 resume=False, callbacks=None, registry=None):
        self.fitness = fitness
        self.constraints = constraints
        self.population = population
        self.generations = generations
        self.max_terms = max_terms
        self.use_phi = use_phi
        self.random_state = random_state
        self.n_jobs = n_jobs
        self.inputs = inputs
        self.output = output
        self.window = window
        self.k = k
        self.criterion = criterion
        self.search_constraints = search_constraints
        self.search_samples = search_samples
        self.cxpb = cxpb
        self.mutpb = mutpb
        self.high_level_cx_rate = high_level_cx_rate
        self.high_level_mut_rate = high_level_mut_rate
        self.tournament_size = tournament_size
        self.elite_fraction = elite_fraction
        self.max_height = max_height
        self.phi_names = phi_names
        self.phi_outputs = phi_outputs
        self.operators = operators
        self.operator_entry = operator_entry
        self.constant = constant
        self.max_lag = max_lag
        self.max_degree = max_degree
        self.max_power = max_power
        self.select = select
        self.size = size
        self.stress = stress
        self.local_search = local_search
        self.extend = extend
        self.operator_params = operator_params
        self.select_candidates = select_candidates
        self.screen = screen
        self.screen_top = screen_top
        self.screen_band = screen_band
        self.prune = prune
        self.noise_lags = noise_lags
        self.t_threshold = t_threshold
        self.estimator = estimator
        self.refine = refine
        self.refine_window = refine_window
        self.backend = backend
        self.scheduler = scheduler
        self.outliers = outliers
        self.checkpoint = checkpoint
        self.resume = resume
        self.callbacks = callbacks
        self.registry = registry

    # -------------------------------------------------------------- sklearn
    _estimator_type = "regressor"

    def get_params(self, deep=True):
        """The parameters (the rows of :data:`mggp.fit.params.PARAMS`) and their values."""
        return {name: getattr(self, name) for name in PARAMS}

    def set_params(self, **params):
        """Set parameters by name; an unknown name is refused with the
        closest parameter named (:func:`mggp.fit.params.unknown_keyword`)."""
        for k, v in params.items():
            if k not in PARAMS:
                raise ValueError(unknown_keyword(k, type(self).__name__))
            setattr(self, k, v)
        return self

    def __sklearn_tags__(self):
        """scikit-learn's tags, imported only when asked for
        (:func:`mggp.fit.sklearn_api.sklearn_tags`)."""
        return sklearn_tags(self)

    def __sklearn_is_fitted__(self) -> bool:
        return hasattr(self, "model_")

    @staticmethod
    def expected_failed_checks(estimator=None) -> dict:
        """The estimator checks of scikit-learn that a structure search of a
        time series cannot pass, each with its reason
        (:data:`mggp.fit.sklearn_api.EXPECTED_FAILED_CHECKS`): the argument
        ``expected_failed_checks`` of
        :func:`sklearn.utils.estimator_checks.parametrize_with_checks`."""
        return dict(EXPECTED_FAILED_CHECKS)

    def __repr__(self):
        """Parameters that differ from the defaults, as scikit-learn shows them."""
        changed = [f"{k}={v!r}" for k, v in self.get_params().items()
                   if not (v is PARAMS[k].default or (type(v) is type(PARAMS[k].default)
                                                      and v == PARAMS[k].default))]
        return f"{type(self).__name__}({', '.join(changed)})"

    # -------------------------------------------------------------- fit
    def _validate(self, data: Data):
        start = max_lag_for_height(self.max_height_)
        self._check_samples(data.n)
        for name in data.inputs:
            if np.ptp(data.input(name)) == 0:
                raise DataError(f"input {name!r} is constant: nothing can be identified")
        if self.fitness == "ksa" and self.k >= data.n - start:
            raise DataError(f"k={self.k} steps ahead do not fit in the {data.n - start} "
                            f"scored samples (k must be below that)")
        data.require_varying_output("nothing can be identified")
        return start

    def _height(self) -> int:
        """The tree height: ``max_height_`` once ``fit`` resolved it, else
        ``max_height`` ('auto': :data:`mggp.fit.choices.HEIGHT`, the least it
        resolves to)."""
        if hasattr(self, "max_height_"):
            return self.max_height_
        return HEIGHT if self.max_height == "auto" else self.max_height

    def _check_samples(self, n: int) -> None:
        """Raise :class:`DataError` when ``n`` samples are fewer than the
        largest lag the terms can have (:func:`reachable_lag`: max_height's
        reach, capped by max_lag) plus the rows of the fit, 4 per term of
        max_terms and at least 20; the message names both settings with
        their values and what would fit."""
        lag = reachable_lag(self._height(), self.max_lag)
        rows = max(4 * self.max_terms, 20)
        if n >= lag + rows:
            return
        by = (f"max_lag={self.max_lag}" if lag == self.max_lag else
              f"what max_height={self._height()} reaches, 1 + 3 × height")
        fits = []
        if n - lag >= 20:
            fits.append(f"max_terms to {(n - lag) // 4}")
        if n - rows >= 1:
            fits.append(f"max_lag to {n - rows}")
        raise DataError(f"{n} samples are too few: the search needs at least {lag + rows}, "
                        f"its largest lag {lag} ({by}) plus {rows} rows to fit "
                        f"(4 per term of max_terms={self.max_terms}, at least 20); give "
                        f"more samples" + (f", or lower {' or '.join(fits)}" if fits else ""))

    def _seed(self) -> int:
        rs = self.random_state
        if rs is None:
            return random.SystemRandom().randrange(2**31)
        if isinstance(rs, np.random.Generator):
            return int(rs.integers(2**31))
        return int(rs)                          # an integer >= 0 (check_params)

    def fit(self, u, y=None):
        """Search a structure on ``(u, y)``, then run the stages of
        :data:`mggp.fit.stages.STAGES`; returns self.

        Parameters
        ----------
        u : array of shape (n,) or (n, m), pandas DataFrame, or narx.Data
            The input signals, one column per input, one row per sample in
            time order; the columns of a DataFrame name the inputs
            (``feature_names_in_``), else ``inputs`` does ('u', or u1..um).
            A narx.Data record may hold the output too (then no ``y``).
        y : array of shape (n,)
            The measured output.
        """
        t0 = time.perf_counter()
        for name in [a for a in vars(self) if a.endswith("_") and not a.startswith("_")]:
            delattr(self, name)                 # nothing from an earlier fit survives
        u, inputs = fit_inputs(self, u)
        if not isinstance(u, Data):
            y = fit_output(y)
        data = as_data(u, y, inputs=inputs, output=self.output)
        data.require_output("fit")
        check_params(self)
        spikes = find_spikes(data) if self.outliers == "auto" else []
        data = repaired(data, spikes)
        scans = onset_scans(data)               # the height choice's and the warning's
        height = (height_choice(data, self.max_lag, scans) if self.max_height == "auto"
                  else None)
        self.max_height_ = self.max_height if height is None else height.value
        start = self._validate(data)
        for msg, kind in data_warnings(data, self.fitness, self.window, self.k,
                                       reach=reachable_lag(self.max_height_, self.max_lag),
                                       max_height=self.max_height_, max_lag=self.max_lag,
                                       scans=scans):
            warnings.warn(msg, kind, stacklevel=2)
        part = None
        if self.search_samples != "all" and data.n > self.search_samples:
            part = search_part_choice(data, self.search_samples)
            data = data.slice(*part.value)
        self.search_samples_ = (0, data.n) if part is None else tuple(part.value)
        held = ("auto" in (self.use_phi, self.constant, self.size)
                and holdout_message(data))
        if held:
            warnings.warn(held, UserWarning, stacklevel=2)
        if self.max_lag is not None and self.max_lag > start:
            warnings.warn(f"max_lag={self.max_lag} has no effect: trees of max_height="
                          f"{self.max_height_} reach lags up to {start} only (1 + 3 × "
                          f"height); raise max_height to reach longer lags",
                          UserWarning, stacklevel=2)
        registry = self.registry or default_registry()
        # the one scorer of the search's settings: the search's in this
        # process, then every stage's
        scorer = StructureScorer(data, self.fitness, window=self.window, k=self.k,
                                 constraints=self.search_constraints, start=start,
                                 registry=registry, estimator=self.estimator)
        # the power cap of the search (max_power='auto': lifted by a pilot,
        # _searches) and the stress test of the final choices (mggp.fit.extrapolation)
        self.max_power_ = {"auto": POWER_CAP, "none": None}.get(self.max_power, self.max_power)
        ctx = FitContext(self, data, registry, start, scorer, shape=self._structure,
                         stress=StressCheck(data, registry) if self.stress else None,
                         allowed=self._allowed, scans=scans)
        if self.outliers == "auto":
            ctx.choices["outliers"] = outliers_choice(spikes, data.output, data.inputs)
        if height is not None:
            ctx.choices["max_height"] = height
        if part is not None:
            ctx.choices["search_samples"] = part
        if self.screen == "auto":
            ctx.choices["screen"] = resolve_screen(self)
        ctx.screen = self._make_screen(data, start, registry, ctx)
        evaluations = self._searches(ctx)
        decided = run_stages(ctx.shape(ctx.result.best.terms), data, ctx)
        self._assign(decided)
        res = ctx.result
        self.choices_ = {name: c.to_dict() for name, c in ctx.choices.items()}
        self.outliers_ = tuple(spikes)
        self.logbook_ = res.logbook
        self.screen_rejected_ = None if ctx.screen is None else ctx.screen.rejected
        self.screen_rejected_hold_ = None if ctx.screen is None else ctx.screen.rejected_hold
        self.n_evaluations_ = evaluations
        self.seed_ = ctx.seed
        self.result_ = res
        self.fit_time_ = time.perf_counter() - t0
        return self

    def _assign(self, decided) -> None:
        """The fitted attributes from the decisions of the stages
        (:func:`mggp.fit.stages.run_stages`); an attribute a stage did not
        decide (``selection_``, ``t_threshold_``, ``cls_error_``) is not set."""
        selected, pruned = decided["select"], decided["prune"]
        self.search_terms_ = selected.terms
        if selected.selection is not None:
            self.selection_ = selected.selection
        self.operator_steps_ = decided["operators"].steps
        if pruned.t_threshold is not None:
            self.t_threshold_ = pruned.t_threshold
        self.local_search_ = decided["local_search"].steps
        self.extension_ = decided["extend"].extension
        self.terms_ = decided["record"].terms
        self.fitness_ = decided["record"].fitness
        self.rank_ = decided["qr_refit"].rank
        self.precision_ = decided["precision"].check
        if decided["cls_refit"].error is not None:
            self.cls_error_ = decided["cls_refit"].error
        refined = decided["refine"]
        self.refinement_ = refined.refinement
        self.model_, self.model_cls_ = refined.model, refined.model_cls
        self.cls_rejected_ = decided["cls_verdict"].rejected
        self.pareto_front_ = decided["pareto"].front

    def _searches(self, ctx: FitContext) -> int:
        """The search of the one model class asked for, or with
        ``use_phi='auto'`` (:func:`mggp.fit.choices.search_classes`) a pilot of
        each class (full population, :func:`mggp.fit.choices.pilot_generations`
        generations, same seed), the class chosen by the least held-out
        free-run error of its pilot's best structure and the smaller ones of
        its Pareto front (with the hold selection: of the structure that
        selection takes; :func:`mggp.fit.choices.class_choice`),
        and that pilot continued to ``generations`` (the same run as an
        uninterrupted search of that class). With ``constant='auto'`` (and
        the constant searched: :func:`mggp.fit.choices.constant_searched`) the
        chosen class also has a pilot without the constant term, and the
        search continues with the constant when its pilot's held-out
        error is over :data:`mggp.fit.choices.GAIN` lower than both that pilot's
        and its own structure's without the constant, significantly at
        :data:`mggp.fit.choices.LEVEL` (:func:`mggp.fit.choices.heldout_gain`, the
        tail and the head held out in turn), or when they tie and
        the constant's structure is the simpler
        (:func:`mggp.fit.choices.constant_pilot_choice`,
        :func:`mggp.fit.choices.fewest_terms`). Sets ``ctx.seed``,
        ``ctx.result``, ``ctx.screen``, ``ctx.search_class``, ``ctx.shape``
        and the choices; returns the structures evaluated."""
        classes = search_classes(self)
        piloted = self.constant == "auto" and constant_searched(self)
        if len(classes) == 1 and self.use_phi == "auto":
            ctx.choices["use_phi"] = Choice(
                "use_phi", True, "Φ: with Φ of outputs the fit is one search with Φ, "
                "not compared with other model classes", {})
        powered = self.max_power == "auto" and (self.max_degree is None
                                                or self.max_degree > POWER_CAP)
        if len(classes) == 1 and not piloted and not powered:
            c = classes[0]
            self._tell("plan", self.generations + 1)    # generation 0: the first population
            self._tell("phase", f"search {c.label}", self.generations)
            ctx.search_class = c
            ctx.seed, ctx.result = self._search(ctx, c, self.generations, ctx.screen,
                                                checkpoint=self.checkpoint,
                                                resume=self.resume)
            return ctx.result.evaluations
        pilot = pilot_generations(self.generations)
        n = len(classes) + piloted + powered
        self._tell("plan", n * (pilot + 1) + max(self.generations - pilot, 0))
        seed, runs = None, []
        if self.resume and self.checkpoint is not None and os.path.exists(self.checkpoint):
            check_context(self.checkpoint, self._context(ctx.data))   # before the pilots
            if self.random_state is None:
                seed = checkpoint_seed(self.checkpoint)     # the run being resumed
        with tempfile.TemporaryDirectory(prefix="mggp-pilot-") as tmp:
            def where(key):                     # beside the checkpoint, to be resumed
                return (os.path.join(tmp, f"{key}.json") if self.checkpoint is None
                        else pilot_checkpoint(self.checkpoint, key))
            for i, c in enumerate(classes):
                label = f"pilot {i + 1}/{n} {c.label}"
                seed, run = self._pilot(ctx, c, pilot, seed, where(c.key), label, ctx.shape,
                                        ctx.screen if i == 0 else None, c.label)
                runs.append(run)
            if all(r.result is None for r in runs):
                raise ValueError(NO_FINITE)
            words = (f"pilots of {pilot} of {self.generations} generations at full "
                     f"population" + THETA_WORDS.get(heldout_theta(self), ""))
            hold = None if all(r.holds is None for r in runs) else [bool(r.holds) for r in runs]
            choice = class_choice(classes, [r.error for r in runs], hold,
                                  words + ("" if hold else ", least error over each "
                                           "pilot's Pareto front") + ", the chosen one "
                                  "continued", [r.unbounded for r in runs],
                                  self._tolerance(ctx))
            win = [c.label for c in classes].index(choice.figures["class"])
            if runs[win].result is None:        # every held-out free run diverges
                win = next(i for i, r in enumerate(runs) if r.result is not None)
                choice = class_choice([classes[win]], [runs[win].error])
            go, plain_kw = win, {}
            if piloted:
                plain = partial(self._structure, constant=False)
                seed, run = self._pilot(ctx, classes[win], pilot, seed,
                                        where(f"{classes[win].key}-no-constant"),
                                        f"pilot {n}/{n} {classes[win].label}, no constant",
                                        plain, None, f"{classes[win].label}, no constant")
                runs.append(run)
                with_c, theta = runs[win].terms, heldout_theta(self)
                kept = constant_pilot_choice(
                    heldout_gain(run.terms, with_c, ctx.data, ctx.registry, seed, GAIN,
                                 CONSTANT_ENDS, theta),
                    heldout_gain(without_constant(with_c, ctx.data, ctx.registry)[0], with_c,
                                 ctx.data, ctx.registry, seed, GAIN, CONSTANT_ENDS, theta),
                    f"{words}, class {classes[win].label}",
                    fewest_terms(runs[win].rows, run.rows, ctx.data, ctx.registry, seed,
                                 theta))
                ctx.choices["constant"] = kept
                if not kept.value and run.result is not None:
                    go, ctx.shape, plain_kw = len(runs) - 1, plain, {"constant": False}
            if powered:
                seed, go = self._power_pilot(ctx, classes[win], pilot, seed, runs, go,
                                             plain_kw, where, f"pilot {n}/{n}", words)
            res, scr, path, tag = runs[go].result, runs[go].screen, runs[go].path, runs[go].tag
            evaluations = sum(r.result.evaluations for i, r in enumerate(runs)
                              if r.result is not None and i != go)
            path = self._continued(path, tag)
            if pilot < self.generations:
                self._tell("phase", f"search {classes[win].label}", self.generations)
                _, res = self._search(ctx, classes[win], self.generations, scr, seed,
                                      checkpoint=path, resume=True, tag=tag)
        if len(classes) > 1:
            ctx.choices["use_phi"] = choice
        ctx.seed, ctx.result, ctx.screen = seed, res, scr
        ctx.search_class = classes[win]
        return evaluations + res.evaluations

    def _power_pilot(self, ctx: FitContext, cls, generations: int, seed, runs, go: int,
                     constant: dict, where, label: str, words: str):
        """``max_power='auto'``: a pilot of the chosen class ``cls`` (and
        constant choice ``constant``) with the power cap lifted, appended to
        ``runs``; the cap is lifted (``max_power_`` None, the search
        continued from this pilot) when :func:`mggp.fit.choices.power_choice`
        says so. Returns ``(seed, index of the run continued)``."""
        suffix = ", no constant" if constant else ""
        free = partial(self._structure, power=None, **constant)
        key = f"{cls.key}{'-no-constant' if constant else ''}-powers"
        seed, run = self._pilot(ctx, cls, generations, seed, where(key),
                                f"{label} {cls.label}{suffix}, powers uncapped", free, None,
                                f"{cls.label}{suffix}, powers uncapped")
        runs.append(run)
        capped = runs[go]
        choice = power_choice(capped.error, run.error, self._tolerance(ctx),
                              f"{words}, class {cls.label}{suffix}",
                              run.unbounded and not capped.unbounded)
        ctx.choices["max_power"] = choice
        if choice.value is None and run.result is not None:
            self.max_power_ = None
            ctx.shape = free
            return seed, len(runs) - 1
        return seed, go

    def _pilot(self, ctx: FitContext, cls, generations: int, seed, path: str, label: str,
               shape, screen, tag: str):
        """One pilot search of ``cls`` scoring the structures ``shape`` makes
        (a new screen unless ``screen``), its checkpoint at ``path`` (resumed
        with ``resume``) tagged ``tag``: ``(seed, PilotRun)``
        (:class:`PilotRun`)."""
        scr = screen if screen is not None else self._make_screen(
            ctx.data, ctx.start, ctx.registry, ctx)
        self._tell("phase", label, generations)
        seed, res = self._search(ctx, cls, generations, scr, seed, checkpoint=path,
                                 resume=self.resume, require_finite=False, shape=shape,
                                 tag=tag)
        if res.best is None or not np.isfinite(res.best.fitness):
            return seed, PilotRun(None, scr, path, False, tag)
        terms, holds = self._held_candidate(ctx, res, shape)
        if holds is not None:
            rows = [(len(terms), heldout_rmse(terms, ctx.data, ctx.registry), tuple(terms))]
        else:
            rows = front_rows_heldout(terms, res, shape, ctx.data, ctx.registry,
                                      heldout_theta(self))
        order = sorted(range(len(rows)), key=lambda i: rows[i][1])
        _, refused, all_fail = bounded_first(rows, order, self._tolerance(ctx), ctx.stress)
        out = {i for i, _ in refused}
        rows = [r for i, r in enumerate(rows) if i not in out]
        return seed, PilotRun(res, scr, path, holds, tag, tuple(rows),
                              all_fail[0][1] if all_fail else "")

    @staticmethod
    def _tolerance(ctx: FitContext) -> float:
        """The size tolerance on the record's held-out samples
        (:func:`mggp.fit.choices.size_tolerance`)."""
        return size_tolerance(heldout_samples(ctx.data.n))

    def _continued(self, pilot_path: str, tag: str) -> str:
        """The checkpoint the chosen pilot continues in: its own file, or
        with ``checkpoint`` that file, a copy of the pilot's unless a resumed
        run finds it further along the same search (``tag``): each search is
        one trajectory from its seed, so continuing from the pilot's state
        or from a later one of the same search ends in the same run."""
        if self.checkpoint is None:
            return pilot_path
        if self.resume and os.path.exists(self.checkpoint):
            held = checkpoint_search(self.checkpoint)
            if held != tag:
                raise CheckpointError(
                    f"checkpoint {os.fspath(self.checkpoint)}: holds the search "
                    f"{held or 'of a run without pilots'!r}, but this run's pilots chose "
                    f"{tag!r} (the pilots' generations follow generations); remove it or "
                    f"run without resume")
            return self.checkpoint
        copy_checkpoint(pilot_path, self.checkpoint)
        return self.checkpoint

    def _tell(self, method: str, *args) -> None:
        """Call ``method(*args)`` of the callbacks that have it: ``phase``
        (which search runs next and its generations) and ``plan`` (the
        generations of the fit's searches together)."""
        for cb in self.callbacks or []:
            if hasattr(cb, method):
                getattr(cb, method)(*args)

    def _held_candidate(self, ctx: FitContext, res, shape):
        """The structure of ``res`` (scored as ``shape`` makes it) the hold
        selection would take (when ``select`` is or resolves to 'hold') and
        whether its CLS refit holds (None: no hold selection); else the
        best-fitness one."""
        best = shape(res.best.terms)
        if self.select not in ("hold", "auto") or (
                self.select == "auto" and resolve_select(self).value != "hold"):
            return best, None
        cands = run_candidates(res, ctx.data.signals, shape, self.select_candidates)
        chosen, _ = select_hold(cands, ctx.data, ctx.start, ctx.registry, self.screen_band)
        return (chosen or best), chosen is not None

    def _search(self, ctx: FitContext, cls, generations: int, screen,
                seed: Optional[int] = None, checkpoint=None, resume: bool = False,
                require_finite: bool = True, shape=None, tag: Optional[str] = None):
        """One evolution of the model class ``cls`` (:class:`mggp.fit.choices.SearchClass`)
        for ``generations`` (continued from ``checkpoint`` with ``resume``),
        its individuals of at most ``max_terms`` genes less the terms
        ``shape`` adds to every structure (the constant term), so that no
        structure scored has more than ``max_terms`` terms:
        ``(seed, EvolutionResult)``; ``ValueError`` when no structure has a
        finite fitness (unless not ``require_finite``); ``shape`` makes the
        scored structures (default ``ctx.shape``); ``tag`` names the search
        of a fit with pilots in the checkpoint's context."""
        data, shape = ctx.data, shape or ctx.shape
        pset = make_pset(data.signals, ctx.registry, use_phi=cls.use_phi,
                         phi_names=self.phi_names,
                         phi_outputs=bool(self.phi_outputs or cls.phi_outputs),
                         operators=search_operators(
                             cls.operators if cls.in_search else None, data.U))
        evaluator = Evaluator(data, self.fitness, window=self.window, k=self.k,
                              constraints=self.search_constraints, start=ctx.start,
                              estimator=self.estimator, criterion=self.criterion,
                              n_jobs=self.n_jobs,
                              backend=self.backend, scheduler=self.scheduler,
                              registry=ctx.registry, scorer=ctx.scorer)
        callbacks = list(self.callbacks or [])

        def evaluate_batch(term_sets):
            sets = [shape(ts) for ts in term_sets]
            values = evaluator(sets)
            return values if screen is None else screen(sets, values)

        def on_generation(state):
            for cb in callbacks:
                cb(state)
        seed = self._seed() if seed is None else seed
        if resume and checkpoint is not None and self.random_state is None:
            seed = checkpoint_seed(checkpoint) or seed   # continue its run
        context = self._context(data)
        if tag is not None:
            context["search"] = tag
        try:
            res = evolve(pset, evaluate_batch, seed=seed, population_size=self.population,
                         generations=generations, cxpb=self.cxpb, mutpb=self.mutpb,
                         high_level_cx_rate=self.high_level_cx_rate,
                         high_level_mut_rate=self.high_level_mut_rate,
                         tournament_size=self.tournament_size,
                         elite_fraction=self.elite_fraction,
                         max_terms=self.max_terms - len(shape(())),   # room beside the constant
                         max_height=self.max_height_, on_generation=on_generation,
                         checkpoint=checkpoint, resume=resume,
                         context=json.loads(json.dumps(context, default=str)),
                         structure=shape)
        finally:
            evaluator.close()
        if require_finite and (res.best is None or not np.isfinite(res.best.fitness)):
            raise ValueError(NO_FINITE)
        return seed, res

    def _context(self, data) -> dict:
        """The checkpoint context of a search of ``data``: the record's
        digest and the parameters the fitness values depend on."""
        return {"data": data_digest(data), **context_of(self)}

    def _make_screen(self, data, start, registry, ctx=None):
        how = self.screen if ctx is None else screened(ctx)
        if how in (None, "none"):
            return None
        top = self.screen_top
        if top is None:
            top = max(1, int(round(self.elite_fraction * self.population)))
        return StabilityScreen(data, start, top, band=self.screen_band,
                               constraints=self.search_constraints, registry=registry,
                               hold=how == "hold")

    def _structure(self, terms, constant: Optional[bool] = None, power="fit") -> tuple:
        """The scored structure of decoded terms: the allowed ones (at most
        ``power`` factors of one signal; 'fit': ``max_power_``), after
        the constant term when ``constant`` (default: when the search offers
        it, :func:`mggp.fit.choices.constant_searched`)."""
        kept = tuple(t for t in terms if self._allowed(t, power))
        if constant is None:
            constant = constant_searched(self)
        return (CONSTANT,) + kept if constant else kept

    def _allowed(self, term, power="fit") -> bool:
        """Whether the search may use ``term``: not identically zero, within
        ``max_lag``, ``max_degree`` and at most ``power`` factors of one
        signal (:func:`mggp.fit.extrapolation.signal_power`; None: any; 'fit':
        ``max_power_``, the cap the fit resolved)."""
        if identically_zero(term, self.registry or default_registry()):
            return False
        if power == "fit":
            power = getattr(self, "max_power_", None)
        if power is not None and signal_power(term) > power:
            return False
        if self.max_lag is not None and term.max_lag > self.max_lag:
            return False
        if self.max_degree is not None and term.degree > self.max_degree:
            return False
        return True

    # -------------------------------------------------------------- use
    def _check_fitted(self):
        if not hasattr(self, "model_"):
            raise not_fitted("this MGGPRegressor is not fitted yet: call fit(u, y) first")

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

    def simulate(self, u, y=None, mode="freerun", constrained=None, *,
                 history="estimate", **kw):
        """The simulation (:class:`narx.simulation.simulate.SimulationResult`) of the best
        model (:meth:`get_best`) on the inputs ``u`` (as ``fit`` takes them,
        the same number of inputs) in ``mode`` ('freerun', 'osa', 'ksa' with
        ``k``, 'ms' with ``window``), from the measured output ``y`` (free
        run: its first samples, or ``y0=`` initial outputs). A record may
        start in motion: with its measured output, the memory operators
        start from the history ('rest', 'rising' or 'falling') whose free
        run fits its first samples best (``history='estimate'``,
        :func:`narx.simulation.simulate.estimate_history`; the result's
        ``history`` says which), else at rest. An
        :class:`narx.records.ranges.ExtrapolationWarning` names the inputs that leave
        the training record's range (:func:`narx.records.ranges.range_warning`), here
        and in :meth:`predict`."""
        self._check_fitted()
        model = self.get_best(constrained)
        u = predict_inputs(self, u)
        _warn_outside(model, u)
        return model.simulate(u, y, mode, history=history, **kw)

    def predict(self, u, y0=None, *, y=None, mode="freerun", constrained=None,
                history="estimate", **kw):
        """The predicted output of the best model (:meth:`get_best`).

        Parameters
        ----------
        u : array of shape (n,) or (n, m), pandas DataFrame, or narx.Data
            The input signals, as ``fit`` takes them.
        y0 : array, optional
            Free run (the default ``mode``): the initial outputs, the first
            ``max_lag`` samples of the output (a longer array, e.g. the
            measured output, gives its first ``max_lag``). None: from rest,
            every initial output 0 (a system at rest at an output far from
            0 needs its own y0: the free run starts at 0), or from the
            measured output of a narx.Data ``u`` that holds one. Other modes
            predict from the measured output, which is then this argument
            (or ``y``).
        y : array, optional
            The measured output, by keyword (free run: its first samples
            are the initial outputs).
        mode : str
            'freerun', 'osa', 'ksa' (with ``k=``) or 'ms' (with ``window=``).
        constrained : bool, optional
            The CLS refit (True) or the LS model (False); default as
            :meth:`get_best`.
        history : str
            The path that starts the memory operators: 'rest', 'rising',
            'falling', or 'estimate' (from the measured output ``y`` when
            given, else 'rest'), as in :meth:`simulate`.

        Returns
        -------
        array of shape (n,)
            The first ``max_lag`` samples are the initial outputs.
        """
        self._check_fitted()
        if y0 is not None and y is not None:
            raise ValueError("predict takes y0 or y, not both (y0: initial outputs of the "
                             "free run, or the measured output of the other modes)")
        model = self.get_best(constrained)
        if y is None and mode_name(mode) != "freerun":
            y, y0 = y0, None                    # the measured output, passed as before
        elif y is None and y0 is None:
            y0 = np.zeros(model.max_lag)        # from rest
        u = predict_inputs(self, u)
        _warn_outside(model, u)
        return model.simulate(u, y, mode, y0=y0, history=history, **kw).y_hat

    def score(self, u, y, sample_weight=None, *, mode="freerun", **kw):
        """R² of the free-run simulation of ``u`` from the measured initial
        outputs (the first ``max_lag`` samples of ``y``):

        .. math:: R^2 = 1 - \\frac{\\sum_k w_k (y_k - \\hat y_k)^2}
                                  {\\sum_k w_k (y_k - \\bar y)^2},

        over the samples k from ``max_lag`` on, :math:`\\hat y` the free run
        of the best model (:meth:`get_best`), :math:`\\bar y` the (weighted)
        mean of y there, ``w`` = ``sample_weight`` (default 1). A free run
        that diverges scores ``-inf``. This is what ``cross_val_score``
        reports; the one-step R² of least squares is much higher and says
        little about a simulation model. ``mode`` (with ``k=`` or
        ``window=``) scores another simulation of :meth:`simulate` instead,
        over the samples it predicts ('osa': the one-step R²).
        """
        self._check_fitted()
        sim = self.simulate(u, fit_output(y), mode=mode, **kw)
        return r2(sim.y[sim.valid], sim.y_hat[sim.valid],
                  None if sample_weight is None else
                  np.asarray(sample_weight, dtype=float)[sim.valid])


MGGPRegressor.__doc__ += params_doc()
