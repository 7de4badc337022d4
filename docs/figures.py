"""The figures of the documentation site, written to docs/figures/.

Command (from the project folder; about 3 CPU minutes)::

    python docs/figures.py            # every figure
    python docs/figures.py piezo      # one group: piezo, diagnose, quasistatic, compensate

Every figure comes from a small budget on simulated records (seeds fixed),
so the script reruns in minutes; the published budgets and their figures are
in benchmarks/RESULTS.md. Each PNG is kept under 200 kB (the script's own
figures at dpi 80; the report figures it copies halved if larger); the
captions, with units, are in the pages that show them
(tests/test_docs.py checks both).
"""
from __future__ import annotations

import os
import shutil
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
OUT = os.path.join(HERE, "figures")
DPI = 80


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _save(fig, name):
    path = os.path.join(OUT, name)
    fig.savefig(path, dpi=DPI)
    _plt().close(fig)
    print(f"{path}: {os.path.getsize(path) / 1024:.0f} kB")


def piezo():
    """PEM and MS models of the simulated piezo actuator (small budget):
    free run on the validation sine, and the input-output loop."""
    from mggp import MGGPRegressor
    from narx.systems import piezo_bouc_wen, sine_input, training_input
    plt = _plt()
    u = training_input(5_000, seed=1)
    y = piezo_bouc_wen(u)
    t, uv = sine_input()
    yv = piezo_bouc_wen(uv)
    runs = {}
    for fitness, kw in (("pem", {}), ("ms", {"window": 1000})):
        est = MGGPRegressor(fitness=fitness, population=40, generations=8,
                            constraints="steady-state", screen="freerun", random_state=1,
                            n_jobs=1, **kw).fit(u, y)
        runs[fitness.upper()] = est.simulate(uv, yv, mode="freerun")
    fig, (a, b) = plt.subplots(2, 1, figsize=(8, 5), sharex=True,
                               gridspec_kw={"height_ratios": [2, 1]})
    a.plot(t, yv, color="0.3", lw=2.2, label="data")
    for (name, r), col in zip(runs.items(), ("tab:red", "tab:blue")):
        a.plot(t, r.y_hat, color=col, lw=1, label=f"{name} model, MAPE {r.mape:.2f} %")
        b.plot(t, yv - r.y_hat, color=col, lw=1, label=name)
    a.set_ylabel("displacement y (µm)")
    a.legend(loc="upper right", fontsize=8)
    a.set_title("Free run on the validation sine (1 Hz, 40 V)")
    b.set_ylabel("error y − ŷ (µm)")
    b.set_xlabel("time (s)")
    b.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    _save(fig, "piezo_freerun.png")
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(uv, yv, color="0.3", lw=2.2, label="data")
    for (name, r), col in zip(runs.items(), ("tab:red", "tab:blue")):
        ax.plot(uv, r.y_hat, color=col, lw=1, label=f"{name} model")
    ax.set_xlabel("input voltage u (V)")
    ax.set_ylabel("displacement y (µm)")
    ax.set_title("Hysteresis loop on the validation sine")
    ax.legend(fontsize=8)
    fig.tight_layout()
    _save(fig, "piezo_loop.png")


def diagnose():
    """``mggp diagnose`` of a piezo record (small budget): the report's
    residual-direction and model figures."""
    from mggp.diagnose import Budget, diagnose as run
    from mggp.diagnose.report import write_report
    from narx.records.data import Data
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(4000, bandwidth=4.0, seed=3)
    dx = run(Data(u, piezo_bouc_wen(u)), budget=Budget(population=60, generations=10),
             seed=0, jobs=1)
    print(dx.summary())
    with tempfile.TemporaryDirectory() as tmp:
        write_report(tmp, dx)
        for src, dst in (("residual_direction.png", "diagnose_residual.png"),
                         ("models.png", "diagnose_models.png")):
            _shrink(os.path.join(tmp, src), os.path.join(OUT, dst))


def _shrink(src, dst):
    """Copy a report's PNG, halved in each direction if over 200 kB."""
    shutil.copyfile(src, dst)
    if os.path.getsize(dst) > 200_000:        # too large: every other pixel
        plt = _plt()
        plt.imsave(dst, plt.imread(src)[::2, ::2])
    print(f"{dst}: {os.path.getsize(dst) / 1024:.0f} kB")


def quasistatic():
    """The quasi-static figure of model (16), y_k = 0.9 y_{k-1} + 0.5 Φ2."""
    import narx
    from mggp.report.quasistatic import plot_quasistatic
    m = narx.Model(["y[k-1]", "Phi2(u[k-1],u[k-2])"], [0.9, 0.5])
    k = np.arange(400)
    u = np.sin(2 * np.pi * 0.1 * k * 0.05)     # 1 V, 0.1 Hz, sampled at 20 Hz: 2 periods
    qs = narx.quasistatic(m, u)
    with tempfile.TemporaryDirectory() as tmp:
        path = plot_quasistatic(os.path.join(tmp, "qs.png"), qs,
                                title="Quasi-static analysis of model (16)",
                                xlabel="input u (V)", ylabel="output y (model units)")
        _shrink(path, os.path.join(OUT, "quasistatic_model16.png"))


def compensate():
    """The published model (19) inverted step by step on a smooth reference."""
    from benchmarks.casestudy import model19
    from narx.analysis.compensate import compensate as invert
    from narx.systems import piezo_bouc_wen, sine_input
    plt = _plt()
    m = model19()
    t, uv = sine_input()
    r = piezo_bouc_wen(uv)                     # a reachable reference (µm)
    res = invert(m, r)
    u_c = res.m
    y_c = piezo_bouc_wen(np.asarray(u_c, float))
    y_n = piezo_bouc_wen(r / 1.6)              # no compensator: the static gain only
    fig, (a, b) = plt.subplots(2, 1, figsize=(8, 5), sharex=True,
                               gridspec_kw={"height_ratios": [2, 1]})
    a.plot(t, r, color="0.3", lw=2.2, label="reference r")
    a.plot(t, y_n, color="tab:red", lw=1, label="static gain only, u = r / 1.6 µm/V")
    a.plot(t, y_c, color="tab:blue", lw=1, label="compensator from model (19)")
    a.set_ylabel("displacement (µm)")
    a.legend(fontsize=8, loc="upper right")
    a.set_title("Tracking a smooth reference on the simulated piezo actuator")
    b.plot(t, r - y_n, color="tab:red", lw=1)
    b.plot(t, r - y_c, color="tab:blue", lw=1)
    b.set_ylabel("error r − y (µm)")
    b.set_xlabel("time (s)")
    fig.tight_layout()
    _save(fig, "compensate_tracking.png")


GROUPS = {"piezo": piezo, "diagnose": diagnose, "quasistatic": quasistatic,
          "compensate": compensate}

if __name__ == "__main__":
    os.makedirs(OUT, exist_ok=True)
    for name in sys.argv[1:] or list(GROUPS):
        GROUPS[name]()
