"""``mggp fit train.csv --constraints steady-state`` with its defaults on the piezo case.

Typical use::

    python -m benchmarks.defaults_piezo --seed 1 --jobs 2 --out runs/piezo
    python -m benchmarks.defaults_piezo --seed 1 --jobs 2 --out runs/piezo_small \\
        -- --population 200 --generations 30

Writes the training record of :func:`benchmarks.casestudy.case_data`
(50,000 samples) to ``OUT/train.csv``, runs ``mggp fit`` on it with
``--constraints steady-state`` and the options after ``--``, and scores the
written model in free run on the validation sine u = 40 sin(2πt) and on the
held sine. Goals: validation MAPE ≤ 0.2 % (published MS-CLS 0.202 %) and a
held output constant to 1e-4 of the output range in the second half of
each hold,

.. math:: \\max_{k \\in H_2} \\hat y_k - \\min_{k \\in H_2} \\hat y_k
          \\le 10^{-4} (\\max y - \\min y),

with :math:`H_2` the second half of a hold. Prints one JSON line.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

import numpy as np

#: the held output's spread in the second half of each hold, in output ranges
HOLD_TOL = 1e-4
#: validation MAPE goal (%)
MAPE_GOAL = 0.2


def held_spread(y_hat, hold: slice, y_range: float) -> float:
    """max − min of ``y_hat`` over the second half of ``hold``, in output ranges."""
    seg = np.asarray(y_hat[hold], dtype=float)
    tail = seg[seg.size // 2:]
    return float(np.ptp(tail)) / y_range if np.all(np.isfinite(tail)) else float("inf")


def score(model, cs) -> dict:
    """Validation and held-sine figures of ``model`` against the goals."""
    rv = model.simulate(cs.uv, cs.yv, "freerun")
    rh = model.simulate(cs.held.u, cs.yh, "freerun")
    yr = float(np.ptp(cs.yh))
    spreads = [held_spread(rh.y_hat, sl, yr)
               for sl in (cs.held.hold_rising, cs.held.hold_falling)]
    out = {"val_mape": float(rv.mape), "held_mape": float(rh.mape),
           "hold_spread_rel": spreads, "diverged": bool(rv.diverged or rh.diverged),
           "estimation": model.meta.get("estimation"), "terms": list(model.term_texts),
           "choices": model.meta.get("choices")}
    out["mape_ok"] = out["val_mape"] <= MAPE_GOAL
    out["holds"] = max(spreads) <= HOLD_TOL
    return out


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[:argv.index("--")] if "--" in argv else argv
    p = argparse.ArgumentParser(prog="python -m benchmarks.defaults_piezo")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--n", type=int, default=50_000, help="training samples")
    p.add_argument("--out", required=True, help="folder for train.csv, model.json, log")
    a = p.parse_args(argv)
    from narx import Model
    from .casestudy import case_data
    os.makedirs(a.out, exist_ok=True)
    cs = case_data(a.n)
    train = os.path.join(a.out, "train.csv")
    if not os.path.exists(train):
        np.savetxt(train, np.column_stack([cs.u, cs.y]), delimiter=",", header="u,y",
                   comments="")
    model_path = os.path.join(a.out, "model.json")
    cmd = [sys.executable, "-m", "mggp", "fit", train, "--constraints", "steady-state",
           "--seed", str(a.seed), "--jobs", str(a.jobs), "--out", model_path,
           "--quiet"] + extra
    run = subprocess.run(cmd, capture_output=True, text=True)
    with open(os.path.join(a.out, "log.txt"), "w") as fh:
        fh.write(" ".join(cmd) + "\n" + run.stdout + run.stderr)
    if run.returncode:
        sys.exit(f"error: mggp fit failed ({run.returncode}): {run.stderr.strip()[-500:]}")
    row = dict(score(Model.load(model_path), cs), command=" ".join(cmd[2:]))
    print(json.dumps(row))


if __name__ == "__main__":
    main()
