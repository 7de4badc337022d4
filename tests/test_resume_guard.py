"""A checkpoint resumes only the run it belongs to: same data, same scoring,
unedited; a run started without a seed resumes with the checkpoint's."""
import json

import numpy as np
import pytest

from mggp import MGGPRegressor

from conftest import first_order_record


def record(seed, n=300):
    return first_order_record(n, seed, noise=0.01)


KW = dict(population=12, generations=2, max_height=2, use_phi=False, fitness="pem")


def test_other_data_or_scoring_is_refused(tmp_path):
    ck = tmp_path / "ck.json"
    MGGPRegressor(random_state=1, checkpoint=ck, **KW).fit(*record(0))
    with pytest.raises(ValueError, match=r"differs in: context\.data"):
        MGGPRegressor(random_state=1, checkpoint=ck, resume=True,
                      **dict(KW, generations=4)).fit(*record(1))
    with pytest.raises(ValueError, match=r"context\.criterion \(checkpoint 'mse', this run 'bic'\)"):
        MGGPRegressor(random_state=1, checkpoint=ck, resume=True, criterion="bic",
                      **dict(KW, generations=4)).fit(*record(0))
    with pytest.raises(ValueError, match=r"seed \(checkpoint 1, this run 2\)"):
        MGGPRegressor(random_state=2, checkpoint=ck, resume=True,
                      **dict(KW, generations=4)).fit(*record(0))
    # control: the same run resumes
    MGGPRegressor(random_state=1, checkpoint=ck, resume=True,
                  **dict(KW, generations=4)).fit(*record(0))


def test_run_without_seed_resumes_with_the_checkpoint_seed(tmp_path):
    ck = tmp_path / "ck.json"
    a = MGGPRegressor(checkpoint=ck, **KW).fit(*record(0))
    b = MGGPRegressor(checkpoint=ck, resume=True, **dict(KW, generations=4)).fit(*record(0))
    assert b.seed_ == a.seed_
    full = MGGPRegressor(random_state=a.seed_, **dict(KW, generations=4)).fit(*record(0))
    assert b.model_.term_texts == full.model_.term_texts
    np.testing.assert_array_equal(b.model_.theta, full.model_.theta)


@pytest.mark.parametrize("seed", [16, 25])
def test_a_checkpoint_does_not_change_the_fit(tmp_path, seed):
    """The automatic choices run their pilots with a checkpoint too (each
    pilot's beside it), so a checkpointed fit is the fit without one. On
    these seeds the pilot without the constant term wins; before, a
    checkpointed fit skipped that pilot and ended elsewhere."""
    ck = tmp_path / "ck.json"
    kw = dict(KW, generations=4)
    a = MGGPRegressor(random_state=seed, checkpoint=ck, **kw).fit(*record(0))
    full = MGGPRegressor(random_state=seed, **kw).fit(*record(0))
    assert a.model_.term_texts == full.model_.term_texts
    np.testing.assert_array_equal(a.model_.theta, full.model_.theta)
    assert a.choices_["constant"]["why"] == full.choices_["constant"]["why"]
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "ck.json", "ck.json.pilot-no_phi", "ck.json.pilot-no_phi-no-constant",
        "ck.json.pilot-no_phi-no-constant-powers"]


class _StopInPilot:
    """Interrupts a fit at the first generation of its second pilot."""

    def __init__(self):
        self.label = ""

    def phase(self, label, generations):
        self.label = label

    def __call__(self, state):
        if self.label.startswith("pilot 2"):
            raise KeyboardInterrupt


def test_a_fit_stopped_in_its_pilots_resumes_to_the_same_model(tmp_path):
    """Stopped during the second of its class pilots (use_phi='auto'), the
    resumed fit takes the finished pilot from its file, continues the
    stopped one and ends as the uninterrupted fit; control: the fit is
    really stopped there (the continued search's file is not yet written)."""
    ck = tmp_path / "ck.json"
    kw = dict(KW, use_phi="auto", generations=5)
    with pytest.raises(KeyboardInterrupt):
        MGGPRegressor(random_state=3, checkpoint=ck, callbacks=[_StopInPilot()],
                      **kw).fit(*record(0))
    assert not ck.exists() and (tmp_path / "ck.json.pilot-no_phi").exists()
    b = MGGPRegressor(random_state=3, checkpoint=ck, resume=True, **kw).fit(*record(0))
    full = MGGPRegressor(random_state=3, **kw).fit(*record(0))
    assert b.model_.term_texts == full.model_.term_texts
    np.testing.assert_array_equal(b.model_.theta, full.model_.theta)
    assert b.choices_["use_phi"]["why"] == full.choices_["use_phi"]["why"]


@pytest.mark.parametrize("edit, text", [
    (lambda d: d.update(population=d["population"][:3]), "population_size=12"),
    (lambda d: d.update(generation=1000000), "logbook holds"),
    (lambda d: d.update(generation=True), "'generation' must be an integer"),
    (lambda d: d["settings"].update(population_size=3), "'fingerprint' does not match"),
    (lambda d: d["population"][0].update(genes=d["population"][0]["genes"] * 40),
     "more than max_terms"),
])
def test_edited_checkpoint_is_refused(tmp_path, edit, text):
    ck = tmp_path / "ck.json"
    MGGPRegressor(random_state=1, checkpoint=ck, **KW).fit(*record(0))
    doc = json.loads(ck.read_text())
    edit(doc)
    ck.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=text):
        MGGPRegressor(random_state=1, checkpoint=ck, resume=True,
                      **dict(KW, generations=4)).fit(*record(0))


def test_fitness_cache_is_packed_and_older_files_still_read(tmp_path):
    from mggp.gp.checkpoint import _pack_cache, _unpack_cache
    cache = {("u[k-1]", "y[k-1]"): 0.5, ("y[k-1]",): float("inf"), ("u[k-1]",): 1.0}
    packed = _pack_cache(cache)
    assert packed["terms"] == ["u[k-1]", "y[k-1]"]           # each text once
    assert _unpack_cache(json.loads(json.dumps(packed))) == cache
    older = [[list(k), v if v != float("inf") else "inf"] for k, v in cache.items()]
    assert _unpack_cache(older) == cache
    with pytest.raises(ValueError, match="entry 0 must be"):
        _unpack_cache({"terms": ["y[k-1]"], "entries": [[[3], 0.1]]})


def test_checkpoint_written_before_phi_outputs_resumes(tmp_path):
    """A default run's settings are those of the version before phi_outputs
    (no such context key), so its checkpoints still resume."""
    from mggp.gp.checkpoint import settings_fingerprint
    from mggp.gp.primitives import make_pset
    from narx.records.data import as_data
    ck = tmp_path / "ck.json"
    MGGPRegressor(random_state=1, checkpoint=ck, **KW).fit(*record(0))
    doc = json.loads(ck.read_text())
    doc["settings"]["context"].pop("phi_outputs", None)     # as the previous version wrote
    pset = make_pset(as_data(*record(0)).signals, use_phi=False)
    doc["fingerprint"] = settings_fingerprint(doc["settings"], pset)
    ck.write_text(json.dumps(doc))
    b = MGGPRegressor(random_state=1, checkpoint=ck, resume=True,
                      **dict(KW, generations=4)).fit(*record(0))
    full = MGGPRegressor(random_state=1, **dict(KW, generations=4)).fit(*record(0))
    assert b.model_.term_texts == full.model_.term_texts


@pytest.mark.parametrize("first, then", [(dict(phi_outputs=True), {}),
                                         ({}, dict(phi_outputs=True)),
                                         ({}, dict(use_phi=False))])
def test_other_primitive_set_names_the_setting(tmp_path, first, then):
    """A resume whose primitive set differs (its genes do not parse, or the
    file's fingerprint does not match this set) names the setting, as for
    any other setting, not only the gene or the fingerprint."""
    ck = tmp_path / "ck.json"
    kw = dict(KW, use_phi=True)
    MGGPRegressor(random_state=1, checkpoint=ck, **dict(kw, **first)).fit(*record(0))
    key = next(iter(then or first))
    with pytest.raises(ValueError, match=rf"differs in: context\.{key} "):
        MGGPRegressor(random_state=1, checkpoint=ck, resume=True,
                      **dict(kw, generations=4, **then)).fit(*record(0))
