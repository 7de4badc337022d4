"""Free-run speed of a 15-term model on 50,000 samples, four ways in one run.

Typical call::

    python -m benchmarks.speed                      # N = 50,000, best of 5
    python -m benchmarks.speed --n 50000 --repeats 5 --json speed.json
    python -m benchmarks.speed --no-peers --no-cli  # ours, Python, floor only

Model: the published MS model (33) (Abreu et al. 2020), θ from
``narx.Model(terms).fit(u, y)`` on the piezo training record
(``training_input(n)`` -> ``piezo_bouc_wen``). Timed side by side:

(a) ours: ``Model.simulate(u, y)`` (arrays in, everything rebuilt: data
    checks, input parts, kernel); ``narx.simulate(terms, θ, data)`` on a
    reused :class:`narx.Data` (input parts cached on it); the kernel alone
    (``run_windows`` with plan and input parts ready). The first call in a
    fresh process is timed in subprocesses: with an empty numba cache
    (compile) and with the on-disk cache (load).
(b) plain Python: a loop hand-written for this one model (lists, no numpy).
(c) the published toolbox's ``predict_freeRun`` (private venv, subprocess;
    its own timer, so process start-up is excluded).
(d) the floor: the same hand-written loop compiled by numba.

All predictions must agree to ``--rtol`` (max |Δ| / max |y|) before any
ratio is reported. The CLI part times two consecutive ``mggp simulate``
subprocesses on a fresh numba cache directory (the first compiles, the
second must load) and reports numba's own cache log (``NUMBA_DEBUG_CACHE``).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

MODEL33 = ("y[k-2]*u[k-1]*u[k-3]", "u[k-5]", "u[k-1]*u[k-5]*y[k-5]",
           "u[k-1]*u[k-3]*u[k-3]", "u[k-5]*y[k-4]*Phi2(u[k-4],u[k-1])",
           "u[k-5]*y[k-1]*Phi2(u[k-3],u[k-1])", "y[k-1]", "Phi1(u[k-5],u[k-1])",
           "Phi2(u[k-4],u[k-6])", "y[k-3]*y[k-8]*Phi2(u[k-4],u[k-1])",
           "y[k-5]*y[k-8]*Phi2(u[k-4],u[k-1])", "u[k-3]*u[k-3]*Phi2(u[k-4],u[k-1])",
           "u[k-1]*u[k-1]*u[k-3]", "u[k-1]*u[k-4]*Phi2(u[k-5],u[k-1])", "u[k-10]")
MAXLAG33 = 10


def model33_loop(u, y, th, out):
    """Free run of model (33) written out by hand (θ in the published order).

    Plain Python on lists for (b); the same source compiled by numba is the
    floor (d). ``y`` only supplies the first 10 samples.
    """
    n = len(u)
    for k in range(10):
        out[k] = y[k]
    for k in range(10, n):
        u1 = u[k - 1]
        u3 = u[k - 3]
        u4 = u[k - 4]
        u5 = u[k - 5]
        d = u4 - u1
        s41 = 1.0 if d > 0 else (-1.0 if d < 0 else 0.0)
        d = u3 - u1
        s31 = 1.0 if d > 0 else (-1.0 if d < 0 else 0.0)
        d = u4 - u[k - 6]
        s46 = 1.0 if d > 0 else (-1.0 if d < 0 else 0.0)
        d = u5 - u1
        s51 = 1.0 if d > 0 else (-1.0 if d < 0 else 0.0)
        y1 = out[k - 1]
        y5 = out[k - 5]
        y8 = out[k - 8]
        out[k] = (th[0] * out[k - 2] * u1 * u3 + th[1] * u5 + th[2] * u1 * u5 * y5
                  + th[3] * u1 * u3 * u3 + th[4] * u5 * out[k - 4] * s41
                  + th[5] * u5 * y1 * s31 + th[6] * y1 + th[7] * (u5 - u1)
                  + th[8] * s46 + th[9] * out[k - 3] * y8 * s41
                  + th[10] * y5 * y8 * s41 + th[11] * u3 * u3 * s41
                  + th[12] * u1 * u1 * u3 + th[13] * u1 * u4 * s51
                  + th[14] * u[k - 10])
    return out


def piezo_record(n: int):
    """(u, y) of the piezo actuator on the filtered random training input."""
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(n)
    return u, piezo_bouc_wen(u)


def best_of(fn, repeats: int):
    """(best seconds, all times, last result) of ``repeats`` calls."""
    times, res = [], None
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        res = fn()
        times.append(time.perf_counter() - t0)
    return min(times), times, res


def load_note() -> str:
    """``uptime``-style load averages, for the record."""
    try:
        a, b, c = os.getloadavg()
        return f"load average {a:.2f}, {b:.2f}, {c:.2f} on {os.cpu_count()} cores"
    except OSError:                              # pragma: no cover
        return "load unknown"


def rel_diff(a, b, y) -> float:
    """max |a - b| / max |y| (inf if shapes differ or values are not finite)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape or not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        return float("inf")
    return float(np.max(np.abs(a - b)) / np.max(np.abs(y)))


_FIRST_CALL = r"""
import json, sys, time
t0 = time.perf_counter()
import numpy as np, narx
t1 = time.perf_counter()
z = np.load(sys.argv[1])
m = narx.Model(json.loads(sys.argv[2]), theta=z["theta"])
t2 = time.perf_counter(); m.simulate(z["u"], z["y"], mode="freerun")
t3 = time.perf_counter(); m.simulate(z["u"], z["y"], mode="freerun")
t4 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "first": t3 - t2, "second": t4 - t3}))
"""


def first_call(npz: Path, terms, cache_dir=None) -> dict:
    """Import, first and second ``Model.simulate`` in a fresh process."""
    env = dict(os.environ)
    if cache_dir is not None:
        env["NUMBA_CACHE_DIR"] = str(cache_dir)
    out = subprocess.run([sys.executable, "-c", _FIRST_CALL, str(npz), json.dumps(list(terms))],
                         env=env, capture_output=True, text=True, timeout=600,
                         cwd=str(Path(__file__).resolve().parents[1]))
    if out.returncode:
        raise RuntimeError(f"first-call subprocess failed: {out.stderr[-500:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def run_freerun(n: int, repeats: int, peers: bool, rtol: float) -> dict:
    import narx
    from narx.records.data import as_data
    from narx.simulation.kernels import Plan, run_windows
    from numba import njit

    u, y = piezo_record(n)
    model = narx.Model(list(MODEL33)).fit(u, y)
    theta = model.theta
    res = {"n": n, "repeats": repeats, "terms": list(MODEL33), "theta": theta.tolist(),
           "load_before": load_note(), "rows": {}}
    rows = res["rows"]

    # (a) ours: first call in fresh processes, then steady state in-process
    with tempfile.TemporaryDirectory() as tmp:
        npz = Path(tmp) / "rec.npz"
        np.savez(npz, u=u, y=y, theta=theta)
        cold = first_call(npz, MODEL33, cache_dir=Path(tmp) / "numba-empty")
        warm = first_call(npz, MODEL33)
    rows["ours_first_call_compile"] = {"seconds": cold["first"], "import": cold["import"],
                                       "second": cold["second"]}
    rows["ours_first_call_cache_load"] = {"seconds": warm["first"], "import": warm["import"],
                                          "second": warm["second"]}
    model.simulate(u, y, mode="freerun")                       # warm in this process
    t, ts, r_ours = best_of(lambda: model.simulate(u, y, mode="freerun"), repeats)
    y_ours = r_ours.y_hat
    rows["ours_model_simulate"] = {"seconds": t, "times": ts}
    data = as_data(u, y)
    narx.simulate(model.terms, theta, data, "freerun")
    t, ts, r2 = best_of(lambda: narx.simulate(model.terms, theta, data, "freerun"), repeats)
    rows["ours_simulate_reused_data"] = {"seconds": t, "times": ts,
                                         "rel_diff": rel_diff(r2.y_hat, y_ours, y)}
    plan = Plan.from_terms(model.terms, data.inputs)
    P = plan.input_parts(data)
    starts = np.array([plan.maxlag])
    t, ts, (yk, _) = best_of(lambda: run_windows(plan, P, data.U, y, theta, starts,
                                                   n - plan.maxlag), repeats)
    yk[:plan.maxlag] = y[:plan.maxlag]
    rows["ours_kernel_only"] = {"seconds": t, "times": ts, "rel_diff": rel_diff(yk, y_ours, y)}

    # (b) plain Python, (d) numba floor: the same hand-written source
    t, ts, y_py = best_of(lambda: model33_loop(u.tolist(), y.tolist(), theta.tolist(),
                                               [0.0] * n), max(1, min(repeats, 3)))
    rows["python_loop"] = {"seconds": t, "times": ts, "rel_diff": rel_diff(y_py, y_ours, y)}
    floor = njit(model33_loop)
    t0 = time.perf_counter()
    floor(u, y, theta, np.empty(n))
    compile_s = time.perf_counter() - t0
    t, ts, y_fl = best_of(lambda: floor(u, y, theta, np.empty(n)), repeats)
    rows["numba_floor"] = {"seconds": t, "times": ts, "compile": compile_s,
                           "rel_diff": rel_diff(y_fl, y_ours, y)}

    # (c) the published toolbox
    if peers:
        rows["toolbox_predict_freeRun"] = _toolbox_row(u, y, theta, y_ours, min(repeats, 2))
    res["mape_train_freerun"] = float(r_ours.mape)
    res["load_after"] = load_note()
    return _ratios(res, rtol)


def _toolbox_row(u, y, theta, y_ours, repeats) -> dict:
    from benchmarks import peers as pe
    try:
        r = pe.toolbox_freerun(list(MODEL33), theta, u, y, repeats=repeats)
    except Exception as exc:                   # a driver failure is reported, not fatal
        return {"available": False, "reason": f"{type(exc).__name__}: {exc}"}
    if not r.get("available"):
        return {"available": False, "reason": r.get("reason", "unavailable")}
    return {"available": True, "seconds": r["seconds"], "times": r["times"],
            "rel_diff": rel_diff(r["y_hat"], y_ours, y),
            "versions": r.get("versions")}


def _ratios(res: dict, rtol: float) -> dict:
    rows = res["rows"]
    bad = {k: v["rel_diff"] for k, v in rows.items()
           if "rel_diff" in v and not v["rel_diff"] <= rtol}
    res["agree"] = not bad
    res["disagree"] = bad
    if bad:
        return res
    full = rows["ours_model_simulate"]["seconds"]
    kern = rows["ours_kernel_only"]["seconds"]
    fl = rows["numba_floor"]["seconds"]
    rat = {"python/ours": rows["python_loop"]["seconds"] / full,
           "python/kernel": rows["python_loop"]["seconds"] / kern,
           "ours/floor": full / fl, "kernel/floor": kern / fl,
           "reused_data/floor": rows["ours_simulate_reused_data"]["seconds"] / fl}
    tb = rows.get("toolbox_predict_freeRun")
    if tb and tb.get("available"):
        rat["toolbox/ours"] = tb["seconds"] / full
        rat["toolbox/kernel"] = tb["seconds"] / kern
    res["ratios"] = rat
    return res


def run_cli(n: int) -> dict:
    """Two consecutive ``mggp simulate`` calls on a fresh numba cache."""
    import narx
    u, y = piezo_record(n)
    model = narx.Model(list(MODEL33)).fit(u, y)
    exe = shutil.which("mggp")
    cmd0 = [exe] if exe else [sys.executable, "-m", "mggp"]
    out = {"command": " ".join(["mggp" if exe else "python -m mggp", "simulate",
                                "MODEL.json", "DATA.csv", "--out", "PRED.csv"]), "calls": []}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        model.save(str(tmp / "MODEL.json"))
        np.savetxt(tmp / "DATA.csv", np.column_stack([u, y]), delimiter=",",
                   header="u,y", comments="", fmt="%.17g")
        env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp / "numba-cache"), NUMBA_DEBUG_CACHE="1")
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import narx, mggp.cli.app"], env=env, check=True,
                       capture_output=True)
        out["import_seconds"] = time.perf_counter() - t0
        for i in range(2):
            t0 = time.perf_counter()
            p = subprocess.run(cmd0 + ["simulate", str(tmp / "MODEL.json"), str(tmp / "DATA.csv"),
                                       "--out", str(tmp / f"PRED{i}.csv")],
                               env=env, capture_output=True, text=True, timeout=600)
            wall = time.perf_counter() - t0
            log = p.stdout + p.stderr
            out["calls"].append({
                "seconds": wall, "returncode": p.returncode,
                "run_seconds": wall - out["import_seconds"],
                "kernel_cache_saved": _cache_lines(log, "data saved"),
                "kernel_cache_loaded": _cache_lines(log, "data loaded"),
                "printed": [ln for ln in p.stdout.splitlines() if not ln.startswith("[cache]")][-2:]})
    c = out["calls"]
    out["second_recompiled"] = bool(c[1]["kernel_cache_saved"])
    return out


def _cache_lines(log: str, what: str) -> int:
    """Lines of numba's cache log about the free-run kernel (narx.simulation.kernels._kernel)."""
    return sum(1 for ln in log.splitlines() if what in ln and "kernels._kernel" in ln)


def markdown(res: dict) -> str:
    """The tables of RESULTS.md from a result dict."""
    fr = res.get("freerun")
    lines = []
    if fr:
        rows = fr["rows"]
        lines += [f"Free run, model (33), N = {fr['n']:,}, best of {fr['repeats']} "
                  f"({fr['load_before']}):", "",
                  "| implementation | time per call | agrees (max abs diff / max abs y) |",
                  "|---|---:|---:|"]
        names = {"ours_first_call_compile": "ours, first call, empty numba cache (compile)",
                 "ours_first_call_cache_load": "ours, first call, on-disk cache (load)",
                 "ours_model_simulate": "ours, `Model.simulate(u, y)` (steady)",
                 "ours_simulate_reused_data": "ours, `narx.simulate` on a reused `Data`",
                 "ours_kernel_only": "ours, kernel only (`run_windows`)",
                 "python_loop": "plain Python loop (hand-written for this model)",
                 "toolbox_predict_freeRun": "published toolbox `predict_freeRun`",
                 "numba_floor": "floor: hand-written numba loop"}
        for k, label in names.items():
            v = rows.get(k)
            if v is None:
                continue
            if v.get("available") is False:
                lines.append(f"| {label} | {v['reason']} | |")
                continue
            agree = "reference" if k == "ours_model_simulate" else (
                f"{v['rel_diff']:.1e}" if "rel_diff" in v else "")
            lines.append(f"| {label} | {_fmt_s(v['seconds'])} | {agree} |")
        if fr.get("ratios"):
            lines += ["", "| ratio | value |", "|---|---:|"]
            lines += [f"| {k} | {v:,.1f}x |" for k, v in fr["ratios"].items()]
        elif not fr.get("agree", True):
            lines += ["", f"Predictions disagree: {fr['disagree']} (no ratios reported)."]
    cli = res.get("cli")
    if cli:
        lines += ["", f"CLI, `{cli['command']}` twice on a fresh numba cache "
                  f"(`import narx, mggp.cli.app` alone: {_fmt_s(cli['import_seconds'])}):", "",
                  "| call | wall | wall minus import | `_kernel` cache: saved / loaded |",
                  "|---|---:|---:|---:|"]
        for i, c in enumerate(cli["calls"]):
            lines.append(f"| {i + 1} | {_fmt_s(c['seconds'])} | {_fmt_s(c['run_seconds'])} | "
                         f"{c['kernel_cache_saved']} / {c['kernel_cache_loaded']} |")
    return "\n".join(lines)


def finish(res: dict, text: str, prog: str, argv, json_path) -> None:
    """Record the command, print the tables, write the JSON (if asked)."""
    res["command"] = f"python -m {prog} " + " ".join(argv if argv is not None else sys.argv[1:])
    print(text)
    if json_path:
        Path(json_path).write_text(json.dumps(res, indent=1, default=float))


def _fmt_s(s: float) -> str:
    if s >= 1:
        return f"{s:.2f} s"
    if s >= 1e-3:
        return f"{s * 1e3:.2f} ms"
    return f"{s * 1e6:.0f} µs"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks.speed", description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=50_000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--rtol", type=float, default=1e-9)
    ap.add_argument("--no-peers", action="store_true", help="skip the published toolbox")
    ap.add_argument("--no-cli", action="store_true", help="skip the mggp simulate timing")
    ap.add_argument("--json", metavar="F")
    a = ap.parse_args(argv)
    res = {"machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
           "python": platform.python_version()}
    res["freerun"] = run_freerun(a.n, a.repeats, not a.no_peers, a.rtol)
    if not a.no_cli:
        res["cli"] = run_cli(a.n)
    finish(res, markdown(res), "benchmarks.speed", argv, a.json)
    return 0 if res["freerun"]["agree"] else 1


if __name__ == "__main__":
    sys.exit(main())
