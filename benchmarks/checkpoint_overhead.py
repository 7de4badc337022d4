"""The time a default fit spends writing its checkpoints, and that they change nothing.

Typical call::

    python -m benchmarks.checkpoint_overhead              # 4,000 piezo samples, seed 1
    python -m benchmarks.checkpoint_overhead --samples 20000 --seed 2

Fits :class:`mggp.MGGPRegressor` with its defaults (the pilots of the
automatic choices included) on ``training_input(N)`` through
``piezo_bouc_wen``, once without a checkpoint and once with one, in this
process on one job, and reports each run's CPU time
(``time.process_time``: robust to other processes on the machine, unlike
the wall time), the CPU time inside the checkpoint writes (every call of
:func:`mggp.gp.checkpoint.save_checkpoint` and of the copy of the chosen
pilot's file, :func:`mggp.gp.checkpoint.copy_checkpoint`) as a share of the
checkpointed run, the files written with their size, and whether both runs
end on the same model (terms and θ). :data:`mggp.gp.checkpoint.CHECKPOINT_SHARE`
spaces each search's writes so that they take about 5 % of its time.
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time
import warnings

import numpy as np

__all__ = ["measure"]


def measure(samples: int = 4000, seed: int = 1) -> dict:
    """CPU seconds of the plain and the checkpointed fit, of the writes,
    the writes' count, the files and their bytes, and whether the models
    are the same."""
    import mggp.gp.checkpoint as ck
    import mggp.fit.estimator as es
    from mggp import MGGPRegressor
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(samples, seed=1)
    y = piezo_bouc_wen(u)
    spent = {"seconds": 0.0, "writes": 0}

    def timed(f):
        def g(*a, **k):
            t = time.process_time()
            try:
                return f(*a, **k)
            finally:
                spent["seconds"] += time.process_time() - t
                spent["writes"] += 1
        return g

    saved = ck.save_checkpoint, es.copy_checkpoint
    ck.save_checkpoint, es.copy_checkpoint = timed(saved[0]), timed(saved[1])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t = time.process_time()
            plain = MGGPRegressor(random_state=seed, n_jobs=1).fit(u, y)
            t_plain = time.process_time() - t
            spent.update(seconds=0.0, writes=0)
            with tempfile.TemporaryDirectory() as d:
                t = time.process_time()
                run = MGGPRegressor(random_state=seed, n_jobs=1,
                                    checkpoint=os.path.join(d, "run.ckpt")).fit(u, y)
                t_ck = time.process_time() - t
                files = {f: os.path.getsize(os.path.join(d, f)) for f in sorted(os.listdir(d))}
    finally:
        ck.save_checkpoint, es.copy_checkpoint = saved
    same = (plain.model_.term_texts == run.model_.term_texts
            and np.array_equal(plain.model_.theta, run.model_.theta))
    return {"plain_cpu": t_plain, "checkpointed_cpu": t_ck, "write_cpu": spent["seconds"],
            "writes": spent["writes"], "files": files, "same_model": bool(same)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.checkpoint_overhead")
    p.add_argument("--samples", type=int, default=4000)
    p.add_argument("--seed", type=int, default=1)
    a = p.parse_args(argv)
    r = measure(a.samples, a.seed)
    share = r["write_cpu"] / r["checkpointed_cpu"]
    print(f"writes take {share:.1%} of the checkpointed fit's CPU time "
          f"({r['write_cpu']:.2f} s in {r['writes']} writes); same model: "
          f"{'yes' if r['same_model'] else 'NO'}")
    print(f"CPU time: {r['plain_cpu']:.1f} s without a checkpoint, "
          f"{r['checkpointed_cpu']:.1f} s with one")
    print(f"files: {', '.join(r['files'])} ({sum(r['files'].values()) / 1e6:.1f} MB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
