"""benchmarks.oscillator: its records and its scoring, without a search."""
import numpy as np

import narx
from benchmarks.oscillator import _rmse_m, records


def test_records_are_the_oscillator_driven_by_a_multisine_and_a_sweep():
    tr, ms, sw = records(n_train=600, n_multisine=300, n_sweep=400, seed=0)
    assert (tr.n, ms.n, sw.n) == (600, 300, 400)
    assert abs(np.std(tr.input("u")) - 50.0) < 1e-9            # 50 N RMS
    assert np.max(np.abs(sw.input("u"))) <= 40.0 + 1e-9
    assert sw.y[0] == 0.0                                      # the sweep starts from rest
    assert not np.allclose(tr.input("u")[:300], ms.input("u"))  # two multisines
    again = records(n_train=600, n_multisine=300, n_sweep=400, seed=0)[0]
    assert np.array_equal(again.y, tr.y)                       # seeded
    # hysteresis: the restoring force is not a function of the displacement,
    # so a linear ARX model leaves a free-run error (a control: the same
    # model simulating its own output has none)
    arx = narx.Model(["y[k-1]", "y[k-2]", "u[k-1]", "u[k-2]"]).fit(tr)
    own = narx.Data(tr.input("u"), arx.simulate(tr, mode="freerun").y_hat)
    assert _rmse_m(arx, tr) > 1e-7
    assert _rmse_m(arx, own) < 1e-12
