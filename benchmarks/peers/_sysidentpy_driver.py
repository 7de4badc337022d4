"""Driver for sysidentpy 0.9.0 (FROLS); run in its venv with ``python -I``.

One JSON job on stdin, one JSON line on stdout, arrays to ``job["out"]``
(.npz). Imports only sysidentpy, numpy and the standard library, never our
packages. sysidentpy 0.9.0 caps numpy at 2.3.5, below our environment's, so
it gets its own venv like the toolbox. Job::

    {"op": "frols", "data": npz, "out": npz, "inputs": ["u", "du"],
     "degree": 2, "ylag": 2, "xlag": 2, "info_criteria": "aic",
     "n_info_values": 15, "n_terms": null, "order_selection": true,
     "err_tol": null, "estimator": "least_squares"}

``data`` holds ``y``, ``x_<name>`` (training) and ``y_val``, ``xv_<name>``.
The result has the model code (``final_model``: rows of factor codes, 0 =
none, ``1000+j`` = y(k-j), ``(i+2)*1000+j`` = input i at lag j), θ, ERR, the
information-criterion curve, fit/predict seconds; ``y_val_hat`` (free run,
the first ``max_lag`` samples are the measured initial conditions) and
``y_train_osa`` go to the .npz.
"""
import contextlib
import json
import sys
import time
import traceback

import numpy as np


def op_versions(job):
    import importlib.metadata as md
    return {"toolbox_versions": {d: md.version(d) for d in
                                 ("sysidentpy", "numpy", "scipy", "matplotlib")}}


def _estimator(name):
    from sysidentpy.parameter_estimation import estimators as est
    table = {"least_squares": est.LeastSquares,
             "recursive_least_squares": est.RecursiveLeastSquares,
             "ridge_regression": est.RidgeRegression,
             "total_least_squares": est.TotalLeastSquares}
    if name not in table:
        raise ValueError(f"estimator must be one of {sorted(table)}")
    return table[name]()


def op_frols(job):
    from sysidentpy.basis_function import Polynomial
    from sysidentpy.model_structure_selection import FROLS
    with np.load(job["data"]) as z:
        arrays = {k: z[k] for k in z.files}
    names = job["inputs"]
    X = np.column_stack([arrays["x_" + n].reshape(-1) for n in names])
    Xv = np.column_stack([arrays["xv_" + n].reshape(-1) for n in names])
    y = arrays["y"].reshape(-1, 1)
    yv = arrays["y_val"].reshape(-1, 1)
    xlag = job.get("xlag", 2)
    if isinstance(xlag, int) and len(names) > 1:
        xlag = [xlag] * len(names)  # one range 1..xlag per input
    model = FROLS(
        order_selection=bool(job.get("order_selection", True)),
        n_info_values=int(job.get("n_info_values", 15)),
        info_criteria=job.get("info_criteria", "aic"),
        n_terms=job.get("n_terms"),
        err_tol=job.get("err_tol"),
        ylag=job.get("ylag", 2), xlag=xlag,
        estimator=_estimator(job.get("estimator", "least_squares")),
        basis_function=Polynomial(degree=int(job.get("degree", 2))),
        model_type="NARMAX",
    )
    t0 = time.perf_counter()
    model.fit(X=X, y=y)
    fit_seconds = time.perf_counter() - t0
    t0 = time.perf_counter()
    with np.errstate(all="ignore"):
        yv_hat = model.predict(X=Xv, y=yv)
    predict_seconds = time.perf_counter() - t0
    with np.errstate(all="ignore"):
        y_osa = model.predict(X=X, y=y, steps_ahead=1)
    np.savez(job["out"], y_val_hat=np.asarray(yv_hat, dtype=float).reshape(-1),
             y_train_osa=np.asarray(y_osa, dtype=float).reshape(-1))
    info = model.info_values
    return {"final_model": np.asarray(model.final_model).astype(int).tolist(),
            "theta": np.asarray(model.theta, dtype=float).reshape(-1).tolist(),
            "err": np.asarray(model.err, dtype=float).reshape(-1)[:len(model.final_model)].tolist(),
            "info_values": None if info is None else
            np.asarray(info, dtype=float).reshape(-1).tolist(),
            "n_terms": int(model.n_terms), "max_lag": int(model.max_lag),
            "fit_seconds": fit_seconds, "predict_seconds": predict_seconds}


OPS = {"versions": op_versions, "frols": op_frols}


def main():
    real_stdout = sys.stdout
    try:
        job = json.loads(sys.stdin.read())
        with contextlib.redirect_stdout(sys.stderr):
            result = OPS[job["op"]](job)
        result["ok"] = True
    except Exception as e:
        traceback.print_exc(file=sys.stderr)
        result = {"ok": False, "error": f"{type(e).__name__}: {e}"}
    real_stdout.write(json.dumps(result, default=float) + "\n")
    real_stdout.flush()
    return 0 if result["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
