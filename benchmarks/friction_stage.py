"""A friction-dominated positioning stage: the default fit against its true structure.

Typical call::

    python -m benchmarks.friction_stage --seeds 1 2 3 --jobs 2      # default budget
    python -m benchmarks.friction_stage --seeds 1 --population 40 --generations 8

The stage (:func:`stage`) is a mass with viscous and Coulomb friction,

.. math:: m \\ddot q = F - c \\dot q - F_c \\operatorname{sign}(\\dot q),

sticking while the force does not overcome :math:`F_c`, held in a
position loop by a PD controller, :math:`F = K_p (r - q) - K_d \\dot q`,
that follows a reference of random steps and ramps. The record is what a
user logs on such a stage: the force command ``F`` (N) as the input and
the measured position ``q`` (mm, white sensor noise) as the output, at
1 kHz; the model is of the open plant F → q, so its free run integrates
like the stage and has no loop to hold it. The system is integrated with
20 semi-implicit Euler steps per sample; a crossing of zero velocity at a
force below :math:`F_c` sticks.

The true structure in the term language, from the equation discretised
at the sample rate with the velocity as a difference of positions, is
``y[k-1] y[k-2] u[k-1] Phi2(y[k-1],y[k-2])``: Coulomb friction as the sign
of the velocity (:data:`TRUTH`). Its oracle fits those terms on the
training record by least squares and by free-run simulation error
(:func:`narx.refine`), keeps the better on the training record's last
quarter, and simulates the validation record. The default ``mggp fit``
must come within :data:`GOAL` of that validation error.
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings
from dataclasses import dataclass

import numpy as np

from narx import Data, Model

from .budget import add_budget_args, budget

__all__ = ["TRUTH", "GOAL", "stage", "records", "oracle", "run", "main"]

#: the true structure of the sampled stage (F -> q)
TRUTH = ("y[k-1]", "y[k-2]", "u[k-1]", "Phi2(y[k-1],y[k-2])")
#: the default fit's validation RMSE must be within this factor of the oracle's
GOAL = 1.5
#: sample time (s), integration steps per sample
TS, SUBSTEPS = 1e-3, 20


@dataclass(frozen=True)
class Stage:
    """Physical constants: mass (kg), viscous (N s/m) and Coulomb (N)
    friction, the PD gains (N/m, N s/m)."""

    m: float = 1.0
    c: float = 8.0
    fc: float = 4.0
    kp: float = 4000.0
    kd: float = 60.0


def reference(n: int, rng) -> np.ndarray:
    """A reference position (m): holds of random length at random levels
    in ±5 mm, joined by ramps of random speed, with slow reversals of small
    amplitude so that the stage sticks and slips at low speed too."""
    r, k, level = np.empty(n), 0, 0.0
    while k < n:
        target = rng.uniform(-5e-3, 5e-3)
        ramp = int(rng.integers(50, 600))
        hold = int(rng.integers(100, 500))
        seg = np.r_[np.linspace(level, target, ramp, endpoint=False), np.full(hold, target)]
        seg = seg + 2e-4 * np.sin(2 * np.pi * rng.uniform(0.5, 3) * np.arange(len(seg)) * TS)
        r[k:k + len(seg)] = seg[:n - k]
        k += len(seg)
        level = target
    return r


def stage(r: np.ndarray, p: Stage = Stage()) -> tuple:
    """Force command F (N) and position q (m) of the stage in its loop
    following the reference ``r`` (m), from rest at 0."""
    n, dt = len(r), TS / SUBSTEPS
    F, q = np.empty(n), np.empty(n)
    x = v = 0.0
    for k in range(n):
        f = p.kp * (r[k] - x) - p.kd * v           # the command, held over the sample
        F[k], q[k] = f, x
        for _ in range(SUBSTEPS):
            if v == 0.0 and abs(f) <= p.fc:
                continue                            # stuck
            s = np.sign(v) if v != 0.0 else np.sign(f)
            v_new = v + dt / p.m * (f - p.c * v - p.fc * s)
            if v != 0.0 and np.sign(v_new) != np.sign(v) and abs(f) <= p.fc:
                v_new = 0.0                         # stops and sticks
            x += dt * v_new
            v = v_new
    return F, q


def records(seed: int, n: int = 6000, noise: float = 2e-6):
    """(training, validation) records, position in mm, the validation one
    from another reference; sensor noise ``noise`` m (white)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(2):
        F, q = stage(reference(n, rng))
        out.append(Data(F, 1e3 * (q + noise * rng.standard_normal(n))))
    return tuple(out)


def _val_rmse(model: Model, val: Data) -> float:
    sim = model.simulate(val, mode="freerun")
    return float("inf") if sim.diverged or not np.isfinite(sim.rmse) else float(sim.rmse)


def oracle(train: Data, val: Data) -> dict:
    """The true structure's validation free-run RMSE: θ by LS and by
    free-run simulation error on the training record, the better on its
    last quarter (θ of that choice fitted on the first three quarters)."""
    from narx import refine
    from mggp.diagnose.run import slice_data
    n = len(train.y)
    cut = n * 3 // 4
    head, tail = slice_data(train, 0, cut), slice_data(train, cut, n)
    fits = {}
    for how in ("LS", "simulation error"):
        for data, key in ((head, "head"), (train, "all")):
            m = Model(list(TRUTH)).fit(data)
            if how == "simulation error":
                try:
                    m = refine(m, data, mode="freerun").model
                except ValueError:
                    pass
            fits[how, key] = m
    tails = {how: _val_rmse(fits[how, "head"], tail) for how in ("LS", "simulation error")}
    best = min(tails, key=tails.get)
    return {"theta": best, "rmse": _val_rmse(fits[best, "all"], val),
            "equation": fits[best, "all"].equation()}


def run(seeds, budget: dict, jobs: int, log=print) -> list:
    from mggp import MGGPRegressor
    rows = []
    for seed in seeds:
        train, val = records(seed)
        orc = oracle(train, val)
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            est = MGGPRegressor(random_state=seed, n_jobs=jobs, **budget).fit(train)
        model = est.get_best()
        row = {"seed": seed, "oracle": orc["rmse"], "oracle_theta": orc["theta"],
               "default": _val_rmse(model, val), "terms": model.n_terms,
               "equation": model.equation(), "seconds": time.perf_counter() - t0,
               "choices": {k: v["value"] for k, v in est.choices_.items()}}
        row["ratio"] = row["default"] / row["oracle"]
        rows.append(row)
        log(f"seed {seed}: default {row['default']:.4g} mm ({row['terms']} terms), true "
            f"structure {orc['rmse']:.4g} mm ({orc['theta']}), ratio {row['ratio']:.2f}, "
            f"{row['seconds']:.0f} s")
    return rows


def markdown(rows) -> str:
    within = sum(r["ratio"] <= GOAL for r in rows)
    md = [f"The default fit is within {GOAL:g}× of the true structure's validation error "
          f"on {within} of {len(rows)} seeds.", "",
          "| seed | default RMSE (mm) | terms | true structure (mm) | its θ by | ratio | "
          "default model |", "|---:|---:|---:|---:|---|---:|---|"]
    for r in rows:
        md.append(f"| {r['seed']} | {r['default']:.4g} | {r['terms']} | {r['oracle']:.4g} | "
                  f"{r['oracle_theta']} | {r['ratio']:.2f} | `{r['equation']}` |")
    return "\n".join(md)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.friction_stage",
                                description=__doc__.split("\n")[0])
    add_budget_args(p, seeds=[1, 2, 3])
    a = p.parse_args(argv)
    print(markdown(run(a.seeds, budget(a), a.jobs, log=lambda s: print(s, flush=True))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
