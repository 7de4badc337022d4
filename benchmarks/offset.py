"""An output at a level far from zero: the constant term or powers of y.

Typical use::

    python -m benchmarks.offset --jobs 2              # 4 levels x 3 settings x 3 seeds
    python -m benchmarks.offset --seeds 1 --levels 0 20
    python -m benchmarks.offset --settings default     # e.g. on another commit

Records (:func:`level_record`): the deviation x from a level L obeys

.. math:: x_k = 0.6\\,x_{k-1} - 0.1\\,x_{k-2} + 0.5\\,u_{k-1} + 0.3\\,u_{k-1}^2,

and the measured output is y = L + x + e, e ~ N(0, 0.01²) white on the
output. The input holds U(-1, 1) values for 10 samples each (2,000 samples).
In y the system is y[k] = 0.5 L + 0.6 y[k-1] - 0.1 y[k-2] + 0.5 u[k-1] +
0.3 u[k-1]²: five terms with the constant, four at L = 0. Inside the
record's range a structure without the constant can hold the level with
a power of the output (y[k-1]² ≈ 2 L y[k-1] - L² near L), and the held-out
errors then tie. Validation: the same system driven by U(-2, 2) (its
output leaves the training range), so a level held by powers of y shows.

For each level and seed, ``mggp fit`` with its defaults, with
``--constant`` and with ``--no-constant`` (the estimator's default budget
unless ``--population``/``--generations`` are given). The table gives, per
setting, how many fits hold the constant, how many find the exact
structure, and the median free-run RMSE on the validation record.
"""
from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from narx import Data

__all__ = ["level_record", "SETTINGS", "run", "markdown"]

#: label -> MGGPRegressor keywords (the flag of ``mggp fit``: ``--<label>``)
SETTINGS = {"default": {}, "constant": dict(constant=True),
            "no-constant": dict(constant=False)}


def _flag(label: str) -> str:
    return label if label == "default" else f"--{label}"


def level_record(n: int = 2000, seed: int = 0, level: float = 20.0, amplitude: float = 1.0,
                 hold: int = 10, square: float = 0.3, lag2: float = -0.1,
                 noise: float = 0.01) -> Data:
    """The record of the module docstring: x[k] = 0.6 x[k-1] + ``lag2``
    x[k-2] + 0.5 u[k-1] + ``square`` u[k-1]², y = ``level`` + x + N(0,
    ``noise``²), u holding U(-``amplitude``, ``amplitude``) values for
    ``hold`` samples each."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-amplitude, amplitude, -(-n // hold)), hold)[:n]
    x = np.zeros(n)
    for k in range(2, n):
        x[k] = 0.6 * x[k - 1] + lag2 * x[k - 2] + 0.5 * u[k - 1] + square * u[k - 1] ** 2
    return Data(u, level + x + noise * rng.standard_normal(n))


def true_terms(level: float, square: float = 0.3, lag2: float = -0.1) -> list:
    """The structure of :func:`level_record`'s system in y."""
    terms = ["y[k-1]", "u[k-1]"] + (["y[k-2]"] if lag2 else []) + \
        (["u[k-1]*u[k-1]"] if square else [])
    return sorted(terms + (["1"] if level else []))


def run(levels, seeds, budget, jobs, log=print, settings=tuple(SETTINGS)) -> dict:
    """``{level: {setting: [row per seed]}}``."""
    from mggp import MGGPRegressor
    out = {}
    for level in levels:
        out[level] = {}
        records = {seed: (level_record(seed=seed, level=level),
                          level_record(seed=1000 + seed, level=level, amplitude=2.0))
                   for seed in seeds}
        for label in settings:
            kw = SETTINGS[label]
            rows = out[level][label] = []
            for seed in seeds:
                tr, va = records[seed]
                t0 = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    est = MGGPRegressor(random_state=seed, n_jobs=jobs, **budget, **kw).fit(tr)
                model = est.get_best()
                sim = model.simulate(va, mode="freerun")
                terms = sorted(model.term_texts)
                rows.append({"constant": "1" in terms, "exact": terms == true_terms(level),
                             "terms": terms,
                             "rmse": float(sim.rmse) if not sim.diverged else float("inf"),
                             "seconds": time.perf_counter() - t0})
                r = rows[-1]
                log(f"level {level:g} [{_flag(label)}] seed {seed}: RMSE {r['rmse']:.4g}, "
                    f"{'exact' if r['exact'] else 'not exact'}, {' + '.join(terms)}, "
                    f"{r['seconds']:.1f} s")
    return out


def markdown(res: dict) -> str:
    """Per level and setting: fits with the constant, exact structures and
    the median validation RMSE."""
    md = ["| level L | setting | with the constant | exact structure | validation RMSE "
          "(median) |", "|---:|---|---:|---:|---:|"]
    for level, settings in res.items():
        for label, rows in settings.items():
            n = len(rows)
            md.append(f"| {level:g} | `{_flag(label)}` | {sum(r['constant'] for r in rows)}/{n} | "
                      f"{sum(r['exact'] for r in rows)}/{n} | "
                      f"{np.median([r['rmse'] for r in rows]):.4g} |")
    return "\n".join(md)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks.offset",
                                description=__doc__.split("\n")[0])
    p.add_argument("--levels", type=float, nargs="+", default=[0.0, 2.0, 20.0, 200.0])
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    p.add_argument("--population", type=int, help="default: mggp fit's")
    p.add_argument("--generations", type=int, help="default: mggp fit's")
    p.add_argument("--settings", nargs="+", choices=list(SETTINGS), default=list(SETTINGS))
    p.add_argument("--jobs", type=int, default=2)
    a = p.parse_args(argv)
    budget = {k: v for k, v in (("population", a.population),
                                ("generations", a.generations)) if v is not None}
    t0 = time.perf_counter()
    res = run(a.levels, a.seeds, budget, a.jobs, settings=a.settings)
    print()
    print(markdown(res))
    print(f"({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
