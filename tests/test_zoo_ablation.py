"""benchmarks.zoo_ablation: which outcomes differ between two runs, the
registry restored after a variant, and evaluation seeds refused."""
import pytest

from benchmarks.zoo_ablation import _registered_only, ablate, changed
from mggp.diagnose import DiagnosticTest, Outcome, register, registered, unregister
from narx.systems import zoo

RUN = {"named": ["hysteresis"], "gain": 2.0, "recommended": "extended", "note": None}


def test_changed_names_each_outcome_that_differs():
    assert changed(RUN, dict(RUN)) == []
    assert changed(RUN, dict(RUN, gain=2.0 * (1 + 1e-12))) == []        # rounding
    assert changed(RUN, dict(RUN, named=[], recommended="baseline", gain=1.0)) == [
        "named", "gain", "recommended"]
    assert changed(RUN, dict(RUN, note="one amplitude")) == ["note"]
    assert changed(RUN, dict(RUN, gain=None)) == ["gain"]


def test_a_variant_runs_with_its_tests_and_the_registry_is_restored():
    dummy = register(DiagnosticTest("ablation dummy", ("hysteresis",),
                                    lambda ctx: Outcome()))
    try:
        before = [t.name for t in registered()]
        with _registered_only([]):
            assert registered() == ()
        with pytest.raises(RuntimeError):
            with _registered_only([dummy]):
                assert [t.name for t in registered()] == ["ablation dummy"]
                raise RuntimeError("a failing diagnosis")
        assert [t.name for t in registered()] == before
    finally:
        unregister("ablation dummy")


def test_an_evaluation_seed_is_refused_before_anything_runs(tmp_path):
    path = tmp_path / "a.jsonl"
    with pytest.raises(zoo.SeedLeak):
        ablate([3, 1000], str(path), population=10, generations=1)
    assert not path.exists()
