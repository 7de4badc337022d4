"""The panel's verdict code on rows built by hand (no search)."""
import json

import numpy as np
import pytest

from benchmarks.panel import GOAL, main, markdown, merge, verdict_spread


def _rows(default, **grid):
    return {"default": [{"rmse": v} for v in default],
            **{k: [{"rmse": v} for v in vs] for k, vs in grid.items()}}


def test_a_default_equal_to_the_best_setting_is_within_in_every_draw():
    rows = _rows([1.0, 2.0, 3.0], a=[1.0, 2.0, 3.0], b=[5.0, 5.0, 5.0])
    sp = verdict_spread(rows)
    assert sp["low"] == sp["high"] == 1.0 and sp["within"] == 1.0


def test_a_default_clearly_worse_is_within_in_no_draw():
    rows = _rows([1.5, 1.6, 1.7], a=[1.0, 1.0, 1.0], b=[1.2, 1.3, 1.2])
    sp = verdict_spread(rows)
    assert sp["within"] == 0.0 and sp["low"] >= 1.5 / 1.2 - 1e-12


def test_seed_noise_shows_as_a_wide_interval():
    """Same medians as above would give one ratio; seeds that spread widely
    give draws on both sides of the goal."""
    rows = _rows([1.0, 1.05, 1.6, 1.1, 0.9, 1.4], a=[1.0, 1.3, 0.95, 1.2, 1.0, 1.1])
    sp = verdict_spread(rows)
    assert sp["low"] < GOAL < sp["high"] and 0.0 < sp["within"] < 1.0
    # a fixed seed of the draws fixes the figures
    assert verdict_spread(rows) == sp


def test_settings_with_other_seeds_are_refused():
    with pytest.raises(ValueError, match="same seeds"):
        verdict_spread(_rows([1.0, 1.0], a=[1.0]))


def test_saved_runs_of_other_seeds_are_pooled_and_tabulated(tmp_path, capsys):
    r1 = {"rec": _rows([1.0, 1.1], a=[1.0, 1.0])}
    r2 = {"rec": _rows([1.2], a=[0.9])}
    assert [r["rmse"] for r in merge([r1, r2])["rec"]["default"]] == [1.0, 1.1, 1.2]
    p1, p2 = tmp_path / "a.json", tmp_path / "b.json"
    p1.write_text(json.dumps(r1))
    p2.write_text(json.dumps(r2))
    assert main(["--from-json", str(p1), str(p2)]) == 0
    out = capsys.readouterr().out
    assert "| rec | 1.1 | 0/3 | `a` | 1 | 0/3 | 1.100 | yes |" in out
    assert main(["--from-json", str(tmp_path / "missing.json")]) == 2
    assert "missing.json" in capsys.readouterr().err


def test_markdown_counts_a_diverged_default_as_a_miss():
    rows = _rows([1.0, np.inf, 1.0], a=[1.0, 1.0, 1.0])
    assert "| rec | 1 | 1/3 | `a` | 1 | 0/3 |" in markdown({"rec": rows})
    assert "| NO |" in markdown({"rec": rows})


def test_markdown_shows_the_best_settings_divergences():
    """The median rule lets a best setting win with a diverged seed; the
    table says so beside it."""
    rows = _rows([1.05, 1.05, 1.05], a=[1.0, np.inf, 1.0], b=[2.0, 2.0, 2.0])
    assert "| rec | 1.05 | 0/3 | `a` | 1 | 1/3 | 1.050 | yes |" in markdown({"rec": rows})


def test_grid_from_fits_the_default_only_and_keeps_the_grid_rows(tmp_path, monkeypatch, capsys):
    """--grid-from: the default row is fitted again (here a stand-in fit),
    every grid setting's rows are the saved run's; a saved run of other
    seeds is one error line and exit code 2."""
    import benchmarks.panel as panel
    fitted = []

    def fake_fit(tr, va, seed, kw, budget, jobs):
        fitted.append((seed, kw))
        return {"rmse": 0.5 + seed, "terms": 3, "seconds": 0.0, "choices": {}}
    monkeypatch.setattr(panel, "RECORDS", {"rec": lambda: ("tr", "va")})
    monkeypatch.setattr(panel, "_fit", fake_fit)
    saved = {"rec": {"default": [{"rmse": 9.0}, {"rmse": 9.0}],
                     **{k: [{"rmse": 1.0 + i}, {"rmse": 2.0 + i}]
                        for i, k in enumerate(panel.GRID)}}}
    src, out = tmp_path / "saved.json", tmp_path / "new.json"
    src.write_text(json.dumps(saved))
    assert main(["--seeds", "1", "2", "--records", "rec", "--grid-from", str(src),
                 "--json", str(out)]) == 0
    assert fitted == [(1, {}), (2, {})]                   # the default only
    new = json.loads(out.read_text())["rec"]
    assert [r["rmse"] for r in new["default"]] == [1.5, 2.5]
    assert {k: v for k, v in new.items() if k != "default"} == \
        {k: v for k, v in saved["rec"].items() if k != "default"}
    capsys.readouterr()
    assert main(["--seeds", "1", "2", "3", "--records", "rec", "--grid-from", str(src)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: --grid-from") and "3 seeds" in err[0]
