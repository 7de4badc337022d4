"""The diagnosis report of a record with two inputs: loops and residual planes for every input (or the ones picked), labels
that read as written, a caption under every figure."""
import numpy as np
import pytest

from narx import Model
from narx.records.data import Data
from mggp.diagnose import Budget, diagnose
from mggp.diagnose.report import write_report

from test_study import uncaptioned_figures


def _two_input_record(n=1500, seed=0):
    r = np.random.default_rng(seed)
    a, v = r.uniform(-1, 1, n), r.uniform(-1, 1, n)
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.5 * y[k - 1] + 0.4 * a[k - 1] + 0.3 * v[k - 1] ** 2 + 0.01 * r.standard_normal()
    return Data(np.c_[a, v], y, inputs=("uEst", "v"), output="f")


@pytest.fixture(scope="module")
def dx():
    d = _two_input_record()
    model = Model(["f[k-1]", "uEst[k-1]"], inputs=("uEst", "v"), output="f").fit(d)
    return diagnose(d, model=model, budget=Budget(population=30, generations=4,
                                                  max_height=3), seed=1)


def test_every_input_is_plotted_and_captioned(dx, tmp_path):
    text = open(write_report(tmp_path / "all", dx)).read()
    assert uncaptioned_figures(text) == []
    assert text.count("![") == 2 + ("holds.png" in text) + ("quasistatic.png" in text)
    assert "each input (uEst, v)" in text
    picked = open(write_report(tmp_path / "v", dx, inputs=["v"])).read()
    assert "each input (v)" in picked and "(uEst, v)" not in picked
    with pytest.raises(ValueError, match=r"inputs: the data's inputs are \['uEst', 'v'\], "
                                         r"got \['w'\]"):
        write_report(tmp_path / "w", dx, inputs=["w"])


def test_summary_names_the_closest_miss_and_what_the_floor_hides():
    from types import SimpleNamespace
    from mggp.diagnose.findings import Check
    from mggp.diagnose.report import closest_misses
    ev = SimpleNamespace(floor=0.852, resolution=0.005)
    checks = [Check("Φ-augmentation", "hysteresis", 0.379, 0.852, ""),
              Check("free-run excess", "prediction-bias", 1.588, 1.67, ""),
              Check("loop gap (u)", "hysteresis", 0.1, 1.136, ""),         # far below
              Check("φ_ue", "unmodelled-dynamics", 0.5, 0.3, "")]           # beats
    out = closest_misses(SimpleNamespace(checks=checks, evidence=ev))
    assert len(out) == 2
    assert out[0].startswith("free-run excess (prediction-bias) 1.588") and "floor" not in out[0]
    assert out[1].startswith("Φ-augmentation (hysteresis) 0.379 against its threshold 0.852, "
                             "the resolution floor (0.005 of the output range)")
    assert "--resolution" in out[1]
    # control: nothing close to its threshold, nothing said
    far = [Check("loop gap (u)", "hysteresis", 0.1, 1.136, "")]
    assert closest_misses(SimpleNamespace(checks=far, evidence=ev)) == []
