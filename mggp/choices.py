"""The automatic choices of :class:`mggp.MGGPRegressor` (parameters left at 'auto').

Typical use (``fit`` does this)::

    from mggp.choices import heldout_rmse, resolve_select, HOLDOUT
    err = heldout_rmse(terms, data, registry)       # θ on the head, free run scored on the tail
    select, why = resolve_select(est)               # 'hold' with constraints, else 'fitness'

Each choice is a :class:`Choice`: the value taken and the figures it was
taken on, in one line ("no Φ: held-out free-run RMSE 0.41 against 0.58 with
Φ"). ``fit`` keeps them in ``choices_`` and in every model's ``meta``
(``meta['choices']``); ``mggp fit`` prints them.

Held-out free-run error
    θ of a structure is estimated by least squares on the first
    ``1 - HOLDOUT`` of the record; the model then runs free over the whole
    record from measured initial conditions and its RMSE is taken on the
    last ``HOLDOUT`` only,

    .. math:: e = \\sqrt{\\tfrac{1}{|T|}\\sum_{k \\in T} (y_k - \\hat y_k)^2},
              \\qquad T = \\{\\lceil (1-h) N \\rceil, \\dots, N-1\\}

    a model whose free run diverges scores ``inf``. The structure saw the
    whole record in the search; its parameters did not see the tail. This
    is the simulation-error check of validation on fresh data used by
    Billings (Nonlinear System Identification, Wiley 2013, ch. 5).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional

import numpy as np

from narx import Model
from narx.data import Data
from narx.model import ignore_rank_warnings

__all__ = ["Choice", "HOLDOUT", "PHI_GAIN", "SIZE_TOLERANCE", "size_choice", "heldout_rmse", "resolve_screen", "resolve_select", "phi_choice"]

#: share of the record (its tail) on which the held-out free-run error is measured
HOLDOUT = 0.3

#: Φ-terms are kept only when they lower the held-out free-run error by more
#: than this share (the simpler class wins what the split cannot tell apart)
PHI_GAIN = 0.05


@dataclass(frozen=True)
class Choice:
    """One automatic choice: the parameter, the value taken, why (one line)
    and the figures it rests on."""

    name: str
    value: Any
    why: str
    figures: dict

    def to_dict(self) -> dict:
        return {"value": self.value, "why": self.why, "figures": self.figures}


def heldout_rmse(terms, data: Data, registry=None, holdout: float = HOLDOUT) -> float:
    """Free-run RMSE on the last ``holdout`` of ``data`` of the structure
    ``terms`` with θ by least squares on the rest (``inf``: diverges or
    cannot be fitted)."""
    n_head = int(np.ceil((1.0 - holdout) * data.n))
    try:
        with ignore_rank_warnings():
            m = Model(tuple(terms), inputs=data.inputs, output=data.output,
                      registry=registry).fit(data.slice(0, n_head))
        sim = m.simulate(data, mode="freerun")
    except (ValueError, np.linalg.LinAlgError, FloatingPointError):
        return float("inf")
    err = np.asarray(sim.y_hat[n_head:], dtype=float) - data.y[n_head:]
    if sim.diverged or not np.all(np.isfinite(err)):
        return float("inf")
    return float(np.sqrt(np.mean(err ** 2)))


#: the smallest structure whose held-out error is within this share of the least is taken
SIZE_TOLERANCE = 0.05


def size_choice(rows) -> Choice:
    """``size='auto'``: among ``rows`` ``(n_terms, held-out RMSE, terms)``
    (the chosen structure first, then the run's Pareto front), the fewest
    terms whose error is within :data:`SIZE_TOLERANCE` of the least
    (ties: the chosen structure, then lower error)."""
    best = min(r[1] for r in rows)
    ok = [(r[0], i > 0, r[1], i) for i, r in enumerate(rows)
          if np.isfinite(r[1]) and r[1] <= (1.0 + SIZE_TOLERANCE) * best]
    if not ok:
        return Choice("size", rows[0][2], "size: the chosen structure (every held-out free "
                      "run diverges)", {"candidates": len(rows)})
    n, _, err, i = min(ok)
    figs = {"terms": n, "heldout_rmse": err, "searched_terms": rows[0][0],
            "searched_heldout_rmse": rows[0][1], "candidates": len(rows)}
    if i == 0:
        why = (f"size {n} terms: the chosen structure (held-out free-run RMSE {err:.4g}; "
               f"no smaller one of the Pareto front within {SIZE_TOLERANCE:.0%})")
    else:
        why = (f"size {n} terms: Pareto-front structure with held-out free-run RMSE "
               f"{err:.4g} against {rows[0][1]:.4g} for the {rows[0][0]}-term chosen one")
    return Choice("size", rows[i][2], why, figs)


def resolve_screen(est) -> Choice:
    """``screen='auto'``: 'hold' when the model is refitted under the
    steady-state constraints (leaders whose CLS refit does not hold are
    screened out in every generation), else 'freerun' (leaders whose free
    run leaves the output band are)."""
    if est.constraints == "steady-state":
        return Choice("screen", "hold", "screen hold: constraints='steady-state': leaders "
                      "whose CLS refit does not hold are screened out", {})
    return Choice("screen", "freerun", "screen freerun: leaders whose free run leaves the "
                  "output band are screened out", {})


def resolve_select(est) -> Choice:
    """``select='auto'``: 'hold' when the model is refitted under the
    steady-state constraints (the structure whose CLS refit holds its
    output on a held input), else 'fitness'."""
    if est.constraints == "steady-state":
        return Choice("select", "hold", "select hold: constraints='steady-state' asks for a "
                      "model that holds its output on a held input", {})
    return Choice("select", "fitness", "select fitness: no constraints to hold", {})


def phi_choice(err_plain: float, err_phi: float, holds_plain: Optional[bool] = None,
               holds_phi: Optional[bool] = None) -> Choice:
    """``use_phi='auto'``: Φ-terms only when the Φ search's structure has
    a held-out free-run error more than :data:`PHI_GAIN` below the plain
    one's (else no Φ, the simpler class). ``holds_*`` (with the hold
    selection): whether the search has a structure whose CLS refit holds;
    a search that has one wins over one that has none, whatever the error."""
    if holds_phi is not None and holds_phi != holds_plain:
        use = bool(holds_phi)
    else:
        use = bool(err_phi < (1.0 - PHI_GAIN) * err_plain
                   or (np.isinf(err_plain) and np.isfinite(err_phi)))
    figs = {"heldout_rmse_phi": err_phi, "heldout_rmse_no_phi": err_plain,
            "holdout": HOLDOUT}
    if holds_phi is not None:
        figs.update(holds_phi=holds_phi, holds_no_phi=holds_plain)
        if holds_phi != holds_plain:
            return Choice("use_phi", use, ("Φ" if use else "no Φ") + ": only the search "
                          + ("with" if use else "without") + " Φ has a structure whose CLS "
                          f"refit holds its output (held-out free-run RMSE {err_phi:.4g} "
                          f"with Φ, {err_plain:.4g} without)", figs)
    if use:
        why = (f"Φ: held-out free-run RMSE {err_phi:.4g} against {err_plain:.4g} "
               f"without Φ")
    else:
        why = (f"no Φ: held-out free-run RMSE {err_plain:.4g} against {err_phi:.4g} "
               f"with Φ")
    return Choice("use_phi", use, why + f" (θ on the first {1 - HOLDOUT:.0%}, error on "
                  f"the last {HOLDOUT:.0%} of the record)", figs)
