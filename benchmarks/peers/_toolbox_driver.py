"""Driver for the published MGGP toolbox (PyPI ``mggp`` 1.0.0); run in its venv.

Run as ``<toolbox venv>/bin/python -I _toolbox_driver.py`` with one JSON job on
stdin; writes one JSON line on stdout (arrays go to the ``.npz`` at
``job["out"]``). It imports only the toolbox (``mggp``, the *peer's* module,
not ours), numpy and the standard library: it must never import our
``mggp``/``narx`` packages. Jobs (built by ``benchmarks.peers``)::

    {"op": "versions"}
    {"op": "freerun",  "data": npz, "out": npz, "variables": [...],
     "trees": ["mul(q1(y1), u1)", ...], "theta": [...], "repeats": 3}
    {"op": "ls_score", ..., "trees": [...], "k": 10, "fitness": "ms", "repeats": 5}
    {"op": "fit", ..., "population": 50, "generations": 10, "max_terms": 15,
     "max_height": 5, "seed": 0, "fitness": "ms", "k": 10, "time_limit": 600}

``data`` holds ``y`` and ``x_<signal>`` (training / the simulated record) and,
for ``fit``, ``y_val`` and ``xv_<signal>``. ``variables`` is the toolbox's
argument list, output first: ``{"arg": "u1", "signal": "u", "lead": false}``;
a ``lead`` variable is the signal advanced one sample (the toolbox has no
lag-0 terminal).
"""
import contextlib
import json
import random
import sys
import time
import traceback

import numpy as np

FIT_SCORES = {"ms": "ksa", "ksa": "ksa", "pem": "osa", "osa": "osa", "freerun": "freeRun"}


def phi1(a, b):
    return a - b


def phi2(a, b):
    return np.sign(a - b)


class Deadline(BaseException):
    """Raised inside the toolbox's loop when the time limit has passed."""


def load_arrays(job):
    with np.load(job["data"]) as z:
        return {k: z[k] for k in z.files}


def columns(arrays, variables, prefix_y="y", prefix_x="x_"):
    """Output as a column and the toolbox's input variables (lead = advanced)."""
    y = arrays[prefix_y].reshape(-1, 1)
    xs = []
    for v in variables[1:]:
        x = arrays[prefix_x + v["signal"]].astype(float).reshape(-1)
        if v["lead"]:
            x = np.append(x[1:], x[-1])
        xs.append(x.reshape(-1, 1))
    return y, xs


def make_element(variables, phi=True, constant=False, max_delay=3):
    import mggp  # the published toolbox, in this venv only
    el = mggp.mggpElement()
    el.setPset(maxDelay=max_delay, numberOfVariables=len(variables), MA=False,
               constant=constant)
    el.renameArguments({f"ARG{i}": v["arg"] for i, v in enumerate(variables)})
    if phi:
        el.addPrimitive(phi1, 2, "Phi1")
        el.addPrimitive(phi2, 2, "Phi2")
    return el


def build(el, trees):
    model = el.createModel(list(trees))
    el.compile_model(model)
    return model


def score(el, model, theta, y, xs, fitness, k):
    kind = FIT_SCORES[fitness]
    if kind == "ksa":
        return float(el.score_ksa(model, theta, int(k), y, *xs))
    if kind == "osa":
        return float(el.score_osa(model, theta, y, *xs))
    return float(el.score_freeRun(model, theta, y, *xs))


def op_versions(job):
    import importlib.metadata as md
    import mggp
    return {"module_file": mggp.__file__,
            "toolbox_versions": {d: md.version(d) for d in
                                 ("mggp", "deap", "numpy", "scipy", "scikit-learn")}}


def op_freerun(job):
    arrays = load_arrays(job)
    variables, trees = job["variables"], job["trees"]
    el = make_element(variables, constant="1" in trees)
    y, xs = columns(arrays, variables)
    model = build(el, trees)
    theta = np.asarray(job["theta"], dtype=float)
    times, yhat = [], None
    for _ in range(max(1, int(job.get("repeats", 1)))):
        t0 = time.perf_counter()
        yhat = el.predict_freeRun(model, theta, y, *[x[:-1] for x in xs])
        times.append(time.perf_counter() - t0)
    np.savez(job["out"], y_hat=np.asarray(yhat, dtype=float).reshape(-1))
    return {"seconds": min(times), "times": times, "lag_max": int(model.lagMax),
            "n_samples": int(y.shape[0])}


def op_ls_score(job):
    arrays = load_arrays(job)
    variables, trees = job["variables"], job["trees"]
    el = make_element(variables, constant="1" in trees)
    y, xs = columns(arrays, variables)
    fitness, k = job.get("fitness", "ms"), job.get("k", 10)
    model = el.createModel(list(trees))
    rows = []
    for _ in range(max(1, int(job.get("repeats", 1)))):
        t0 = time.perf_counter()
        el.compile_model(model)
        t1 = time.perf_counter()
        theta = el.ls(model, y, *xs)
        t2 = time.perf_counter()
        s = score(el, model, theta, y, xs, fitness, k)
        t3 = time.perf_counter()
        rows.append((t3 - t0, t1 - t0, t2 - t1, t3 - t2))
    best = min(rows)
    return {"seconds": best[0], "mean_seconds": float(np.mean([r[0] for r in rows])),
            "times": [r[0] for r in rows], "compile_seconds": best[1],
            "ls_seconds": best[2], "score_seconds": best[3], "score": s,
            "theta": np.asarray(theta, dtype=float).reshape(-1).tolist(),
            "lag_max": int(model.lagMax), "n_samples": int(y.shape[0])}


def op_fit(job):
    import mggp
    arrays = load_arrays(job)
    variables = job["variables"]
    phi = bool(job.get("phi", True))
    el = make_element(variables, phi=phi)
    y, xs = columns(arrays, variables)
    yv, xvs = columns(arrays, variables, "y_val", "xv_")
    fitness, k = job.get("fitness", "ms"), job.get("k", 10)
    if fitness not in FIT_SCORES:
        raise ValueError(f"fitness must be one of {sorted(FIT_SCORES)}")
    seed = int(job.get("seed", 0))
    random.seed(seed)
    np.random.seed(seed)
    evolver = mggp.mggpEvolver(
        popSize=int(job["population"]), CXPB=float(job.get("crossover", 0.8)),
        MTPB=float(job.get("mutation", 0.2)), n_gen=int(job["generations"]),
        maxHeight=int(job.get("max_height", 5)), maxTerms=int(job.get("max_terms", 15)),
        verbose=False, elite=float(job.get("elite", 10)), element=el)
    # Φ arguments: lagged inputs only, as in the published setup (the
    # toolbox's constraint_funcs matches renamed terminals by default name).
    input_terms = [t for t in el.getTerminalsObjects() if t.name != "ARG0"
                   and t.name != "1"]
    banned = ["ARG0", "mul", "Phi1", "Phi2"]
    state = {"evals": 0, "gens": 0, "best": (np.inf, None), "timed_out": False}
    select = evolver._toolbox.select

    def counting_select(*a, **kw):
        state["gens"] += 1
        return select(*a, **kw)
    evolver._toolbox.register("select", counting_select)
    limit = job.get("time_limit")
    t_start = time.perf_counter()
    deadline = t_start + float(limit) if limit else None

    def evaluate(ind):
        if deadline is not None and time.perf_counter() > deadline:
            state["timed_out"] = True
            raise Deadline()
        state["evals"] += 1
        try:
            if phi and job.get("phi_inputs_only", True):
                el.constraint_funcs(ind, ["Phi1", "Phi2"], banned, input_terms)
            el.compile_model(ind)
            theta = el.ls(ind, y, *xs)
            fit = score(el, ind, theta, y, xs, fitness, k)
        except Exception:  # singular LS, blow-up, shape trouble: the toolbox's way
            fit = np.inf
        if not np.isfinite(fit):
            fit = np.inf
        if fit < state["best"][0]:
            state["best"] = (fit, el.model2List(ind))
        return (fit,)
    try:
        evolver.run(evaluate=evaluate)
    except Deadline:
        pass
    fit_seconds = time.perf_counter() - t_start
    best_fit, trees = state["best"]
    out = {"fit_seconds": fit_seconds, "evaluations": state["evals"],
           "generations_started": state["gens"], "timed_out": state["timed_out"],
           "generations_completed": state["gens"] - (1 if state["timed_out"] else 0),
           "fitness_value": best_fit, "trees": trees}
    if trees is None:
        return dict(out, theta=None, error_note="no individual got a finite fitness")
    model = build(el, trees)
    theta = el.ls(model, y, *xs)
    t0 = time.perf_counter()
    yv_hat = el.predict_freeRun(model, theta, yv, *[x[:-1] for x in xvs])
    out["predict_val_seconds"] = time.perf_counter() - t0
    arrays_out = {"y_val_hat": np.asarray(yv_hat, dtype=float).reshape(-1)}
    if job.get("freerun_train"):
        yt = el.predict_freeRun(model, theta, y, *[x[:-1] for x in xs])
        arrays_out["y_train_hat"] = np.asarray(yt, dtype=float).reshape(-1)
    np.savez(job["out"], **arrays_out)
    out.update(theta=np.asarray(theta, dtype=float).reshape(-1).tolist(),
               lag_max=int(model.lagMax), lag_maxes=[int(t.lagMax) for t in model])
    return out


OPS = {"versions": op_versions, "freerun": op_freerun, "ls_score": op_ls_score,
       "fit": op_fit}


def main():
    real_stdout = sys.stdout
    try:
        job = json.loads(sys.stdin.read())
        with contextlib.redirect_stdout(sys.stderr):  # the toolbox prints
            result = OPS[job["op"]](job)
        result["ok"] = True
    except Exception as e:  # reported to the caller, which raises PeerError
        traceback.print_exc(file=sys.stderr)
        result = {"ok": False, "error": f"{type(e).__name__}: {e}"}
    real_stdout.write(json.dumps(result, default=float) + "\n")
    real_stdout.flush()
    return 0 if result["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
