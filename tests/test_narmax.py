"""NARMAX noise terms selected after a search (``noise_lags``)."""
import numpy as np
import pytest

from mggp import MGGPRegressor
from narx.systems.testsystems import system_by_name

SETTINGS = dict(fitness="pem", criterion="bic", population=200, generations=40,
                max_terms=8, max_height=3, use_phi=False, prune="t", max_lag=4,
                max_degree=3, random_state=0, screen=None, select="fitness", size="search")


def split(terms):
    return (sorted(t for t in terms if "e[" not in t), sorted(t for t in terms if "e[" in t))


def test_s5_gets_its_process_terms_and_the_ma_term():
    d = system_by_name("S5", n=500, seed=0)
    est = MGGPRegressor(noise_lags=2, **SETTINGS).fit(d.u, d.y)
    process, noise = split(est.model_.term_texts)
    assert process == sorted(t for t in d.terms if "e[" not in t)
    assert "e[k-1]" in noise


def test_white_noise_gets_no_noise_term():
    d = system_by_name("S4", n=500, seed=0)                       # control
    est = MGGPRegressor(noise_lags=2, **SETTINGS).fit(d.u, d.y)
    assert split(est.model_.term_texts)[1] == []


def _coloured(seed, n=1100, sd=0.15):
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, n)
    e = rng.normal(0, sd, n)
    y = np.zeros(n)
    for k in range(2, n):
        y[k] = 0.8 * y[k - 1] + 0.5 * u[k - 1] - 0.3 * y[k - 1] * u[k - 1] + e[k] + 0.7 * e[k - 1]
    return u[100:], y[100:]


def test_coloured_noise_proxies_are_pruned_once_the_noise_model_is_in():
    # a one-step search under MA noise adds lags that only predict the noise;
    # with the MA(2) model in the fit their t-statistics fall and they go
    u, y = _coloured(1)
    uv, yv = _coloured(99, sd=0.0)
    plain = MGGPRegressor(noise_lags=0, **SETTINGS).fit(u, y)
    narmax = MGGPRegressor(noise_lags=2, **SETTINGS).fit(u, y)
    process, noise = split(narmax.model_.term_texts)
    assert process == sorted(["y[k-1]", "u[k-1]", "y[k-1]*u[k-1]"]) and noise == ["e[k-1]"]
    assert len(split(plain.model_.term_texts)[0]) > 3               # the proxies
    mse = [m.model_.simulate(uv, yv, mode="freerun").mse for m in (plain, narmax)]
    assert mse[1] < mse[0] / 3


def test_cli_noise_lags_selects_the_ma_terms(tmp_path, capsys):
    """`mggp fit --noise-lags Q` reaches the NARMAX selection; without it no
    noise term appears (control)."""
    import json
    from mggp.cli.app import main
    d = system_by_name("S5", n=500, seed=1)
    csv = tmp_path / "s5.csv"
    np.savetxt(csv, np.c_[d.u.ravel(), d.y], delimiter=",", header="u,y", comments="")
    base = ["fit", str(csv), "--no-phi", "--max-lag", "2", "--max-degree", "3",
            "--population", "200", "--generations", "20", "--seed", "1", "--fitness", "pem",
            "--criterion", "bic", "--prune", "t", "--quiet"]
    terms = {}
    for q in ("0", "2"):
        out = tmp_path / f"m{q}.json"
        assert main(base + ["--noise-lags", q, "--out", str(out)]) == 0
        terms[q] = json.loads(out.read_text())["terms"]
    capsys.readouterr()
    assert not [t for t in terms["0"] if "e[" in t]
    process, noise = split(terms["2"])
    assert process == sorted(t for t in d.terms if "e[" not in t)
    assert noise == sorted(t for t in d.terms if "e[" in t)
    assert main(base + ["--noise-lags", "-1"]) == 2
    assert "--noise-lags must be >= 0, got -1" in capsys.readouterr().err
