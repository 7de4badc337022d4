"""Automatic choices of MGGPRegressor (mggp.choices): Φ by held-out free-run
error, the selection by the constraints; recorded in choices_ and meta."""
import numpy as np
import pytest

from mggp import MGGPRegressor
from mggp.choices import PHI_GAIN, heldout_rmse, phi_choice
from narx.data import Data
from narx.testsystems import system_by_name

_KW = dict(fitness="pem", population=16, generations=2, max_height=2, max_terms=5,
           random_state=1)


def test_phi_kept_only_for_a_clear_gain():
    assert phi_choice(1.0, 0.5).value is True
    assert phi_choice(1.0, 1.0 - PHI_GAIN / 2).value is False     # within the margin
    assert phi_choice(0.5, 1.0).value is False
    assert phi_choice(float("inf"), 3.0).value is True            # plain diverges
    c = phi_choice(0.41, 0.58)
    assert c.why.startswith("no Φ: held-out free-run RMSE 0.41 against 0.58 with Φ")
    assert c.figures["heldout_rmse_phi"] == 0.58


def test_a_search_that_holds_wins_whatever_its_error():
    assert phi_choice(0.1, 1.0, holds_plain=False, holds_phi=True).value is True
    assert phi_choice(1.0, 0.1, holds_plain=True, holds_phi=False).value is False
    # control: both hold, the error decides
    assert phi_choice(1.0, 0.1, holds_plain=True, holds_phi=True).value is True


def test_heldout_rmse_is_measured_on_the_tail_only():
    d = system_by_name("S1", n=500, seed=0)
    data = Data(d.u, d.y)
    true = heldout_rmse(["y[k-1]", "y[k-2]", "u[k-1]", "u[k-2]"], data)
    wrong = heldout_rmse(["u[k-1]"], data)
    assert np.isfinite(true) and true < wrong


def test_defaults_choose_and_record_with_figures():
    d = system_by_name("S1", n=500, seed=0)
    est = MGGPRegressor(**_KW).fit(d.u, d.y)
    phi = est.choices_["use_phi"]
    assert isinstance(phi["value"], bool) and "held-out free-run RMSE" in phi["why"]
    assert {"heldout_rmse_phi", "heldout_rmse_no_phi"} <= set(phi["figures"])
    assert est.choices_["select"]["value"] == "fitness"
    meta = est.model_.meta
    assert meta["use_phi"] is phi["value"] and meta["select"] == "fitness"
    assert meta["choices"]["use_phi"]["why"] == phi["why"]


def test_explicit_values_disable_the_choices():
    d = system_by_name("S1", n=500, seed=0)
    est = MGGPRegressor(use_phi=False, select="fitness", screen="freerun", size="search",
                        **_KW).fit(d.u, d.y)
    assert est.choices_ == {} and "choices" not in est.model_.meta


def test_constraints_resolve_select_to_hold():
    d = system_by_name("S1", n=500, seed=0)
    est = MGGPRegressor(use_phi=False, constraints="steady-state", **_KW).fit(d.u, d.y)
    assert est.choices_["select"]["value"] == "hold"
    assert est.choices_["select"]["figures"]["candidates"] >= 1


@pytest.mark.parametrize("argv", [["--phi", "--no-phi"]])
def test_cli_phi_and_no_phi_exclude_each_other(tmp_path, capsys, argv):
    from mggp.cli import main
    d = system_by_name("S1", n=200, seed=0)
    path = tmp_path / "d.csv"
    np.savetxt(path, np.column_stack([d.u, d.y]), delimiter=",", header="u,y", comments="")
    assert main(["fit", str(path)] + argv) == 2
    assert "--phi and --no-phi" in capsys.readouterr().err


def test_cli_prints_each_automatic_choice(tmp_path, capsys):
    from mggp.cli import main
    d = system_by_name("S1", n=300, seed=0)
    path = tmp_path / "d.csv"
    np.savetxt(path, np.column_stack([d.u, d.y]), delimiter=",", header="u,y", comments="")
    assert main(["fit", str(path), "--population", "16", "--generations", "2",
                 "--max-height", "2", "--seed", "1", "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "auto: " in err and "held-out free-run RMSE" in err and "auto: select" in err


def test_screen_follows_the_constraints():
    d = system_by_name("S1", n=500, seed=0)
    plain = MGGPRegressor(use_phi=False, **_KW).fit(d.u, d.y)
    held = MGGPRegressor(use_phi=False, constraints="steady-state", **_KW).fit(d.u, d.y)
    assert plain.choices_["screen"]["value"] == "freerun"
    assert held.choices_["screen"]["value"] == "hold" and held.model_.meta["screen"] == "hold"


def test_size_takes_the_fewest_terms_within_the_tolerance():
    from mggp.choices import SIZE_TOLERANCE, size_choice
    big, small, tiny = ("a", "b", "c"), ("a", "b"), ("a",)
    within = 1.0 * (1 + SIZE_TOLERANCE / 2)
    c = size_choice([(3, 1.0, big), (2, within, small), (1, 2.0, tiny)])
    assert c.value == small and c.figures["terms"] == 2
    # control: the smaller one is clearly worse, the chosen structure stays
    assert size_choice([(3, 1.0, big), (2, 1.5, small)]).value == big
