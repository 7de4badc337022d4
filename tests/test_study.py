"""Smoke test of the headline study script (tiny budget) and its goal logic."""
import json
import os

import numpy as np

from benchmarks import pem_vs_ms, published_structures
from benchmarks.casestudy import case_data, model19, score_model


def uncaptioned_figures(markdown: str) -> list:
    """Images of a Markdown report not followed by an italic 'Figure N.' caption."""
    lines = [ln for ln in markdown.splitlines() if ln.strip()]
    return [ln for i, ln in enumerate(lines) if ln.startswith("![")
            and not (i + 1 < len(lines) and lines[i + 1].startswith("*Figure "))]


def test_uncaptioned_figures_are_found():
    assert uncaptioned_figures("![a](a.png)\n\n*Figure 1. A.*\n") == []
    assert uncaptioned_figures("![a](a.png)\n\ntext\n![b](b.png)") == ["![a](a.png)",
                                                                        "![b](b.png)"]


def test_study_runs_end_to_end_and_writes_report(tmp_path):
    out = tmp_path / "rep"
    js = tmp_path / "s.json"
    code = pem_vs_ms.main(["--n", "4000", "--population", "12", "--generations", "2",
                           "--window", "200", "--jobs", "1", "--peers", "no",
                           "--no-damper", "--out", str(out), "--json", str(js)])
    assert code == 0
    text = (out / "report.md").read_text()
    for name in ("PEM-LS", "MS-LS", "model (19) CLS", "missing"):
        assert name in text
    for fig in ("loops.png", "freerun.png", "held.png", "convergence.png"):
        assert os.path.getsize(out / fig) > 1000
    assert text.split("\n")[2].startswith("**Conclusion.**")     # first, under the title
    assert uncaptioned_figures(text) == []
    assert text.count("![") == 4
    doc = json.loads(js.read_text())
    assert {r["name"] for r in doc["summary"]} >= {"PEM-LS", "MS-LS", "model (19) CLS"}
    assert doc["settings"]["filter_order"] == 4 and "low-pass of order 4 (data seed 0)" in text


def test_goal_logic_flags_shortfalls():
    summ = [dict(name="PEM-LS", val_mape=1.0), dict(name="MS-LS", val_mape=0.25),
            dict(name="MS-CLS", val_mape=0.5, drift_loading_max=0.0, drift_unloading_max=1.0,
                 ss_loading=0.1, ss_unloading=0.1)]
    checks = {t: ok for t, ok, _ in pem_vs_ms.goals(summ, False, 100.0)}
    assert checks["MS-LS val MAPE <= 0.3"]
    assert not checks["PEM-LS at least 5x worse than MS-LS"]
    assert not checks["MS-CLS val MAPE <= 0.4"]
    assert not checks["MS-CLS drift under 1e-6 of the output range (µm)"]


def test_published_model19_scores_as_published():
    cs = case_data(n=2000)
    r = score_model(model19(), cs)
    assert abs(r["val_mape"] - 0.241) < 0.03


def test_filter_order_changes_the_training_record_only():
    a, b = case_data(n=3000, order=4), case_data(n=3000, order=1)
    assert not np.array_equal(a.u, b.u)
    assert np.array_equal(a.uv, b.uv) and np.array_equal(a.yh, b.yh)
    assert np.ptp(a.u) == np.ptp(b.u)                       # both span +/-80 V
    rate = [np.sqrt(np.mean(np.diff(c.u) ** 2)) for c in (a, b)]
    assert rate[1] > 1.3 * rate[0]                          # 1st order: faster rates


def test_published_structures_table(capsys):
    assert published_structures.main(["--orders", "1", "4", "--n", "4000"]) == 0
    text = capsys.readouterr().out
    rows = published_structures.run(orders=[4], seeds=[0], n=4000)
    assert [(r["structure"], r["estimator"]) for r in rows] == [
        ("model (19)", "LS"), ("model (19)", "CLS"), ("model (33)", "LS"), ("model (33)", "CLS")]
    assert all(np.isfinite(r["val_mape"]) for r in rows if r["structure"] == "model (19)")
    assert "| 1 | model (19) | CLS |" in text and "0.44 / 0.241" in text


def test_mr_damper_data_ships_with_the_benchmarks(tmp_path, monkeypatch):
    from benchmarks import mr_damper
    monkeypatch.setenv("MGGP_SHARED_DATA", str(tmp_path))        # no file there
    path = mr_damper.damper_path()
    assert path is not None and os.path.basename(os.path.dirname(path)) == "data"
    tr, te = mr_damper.load_damper(path)
    assert tr.shape == (1600, 3) and te.shape == (1599, 3)
    assert np.max(np.abs(tr), axis=0).tolist() == [1.0, 1.0, 1.0]   # scaled on training


def test_study_rejects_bad_settings_in_one_line(capsys):
    import pytest
    for argv, text in ((["--filter-order", "0"], "--filter-order must be >= 1, got 0"),
                       (["--data-seed", "-1"], "seeds must be >= 0"),
                       (["--window", "0"], "--window must be >= 1, got 0")):
        with pytest.raises(SystemExit) as e:
            pem_vs_ms.main(argv + ["--peers", "no", "--no-damper"])
        assert e.value.code == 2 and text in capsys.readouterr().err


def test_error_groups_keep_small_errors_on_their_own_axis():
    """Errors within ten times of a group's largest share its panel; the
    0.2-sized errors do not share the 20-sized ones'."""
    from mggp.report.summary import error_groups
    y = np.zeros(100)
    sims = {n: np.full(100, v) for n, v in
            (("MS-LS", 0.2), ("PEM", 22.0), ("toolbox", 4.5), ("m19", 1.2), ("MS-CLS", 0.19))}
    assert error_groups(y, sims) == [["PEM", "toolbox"], ["m19", "MS-LS", "MS-CLS"]]
    assert error_groups(y, {"a": np.ones(100)}) == [["a"]]
