"""What every diagnose test is given: the model, the records, the settings,
and the quantities several tests share (computed once, when first asked for).

Typical use (inside a test's ``run``)::

    def run(ctx):
        r = ctx.model.simulate(ctx.fit, mode="freerun")     # the fitting samples
        ctx.alpha, ctx.floor                                # false-alarm rate, floor
        ctx.holds                                           # hold responses, both records
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Dict, List, Tuple

import numpy as np

from narx import Model
from narx.records.data import Data

from .budget import Budget
from .holds import HoldResponse, continuum_violations, find_holds, hold_responses

__all__ = ["Context"]


def _range(y) -> float:
    return float(np.ptp(y)) or 1.0


@dataclass
class Context:
    """The model under diagnosis and everything its tests may read.

    Parameters
    ----------
    model : narx.Model
        The baseline (θ fitted on ``fit``, or the user's).
    fit : narx.Data
        The fitting samples: the evidence comes from them.
    measure : narx.Data
        The measuring samples (validation record or training tail); only
        their held-input segments are used as evidence, nothing is fitted
        on them.
    records : (str, str)
        Names of the fitting and measuring records, for reports.
    offset : int
        Number of the measuring record's first sample in its file.
    budget : Budget
        Search effort and sample sizes of the statistics (``shifts``).
    alpha : float
        False-alarm probability of each test.
    resolution : float
        Smallest effect worth naming, as a fraction of the output's range.
    seed : int
        Seed of the diagnosis; a test with random draws seeds its own
        generator from it.

    Attributes
    ----------
    floor : float
        Resolution floor of the fitting record, ``resolution`` × range of y.
    hold_floors : dict
        Resolution floor of each record, by name.
    input_tolerance : float
        Holds whose input levels differ by at most this count as holds at
        the same input (``resolution`` × range of the first input).
    hold_min_len : int
        Shortest held-input segment searched, max(20, 2 L + 12).
    """

    model: Model
    fit: Data
    measure: Data
    records: Tuple[str, str]
    offset: int
    budget: "Budget"
    alpha: float
    resolution: float
    seed: int
    floor: float = field(init=False)
    hold_floors: Dict[str, float] = field(init=False)
    input_tolerance: float = field(init=False)
    hold_min_len: int = field(init=False)

    def __post_init__(self):
        self.floor = self.resolution * _range(self.fit.y)
        self.hold_floors = {self.records[0]: self.floor,
                            self.records[1]: self.resolution * _range(self.measure.y)}
        self.input_tolerance = self.resolution * float(np.ptp(self.fit.U[0]))
        self.hold_min_len = max(20, 2 * self.model.max_lag + 12)

    @property
    def output(self) -> str:
        return self.fit.output

    @cached_property
    def osa_rms(self) -> float:
        """RMS of the model's one-step residual on the fitting samples."""
        osa = self.model.simulate(self.fit, mode="osa")
        eps = np.where(osa.valid, self.fit.y - osa.y_hat, np.nan)
        ok = np.isfinite(eps)
        return float(np.sqrt(np.mean(eps[ok] ** 2))) if ok.any() else 0.0

    @cached_property
    def freerun_rms(self) -> float:
        """RMS of the model's free-run error on the fitting samples (``inf``
        if the free run diverges)."""
        from .simulation import freerun_rmse
        return freerun_rmse(self.model, self.fit)

    @cached_property
    def fit_holds(self) -> List[Tuple[int, int]]:
        """Held-input segments of the fitting samples (:func:`find_holds`)."""
        return find_holds(self.fit, self.hold_min_len)

    @cached_property
    def measure_holds(self) -> List[Tuple[int, int]]:
        """Held-input segments of the measuring samples."""
        return find_holds(self.measure, self.hold_min_len)

    @property
    def holds_found(self) -> Dict[str, int]:
        """Number of held-input segments found in each record (usable or not)."""
        return {self.records[0]: len(self.fit_holds), self.records[1]: len(self.measure_holds)}

    @cached_property
    def holds(self) -> List[HoldResponse]:
        """The model's and the data's response in every usable hold of both
        records (:func:`hold_responses`), fitting record first."""
        out = hold_responses(self.model, self.fit, self.records[0], self.hold_min_len,
                             self.fit_holds)
        return out + hold_responses(self.model, self.measure, self.records[1],
                                    self.hold_min_len, self.measure_holds, self.offset)

    @cached_property
    def cluster_violations(self) -> List[Tuple[str, float, float]]:
        """The model's cluster sums off the continuum (:func:`continuum_violations`)."""
        return continuum_violations(self.model)

    def floor_of(self, record: str) -> float:
        """Resolution floor of ``record`` (that of the fitting record if unknown)."""
        return self.hold_floors.get(record, self.floor)
