"""False-alarm rate of a diagnose test, measured by simulation over controls.

Typical use::

    from mggp.diagnose.calibration import false_alarm_rate
    from mggp.diagnose.augmentation import AUGMENTATION
    fa = false_alarm_rate(AUGMENTATION, per_kind=9, seed=0)  # 6 kinds x 9 = 54 records
    fa.rate, fa.interval(), fa.by_kind
    fa.threshold_factor(0.01)     # scale of the thresholds for a 1 % false-alarm rate

A control realisation is a record with nothing to name
(:func:`~mggp.diagnose.controls.control_record`: linear, polynomial NARX,
Hammerstein, Wiener, saturation, dead zone, fixed seeds) and a model of it
with no missing kind of term (by default its terms fitted by LS on the
fitting samples; ``model_of`` can put the MGGP baseline search in its
place). The test runs on each as in a diagnosis without a validation
record (fitting samples: the first 1 − ``holdout``; measuring samples:
the tail). A realisation is a *false alarm* when any check of the test
beats its threshold.

Beside the count, each realisation gives the largest ratio
statistic / threshold over the test's checks that have power (``nan``
when none has). Multiplying every threshold of the test by f turns a
realisation into an alarm exactly when its ratio exceeds f, so the
(1 − r) quantile of the ratios is the factor that gives a false-alarm rate
of at most r on these controls (:meth:`FalseAlarmRate.threshold_factor`):
a threshold that comes from a stated false-alarm rate instead of a fixed
fraction of the output's range. The rate's uncertainty is the exact
(Clopper–Pearson) binomial interval [1]_.

References
----------
.. [1] Clopper, C. J., Pearson, E. S., "The use of confidence or fiducial
   limits illustrated in the case of the binomial", Biometrika 26(4),
   1934, 404-413.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Dict, Optional, Sequence, Tuple

import numpy as np
from scipy.stats import beta

from narx import Model
from narx.records.data import Data

from .context import Context
from .controls import CONTROL_KINDS, control_record
from .budget import Budget
from .registry import DiagnosticTest

__all__ = ["FalseAlarmRate", "false_alarm_rate", "control_checks", "threshold_factors"]


@dataclass(frozen=True)
class FalseAlarmRate:
    """False alarms of one test over control realisations.

    Attributes
    ----------
    test : str
        Name of the test.
    kinds : tuple of str
        The kind of control of each realisation.
    seeds : tuple of int
        Its seed.
    alarms : tuple of bool
        Whether any check beat its threshold.
    ratios : tuple of float
        Largest statistic / threshold over the checks with power (``nan``:
        no check, or none with power).
    """

    test: str
    kinds: Tuple[str, ...]
    seeds: Tuple[int, ...]
    alarms: Tuple[bool, ...]
    ratios: Tuple[float, ...]

    @property
    def realisations(self) -> int:
        return len(self.alarms)

    @property
    def rate(self) -> float:
        """Fraction of realisations with a false alarm."""
        return float(np.mean(self.alarms)) if self.alarms else float("nan")

    @property
    def without_power(self) -> int:
        """Realisations in which no check of the test had power."""
        return int(np.sum(np.isnan(self.ratios)))

    @property
    def by_kind(self) -> Dict[str, Tuple[int, int]]:
        """kind -> (false alarms, realisations)."""
        out: Dict[str, Tuple[int, int]] = {}
        for k, a in zip(self.kinds, self.alarms):
            n_a, n = out.get(k, (0, 0))
            out[k] = (n_a + int(a), n + 1)
        return out

    def interval(self, confidence: float = 0.95) -> Tuple[float, float]:
        """Exact (Clopper–Pearson) interval of the false-alarm rate."""
        n, x = self.realisations, int(np.sum(self.alarms))
        if n == 0:
            return (0.0, 1.0)
        a = 1.0 - confidence
        lo = float(beta.ppf(a / 2, x, n - x + 1)) if x > 0 else 0.0
        hi = float(beta.ppf(1 - a / 2, x + 1, n - x)) if x < n else 1.0
        return lo, hi

    def threshold_factor(self, rate: float) -> float:
        """Factor f by which every threshold of the test must be multiplied
        for a false-alarm rate of at most ``rate`` on these realisations:
        the (1 − rate) quantile of the ratios (realisations without power
        count as 0, they cannot alarm). Below 1: the thresholds are more
        conservative than the rate asks; above 1: they alarm too often."""
        if not 0.0 < rate < 1.0:
            raise ValueError(f"rate must be in (0, 1), got {rate!r}")
        r = np.nan_to_num(np.asarray(self.ratios, dtype=float), nan=0.0)
        if not r.size:
            return float("nan")
        return float(np.quantile(r, 1.0 - rate, method="higher"))

    def describe(self) -> str:
        lo, hi = self.interval()
        kinds = ", ".join(f"{k} {a}/{n}" for k, (a, n) in self.by_kind.items())
        return (f"{self.test}: {int(np.sum(self.alarms))} false alarms in "
                f"{self.realisations} control realisations (rate {self.rate:.3g}, 95 % "
                f"interval {lo:.3g}-{hi:.3g}; {kinds}); {self.without_power} without power")


def _ratio(checks) -> float:
    r = [c.statistic / c.threshold if c.threshold > 0 else
         (float("inf") if c.statistic > 0 else 0.0)
         for c in checks if c.power and np.isfinite(c.threshold)]
    return float(max(r)) if r else float("nan")


def control_checks(test: DiagnosticTest, *, kinds: Sequence[str] = CONTROL_KINDS,
                   per_kind: int = 9, n: int = 2000, snr_db: float = 40.0, holds: int = 0,
                   seed: int = 0, alpha: float = 0.01, resolution: float = 0.005,
                   budget: Budget = Budget(), holdout: float = 0.3,
                   model_of: Optional[Callable[[Data, Tuple[str, ...]], Model]] = None,
                   calibrated: bool = True):
    """The checks of ``test`` on each control realisation (arguments as in
    :func:`false_alarm_rate`; ``calibrated``: thresholds scaled by
    :func:`~mggp.diagnose.thresholds.calibrated` as in a diagnosis, else
    the raw ones). Yields ``(kind, seed, checks)``."""
    from .thresholds import calibrated as scale
    if int(per_kind) < 1:
        raise ValueError(f"per_kind must be at least 1, got {per_kind!r}")
    if not 0.0 < holdout < 1.0:
        raise ValueError(f"holdout must be a fraction in (0, 1), got {holdout!r}")
    fit_model = model_of or (lambda d, terms: Model(list(terms)).fit(d))
    for kind in kinds:
        for i in range(int(per_kind)):
            rec = control_record(kind, seed + i, n, snr_db, holds)
            d = rec.data
            n_fit = int(round(d.n * (1.0 - holdout)))
            fit = Data(d.U[:, :n_fit].T, d.y[:n_fit], inputs=d.inputs, output=d.output)
            measure = Data(d.U[:, n_fit:].T, d.y[n_fit:], inputs=d.inputs, output=d.output)
            model = fit_model(fit, rec.terms)
            ctx = Context(model, fit, measure, ("control", "control (tail)"), n_fit, budget,
                          alpha, resolution, seed + i)
            checks = list(test.run(ctx).checks)
            yield kind, seed + i, [scale(c) for c in checks] if calibrated else checks


def threshold_factors(checks_per_realisation, rate: float = 0.05) -> Dict[str, float]:
    """Factors of the check families of one test (:func:`~mggp.diagnose.thresholds.check_family`)
    that give the *test* a false-alarm rate of at most ``rate`` on the
    realisations.

    A test alarms when any of its checks beats its threshold, so with c
    families each at rate r its rate can reach c·r. Every family is set to
    the same per-family rate q: its factor is the (1 − q) quantile
    (``'higher'``) of statistic / raw threshold over the realisations (a
    realisation without that family, or without power, counts 0), applied
    only when above 1 (as :func:`~mggp.diagnose.thresholds.calibrated`
    does). q is the largest of ``rate``·(1 − i/50), i = 0..50, at which the
    fraction of realisations with any family above its applied factor is
    at most ``rate``; at q = 0 every factor is the largest ratio and no
    realisation alarms. With a single family this is its (1 − ``rate``)
    quantile.

    Parameters
    ----------
    checks_per_realisation : iterable of list of Check
        The raw checks (``calibrated=False``) of one test on every realisation.
    rate : float
        The stated false-alarm rate of the test.

    Returns
    -------
    dict
        family -> factor (values below 1 are returned as measured; they
        leave the raw threshold unchanged).
    """
    from .thresholds import check_family
    if not 0.0 < rate < 1.0:
        raise ValueError(f"rate must be in (0, 1), got {rate!r}")
    rows = [list(cs) for cs in checks_per_realisation]
    fams = sorted({check_family(c.test) for cs in rows for c in cs})
    if not fams:
        return {}
    R = np.array([[np.nan_to_num(_ratio([c for c in cs if check_family(c.test) == f]),
                                 nan=0.0) for f in fams] for cs in rows])
    for q in rate * (1.0 - np.arange(51) / 50.0):
        f = (np.quantile(R, 1.0 - q, axis=0, method="higher") if q > 0 else R.max(axis=0))
        if np.mean(np.any(R > np.maximum(f, 1.0), axis=1)) <= rate:
            break
    return {fam: float(v) for fam, v in zip(fams, f)}


def false_alarm_rate(test: DiagnosticTest, *, kinds: Sequence[str] = CONTROL_KINDS,
                     per_kind: int = 9, n: int = 2000, snr_db: float = 40.0, holds: int = 0,
                     seed: int = 0,
                     alpha: float = 0.01, resolution: float = 0.005,
                     budget: Budget = Budget(), holdout: float = 0.3,
                     model_of: Optional[Callable[[Data, Tuple[str, ...]], Model]] = None,
                     calibrated: bool = True) -> FalseAlarmRate:
    """Run ``test`` on ``per_kind`` realisations of each control kind.

    Parameters
    ----------
    test : DiagnosticTest
        The test (e.g. :data:`mggp.diagnose.augmentation.AUGMENTATION`).
    kinds : sequence of str
        Kinds of control (:data:`~mggp.diagnose.controls.CONTROL_KINDS`).
    per_kind : int
        Realisations of each kind; realisation i has seed ``seed + i``.
    n, snr_db, holds : int, float, int
        Record length, output SNR and held-input segments
        (:func:`~mggp.diagnose.controls.control_record`).
    seed : int
        First seed; also the diagnosis seed the test is given.
    alpha, resolution, budget : float, float, Budget
        As in :func:`mggp.diagnose.diagnose`.
    holdout : float
        Fraction of the record held out as measuring samples.
    model_of : callable, optional
        ``model_of(fit_data, terms) -> Model`` (fitted); default: ``terms``
        fitted by LS.
    calibrated : bool
        Thresholds as a diagnosis uses them (scaled by the calibration
        table of :mod:`~mggp.diagnose.thresholds`); False: the raw ones.

    Returns
    -------
    FalseAlarmRate
    """
    ks, ss, alarms, ratios = [], [], [], []
    for kind, s, checks in control_checks(test, kinds=kinds, per_kind=per_kind, n=n,
                                          snr_db=snr_db, holds=holds, seed=seed, alpha=alpha,
                                          resolution=resolution, budget=budget,
                                          holdout=holdout, model_of=model_of,
                                          calibrated=calibrated):
        ks.append(kind)
        ss.append(s)
        alarms.append(any(c.beats for c in checks))
        ratios.append(_ratio(checks))
    return FalseAlarmRate(test.name, tuple(ks), tuple(ss), tuple(alarms), tuple(ratios))
