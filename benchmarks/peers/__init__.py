"""Peer tools, timed on the same machine in the same run: the published MGGP
toolbox (PyPI ``mggp`` 1.0.0) and sysidentpy 0.9.0 (FROLS).

Both run in private venvs (``benchmarks/.peers/<name>/``, see :mod:`.envs`)
through driver scripts in subprocesses: the toolbox's top-level module is
also called ``mggp`` and it needs scikit-learn without declaring it;
sysidentpy 0.9.0 caps numpy at 2.3.5, below ours, so it is isolated the same
way. Terms are given as canonical text or the neutral structure of
:mod:`.terms`. Every function returns a dict with ``available``, ``reason``
and ``versions``; when a venv cannot be built (no network) it returns
``{"available": False, "reason": "unavailable: ..."}`` instead of raising.
A driver that fails on a job raises :class:`PeerError`.

Typical use::

    from benchmarks import peers
    r = peers.toolbox_freerun(["y[k-1]", "u[k-1]"], [0.5, 1.0], u, y)
    r["seconds"], r["y_hat"]            # best wall time, prediction (len N)
    s = peers.toolbox_ls_ms_score(terms, u, y, k=10)   # s["seconds"], s["score"]
    f = peers.toolbox_fit(u, y, uv, yv, population=50, generations=5, time_limit=300)
    g = peers.sysidentpy_frols(u, y, uv, yv, degree=2, ylag=2, xlag=2,
                               extra_inputs=peers.phi_inputs(u, uv))

What the published toolbox is (read from its installed source, ``mggp.py``,
843 lines, one module):

- ``mggpElement()`` holds a DEAP primitive set: ``mul`` and back-shifts
  ``q1..q<maxDelay>`` (``q_i(x)`` = ``np.roll(x, i)``, i.e. x delayed i
  samples), terminals ``ARG0..`` renamed to ``y1``, ``u1`` (one-step-lagged
  signals, ``y1`` = y[k-1]; the output must be ARG0), optional terminal
  ``1``. ``setPset(maxDelay=3, numberOfVariables=2, MA=False,
  constant=False)``, ``renameArguments({...})``, ``addPrimitive(f, arity,
  name)`` (we add ``Phi1``, ``Phi2``). A model is a ``creator.Individual``
  (list of ``PrimitiveTree``) built by ``createModel(["mul(q1(y1), u1)",
  ...])`` and ``compile_model(model)``, which also sets ``model.lagMax`` =
  the longest chain of q's (model max lag = lagMax + 1). There is no lag-0
  terminal: we feed ``u[k]`` as an extra variable ``u0`` = u advanced one
  sample.
- ``ls(model, y, *inputs)``: regressors from ``y[:-1], u[:-1]`` (rolls wrap
  around; the first lagMax rows are dropped), ``inv(P'P) P' y[lagMax+1:]``;
  raises ``LinAlgError`` if ``cond(P, -2) < 1e-10``.
- ``predict_freeRun(model, theta, y0, *inputs)``: a Python loop that at each
  step rebuilds the regressors of a (lagMax+1)-sample window by calling every
  compiled tree, then ``np.vstack``s the new sample onto the output (quadratic
  copying). Called with ``u[:-1]`` it returns N samples, the first lagMax+1
  being the measured initial conditions.
- ``score_ksa(model, theta, k, y, *inputs)`` (via ``predict_ksa``): despite
  the name it is multiple shooting: the record is cut into non-overlapping
  windows of lagMax+1+k samples (the remainder is dropped), each simulated k
  steps from measured initial conditions, all windows at once (3-D arrays;
  the ``k_pset`` rolls along axis 1); MSE over the simulated samples (sklearn
  ``mean_squared_error``; ValueError on NaN/inf -> ``inf``). Our ``ms`` and
  ``ksa`` fitness names both map to it. Also ``score_osa``,
  ``score_freeRun``, ``ols`` (pruning), ``constraint_funcs``.
- ``mggpEvolver(popSize, CXPB, MTPB, n_gen, maxHeight, maxTerms, verbose,
  elite, element).run(evaluate)`` returns ``(hof, logbook)`` (its README says
  just the hall of fame); the user writes ``evaluate(ind) -> (fitness,)``
  (compile, LS, score). Uses both ``random`` and ``np.random``; no time limit
  (we stop it from inside ``evaluate`` and keep the best individual seen).
- Quirks: ``import sklearn`` undeclared; ``np.AxisError`` (gone in numpy 2)
  in an except clause, so we pin numpy 1.26; ``renameArguments`` changes a
  terminal's value but not its ``.name``, so ``constraint_funcs`` must be
  given ``'ARG0'``, not ``'y1'``; the README's ``constraint_1arityFuncs`` /
  ``constraint_2arityFuncs`` do not exist; ``q`` over a ``mul``/Φ subtree
  (possible after crossover) delays the whole subtree, but the ``lagMax``
  scan then sums every q under it (too large) or skips the rest of the tree
  (``mul(q1(mul(u1, u1)), q3(q3(u1)))`` gets lagMax 1 for a lag of 7: its LS
  and free run use wrapped-around samples; ``toolbox_fit`` flags this as
  ``lag_quirk``); ``warnings`` are silenced globally on import.
"""
from __future__ import annotations

import time
from typing import Mapping, Optional, Sequence, Union

import numpy as np

from .envs import PEERS, PeerError, ensure_env, peers_dir, run_driver
from .terms import (as_struct, from_toolbox, max_lag, parse_term, parse_terms,
                    term_text, to_toolbox, toolbox_variables)

__all__ = ["toolbox_freerun", "toolbox_ls_ms_score", "toolbox_fit", "sysidentpy_frols",
           "phi_inputs", "mape", "ensure_env", "PeerError", "PEERS", "peers_dir",
           "parse_term", "parse_terms", "term_text"]

Inputs = Union[np.ndarray, Sequence[float], Mapping[str, np.ndarray]]


def _inputs(u: Inputs) -> dict:
    if isinstance(u, Mapping):
        return {str(k): np.asarray(v, dtype=float).reshape(-1) for k, v in u.items()}
    return {"u": np.asarray(u, dtype=float).reshape(-1)}


def _data(y, xs: dict, prefix_y="y", prefix_x="x_") -> dict:
    y = np.asarray(y, dtype=float).reshape(-1)
    for name, x in xs.items():
        if x.shape != y.shape:
            raise ValueError(f"input {name!r} has {x.size} samples, output {y.size}")
    return {prefix_y: y, **{prefix_x + k: v for k, v in xs.items()}}


def mape(y, y_hat, start: int = 0) -> float:
    """Range-normalised MAPE in % (the published metric), from sample ``start``;
    ``inf`` if the prediction is not finite."""
    y = np.asarray(y, dtype=float).reshape(-1)[start:]
    y_hat = np.asarray(y_hat, dtype=float).reshape(-1)[start:]
    if y_hat.shape != y.shape or not np.all(np.isfinite(y_hat)):
        return float("inf")
    span = float(y.max() - y.min())
    return float(100.0 * np.mean(np.abs(y - y_hat)) / span) if span > 0 else float("inf")


def phi_inputs(u_train, u_val=None, name: str = "u") -> dict:
    """Φ-like extra inputs for FROLS: ``d<name>[k] = u[k] - u[k-1]`` and
    ``s<name>[k] = sign(d<name>[k])`` (0 at k = 0). With lag j they are
    ``Phi1(u[k-j],u[k-j-1])`` and ``Phi2(...)``. Returns ``{name: (train,
    val)}`` (val None if ``u_val`` is None), ready for ``extra_inputs``."""
    def d(x):
        x = np.asarray(x, dtype=float).reshape(-1)
        return np.concatenate([[0.0], np.diff(x)])
    dt = d(u_train)
    dv = None if u_val is None else d(u_val)
    return {f"d{name}": (dt, dv),
            f"s{name}": (np.sign(dt), None if dv is None else np.sign(dv))}


def _model(terms, output: str, inputs: Sequence[str]):
    structs = parse_terms(terms)
    if not structs:
        raise ValueError("a model needs at least one term")
    for t in structs:
        for f in t:
            if f["kind"] == "phi" and f["name"] not in ("Phi1", "Phi2"):
                raise ValueError(f"the toolbox driver knows Phi1 and Phi2, not {f['name']}")
    variables = toolbox_variables(structs, output, list(inputs))
    return structs, variables, [to_toolbox(t) for t in structs]


def toolbox_freerun(terms, theta, u: Inputs, y, repeats: int = 3, *,
                    output: str = "y", timeout: Optional[float] = None) -> dict:
    """Free-run the given model with the toolbox's ``predict_freeRun``.

    Initial conditions are the first ``max_lag`` samples of ``y``. Returns
    ``seconds`` (best of ``repeats``), ``times``, ``y_hat`` (N samples, the
    first ``max_lag`` measured), ``max_lag``, ``trees`` (the model as the
    toolbox's strings), ``terms`` (text), plus ``available``/``versions``.
    """
    xs = _inputs(u)
    structs, variables, trees = _model(terms, output, xs)
    theta = np.asarray(theta, dtype=float).reshape(-1)
    if theta.size != len(structs):
        raise ValueError(f"{len(structs)} terms but {theta.size} parameters")
    job = {"op": "freerun", "variables": variables, "trees": trees,
           "theta": theta.tolist(), "repeats": int(repeats)}
    res = run_driver("toolbox", job, _data(y, xs), timeout=timeout)
    res.update(terms=[term_text(t, output) for t in structs], trees=trees,
               max_lag=max(max_lag(structs), 1))
    return res


def toolbox_ls_ms_score(terms, u: Inputs, y, *, k: int = 10, fitness: str = "ms",
                        repeats: int = 5, output: str = "y",
                        timeout: Optional[float] = None) -> dict:
    """Time one toolbox fitness evaluation: ``compile_model`` + ``ls`` +
    ``score_ksa`` (windows of lagMax+1+k samples; ``fitness="pem"`` uses
    ``score_osa``, ``"freerun"`` ``score_freeRun``), ``repeats`` times.

    Returns ``seconds`` (best per evaluation), ``mean_seconds``, the split
    ``compile_seconds``/``ls_seconds``/``score_seconds``, ``score`` (MSE),
    ``theta`` (the toolbox's LS), ``trees``, ``terms``.
    """
    xs = _inputs(u)
    structs, variables, trees = _model(terms, output, xs)
    job = {"op": "ls_score", "variables": variables, "trees": trees, "k": int(k),
           "fitness": fitness, "repeats": int(repeats)}
    res = run_driver("toolbox", job, _data(y, xs), timeout=timeout)
    res.update(terms=[term_text(t, output) for t in structs], trees=trees)
    return res


def toolbox_fit(u_train: Inputs, y_train, u_val: Inputs, y_val, population: int = 50,
                generations: int = 10, max_terms: int = 15, max_height: int = 5,
                seed: int = 0, fitness: str = "ms", *, k: int = 10,
                time_limit: Optional[float] = 600.0, crossover: float = 0.8,
                mutation: float = 0.2, elite: float = 10.0, phi: bool = True,
                freerun_train: bool = False, output: str = "y",
                timeout: Optional[float] = None) -> dict:
    """Run the toolbox's own MGGP search (``mggpEvolver.run``) with the
    published primitives (×, Φ1, Φ2, q1..q3; terminals y[k-1], u[k-1]; Φ
    arguments restricted to inputs) and LS + ``fitness`` (``ms``/``ksa`` ->
    ``score_ksa`` with ``k``; ``pem``; ``freerun``).

    ``time_limit`` (s) stops the search from inside the evaluation; the best
    individual evaluated so far is kept. Returns ``fit_seconds`` (search),
    ``wall_seconds`` (whole subprocess), ``generations_completed``,
    ``evaluations``, ``timed_out``, ``fitness_value``, ``terms`` (our text
    where the tree is expressible, else the toolbox's string), ``trees``,
    ``theta``, ``y_val_hat`` (free run on validation), ``val_mape``,
    ``lag_quirk`` (the toolbox under-counted some tree's lag; then its
    prediction is not that of ``terms``).
    """
    xs, xvs = _inputs(u_train), _inputs(u_val)
    if list(xs) != list(xvs):
        raise ValueError("training and validation inputs differ")
    variables = toolbox_variables([], output, list(xs))
    arrays = {**_data(y_train, xs), **_data(y_val, xvs, "y_val", "xv_")}
    job = {"op": "fit", "variables": variables, "population": int(population),
           "generations": int(generations), "max_terms": int(max_terms),
           "max_height": int(max_height), "seed": int(seed), "fitness": fitness,
           "k": int(k), "time_limit": time_limit, "crossover": crossover,
           "mutation": mutation, "elite": elite, "phi": bool(phi),
           "freerun_train": bool(freerun_train)}
    if timeout is None and time_limit:
        timeout = 3 * float(time_limit) + 600
    t0 = time.perf_counter()
    res = run_driver("toolbox", job, arrays, timeout=timeout)
    if not res["available"]:
        return res
    res["wall_seconds"] = time.perf_counter() - t0
    trees = res.get("trees") or []
    structs = [from_toolbox(t, variables) for t in trees]
    res["terms_struct"] = structs
    res["terms"] = [term_text(s, output) if s is not None else t
                    for s, t in zip(structs, trees)]
    # True if the toolbox's lagMax scan undercounts a tree (q over a subtree):
    # its LS and free run then use wrapped-around samples for that tree.
    res["lag_quirk"] = any(s is not None and max_lag([s]) > lm + 1
                           for s, lm in zip(structs, res.get("lag_maxes") or []))
    if "y_val_hat" in res:
        start = max(res.get("lag_max", 0) + 1, 1)
        res["val_mape"] = mape(y_val, res["y_val_hat"], start)
        if "y_train_hat" in res:
            res["train_mape"] = mape(y_train, res["y_train_hat"], start)
    return res


def _sysid_terms(final_model, output: str, names: Sequence[str]) -> list:
    terms = []
    for row in final_model:
        fs = []
        for c in row:
            c = int(c)
            if c == 0:
                continue
            group, lag = divmod(c, 1000)
            sig = output if group == 1 else names[group - 2]
            fs.append({"kind": "lag", "signal": sig, "lag": lag})
        terms.append(term_text(fs, output))
    return terms


def sysidentpy_frols(u_train: Inputs, y_train, u_val: Inputs, y_val, degree: int = 2,
                     ylag=2, xlag=2, extra_inputs: Optional[Mapping] = None, *,
                     info_criteria: str = "aic", n_info_values: int = 15,
                     n_terms: Optional[int] = None, order_selection: bool = True,
                     err_tol: Optional[float] = None, estimator: str = "least_squares",
                     output: str = "y", timeout: Optional[float] = None) -> dict:
    """FROLS (ERR ranking, information-criterion order selection, least
    squares) fitted by one-step prediction, then a free run on validation.

    ``extra_inputs`` maps a name to ``(train, val)`` arrays appended as input
    columns (e.g. :func:`phi_inputs`). ``xlag`` is an int (the same lags
    1..xlag for every input) or sysidentpy's per-input list. Returns
    ``fit_seconds``, ``predict_seconds``, ``terms`` (our text), ``theta``,
    ``err``, ``info_values``, ``y_val_hat`` (N, first ``max_lag`` measured),
    ``val_mape``, ``diverged``, ``y_train_osa``.
    """
    xs, xvs = _inputs(u_train), _inputs(u_val)
    if list(xs) != list(xvs):
        raise ValueError("training and validation inputs differ")
    for name, (tr, va) in (extra_inputs or {}).items():
        if name in xs or name == output:
            raise ValueError(f"extra input {name!r} clashes with a signal name")
        xs[name] = np.asarray(tr, dtype=float).reshape(-1)
        xvs[name] = np.asarray(va, dtype=float).reshape(-1)
    names = list(xs)
    arrays = {**_data(y_train, xs), **_data(y_val, xvs, "y_val", "xv_")}
    job = {"op": "frols", "inputs": names, "degree": int(degree), "ylag": ylag,
           "xlag": xlag, "info_criteria": info_criteria,
           "n_info_values": int(n_info_values), "n_terms": n_terms,
           "order_selection": bool(order_selection), "err_tol": err_tol,
           "estimator": estimator}
    res = run_driver("sysidentpy", job, arrays, timeout=timeout)
    if not res["available"]:
        return res
    res["terms"] = _sysid_terms(res["final_model"], output, names)
    yv = np.asarray(y_val, dtype=float).reshape(-1)
    res["val_mape"] = mape(yv, res["y_val_hat"], res["max_lag"])
    yh = res["y_val_hat"]
    span = float(yv.max() - yv.min()) or 1.0
    res["diverged"] = bool(not np.all(np.isfinite(yh))
                           or np.max(np.abs(yh - yv)) > 10 * span)
    return res
