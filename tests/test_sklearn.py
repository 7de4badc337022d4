"""MGGPRegressor as a scikit-learn estimator: the estimator checks (those a
time-series model cannot pass are listed, with the reason, by the estimator
itself), cross-validation over time, Pipeline, DataFrame names, the
misspelt keyword, predict from given or rest initial outputs."""
import numpy as np
import pytest

sklearn = pytest.importorskip("sklearn")

from sklearn.base import clone, is_regressor                      # noqa: E402
from sklearn.utils.estimator_checks import parametrize_with_checks  # noqa: E402

from mggp import MGGPRegressor                                     # noqa: E402

#: the budget of the checks: a tiny search of one model class, every
#: stage after it as by default
SMALL = dict(population=6, generations=1, random_state=0, n_jobs=1, use_phi=False,
             constant=False, max_terms=4, max_height=1, max_lag=1)


@parametrize_with_checks([MGGPRegressor(**SMALL)],
                         expected_failed_checks=MGGPRegressor.expected_failed_checks,
                         xfail_strict=True)      # a listed check that passes fails
def test_sklearn_estimator_checks(estimator, check):
    check(estimator)


def test_every_listed_check_is_one_scikit_learn_runs():
    """Each expected failure names a check scikit-learn runs on the
    estimator, and says why in a sentence (no silent skips); that each
    fails is xfail_strict's part above."""
    from sklearn.utils.estimator_checks import _yield_all_checks
    names = set()
    for check in _yield_all_checks(MGGPRegressor(**SMALL), legacy=True):
        names.add(getattr(check, "__name__", getattr(getattr(check, "func", None),
                                                     "__name__", "")))
    listed = MGGPRegressor.expected_failed_checks()
    assert set(listed) <= names, set(listed) - names
    assert all(len(why) > 40 for why in listed.values())


def test_what_the_checks_on_too_few_samples_would_test():
    """The checks listed for fitting too few samples, on enough: predict
    and score leave the estimator as it was; fit adds only attributes that
    end in '_' (or start with it); float32, int and Fortran-ordered inputs
    fit; a wrong number of features and NaN in u are refused."""
    import pickle
    rng = np.random.default_rng(1)
    X = 3 * rng.uniform(size=(60, 3))
    y = X[:, 0].astype(int)
    est = MGGPRegressor(**SMALL)
    before = set(vars(est))
    est.fit(X, y)
    added = set(vars(est)) - before
    assert added and all(a.endswith("_") or a.startswith("_") for a in added)
    state = pickle.dumps(vars(est))
    est.predict(X)
    est.score(X, y)
    assert pickle.dumps(vars(est)) == state
    for Xd in (X.astype(np.float32), X.astype(np.int64), np.asfortranarray(X)):
        assert MGGPRegressor(**SMALL).fit(Xd, y).predict(Xd).shape == (60,)
    with pytest.raises(ValueError, match="X has 2 features, but MGGPRegressor is expecting 3 "
                                         "features as input"):
        est.predict(X[:, :2])
    bad = X.copy()
    bad[5, 1] = np.nan
    with pytest.raises(ValueError, match="non-finite value"):
        est.predict(bad)
    with pytest.raises(ValueError, match="non-finite value"):
        MGGPRegressor(**SMALL).fit(bad, y)


def test_sample_order_matters():
    """What the two invariance checks would find on enough samples: the
    free run of a subset of rows, or of shuffled rows, is not the subset
    or the shuffle of the free run of all rows; control: the same rows in
    the same order give the same prediction."""
    rng = np.random.default_rng(1)
    X = 3 * rng.uniform(size=(60, 3))
    y = np.zeros(60)
    for k in range(1, 60):
        y[k] = 0.5 * y[k - 1] + X[k - 1, 0]
    est = MGGPRegressor(**SMALL).fit(X, y)
    whole = est.predict(X)
    np.testing.assert_array_equal(est.predict(X), whole)                 # control
    assert not np.allclose(est.predict(X[30:])[5:], whole[35:])
    order = rng.permutation(60)
    assert not np.allclose(est.predict(X[order]), whole[order])


def _record(n=600, seed=0):
    """y[k] = 0.6 y[k-1] + 0.5 u[k-1] - 0.2 u[k-2] y[k-1], u white in [-1, 1]."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, n)
    y = np.zeros(n)
    for k in range(2, n):
        y[k] = 0.6 * y[k - 1] + 0.5 * u[k - 1] - 0.2 * u[k - 2] * y[k - 1]
    return u, y


FAST = dict(population=12, generations=2, random_state=0, n_jobs=1, use_phi=False,
            constant=False, max_terms=6)


def test_is_a_regressor_and_clones():
    est = MGGPRegressor(population=40, fitness="pem")
    assert is_regressor(est) and est._estimator_type == "regressor"
    twin = clone(est)
    assert twin.get_params() == est.get_params() and twin is not est


def test_cross_val_score_over_time():
    from sklearn.model_selection import TimeSeriesSplit, cross_val_score
    u, y = _record()
    scores = cross_val_score(MGGPRegressor(**FAST), u, y, cv=TimeSeriesSplit(3))
    assert scores.shape == (3,) and np.all(np.isfinite(scores))
    assert np.all(scores > 0.9), scores           # the structure is easy to find


def test_pipeline_with_a_scaler():
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler
    u, y = _record()
    U = np.c_[u, 10 + 5 * u]                       # two inputs, the second scaled
    pipe = make_pipeline(StandardScaler(), MGGPRegressor(**FAST)).fit(U[:400], y[:400])
    assert pipe.predict(U[400:]).shape == (200,)
    assert pipe.score(U[400:], y[400:]) > 0.9
    assert pipe[-1].n_features_in_ == 2


def test_dataframe_columns_name_the_inputs():
    pd = pytest.importorskip("pandas")
    u, y = _record()
    df = pd.DataFrame({"volts": u, "y": y})
    est = MGGPRegressor(**FAST).fit(df[["volts"]], df["y"])
    assert list(est.feature_names_in_) == ["volts"] and est.n_features_in_ == 1
    assert est.model_.inputs == ("volts",) or list(est.model_.inputs) == ["volts"]
    assert any("volts[k-" in t for t in est.model_.term_texts)
    with pytest.warns(UserWarning, match="does not have valid feature names"):
        np.testing.assert_array_equal(est.predict(df[["volts"]]),
                                      est.predict(df[["volts"]].values))
    with pytest.raises(ValueError, match="feature names should match"):
        est.predict(pd.DataFrame({"amps": u}))
    with pytest.warns(UserWarning, match="does not have valid feature names"):
        est.predict(u)
        with pytest.raises(ValueError, match="X has 2 features, but MGGPRegressor is "
                                             "expecting 1"):
            est.predict(np.c_[u, u])
    # control: an array fit has no names, and the default input name
    plain = MGGPRegressor(**FAST).fit(u, y)
    assert not hasattr(plain, "feature_names_in_")
    assert any("u[k-" in t for t in plain.model_.term_texts)


def test_dataframe_columns_must_agree_with_inputs():
    pd = pytest.importorskip("pandas")
    u, y = _record()
    with pytest.raises(ValueError, match=r"inputs=\['u'\] differ from the columns"):
        MGGPRegressor(inputs=["u"], **FAST).fit(pd.DataFrame({"volts": u}), y)


def test_misspelt_keyword_names_the_closest_parameter():
    with pytest.raises(TypeError, match="'populaton': did you mean 'population'"):
        MGGPRegressor(populaton=40)
    with pytest.raises(ValueError, match="'generatons': did you mean 'generations'"):
        MGGPRegressor().set_params(generatons=3)
    with pytest.raises(TypeError, match="'zzz'"):          # nothing close: the list
        MGGPRegressor(zzz=1)
    assert MGGPRegressor(population=40).population == 40   # control


def test_predict_free_run_from_rest_or_from_y0():
    """predict(u) starts at rest (initial outputs 0); predict(u, y0) from
    y0, the same free run as from the measured output; other initial
    outputs give another free run (control)."""
    u, y = _record()
    y = y.copy()
    est = MGGPRegressor(extend="none", **FAST).fit(u, y)   # the control's threshold: its model
    lag = est.get_best().max_lag
    rest = est.predict(u)
    assert np.all(rest[:lag] == 0)
    given = est.predict(u, y0=y[:lag])
    np.testing.assert_array_equal(given[:lag], y[:lag])
    # the same free run as passing the measured output (the former way)
    np.testing.assert_allclose(given, est.predict(u, y=y))
    np.testing.assert_allclose(given, est.simulate(u, y).y_hat)
    # y0 matters (control): other initial outputs, another free run at first
    other = est.predict(u, y0=np.full(lag, 2.0))
    assert abs(other[lag] - given[lag]) > 0.1
    # the other modes take the measured output as before (positional or y=)
    osa = est.predict(u, y, mode="osa")
    np.testing.assert_allclose(osa, est.predict(u, y=y, mode="osa"))
    assert not np.allclose(osa[lag:], given[lag:])
    with pytest.raises(ValueError, match="not both"):
        est.predict(u, y[:lag], y=y)


def test_score_is_the_free_run_r2():
    u, y = _record()
    est = MGGPRegressor(**FAST).fit(u[:400], y[:400])
    sim = est.simulate(u[400:], y[400:])
    yv, yh = sim.y[sim.valid], sim.y_hat[sim.valid]
    r2 = 1 - np.sum((yv - yh) ** 2) / np.sum((yv - yv.mean()) ** 2)
    assert est.score(u[400:], y[400:]) == pytest.approx(r2)
    # mode='osa': the same formula over the one-step predictions
    one = est.simulate(u[400:], y[400:], mode="osa")
    yv1, yh1 = one.y[one.valid], one.y_hat[one.valid]
    assert est.score(u[400:], y[400:], mode="osa") == pytest.approx(
        1 - np.sum((yv1 - yh1) ** 2) / np.sum((yv1 - yv1.mean()) ** 2))
    # control: a worse prediction (the mean) scores 0 by the same formula
    from narx.simulation.metrics import r2 as r2_of
    assert r2_of(yv, np.full_like(yv, yv.mean())) == pytest.approx(0.0, abs=1e-12)


def test_unfitted_estimator_says_so():
    from mggp import NotFittedError
    u, y = _record(100)
    with pytest.raises(NotFittedError, match="not fitted yet"):
        MGGPRegressor().predict(u)


def test_scikit_learn_stays_optional():
    """Without scikit-learn (its import blocked in a fresh interpreter)
    fit, predict and score work and the not-fitted error is mggp's;
    control: the same run here imports it for the tags."""
    import subprocess
    import sys
    code = ("import sys; sys.modules['sklearn'] = None\n"
            "import numpy as np\n"
            "from mggp import MGGPRegressor, NotFittedError\n"
            "rng = np.random.default_rng(0); u = rng.uniform(-1, 1, 200)\n"
            "y = np.r_[0, 0.5 * u[:-1]]\n"
            "try:\n    MGGPRegressor().predict(u)\n"
            "except NotFittedError as e:\n    print(type(e) is NotFittedError)\n"
            "est = MGGPRegressor(population=4, generations=0, use_phi=False, constant=False,"
            " max_height=1, fitness='pem', random_state=0).fit(u, y)\n"
            "print(est.predict(u).shape, round(est.score(u, y), 3))\n"
            "try:\n    est.__sklearn_tags__()\nexcept ImportError:\n    print('no tags')\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines() == ["True", "(200,) 1.0", "no tags"], out.stdout
    assert MGGPRegressor().__sklearn_tags__().estimator_type == "regressor"   # control
