"""MGGP estimator: structure recovery, determinism over workers, resume, CLI fit."""
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from mggp import MGGPRegressor
from narx.systems.testsystems import SYSTEMS, system_by_name


def recover(name, seed, data_seed=0, **kw):
    d = system_by_name(name, n=500, seed=data_seed)
    params = dict(fitness="pem", criterion="bic", population=200, generations=40,
                  max_terms=8, max_height=3, use_phi=False, prune="t",
                  max_lag=4, max_degree=3, constant=False, random_state=seed)
    params.update(kw)
    est = MGGPRegressor(**params).fit(d.u, d.y)
    true = sorted(t for t in d.terms if "e[" not in t)
    return sorted(est.model_.term_texts), true, est


def test_structure_recovery_fast_case():
    found, true, est = recover("S4", seed=0)
    assert found == true
    assert est.pareto_front_ and est.logbook_[-1]["gen"] == 40


def test_recovery_control_wrong_with_tiny_budget():
    # the search is what finds the structure: one generation of a tiny
    # population does not (guards against a test that cannot fail)
    found, true, _ = recover("S3", seed=0, population=4, generations=0)
    assert found != true


def test_recovery_benchmark_default_takes_no_settings(capsys):
    """benchmarks.recovery --default runs MGGPRegressor's own defaults, so a
    protocol setting given with it is refused (command line and function)."""
    from benchmarks import recovery
    with pytest.raises(SystemExit) as e:
        recovery.main(["--default", "--fitness", "freerun"])
    assert e.value.code == 2 and "--default takes every setting" in capsys.readouterr().err
    with pytest.raises(ValueError, match="default=True takes no settings"):
        recovery.run("S1", 0, 0, default=True, fitness="freerun")


@pytest.mark.slow
@pytest.mark.parametrize("name", SYSTEMS)
def test_structure_recovery_nine_of_ten_seeds(name):
    hits = sum(found == true for found, true, _ in (recover(name, s) for s in range(10)))
    assert hits >= 9, f"{name}: exact structure in {hits}/10 seeds"


def _piezo(n=6000, seed=4):
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(n, seed=seed, bandwidth=2.0)
    return u, piezo_bouc_wen(u)


def test_same_seed_same_model_for_one_and_two_workers():
    u, y = _piezo()
    kw = dict(fitness="ms", window=50, population=40, generations=5, random_state=7,
              max_terms=8)
    a = MGGPRegressor(n_jobs=1, **kw).fit(u, y)
    b = MGGPRegressor(n_jobs=2, **kw).fit(u, y)
    assert a.model_.term_texts == b.model_.term_texts
    assert np.array_equal(a.model_.theta, b.model_.theta)
    assert [r["best"] for r in a.logbook_] == [r["best"] for r in b.logbook_]
    c = MGGPRegressor(n_jobs=1, **dict(kw, random_state=8)).fit(u, y)
    assert [r["best"] for r in c.logbook_] != [r["best"] for r in a.logbook_]


@pytest.mark.filterwarnings("ignore::mggp.fit.selection.CLSRejectedWarning")
def test_cls_refit_satisfies_steady_state_constraints():
    u, y = _piezo()
    est = MGGPRegressor(fitness="ms", window=50, population=40, generations=4,
                        random_state=3, constraints="steady-state", max_terms=8).fit(u, y)
    if est.model_cls_ is None:
        pytest.skip("structure without an output term: " + est.cls_error_)
    cons = est.model_cls_.steady_state_constraints()
    assert np.max(np.abs(cons.residual(est.model_cls_.theta))) < 1e-10
    assert est.get_best(constrained=True) is est.model_cls_
    # by default the CLS refit unless it was rejected (over 2x worse in free run)
    assert est.get_best() is (est.model_ if est.cls_rejected_ else est.model_cls_)


def _fit_cmd(csv, out, ckpt, gens):
    return [sys.executable, "-m", "mggp", "fit", str(csv), "--fitness", "ms", "--window",
            "50", "--population", "60", "--generations", str(gens), "--seed", "5",
            "--max-terms", "8", "--out", str(out), "--checkpoint", str(ckpt), "--quiet"]


def test_resume_after_kill_equals_uninterrupted(tmp_path):
    u, y = _piezo(n=20000)
    csv = tmp_path / "d.csv"
    np.savetxt(csv, np.c_[u, y], delimiter=",", header="u,y", comments="")
    full = tmp_path / "full.json"
    r = subprocess.run(_fit_cmd(csv, full, tmp_path / "a.ckpt", 12), capture_output=True,
                       text=True)
    assert r.returncode == 0, r.stderr
    ck = tmp_path / "b.ckpt"
    p = subprocess.Popen(_fit_cmd(csv, tmp_path / "x.json", ck, 12),
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    gen = -1
    while time.time() < deadline and p.poll() is None:
        if ck.exists():
            try:
                gen = json.loads(ck.read_text())["generation"]
            except (ValueError, KeyError):
                gen = -1
            if gen >= 3:
                break
        time.sleep(0.02)
    if p.poll() is not None:
        pytest.skip("the run finished before it could be killed")
    os.kill(p.pid, signal.SIGKILL)
    p.wait()
    assert not (tmp_path / "x.json").exists()
    resumed = tmp_path / "resumed.json"
    r = subprocess.run(_fit_cmd(csv, resumed, ck, 12) + ["--resume"], capture_output=True,
                       text=True)
    assert r.returncode == 0, r.stderr
    a, b = json.loads(full.read_text()), json.loads(resumed.read_text())
    assert a["terms"] == b["terms"] and a["theta"] == b["theta"]


def test_fit_cli_bad_arguments(tmp_path, capsys):
    from mggp.cli.app import main
    csv = tmp_path / "d.csv"
    csv.write_text("u,y\n" + "\n".join(f"{i % 7},{i % 5}" for i in range(300)))
    assert main(["fit", str(csv), "--population", "0"]) == 2
    assert "--population must be >= 2, got 0" in capsys.readouterr().err
    assert main(["fit", str(csv), "--resume"]) == 2
    assert "--resume needs --checkpoint" in capsys.readouterr().err
    const = tmp_path / "c.csv"
    const.write_text("u,y\n" + "\n".join(f"1.0,{i}" for i in range(300)))
    assert main(["fit", str(const), "--generations", "1", "--population", "4"]) == 2
    assert "input 'u' is constant" in capsys.readouterr().err


def test_select_freerun_picks_the_best_whole_record_simulation():
    u, y = _piezo()
    kw = dict(fitness="ms", window=50, population=40, generations=4, random_state=2,
              max_terms=8, local_search=False, constant=False,
              size="search", operator_params="none",
              extend="none")                             # the selection as it chose
    a = MGGPRegressor(select="freerun", select_candidates=10, **kw).fit(u, y)
    ranked = a.selection_
    assert ranked and all(m1 <= m2 for (m1, _), (m2, _) in zip(ranked, ranked[1:]))
    assert sorted(a.model_.term_texts) == sorted(ranked[0][1])
    fr = a.model_.simulate(u, y, mode="freerun")
    assert not fr.diverged
    b = MGGPRegressor(select="fitness", **kw).fit(u, y)
    # the chosen structure is never worse in free run than the best-fitness one
    fb = b.model_.simulate(u, y, mode="freerun")
    assert fr.mse <= fb.mse * (1 + 1e-9) or fb.diverged
    with pytest.raises(ValueError,
                       match="select must be one of 'auto', 'fitness', 'freerun', 'hold', got 'best'"):
        MGGPRegressor(select="best", **kw).fit(u, y)


def _two_input_fit(scale=1.0):
    """A search on y = piezo(u1 + 20 u2), u1 of amplitude 80 and u2 of 1 (other
    units), u2 multiplied by ``scale``."""
    from narx.systems import piezo_bouc_wen, training_input
    u1 = training_input(2000, seed=1, bandwidth=2.0)
    u2 = training_input(2000, seed=2, bandwidth=2.0, amplitude=1.0)
    y = piezo_bouc_wen(u1 + 20 * u2)
    est = MGGPRegressor(fitness="ms", window=50, population=40, generations=4,
                        random_state=5, max_terms=8, n_jobs=1, inputs=["u1", "u2"],
                        use_phi=True)
    return est.fit(np.c_[u1, scale * u2], y)


def _phi_input_sets(terms):
    from narx.language.terms import PhiCall
    return [{a.signal for a in f.args} for t in terms for f in t.factors
            if isinstance(f, PhiCall)]


def test_two_input_search_never_mixes_inputs_in_phi():
    from mggp.gp.primitives import Decoder
    est = _two_input_fit()
    dec = Decoder(est.model_.signals)
    searched = [t for ind in est.result_.population for t in dec.decode_individual(ind)]
    searched += [t for r in est.result_.pareto for t in r.terms]
    sets = _phi_input_sets(searched) + _phi_input_sets(est.model_.terms)
    assert sets and all(len(s) == 1 for s in sets), "a Φ-term mixes u1 and u2"
    assert set().union(*sets) == {"u1", "u2"}


def test_two_input_search_does_not_depend_on_the_unit_of_u2():
    a, b = _two_input_fit(), _two_input_fit(scale=1e3)
    assert a.model_.term_texts == b.model_.term_texts
    assert a.n_evaluations_ == b.n_evaluations_
    assert [r["best"] for r in a.logbook_] == pytest.approx([r["best"] for r in b.logbook_],
                                                            rel=1e-6)


def test_phi_outputs_recovers_a_term_of_the_output_direction():
    """y = 0.6 y₋₁ + 0.5 u₋₁ + 0.2 sign(y₋₁ − y₋₂) + e: with phi_outputs the
    exact structure is found (Phi2 of the two output lags, either order: the
    same column up to sign); the default's class pilots take the class with
    Φ of the output lags here; a search with Φ of the inputs only cannot
    build it (control)."""
    rng = np.random.default_rng(0)
    u = rng.uniform(-1, 1, 600)
    e = 0.01 * rng.standard_normal(600)
    y = np.zeros(600)
    for k in range(2, 600):
        y[k] = 0.6 * y[k - 1] + 0.5 * u[k - 1] + 0.2 * np.sign(y[k - 1] - y[k - 2]) + e[k]
    kw = dict(fitness="pem", criterion="bic", population=200, generations=40, max_terms=6,
              max_height=3, prune="t", max_lag=4, max_degree=3, random_state=1)
    found = sorted(MGGPRegressor(phi_outputs=True, **kw).fit(u, y).model_.term_texts)
    assert found in (sorted(["y[k-1]", "u[k-1]", "Phi2(y[k-1],y[k-2])"]),
                     sorted(["y[k-1]", "u[k-1]", "Phi2(y[k-2],y[k-1])"]))
    # the searches alone (no extension: the extend stage's catalogue holds Φ of
    # the output lags, so a fit may add them after any search)
    auto = MGGPRegressor(extend="none", **kw).fit(u, y)
    assert auto.choices_["use_phi"]["figures"]["class"] == "Φ of outputs"
    assert any("Phi2(y" in t for t in auto.model_.term_texts)
    plain = MGGPRegressor(extend="none", use_phi=True, **kw).fit(u, y).model_.term_texts
    assert not any("Phi1(y" in t or "Phi2(y" in t for t in plain)


def _structures(est):
    """Every structure the fit scored, printed or chose: the final
    population and the archive as scored, the logbook's best, the Pareto
    front, the model."""
    from mggp.gp.primitives import Decoder
    dec = Decoder(est.model_.signals)
    res = est.result_
    sizes = [len(est._structure(dec.decode_individual(i))) for i in res.population]
    sizes += [len(est._structure(r.terms)) for r in res.pareto]
    sizes += [r["best_terms"] for r in est.logbook_]
    sizes += [len(r["terms"]) for r in est.pareto_front_]
    return sizes + [est.model_.n_terms]


def test_max_terms_counts_the_constant_term():
    """With the constant term in every structure, the search's individuals
    hold at most max_terms - 1 genes, so no structure scored, printed or
    chosen has more than max_terms terms (it had max_terms + 1: the
    constant beside max_terms genes); the bound is reached. Control: without
    the constant the individuals hold max_terms genes."""
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(800, seed=1, bandwidth=2.0)
    y = piezo_bouc_wen(u) + 5.0
    kw = dict(population=30, generations=3, max_terms=4, random_state=0, use_phi=False,
              operators="none", n_jobs=1)
    with_constant = MGGPRegressor(constant=True, **kw).fit(u, y)
    sizes = _structures(with_constant)
    assert max(sizes) == 4, sizes
    assert "1" in with_constant.model_.term_texts
    assert max(len(i) for i in with_constant.result_.population) == 3
    plain = MGGPRegressor(constant=False, **kw).fit(u, y)
    assert max(_structures(plain)) == 4
    assert max(len(i) for i in plain.result_.population) == 4        # control
    with pytest.raises(ValueError, match="constant=True needs max_terms >= 2"):
        MGGPRegressor(constant=True, **dict(kw, max_terms=1)).fit(u, y)


def test_max_terms_counts_the_noise_terms():
    """Moving-average noise terms fill only the room max_terms leaves: with
    max_terms=2 and a two-term process none is added; control: with room
    for them the coloured noise gets its term."""
    rng = np.random.default_rng(0)
    n = 800
    u, e = rng.uniform(-1, 1, n), 0.3 * rng.standard_normal(n)
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.5 * y[k - 1] + u[k - 1] + e[k] + 0.8 * e[k - 1]
    kw = dict(population=20, generations=2, random_state=0, constant=False, use_phi=False,
              fitness="pem", noise_lags=2, max_height=2)
    tight = MGGPRegressor(max_terms=2, **kw).fit(u, y).model_
    assert sorted(tight.term_texts) == ["u[k-1]", "y[k-1]"]
    roomy = MGGPRegressor(max_terms=6, **kw).fit(u, y).model_
    assert any(t.startswith("e[k-") for t in roomy.term_texts) and roomy.n_terms <= 6
