"""Steady-state clusters and continuum-of-steady-states constraints (narx.analysis.steady),
and CLS on the published case study.

The constraints are checked as matrices (rows of S and entries of c, mapped
back to θ indices), not by their labels. On the piezo case study the CLS
model must hold its output when the input is held, the LS model (the
control) must not.
"""
import numpy as np
import pytest

import narx
from narx import (EstimationError, Model, PhiRegistry, cluster_sums, clusters,
                  parse_terms, steady_state_constraints)
from narx.systems import bouc_wen_discrete, bouc_wen_discrete_narx, held_sine, \
    piezo_bouc_wen, training_input


def rows_as_sets(cons):
    """{frozenset of (θ index (1-based), coefficient)): c} of S θ = c."""
    out = {}
    for row, ci in zip(cons.S, cons.c):
        key = frozenset((int(i) + 1, float(row[i])) for i in np.flatnonzero(row))
        assert key not in out
        out[key] = float(ci)
    return out


# --------------------------------------------------------------- published models
def test_model_33_constraints_are_the_published_ones(model33_terms):
    terms = parse_terms(model33_terms)
    cons = steady_state_constraints(terms)
    assert cons.S.shape == (4, 15) and cons.c.shape == (4,)
    expected = {
        frozenset({(7, 1.0)}): 1.0,                   # Σ_y    = θ7         = 1
        frozenset({(2, 1.0), (15, 1.0)}): 0.0,        # Σ_u    = θ2 + θ15   = 0
        frozenset({(4, 1.0), (13, 1.0)}): 0.0,        # Σ_u³   = θ4 + θ13   = 0
        frozenset({(1, 1.0), (3, 1.0)}): 0.0,         # Σ_yu²  = θ1 + θ3    = 0
    }
    assert rows_as_sets(cons) == expected
    assert np.all((cons.S == 0) | (cons.S == 1))
    labels = {lab.replace(" ", "") for lab in cons.labels}
    assert labels == {"Σ_y=1", "Σ_u=0", "Σ_u^3=0", "Σ_y*u^2=0"}
    desc = {d.split(" = ")[0]: d for d in cons.describe(terms)}
    assert desc["Σ_u"] == "Σ_u = θ2 + θ15 = 0"
    assert desc["Σ_y"] == "Σ_y = θ7 = 1"
    # residual / satisfied on a θ that meets them and one that does not
    th = np.zeros(15)
    th[6], th[1], th[14], th[3], th[12], th[0], th[2] = 1, .3, -.3, .2, -.2, .1, -.1
    assert cons.satisfied(th) and np.all(cons.residual(th) == 0)
    th[14] = -0.29
    assert not cons.satisfied(th)
    np.testing.assert_allclose(sorted(np.abs(cons.residual(th))), [0, 0, 0, 0.01], atol=1e-15)


def test_model_19_gives_only_sigma_y(model19):
    terms, theta = model19
    cons = steady_state_constraints(parse_terms(terms))
    assert rows_as_sets(cons) == {frozenset({(1, 1.0)}): 1.0}
    assert cons.labels == ("Σ_y = 1",)
    assert cons.satisfied(theta)                 # the published CLS θ1 = 1
    sums = Model(terms, theta).cluster_sums()
    assert dict(sums) == {"y": 1.0}


def test_model_32_pem_clusters(model32_terms):
    terms = parse_terms(model32_terms)
    cons = steady_state_constraints(terms)
    # y: θ6 + θ7 + θ13 = 1; u: θ14 + θ15; u²: θ2; y·u: θ3 + θ5; y·u²: θ1
    assert rows_as_sets(cons) == {
        frozenset({(6, 1.0), (7, 1.0), (13, 1.0)}): 1.0,
        frozenset({(14, 1.0), (15, 1.0)}): 0.0,
        frozenset({(2, 1.0)}): 0.0,
        frozenset({(3, 1.0), (5, 1.0)}): 0.0,
        frozenset({(1, 1.0)}): 0.0,
    }


def test_clusters_and_sums():
    terms = parse_terms(["y[k-1]", "y[k-2]", "u[k-1]", "u[k-3]*y[k-2]", "y[k-1]*u[k-2]",
                         "Phi1(u[k-1],u[k-2])*y[k-1]", "u[k-1]*u[k-2]", "1"])
    cl = {c.key: sorted(i for i, _ in c.members) for c in clusters(terms)}
    assert cl == {"y": [0, 1], "u": [2], "y*u": [3, 4], "u^2": [6], "1": [7]}
    th = [0.6, 0.3, 0.5, 0.25, -0.05, 9.0, 0.125, 2.0]
    s = cluster_sums(terms, th)
    assert s == pytest.approx({"y": 0.9, "u": 0.5, "y*u": 0.2, "u^2": 0.125, "1": 2.0})
    cons = steady_state_constraints(terms)
    assert rows_as_sets(cons)[frozenset({(8, 1.0)})] == 0.0      # constant term: Σ_1 = 0


def test_phi_of_equal_signals_vanishes_even_with_outputs():
    # at steady state y[k-1] = y[k-2] = ȳ, so Phi1/Phi2 of outputs are 0 too
    terms = parse_terms(["y[k-1]", "Phi1(y[k-1],y[k-3])", "u[k-1]*Phi2(y[k-2],y[k-1])",
                         "u[k-2]"])
    assert rows_as_sets(steady_state_constraints(terms)) == {
        frozenset({(1, 1.0)}): 1.0, frozenset({(4, 1.0)}): 0.0}


def test_phi_of_different_signals_does_not_vanish():
    # Phi1(y, u) at steady state is ȳ - ū, not 0: it must stay in a cluster
    terms = parse_terms(["y[k-1]", "Phi1(y[k-1],u[k-1])"])
    cons = steady_state_constraints(terms)
    assert cons.S.shape == (2, 2)
    assert rows_as_sets(cons)[frozenset({(2, 1.0)})] == 0.0


def test_multiple_inputs_form_separate_clusters():
    sig = narx.Signals(output="f", inputs=("x", "v"))
    terms = parse_terms(["f[k-1]", "f[k-2]", "x[k-1]", "v[k-1]", "x[k-2]", "x[k-1]*v[k-2]",
                         "v[k-1]*x[k-3]", "f[k-1]*x[k-1]", "Phi1(x[k-1],x[k-2])"], sig)
    cons = steady_state_constraints(terms)
    assert rows_as_sets(cons) == {
        frozenset({(1, 1.0), (2, 1.0)}): 1.0,
        frozenset({(3, 1.0), (5, 1.0)}): 0.0,
        frozenset({(4, 1.0)}): 0.0,
        frozenset({(6, 1.0), (7, 1.0)}): 0.0,
        frozenset({(8, 1.0)}): 0.0,
    }


@pytest.mark.parametrize("texts", [
    ["u[k-1]", "Phi1(u[k-1],u[k-2])"],
    ["y[k-1]*Phi1(u[k-1],u[k-2])", "u[k-1]"],
    ["y[k-1]*y[k-2]", "u[k-1]"],
    ["y[k-1]*u[k-1]", "u[k-2]"],
])
def test_model_without_a_surviving_linear_output_term_raises(texts):
    with pytest.raises(EstimationError, match="no continuum of steady states.*Σ_y = 1"):
        steady_state_constraints(parse_terms(texts))
    rng = np.random.default_rng(0)
    u, y = rng.normal(size=200), rng.normal(size=200)
    with pytest.raises(EstimationError, match="no linear output term"):
        Model(texts).fit(u, y, constraints="steady-state")


# --------------------------------------------------------------- user Φ
def test_user_phi_constant_steady_multiplies_and_zero_drops():
    reg = PhiRegistry()
    reg.register("Half", 2, lambda a, b: 0.5 + (a - b), steady=0.5)
    reg.register("Odd", 2, lambda a, b: np.tanh(a - b), steady=0.0)
    reg.register("Three", 1, lambda a: 3.0 + 0.0 * a, steady=3)
    terms = parse_terms(["y[k-1]", "y[k-2]*Half(u[k-1],u[k-3])", "u[k-1]*Odd(u[k-2],u[k-1])",
                         "u[k-2]", "u[k-3]*Three(u[k-1])*Half(u[k-1],u[k-2])",
                         "Odd(y[k-1],y[k-2])"], registry=reg)
    cons = steady_state_constraints(terms, registry=reg)
    assert rows_as_sets(cons) == {
        frozenset({(1, 1.0), (2, 0.5)}): 1.0,         # Σ_y = θ1 + 0.5 θ2 = 1
        frozenset({(4, 1.0), (5, 1.5)}): 0.0,         # Σ_u = θ4 + 3·0.5 θ5 = 0
    }
    sums = cluster_sums(terms, [0.8, 0.4, 7.0, 0.3, -0.2, 5.0], registry=reg)
    assert sums == pytest.approx({"y": 1.0, "u": 0.0})
    # the default registry does not know these functions
    with pytest.raises(narx.TermError):
        parse_terms(["y[k-2]*Half(u[k-1],u[k-3])"])


def test_user_phi_of_the_output_bouc_wen(abs_registry):
    terms, theta = bouc_wen_discrete_narx()
    m = Model(terms, registry=abs_registry)
    cons = m.steady_state_constraints()
    assert rows_as_sets(cons) == {frozenset({(1, 1.0)}): 1.0}
    # the true system has a continuum of steady states; CLS recovers it exactly
    u = training_input(n=4000, seed=2)
    y = bouc_wen_discrete(u, h0=0.3)
    m.fit(u, y, constraints="steady-state")
    np.testing.assert_allclose(m.theta, theta, rtol=1e-9, atol=1e-12)
    assert m.fit_info_["method"] == "cls"


def test_user_phi_with_value_dependent_steady_is_its_own_cluster(abs_registry):
    terms = parse_terms(["y[k-1]", "Abs(y[k-1])", "Abs(y[k-2])*u[k-1]", "Abs(u[k-1])"],
                        registry=abs_registry)
    cons = steady_state_constraints(terms, registry=abs_registry)
    rows = rows_as_sets(cons)
    assert rows[frozenset({(1, 1.0)})] == 1.0
    assert len(rows) == 4 and all(v == 0.0 for k, v in rows.items() if (1, 1.0) not in k)


# --------------------------------------------------------------- CLS on the piezo
@pytest.fixture(scope="module")
def piezo_models(piezo_training, model33_terms):
    u, y = piezo_training
    ls = Model(model33_terms).fit(u, y)
    cls = Model(model33_terms).fit(u, y, constraints="steady-state")
    return ls, cls


def test_cls_on_piezo_meets_the_constraints(piezo_models):
    ls, cls = piezo_models
    cons = cls.steady_state_constraints()
    assert np.max(np.abs(cons.S @ cls.theta - cons.c)) < 1e-10
    th = cls.theta
    assert abs(th[6] - 1) < 1e-10 and abs(th[1] + th[14]) < 1e-10
    assert abs(th[3] + th[12]) < 1e-10 and abs(th[0] + th[2]) < 1e-10
    assert cls.fit_info_["method"] == "cls" and len(cls.fit_info_["constraints"]) == 4
    # LS does not meet them (otherwise the drift control below is meaningless)
    assert np.max(np.abs(cons.S @ ls.theta - cons.c)) > 1e-6
    # and CLS costs one-step-ahead fit, but not much
    assert ls.fit_info_["residual_ss"] < cls.fit_info_["residual_ss"]


def test_cls_model_holds_its_output_when_the_input_is_held(piezo_models):
    ls, cls = piezo_models
    hs = held_sine()
    y = piezo_bouc_wen(hs.u)
    span = np.ptp(y)
    drift = {}
    for name, m in (("ls", ls), ("cls", cls)):
        r = m.simulate(hs.u, y, "freerun")
        assert not r.diverged
        drift[name] = [np.ptp(r.y_hat[h.start + 100:h.stop])
                       for h in (hs.hold_rising, hs.hold_falling)]
    assert max(drift["cls"]) < 1e-6 * span, drift
    assert max(drift["ls"]) > 1e-6 * span, drift          # the control drifts
    assert min(drift["ls"]) > 10 * max(drift["cls"]), drift


def test_constraints_of_term_texts():
    """Term texts are accepted as the rest of the API accepts them (an
    AttributeError before)."""
    from narx.analysis.steady import steady_state_constraints
    from narx.language.terms import parse_terms
    texts = ["y[k-1]", "u[k-1]", "u[k-2]", "Phi1(u[k-1],u[k-2])"]
    a = steady_state_constraints(texts)
    b = steady_state_constraints(parse_terms(texts))
    np.testing.assert_array_equal(a.S, b.S)
    assert a.labels == b.labels
