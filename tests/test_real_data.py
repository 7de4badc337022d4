"""benchmarks.real_data: the shared records load as u, y and the table shows
every row (no search here: a hand-made result)."""
import numpy as np
import pytest

from benchmarks.real_data import RECORDS, load_record, markdown


@pytest.mark.parametrize("name", list(RECORDS))
def test_records_load_as_u_and_y(name):
    pair = load_record(name)
    if pair is None:
        pytest.skip("shared data not found")
    tr, va = pair
    assert tr.inputs == ("u",) and tr.output == "y"
    assert tr.n > 900 and va.n > 900
    assert np.all(np.isfinite(tr.y)) and np.all(np.isfinite(va.y))
    assert not np.array_equal(tr.y[:900], va.y[:900])        # two records, not one


def test_markdown_rows_and_published_figures():
    res = {"cascaded tanks": {"rows": [{"setting": "--no-phi", "rmse": [0.4, 0.5, float("inf")],
                                        "terms": [15, 14, 15], "seconds": [4.0, 5.0, 6.0]}],
                              "published": {"PNLSS": 0.45}}}
    md = markdown(res, [1, 2, 3])
    assert "| --no-phi | 0.5 | 0.4 | inf | 15 | 5.0 |" in md
    assert "| PNLSS, published | 0.45 |" in md
