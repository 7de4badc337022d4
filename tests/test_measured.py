"""The measured-record panel: its explosion rule and one smoke fit."""
import numpy as np
import pytest

from benchmarks import measured


def test_explodes_names_a_free_run_outside_three_ranges():
    y = np.sin(np.linspace(0, 20, 500))            # range [-1, 1]: band [-3, 3]
    assert not measured.explodes(y * 2.9, y)       # control: inside the band
    assert measured.explodes(y * 3.1, y)
    assert measured.explodes(np.r_[y[:-1], np.inf], y)
    assert measured.explodes(np.r_[y[:-1], np.nan], y)


def test_panel_fits_a_record_and_tabulates_it():
    if measured.RECORDS["buck converter"][0]() is None:
        pytest.skip("shared data not found")
    res = measured.run(["buck converter"], [1], {"population": 12, "generations": 2}, 1,
                       log=lambda s: None)
    row = res["buck converter"]["rows"][0]
    assert np.isfinite(row["rmse"]) and row["terms"] >= 1
    assert "constant" in row["choices"]
    md = measured.markdown(res)
    assert md.splitlines()[0].startswith("The default `mggp fit` exploded on")
    assert "| buck converter |" in md
