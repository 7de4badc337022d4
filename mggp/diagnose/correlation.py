"""Billings–Voon correlation tests of one-step residuals.

Typical use::

    from mggp.diagnose.correlation import correlation_tests
    tests = correlation_tests(eps, {"u": u}, max_lag=20, alpha=0.01)
    for t in tests:
        print(t.label, t.max_abs, t.band, t.significant)

As the diagnose test :data:`CORRELATION` (effects ``unmodelled-dynamics``
for φ_ee, φ_ue and ``unmodelled-nonlinearity`` for φ_u²'e, φ_u²'e²), each
test's threshold is the larger of its Bonferroni band and the resolution
floor in correlation units. The floor is a free-run error (a fraction of
the output's range) while the test sees a one-step residual, so the floor
is carried to the one-step scale by the model's own propagation factor
:math:`s = \\max(1, \\mathrm{RMS}_{fr} / \\mathrm{RMS}_{osa})` (free-run over
one-step RMS error on the fitting samples): a correlation φ of a residual
of RMS :math:`r` stands for a one-step error component φ r, which the
free run turns into about φ r s, so it is worth naming only when

.. math::

    \\phi > \\frac{\\text{floor}}{r\\, s} .

For the model's own residual (r = RMS_osa) this is floor / RMS_fr: a
correlation must explain at least the floor of the free-run error. A
test has no power only when the model's free run is already within the
floor (nothing a correlation finds is then worth a change).

For an adequate NARX model the one-step residuals :math:`\\varepsilon_k`
are unpredictable from past inputs and residuals, so [1]_

.. math::

    \\phi_{\\varepsilon\\varepsilon}(\\tau) = \\delta(\\tau), \\quad
    \\phi_{u\\varepsilon}(\\tau) = 0, \\quad
    \\phi_{u^{2\\prime}\\varepsilon}(\\tau) = 0, \\quad
    \\phi_{u^{2\\prime}\\varepsilon^{2\\prime}}(\\tau) = 0,

with :math:`u^{2\\prime}_k = u_k^2 - \\overline{u^2}` and the normalised
correlation

.. math::

    \\phi_{ab}(\\tau) = \\frac{\\sum_{k} (a_{k-\\tau} - \\bar a)(b_k - \\bar b)}
                             {\\sqrt{\\sum_k (a_k - \\bar a)^2 \\sum_k (b_k - \\bar b)^2}} ,

here for τ = 0..L (the input leads the residual; τ = 1..L for
:math:`\\phi_{\\varepsilon\\varepsilon}`). Under the hypothesis each
:math:`\\sqrt{N}\\,\\phi(\\tau)` is approximately standard normal, which gives
the classical 95 % band ±1.96/√N; its excursions are counted and plotted.

**False-alarm rule.** With m lags tested, about 5 % of them leave the 95 %
band by chance, so a count of excursions proves nothing. A test is
*significant* only if its largest :math:`|\\phi(\\tau)|` leaves the
Bonferroni band :math:`z_{1-\\alpha/(2m)}/\\sqrt{N}`; the probability that
a test of an adequate model is significant is then at most α whatever the
number of lags (Bonferroni's inequality).

**Completed residuals** (:func:`model_tests`). The tests assume the other
part of the model is right: a model that only lacks a linear lag leaves
squares of past inputs in ε², so φ_u²'ε² fires and reads as a missing
nonlinearity; a model that only lacks a static nonlinearity leaves u³ in ε,
so φ_uε fires and reads as missing dynamics. So the nonlinear tests use the
residual of the model refitted with the *linear* lags y[k-1..4], u[k-1..4]
added, and the linear tests the residual of the model refitted with the
*static* terms y[k-1]², y[k-1]³, u[k-1]², u[k-1]³, y[k-1]u[k-1] added: each
test then answers for what the other kind of term cannot repair.
Both refits are column-scaled LS (:func:`narx.estimation.estimate.least_squares`), so
the tests do not depend on the units of the input or the output.

References
----------
.. [1] Billings, S. A., Voon, W. S. F., "Correlation based model validity
   tests for non-linear models", Int. J. Control 44(1), 1986, 235-244.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Dict, List, Optional

import numpy as np

from ..fit.choices import RESOLUTION as ROUNDING
from .findings import Check, number_text as _g
from .registry import DiagnosticTest, Outcome
from .thresholds import bonferroni_z

__all__ = ["CorrelationTest", "correlation_tests", "cross_correlation", "TEST_LABELS",
           "model_tests", "completed_residual", "correlation_checks", "no_power_reason",
           "propagation_factor",
           "CORRELATION"]

#: test key -> label shown in reports
TEST_LABELS = {"ee": "φ_ee", "ue": "φ_ue", "u2e": "φ_u²'e", "u2e2": "φ_u²'e²"}


@dataclass(frozen=True)
class CorrelationTest:
    """One correlation function and its bands.

    Attributes
    ----------
    key : {'ee', 'ue', 'u2e', 'u2e2'}
    signal : str
        The input involved ('' for ``ee``).
    lags, r : ndarray
        Lags τ and :math:`\\phi(\\tau)`.
    n : int
        Samples used.
    band95 : float
        1.96/√N.
    band : float
        Bonferroni band :math:`z_{1-\\alpha/(2m)}/\\sqrt N`, m = len(lags).
    rms : float or None
        RMS of the residual tested (None: the model's own one-step residual).
    completed : str
        What the model was completed with before the test ('' : nothing).
    """

    key: str
    signal: str
    lags: np.ndarray
    r: np.ndarray
    n: int
    band95: float
    band: float
    rms: Optional[float] = None
    completed: str = ""

    @property
    def label(self) -> str:
        """``φ_ue`` for the input ``u``; an input of a longer name is set off
        by a comma so that it reads as written: ``φ_uEst,e``, ``φ_v²',e²``."""
        lab = TEST_LABELS[self.key]
        if self.key == "ee" or not self.signal or self.signal == "u":
            return lab
        head, tail = lab[2:].split("e", 1)            # 'u', "u²'" -> signal part
        return "φ_" + head.replace("u", self.signal, 1) + ",e" + tail

    @property
    def max_abs(self) -> float:
        return float(np.max(np.abs(self.r))) if self.r.size else 0.0

    @property
    def worst_lag(self) -> int:
        return int(self.lags[int(np.argmax(np.abs(self.r)))]) if self.r.size else 0

    @property
    def excursions(self) -> int:
        """Lags outside the 95 % band (about 5 % of them by chance)."""
        return int(np.sum(np.abs(self.r) > self.band95))

    @property
    def significant(self) -> bool:
        return self.max_abs > self.band

    def describe(self) -> str:
        done = f" (residual of the model completed with {self.completed})" \
            if self.completed else ""
        return (f"{self.label}{done}: {self.excursions} of {self.lags.size} lags outside "
                f"±1.96/√N "
                f"= ±{self.band95:.3g} (≈{0.05 * self.lags.size:.1f} expected by chance); "
                f"max |φ| = {self.max_abs:.3g} at τ = {self.worst_lag}, "
                f"Bonferroni band ±{self.band:.3g}")


def _centred(x):
    x = np.asarray(x, dtype=float)
    return x - x.mean()


def cross_correlation(a, b, lags) -> np.ndarray:
    """Normalised :math:`\\phi_{ab}(\\tau)` (a leads b by τ >= 0)."""
    a, b = _centred(a), _centred(b)
    den = float(np.sqrt(np.dot(a, a) * np.dot(b, b)))
    n = a.size
    out = np.zeros(len(lags))
    if den <= 0 or not np.isfinite(den):
        return out
    for i, t in enumerate(lags):
        t = int(t)
        out[i] = np.dot(a[:n - t], b[t:]) / den
    return out


def correlation_tests(eps, inputs: Dict[str, np.ndarray], max_lag: int = 20,
                      alpha: float = 0.01) -> List[CorrelationTest]:
    """The four Billings–Voon tests for residuals ``eps`` and each input.

    Parameters
    ----------
    eps : array (N,)
        One-step residuals.
    inputs : dict name -> array (N,)
        Inputs aligned with ``eps`` (same samples).
    max_lag : int
        L, the largest lag tested.
    alpha : float
        False-alarm probability of each test (Bonferroni over its lags).

    Returns
    -------
    list of CorrelationTest
        ``ee`` first, then ``ue``, ``u2e``, ``u2e2`` per input. Constant
        signals give zero correlation (nothing to test).
    """
    eps = np.asarray(eps, dtype=float)
    n = eps.size
    L = int(max(1, min(max_lag, n // 4)))
    lag0 = np.arange(0, L + 1)
    lag1 = np.arange(1, L + 1)
    sq = np.sqrt(n)
    band95 = 1.96 / sq
    e2 = eps ** 2
    out = [CorrelationTest("ee", "", lag1, cross_correlation(eps, eps, lag1), n, band95,
                           bonferroni_z(alpha, lag1.size) / sq)]
    for name, u in inputs.items():
        u = np.asarray(u, dtype=float)
        u2 = u ** 2
        band = bonferroni_z(alpha, lag0.size) / sq
        out.append(CorrelationTest("ue", name, lag0, cross_correlation(u, eps, lag0), n,
                                   band95, band))
        out.append(CorrelationTest("u2e", name, lag0, cross_correlation(u2, eps, lag0), n,
                                   band95, band))
        out.append(CorrelationTest("u2e2", name, lag0, cross_correlation(u2, e2, lag0), n,
                                   band95, band))
    return out


def completed_residual(model, data, extra: List[str]):
    """One-step residual of ``model``'s terms plus ``extra`` refitted by LS.

    The fit is :func:`narx.estimation.estimate.least_squares` (pivoted QR on columns
    scaled to unit norm), so the residual scales with the output and does
    not depend on the units of the input: regressors such as y[k-1]³ may be
    many orders of magnitude larger than y[k-1], and an unscaled solver
    would lose the small columns to rounding.

    Parameters
    ----------
    model : narx.Model
        The model whose terms are completed (its θ is not used).
    data : narx.Data
        The record to fit on.
    extra : list of str
        Terms to add (those already in the model are skipped).

    Returns
    -------
    tuple (ndarray, ndarray) or None
        The residual and the sample indices it belongs to; None if the
        completed model cannot be fitted or its residual is not finite.
    """
    from narx import Model
    from narx.estimation.estimate import least_squares
    from narx.records.regressors import regressor_matrix
    sig = dict(inputs=data.inputs, output=data.output, registry=model.registry)
    have = set(model.term_texts)
    terms = model.term_texts + [t for t in Model(extra, **sig).term_texts if t not in have]
    try:
        m = Model(terms, **sig)
        Psi, target, start = regressor_matrix(m.terms, data, registry=model.registry)
        theta = least_squares(Psi, target).theta
    except (ValueError, np.linalg.LinAlgError):
        return None
    r = target - Psi @ theta
    return (r, np.arange(start, data.n)) if np.all(np.isfinite(r)) else None


def model_tests(model, data, max_lag: int = 20, alpha: float = 0.01
                ) -> List[CorrelationTest]:
    """The four tests of ``model`` on ``data`` with completed residuals (see
    the module docstring): ``ee``/``ue`` on the statically completed
    residual, ``u2e``/``u2e2`` on the linearly completed one. Empty when the
    record is too short (fewer than 21 residuals)."""
    y = data.output
    linear = [f"{s}[k-{j}]" for s in (y, *data.inputs) for j in range(1, 5)]
    static = [f"{y}[k-1]*{y}[k-1]", f"{y}[k-1]*{y}[k-1]*{y}[k-1]"]
    for n in data.inputs:
        static += [f"{n}[k-1]*{n}[k-1]", f"{n}[k-1]*{n}[k-1]*{n}[k-1]", f"{y}[k-1]*{n}[k-1]"]
    out = []
    for extra, keys, what in ((static, ("ee", "ue"), "static terms of the last samples"),
                              (linear, ("u2e", "u2e2"), "linear lags 1-4")):
        got = completed_residual(model, data, extra)
        if got is None or got[0].size <= 20:
            return []
        r, rows = got
        rms = float(np.sqrt(np.mean(r ** 2)))
        tests = correlation_tests(r, {n: data.input(n)[rows] for n in data.inputs},
                                  max_lag, alpha)
        out += [replace(t, rms=rms, completed=what) for t in tests if t.key in keys]
    order = {n: i for i, n in enumerate(data.inputs)}
    return sorted(out, key=lambda t: (order.get(t.signal, -1),
                                      ("ee", "ue", "u2e", "u2e2").index(t.key)))


_EFFECT = {"ee": "unmodelled-dynamics", "ue": "unmodelled-dynamics",
           "u2e": "unmodelled-nonlinearity", "u2e2": "unmodelled-nonlinearity"}


def correlation_checks(tests: List[CorrelationTest], floor: float, osa_rms: float,
                       resolution: Optional[float] = None,
                       freerun_rms: Optional[float] = None) -> List[Check]:
    """A check per test: max |φ| against max(Bonferroni band, floor / (r s)).

    Parameters
    ----------
    tests : list of CorrelationTest
    floor : float
        Resolution floor in output units (a free-run error).
    osa_rms : float
        RMS of the model's own one-step residual (for a test whose ``rms``
        is None, and the denominator of the propagation factor s).
    resolution : float, optional
        The resolution that made ``floor`` (fraction of the output's range),
        to say which resolution would give a test without power its power.
    freerun_rms : float, optional
        RMS of the model's free-run error on the same samples; the
        propagation factor is s = max(1, freerun_rms / osa_rms) (module
        doc; ``inf`` for a diverged free run, whose floor is then 0).
        None: s = 1 (the floor compared with the one-step residual as is).

    Returns
    -------
    list of Check
        Ceiling 1; a check whose threshold is 1 or more has no power and
        says why in one line (:func:`no_power_reason`).
    """
    s = propagation_factor(osa_rms, freerun_rms)
    out = []
    for t in tests:
        r_rms = osa_rms if t.rms is None else t.rms          # of the residual tested
        scale = r_rms * s                                    # its free-run counterpart
        floor_r = floor / scale if scale > 0 else float("inf")
        thr = max(t.band, floor_r)
        detail = (t.describe() + f"; resolution floor {_g(floor_r)} in correlation units "
                  f"(floor {_g(floor)} / (RMS {_g(r_rms)} of the residual tested × "
                  f"free-run/one-step factor {_g(s)}))")
        why = ""
        if thr >= 1.0:
            why = no_power_reason(t, scale, floor, resolution)
            detail += (f"; no power: the threshold {_g(thr)} is at least 1, the largest "
                       f"correlation there is, because {why}: this test could not fire")
        out.append(Check(t.label, _EFFECT[t.key], t.max_abs, thr, detail, 1.0, why))
    return out


def propagation_factor(osa_rms: float, freerun_rms: Optional[float]) -> float:
    """s = max(1, freerun_rms / osa_rms): how much larger the free-run error
    is than the one-step residual (1 when ``freerun_rms`` is None; ``inf``
    when the free run diverged or the one-step residual is zero)."""
    if freerun_rms is None:
        return 1.0
    if not np.isfinite(freerun_rms):
        return float("inf")
    return max(1.0, freerun_rms / osa_rms) if osa_rms > 0 else float("inf")


def no_power_reason(t: CorrelationTest, scale: float, floor: float,
                    resolution: Optional[float] = None) -> str:
    """Why test ``t`` cannot fire, with the numbers that would change it.

    Either the free-run counterpart ``scale`` (r s) of the residual tested
    is no larger than the resolution floor (then floor / scale >= 1 and no
    correlation can explain the floor; the resolution below which it could
    is resolution × scale / floor; below :data:`mggp.fit.choices.RESOLUTION` of
    the output's range the residual is rounding, and the reason says so),
    or its Bonferroni band z/√N is 1 or
    more (then more than z² samples are needed).
    """
    if floor >= scale:
        text = (f"the residual tested, carried to the free-run scale (RMS {_g(scale)}), "
                f"is no larger than the resolution floor ")
        if scale <= 0:
            return text + f"{_g(floor)}: it is zero, there is nothing to correlate"
        if resolution and scale <= ROUNDING * floor / resolution:
            return (f"the residual tested, carried to the free-run scale (RMS {_g(scale)}), "
                    f"is rounding (below {ROUNDING:g} of the output's range): the model "
                    f"reproduces these samples and there is nothing to correlate")
        text += f"{_g(floor)}, {_g(floor / scale)} times that RMS"
        if resolution:
            text += (f" (a correlation could reach the floor only with a resolution below "
                     f"{_g(resolution * scale / floor)} instead of {resolution:g})")
        return text
    z = t.band * np.sqrt(t.n)
    return (f"the Bonferroni band z/√N = {_g(t.band)} of N = {t.n} samples is at least 1 "
            f"(more than z² = {_g(z * z)} samples are needed)")


def _run(ctx) -> Outcome:
    tests = model_tests(ctx.model, ctx.fit, ctx.budget.corr_lags, ctx.alpha)
    if not tests:
        return Outcome(missing="correlation tests (fewer than 21 one-step residuals)")
    return Outcome(correlation_checks(tests, ctx.floor, ctx.osa_rms, ctx.resolution,
                                      ctx.freerun_rms), tests)


#: Billings–Voon tests of the completed one-step residuals.
CORRELATION = DiagnosticTest("correlation", ("unmodelled-dynamics",
                                             "unmodelled-nonlinearity"), _run)
