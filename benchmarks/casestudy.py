"""The published piezo-actuator case study: data, published figures, scoring.

Typical use::

    from benchmarks.casestudy import case_data, score_model, MODEL19
    cs = case_data(n=50_000, seed=0)
    row = score_model(model, cs)      # train/val MAPE, RMSE, hold drift, ss errors

Data (the published case study, Abreu et al. 2020): training input a filtered pseudo-random signal spanning
±80 V with about 1 Hz bandwidth, N samples at 1 ms; validation
u = 40 sin(2πt), 5 s; the held-input sine (input frozen for 1 s once while
rising, once while falling) for steady-state checks; all passed through
the RK4 Bouc-Wen piezo model. Metric: range-normalised MAPE (%).

Hold metrics, for each hold: *drift* = max − min of the simulated output
over the hold after a settling time of ``settle`` samples (the model's
regressors need up to its largest lag to see the frozen input, and its
linear output dynamics a few more samples to settle); *steady-state error*
= |ŷ − y| at the end of the hold, against the true system; and over both
holds the *edge error*, the largest |ŷ − y| within 20 samples after the
input stops or starts again (:func:`edge_error`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Optional

import numpy as np

from narx import Model
from narx.systems import held_sine, piezo_bouc_wen, sine_input, training_input

__all__ = ["CaseData", "case_data", "score_model", "hold_metrics", "MODEL19", "PUBLISHED",
           "MODEL33_TERMS", "MODEL32_TERMS", "model19"]

MODEL19 = {
    "terms": ["y[k-1]", "Phi1(u[k-2],u[k-3])",
              "Phi2(u[k-2],u[k-3])*Phi1(u[k-2],u[k-3])*u[k-2]",
              "Phi2(u[k-2],u[k-3])*Phi1(u[k-2],u[k-3])*y[k-1]",
              "Phi1(u[k-2],u[k-3])*u[k-2]*u[k-2]",
              "Phi1(u[k-2],u[k-3])*u[k-2]*y[k-1]",
              "Phi2(u[k-2],u[k-3])*y[k-1]", "Phi1(u[k-1],u[k-2])",
              "Phi2(u[k-2],u[k-3])*Phi1(u[k-2],u[k-3])*Phi1(u[k-2],u[k-3])"],
    "theta": [1.0, -0.2310, 0.0146, -0.0099, 3.2333e-4, -2.5494e-4, 1.7891e-5, 1.0080,
              -0.0604],
}

MODEL33_TERMS = ["y[k-2]*u[k-1]*u[k-3]", "u[k-5]", "u[k-1]*u[k-5]*y[k-5]",
                 "u[k-1]*u[k-3]*u[k-3]", "u[k-5]*y[k-4]*Phi2(u[k-4],u[k-1])",
                 "u[k-5]*y[k-1]*Phi2(u[k-3],u[k-1])", "y[k-1]", "Phi1(u[k-5],u[k-1])",
                 "Phi2(u[k-4],u[k-6])", "y[k-3]*y[k-8]*Phi2(u[k-4],u[k-1])",
                 "y[k-5]*y[k-8]*Phi2(u[k-4],u[k-1])", "u[k-3]*u[k-3]*Phi2(u[k-4],u[k-1])",
                 "u[k-1]*u[k-1]*u[k-3]", "u[k-1]*u[k-4]*Phi2(u[k-5],u[k-1])", "u[k-10]"]

MODEL32_TERMS = ["u[k-1]*u[k-4]*y[k-1]", "u[k-2]*u[k-4]", "u[k-3]*y[k-1]",
                 "u[k-1]*y[k-1]*Phi2(u[k-4],u[k-6])", "u[k-1]*y[k-1]", "y[k-1]", "y[k-3]",
                 "Phi2(u[k-1],u[k-8])", "Phi2(u[k-1],u[k-3])", "Phi2(u[k-1],u[k-2])",
                 "Phi2(u[k-5],u[k-1])", "Phi2(u[k-5],u[k-2])", "y[k-2]", "u[k-1]", "u[k-4]"]

#: published figures (MAPE %, train / validation; steady-state errors in µm)
PUBLISHED = {
    "PEM-LS": {"train": 2.813, "val": 4.077},
    "MS-LS": {"train": 0.165, "val": 0.147},
    "MS-CLS": {"train": 0.261, "val": 0.202, "ss_loading": 0.034, "ss_unloading": 0.353},
    "model (19) CLS": {"train": 0.440, "val": 0.241, "ss_loading": 0.276,
                       "ss_unloading": 0.287},
}


@dataclass
class CaseData:
    u: np.ndarray
    y: np.ndarray
    uv: np.ndarray
    yv: np.ndarray
    tv: np.ndarray
    held: object            # narx.systems.HeldSine
    yh: np.ndarray          # true response to the held sine
    seed: int


#: order of the Butterworth low-pass of the training input (see ``case_data``)
TRAINING_FILTER_ORDER = 4


def case_data(n: int = 50_000, seed: int = 0, order: int = TRAINING_FILTER_ORDER) -> CaseData:
    """Training, validation and held-sine records of the piezo case study.

    The publication gives the training input only as "filtered
    pseudo-random, ±80 V, about 1 Hz bandwidth"; ``order`` is that of the
    1 Hz Butterworth low-pass. A published structure refitted on our record
    (``python -m benchmarks.published_structures --seeds 0 1 2 3 4``;
    validation MAPE %, median over data seeds 0-4):

    ================  =============  ===========  ==========================
    1 Hz Butterworth  (19) CLS       (33) LS      MS search (full, seeds 1-5)
    ================  =============  ===========  ==========================
    published         0.241          0.147        0.147 (MS-LS)
    4th (default)     0.430          2.218        0.220 MS-LS, 0.233 MS-CLS
    2nd               0.367          1.683
    1st               0.248          0.724        0.324 MS-LS, 0.330 MS-CLS
    ================  =============  ===========  ==========================

    A 1st-order filter leaves more fast input rates (rms 161 V/s against
    90 V/s; the 40 V, 1 Hz validation sine peaks at 251 V/s) and reproduces
    the reference model (19) closely, but no order reproduces the published
    MS model (33): refitted on our record it stays 5-15x above its published
    validation figure, so that figure belongs to the published record. The
    MS searches of the study do better on the default 4th order than on the
    1st (benchmarks/RESULTS.md), so the default stays.
    """
    u = training_input(n, seed=seed, order=order)
    t, uv = sine_input()
    hs = held_sine()
    return CaseData(u, piezo_bouc_wen(u), uv, piezo_bouc_wen(uv), t, hs,
                    piezo_bouc_wen(hs.u), seed)


def model19(theta=None) -> Model:
    return Model(MODEL19["terms"], MODEL19["theta"] if theta is None else theta)


def hold_metrics(y_hat, y_true, hold: slice, settle: int) -> Dict[str, float]:
    seg = y_hat[hold]
    tail = seg[settle:] if seg.size > settle + 1 else seg
    return {"drift": float(np.ptp(tail)) if np.all(np.isfinite(tail)) else float("inf"),
            "ss_error": float(abs(seg[-1] - y_true[hold][-1]))}


def edge_error(y_hat, y_true, holds, width: int = 20) -> float:
    """Largest |ŷ − y| within ``width`` samples after each hold's start and
    end: the transient when the input stops or starts again, which the drift
    (after settling) and the end-of-hold error do not see."""
    worst = 0.0
    for sl in holds:
        for e in (sl.start, sl.stop):
            seg = np.abs(y_hat[e:e + width] - y_true[e:e + width])
            if seg.size:
                worst = max(worst, float(np.max(seg)) if np.all(np.isfinite(seg))
                            else float("inf"))
    return worst


def score_model(model: Model, cs: CaseData, settle: Optional[int] = None) -> dict:
    """Free-run figures of a model on the case-study records."""
    settle = 100 if settle is None else settle
    rt = model.simulate(cs.u, cs.y, "freerun")
    rv = model.simulate(cs.uv, cs.yv, "freerun")
    rh = model.simulate(cs.held.u, cs.yh, "freerun")
    out = {"train_mape": rt.mape, "val_mape": rv.mape,
           "train_rmse": rt.rmse, "val_rmse": rv.rmse,
           "diverged": bool(rt.diverged or rv.diverged or rh.diverged),
           "n_terms": model.n_terms, "terms": model.term_texts,
           "theta": [float(v) for v in model.theta],
           "y_val": rv.y_hat, "y_held": rh.y_hat}
    yr = float(np.ptp(cs.yh))
    out["hold_edge_error"] = edge_error(rh.y_hat, cs.yh, (cs.held.hold_rising,
                                                         cs.held.hold_falling))
    for name, sl in (("loading", cs.held.hold_rising), ("unloading", cs.held.hold_falling)):
        if rh.diverged:
            out[f"drift_{name}"] = out[f"ss_{name}"] = float("inf")
            continue
        h = hold_metrics(rh.y_hat, cs.yh, sl, settle)
        out[f"drift_{name}"] = h["drift"]
        out[f"drift_{name}_rel"] = h["drift"] / yr
        out[f"ss_{name}"] = h["ss_error"]
    return out

