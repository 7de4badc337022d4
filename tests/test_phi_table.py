"""The table of built-in Φ-functions (narx.language.phi.BUILTINS) and every compiled
kernel that reads it: each computes the row's numpy function bit for bit,
and a code not in the table is rejected, never computed."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import narx
import narx.simulation.ms_kernel as msk
from narx.records.colbuild import ColumnBuilder, build_into
from narx.records.data import Data
from narx.estimation.fitness import StructureScorer
from narx.simulation.kernels import Plan, run_windows
from narx.language.phi import BUILTINS, FORMS, builtin_code, check_codes, phi_value
from narx.records.regressors import factor_column, shift
from narx.language.terms import parse_term

ROWS = [f for f in BUILTINS]
UNKNOWN = max(f.code for f in BUILTINS) + 1


def _record(n=600, seed=0):
    rng = np.random.default_rng(seed)
    u = np.round(np.cumsum(rng.standard_normal(n)), 1)      # ties: sign 0 happens
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.9 * y[k - 1] + 0.1 * u[k - 1]
    return u, y


def test_table_rows_are_consistent():
    names = [f.name for f in BUILTINS]
    assert names[:2] == ["Phi1", "Phi2"] and len(set(names)) == len(names)
    codes = [f.code for f in BUILTINS]
    assert len(set(codes)) == len(codes) and all(c > 0 for c in codes)
    reg = narx.PhiRegistry()
    for f in BUILTINS:
        assert f.builtin and f.form in FORMS and f.arity == 2
        assert reg.get(f.name) is f and builtin_code(f.name) == f.code
        assert f.steady_is_constant
    assert builtin_code("Abs") is None
    check_codes(codes)
    with pytest.raises(ValueError, match=r"unknown built-in Φ-function code\(s\) \[%d\]"
                       % UNKNOWN):
        check_codes(codes + [UNKNOWN])


@pytest.mark.parametrize("row", ROWS, ids=lambda f: f.name)
def test_phi_value_is_the_numpy_function(row):
    vals = np.array([-np.inf, -3.5, -1e-300, -0.0, 0.0, 1e-300, 2.0, 3.5, np.inf, np.nan])
    a, b = np.meshgrid(vals, vals[::-1])
    a, b = a.ravel(), b.ravel()
    with np.errstate(invalid="ignore"):
        want = row.func(a, b)
    got = np.array([phi_value(row.code, x, z) for x, z in zip(a, b)])
    np.testing.assert_array_equal(got, want)                # NaN where numpy has NaN
    assert np.array_equal(np.signbit(got), np.signbit(want))


def test_unknown_codes_are_rejected_by_every_kernel():
    with pytest.raises(ValueError, match="unknown built-in"):
        phi_value(UNKNOWN, 1.0, 2.0)
    S = np.arange(20.0).reshape(2, 10)
    one = np.ones(1, dtype=np.int64)
    with pytest.raises(ValueError, match="unknown built-in"):
        build_into(np.empty(10), S, np.array([UNKNOWN]), 0 * one, one, 0 * one, 2 * one)
    u, y = _record(200)
    terms = narx.parse_terms(["y[k-1]", "Phi1(y[k-1],y[k-2])"])
    plan = Plan.from_terms(terms, ("u",))
    d = Data(u, y)
    bad = dataclasses.replace(plan, p_kind=np.array([UNKNOWN], dtype=np.int64))
    with pytest.raises(ValueError, match="unknown built-in"):
        run_windows(bad, bad.input_parts(d), d.U, y, [0.5, 0.1], np.array([2]), 50)
    # control: the same plan with its own code runs
    out, diverged = run_windows(plan, plan.input_parts(d), d.U, y, [0.5, 0.1],
                                np.array([2]), 50)
    assert not diverged and np.isfinite(out[2:52]).all()


@pytest.mark.parametrize("row", ROWS, ids=lambda f: f.name)
def test_regressor_column_is_the_numpy_function(row):
    u, y = _record()
    d = Data(u, y)
    call = parse_term(f"{row.name}(u[k-1],u[k-3])").factors[0]
    with np.errstate(invalid="ignore"):
        want = row.func(shift(u, 1), shift(u, 3))
    got = factor_column(call, d)
    np.testing.assert_array_equal(got, want)
    assert np.isnan(got[:3]).all() and (got[3:] == 0).any()         # ties are covered


@pytest.mark.parametrize("row", ROWS, ids=lambda f: f.name)
def test_column_builder_is_the_numpy_function(row):
    u, y = _record()
    d = Data(u, y)
    cb = ColumnBuilder(d, y, narx.default_registry())
    for text in (f"{row.name}(u[k-1],u[k-3])", f"y[k-1]*{row.name}(u[k-2],u[k-1])",
                 f"{row.name}(y[k-1],u[k-2])*u[k-1]"):
        t = parse_term(text)
        out = np.empty(d.n)
        assert cb.build(t, out)
        want = np.nan_to_num(narx.records.regressors.term_column(t, d, y), nan=0.0)
        np.testing.assert_array_equal(out, want)


@pytest.mark.parametrize("row", ROWS, ids=lambda f: f.name)
def test_recursion_kernel_is_the_numpy_function(row):
    u, y = _record()
    d = Data(u, y)
    terms = narx.parse_terms(["y[k-1]", f"{row.name}(y[k-1],y[k-2])",
                              f"u[k-1]*{row.name}(y[k-2],u[k-1])"])
    plan = Plan.from_terms(terms, d.inputs)
    assert plan.compiled and sorted(set(plan.p_kind)) == [row.code]
    P = plan.input_parts(d)
    theta = np.array([0.9, 0.05, 0.01])
    starts = np.arange(2, d.n, 40)
    fast, dv1 = run_windows(plan, P, d.U, y, theta, starts, 40)
    ref, dv2 = run_windows(plan, P, d.U, y, theta, starts, 40, force_python=True)
    assert not dv1 and not dv2
    np.testing.assert_array_equal(fast, ref)


@pytest.mark.parametrize("row", ROWS, ids=lambda f: f.name)
def test_shooting_kernel_is_the_numpy_function(row, monkeypatch):
    u, y = _record()
    d = Data(u, y)
    terms = tuple(narx.parse_terms(["y[k-1]", f"{row.name}(y[k-1],y[k-2])",
                                    f"u[k-1]*{row.name}(y[k-2],y[k-3])"]))
    assert all(msk._term_info(t) is not None for t in terms)
    theta = np.array([0.9, 0.05, 0.01])
    got = {}
    for flag in (True, False):
        monkeypatch.setattr(msk, "ENABLED", flag)
        got[flag] = StructureScorer(d, "ms", window=30, start=4).simulated_mse(terms, theta, 4)
    assert np.isfinite(got[True]) and got[True] == got[False]
