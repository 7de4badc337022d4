"""The command line: the published model through `mggp simulate`, and bad input."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from mggp.cli.app import main
from benchmarks.casestudy import MODEL19 as _M19
from narx.systems import piezo_bouc_wen, sine_input

MODEL19 = {"output": "y", "inputs": ["u"], **_M19}


def write_csv(path, header, rows):
    with open(path, "w") as fh:
        fh.write(",".join(header) + "\n")
        for r in rows:
            fh.write(",".join(str(v) for v in r) + "\n")
    return str(path)


@pytest.fixture
def sine_csv(tmp_path):
    t, u = sine_input()
    y = piezo_bouc_wen(u)
    return write_csv(tmp_path / "sine.csv", ["t", "u", "y"], zip(t, u, y))


@pytest.fixture
def model19(tmp_path):
    p = tmp_path / "m19.json"
    p.write_text(json.dumps(MODEL19))
    return str(p)


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_error_line(err):
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("error: "), err
    assert "Traceback" not in err
    return lines[0]


def test_simulate_published_model19_mape(capsys, sine_csv, model19, tmp_path):
    out_csv = tmp_path / "pred.csv"
    code, out, err = run(capsys, "simulate", model19, sine_csv, "--out", out_csv)
    assert code == 0, err
    mape = float(out.split("MAPE")[1].split("%")[0])
    assert abs(mape - 0.241) <= 0.03
    lines = out_csv.read_text().splitlines()
    assert lines[0] == "t,u,y,y_hat"
    assert len(lines) == 5001


def test_estimate_then_simulate_roundtrip(capsys, sine_csv, tmp_path):
    m = tmp_path / "m.json"
    code, out, err = run(capsys, "estimate", sine_csv, "--terms", "y[k-1]",
                         "Phi1(u[k-1],u[k-2])", "--constraints", "steady-state",
                         "--out", m)
    assert code == 0, err
    d = json.loads(m.read_text())
    assert d["terms"] == ["y[k-1]", "Phi1(u[k-1],u[k-2])"]
    assert abs(d["theta"][0] - 1.0) < 1e-12          # Σ_y = 1 imposed
    code, out, err = run(capsys, "simulate", m, sine_csv, "--mode", "ksa", "--k", "5")
    assert code == 0 and "ksa: RMSE" in out


@pytest.mark.parametrize("content, needle", [
    ("t,u,y\n0,1,2\n1,nan,3\n2,1,1\n", "line 3, column 'u': value 'nan' is not finite"),
    ("t,u,y\n0,1,2\n1,2\n2,1,1\n", "line 3 has 2 fields but the header has 3"),
    ("t,u\n0,1\n1,2\n", "no column 'y' (columns: t, u; fields separated by ',')"),
    ("t,u,y\n0,1,abc\n", "line 2, column 'y': 'abc' is not a number"),
    ("", "empty file"),
    ("u,y,u\n1,2,3\n", "column 'u' appears 2 times"),
    ("u,y\n", "no data rows"),
])
def test_estimate_bad_csv(capsys, tmp_path, content, needle):
    p = tmp_path / "bad.csv"
    p.write_text(content)
    code, out, err = run(capsys, "estimate", p, "--terms", "y[k-1]", "u[k-1]")
    assert code == 2
    line = one_error_line(err)
    assert needle in line and "bad.csv" in line


@pytest.mark.parametrize("cmd", [["fit", "--population", "4", "--generations", "1"],
                                 ["estimate", "--terms", "y[k-1]"]])
def test_a_missing_default_column_names_the_option_that_names_it(capsys, tmp_path, cmd):
    p = write_csv(tmp_path / "rec.csv", ["time", "force", "y"], [(0, 1, 2), (1, 2, 3)])
    code, _, err = run(capsys, cmd[0], p, *cmd[1:])
    line = one_error_line(err)
    assert code == 2 and "no column 'u'" in line
    assert line.endswith("name the input columns with --input NAME [NAME ...]")
    q = write_csv(tmp_path / "rec2.csv", ["time", "u", "pos"], [(0, 1, 2), (1, 2, 3)])
    code, _, err = run(capsys, cmd[0], q, *cmd[1:])
    assert code == 2 and one_error_line(err).endswith("name the output column with --output NAME")
    # control: a column named by the user and missing gets no hint (it was named)
    code, _, err = run(capsys, cmd[0], p, "--input", "forces", *cmd[1:])
    line = one_error_line(err)
    assert code == 2 and "no column 'forces'" in line and "--input" not in line


def test_a_missing_model_signal_column_names_the_option_too(capsys, tmp_path):
    """simulate reads the model's signal names by default: a CSV without
    them gets the same hint, and none when the user named the columns."""
    rows = [(k, np.sin(k), np.cos(k)) for k in range(40)]
    rec = write_csv(tmp_path / "rec.csv", ["time", "force", "pos"], rows)
    m = tmp_path / "m.json"
    code, _, err = run(capsys, "estimate", rec, "--input", "force", "--output", "pos",
                       "--terms", "pos[k-1]", "force[k-1]", "--out", m)
    assert code == 0, err
    other = write_csv(tmp_path / "other.csv", ["u", "pos"], [(r[1], r[2]) for r in rows])
    code, _, err = run(capsys, "simulate", m, other)
    line = one_error_line(err)
    assert code == 2 and "no column 'force'" in line
    assert line.endswith("name the input columns with --input NAME [NAME ...]")
    code, _, err = run(capsys, "simulate", m, other, "--input", "f")     # control
    line = one_error_line(err)
    assert code == 2 and "no column 'f'" in line and "--input" not in line


def test_estimate_unknown_term(capsys, sine_csv):
    code, _, err = run(capsys, "estimate", sine_csv, "--terms", "y[k-1]", "Phi7(u[k-1])")
    assert code == 2
    assert "unknown Φ-function 'Phi7'" in one_error_line(err)


def test_estimate_too_few_samples(capsys, tmp_path):
    p = write_csv(tmp_path / "short.csv", ["u", "y"], [(1, 2), (2, 3), (3, 1)])
    code, _, err = run(capsys, "estimate", p, "--terms", "y[k-5]", "u[k-1]")
    assert code == 2
    assert "too few" in one_error_line(err)


def test_simulate_wrong_theta_count(capsys, tmp_path, sine_csv):
    bad = dict(MODEL19, theta=MODEL19["theta"][:-1])
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(bad))
    code, _, err = run(capsys, "simulate", p, sine_csv)
    assert code == 2
    line = one_error_line(err)
    assert "'theta' has 8 values but 'terms' has 9" in line and "bad.json" in line


def test_simulate_unknown_term_in_model(capsys, tmp_path, sine_csv):
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(dict(MODEL19, terms=["z[k-1]"] + MODEL19["terms"][1:])))
    code, _, err = run(capsys, "simulate", p, sine_csv)
    assert code == 2 and "unknown signal 'z'" in one_error_line(err)


def test_simulate_unstable_model_keeps_existing_output(capsys, tmp_path, sine_csv):
    p = tmp_path / "unstable.json"
    p.write_text(json.dumps({"output": "y", "inputs": ["u"],
                             "terms": ["y[k-1]", "u[k-1]"], "theta": [1.5, 1.0]}))
    out_csv = tmp_path / "pred.csv"
    out_csv.write_text("precious\n")
    code, _, err = run(capsys, "simulate", p, sine_csv, "--out", out_csv)
    assert code == 2
    assert "unstable" in one_error_line(err)
    assert out_csv.read_text() == "precious\n"


def test_simulate_nan_in_data(capsys, tmp_path, model19):
    p = write_csv(tmp_path / "nan.csv", ["u", "y"],
                  [(0, 0), (1, 1), (2, 2), (float("nan"), 1), (3, 3)])
    code, _, err = run(capsys, "simulate", model19, p)
    assert code == 2 and "line 5, column 'u'" in one_error_line(err)


def test_hostile_model_file_runs_nothing(capsys, tmp_path, sine_csv):
    marker = tmp_path / "pwned"
    p = tmp_path / "evil.json"
    p.write_text(json.dumps({"output": "y", "inputs": ["u"],
                             "terms": [f"__import__('os').system('touch {marker}')"],
                             "theta": [1.0]}))
    code, _, err = run(capsys, "simulate", p, sine_csv)
    assert code == 2
    one_error_line(err)
    assert not marker.exists()


def test_console_script_exit_code_and_single_line(tmp_path):
    p = write_csv(tmp_path / "d.csv", ["u", "y"], [(1, 2), (2, "x")])
    r = subprocess.run([sys.executable, "-m", "mggp", "estimate", p, "--terms", "y[k-1]"],
                       capture_output=True, text=True, env=dict(os.environ))
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and r.stderr.startswith("error: ")


def test_usage_error_is_one_line(capsys):
    code, _, err = run(capsys, "simulate")
    assert code == 2
    assert "required" in one_error_line(err)


def test_dependent_terms_warn_in_one_line_and_the_model_is_written(capsys, tmp_path):
    # u in {-1, 1}: u[k-1]*u[k-1] equals the constant term, so the record
    # cannot tell them apart; the fit still succeeds (minimum-norm θ)
    rng = np.random.default_rng(0)
    u = rng.choice([-1.0, 1.0], 200)
    y = np.r_[0.0, 0.7 * u[:-1]] + 0.3
    data = write_csv(tmp_path / "pm.csv", ["u", "y"], zip(u, y))
    out = tmp_path / "m.json"
    code, _, err = run(capsys, "estimate", data, "--terms", "1", "u[k-1]*u[k-1]", "u[k-1]",
                       "--out", out)
    assert code == 0 and out.exists()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("warning: "), err
    assert "have rank 2" in lines[0]
    # control: a record that separates them gives no warning
    u2 = rng.uniform(-1, 1, 200)
    data2 = write_csv(tmp_path / "pm2.csv", ["u", "y"], zip(u2, np.r_[0.0, u2[:-1]]))
    code, _, err = run(capsys, "estimate", data2, "--terms", "1", "u[k-1]*u[k-1]", "u[k-1]",
                       "--out", tmp_path / "m2.json")
    assert code == 0 and err.strip() == ""


@pytest.mark.parametrize("sep", [";", "\t"])
def test_semicolon_and_tab_files_with_decimal_commas(capsys, sine_csv, model19, tmp_path, sep):
    """Spreadsheet exports: ';' or tab separated, decimal commas; the same
    figures as the comma file, and the prediction written with the source's
    separator."""
    code, out, _ = run(capsys, "simulate", model19, sine_csv)
    assert code == 0
    lines = open(sine_csv).read().splitlines()
    p = tmp_path / "semi.csv"
    p.write_text("\n".join(sep.join(f.replace(".", ",") for f in ln.split(","))
                           for ln in lines) + "\n")
    pred = tmp_path / "pred.csv"
    code2, out2, err2 = run(capsys, "simulate", model19, p, "--out", pred)
    assert code2 == 0, err2
    assert out2.splitlines()[0] == out.splitlines()[0]          # same RMSE and MAPE
    head = pred.read_text().splitlines()[:3]
    assert head[0] == sep.join(["t", "u", "y", "y_hat"])
    assert len(head[1].split(sep)) == 4
    row = pred.read_text().splitlines()[-1]        # simulated (the first rows are empty)
    last = row.split(sep)[-1]                      # the source's decimal comma
    assert "," in last and "." not in last, row


def test_units_row_under_the_header_is_named(capsys, tmp_path):
    p = tmp_path / "units.csv"
    p.write_text("t;u;y\ns;V;um\n0;1;2\n1;2;3\n")
    code, _, err = run(capsys, "estimate", p, "--terms", "u[k-1]")
    line = one_error_line(err)
    assert code == 2 and "line 2" in line and "'V' is not a number" in line and "units" in line


def test_trailing_separators_on_data_rows_are_ignored(capsys, sine_csv, model19, tmp_path):
    code, out, _ = run(capsys, "simulate", model19, sine_csv)
    p = tmp_path / "trailing.csv"
    lines = open(sine_csv).read().splitlines()
    p.write_text("\n".join([lines[0]] + [ln + "," for ln in lines[1:]]) + "\n")
    pred = tmp_path / "pred.csv"
    code2, out2, err2 = run(capsys, "simulate", model19, p, "--out", pred)
    assert code2 == 0, err2
    assert out2.splitlines()[0] == out.splitlines()[0]
    assert all(len(r.split(",")) == 4 for r in pred.read_text().splitlines())
    bad = tmp_path / "bad.csv"                          # a filled extra field still counts
    bad.write_text("u,y\n1,2,3\n2,3\n")
    code3, _, err3 = run(capsys, "estimate", bad, "--terms", "u[k-1]")
    assert code3 == 2 and "line 2 has 3 fields but the header has 2" in err3


def test_column_name_that_is_no_identifier_gets_a_rename_hint(capsys, tmp_path):
    p = tmp_path / "v.csv"
    p.write_text("Voltage [V],y\n1,2\n2,3\n3,1\n4,2\n")
    code, _, err = run(capsys, "estimate", p, "--input", "Voltage [V]", "--terms", "u[k-1]")
    line = one_error_line(err)
    assert code == 2 and "'Voltage [V]'" in line and "rename the column (e.g. 'Voltage_V')" in line


@pytest.mark.parametrize("text", ['u,y,"unit: V;A;N;s"\n1,2,x\n2,3,y\n3,1,z\n4,2,w\n',
                                  'u;y;"a,b,c"\n1;2;x\n2;3;y\n3;1;z\n4;2;w\n'])
def test_separators_inside_quoted_header_fields_do_not_count(capsys, tmp_path, text):
    p = tmp_path / "q.csv"
    p.write_text(text)
    code, out, err = run(capsys, "estimate", p, "--terms", "u[k-1]")
    assert code == 0, err


def test_list_option_does_not_swallow_the_data_file(capsys, tmp_path):
    """`mggp fit --input E v data.csv --output f`: argparse gives data.csv to
    --input; it goes back to DATA.csv and E, v stay the inputs."""
    rng = np.random.default_rng(0)
    e, v = rng.standard_normal(300), rng.standard_normal(300)
    f = np.zeros(300)
    for k in range(1, 300):
        f[k] = 0.5 * f[k - 1] + e[k - 1] - 0.3 * v[k - 1]
    data = write_csv(tmp_path / "data.csv", ["E", "v", "f"], zip(e, v, f))
    out = tmp_path / "m.json"
    code, _, err = run(capsys, "fit", "--input", "E", "v", data, "--output", "f",
                       "--population", "10", "--generations", "1", "--max-height", "2",
                       "--fitness", "pem", "--seed", "0", "--quiet", "--out", out)
    assert code == 0, err
    assert json.loads(out.read_text())["inputs"] == ["E", "v"]
    code, _, err = run(capsys, "fit", "--input", "E", "--output", "f")     # control
    assert code == 2 and "the following arguments are required: DATA.csv" in \
        one_error_line(err)


def test_fit_help_groups_every_option_with_its_default(capsys):
    from mggp.cli.fit import FIT_OPTIONS
    with pytest.raises(SystemExit):
        main(["fit", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for title in ("data (", "search budget", "model class (", "selection (",
                  "parallelism and reproducibility", "output"):
        assert title in text
    assert "--window WINDOW multiple-shooting window in samples" in text
    assert text.count("(default: ") == sum(1 for p in FIT_OPTIONS if p.flag)


def test_simulate_names_the_prediction_after_the_models_output(capsys, tmp_path):
    """A model of output f writes f_hat; a data file that already has that
    column is refused before anything is written (control: y_hat for y above)."""
    t, u = sine_input()
    f = piezo_bouc_wen(u)
    data = write_csv(tmp_path / "f.csv", ["t", "v", "f"], zip(t, u, f))
    m = tmp_path / "m.json"
    code, out, err = run(capsys, "estimate", data, "--terms", "f[k-1]", "v[k-1]",
                         "--input", "v", "--output", "f", "--out", m)
    assert code == 0, err
    pred = tmp_path / "pred.csv"
    code, out, err = run(capsys, "simulate", m, data, "--out", pred)
    assert code == 0, err
    assert pred.read_text().splitlines()[0] == "t,v,f,f_hat"
    clash = write_csv(tmp_path / "clash.csv", ["v", "f", "f_hat"],
                      zip(u, f, f))
    code, out, err = run(capsys, "simulate", m, clash, "--out", tmp_path / "p2.csv")
    assert code == 2 and "f_hat" in err
    one_error_line(err)
    assert not (tmp_path / "p2.csv").exists()


@pytest.mark.parametrize("command", ["simulate", "estimate", "compensate"])
def test_every_option_has_help_with_its_default(command):
    """Every option but --help (and the required --terms) says what it does
    and its default."""
    from mggp.cli.app import build_parser
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices[command]
    for action in sub._actions:
        if action.dest == "help" or not action.option_strings:
            continue
        text = action.help or ""
        assert len(text) > 15, (command, action.option_strings)
        if not action.required:
            assert "default" in text, (command, action.option_strings, text)
    simulate = next(a for a in parser._actions if a.dest == "command").choices["simulate"]
    assert "(default: u)" not in simulate.format_help()


@pytest.mark.parametrize("mode, extra", [("freerun", []), ("ksa", ["--k", "3"])])
def test_simulate_out_leaves_the_rows_not_simulated_empty(capsys, sine_csv, model19, tmp_path,
                                                          mode, extra):
    """The help says the prediction is empty where not simulated: the
    initial-condition rows (and the first ksa horizon) get no measured y."""
    out = tmp_path / "p.csv"
    code, _, err = run(capsys, "simulate", model19, sine_csv, "--mode", mode, *extra,
                       "--out", out)
    assert code == 0, err
    rows = [ln.split(",") for ln in out.read_text().splitlines()[1:]]
    empty = [i for i, r in enumerate(rows) if r[-1] == ""]
    assert empty and empty == list(range(len(empty)))
    assert all(r[-1] != "" for r in rows[len(empty):])
