"""mggp diagnose: findings that do not depend on units, noise on a held input,
tests that cannot fire, and an extension that does not help.

Records are short and budgets tiny (the user's model is given, so no
baseline search runs); each test takes a few seconds.
"""
import numpy as np
import pytest

import narx
from narx.data import Data
from narx.systems import held_sine, piezo_bouc_wen, training_input

from mggp.diagnose import Budget, diagnose

TINY = Budget(population=20, generations=2, shifts=19, bootstrap=39)
P1, P2 = "Phi1(u[k-1],u[k-2])", "Phi2(u[k-1],u[k-2])"


def piezo_case(u_scale=1.0, y_scale=1.0):
    """A 2000-sample piezo record, a held sine to validate on, and a
    deliberately incomplete Bouc–Wen model (no u[k-1]·|Δu| term), all in the
    units given by the scales."""
    u = training_input(2000, bandwidth=4.0, seed=0)
    hs = held_sine(amplitude=60, freq=2.0, hold=0.5)
    train = Data(u * u_scale, piezo_bouc_wen(u) * y_scale)
    val = Data(hs.u * u_scale, piezo_bouc_wen(hs.u) * y_scale)
    model = narx.Model(["y[k-1]", P1, f"y[k-1]*{P1}*{P2}"]).fit(train)
    return train, val, model


# ------------------------------------------------------------------ units
@pytest.fixture(scope="module")
def base_diagnosis():
    train, val, model = piezo_case()
    return diagnose(train, val, model, budget=TINY, seed=0)


@pytest.mark.parametrize("u_scale, y_scale", [(1.0, 1e-6), (1.0, 1e6), (1e3, 1.0)],
                         ids=["y*1e-6", "y*1e6", "u*1e3"])
def test_findings_do_not_depend_on_the_units(base_diagnosis, u_scale, y_scale):
    # the completed residuals of the correlation tests were fitted without
    # column scaling: with y in µm×1e6, y[k-1]³ ~ 1e21 swamped the other
    # columns, the residual grew and φ_ee/φ_ue fired (unmodelled-dynamics)
    train, val, model = piezo_case(u_scale, y_scale)
    dx = diagnose(train, val, model, budget=TINY, seed=0)
    assert dx.effects == base_diagnosis.effects
    assert [c.test for c in dx.checks] == [c.test for c in base_diagnosis.checks]
    for c, c0 in zip(dx.checks, base_diagnosis.checks):
        if np.isfinite(c0.threshold) and c0.threshold > 0:
            assert c.statistic / c.threshold == pytest.approx(
                c0.statistic / c0.threshold, rel=1e-6, abs=1e-9), c.test
