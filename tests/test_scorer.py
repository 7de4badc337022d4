"""StructureScorer: memory that grows with use, its divergence bound, and the
multiple-shooting kernel it owns."""
from __future__ import annotations

import os

import numpy as np
import pytest

import narx
import narx.simulation.ms_kernel as msk
from narx.records.data import Data
from narx.estimation.fitness import StructureScorer


def _record(n, seed=0):
    rng = np.random.default_rng(seed)
    u = np.cumsum(rng.standard_normal(n))
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.9 * y[k - 1] + 0.1 * u[k - 1]
    return Data(u, y)


#: run in a fresh interpreter: in a long process ``numpy.empty`` may be handed
#: a block an earlier test freed and the allocator kept resident, and then
#: no store, lazy or not, could show its growth (a CI run read 0 bytes)
_MEASURE = """
import json
from narx.estimation.fitness import ColumnStore

def resident(array):
    # resident bytes of the mappings that hold array, from the page tables
    # (/proc/self/smaps); numpy may split it over several mappings
    start = array.ctypes.data
    stop = start + array.nbytes
    inside, total = False, 0
    with open("/proc/self/smaps") as fh:
        for line in fh:
            head = line.split()[0]
            if "-" in head and not head.endswith(":"):
                low, high = (int(x, 16) for x in head.split("-"))
                inside = low < stop and start < high
            elif inside and head == "Rss:":
                total += int(line.split()[1]) * 1024
    return total

n, budget = 200_000, 64 * 2**20
lazy = ColumnStore(n, budget)
out = {"slots": lazy.capacity, "built": resident(lazy.array)}
for i in range(4):
    lazy.get(f"c{i}", lambda row: row.fill(1.0))
out["filled"] = resident(lazy.array)
del lazy
eager = ColumnStore(n, budget, prefault=True)
out["prefaulted"] = resident(eager.array)
print(json.dumps(out))
"""


@pytest.mark.skipif(not os.path.exists("/proc/self/smaps"), reason="needs /proc")
def test_column_store_memory_grows_with_the_columns_held():
    """A lazy store's pages become resident as its columns are written: none
    at construction, about four columns after four; the control, a
    prefaulted store, is resident at once."""
    import json
    import subprocess
    import sys
    n = 200_000
    run = subprocess.run([sys.executable, "-c", _MEASURE], capture_output=True, text=True,
                         timeout=300, check=True)
    got = json.loads(run.stdout.strip().splitlines()[-1])
    full = got["slots"] * 8 * n                           # ~100 MB
    assert got["built"] < full / 10
    assert 3 * 8 * n <= got["filled"] < full / 4          # about four columns
    assert got["prefaulted"] > full / 2


def test_lazy_and_prefaulted_scorers_score_the_same():
    d = _record(3000)
    sets = [narx.parse_terms(t) for t in (["y[k-1]", "u[k-1]"],
                                          ["y[k-1]", "Phi1(u[k-1],u[k-2])", "y[k-2]*u[k-1]"],
                                          ["y[k-1]", "Phi2(y[k-1],y[k-2])", "u[k-2]"])]
    for fitness in ("pem", "freerun", "ms"):
        a = StructureScorer(d, fitness, start=4, window=50)
        b = StructureScorer(d, fitness, start=4, window=50, prefault=True)
        assert [a.score(s) for s in sets] == [b.score(s) for s in sets]


def test_bound_is_set_by_argument_or_method_and_checked():
    d = _record(2000)
    sc = StructureScorer(d, "freerun", start=2)
    assert sc.bound == 1e4 * np.max(np.abs(d.y))
    terms = narx.parse_terms(["y[k-1]", "u[k-1]"])
    mse = sc.score(terms)
    assert np.isfinite(mse)
    peak = float(np.max(np.abs(d.y[2:])))
    assert sc.set_bound(0.5 * peak) is sc and sc.bound == 0.5 * peak
    assert sc.score(terms) == np.inf                      # the simulation leaves the bound
    assert StructureScorer(d, "freerun", start=2, bound=0.5 * peak).score(terms) == np.inf
    assert StructureScorer(d, "freerun", start=2, bound=10 * peak).score(terms) == mse
    for bad in (-1.0, np.inf, np.nan, "x"):
        with pytest.raises(ValueError, match="bound must be a finite number >= 0"):
            sc.set_bound(bad)
    with pytest.raises(AttributeError):
        sc.bound = 1.0                                    # read-only: use set_bound


def test_scorer_owns_its_multiple_shooting_kernel(monkeypatch):
    d = _record(3000)
    terms = tuple(narx.parse_terms(["y[k-1]", "u[k-1]", "Phi1(u[k-1],u[k-2])"]))
    sc = StructureScorer(d, "ms", start=3, window=40)
    assert isinstance(sc.shooting, msk.MultipleShooting)
    assert StructureScorer(d, "ms", window=40).shooting is None       # no fixed start
    assert StructureScorer(d, "freerun", start=3).shooting is None
    fast = sc.score(terms)
    assert sc.shooting.store.builds == 3
    monkeypatch.setattr(msk, "ENABLED", False)
    assert sc.shooting.mse(terms, sc.fit(terms)[0], 3, sc.bound, sc.input_column) is None
    assert StructureScorer(d, "ms", start=3, window=40).score(terms) == fast
    monkeypatch.setattr(msk, "ENABLED", True)
    sc.clear_cache()
    assert not sc.shooting.store.slots and not sc.shooting.info
    assert sc.score(terms) == fast and sc.shooting.store.builds == 6


@pytest.mark.parametrize("fitness", ["pem", "freerun", "ms"])
def test_a_dropped_scorer_is_freed_at_once(fitness):
    # no reference cycle: a fit builds several scorers one after the other,
    # and each must release its stores when dropped, not at the next GC
    import gc
    import weakref
    d = _record(2000)
    gc.disable()
    try:
        sc = StructureScorer(d, fitness, start=3, window=40)
        sc.score(narx.parse_terms(["y[k-1]", "u[k-1]", "Phi2(y[k-1],y[k-2])"]))
        ref = weakref.ref(sc)
        del sc
        assert ref() is None
    finally:
        gc.enable()
