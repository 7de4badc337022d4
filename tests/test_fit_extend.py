"""The ``extend`` stage of the fit: the diagnosis's catalogue tried on the chosen structure.

A record with plays of the output hidden in its feedback (zoo development
seed 29, a Maxwell-slip element in the feedback of second-order dynamics)
must get a memory extension that validates better than the fit without the
stage; a memory-free control (development seed 3, Hammerstein) must not.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from mggp import MGGPRegressor
from narx.systems import zoo

#: a small budget: the search alone misses the hysteresis in the feedback
SMALL = dict(population=40, generations=4, random_state=1)


def _draw(seed):
    with zoo.tuning():
        return zoo.draw(seed, n=2000)


def _fit(d, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return MGGPRegressor(**SMALL, **kw).fit(d.train)


def _validation_rmse(est, d) -> float:
    sim = est.get_best().simulate(d.validation, mode="freerun")
    return float("inf") if sim.diverged else float(sim.rmse)


@pytest.fixture(scope="module")
def feedback_play():
    d = _draw(29)
    assert d.hysteretic and any("Play(y[k-1]" in t for t in d.truth.terms)
    return d, _fit(d), _fit(d, extend="none")


def test_hidden_hysteresis_gets_a_memory_extension(feedback_play):
    d, auto, none = feedback_play
    c = auto.choices_["extend"]
    assert c["figures"]["effect"] == "hysteresis" and c["value"] == c["figures"]["winner"]
    assert c["why"].startswith(f"extended by {c['value']} (hysteresis): held-out free-run RMSE")
    assert "p = " in c["why"] and c["figures"]["p_value"] < 0.05
    assert c["figures"]["heldout_rmse_extended"] < c["figures"]["heldout_rmse"]
    # the extension is the model: its terms, refitted on the whole record
    assert auto.extension_["winner"] == c["value"]
    assert set(auto.model_.term_texts) != set(none.model_.term_texts)
    assert auto.model_.meta["choices"]["extend"]["value"] == c["value"]
    if auto.extension_["theta"] == "freerun":
        assert "refined" in auto.model_.meta and auto.refinement_ is not None
    # out of sample: it validates better than the fit without the stage
    assert _validation_rmse(auto, d) < 0.5 * _validation_rmse(none, d)


def test_extend_none_skips_the_stage(feedback_play):
    d, auto, none = feedback_play
    assert "extend" not in none.choices_ and none.extension_ is None
    # the stage comes last among the structure's choices: the rest is the same fit
    assert auto.search_terms_ == none.search_terms_
    assert auto.choices_["use_phi"] == none.choices_["use_phi"]


def test_memory_free_control_gets_no_memory_extension():
    d = _draw(3)
    assert not d.hysteretic
    est = _fit(d)
    c = est.choices_["extend"]
    assert c["figures"].get("effect") != "hysteresis"
    assert c["why"].startswith(("kept: no extension won", "extended by"))
    assert len(c["figures"]["tried"]) >= 10 and est.extension_["test"]["candidates"]


def test_no_extension_under_the_steady_state_constraints():
    d = _draw(3)
    est = _fit(d, constraints="steady-state")
    c = est.choices_["extend"]
    assert c["value"] == "none" and "steady-state" in c["why"]


def test_a_bad_extend_value_is_named():
    u = np.sin(np.arange(300) / 7.0)
    with pytest.raises(ValueError, match=r"extend must be one of 'auto', 'none', got 'yes'"):
        MGGPRegressor(extend="yes", population=10, generations=1).fit(u, np.roll(u, 1))


def test_the_cli_flag_reaches_the_parameter(capsys, tmp_path):
    from test_cli import one_error_line, run
    p = tmp_path / "d.csv"
    u = np.sin(np.arange(300) / 7.0)
    p.write_text("u,y\n" + "\n".join(f"{a:.9g},{b:.9g}" for a, b in zip(u, np.roll(u, 1))))
    code, _, err = run(capsys, "fit", p, "--population", "10", "--generations", "1",
                       "--extend", "maybe")
    assert code == 2 and "--extend" in one_error_line(err)
    code, out, err = run(capsys, "fit", p, "--population", "10", "--generations", "1",
                         "--seed", "0", "--extend", "none", "--quiet")
    assert code == 0 and "auto: kept" not in err and "auto: extended" not in err
