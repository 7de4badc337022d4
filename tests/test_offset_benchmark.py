"""benchmarks.offset: its records hold the system its docstring states, and
its table counts what the rows say (no search)."""
import numpy as np
import pytest

import narx
from benchmarks.offset import level_record, markdown, true_terms


@pytest.mark.parametrize("level", [0.0, 20.0, 1000.0])
def test_the_record_is_the_stated_system_in_y(level):
    """Noise-free, LS on the true structure returns θ = (0.5 L, 0.6, -0.1,
    0.5, 0.3) for y = 0.5 L + 0.6 y[k-1] - 0.1 y[k-2] + 0.5 u[k-1] + 0.3 u[k-1]²
    (no constant at L = 0); the output stays near L."""
    d = level_record(n=600, seed=3, level=level, noise=0.0)
    terms = true_terms(level)
    model = narx.Model(terms).fit(d)
    theta = dict(zip(model.term_texts, model.theta))
    want = {"y[k-1]": 0.6, "y[k-2]": -0.1, "u[k-1]": 0.5, "u[k-1]*u[k-1]": 0.3}
    if level:
        want["1"] = 0.5 * level
    assert set(theta) == set(want)
    for k, v in want.items():
        assert theta[k] == pytest.approx(v, abs=1e-6 * max(1.0, level))
    assert abs(np.median(d.y) - level) < 3.0


def test_input_amplitude_and_holds():
    d = level_record(n=95, seed=0, amplitude=2.0, hold=10)
    u = d.input("u")
    assert d.n == 95 and np.abs(u).max() <= 2.0 and np.abs(u).max() > 1.0
    assert np.all(u[:10] == u[0]) and u[10] != u[9]


def test_markdown_counts_the_rows():
    rows = [{"constant": True, "exact": True, "rmse": 1.0},
            {"constant": True, "exact": False, "rmse": 3.0},
            {"constant": False, "exact": False, "rmse": np.inf}]
    md = markdown({20.0: {"default": rows, "no-constant": rows[2:]}})
    assert "| 20 | `default` | 2/3 | 1/3 | 3 |" in md
    assert "| 20 | `--no-constant` | 0/1 | 0/1 | inf |" in md
