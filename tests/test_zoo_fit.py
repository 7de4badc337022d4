"""The zoo fit study's table and command line (benchmarks.zoo_fit): the
share within the goal, explosions and failures counted, identifiable
draws from the diagnosis records, development seeds only in calibrate."""
import json

from benchmarks.zoo_fit import GOAL, fit_table, main


def rec(seed, family, hysteretic, ratio, exploded=False, **kw):
    r = {"seed": seed, "family": family, "hysteretic": hysteretic, "ratio": ratio,
         "fit_rmse": None if ratio is None else ratio, "oracle_rmse": 1.0,
         "exploded": exploded, "seconds": 10.0}
    r.update(kw)
    return r


RECS = [rec(1000, "play", True, 1.2), rec(1001, "play", True, 3.0),
        rec(1002, "bouc-wen", True, 1.0, exploded=True), rec(1003, "linear", False, 1.0),
        rec(1004, "bilinear", False, GOAL + 0.01),
        {"seed": 1005, "family": "wiener", "hysteretic": False, "error": "boom",
         "seconds": 1.0}]


def test_table_counts_the_goal_explosions_and_failures():
    t = fit_table(RECS)
    assert "1/3 (33 %) hysteretic draws" in t          # 1.2 holds; 3.0 and the explosion not
    assert "1/3 (33 %) controls" in t                  # 1.0 holds; 1.51 and the failure not
    assert "exploded or failed: 2/6" in t
    assert "| play | 2 | 1 | 0 |" in t


def test_identifiable_draws_come_from_the_diagnosis_records():
    zoo = [{"seed": 1000, "identifiable": True, "input_kind": "sine"},
           {"seed": 1001, "identifiable": False}, {"seed": 1002, "identifiable": False},
           {"seed": 1003, "input_kind": "sine"}, {"seed": 1004, "input_kind": "chirp"}]
    t = fit_table(RECS, zoo)
    assert "1/1 (100 %) identifiable hysteretic" in t
    assert "2/4 (50 %) of both together" in t
    assert "not identifiable, on their own: 0/2 (0 %)" in t
    assert "| sine | 1/1 | 1/1 |" in t and "| chirp | 0/0 | 0/1 |" in t
    # control: without them every hysteretic draw counts
    assert "identifiable" not in fit_table(RECS).split("\n")[0]


def test_cli_table_and_its_errors(tmp_path, capsys):
    path = tmp_path / "fit.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in RECS) + '{"torn')
    assert main(["table", str(path)]) == 0
    assert "Default fit against the oracle" in capsys.readouterr().out
    # the diagnosis records may come in several files, read as one
    z1, z2 = tmp_path / "z1.jsonl", tmp_path / "z2.jsonl"
    z1.write_text(json.dumps({"seed": 1000, "identifiable": True}) + "\n")
    z2.write_text("".join(json.dumps({"seed": s, "identifiable": False}) + "\n"
                          for s in (1001, 1002)))
    assert main(["table", str(path), "--zoo", str(z1), str(z2)]) == 0
    assert "1/1 (100 %) identifiable hysteretic" in capsys.readouterr().out
    assert main(["table", str(path), "--zoo", str(z1)]) == 0     # control: 1001, 1002 count
    assert "1/3 (33 %) identifiable hysteretic" in capsys.readouterr().out
    assert main(["table", str(tmp_path / "none.jsonl")]) == 2
    assert "no records" in capsys.readouterr().err
    assert main(["calibrate", "--seeds", "1000", "--json", str(path)]) == 2
    assert "evaluation seed" in capsys.readouterr().err
    assert main(["fit", "--seeds", "1", "--json", str(path), "--jobs", "0"]) == 2
