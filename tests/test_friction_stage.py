"""The simulated friction stage: it sticks, and its true structure holds it."""
import numpy as np

from benchmarks import friction_stage as fs
from narx import Model


def _stuck_share(q):
    return float(np.mean(np.diff(q) == 0.0))


def test_the_stage_sticks_only_with_coulomb_friction():
    r = fs.reference(3000, np.random.default_rng(0))
    _, q = fs.stage(r)
    _, q_free = fs.stage(r, fs.Stage(fc=0.0))          # control: no Coulomb friction
    assert _stuck_share(q) > 0.05
    assert _stuck_share(q_free) < 0.01


def test_the_true_structure_finds_the_coulomb_term():
    train, val = fs.records(0, n=3000, noise=0.0)
    m = Model(list(fs.TRUTH)).fit(train)
    th = dict(zip((str(t) for t in m.terms), m.theta))
    # q[k] ≈ (2 − cT/m) q[k-1] − (1 − cT/m) q[k-2] + T²/m F − T² Fc/m sign(v), in mm
    assert abs(th["y[k-1]"] + th["y[k-2]"] - 1.0) < 1e-3
    assert th["Phi2(y[k-1],y[k-2])"] < 0                   # friction opposes the motion
    plain = Model(list(fs.TRUTH[:3])).fit(train)           # control: without the friction term
    e_true = m.simulate(val, mode="freerun").rmse
    assert plain.simulate(val, mode="freerun").rmse > 1.3 * e_true
