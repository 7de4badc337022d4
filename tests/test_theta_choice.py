"""θ by simulation error in the automatic choices (``refine='auto'``, the
default, and ``'compare'``; mggp.fit.choices.heldout_errors with theta,
theta_choice): under output noise
the LS θ of the true structure are biased and its free-run refit simulates
the held-out part better; under equation noise LS is the right estimate
and is kept."""
import numpy as np
import pytest

import narx

from mggp import MGGPRegressor
from mggp.fit.choices import THETA_WORDS, heldout_rmse, heldout_theta, theta_choice
from mggp.fit.extrapolation import StressCheck
from narx.records.data import Data

TRUTH = ("y[k-1]", "y[k-2]", "u[k-1]")


def record(kind: str, n=1500, seed=0):
    """y = 1.5 y[k-1] - 0.7 y[k-2] + u[k-1] (a lightly damped pole pair),
    with white 'output' noise on the measured y (LS biased) or the same
    noise entering the 'equation' (LS consistent)."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n)
    e = 0.8 * rng.standard_normal(n)
    x = np.zeros(n)
    for k in range(2, n):
        x[k] = 1.5 * x[k - 1] - 0.7 * x[k - 2] + u[k - 1] + (e[k] if kind == "equation"
                                                            else 0.0)
    y = x + (e if kind == "output" else 0.0)
    return Data(u, y)


def test_output_noise_takes_the_free_run_refit():
    d = record("output")
    ls, best = (heldout_rmse(TRUTH, d, theta=t) for t in ("ls", "best"))
    assert best < 0.9 * ls
    c = theta_choice(TRUTH, d, seed=0)
    assert c.value == "freerun" and c.why.startswith("θ by free-run simulation error")
    assert c.figures["heldout_rmse_freerun"] < c.figures["heldout_rmse_ls"]


def test_equation_noise_keeps_least_squares():
    """Control: the noise enters the equation, LS is unbiased; the refit gains nothing
    beyond chance."""
    d = record("equation")
    c = theta_choice(TRUTH, d, seed=0)
    assert c.value is None and c.why.startswith("θ by least squares")
    assert heldout_rmse(TRUTH, d, theta="best") <= heldout_rmse(TRUTH, d, theta="ls")


def test_a_structure_with_memory_operators_keeps_least_squares():
    """The same output noise on a record whose structure holds a play: LS
    is kept without a refit (their initial state is unknown); the control is
    test_output_noise_takes_the_free_run_refit (no operator, refit taken)."""
    rng = np.random.default_rng(0)
    u = np.sin(np.linspace(0, 30, 1500)) + 0.3 * rng.standard_normal(1500)
    d = record("none")
    terms = TRUTH + ("Play(u[k-1],0.2)",)
    v = narx.Model(list(terms), theta=[1.5, -0.7, 1.0, 0.5]).simulate(Data(u, d.y)).y_hat
    y = np.asarray(v) + 0.8 * rng.standard_normal(1500)
    c = theta_choice(terms, Data(u, y), seed=0)
    assert c.value is None and "memory operators" in c.why
    assert theta_choice(TRUTH, Data(u, y), seed=0).value == "freerun"


def test_theta_must_be_known():
    with pytest.raises(ValueError, match="theta must be one of"):
        heldout_rmse(TRUTH, record("output"), theta="oe")


def test_the_fit_says_and_applies_the_choice():
    d = record("output")
    kw = dict(fitness="pem", population=16, generations=2, max_height=2, max_terms=4,
              random_state=1, use_phi=False, operators="none", constant=False)
    est = MGGPRegressor(refine="compare", **kw).fit(d)
    c = est.choices_["refine"]
    assert THETA_WORDS["best"].replace(",", ";", 1) in est.choices_["size"]["why"]
    assert (c["value"] == "freerun") == ("refined" in est.model_.meta
                                         and est.model_.meta["refined"]["improved"])
    # control: refine='none' and the steady-state constraints make no such choice
    assert "refine" not in MGGPRegressor(refine="none", **kw).fit(d).choices_
    steady = MGGPRegressor(constraints="steady-state", refine="compare", **kw)
    assert heldout_theta(steady) == "ls"
    assert heldout_theta(MGGPRegressor(**kw)) == "ls"      # the default compares LS θ


def _validation_rmse(model) -> float:
    """Free-run RMSE against the noise-free output of a new record."""
    clean = record("none", n=1500, seed=7)
    return float(np.sqrt(np.mean((model.simulate(clean).y_hat - clean.y)[2:] ** 2)))


def test_the_refit_taken_simulates_a_new_record_better():
    """Under output noise the refit that theta_choice takes simulates a new
    noise-free record of the system far better than the LS θ (the control,
    equation noise, keeps LS: test_equation_noise_keeps_least_squares)."""
    import narx
    from narx.refine import refine
    d = record("output")
    assert theta_choice(TRUTH, d, seed=0).value == "freerun"
    ls = narx.Model(list(TRUTH)).fit(d)
    assert _validation_rmse(refine(ls, d, mode="freerun").model) < 0.5 * _validation_rmse(ls)


def test_the_default_makes_the_choice_and_applies_it():
    """The default (refine='auto') judges the final structure's refit and
    refines it exactly when that is taken; the structure is refine='none''s
    (control: refine='none' makes no choice)."""
    kw = dict(fitness="ms", population=16, generations=2, max_lag=2, max_degree=1,
              max_terms=4, random_state=1, use_phi=False, operators="none",
              constant=False, extend="none")
    d = record("output")
    est = MGGPRegressor(**kw).fit(d)
    plain = MGGPRegressor(refine="none", **kw).fit(d)
    assert est.terms_ == plain.terms_ and "refine" not in plain.choices_
    c = est.choices_["refine"]
    taken = c["figures"]["heldout_rmse_freerun"] < c["figures"]["heldout_rmse_ls"]
    assert (c["value"] == "freerun") == taken == (est.refinement_ is not None)
    if not taken:
        assert np.allclose(est.model_.theta, plain.model_.theta)


def test_a_noise_free_record_keeps_least_squares():
    """Both θ simulate the held-out part to rounding: a tie keeps LS."""
    c = theta_choice(TRUTH, record("none"), seed=0)
    assert c.value is None and c.why.startswith("θ by least squares")


def test_the_final_theta_choice_compares_the_converged_refit(monkeypatch):
    """theta_choice judges the refit the refine stage delivers, run to
    convergence, not the capped refit of the structures the other choices
    compare. With the cap at one evaluation the capped refit barely leaves
    the LS θ (control: heldout_rmse with 'freerun' under that cap), while
    the choice's figure is the converged refit's."""
    from mggp.fit import choices
    d = record("output")
    converged = choices.heldout_rmse(TRUTH, d, theta="freerun")    # the cap (10) suffices here
    monkeypatch.setattr(choices, "REFIT_NFEV", 1)
    capped = choices.heldout_rmse(TRUTH, d, theta="freerun")
    assert capped > 1.05 * converged
    c = theta_choice(TRUTH, d, seed=0)
    assert c.figures["heldout_rmse_freerun"] == pytest.approx(converged, rel=1e-3)


class _Stress(StressCheck):
    """A stand-in stress test that fails the models of ``bad``."""

    def __init__(self, *bad):
        self.bad = bad

    def model_verdict(self, model):
        return "diverges when the input is scaled 1.5× about its mean" \
            if any(model is b for b in self.bad) else ""


def _refit_case(stress):
    from types import SimpleNamespace

    from mggp.fit.choices import Choice
    from mggp.fit.stages import _stress_refit
    before = narx.Model(list(TRUTH), [1.5, -0.7, 1.0])
    refit = narx.Model(list(TRUTH), [1.6, -0.7, 1.0])
    ctx = SimpleNamespace(stress=stress(before, refit), choices={})
    c = Choice("refine", "freerun", "θ by free-run simulation error: ...", {"x": 1})
    return ctx, before, refit, _stress_refit(ctx, c, before, None, refit, None, "r")


def test_a_refit_that_fails_the_stress_inputs_is_not_kept():
    ctx, before, refit, (model, cls, refinement) = _refit_case(lambda b, r: _Stress(r))
    assert model is before and refinement is None
    kept = ctx.choices["refine"]
    assert kept.value is None and "diverges when the input is scaled" in kept.why
    assert before.meta["choices"]["refine"]["value"] is None


def test_a_refit_is_kept_when_the_ls_theta_fails_too():
    """Control: both fail the stress inputs, the refit (lower error) stays."""
    ctx, before, refit, (model, _, refinement) = _refit_case(lambda b, r: _Stress(b, r))
    assert model is refit and refinement == "r" and not ctx.choices


def test_a_bounded_refit_is_kept():
    ctx, before, refit, (model, _, refinement) = _refit_case(lambda b, r: _Stress())
    assert model is refit and refinement == "r" and not ctx.choices
