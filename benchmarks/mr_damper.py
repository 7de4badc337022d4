"""Second study: the simulated magnetorheological damper of the shared data.

Typical use::

    python -m benchmarks.mr_damper                 # quick search, prints RRSE
    run_damper(args, print)                        # from benchmarks.pem_vs_ms

Data (``mr_damper.csv``, shipped in ``benchmarks/data`` with its origin and
licence in ``benchmarks/data/SOURCES.md``): inputs voltage ``E`` and
velocity ``v``, output force ``f``; training rows 400–1999, test rows
2001–3599, each signal scaled by its maximum absolute value on the training
part (the published protocol). The published yardstick is SysIdentPy's
FROLS with inputs E, v and sign(v), degree 3, lags 1: free-run root relative
squared error (RRSE) 0.0451 on the test part (MetaMSS 0.0557).

Our model: MGGP structure search with free-run fitness over the inputs E and
v, with ``Sign`` registered as a user Φ-function (``sign`` of a lagged
input; steady value ``sign``) so the search may use sign(v) as the
published regressor set does. The test part is simulated free-run from its
first samples. FROLS runs beside it in the same run when its environment is
installed.
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

from narx import Data, PhiRegistry, rrse
from narx.records.csvdata import read_columns

__all__ = ["load_damper", "run_damper", "damper_path", "data_path", "data_dirs"]

PUBLISHED = {"FROLS (sysidentpy tutorial)": 0.0451, "MetaMSS": 0.0557}


def data_dirs():
    """Folders searched for shared data files, in order: ``$MGGP_SHARED_DATA``
    if set, the copies shipped in ``benchmarks/data``, and ``../shared/data``
    from the project root (where the project's shared data sit beside a
    clone)."""
    env = os.environ.get("MGGP_SHARED_DATA")
    here = os.path.dirname(os.path.abspath(__file__))
    return ([env] if env else []) + [os.path.join(here, "data"), os.path.normpath(
        os.path.join(here, "..", "..", "shared", "data"))]


def data_path(name):
    """Path of the shared data file ``name`` in the first of
    :func:`data_dirs` that has it; None if none has it."""
    for folder in data_dirs():
        p = os.path.join(folder, name)
        if os.path.exists(p):
            return os.path.normpath(p)
    return None


def shared_data_error(names):
    """The one ``error:`` line of a study whose shared data files ``names``
    are not all found by :func:`data_path` (None when every one is)."""
    missing = [n for n in dict.fromkeys(names) if data_path(n) is None]
    if not missing:
        return None
    return (f"error: shared data not found: {', '.join(missing)} (looked in "
            f"{', '.join(data_dirs())}; set MGGP_SHARED_DATA to the folder that has them)")


def damper_path():
    """``mr_damper.csv`` (see :func:`data_path`)."""
    return data_path("mr_damper.csv")


def load_damper(path):
    arr, _ = read_columns(path, ["E", "v", "f"])
    tr, te = arr[400:2000], arr[2001:3600]
    scale = np.max(np.abs(tr), axis=0)
    return tr / scale, te / scale


def _registry():
    reg = PhiRegistry()
    reg.register("Sign", 1, np.sign, np.sign, doc="sign of a lagged input")
    return reg


def run_damper(args, log):
    from mggp import MGGPRegressor
    from mggp.fit.choices import AS_SEARCHED
    path = damper_path()
    if path is None:
        log("  MR damper: data file not found (set MGGP_SHARED_DATA)")
        return {"available": False, "markdown": "MR damper data not found: row missing."}
    tr, te = load_damper(path)
    full = getattr(args, "full", False)
    seeds = [1, 2, 3, 4, 5] if full else [1]
    rows = []
    for seed in seeds:
        t0 = time.perf_counter()
        est = MGGPRegressor(fitness="freerun", population=300 if full else 150,
                            generations=100 if full else 30, max_terms=15, max_height=3,
                            inputs=("E", "v"), output="f", random_state=seed,
                            n_jobs=getattr(args, "jobs", 1), registry=_registry(),
                            # the published study's setting: Φ primitives, searched size
                            use_phi=True, screen=None, select="fitness", **AS_SEARCHED)
        est.fit(Data(tr[:, :2], tr[:, 2], inputs=("E", "v"), output="f"))
        fit_time = time.perf_counter() - t0
        dte = Data(te[:, :2], te[:, 2], inputs=("E", "v"), output="f")
        r = est.model_.simulate(dte, mode="freerun")
        score = rrse(te[r.start:, 2], r.y_hat[r.start:]) if not r.diverged else float("inf")
        rows.append({"seed": seed, "rrse": score, "fit_time": fit_time,
                     "terms": est.model_.term_texts})
        log(f"  MR damper seed {seed}: test RRSE {score:.4f} ({fit_time:.0f} s, "
            f"{est.model_.n_terms} terms)")
    peer = _frols_damper(tr, te, getattr(args, "peers", "auto"), log)
    med = float(np.median([r["rrse"] for r in rows]))
    md = ["| model | test RRSE (free run) | fit s | terms |", "|---|---:|---:|---|"]
    for r in rows:
        md.append(f"| MGGP freerun (seed {r['seed']}) | {r['rrse']:.4f} | {r['fit_time']:.0f} "
                  f"| {len(r['terms'])}: " + ", ".join(f"`{t}`" for t in r["terms"]) + " |")
    if peer.get("available"):
        md.append(f"| sysidentpy FROLS deg 3, lags 1, E, v, sign v (this run) | "
                  f"{peer['rrse']:.4f} | {peer['fit_time']:.1f} | {peer['n_terms']} |")
    else:
        md.append(f"| sysidentpy FROLS (this run) | missing: {peer.get('reason')} | | |")
    for k, v in PUBLISHED.items():
        md.append(f"| {k}, published | {v} | | |")
    md.append("")
    ref = PUBLISHED["FROLS (sysidentpy tutorial)"]
    md.append(f"Median over {len(rows)} seed(s): {med:.4f}, "
              + (f"better than the published FROLS {ref} (lower RRSE is better)"
                 if med < ref else f"as good as the published FROLS {ref}" if med == ref
                 else f"worse than the published FROLS {ref} by {100 * (med / ref - 1):.0f} % "
                      f"(lower RRSE is better)") + ".")
    return {"available": True, "rows": rows, "median_rrse": med, "peer": {
        k: v for k, v in peer.items() if k != "y"}, "markdown": "\n".join(md)}


def _frols_damper(tr, te, mode, log):
    from .study_peers import _ready
    st = _ready("sysidentpy", mode, log)
    if not st["available"]:
        return st
    from . import peers
    extra = {"sv": (np.sign(tr[:, 1]), np.sign(te[:, 1]))}
    r = peers.sysidentpy_frols({"E": tr[:, 0], "v": tr[:, 1]}, tr[:, 2],
                               {"E": te[:, 0], "v": te[:, 1]}, te[:, 2], degree=3, ylag=1,
                               xlag=1, extra_inputs=extra, output="f")
    yh = np.asarray(r.get("y_val_hat", []), dtype=float)
    score = rrse(te[1:, 2], yh[1:]) if yh.size == te.shape[0] and np.all(np.isfinite(yh)) \
        else float("inf")
    log(f"  MR damper FROLS: test RRSE {score:.4f}")
    return {"available": True, "rrse": score, "fit_time": r.get("fit_seconds"),
            "n_terms": len(r.get("terms", [])), "versions": r.get("versions")}


if __name__ == "__main__":
    p = argparse.ArgumentParser(prog="python -m benchmarks.mr_damper")
    p.add_argument("--full", action="store_true")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--peers", choices=["auto", "yes", "no"], default="yes",
                   help="yes: run FROLS beside it, installing its environment on first "
                        "use; auto: only if installed; no: skip (default yes)")
    a = p.parse_args()
    print(run_damper(a, print)["markdown"])
