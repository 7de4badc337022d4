"""The Pareto front of a structure search: complexity against loss.

Typical use::

    est = MGGPRegressor(...).fit(u, y)
    print(est.pareto_front_)                 # complexity, loss, score, equation
    m = est.pareto_front_.get_best()         # lowest loss, as a narx.Model
    m = est.pareto_front_.get_best("score")  # best loss drop per term, loss within 2x the best
    est.pareto_front_.to_latex(2)            # row 2 as LaTeX
    est.pareto_front_.to_sympy(-1)           # the last row as a sympy expression

Each row is a dict with ``complexity`` (number of terms), ``loss`` (the
search fitness of the structure), ``terms``, ``theta`` (the parameters the
loss was computed with: LS, or CLS when the search was constrained, on
the scored rows of the training record) and ``equation``. Rows are sorted by
complexity; along the front the loss decreases strictly.

The ``score`` of a row is the drop in log-loss per added term from the
previous row, :math:`-\\Delta \\ln J / \\Delta c` (the first row scores 0),
as in PySR [1]_; ``get_best("score")`` returns the row with the largest score
among those whose loss is within ``tolerance`` times the best loss.

References
----------
.. [1] Cranmer, M., "Interpretable Machine Learning for Science with PySR
   and SymbolicRegression.jl", arXiv:2305.01582, 2023.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence

from narx import Model

__all__ = ["ParetoFront"]


class ParetoFront(list):
    """Rows (complexity, loss, terms, theta, equation) of the non-dominated
    structures of a search, as a table; each row exports to a model, sympy
    or LaTeX.

    Parameters
    ----------
    rows : iterable of dict
        ``complexity``, ``loss``, ``terms`` and, when known, ``theta``.
    inputs, output : signal names of the models built from the rows.
    registry : PhiRegistry, optional
        Φ-functions the terms use (default: the built-in registry).
    """

    def __init__(self, rows=(), *, inputs: Sequence[str] = ("u",), output: str = "y",
                 registry=None):
        super().__init__()
        self.inputs, self.output, self.registry = tuple(inputs), output, registry
        prev = None
        for r in sorted(rows, key=lambda r: (r["complexity"], r["loss"])):
            if prev is not None and not r["loss"] < prev["loss"]:
                continue                        # dominated by a simpler row
            r = dict(r)
            r["terms"] = [str(t) for t in r["terms"]]
            th = r.get("theta")
            r["theta"] = None if th is None else [float(v) for v in th]
            r["equation"] = (self._model(r).equation() if r["theta"] is not None
                             else " + ".join(r["terms"]))
            ok = prev is not None and prev["loss"] > 0 and r["loss"] > 0 \
                and math.isfinite(prev["loss"]) and math.isfinite(r["loss"])
            r["score"] = (-(math.log(r["loss"]) - math.log(prev["loss"]))
                          / max(1, r["complexity"] - prev["complexity"])) if ok else 0.0
            self.append(r)
            prev = r

    def _model(self, r) -> Model:
        return Model(r["terms"], theta=r["theta"], inputs=self.inputs, output=self.output,
                     meta={"complexity": r["complexity"], "loss": r["loss"]},
                     registry=self.registry)

    def _row(self, i: int) -> dict:
        if not self:
            raise ValueError("the Pareto front is empty")
        try:
            return self[i]
        except IndexError:
            raise IndexError(f"row must be in [-{len(self)}, {len(self) - 1}], got {i}") \
                from None

    def model(self, i: int) -> Model:
        """Row ``i`` as a :class:`narx.Model` with the θ of its loss."""
        r = self._row(i)
        if r["theta"] is None:
            raise ValueError(f"row {i} has no parameters (its fit failed)")
        return self._model(r)

    def get_best(self, criterion: str = "loss", tolerance: float = 2.0) -> Model:
        """The lowest-loss row (``'loss'``), or the row with the largest
        ``score`` among those with loss <= ``tolerance`` × the lowest
        (``'score'``), as a model."""
        if criterion not in ("loss", "score"):
            raise ValueError(f"criterion must be 'loss' or 'score', got {criterion!r}")
        if not tolerance >= 1:
            raise ValueError(f"tolerance must be >= 1, got {tolerance!r}")
        fitted = [i for i, r in enumerate(self) if r["theta"] is not None]
        if not fitted:
            raise ValueError("the Pareto front has no fitted row")
        lo = min(self[i]["loss"] for i in fitted)
        if criterion == "loss":
            best = min(fitted, key=lambda i: (self[i]["loss"], self[i]["complexity"]))
        else:
            if not lo > 0:
                raise ValueError(f"criterion='score' needs positive losses (an MSE); this "
                                 f"front's lowest loss is {lo:g} (an information "
                                 f"criterion?): use criterion='loss'")
            near = [i for i in fitted if self[i]["loss"] <= tolerance * lo]
            best = max(near, key=lambda i: (self[i]["score"], -self[i]["complexity"]))
        return self.model(best)

    def to_sympy(self, i: int = -1):
        """Row ``i`` (default: the last, lowest loss) as a sympy expression."""
        return self.model(i).to_sympy()

    def to_latex(self, i: int = -1, precision: int = 4) -> str:
        """Row ``i`` (default: the last, lowest loss) as LaTeX."""
        return self.model(i).to_latex(precision)

    def __repr__(self):
        lines = [f"{'complexity':>10}  {'loss':>12}  {'score':>8}  equation"]
        for r in self:
            lines.append(f"{r['complexity']:>10d}  {r['loss']:>12.6g}  {r['score']:>8.3g}  "
                         f"{r['equation']}")
        return "\n".join(lines)

    def to_markdown(self) -> str:
        out = ["| complexity | loss | score | equation |", "|---:|---:|---:|---|"]
        for r in self:
            out.append(f"| {r['complexity']} | {r['loss']:.6g} | {r['score']:.3g} | "
                       f"`{r['equation']}` |")
        return "\n".join(out)


def front_rows(pareto, scorer, shape) -> list:
    """Rows for :class:`ParetoFront` from a search's front, with the θ the
    scorer estimates for each structure (None when its fit fails);
    ``shape`` maps decoded terms to the scored structure."""
    rows = []
    for r in pareto:
        terms = shape(r.terms)
        if not terms:
            continue
        theta: Optional[list] = None
        try:
            th, _ = scorer.fit(terms)
            if all(math.isfinite(float(v)) for v in th):
                theta = [float(v) for v in th]
        except (ValueError, ArithmeticError):
            theta = None
        rows.append({"complexity": len(terms), "loss": float(r.fitness),
                     "terms": [str(t) for t in terms], "theta": theta})
    return rows
