"""The class choice of the default fit on zoo draws, without the rest of the fit.

Typical call (from the project root)::

    python benchmarks/results/zoo_fit/class_only.py OUT.jsonl 1150-1203 1221-1251

Runs ``MGGPRegressor(random_state=seed)`` on each draw's training record
and stops it right after :func:`mggp.fit.choices.class_choice` (patched
here to raise), writing one line per draw: ``seed, family, class, why,
errors`` (each pilot's held-out RMSE). The pilots share one seed and a
class's continuation does not depend on the other classes, so a draw whose
class is the one an earlier run of the fit took is fitted as that run
fitted it; only the draws whose class moved need the full fit
(``python -m benchmarks.zoo_fit fit``). Used for the rerun of the
evaluation draws after the class with Φ of the output's lags joined the
pilots (``benchmarks/RESULTS.md``).
"""
import sys
import time
import warnings

import mggp.fit.estimator as E
from benchmarks.zoo import STUDY_N, parse_seeds, resume
from mggp import MGGPRegressor
from narx.systems import zoo

warnings.simplefilter("ignore")


class Stop(Exception):
    """Raised with the class choice, to end the fit there."""


_class_choice = E.class_choice


def _stop_after_class_choice(*a, **k):
    raise Stop(_class_choice(*a, **k))


def one(seed: int) -> dict:
    """The class choice of the default fit on draw ``seed``."""
    t = time.perf_counter()
    d = zoo.draw(seed, n=STUDY_N)
    rec = {"seed": seed, "family": d.family}
    try:
        MGGPRegressor(random_state=seed, n_jobs=1).fit(d.train)
        rec["class"] = None
    except Stop as s:
        c = s.args[0]
        rec.update({"class": c.figures["class"], "why": c.why,
                    "errors": {k: float(v) for k, v in c.figures.items()
                               if k.startswith("heldout_rmse_")}})
    except Exception as exc:
        rec["error"] = f"{type(exc).__name__}: {exc}"
    rec["seconds"] = time.perf_counter() - t
    return rec


if __name__ == "__main__":
    E.class_choice = _stop_after_class_choice
    resume(parse_seeds(sys.argv[2:]), sys.argv[1], one,
           lambda r: print(r["seed"], r.get("class"), round(r["seconds"]), flush=True))
