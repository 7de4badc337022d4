"""The compiled column builder and the fused Gram products give the numpy
path's values bit for bit (the search's results must not change with them)."""
import numpy as np
import pytest

from narx.records.colbuild import ColumnBuilder
from narx.records.data import Data
from narx.estimation.fitness import StructureScorer, _finite_inplace
from narx.estimation.gram import fill_gram, fixed_dot
from narx.language.phi import PhiRegistry
from narx.records.regressors import input_part, term_column
from narx.language.terms import parse_term

TERMS = ["Phi2(u1[k-2],u1[k-3])", "Phi1(u1[k-1],u1[k-3])*u2[k-2]*y[k-1]",
         "u1[k-1]*u1[k-2]*y[k-1]*y[k-2]", "y[k-1]", "u2[k-4]",
         "Phi2(u2[k-1],u2[k-2])*Phi1(u1[k-2],u1[k-3])*u1[k-1]",
         "Phi1(y[k-1],u1[k-2])", "Phi2(u1[k-1],u2[k-1])*y[k-3]", "u1[k]"]


def _record(n=3000, seed=0):
    rng = np.random.default_rng(seed)
    u1 = np.round(np.cumsum(rng.standard_normal(n)), 1)   # held steps: Φ = 0
    u1[100:400] = 2.5                                     # a long hold
    u2 = rng.uniform(-1e3, 1e3, n)
    y = np.cumsum(rng.standard_normal(n)) * 1e-3
    return Data(np.column_stack([u1, u2]), y, inputs=["u1", "u2"])


def _numpy_column(term, data, input_only):
    if input_only:
        col = input_part(term, data).copy()
    else:
        col = term_column(term, data).copy()
    return _finite_inplace(col)


@pytest.mark.parametrize("text", TERMS)
@pytest.mark.parametrize("input_only", [False, True])
def test_builder_matches_numpy_path(text, input_only):
    data = _record()
    term = parse_term(text, data.signals)
    cb = ColumnBuilder(data, data.y, PhiRegistry())
    out = np.full(data.n, 7.0)
    assert cb.build(term, out, input_only=input_only)
    ref = _numpy_column(term, data, input_only)
    assert out.tobytes() == ref.tobytes(), text
    lag = term.max_lag if not input_only else max(
        (f.max_lag for f in term.input_factors), default=0)
    assert np.all(out[:lag] == 0.0)


def test_builder_declines_user_phi_and_noise_terms():
    data = _record()
    reg = PhiRegistry()
    reg.register("Sat", 1, lambda a: np.clip(a, -1, 1), 0.0)
    cb = ColumnBuilder(data, data.y, reg)
    out = np.zeros(data.n)
    assert not cb.build(parse_term("Sat(u1[k-1])*y[k-1]", data.signals, registry=reg), out)
    assert not cb.build(parse_term("e[k-1]*u1[k-1]", data.signals), out)
    assert np.all(out == 0.0)                     # nothing written


def test_fill_gram_equals_fixed_dot_for_every_group_size():
    rng = np.random.default_rng(3)
    arr = rng.standard_normal((12, 1001))           # odd length: the tail sums
    y = rng.standard_normal(1001)
    for t in range(1, 9):                            # groups of 1..4 and more
        G = np.full((12, 12), np.nan)
        bv = np.full(12, np.nan)
        slots = rng.permutation(12)[:t].astype(np.int64)
        G[slots[0], slots[-1]] = G[slots[-1], slots[0]] = np.nan
        sub, b = fill_gram(G, bv, arr, slots, y, 5)
        for i, a in enumerate(slots):
            assert b[i] == fixed_dot(arr[a, 5:], y[5:])
            for j, c in enumerate(slots):
                assert sub[i, j] == fixed_dot(arr[a, 5:], arr[c, 5:])


def test_scorer_uses_builder_and_scores_as_before():
    """The scorer's store rows are the numpy path's columns."""
    data = _record()
    terms = [parse_term(t, data.signals) for t in TERMS[:6]]
    sc = StructureScorer(data, "ms", window=50, start=4)
    mse, theta = sc.evaluate(terms)
    assert np.isfinite(mse)
    for t in terms:
        row = sc.store.array[sc.store.slots["r:" + t.text]]
        assert row.tobytes() == _numpy_column(t, data, False).tobytes()


@pytest.mark.parametrize("fitness", ["pem", "freerun", "ms"])
@pytest.mark.parametrize("start", [None, 12])
def test_record_shorter_than_the_lags_scores_inf(fitness, start):
    """No row to fit or score: inf, as a failed fit (the compiled builder's
    all-zero columns scored a perfect -0.0 in pem, and freerun raised
    ZeroDivisionError)."""
    rng = np.random.default_rng(0)
    data = Data(rng.standard_normal(10), rng.standard_normal(10))
    sc = StructureScorer(data, fitness, start=start)
    for text in (["y[k-12]"], ["u[k-12]", "y[k-1]"], ["Phi1(u[k-1],u[k-12])"], ["y[k-10]"]):
        terms = [parse_term(t, data.signals) for t in text]
        assert sc.score(terms) == float("inf"), text
