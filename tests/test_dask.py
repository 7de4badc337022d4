"""The evaluator on a dask.distributed cluster: same seeded result as one process.

A LocalCluster of two worker processes (loopback only, one thread each, no
dashboard) is started once for the module; runs through the Python API and
through ``mggp fit --backend dask --scheduler ADDRESS`` must equal the
single-process run bit for bit, and a user Φ-function registered only in
this process must reach the workers.
"""
import json
import os
import sys

import numpy as np
import pytest

distributed = pytest.importorskip(
    "distributed", reason="dask.distributed is not installed (pip install 'mggp-narx[dask]')")

import narx                                                  # noqa: E402
from mggp import MGGPRegressor                               # noqa: E402
from mggp.cli.app import main                                    # noqa: E402
from mggp.gp.evaluate import Evaluator                          # noqa: E402
from narx.records.data import Data                                   # noqa: E402
from narx.systems import piezo_bouc_wen, training_input     # noqa: E402
from narx.language.terms import parse_terms                           # noqa: E402


@pytest.fixture(scope="module")
def cluster():
    from dask.distributed import LocalCluster
    c = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                     dashboard_address=None, host="127.0.0.1", protocol="tcp")
    try:
        yield c
    finally:
        c.close()


@pytest.fixture(scope="module")
def piezo():
    u = training_input(4000, seed=3, bandwidth=2.0)
    return u, piezo_bouc_wen(u)


def _worker_scorers(address):
    from dask.distributed import Client

    def count():
        from mggp.gp import evaluate
        return sum(len(v) for v in evaluate._IDLE.values())
    with Client(address, set_as_default=False) as c:
        return c.run(count)


def _faults():
    """The helpers of test_faults (the killing plug-in, fit arguments)."""
    here = os.path.dirname(os.path.abspath(__file__))
    if here not in sys.path:
        sys.path.insert(0, here)
    import test_faults
    return test_faults


def _user_phi():
    # defined locally, so it is shipped by value: the workers cannot import it
    def sat(a):
        return np.tanh(np.asarray(a) / 40.0)
    return sat


FIT = dict(fitness="ms", window=50, population=24, generations=3, max_terms=6,
           max_height=3, random_state=11)


def test_dask_fit_equals_single_process(cluster, piezo):
    u, y = piezo
    a = MGGPRegressor(n_jobs=1, backend="sequential", **FIT).fit(u, y)
    b = MGGPRegressor(backend="dask", scheduler=cluster.scheduler_address, **FIT).fit(u, y)
    assert a.model_.term_texts == b.model_.term_texts
    assert np.array_equal(a.model_.theta, b.model_.theta)
    assert [r["best"] for r in a.logbook_] == [r["best"] for r in b.logbook_]
    assert a.n_evaluations_ == b.n_evaluations_
    counts = _worker_scorers(cluster.scheduler_address)
    assert len(counts) == 2 and sum(counts.values()) >= 1, counts


def test_user_phi_registered_in_parent_reaches_workers(cluster, piezo):
    u, y = piezo
    narx.register_phi("SatD", 1, _user_phi(), steady=0.0)
    try:
        reg = narx.language.phi.default_registry()
        data = Data(u, y)
        sets = [parse_terms(["y[k-1]", f"SatD(u[k-{j}])", "Phi1(u[k-1],u[k-2])",
                             f"y[k-1]*SatD(u[k-{j}])"][: 2 + i % 3])
                for i, j in enumerate([1, 2, 3, 1, 2, 3, 1, 2])]
        local = Evaluator(data, "ms", window=50, start=6, backend="sequential")
        want = local(sets)
        local.close()
        from dask.distributed import Client
        with Client(cluster.scheduler_address, set_as_default=False) as client:
            assert not any(client.run(lambda: "SatD" in narx.language.phi.default_registry()).values())
            with Evaluator(data, "ms", window=50, start=6, backend="dask",
                           scheduler=client) as ev:
                got = ev(sets)
        assert got == want and all(np.isfinite(want))
        # and a whole search whose primitive set holds the plug-in
        kw = dict(FIT, random_state=5)
        a = MGGPRegressor(backend="sequential", **kw).fit(u, y)
        b = MGGPRegressor(backend="dask", scheduler=cluster.scheduler_address, **kw).fit(u, y)
        assert "SatD" in reg
        assert a.model_.term_texts == b.model_.term_texts
        assert np.array_equal(a.model_.theta, b.model_.theta)
    finally:
        narx.unregister_phi("SatD")


def test_cli_fit_backend_dask(cluster, piezo, tmp_path, capsys):
    common = _faults().fit_args(tmp_path, *piezo, population=20, generations=2, seed=3,
                                max_terms=5)
    assert main(common + ["--out", str(tmp_path / "a.json"), "--backend",
                          "sequential"]) == 0
    assert main(common + ["--out", str(tmp_path / "b.json"), "--backend", "dask",
                          "--scheduler", cluster.scheduler_address]) == 0
    capsys.readouterr()
    a = json.loads((tmp_path / "a.json").read_text())
    b = json.loads((tmp_path / "b.json").read_text())
    assert a["terms"] == b["terms"] and a["theta"] == b["theta"]


def test_cli_dask_needs_reachable_scheduler(piezo, tmp_path, capsys):
    u, y = piezo
    csv = tmp_path / "d.csv"
    np.savetxt(csv, np.c_[u[:400], y[:400]], delimiter=",", header="u,y", comments="")
    base = ["fit", str(csv), "--population", "4", "--generations", "1", "--quiet"]
    assert main(base + ["--backend", "dask"]) == 2
    assert "--backend dask needs --scheduler" in capsys.readouterr().err
    # a closed port on the loopback: one error line, exit code 2
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    import dask
    with dask.config.set({"distributed.comm.timeouts.connect": "2s"}):
        code = main(base + ["--backend", "dask", "--scheduler", f"tcp://127.0.0.1:{port}"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("error: --scheduler"), err


def test_dask_worker_process_dying_mid_batch(cluster, piezo, tmp_path):
    """A worker that os._exit's while scoring is restarted by its nanny; its
    tasks run again elsewhere and the scores equal the single-process ones."""
    marker = str(tmp_path / "killed")
    reg = _faults().killer_registry(marker)               # os._exit's once, in a worker
    base = ["y[k-1]", "Phi1(u[k-1],u[k-2])", "u[k-1]", "y[k-2]"]
    sets = [parse_terms(base[: 1 + i % 4] + [f"Kab(u[k-{1 + i % 3}])*y[k-1]"],
                        registry=reg) for i in range(12)]
    data = Data(*piezo)
    with Evaluator(data, "ms", window=50, start=6, backend="sequential",
                   registry=reg) as ev:
        want = ev(sets)
    with Evaluator(data, "ms", window=50, start=6, backend="dask",
                   scheduler=cluster.scheduler_address, registry=reg) as ev:
        got = ev(sets)
    assert os.path.exists(marker)
    assert got == want
