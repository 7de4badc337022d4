"""Development run of ``mggp diagnose`` on zoo draws (development seeds only).

Typical use::

    python -m benchmarks.diagnose_zoo_dev --seeds 0-15 --n 4000 --population 60 \
        --generations 10

Each draw of :mod:`narx.systems.zoo` (inside ``zoo.tuning()``, so an
evaluation seed raises ``zoo.SeedLeak``) is diagnosed on its training
record with its validation record; one line per draw: family, whether it is
hysteretic, the named effects, the hysteresis p-value, the measured gain
ratio and whether the record separates memory from dynamics. This is the
development measure of the verdict rule; the evaluation seeds are for the
integrator's report.
"""
from __future__ import annotations

import argparse
import json
import time

from narx.systems import zoo

from mggp.diagnose import Budget, diagnose


def _seeds(text: str):
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def main(argv=None) -> list:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", default="0-15")
    p.add_argument("--n", type=int, default=4000)
    p.add_argument("--population", type=int, default=60)
    p.add_argument("--generations", type=int, default=10)
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--json", default=None, help="write the rows here")
    a = p.parse_args(argv)
    rows = []
    with zoo.tuning():
        for seed in _seeds(a.seeds):
            d = zoo.draw(seed, n=a.n)
            t = time.perf_counter()
            dx = diagnose(d.train, d.validation, budget=Budget(population=a.population,
                                                               generations=a.generations),
                          seed=seed, jobs=a.jobs)
            row = {"seed": seed, "family": d.family, "hysteretic": bool(d.hysteretic),
                   "named": dx.effects,
                   "p_values": {k: round(v, 4) for k, v in dx.verdict.p_values.items()},
                   "winner": dx.verdict.winner.structure.name if dx.verdict.winner else None,
                   "gain": round(float(dx.gain.ratio), 3), "separation": dx.separation is None,
                   "seconds": round(time.perf_counter() - t, 1),
                   "timings": {k: round(v, 1) for k, v in dx.timings.items()}}
            rows.append(row)
            print(json.dumps(row), flush=True)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return rows


if __name__ == "__main__":
    main()
