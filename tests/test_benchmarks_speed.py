"""Smoke tests of the speed benchmarks and of the window-major MS kernel.

Tiny records only; the timed studies themselves are run by hand
(``python -m benchmarks.speed`` etc., see benchmarks/RESULTS.md).
"""
import random

import numpy as np
import pytest

import narx
import narx.simulation.ms_kernel as msk
from benchmarks import evals, full_setup, speed
from narx.records.data import as_data
from narx.estimation.fitness import StructureScorer
from conftest import piezo_record


@pytest.fixture(scope="module")
def record():
    return piezo_record(3000, seed=3)


def test_hand_written_loop_is_model33(record):
    u, y = record
    m = narx.Model(list(speed.MODEL33)).fit(u, y)
    ours = m.simulate(u, y, mode="freerun").y_hat
    hand = speed.model33_loop(u.tolist(), y.tolist(), m.theta.tolist(), [0.0] * len(u))
    assert speed.rel_diff(hand, ours, y) < 1e-9


def test_speed_markdown_renders():
    rows = {k: {"seconds": 1e-3, "rel_diff": 0.0} for k in
            ("ours_model_simulate", "ours_simulate_reused_data", "ours_kernel_only",
             "python_loop", "numba_floor")}
    rows["toolbox_predict_freeRun"] = {"available": False, "reason": "unavailable: offline"}
    res = speed._ratios({"n": 10, "repeats": 1, "load_before": "x", "rows": rows}, 1e-9)
    assert res["agree"] and res["ratios"]["kernel/floor"] == pytest.approx(1.0)
    text = speed.markdown({"freerun": res})
    assert "unavailable: offline" in text and "kernel/floor" in text
    rows["python_loop"]["rel_diff"] = 1.0
    bad = speed._ratios({"n": 10, "repeats": 1, "load_before": "x", "rows": rows}, 1e-9)
    assert not bad["agree"] and "ratios" not in bad


def test_random_term_sets_respect_limits():
    sets = evals.random_term_sets(30, seed=1)
    assert len(sets) == 30 and all(1 <= len(s) <= 15 for s in sets)
    assert all(len(set(s)) == len(s) for s in sets)


def _sets(n, seed=0):
    return evals.random_term_sets(n, seed=seed)


def _sets_phi_outputs(n, seed=0):
    """Random individuals of a ``phi_outputs`` set: terms with Φ of output lags."""
    import random
    from mggp.gp.operators import random_individual
    from mggp.gp.primitives import Decoder, make_pset
    ps, rng = make_pset(phi_outputs=True), random.Random(seed)
    dec, sets = Decoder(ps.signals), []
    while len(sets) < n:
        terms = tuple(t for t in dec.decode_individual(random_individual(
            ps, rng, max_terms=15, max_height=5)) if not any(
            f.name == "Phi1" and f.args[0] == f.args[1] for f in t.factors
            if hasattr(f, "args")))
        if terms:
            sets.append(terms)
    return sets


@pytest.mark.parametrize("window", [1, 7, 100, 5000])
def test_ms_kernel_bit_identical_to_general_kernel(record, window):
    u, y = record
    sets = _sets(25, seed=window) + [tuple(narx.parse_terms(speed.MODEL33))]
    phi_y = _sets_phi_outputs(25, seed=window)          # Φ of output lags: fast path too
    assert sum(any("(y[" in t.text for t in s) for s in phi_y) > 10
    assert all(msk._term_info(t) is not None for s in phi_y for t in s)
    sets += phi_y
    out = {}
    for flag in (False, True):
        old = msk.ENABLED
        msk.ENABLED = flag
        try:
            sc = StructureScorer(as_data(u, y), "ms", window=window, start=16)
            out[flag] = [sc.score(s) for s in sets] + [sc.score(s) for s in sets[::-1]]
        finally:
            msk.ENABLED = old
    assert out[True] == out[False]                       # bit for bit, infs included
    assert any(np.isfinite(v) for v in out[True])


def test_ms_kernel_agrees_with_narx_simulate(record):
    u, y = record
    sc = StructureScorer(as_data(u, y), "ms", window=50, start=16)
    checked = 0
    for s in _sets(20, seed=5) + [tuple(narx.parse_terms(speed.MODEL33))]:
        mse, theta = sc.evaluate(s)
        if not np.isfinite(mse):
            continue
        ml = max(t.max_lag for t in s)
        ref = narx.simulate(s, theta, as_data(u[16 - ml:], y[16 - ml:]), "ms", window=50)
        assert mse == pytest.approx(ref.mse, rel=1e-12)
        checked += 1
    assert checked >= 5


def test_ms_kernel_falls_back_when_not_handled(record):
    u, y = record
    # a Φ-call with an output argument, and a scorer without a fixed start
    terms = tuple(narx.parse_terms(["y[k-1]", "Phi1(y[k-1],u[k-2])", "u[k-1]"]))
    sc = StructureScorer(as_data(u, y), "ms", window=40, start=16)
    assert sc.shooting.mse(terms, np.array([0.9, 0.01, 0.1]), 16, sc.bound, sc.input_column) is None
    plain = tuple(narx.parse_terms(["y[k-1]", "u[k-1]"]))
    assert sc.shooting.mse(plain, np.array([0.9, 0.1]), 16, sc.bound,
                           sc.input_column) is not None
    free = StructureScorer(as_data(u, y), "ms", window=40)
    assert free.shooting is None
    assert np.isfinite(sc.score(terms)) and np.isfinite(free.score(plain))


def test_evals_sequential_smoke(record):
    u, y = record
    r = evals.sequential(u, y, _sets(6), window=100, repeats=1, fast=True)
    assert r["cold_eps"] > 0 and r["warm_eps"] > 0 and len(r["values"]) == 6


def test_full_setup_smoke():
    r = full_setup.run(n=1500, population=6, generations=1, jobs=1, seed=0)
    assert r["evaluations"] >= 1 and np.isfinite(r["best_fitness"])
    assert "wall time" in full_setup.markdown(r)


@pytest.mark.parametrize("n, L", [(1, 1), (10, 3), (1000, 100), (1001, 100), (57, 1000)])
def test_window_sse_sums_each_window_then_the_windows(n, L):
    r = np.random.default_rng(n).standard_normal(n) * 1e3
    total = 0.0
    for a in range(0, n, L):                  # the documented order, in Python
        acc = 0.0
        for v in r[a:a + L].tolist():
            acc += v * v
        total += acc
    assert msk.window_sse(r, L) == total
    assert msk.window_sse(r, L) == pytest.approx(float(r @ r), rel=1e-12)


def test_eval_phases_account_for_the_whole_evaluation():
    from benchmarks.eval_phases import run
    r = run(n=3000, individuals=12, window=100, repeats=1)
    ph = r["phases"]
    assert {"Gram entries", "MS kernel", "columns", "Python"} <= set(ph)
    assert sum(ph.values()) == pytest.approx(r["seconds_per_eval"])
    assert all(v >= 0 for k, v in ph.items() if k != "Python")
    import narx.estimation.fitness as fit
    assert fit.fixed_dot.__name__ == "fixed_dot"          # wrappers removed again
