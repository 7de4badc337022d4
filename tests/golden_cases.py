"""Reference runs whose every number must survive a change of the code's shape.

Typical use::

    python -m tests.golden_cases --write tests/data/golden.json   # record (on main)
    python -m pytest tests/test_golden.py                          # compare

Three runs at small budgets, each with a fixed seed: the S1–S6 structure
recovery of :mod:`benchmarks.recovery`, the PEM and MS searches of the
quick case study (:mod:`benchmarks.pem_vs_ms`: free-run screen, MS with the
hold selection and the CLS refit) and a diagnosis of the published PEM
model (32) with the held sine as validation record. Every float is stored as ``float.hex`` so the comparison is bit
for bit.

Bit for bit holds for one BLAS kernel: OpenBLAS picks its kernel from the
processor (``threadpoolctl`` names it, e.g. ``Haswell``, ``SkylakeX``), and
another kernel sums in another order, which moves last bits and, through
the search's ties, even a Pareto row. The file therefore holds one record
per kernel (:func:`blas_kernel`), and ``--write`` adds or replaces the
current kernel's record, leaving the others.
"""
from __future__ import annotations

import argparse
import json
import warnings

import numpy as np


def _hex(values):
    return [float(v).hex() for v in np.ravel(np.asarray(values, dtype=float))]


def _model(m):
    return None if m is None else {"terms": list(m.term_texts), "theta": _hex(m.theta)}


def _estimator(est):
    return {"model": _model(est.model_), "cls": _model(est.model_cls_),
            "fitness": _hex([est.fitness_]),
            "best": _hex([row["best"] for row in est.logbook_]),
            "pareto": [[r["complexity"], float(r["loss"]).hex(), r["terms"],
                        None if r["theta"] is None else _hex(r["theta"])]
                       for r in est.pareto_front_]}


def recovery():
    from mggp import MGGPRegressor
    from mggp.fit.choices import AS_SEARCHED
    from benchmarks.recovery import SETTINGS
    from narx.systems.testsystems import SYSTEMS, system_by_name
    out = {}
    for name in SYSTEMS:
        d = system_by_name(name, n=500, seed=0)
        kw = dict(SETTINGS, population=40, generations=6, screen=None, select="fitness",
                  **AS_SEARCHED)
        est = MGGPRegressor(random_state=1, **kw).fit(d.u, d.y)
        out[name] = _estimator(est)
    return out


def case_study():
    from mggp import MGGPRegressor
    from mggp.fit.choices import AS_SEARCHED
    from benchmarks.casestudy import case_data
    cs = case_data(n=3000)
    out = {}
    pem = MGGPRegressor(fitness="pem", population=24, generations=4, random_state=1,
                        screen="freerun", use_phi=True, select="fitness",
                        **AS_SEARCHED).fit(cs.u, cs.y)
    out["pem"] = _estimator(pem)
    ms = MGGPRegressor(fitness="ms", window=200, population=24, generations=4,
                       random_state=1, screen="freerun", constraints="steady-state",
                       use_phi=True,
                       select="hold", select_candidates=50).fit(cs.u, cs.y)
    out["ms"] = dict(_estimator(ms), rejected=ms.cls_rejected_)
    return out


def diagnosis():
    from mggp.diagnose import Budget, diagnose
    from narx import Model
    from narx.records.data import Data
    from benchmarks.casestudy import MODEL32_TERMS, case_data
    cs = case_data(n=4000)
    train, held = Data(cs.u, cs.y), Data(cs.held.u, cs.yh)
    model = Model(MODEL32_TERMS, meta={"fitness": "pem", "estimation": "ls"}).fit(train)
    dx = diagnose(train, held, model, budget=Budget(population=24, generations=4,
                                                    shifts=19), seed=1, jobs=1)
    d = dx.to_dict()
    keep = {"findings": d["findings"], "baseline": d["baseline"], "extended": d["extended"],
            "gain": d["gain"], "samples": d["samples"]}
    return json.loads(json.dumps(keep, default=lambda v: float(v)),
                      parse_float=lambda s: float(s).hex())


def blas_kernel() -> str:
    """The OpenBLAS kernel numpy's BLAS runs here (``"unknown"`` when none is named)."""
    from threadpoolctl import threadpool_info
    for lib in threadpool_info():
        if lib.get("user_api") == "blas":
            return str(lib.get("architecture") or lib.get("internal_api") or "unknown")
    return "unknown"


def record():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {"recovery": recovery(), "case_study": case_study(), "diagnosis": diagnosis()}


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m tests.golden_cases")
    p.add_argument("--write", required=True, help="JSON file to write")
    a = p.parse_args(argv)
    try:
        with open(a.write) as fh:
            doc = json.load(fh)
    except FileNotFoundError:
        doc = {}
    doc[blas_kernel()] = record()
    from narx.atomic import atomic_write_text
    atomic_write_text(a.write, json.dumps(doc, indent=1, sort_keys=True))


if __name__ == "__main__":
    main()
