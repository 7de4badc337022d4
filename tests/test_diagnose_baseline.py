"""The diagnosis's baseline must stay bounded over the records it is run
on (:func:`mggp.diagnose.extend.bounded_baseline`); fronts built by hand,
no search."""
import numpy as np

from narx import Model
from narx.records.data import Data
from mggp.diagnose.extend import bounded_baseline


def _record(n=800, seed=0, amplitude=0.6):
    """y[k] = 0.5 y[k-1] + 0.15 y[k-1]^3 + 0.5 u[k-1], u uniform in ±0.6:
    bounded on its own input, without a steady state once the input is
    scaled 1.5× (0.5 y + 0.15 y^3 + 0.45 > y for every y > 0)."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.uniform(-amplitude, amplitude, n // 10), 10)
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = float(np.clip(0.5 * y[k - 1] + 0.15 * y[k - 1] ** 3 + 0.5 * u[k - 1], -1e6, 1e6))
    return Data(u[:, None], y, inputs=["u"], output="y")


CUBIC = ["y[k-1]", "y[k-1]*y[k-1]*y[k-1]", "u[k-1]"]
LINEAR = ["y[k-1]", "u[k-1]"]


def _front(data):
    rows = []
    for terms in (["y[k-1]"], LINEAR, CUBIC):
        m = Model(terms, inputs=["u"], output="y").fit(data)
        e = data.y[1:] - m.simulate(data, mode="pem").y_hat[1:]
        rows.append({"complexity": len(terms), "loss": float(np.mean(e * e)) + 1e-12 * len(terms),
                     "terms": terms})
    return sorted(rows, key=lambda r: r["complexity"])


def test_a_baseline_that_diverges_on_a_record_gives_way_to_a_bounded_one():
    d, other = _record(), _record(seed=1, amplitude=0.9)   # the other record reaches 1.5x
    cubic = Model(CUBIC, inputs=["u"], output="y").fit(d)
    assert np.isfinite(cubic.simulate(d, mode="freerun").rmse)   # fine on its own samples
    got = bounded_baseline(cubic, _front(d), d, [("train", d), ("other", other)])
    assert sorted(got.term_texts) == sorted(LINEAR)             # the least-loss bounded row
    assert "diverges over other" in got.meta["bounded"] and "front" in got.meta["bounded"]


def test_a_baseline_bounded_on_its_records_is_kept_as_searched():
    d = _record()
    cubic = Model(CUBIC, inputs=["u"], output="y").fit(d)
    got = bounded_baseline(cubic, _front(d), d, [("train", d), ("other", _record(seed=1))])
    assert got is cubic and got.meta["bounded"] == "the search's model"


def test_when_no_structure_is_bounded_the_search_model_is_kept_and_said():
    d, other = _record(), _record(seed=1, amplitude=0.9)
    cubic = Model(CUBIC, inputs=["u"], output="y").fit(d)
    front = [r for r in _front(d) if r["terms"] == CUBIC]
    got = bounded_baseline(cubic, front, d, [("train", d), ("other", other)])
    assert got is cubic and "every structure of its front; kept" in got.meta["bounded"]
