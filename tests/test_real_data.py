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


def test_shared_data_are_looked_for_beside_the_project(monkeypatch):
    """Without MGGP_SHARED_DATA the last folder searched is ../shared/data
    from the project root (where a clone has the project's shared data)."""
    import os
    from benchmarks.mr_damper import data_dirs
    monkeypatch.delenv("MGGP_SHARED_DATA", raising=False)
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    assert data_dirs()[-1] == os.path.normpath(os.path.join(root, "..", "shared", "data"))
    monkeypatch.setenv("MGGP_SHARED_DATA", "/elsewhere")
    assert data_dirs()[0] == "/elsewhere"


def test_missing_data_exit_2_with_one_error_line(monkeypatch, capsys):
    from benchmarks import mr_damper, real_data
    monkeypatch.setattr(mr_damper, "data_path", lambda name: None)
    assert real_data.main(["--seeds", "1"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.strip().splitlines()) == 1
    assert err.startswith("error: shared data not found: cascaded_tanks.csv")


@pytest.mark.parametrize("module", ["panel", "diagnose_panel"])
def test_panels_exit_2_with_one_error_line_when_data_are_missing(module, monkeypatch, capsys):
    import importlib
    from benchmarks import mr_damper
    monkeypatch.setattr(mr_damper, "data_path", lambda name: None)
    assert importlib.import_module(f"benchmarks.{module}").main([]) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.strip().splitlines()) == 1
    assert err.startswith("error: shared data not found: ")
