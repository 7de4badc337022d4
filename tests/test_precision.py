"""The search's normal-equation fits against the final QR refit (mggp.fit.precision)."""
import subprocess
import sys
import warnings

import numpy as np
import pytest

from mggp import MGGPRegressor
from mggp.fit.precision import SearchPrecisionWarning, offsets, search_precision
from narx import Model
from narx.records.data import as_data
from narx.estimation.fitness import StructureScorer
from conftest import piezo_record
from narx.language.terms import parse_terms

#: a structure a search found on the record below: nearly collinear Φ1 and
#: output lags, whose exact LS θ (QR) has large cancelling coefficients
COLLINEAR = ["Phi1(u[k-1],u[k-6])", "y[k-3]", "u[k-1]", "Phi1(u[k-8],u[k-9])",
             "y[k-2]*Phi2(u[k-4],u[k-1])", "y[k-5]", "y[k-1]", "Phi1(u[k-6],u[k-9])",
             "Phi2(u[k-2],u[k-1])", "Phi1(u[k-2],u[k-3])", "y[k-1]*u[k-1]", "y[k-4]",
             "Phi2(u[k-2],u[k-3])"]


@pytest.fixture(scope="module")
def record():
    return piezo_record(10_000, seed=1)


def test_qr_refit_of_collinear_terms_simulates_worse_than_the_search_fit(record):
    u, y = record
    data = as_data(u, y)
    terms = parse_terms(COLLINEAR, data.signals)
    sc = StructureScorer(data, "ms", window=100, start=16)
    qr = Model(COLLINEAR).fit(u, y)
    check = search_precision(sc, terms, qr.theta)
    assert check.refit_worse and not check.refit_better
    assert check.refit_mse > 100 * check.search_mse
    # control: a well-conditioned structure refits to the same fitness
    good = ["y[k-1]", "Phi1(u[k-1],u[k-2])", "Phi2(u[k-1],u[k-2])*Phi1(u[k-1],u[k-2])"]
    ok = search_precision(sc, parse_terms(good, data.signals), Model(good).fit(u, y).theta)
    assert not ok.refit_worse and not ok.refit_better
    assert ok.refit_mse == pytest.approx(ok.search_mse, rel=1e-3)


def test_estimator_keeps_the_scored_theta_when_the_refit_is_worse(record, monkeypatch):
    """The search is replaced by one that returns COLLINEAR, so the test
    needs no search: model_ must simulate as the search scored it."""
    import mggp.fit.estimator as E
    u, y = record
    real = E.evolve

    def fake(pset, evaluate_batch, **kw):
        import dataclasses
        res = real(pset, evaluate_batch, **kw)
        terms = tuple(parse_terms(COLLINEAR, as_data(u, y).signals))
        fit = evaluate_batch([terms])[0]
        return dataclasses.replace(res, best=dataclasses.replace(res.best, terms=terms,
                                                                 fitness=fit))
    monkeypatch.setattr(E, "evolve", fake)
    est = MGGPRegressor(population=4, generations=0, random_state=0, use_phi=True,
                        screen=None, select="fitness", size="search",
                        local_search=False, extend="none").fit(u, y)
    assert est.model_.term_texts == COLLINEAR
    assert est.model_.meta["estimation"] == "ls-search"
    assert np.isfinite(est.model_.simulate(u, y).mape)
    assert est.precision_.refit_worse
    assert est.model_.meta["qr_refit_fitness_value"] == est.precision_.refit_mse


@pytest.mark.parametrize("shift", [0.0, 3.0])
def test_no_offset_warning_without_a_dominating_offset(record, shift):
    u, y = record
    data = as_data(u + shift * u.std(), y + shift * y.std())
    assert offsets(data) == []


def test_offset_that_dominates_the_output_is_named_before_the_search(record):
    u, y = record
    with pytest.warns(SearchPrecisionWarning, match=r"an offset dominates y \(mean"):
        MGGPRegressor(population=6, generations=1, random_state=0).fit(u, y + 1e3)
    with warnings.catch_warnings():                                  # control
        warnings.simplefilter("error", SearchPrecisionWarning)
        MGGPRegressor(population=6, generations=1, random_state=0).fit(u, y)


def test_a_horizon_that_sees_little_of_the_motion_is_named(record):
    """Δm = 10 samples of a 1 kHz record whose output moves at about 1 Hz:
    the MS fitness is close to the one-step error; Δm = 100 is not named
    (control)."""
    from mggp import SearchPrecisionWarning as SPW
    u, y = record
    with pytest.warns(UserWarning, match=r"window = 10 samples covers little of the output"):
        MGGPRegressor(fitness="ms", window=10, population=6, generations=1,
                      random_state=0).fit(u, y)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        MGGPRegressor(fitness="ms", window=100, population=6, generations=1,
                      random_state=0).fit(u, y)
    assert SPW is SearchPrecisionWarning


def test_a_constrained_search_leaves_model_ls(record):
    """With search_constraints the search scores CLS fits: model_ stays the
    LS fit (its θ is never replaced by a CLS one)."""
    u, y = record
    est = MGGPRegressor(search_constraints="steady-state", population=10, generations=2,
                        random_state=0).fit(u, y)
    assert est.precision_ is None and est.model_.meta["estimation"] == "ls"


def test_on_a_short_record_both_thetas_are_compared_on_the_models_own_rows():
    """60 samples: the search fits every structure from row 16 (the lag its
    trees can reach), the written model starts at its largest lag, 7. The
    search's θ of the chosen structure, kept before because it scored
    better from row 16, had cancelling coefficients that missed rows 7-15
    (free-run RMSE 0.196 against 1e-6 for the QR refit). The model written
    must simulate as well as the QR refit of its terms on its own rows."""
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(2000, seed=1)[:60]
    y = piezo_bouc_wen(training_input(2000, seed=1))[:60]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est = MGGPRegressor(population=40, generations=4, max_terms=10, random_state=1,
                            n_jobs=1).fit(u, y)
    m = est.model_
    qr = Model(m.term_texts).fit(u, y)
    assert m.fit_info_["start"] < 16
    written = m.simulate(u, y, mode="freerun").rmse
    assert written <= 1.25 * qr.simulate(u, y, mode="freerun").rmse, (written, m.equation())


def _bilinear():
    from benchmarks.outliers import bilinear_record
    return bilinear_record(n=1000)


def test_an_output_held_at_its_extreme_is_named_and_a_quantised_one_is_not(tmp_path):
    """A bilinear record clipped at 80 % of its largest value is named with
    the clip, its count and its longest run; the record unclipped and the
    same record quantised to 40 levels (every level repeats, the extremes
    no more than others) are not (controls)."""
    from mggp.fit.precision import saturation, saturation_message
    u, y = _bilinear()
    top = 0.8 * float(np.max(y))
    clipped = np.minimum(y, top)
    held = saturation(clipped)
    assert len(held) == 1 and held[0][:3] == ("largest", top, int(np.sum(y >= top)))
    assert held[0][3] >= 3
    assert saturation(y) == []
    step = float(np.ptp(y)) / 40
    assert saturation(np.round(y / step) * step) == []
    from narx.systems import piezo_bouc_wen, training_input
    uh = training_input(3000, seed=1)
    uh[:1000] = uh[1000]                        # a held input: the output settles, exactly
    yh = piezo_bouc_wen(uh)
    assert saturation(yh) != [] and saturation(yh, [uh]) == []
    msg = saturation_message(as_data(u, clipped))
    assert msg.startswith(f"y sits at its largest value, {top:.6g}, on ")
    path = tmp_path / "clipped.csv"
    np.savetxt(path, np.c_[u, clipped], delimiter=",", header="u,y", comments="")
    p = subprocess.run([sys.executable, "-m", "mggp", "fit", str(path), "--population", "20",
                        "--generations", "2", "--seed", "1"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert sum(ln.startswith("warning: y sits at its largest value") for ln in
               p.stderr.splitlines()) == 1


def test_the_cascaded_tanks_saturation_is_named():
    """The measured cascaded tanks sit at 10 V on 47 of 1,024 training
    samples (the overflow of the benchmark); the quantised buck converter
    (every 0.2 V level repeats) is not named (control)."""
    from benchmarks.real_data import load_record
    from mggp.fit.precision import saturation
    tanks, buck = load_record("cascaded tanks"), load_record("buck converter")
    if tanks is None or buck is None:
        pytest.skip("shared data not found")
    assert [h[:3] for h in saturation(tanks[0].y)] == [("largest", 10.0, 47)]
    assert saturation(buck[0].y) == [] and saturation(buck[1].y) == []
    from benchmarks.panel import RECORDS
    named = {name for name, make in RECORDS.items() for part in (make() or ())
             if saturation(part.y)}
    assert named == {"cascaded tanks"}                          # no other panel record
