"""Peer timings on the reference case (piezo, Bouc-Wen), as a runnable study.

Typical use::

    python -m benchmarks.peers.reference                  # N = 50,000, prints a table
    python -m benchmarks.peers.reference --n 10000 --fit-seconds 60 --json peers.json

Rows: the published toolbox's free run of the 15-term MS model (33) over the
training record, one LS + ``score_ksa`` evaluation of that model, its free
run of the reference model (19) with the published θ on the validation sine
(range-normalised MAPE, ~0.24 % expected: proof that Φ models are built
right), optionally a short toolbox MGGP search, and sysidentpy FROLS with and
without Φ-like extra inputs. The data generator here is a small stand-alone
RK4 of the case study (``narx.systems`` is the project's own); peers stay
independent of our packages.
"""
from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from . import (mape, phi_inputs, sysidentpy_frols, toolbox_fit, toolbox_freerun,
               toolbox_ls_ms_score)

MS_MODEL = ["y[k-2]*u[k-1]*u[k-3]", "u[k-5]", "u[k-1]*u[k-5]*y[k-5]", "u[k-1]*u[k-3]*u[k-3]",
            "u[k-5]*y[k-4]*Phi2(u[k-4],u[k-1])", "u[k-5]*y[k-1]*Phi2(u[k-3],u[k-1])",
            "y[k-1]", "Phi1(u[k-5],u[k-1])", "Phi2(u[k-4],u[k-6])",
            "y[k-3]*y[k-8]*Phi2(u[k-4],u[k-1])", "y[k-5]*y[k-8]*Phi2(u[k-4],u[k-1])",
            "u[k-3]*u[k-3]*Phi2(u[k-4],u[k-1])", "u[k-1]*u[k-1]*u[k-3]",
            "u[k-1]*u[k-4]*Phi2(u[k-5],u[k-1])", "u[k-10]"]
REF_MODEL = [("y[k-1]", 1.0), ("Phi1(u[k-2],u[k-3])", -0.2310),
             ("Phi2(u[k-2],u[k-3])*Phi1(u[k-2],u[k-3])*u[k-2]", 0.0146),
             ("Phi2(u[k-2],u[k-3])*Phi1(u[k-2],u[k-3])*y[k-1]", -0.0099),
             ("Phi1(u[k-2],u[k-3])*u[k-2]*u[k-2]", 3.2333e-4),
             ("Phi1(u[k-2],u[k-3])*u[k-2]*y[k-1]", -2.5494e-4),
             ("Phi2(u[k-2],u[k-3])*y[k-1]", 1.7891e-5),
             ("Phi1(u[k-1],u[k-2])", 1.0080),
             ("Phi2(u[k-2],u[k-3])*Phi1(u[k-2],u[k-3])*Phi1(u[k-2],u[k-3])", -0.0604)]


def piezo(u, dt=1e-3, d_p=1.6, A=0.9, beta=0.008, gamma=0.008):
    """Bouc-Wen piezo of the case study, RK4 with u linear between samples."""
    u = np.asarray(u, dtype=float)
    h, out = 0.0, np.empty_like(u)
    out[0] = d_p * u[0]
    for k in range(len(u) - 1):
        du = (u[k + 1] - u[k]) / dt
        f = lambda hh: A * du - beta * abs(du) * hh - gamma * du * abs(hh)  # noqa: E731
        k1 = f(h)
        k2 = f(h + 0.5 * dt * k1)
        k3 = f(h + 0.5 * dt * k2)
        k4 = f(h + dt * k3)
        h += dt * (k1 + 2 * k2 + 2 * k3 + k4) / 6
        out[k + 1] = d_p * u[k + 1] - h
    return out


def training_input(n=50_000, seed=0, amplitude=80.0, bandwidth=1.0, dt=1e-3):
    """Filtered pseudo-random input spanning +/-amplitude, ~bandwidth Hz."""
    from scipy import signal
    rng = np.random.default_rng(seed)
    b, a = signal.butter(4, bandwidth * 2 * dt)
    x = signal.lfilter(b, a, rng.standard_normal(n + 2000))[2000:]
    x -= x.mean()
    return amplitude * x / np.max(np.abs(x))


def sine(duration=5.0, amplitude=40.0, freq=1.0, dt=1e-3):
    t = np.arange(int(round(duration / dt))) * dt
    return amplitude * np.sin(2 * np.pi * freq * t)


def run(n=50_000, freerun_repeats=1, score_repeats=5, k=10, fit_seconds=0.0, seed=0):
    rows, out = [], {"n": n}
    u = training_input(n, seed)
    y = piezo(u)
    uv = sine()
    yv = piezo(uv)

    s = toolbox_ls_ms_score(MS_MODEL, u, y, k=k, repeats=score_repeats)
    out["toolbox_ls_ms_score"] = s
    if not s["available"]:
        rows.append(("toolbox", "unavailable", s["reason"]))
    else:
        out["versions_toolbox"] = s["versions"]
        rows.append(("toolbox LS+score_ksa, 15 terms", f"{1e3 * s['seconds']:.1f} ms",
                     f"compile {1e3 * s['compile_seconds']:.1f} / LS {1e3 * s['ls_seconds']:.1f}"
                     f" / score {1e3 * s['score_seconds']:.1f} ms, k={k}, MSE {s['score']:.3g}"))
        f = toolbox_freerun(MS_MODEL, s["theta"], u, y, repeats=freerun_repeats)
        out["toolbox_freerun"] = {kk: v for kk, v in f.items() if kk != "y_hat"}
        rows.append((f"toolbox free run, 15 terms, N={n}", f"{f['seconds']:.2f} s",
                     f"train MAPE {mape(y, f['y_hat'], f['max_lag']):.3f} % (LS θ)"))
        terms, theta = zip(*REF_MODEL)
        r = toolbox_freerun(list(terms), list(theta), uv, yv, repeats=1)
        m = mape(yv, r["y_hat"], r["max_lag"])
        out["toolbox_reference_model_val_mape"] = m
        rows.append(("toolbox free run, model (19), sine", f"{r['seconds']:.2f} s",
                     f"val MAPE {m:.3f} % (published 0.241)"))
        if fit_seconds > 0:
            g = toolbox_fit(u, y, uv, yv, population=500, generations=200, max_terms=15,
                            max_height=5, seed=seed, fitness="ms", k=k,
                            time_limit=fit_seconds)
            out["toolbox_fit"] = {kk: v for kk, v in g.items() if not kk.startswith("y_")}
            rows.append(("toolbox MGGP (pop 500), time-limited",
                         f"{g['fit_seconds']:.0f} s",
                         f"{g['generations_completed']} gens, {g['evaluations']} evals, "
                         f"{len(g['terms'])} terms, val MAPE {g['val_mape']:.3f} %"))
    for label, extra, deg, lag in [("u", None, 2, 2), ("u", None, 3, 3),
                                   ("u+Φ", phi_inputs(u, uv), 2, 2),
                                   ("u+Φ", phi_inputs(u, uv), 3, 3)]:
        r = sysidentpy_frols(u, y, uv, yv, degree=deg, ylag=lag, xlag=lag,
                             extra_inputs=extra, info_criteria="aic")
        key = f"frols_{label}_deg{deg}_lag{lag}"
        if not r["available"]:
            rows.append(("sysidentpy", "unavailable", r["reason"]))
            break
        out["versions_sysidentpy"] = r["versions"]
        out[key] = {kk: v for kk, v in r.items() if not kk.startswith("y_")}
        rows.append((f"FROLS {label} deg {deg} lags {lag}", f"{r['fit_seconds']:.2f} s",
                     f"{r['n_terms']} terms, val MAPE {r['val_mape']:.3g} %"
                     f"{' (diverged)' if r['diverged'] else ''}"))
    return rows, out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=50_000)
    ap.add_argument("--k", type=int, default=10)
    ap.add_argument("--freerun-repeats", type=int, default=1)
    ap.add_argument("--fit-seconds", type=float, default=0.0)
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    rows, out = run(a.n, a.freerun_repeats, k=a.k, fit_seconds=a.fit_seconds)
    width = max(len(r[0]) for r in rows)
    for name, fig, note in rows:
        print(f"{name:<{width}}  {fig:>10}  {note}")
    print(f"(total {time.perf_counter() - t0:.0f} s)")
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(out, fh, indent=1, default=lambda o: o.tolist()
                      if isinstance(o, np.ndarray) else float(o))
    return 0


if __name__ == "__main__":
    sys.exit(main())
