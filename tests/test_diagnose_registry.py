"""Diagnose tests in a registry: a test registered at run time runs in the
diagnosis, its checks reach the JSON document and the report, and a check
that beats its threshold is evidence by the findings rule, never the verdict;
no test runs by default."""
import json

import numpy as np
import pytest

import narx
from narx.records.data import Data
from narx.systems import held_sine, piezo_bouc_wen, training_input

from mggp.diagnose import (Budget, Check, DiagnosticTest, Outcome, diagnose, register,
                           registered, unregister)
from mggp.diagnose.report import write_report

TINY = Budget(population=20, generations=2, shifts=19)
BUILTIN = []


@pytest.fixture(scope="module")
def case():
    """A 1500-sample piezo record, a held sine, and a linear model of it."""
    u = training_input(1500, bandwidth=4.0, seed=0)
    hs = held_sine(amplitude=60, freq=2.0, hold=0.5)
    train, val = Data(u, piezo_bouc_wen(u)), Data(hs.u, piezo_bouc_wen(hs.u))
    return train, val, narx.Model(["y[k-1]", "u[k-1]"]).fit(train)


def mean_residual_test(factor, effect="prediction-bias"):
    """A dummy test: |mean one-step residual| against ``factor`` × floor."""
    def run(ctx):
        r = ctx.model.simulate(ctx.fit, mode="osa").residual
        stat = float(abs(np.nanmean(r)))
        thr = factor * ctx.floor
        return Outcome([Check("mean residual", effect, stat, thr,
                              f"|mean one-step residual| {stat:.3g}, threshold {thr:.3g}")],
                       result=stat)
    return DiagnosticTest("dummy mean residual", (effect,), run)


@pytest.fixture
def dummy():
    """Register a dummy test for one test function, and unregister it after."""
    tests = []

    def add(test):
        tests.append(register(test))
        return test
    yield add
    for t in tests:
        unregister(t.name)


def test_no_residual_test_runs_by_default(case):
    """The checks that ran by default changed no outcome on the zoo's
    development draws (``python -m benchmarks.zoo ablate``) and were removed."""
    assert [t.name for t in registered()] == BUILTIN
    train, val, model = case
    dx = diagnose(train, val, model, budget=TINY, seed=0)
    assert dx.checks == [] and dx.evidence_findings == [] and "evidence" not in dx.summary()


def test_a_registered_test_runs_and_its_checks_reach_json_and_report(case, dummy, tmp_path):
    train, val, model = case
    before = diagnose(train, val, model, budget=TINY, seed=0)
    dummy(mean_residual_test(factor=1e9))            # cannot fire
    assert [t.name for t in registered()] == BUILTIN + ["dummy mean residual"]
    dx = diagnose(train, val, model, budget=TINY, seed=0)
    assert dx.evidence.result("dummy mean residual") >= 0
    tests = {t["test"]: t for t in dx.to_dict()["tests"]}
    assert tests["mean residual"]["effect"] == "prediction-bias"
    assert tests["mean residual"]["beats_threshold"] is False
    assert json.dumps(dx.to_dict(), allow_nan=False)
    report = open(write_report(tmp_path / "r", dx)).read()
    assert "| mean residual | prediction-bias |" in report
    # the other checks (none by default) and the findings are those without the dummy
    assert [c.test for c in dx.checks] == [c.test for c in before.checks] + ["mean residual"]
    assert dx.effects == before.effects


def test_a_registered_check_that_beats_its_threshold_is_evidence_not_the_verdict(case, dummy):
    train, val, model = case
    before = diagnose(train, val, model, budget=TINY, seed=0)
    effect = "unmodelled-nonlinearity"
    assert effect not in [f.effect for f in before.evidence_findings]   # control
    dummy(mean_residual_test(factor=0.0, effect=effect))   # any nonzero mean fires
    dx = diagnose(train, val, model, budget=TINY, seed=0)
    c = next(c for c in dx.checks if c.test == "mean residual")
    assert c.beats and effect in [f.effect for f in dx.evidence_findings]
    f = next(f for f in dx.evidence_findings if f.effect == effect)
    assert f.evidence.startswith(c.detail) and f.statistic == c.statistic
    # the named effects come from the paired test of the candidates, not the check
    assert dx.effects == before.effects


def test_after_unregister_the_test_no_longer_runs(case):
    train, val, model = case
    t = register(mean_residual_test(factor=0.0))
    unregister(t.name)
    dx = diagnose(train, val, model, budget=TINY, seed=0)
    assert "mean residual" not in [c.test for c in dx.checks]
    assert [t.name for t in registered()] == BUILTIN


def test_registry_rejects_what_it_cannot_run(case, dummy):
    with pytest.raises(ValueError, match="effects must be one or more of"):
        DiagnosticTest("bad", ("friction",), lambda ctx: Outcome())
    dummy(DiagnosticTest("twice", ("hysteresis",), lambda ctx: Outcome()))
    with pytest.raises(ValueError, match="'twice' is registered already"):
        register(DiagnosticTest("twice", ("hysteresis",), lambda ctx: Outcome()))
    with pytest.raises(KeyError, match="no diagnose test named 'nothing'"):
        unregister("nothing")
    # a check of an effect the test does not declare stops the diagnosis
    train, val, model = case
    dummy(DiagnosticTest("liar", ("hysteresis",), lambda ctx: Outcome(
        [Check("liar", "prediction-bias", 1.0, 0.0, "")])))
    with pytest.raises(ValueError, match="returned check 'liar' of effect 'prediction-bias'"):
        diagnose(train, val, model, budget=TINY, seed=0)
