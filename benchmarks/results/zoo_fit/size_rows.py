"""The size choice's candidates on zoo development draws, with their stress verdicts.

Typical call (from the project root)::

    python benchmarks/results/zoo_fit/size_rows.py FIT.jsonl ROWS.jsonl 60-109

Runs the zoo fit study (:func:`benchmarks.zoo_fit.fit_study`, development
seeds only, inside :func:`narx.systems.zoo.tuning`) and writes FIT.jsonl
as ``python -m benchmarks.zoo_fit calibrate`` does. Beside it, one line
per draw in ROWS.jsonl: every row the final size choice weighed
(:func:`mggp.fit.choices.size_choice`, wrapped here): its terms, held-out
free-run RMSE, the stress verdict (``why``, '' when it passes), its free
run's largest distance from the training output's mean on each stress
record (``exc``, in training-output ranges; None: diverges; the band is
:data:`mggp.fit.extrapolation.STRESS_BAND`), and the validation free-run
RMSE and explosion of the structure fitted by least squares on the whole
training record (``val``, ``exploded``: :func:`benchmarks.measured.explodes`);
``chosen``: the structure taken; ``ref``: the same figures of a linear
ARX model of two lags of each signal. Used to weigh the all-fail rule of
the stress inputs (``benchmarks/RESULTS.md``, section Measured-record panel,
Zoo fit). The final model's validation error differs from ``val``: the
extension and θ stages follow the size choice.
"""
import json
import sys
import warnings

import numpy as np

import benchmarks.zoo_fit as zf
import mggp.fit.stages as stages
from benchmarks.measured import explodes
from benchmarks.zoo import STUDY_N, parse_seeds
from mggp.fit.extrapolation import STRESS_BAND
from narx import Model
from narx.systems import zoo

CUR = {}


def excursions(model, check):
    """Largest distance of the free run from the band's middle on each stress
    record, in training-output ranges (None where it diverges)."""
    mid, span = 0.5 * (check.lo + check.hi), (check.hi - check.lo) / (2.0 * STRESS_BAND)
    out = []
    for _, rec in check.records:
        try:
            with np.errstate(all="ignore"):
                sim = model.simulate(rec, mode="freerun")
        except (ValueError, FloatingPointError):
            out.append(None)
            continue
        yh = np.asarray(sim.y_hat, float)[sim.valid]
        ok = not sim.diverged and np.all(np.isfinite(yh))
        out.append(float(np.max(np.abs(yh - mid)) / span) if ok and yh.size else
                   (0.0 if ok else None))
    return out


def validation(model, d):
    """``(RMSE or None, exploded)`` of the free run on the draw's validation record."""
    with np.errstate(all="ignore"):
        sim = model.simulate(d.validation, mode="freerun")
    ok, yh = np.asarray(sim.valid, bool), np.asarray(sim.y_hat, float)
    v = float(sim.rmse) if not sim.diverged and np.isfinite(sim.rmse) else None
    return v, bool(v is None or explodes(yh[ok], np.asarray(d.validation.y)[ok]))


def figures(terms, d, check) -> dict:
    """The stress and validation figures of ``terms`` fitted by LS on the training record."""
    out = {}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = Model(tuple(terms), inputs=d.train.inputs, output=d.train.output).fit(d.train)
            out["exc"] = excursions(m, check) if check is not None else None
            out["val"], out["exploded"] = validation(m, d)
    except (ValueError, np.linalg.LinAlgError, FloatingPointError) as exc:
        out["error"] = str(exc)
    return out


ORIGINAL = stages.size_choice


def probed(rows, n_heldout=0, check=None):
    c = ORIGINAL(rows, n_heldout, check)
    d = CUR["draw"]
    lst = [dict(n=r[0], held=float(r[1]) if np.isfinite(r[1]) else None,
                terms=[str(t) for t in r[2]], why=check(r[2]) if check is not None else "",
                **figures(r[2], d, check)) for r in rows]
    ref = ["y[k-1]", "y[k-2]"] + [f"{v}[k-{i}]" for v in d.train.inputs for i in (1, 2)]
    CUR.setdefault("calls", []).append(dict(rows=lst, chosen=[str(t) for t in c.value],
                                            n_heldout=n_heldout, ref=figures(ref, d, check)))
    return c


def main(fit_path, rows_path, seeds):
    stages.size_choice = probed
    plain = zf.fit_one

    def fit_one(seed, jobs=1, extend=None):
        CUR.clear()
        CUR["draw"] = zoo.draw(seed, n=STUDY_N)
        rec = plain(seed, jobs, extend)
        with open(rows_path, "a", encoding="utf-8") as fh:
            fh.write(json.dumps(dict(seed=seed, family=rec["family"],
                                     calls=CUR.get("calls", []), fit_rmse=rec.get("fit_rmse"),
                                     oracle_rmse=rec.get("oracle_rmse"),
                                     exploded=rec.get("exploded"),
                                     stress=rec.get("stress"))) + "\n")
        return rec

    zf.fit_one = fit_one
    with zoo.tuning():
        for s in seeds:
            zoo.guard(s)
        zf.fit_study(seeds, fit_path, 1)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], parse_seeds(sys.argv[3:]))
