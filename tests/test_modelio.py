"""Model files (narx.modelio, Model.save / Model.load).

A model file is data, never code: every malformed or crafted file raises
ModelFileError whose message names the file and the broken rule; nothing in
it is executed; saving is atomic.
"""
import builtins
import json
import os

import numpy as np
import pytest

import narx
from narx import Model, ModelFileError, load_model, save_model

TRICKY = [0.1, 1 / 3, -0.0, 5e-324, 1e-300, -1.7976931348623157e308, 2.0 ** 52 + 1,
          -0.2310, 3.2333e-4, np.nextafter(1.0, 2.0)]


def good_dict(**over):
    d = {"output": "y", "inputs": ["u"], "terms": ["y[k-1]", "Phi1(u[k-1],u[k-2])"],
         "theta": [0.9, 0.5]}
    d.update(over)
    return d


def write(tmp_path, content, name="m.json"):
    p = tmp_path / name
    if isinstance(content, bytes):
        p.write_bytes(content)
    else:
        p.write_text(content if isinstance(content, str) else json.dumps(content),
                     encoding="utf-8")
    return p


# --------------------------------------------------------------- round trip
def test_round_trip_is_exact(tmp_path):
    terms = [f"y[k-1]*u[k-{j}]" for j in range(1, len(TRICKY))] + ["1"]
    m = Model(terms, TRICKY, meta={"fitness": "ms", "seed": 42, "window": 50,
                                   "note": "Σ_y = 1 ✓", "nested": {"a": [1, 2]}})
    p = tmp_path / "model.json"
    m.save(p)
    back = Model.load(p)
    assert back.term_texts == m.term_texts
    assert back.theta.dtype == np.float64
    assert [v.hex() for v in back.theta] == [float(v).hex() for v in TRICKY]  # bit-exact
    assert np.signbit(back.theta[2])                                       # -0.0 kept
    assert back.inputs == ("u",) and back.output == "y"
    for k in ("fitness", "seed", "window", "note", "nested"):
        assert back.meta[k] == m.meta[k]
    raw = json.loads(p.read_text(encoding="utf-8"))
    assert raw["output"] == "y" and raw["inputs"] == ["u"] and raw["terms"] == m.term_texts
    assert "narx" in raw["meta"]["versions"]                # enough to reproduce
    assert "numpy" in raw["meta"]["versions"]
    # the loaded model behaves identically
    rng = np.random.default_rng(0)
    m2 = Model(["y[k-1]", "Phi1(u[k-1],u[k-2])", "u[k-1]*y[k-2]"], [0.7, 0.4, -0.1])
    m2.save(p)
    u, y = rng.uniform(-1, 1, 300), rng.normal(size=300)
    np.testing.assert_array_equal(Model.load(p).simulate(u, y).y_hat, m2.simulate(u, y).y_hat)


def test_round_trip_with_named_signals_and_canonical_terms(tmp_path):
    m = Model(["x[k-1]*f[k-2]", "Phi2(v[k-1],v[k-3])*E[k]", "f[k-1]"], [0.25, -1.5, 0.875],
              inputs=("x", "v", "E"), output="f")
    p = tmp_path / "named.json"
    save_model(m, p)
    back = load_model(p)
    assert back.inputs == ("x", "v", "E") and back.output == "f"
    assert back.term_texts == ["f[k-2]*x[k-1]", "E[k]*Phi2(v[k-1],v[k-3])", "f[k-1]"]
    np.testing.assert_array_equal(back.theta, m.theta)
    # a hand-written, non-canonical file loads into canonical terms
    q = write(tmp_path, good_dict(terms=["Phi1(u[k-1],u[k-2])*y[k-1]", "u[k-1]*y[k-2]"]))
    assert load_model(q).term_texts == ["y[k-1]*Phi1(u[k-1],u[k-2])", "y[k-2]*u[k-1]"]


def test_user_phi_model_needs_its_registry(tmp_path, abs_registry):
    from narx.systems import bouc_wen_discrete_narx
    terms, theta = bouc_wen_discrete_narx()
    p = tmp_path / "bw.json"
    Model(terms, theta, registry=abs_registry).save(p)
    back = Model.load(p, registry=abs_registry)
    assert back.term_texts == list(terms)
    if "Abs" not in narx.default_registry():
        with pytest.raises(ModelFileError, match="unknown Φ-function 'Abs'") as ei:
            Model.load(p)
        assert str(p) in str(ei.value)


def test_unfitted_model_save_is_refused_or_round_trips(tmp_path):
    p = tmp_path / "unfitted.json"
    m = Model(["y[k-1]", "u[k-1]"])
    try:
        m.save(p)
    except ValueError:
        assert not p.exists()
        return
    back = Model.load(p)
    assert back.theta is None and back.term_texts == m.term_texts


# --------------------------------------------------------------- rejected files
BAD = [
    ("invalid_json", '{"output": "y", "inputs": ["u"],', "invalid JSON at line"),
    ("empty", "", "invalid JSON"),
    ("top_list", [1, 2], "top level must be a JSON object"),
    ("missing_terms", {"output": "y", "inputs": ["u"], "theta": [1.0]}, "missing key 'terms'"),
    ("missing_theta", {"output": "y", "inputs": ["u"], "terms": ["y[k-1]"]},
     "missing key 'theta'"),
    ("missing_output", {"inputs": ["u"], "terms": ["y[k-1]"], "theta": [1.0]},
     "missing key 'output'"),
    ("theta_strings", good_dict(theta=["0.9", "0.5"]), "'theta' must be a list of numbers"),
    ("theta_bools", good_dict(theta=[True, 0.5]), "'theta' must be a list of numbers"),
    ("theta_null", good_dict(theta=[None, 0.5]), "'theta' must be a list of numbers"),
    ("theta_scalar", good_dict(theta=0.9), "'theta' must be a list of numbers"),
    ("theta_nested", good_dict(theta=[[0.9], [0.5]]), "'theta' must be a list of numbers"),
    ("terms_numbers", good_dict(terms=[1, 2]), "'terms' must be a non-empty list of strings"),
    ("terms_string", good_dict(terms="y[k-1]"), "'terms' must be a non-empty list of strings"),
    ("terms_empty", good_dict(terms=[], theta=[]), "'terms' must be a non-empty list"),
    ("inputs_numbers", good_dict(inputs=[1]), "'inputs' must be a non-empty list of strings"),
    ("inputs_empty", good_dict(inputs=[]), "'inputs' must be a non-empty list"),
    ("output_number", good_dict(output=3), "'output' must be a string"),
    ("meta_list", good_dict(meta=[1]), "'meta' must be an object"),
    ("nan", '{"output": "y", "inputs": ["u"], "terms": ["y[k-1]"], "theta": [NaN]}',
     "NaN"),
    ("infinity", '{"output": "y", "inputs": ["u"], "terms": ["y[k-1]"], "theta": [Infinity]}',
     "Infinity"),
    ("minus_infinity",
     '{"output": "y", "inputs": ["u"], "terms": ["y[k-1]"], "theta": [-Infinity]}',
     "Infinity"),
    ("overflow", '{"output": "y", "inputs": ["u"], "terms": ["y[k-1]"], "theta": [1e999]}',
     "not finite"),
    ("theta_short", good_dict(theta=[0.9]), "'theta' has 1 values but 'terms' has 2"),
    ("theta_long", good_dict(theta=[0.9, 0.5, 0.1]), "'theta' has 3 values but 'terms' has 2"),
    ("unknown_term", good_dict(terms=["y[k-1]", "z[k-1]"]), "unknown signal 'z'"),
    ("unknown_phi", good_dict(terms=["y[k-1]", "Phi9(u[k-1],u[k-2])"]),
     "unknown Φ-function 'Phi9'"),
    ("output_lag0", good_dict(terms=["y[k]", "u[k-1]"]), "lag 0"),
    ("duplicate_term", good_dict(terms=["u[k-1]*y[k-1]", "y[k-1]*u[k-1]"]), "appears twice"),
    ("clashing_names", good_dict(output="u"), "distinct"),
    ("not_utf8", b'{"output": "\xff\xfe", "inputs": ["u"]}', "UTF-8"),
]


@pytest.mark.parametrize("name,content,rule", BAD, ids=[b[0] for b in BAD])
def test_bad_files_raise_model_file_error_naming_file_and_rule(tmp_path, name, content, rule):
    p = write(tmp_path, content, f"{name}.json")
    with pytest.raises(ModelFileError) as ei:
        load_model(p)
    msg = str(ei.value)
    assert str(p) in msg, msg
    assert rule in msg, msg
    assert "\n" not in msg.strip()
    assert isinstance(ei.value, ValueError)


def test_missing_file(tmp_path):
    p = tmp_path / "nope.json"
    with pytest.raises(ModelFileError, match="nope.json: cannot read model file"):
        load_model(p)


def test_huge_integer_theta_is_a_model_file_error(tmp_path):
    p = write(tmp_path, '{"output": "y", "inputs": ["u"], "terms": ["y[k-1]"], "theta": [1'
              + "0" * 400 + "]}")
    with pytest.raises(ModelFileError, match="theta"):
        load_model(p)


@pytest.mark.parametrize("kind", ["directory", "deep_nesting"])
def test_unreadable_or_pathological_files_are_model_file_errors(tmp_path, kind):
    p = tmp_path / "m.json"
    if kind == "directory":
        p.mkdir()
    else:
        p.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(ModelFileError, match="m.json"):
        load_model(p)


CRAFTED_TERMS = [
    "__import__('os').system('touch {p}')",
    "y[k-1]*__import__('os').system('touch {p}')",
    "open('{p}', 'w').write('x')",
    "exec(\"open('{p}','w')\")",
    "Phi1(u[k-1],u[k-2]).__class__.__init__.__globals__",
]


@pytest.mark.parametrize("template", CRAFTED_TERMS)
def test_crafted_file_with_python_code_is_rejected_and_nothing_runs(tmp_path, template,
                                                                     monkeypatch):
    pwned = tmp_path / "pwned"
    calls = []
    for fn in ("eval", "exec"):
        real = getattr(builtins, fn)
        monkeypatch.setattr(builtins, fn,
                            lambda *a, _r=real, _n=fn, **k: (calls.append(_n), _r(*a, **k))[1])
    text = template.format(p=pwned)
    for d in (good_dict(terms=["y[k-1]", text]),
              good_dict(terms=["y[k-1]", "u[k-1]"], output=text),
              good_dict(terms=["y[k-1]", "u[k-1]"], inputs=[text])):
        p = write(tmp_path, d)
        with pytest.raises(ModelFileError) as ei:
            load_model(p)
        assert str(p) in str(ei.value)
    assert not pwned.exists()
    assert calls == []


def test_model_from_dict_checks_like_a_file():
    m = narx.Model.from_dict(good_dict(), source="inline")
    assert m.term_texts == ["y[k-1]", "Phi1(u[k-1],u[k-2])"]
    with pytest.raises(ModelFileError, match="^inline: 'theta' has 1 values"):
        narx.Model.from_dict(good_dict(theta=[1.0]), source="inline")
    # a dict made in Python may hold NaN directly (no JSON constant to catch it)
    with pytest.raises(ModelFileError, match=r"'theta'\[1\] is not finite"):
        narx.Model.from_dict(good_dict(theta=[0.5, float("nan")]), source="inline")
    d = m.to_dict()
    assert set(d) >= {"output", "inputs", "terms", "theta"}
    back = narx.Model.from_dict(json.loads(json.dumps(d)))
    assert back.term_texts == m.term_texts and list(back.theta) == [0.9, 0.5]


# --------------------------------------------------------------- atomic save
def test_save_is_atomic(tmp_path, monkeypatch):
    p = tmp_path / "model.json"
    old = Model(["y[k-1]", "u[k-1]"], [0.5, 0.25])
    old.save(p)
    before = p.read_bytes()

    def boom(src, dst):
        raise OSError("disk full (simulated)")
    monkeypatch.setattr(os, "replace", boom)
    new = Model(["y[k-2]", "u[k-3]", "u[k-1]"], [0.1, 0.2, 0.3])
    with pytest.raises(OSError, match="simulated"):
        new.save(p)
    monkeypatch.undo()
    assert p.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["model.json"]       # no temporary left over
    back = Model.load(p)
    assert back.term_texts == ["y[k-1]", "u[k-1]"] and list(back.theta) == [0.5, 0.25]
    new.save(p)                                                   # and a real save works
    assert Model.load(p).term_texts == new.term_texts
    assert sorted(os.listdir(tmp_path)) == ["model.json"]


def test_save_does_not_touch_the_file_when_serialisation_fails(tmp_path):
    p = tmp_path / "model.json"
    Model(["y[k-1]"], [0.5]).save(p)
    before = p.read_bytes()
    bad = Model(["y[k-1]"], [0.5], meta={"obj": object()})
    with pytest.raises(TypeError):
        bad.save(p)
    assert p.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["model.json"]


def test_repr_keeps_small_parameters():
    """θ of a model whose output is in metres and input in newtons is ~1e-6:
    the repr keeps six significant digits, not six decimals (which showed
    8.8e-07 as -1e-06 and 3e-07 as 0.0)."""
    import narx
    m = narx.Model(["y[k-1]", "u[k-1]", "u[k-2]", "y[k-1]*y[k-1]*y[k-2]"],
                   theta=[2.29641178, -8.81827690e-07, 3.01269919e-07, -12834.9235])
    text = repr(m)
    assert "theta=[2.29641, -8.81828e-07, 3.0127e-07, -12834.9]" in text
    assert "0.0" not in text
