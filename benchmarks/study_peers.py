"""Peer rows of the piezo case study: sysidentpy FROLS and the published toolbox.

Typical use (from :mod:`benchmarks.pem_vs_ms`)::

    peers = run_peers(case_data, args, print)   # list of dicts, one per peer row

Both peers run on the same training and validation records, with the same
metric (range-normalised free-run MAPE), on the same machine, in the same
run. FROLS is given a small grid of its settings (degree, lags, and the
Φ-like regressors Δu and sign(Δu) as extra inputs) and the best validation
row is reported with the grid; the published toolbox runs its own MGGP
search with multiple-shooting fitness under a time limit. With
``--peers yes`` (the study's default) a peer's environment is installed on
first use (one line says so); a peer that cannot be installed or run gives
a row that says why.
"""
from __future__ import annotations

import numpy as np

from narx import rmse

__all__ = ["run_peers"]

FROLS_GRID = [dict(degree=2, ylag=2, xlag=2, phi=False), dict(degree=3, ylag=3, xlag=3, phi=False),
              dict(degree=2, ylag=2, xlag=2, phi=True), dict(degree=3, ylag=2, xlag=2, phi=True)]


def _ready(name, mode, log=None):
    """The environment of peer ``name``; with ``mode='yes'`` a missing one is
    installed, and one line on ``log`` says so (or why it could not be)."""
    from .peers import envs
    if mode == "no":
        return {"available": False, "reason": "skipped (--peers no)"}
    st = envs.ensure_env(name, install=False)
    if st["available"]:
        return st
    if mode == "auto":
        st["reason"] = "not installed (run with --peers yes to install it)"
        return st
    if log is not None:
        log(f"  installing peer {name} ({', '.join(envs.PEERS[name]['packages'])}) into its "
            f"own environment {envs.peers_dir() / name} (first use only, about a minute)")
    st = envs.ensure_env(name, install=True)
    if not st["available"] and log is not None:
        log(f"  peer {name} not available: {st['reason']}")
    return st


def _frols(cs, args, log):
    from . import peers
    row = {**_ready("sysidentpy", args.peers, log), "name": "sysidentpy FROLS"}
    if not row["available"]:
        return row
    grid = FROLS_GRID if args.full else FROLS_GRID[::2]
    best, tried = None, []
    for g in grid:
        extra = peers.phi_inputs(cs.u, cs.uv) if g["phi"] else None
        r = peers.sysidentpy_frols(cs.u, cs.y, cs.uv, cs.yv, degree=g["degree"], ylag=g["ylag"],
                                   xlag=g["xlag"], extra_inputs=extra)
        v = r.get("val_mape", float("inf"))
        v = float("inf") if (r.get("diverged") or v is None or not np.isfinite(v)) else v
        tried.append({**g, "val_mape": v, "fit_time": r.get("fit_seconds")})
        log(f"  FROLS {g}: val MAPE {v:.3g}, fit {r.get('fit_seconds', float('nan')):.1f} s")
        if best is None or v < best[0]:
            best = (v, g, r)
    v, g, r = best
    yh = np.asarray(r.get("y_val_hat", []), dtype=float)
    row.update(val_mape=v, fit_time=r.get("fit_seconds"), n_terms=len(r.get("terms", [])),
               terms=r.get("terms"), settings=g, grid=tried, versions=r.get("versions"),
               val_rmse=rmse(cs.yv, yh) if yh.size == cs.yv.size and np.isfinite(v)
               else float("inf"), y_val=yh if yh.size == cs.yv.size else None)
    return row


def _toolbox(cs, args, log):
    from . import peers
    row = {**_ready("toolbox", args.peers, log), "name": "published toolbox (MS)"}
    if not row["available"]:
        return row
    limit = 600.0 if args.full else 90.0
    r = peers.toolbox_fit(cs.u, cs.y, cs.uv, cs.yv, population=min(args.population, 500),
                          generations=args.generations, max_terms=15, max_height=5, seed=1,
                          fitness="ms", k=args.window, time_limit=limit, freerun_train=True)
    yh = np.asarray(r.get("y_val_hat", []), dtype=float)
    row.update(val_mape=r.get("val_mape"), train_mape=r.get("train_mape"),
               fit_time=r.get("fit_seconds"), n_terms=len(r.get("terms", [])),
               terms=r.get("terms"), versions=r.get("versions"),
               generations_completed=r.get("generations_completed"),
               evaluations=r.get("evaluations"), timed_out=r.get("timed_out"),
               time_limit=limit,
               val_rmse=rmse(cs.yv[-yh.size:], yh) if yh.size and np.all(np.isfinite(yh))
               else float("inf"), y_val=yh if yh.size == cs.yv.size else None)
    log(f"  toolbox: {r.get('generations_completed')} generations in {r.get('fit_seconds', 0):.0f} s "
        f"(limit {limit:.0f} s), val MAPE {float(row['val_mape'] if row['val_mape'] is not None else 'nan'):.3g} %")
    return row


def run_peers(cs, args, log):
    rows = []
    for fn in (_frols, _toolbox):
        try:
            rows.append(fn(cs, args, log))
        except Exception as exc:          # a peer failing must not sink the study
            rows.append({"name": fn.__name__.strip("_"), "available": False,
                         "reason": f"failed: {type(exc).__name__}: {exc}"[:200]})
    return rows
