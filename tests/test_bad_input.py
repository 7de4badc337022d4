"""Bad and hostile input: one ``error:`` line naming file, place and rule; nothing runs.

Every malformed CSV and model file goes through ``mggp.cli.app.main`` for
``estimate``, ``simulate`` and ``fit``: exit code 2 and exactly one stderr
line that names the file, where the problem is (line, column, key) and the
rule broken. Hostile model files (term text that DEAP's
``PrimitiveTree.from_string`` would evaluate, ``__import__``, dunders, huge
powers and lags, deep nesting, giant lists) are rejected while spies on
``eval``/``exec`` and ``from_string`` see no call and no marker file appears.
Property-based tests throw random malformed CSV and JSON at the loaders and
the CLI: only :class:`DataError` / :class:`ModelFileError` (ValueErrors) may
come out, and the CLI returns 2 with one line.
"""
import builtins
import contextlib
import io
import json
import os
import string
import tempfile

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mggp.cli.app import main
from narx.records.csvdata import read_csv
from narx.records.data import DataError
from narx import ModelFileError, load_model
from narx.systems import piezo_bouc_wen, training_input

N = 300
_U = training_input(N, seed=1)
_Y = piezo_bouc_wen(_U)
GOOD_LINES = ["t,u,y"] + [f"{i},{float(a)!r},{float(b)!r}" for i, (a, b) in
                          enumerate(zip(_U, _Y))]
MODEL = {"output": "y", "inputs": ["u"], "terms": ["y[k-1]", "Phi1(u[k-1],u[k-2])"],
         "theta": [1.0, 0.5]}


def csv_with(line_no, row):
    """The good CSV with (1-based) line ``line_no`` replaced by ``row``."""
    lines = list(GOOD_LINES)
    lines[line_no - 1] = row
    return "\n".join(lines) + "\n"


def run(*argv):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main([str(a) for a in argv])
    return code, err.getvalue()


def one_line(err):
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("error: ") and "Traceback" not in err, err
    return lines[0]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("bad")
    (d / "good.csv").write_text("\n".join(GOOD_LINES) + "\n")
    (d / "model.json").write_text(json.dumps(MODEL))
    return d


def commands(files, csv):
    return {"estimate": ["estimate", csv, "--terms", "y[k-1]", "u[k-1]"],
            "simulate": ["simulate", files / "model.json", csv],
            "fit": ["fit", csv, "--population", "4", "--generations", "1", "--quiet"]}


# ------------------------------------------------------------------ bad CSV
BAD_CSV = [
    ("comment", "# recorded 2024, volts\n" + "\n".join(GOOD_LINES) + "\n",
     ["line 1 starts with '#'", "comment lines before the header row are not supported"]),
    ("nan", csv_with(6, "4,nan,1.0"), ["line 6, column 'u'", "not finite"]),
    ("inf", csv_with(8, "6,1.0,-inf"), ["line 8, column 'y'", "'-inf' is not finite"]),
    ("infinity", csv_with(3, "1,Infinity,1.0"), ["line 3, column 'u'", "not finite"]),
    ("text", csv_with(10, "8,abc,1.0"), ["line 10, column 'u'", "'abc' is not a number"]),
    ("empty_field", csv_with(4, "2,,1.0"), ["line 4, column 'u'", "'' is not a number"]),
    ("underscore", csv_with(5, "3,1_000,1.0"), ["line 5, column 'u'", "is not a number"]),
    ("nul_byte", csv_with(5, "3,1\x00,1.0"), ["line 5, column 'u'", "is not a number"]),
    ("ragged_short", csv_with(12, "10,1.0"), ["line 12 has 2 fields", "header has 3"]),
    ("ragged_long", csv_with(12, "10,1.0,2.0,3.0"), ["line 12 has 4 fields", "header has 3"]),
    ("unclosed_quote", csv_with(7, '5,"1.0,2.0'), ["line 7 has", "unclosed quote"]),
    ("duplicated_column", "u,u,y\n1,2,3\n2,3,4\n", ["column 'u' appears 2 times",
                                                   "fields 1, 2"]),
    ("missing_column", "t,v,y\n1,2,3\n2,3,4\n", ["line 1 (header)", "no column 'u'",
                                                "columns: t, v, y"]),
    ("empty", "", ["empty file (no header row)"]),
    ("blank_lines_only", "\n \n\n", ["empty file (no header row)"]),
    ("header_only", "t,u,y\n", ["no data rows after the header"]),
    ("not_utf8", None, ["not UTF-8 text", "line 1"]),
]


@pytest.mark.parametrize("cmd", ["estimate", "simulate", "fit"])
@pytest.mark.parametrize("name,content,needles", BAD_CSV, ids=[c[0] for c in BAD_CSV])
def test_bad_csv_one_error_line(files, cmd, name, content, needles):
    p = files / f"{name}.csv"
    if content is None:
        p.write_bytes(b"t,u,y\n\xff\xfe\x80,1,2\n")
    else:
        p.write_text(content)
    code, err = run(*commands(files, p)[cmd])
    assert code == 2, err
    line = one_line(err)
    assert f"{name}.csv" in line
    for needle in needles:
        assert needle in line, line


@pytest.mark.parametrize("cmd, needles", [
    ("estimate", ["too few for 2 terms with largest lag 1"]),
    ("simulate", ["too few for the model's largest lag 2"]),
    ("fit", ["too few: the search needs at least", "largest lag 16"]),
])
def test_too_few_samples_for_the_lags(files, cmd, needles):
    p = files / "short.csv"
    p.write_text("\n".join(GOOD_LINES[:4]) + "\n")
    code, err = run(*commands(files, p)[cmd])
    line = one_line(err)
    assert code == 2 and "short.csv: 3 samples are" in line
    for needle in needles:
        assert needle in line, line


@pytest.mark.parametrize("argv, needles", [
    (["--max-lag", "4"], ["60 samples are too few: the search needs at least 64, its "
                          "largest lag 4 (max_lag=4) plus 60 rows to fit (4 per term of "
                          "max_terms=15, at least 20)", "lower max_terms to 14"]),
    ([], ["at least 76, its largest lag 16 (what max_height=5 reaches",
          "give more samples, or lower max_terms to 11"]),
])
def test_too_few_samples_counts_the_lag_the_search_reaches(files, argv, needles):
    """The rule is the largest lag the terms can have (max_height's reach,
    capped by max_lag) plus 4 rows per term of max_terms (at least 20); the
    message names both settings and what would fit. The advice holds:
    --max-terms 14 with --max-lag 4 fits the 60 samples."""
    p = files / "short60.csv"
    p.write_text("\n".join(GOOD_LINES[:61]) + "\n")
    code, err = run("fit", str(p), *argv)
    line = one_line(err)
    assert code == 2 and line.startswith("error: ") and "short60.csv: " in line
    for needle in needles:
        assert needle in line, line
    from mggp import MGGPRegressor
    data = read_csv(p)
    MGGPRegressor(max_lag=4, max_terms=14)._check_samples(data.n)      # no error


def test_constant_input_rejected_for_identification_not_for_simulation(files):
    p = files / "const.csv"
    p.write_text("t,u,y\n" + "".join(f"{i},2.5,{float(b)!r}\n" for i, b in enumerate(_Y)))
    for cmd in ("estimate", "fit"):
        code, err = run(*commands(files, p)[cmd])
        line = one_line(err)
        assert code == 2 and "const.csv: input 'u' is constant" in line, line
        assert f"holds 2.5 on all {N} data rows" in line and "must vary" in line
    # simulating a held input is legitimate (it is how a steady state is checked)
    code, err = run(*commands(files, p)["simulate"])
    assert code == 0, err


# ------------------------------------------------------------------ bad model files
BAD_MODEL = [
    ("theta_string", dict(MODEL, theta="1.0"), ["'theta' must be a list of numbers"]),
    ("theta_item", dict(MODEL, theta=[1.0, "x"]), ["'theta'[1] is \"x\""]),
    ("theta_bool", dict(MODEL, theta=[True, 0.5]), ["'theta'[0] is true"]),
    ("theta_short", dict(MODEL, theta=[1.0]), ["'theta' has 1 values but 'terms' has 2"]),
    ("theta_long", dict(MODEL, theta=[1.0, 2.0, 3.0]), ["'theta' has 3 values"]),
    ("terms_number", dict(MODEL, terms=["y[k-1]", 7]), ["'terms'[1] is 7"]),
    ("terms_object", dict(MODEL, terms={"a": 1}), ["'terms' must be a non-empty list"]),
    ("inputs_number", dict(MODEL, inputs=3), ["'inputs' must be a non-empty list"]),
    ("output_list", dict(MODEL, output=["y"]), ["'output' must be a string"]),
    ("unknown_signal", dict(MODEL, terms=["y[k-1]", "z[k-1]"]),
     ["'terms'[1]", "unknown signal 'z'"]),
    ("unknown_phi", dict(MODEL, terms=["Phi9(u[k-1],u[k-2])", "y[k-1]"]),
     ["'terms'[0]", "unknown Φ-function 'Phi9'"]),
    ("wrong_arity", dict(MODEL, terms=["y[k-1]", "Phi1(u[k-1])"]),
     ["'terms'[1]", "Phi1 takes 2 arguments, got 1"]),
    ("future_sample", dict(MODEL, terms=["y[k-1]", "u[k+1]"]), ["'terms'[1]", "not causal"]),
    ("missing_theta", {k: v for k, v in MODEL.items() if k != "theta"},
     ["missing key 'theta'"]),
    ("top_list", [MODEL], ["top level must be a JSON object, got list"]),
    ("truncated", '{"output": "y", "inputs": [', ["invalid JSON at line 1 column 28"]),
    ("nan_theta", '{"output":"y","inputs":["u"],"terms":["y[k-1]"],"theta":[NaN]}',
     ["non-standard JSON constant NaN"]),
    ("duplicate_key", '{"output":"y","output":"u","inputs":["u"],"terms":["y[k-1]"],'
                      '"theta":[1]}', ["key \"output\" appears more than once"]),
]


@pytest.mark.parametrize("name,content,needles", BAD_MODEL, ids=[c[0] for c in BAD_MODEL])
def test_bad_model_file_one_error_line(files, name, content, needles):
    p = files / f"{name}.json"
    p.write_text(content if isinstance(content, str) else json.dumps(content))
    code, err = run("simulate", p, files / "good.csv")
    assert code == 2, err
    line = one_line(err)
    assert f"{name}.json" in line
    for needle in needles:
        assert needle in line, line


# ------------------------------------------------------------------ hostile model files
def hostile_models(marker):
    cmd = f"touch {marker}"
    evil = [f"__import__('os').system('{cmd}')",
            f"mul(__import__('os').system('{cmd}'), y[k-1])",       # DEAP from_string
            "y[k-1].__class__.__mro__[1].__subclasses__()",
            "__builtins__[k-1]", "y[k-1]*__class__(u[k-1])",
            f"Phi1(u[k-1],exec('open(\"{marker}\",\"w\")'))",
            "u[k-1]^99999999999", "u[k-1]**10**10", "u[k-1]^-1",
            "u[k-99999999999999999999]", "u[k-" + "9" * 5000 + "]",
            "*".join(["u[k-1]^10"] * 90), "*".join(["u[k-1]^10"] * 120), "(lambda: 1)()", "y[k-1] if 1 else 0",
            "y[k-1];import os", "y[k-1]\nimport os"]
    for i, term in enumerate(evil):
        yield f"term{i}", json.dumps(dict(MODEL, terms=["y[k-1]", term]))
    yield "deep_list", "[" * 200_000 + "]" * 200_000
    yield "deep_meta", json.dumps(MODEL)[:-1] + ', "meta": ' + '{"a":' * 200_000 + "1" + \
        "}" * 200_000 + "}"
    yield "million_terms", json.dumps(dict(MODEL, terms=["u[k-1]"] * 1_000_000,
                                           theta=[0.0] * 1_000_000))
    yield "huge_integer", '{"output":"y","inputs":["u"],"terms":["y[k-1]"],"theta":[' + \
        "9" * 100_000 + "]}"
    yield "many_keys", "{" + ",".join(f'"k{i}":0' for i in range(200_000)) + "}"
    yield "dunder_names", json.dumps(dict(MODEL, output="__class__",
                                          terms=["__class__[k-1]"], theta=[1.0]))


def test_hostile_model_files_are_rejected_and_nothing_runs(files, monkeypatch, tmp_path):
    from deap import gp
    assert run("simulate", files / "model.json", files / "good.csv")[0] == 0  # warm up
    calls = []

    def spy(name, real):
        def f(*a, **k):
            calls.append((name, str(a[0])[:80] if a else ""))
            return real(*a, **k)
        return f
    monkeypatch.setattr(builtins, "eval", spy("eval", builtins.eval))
    monkeypatch.setattr(builtins, "exec", spy("exec", builtins.exec))
    monkeypatch.setattr(gp.PrimitiveTree, "from_string",
                        classmethod(lambda cls, *a: calls.append(("from_string", ""))))
    monkeypatch.setattr(os, "system", spy("os.system", os.system))
    marker = tmp_path / "pwned"
    seen = []
    for name, text in hostile_models(marker):
        p = tmp_path / f"{name}.json"
        p.write_text(text)
        with pytest.raises(ModelFileError):
            load_model(p)
        for cmd in (["simulate", p, files / "good.csv"],
                    ["simulate", p, files / "good.csv", "--mode", "ms"]):
            code, err = run(*cmd)
            assert code == 2, (name, err)
            line = one_line(err)
            assert f"{name}.json" in line, line
        seen.append(line)
    assert not marker.exists()
    assert calls == []
    text = "\n".join(seen)
    for rule in ("unexpected character", "power must be 1..10", "exceeds the maximum",
                 "more than the 256 allowed", "nested too deeply", "digits",
                 "characters long", "900 factors, more than the 64 allowed",
                 "unknown signal '__builtins__'", "unknown Φ-function '__class__'",
                 "'output': signal name \"__class__\" must not start with '__'"):
        assert rule in text, rule


def test_hostile_terms_on_the_command_line(files, tmp_path):
    marker = tmp_path / "pwned"
    code, err = run("estimate", files / "good.csv", "--terms", "y[k-1]",
                    f"__import__('os').system('touch {marker}')")
    assert code == 2 and "unexpected character" in one_line(err)
    assert not marker.exists()


def test_hostile_checkpoint_is_rejected(files, tmp_path):
    from mggp.gp.checkpoint import load_checkpoint
    from mggp.gp.primitives import make_pset
    p = tmp_path / "evil.ckpt"
    p.write_text("[" * 200_000 + "]" * 200_000)
    with pytest.raises(ValueError, match="not a readable JSON file"):
        load_checkpoint(p, make_pset())
    code, err = run("fit", files / "good.csv", "--population", "4", "--generations", "1",
                    "--quiet", "--checkpoint", p, "--resume")
    assert code == 2 and "evil.ckpt" in one_line(err)


# ------------------------------------------------------------------ properties
CELL = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10**30, 10**30).map(str),
    st.sampled_from(["", " ", "nan", "-inf", "Infinity", "1e999", "1_0", "0x10", "abc",
                     '"', '""', '"1,2"', "1e", "١٢", "\x00", "\t3", "u", "y", "1.5\n2"]),
    st.text(string.printable + "éΦ\x00", max_size=8),
)
ROW = st.lists(CELL, min_size=0, max_size=5).map(",".join)
HEADER = st.lists(st.sampled_from(["u", "y", "t", "", " u", "u ", "x", "y"]),
                  min_size=0, max_size=5).map(",".join)
GOOD_TEXT = "\n".join(GOOD_LINES) + "\n"


def _cell_replaced(line_no, col, cell):
    fields = GOOD_LINES[line_no - 1].split(",")
    fields[col] = cell
    return csv_with(line_no, ",".join(fields))


CSV_TEXT = st.one_of(
    st.tuples(HEADER, st.lists(ROW, max_size=12)).map(lambda hr: "\n".join([hr[0], *hr[1]])),
    st.text(max_size=200),
    st.tuples(st.integers(1, 301), ROW).map(lambda t: csv_with(*t)),
    st.tuples(st.integers(2, 301), st.integers(0, 2), CELL).map(lambda t: _cell_replaced(*t)),
    st.integers(0, len(GOOD_TEXT)).map(lambda n: GOOD_TEXT[:n]),
)
JSON = st.recursive(
    st.none() | st.booleans() | st.integers(-2**70, 2**70) | st.floats() |
    st.text(max_size=12) | st.sampled_from(["y[k-1]", "u[k-1]", "Phi1(u[k-1],u[k-2])",
                                            "y", "u", "e", "Phi2(y[k-1],u[k-3])"]),
    lambda kids: st.lists(kids, max_size=4) | st.dictionaries(st.text(max_size=6), kids,
                                                              max_size=4),
    max_leaves=12)
TERM_TEXT = st.sampled_from(["y[k-1]", "y[k-2]", "u[k-1]", "u2[k-2]", "Phi1(u[k-1],u[k-2])",
                             "Phi2(y[k-1],u[k-1])", "y[k-1]^3", "1", "e[k-1]", "y[k-0]",
                             "u[k]", "u[k-3]*y[k-1]", "Phi1(u[k-1],u[k-12])"])


@st.composite
def model_dicts(draw):
    terms = draw(st.lists(TERM_TEXT, min_size=1, max_size=4))
    n = len(terms) if draw(st.booleans()) or draw(st.booleans()) else draw(st.integers(0, 5))
    return {"output": draw(st.sampled_from(["y", "y", "u", "z", ""])),
            "inputs": draw(st.sampled_from([["u"], ["u"], ["u", "u2"], ["y"], ["k"], []])),
            "terms": terms,
            "theta": draw(st.lists(st.floats(-1.5, 1.5), min_size=n, max_size=n))}


MODEL_DICT = st.one_of(
    JSON,
    st.fixed_dictionaries({k: st.one_of(st.just(v), JSON) for k, v in MODEL.items()}),
    model_dicts(),
)
MODEL_TEXT = st.one_of(MODEL_DICT.map(json.dumps), st.text(max_size=80),
                       MODEL_DICT.map(lambda d: json.dumps(d)[:-1]))
PROPS = settings(max_examples=int(os.environ.get("MGGP_HYPOTHESIS", "150")), deadline=None,
                 suppress_health_check=[HealthCheck.too_slow])


def _write(text, suffix, mode="w"):
    fd, path = tempfile.mkstemp(suffix=suffix)
    with os.fdopen(fd, mode) as fh:
        fh.write(text)
    return path


def _loads_or_says_why(loader, error, content, suffix):
    """``loader(path)`` succeeds or raises ``error`` (a ValueError) in one line
    naming the file; anything else fails the test. Returns the result."""
    path = _write(content, suffix, "wb" if isinstance(content, bytes) else "w")
    try:
        return loader(path)
    except error as exc:
        assert isinstance(exc, ValueError)
        assert path in str(exc) and "\n" not in str(exc)
    finally:
        os.unlink(path)


@PROPS
@given(CSV_TEXT)
@pytest.mark.filterwarnings("ignore:.*column 't' (does not increase|has)")   # random times
def test_property_csv_reader_raises_only_data_error(text):
    d = _loads_or_says_why(read_csv, DataError, text, ".csv")
    if d is not None:
        assert np.all(np.isfinite(d.U)) and np.all(np.isfinite(d.y)) and d.n >= 2


@PROPS
@given(st.binary(max_size=120))
def test_property_random_bytes_as_csv_and_model(blob):
    _loads_or_says_why(read_csv, DataError, blob, ".csv")
    _loads_or_says_why(load_model, ModelFileError, blob, ".json")


@PROPS
@given(MODEL_TEXT)
def test_property_model_loader_raises_only_model_file_error(text):
    m = _loads_or_says_why(load_model, ModelFileError, text, ".json")
    if m is not None:
        assert len(m.theta) == len(m.terms)


@settings(max_examples=int(os.environ.get("MGGP_HYPOTHESIS_CLI", "40")), deadline=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(MODEL_TEXT, CSV_TEXT, st.sampled_from(["simulate", "estimate", "ms"]))
def test_property_cli_returns_two_with_one_line(model_text, csv_text, cmd):
    m, d = _write(model_text, ".json"), _write(csv_text, ".csv")
    try:
        if cmd == "estimate":
            argv = ["estimate", d, "--terms", "y[k-1]", "Phi1(u[k-1],u[k-2])"]
        else:
            argv = ["simulate", m, d] + (["--mode", "ms", "--window", "5"]
                                         if cmd == "ms" else [])
        code, err = run(*argv)
        assert code in (0, 2), err
        if code == 2:
            one_line(err)
    finally:
        os.unlink(m)
        os.unlink(d)


def test_non_ascii_column_name_gets_an_ascii_suggestion(files):
    """Signal names are ASCII identifiers; the suggested name must be one
    (it repeated 'Displacement_µm', a Unicode identifier) and the file is named."""
    from narx.language.terms import ascii_name
    p = files / "uni.csv"
    p.write_text("Voltage_V,Displacement_µm\n" + "".join(
        f"{float(a)!r},{float(b)!r}\n" for a, b in zip(_U, _Y)))
    code, err = run("fit", str(p), "--input", "Voltage_V", "--output", "Displacement_µm")
    line = one_line(err)
    assert code == 2 and "uni.csv: signal names must be identifiers" in line
    assert "got 'Displacement_µm': rename the column (e.g. 'Displacement__m')" in line
    assert ascii_name("Température_°C") == "Temperature__C"


@pytest.mark.parametrize("cmd, why", [
    ("estimate", "nothing can be identified"),
    ("fit", "nothing can be identified"),
    ("simulate", "the simulation error cannot be scored"),
    ("validation", "the simulation error cannot be scored"),
])
def test_constant_output_names_the_file_and_the_value(files, cmd, why):
    """One wording for every command (fit's): the file, the output and its value."""
    p = files / "flat.csv"
    p.write_text("t,u,y\n" + "".join(f"{i},{float(a)!r},5.0\n" for i, a in enumerate(_U)))
    argv = (["diagnose", files / "good.csv", "--validation", p] if cmd == "validation"
            else commands(files, p)[cmd])
    code, err = run(*argv)
    line = one_line(err)
    assert code == 2 and f"flat.csv: output 'y' is constant (every sample 5.0): {why}" in line


def _timed(path, t, name="t"):
    lines = [f"{name},u,y"] + [f"{float(a)!r},{float(b)!r},{float(c)!r}"
                               for a, b, c in zip(t, _U, _Y)]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_gap_or_a_backward_step_in_the_time_column_is_named(tmp_path, capsys):
    """NARX lags assume consecutive, evenly spaced samples: a time column
    with five samples missing, or two rows swapped, gets one warning line
    naming the place; the even column (the control) and a column of text
    timestamps get none, and every file is still read."""
    t = np.arange(N) * 0.01
    gap = t.copy()
    gap[200:] += 0.05
    swapped = t.copy()
    swapped[[100, 101]] = swapped[[101, 100]]
    with pytest.warns(UserWarning, match=r"column 'time' has 1 gap\(s\).*6 steps, after data "
                      r"row 200"):
        read_csv(_timed(tmp_path / "gap.csv", gap, "time"))
    with pytest.warns(UserWarning, match=r"column 't' does not increase at data row 102"):
        read_csv(_timed(tmp_path / "swap.csv", swapped))
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_csv(_timed(tmp_path / "even.csv", t))
        stamps = [f"2024-01-01T00:00:{i:04d}" for i in range(N)]
        (tmp_path / "text.csv").write_text("Time (s),u,y\n" + "".join(
            f"{s},{float(a)!r},{float(b)!r}\n" for s, a, b in zip(stamps, _U, _Y)))
        text = read_csv(tmp_path / "text.csv")
        assert text.n == N and np.array_equal(text.y, read_csv(tmp_path / "even.csv").y)
    code = main(["estimate", str(tmp_path / "gap.csv"), "--terms", "y[k-1]", "u[k-1]"])
    err = capsys.readouterr().err
    assert code == 0 and err.count("warning:") == 1 and "gap.csv: column 'time'" in err


def test_an_error_after_a_warning_is_still_one_line(files):
    """Found by the property test above: a CSV whose time column has a gap
    (a warning) and an unstable model (an error) gave two lines. The
    warnings are held and printed when the command ends, unless it ends in
    an error; control: with a stable model the same file exits 0 and the
    gap's warning is printed."""
    gap = csv_with(3, "")                       # data row 2 left out: t jumps 1 -> 3
    d = _write(gap, ".csv")
    unstable = _write(json.dumps({"output": "y", "inputs": ["u"], "terms": ["y[k-1]"],
                                  "theta": [5]}), ".json")
    try:
        code, err = run("simulate", unstable, d)
        assert code == 2 and "diverged" in one_line(err), err
        code, err = run("simulate", files / "model.json", d)
        assert code == 0, err
        assert any(ln.startswith("warning: ") and "gap" in ln for ln in err.splitlines()), err
    finally:
        os.unlink(d)
        os.unlink(unstable)
