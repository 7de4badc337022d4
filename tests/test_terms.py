"""The term language (narx.language.terms) and the Φ-function registry (narx.language.phi).

Independent checks: canonical text is a function of the term only (order
of factors, spelling of powers), print -> parse -> print is the identity on
random terms built here from factor descriptions, every malformed or hostile
text raises TermError without anything being evaluated, and user Φ-functions
live in their own registry.
"""
import builtins

import numpy as np
import pytest

import narx
from narx import (Lag, PhiCall, PhiRegistry, Signals, Term, TermError, default_registry,
                  parse_term, parse_terms)

# --------------------------------------------------------------- helpers
ROLE_RANK = {"y": 0, "u": 1, "e": 2}


def lag_text(sig, lag):
    return f"{sig}[k]" if lag == 0 else f"{sig}[k-{lag}]"


def random_factor(rng, signals, phis):
    """A random factor as (sort_key, canonical_text); phis: [(name, arity)]."""
    def random_lag():
        r = rng.random()
        if r < 0.35:
            sig, role, lag = signals.output, "y", int(rng.integers(1, 9))
        else:
            sig = signals.inputs[int(rng.integers(len(signals.inputs)))]
            role, lag = "u", int(rng.integers(0, 9))
        return (ROLE_RANK[role], sig, lag), lag_text(sig, lag)

    if rng.random() < 0.3:
        name, arity = phis[int(rng.integers(len(phis)))]
        args = [random_lag() for _ in range(arity)]
        key = (3, name, tuple(a[0] for a in args))
        return key, f"{name}({','.join(a[1] for a in args)})"
    return random_lag()


def random_term(rng, signals, phis):
    """(written text in random order with powers, expected canonical text)."""
    if rng.random() < 0.05:
        return "1", "1"
    nf = int(rng.integers(1, 5))
    factors = [random_factor(rng, signals, phis) for _ in range(nf)]
    written, expanded = [], []
    for key, text in factors:
        r = rng.random()
        if r < 0.2:
            written.append(f"{text}^2")
            expanded += [(key, text)] * 2
        elif r < 0.3:
            written.append(f"{text}**2")
            expanded += [(key, text)] * 2
        elif r < 0.35:
            written.append(f"{text} ^ 3")
            expanded += [(key, text)] * 3
        else:
            written.append(text)
            expanded.append((key, text))
    order = rng.permutation(len(written))
    sep = [" * ", "*", "* "]
    text = ""
    for i, j in enumerate(order):
        text += (sep[int(rng.integers(3))] if i else "") + written[j]
    canonical = "*".join(t for _, t in sorted(expanded, key=lambda kt: kt[0]))
    return text, canonical


# --------------------------------------------------------------- canonical form
def test_canonical_text_is_order_independent():
    a = parse_term("u[k-1]*y[k-2]")
    b = parse_term("y[k-2]*u[k-1]")
    assert a == b and hash(a) == hash(b)
    assert str(a) == str(b) == "y[k-2]*u[k-1]"
    # the documented example of the module
    t = parse_term("Phi2(u[k-1],u[k-3])*y[k-1]*u[k-2]^2")
    assert str(t) == "y[k-1]*u[k-2]*u[k-2]*Phi2(u[k-1],u[k-3])"
    assert t.max_lag == 3 and t.degree == 4
    # powers are repeated factors, whatever their spelling
    assert parse_term("u[k-1]^2*y[k-1]") == parse_term("y[k-1]*u[k-1]**2") \
        == parse_term("u[k-1]*y[k-1]*u[k-1]")
    # a Φ-call keeps its argument order (Phi1 is not symmetric)
    assert parse_term("Phi1(u[k-1],u[k-3])") != parse_term("Phi1(u[k-3],u[k-1])")
    # u[k-0] is u[k]
    assert str(parse_term("u[k-0]")) == "u[k]"


def test_term_built_from_factor_objects_matches_parsed_text():
    y1, u2 = Lag("y", 1, "y"), Lag("u", 2, "u")
    p = PhiCall("Phi1", (Lag("u", 1, "u"), Lag("u", 3, "u")))
    for fs in ([p, u2, y1], [u2, y1, p], [y1, p, u2]):
        assert str(Term(fs)) == "y[k-1]*u[k-2]*Phi1(u[k-1],u[k-3])"
    assert Term(fs) == parse_term("Phi1(u[k-1],u[k-3])*u[k-2]*y[k-1]")
    assert str(Term()) == "1" and parse_term("1") == Term() and parse_term(" 1 ") == Term()
    assert Term([y1]) * Term([u2]) == parse_term("u[k-2]*y[k-1]")


@pytest.mark.parametrize("signals", [Signals(), Signals("y", ("u", "u2")),
                                     Signals(output="f", inputs=("x", "v", "E"))],
                         ids=["u", "u_u2", "f_xvE"])
def test_random_terms_round_trip(signals):
    reg = PhiRegistry()
    reg.register("Sat", 1, np.tanh, steady=np.tanh)
    reg.register("Mid", 3, lambda a, b, c: np.median([a, b, c], axis=0), steady=0.0)
    phis = [("Phi1", 2), ("Phi2", 2), ("Sat", 1), ("Mid", 3)]
    rng = np.random.default_rng(20240601)
    seen = 0
    for _ in range(400):
        text, expected = random_term(rng, signals, phis)
        t = parse_term(text, signals, registry=reg)
        assert str(t) == expected, text
        again = parse_term(str(t), signals, registry=reg)
        assert again == t and str(again) == str(t)
        # every permutation of the canonical factors prints the same
        perm = [str(f) for f in t.factors]
        rng.shuffle(perm)
        if perm:
            assert str(parse_term("*".join(perm), signals, registry=reg)) == expected
        seen += "Phi" in expected or "Sat(" in expected or "Mid(" in expected
    assert seen > 50                                   # Φ-calls were exercised


def test_multiple_named_inputs():
    sig = Signals(output="f", inputs=("x", "v", "E"))
    t = parse_term("Phi2(v[k-1],x[k-2])*E[k]*x[k-1]*f[k-3]*v[k-2]", sig)
    text = str(t)
    assert text.startswith("f[k-3]*") and text.endswith("*Phi2(v[k-1],x[k-2])")
    assert sorted(text.split("*")) == sorted(["f[k-3]", "E[k]", "x[k-1]", "v[k-2]",
                                              "Phi2(v[k-1],x[k-2])"])
    assert parse_term(text, sig) == t
    assert t.max_lag == 3
    with pytest.raises(TermError, match="unknown signal 'u'"):
        parse_term("u[k-1]", sig)
    with pytest.raises(TermError, match="f\\[k\\]"):
        parse_term("f[k]*x[k-1]", sig)
    m = narx.Model(["f[k-1]", "x[k-1]*v[k-2]", "Phi1(E[k-1],E[k-2])"], [0.5, 0.1, 0.2],
                   inputs=("x", "v", "E"), output="f")
    assert m.term_texts == ["f[k-1]", "x[k-1]*v[k-2]", "Phi1(E[k-1],E[k-2])"] or \
        m.term_texts == ["f[k-1]", "v[k-2]*x[k-1]", "Phi1(E[k-1],E[k-2])"]


def test_same_term_twice_is_an_error_in_a_term_list():
    with pytest.raises(TermError, match="appears twice"):
        parse_terms(["u[k-1]*y[k-2]", "y[k-1]", "y[k-2]*u[k-1]"])
    with pytest.raises(TermError, match="appears twice"):
        narx.Model(["y[k-1]*y[k-1]", "y[k-1]^2"])


# --------------------------------------------------------------- errors
@pytest.mark.parametrize("text,match", [
    ("z[k-1]", "unknown signal 'z'"),
    ("Y[k-1]", "unknown signal 'Y'"),
    ("Phi3(u[k-1],u[k-2])", "unknown Φ-function 'Phi3'"),
    ("Phi1(u[k-1])", "Phi1 takes 2 arguments, got 1"),
    ("Phi2(u[k-1],u[k-2],u[k-3])", "Phi2 takes 2 arguments, got 3"),
    ("y[k]", "lag 0"),
    ("u[k-1]*y[k-0]", "lag 0"),
    ("u[k+1]", "future sample"),
    ("y[k+2]*u[k-1]", "future sample"),
    ("Phi1(Phi1(u[k-1],u[k-2]),u[k-1])", "nested Φ-calls"),
    ("Phi2(u[k-1],Phi1(u[k-2],u[k-3]))", "nested Φ-calls"),
    ("Phi1", "needs arguments"),
    ("y[k-1]*", "malformed"),
    ("*y[k-1]", "malformed"),
    ("y[k-1]u[k-1]", "malformed"),
    ("y[k-1]+u[k-1]", "malformed"),
    ("y[j-1]", "time index must be 'k'"),
    ("y[k-1.5]", "malformed"),
    ("y[k--1]", "malformed"),
    ("y[k-1", "malformed"),
    ("Phi1(u[k-1],u[k-2]", "malformed"),
    ("Phi1(u[k-1],)", "malformed"),
    ("Phi1()", "malformed"),
    ("y[k-1]^0", "power"),
    ("y[k-1]^11", "power"),
    ("y[k-1]^2^2", "malformed"),
    ("2*y[k-1]", "malformed"),
    ("1*y[k-1]", "malformed"),
    ("y[k-99999]", "exceeds the maximum"),
    ("", "empty"),
    ("   ", "empty"),
])
def test_term_errors(text, match):
    with pytest.raises(TermError, match=match):
        parse_term(text)


def test_term_must_be_text():
    with pytest.raises(TermError, match="must be text"):
        parse_term(3)
    with pytest.raises(TermError, match="must be text"):
        parse_terms([["y[k-1]"]])
    assert isinstance(TermError("x"), ValueError)


def test_signal_names_are_validated():
    with pytest.raises(TermError, match="identifiers"):
        Signals(output="y 1")
    with pytest.raises(TermError, match="reserved"):
        Signals(inputs=("k",))
    with pytest.raises(TermError, match="distinct"):
        Signals(output="u", inputs=("u",))
    with pytest.raises(TermError, match="at least one input"):
        Signals(inputs=())


HOSTILE = [
    "__import__('os').system('touch {p}')",
    "y[k-1]*__import__('os').system('touch {p}')",
    "Phi1(u[k-1],__import__('os').system('touch {p}'))",
    "y[k-1]; __import__('os').system('touch {p}')",
    "exec(\"open('{p}','w')\")",
    "eval(\"open('{p}','w')\")",
    "open('{p}','w')",
    "Phi1(u[k-1],u[k-2]).__class__",
    "y[k-1] if open('{p}','w') else u[k-1]",
    "[c for c in ().__class__.__base__.__subclasses__()]",
    "lambda: open('{p}','w')",
    "y[k-1]\n__import__('os').system('touch {p}')",
    "u[k-1]*y[k-1]#",
    "y[k-(__import__('os').system('touch {p}'))]",
]


@pytest.mark.parametrize("template", HOSTILE)
def test_hostile_text_is_rejected_and_nothing_runs(template, tmp_path, monkeypatch):
    pwned = tmp_path / "pwned"
    calls = []

    def spy(name):
        real = getattr(builtins, name)

        def f(*a, **k):
            calls.append(name)
            return real(*a, **k)
        return f
    monkeypatch.setattr(builtins, "eval", spy("eval"))
    monkeypatch.setattr(builtins, "exec", spy("exec"))
    text = template.format(p=pwned)
    with pytest.raises(TermError):
        parse_term(text)
    with pytest.raises(TermError):
        narx.Model(["y[k-1]", text])
    assert not pwned.exists()
    assert calls == []


# --------------------------------------------------------------- Φ registry
def test_user_phi_in_a_fresh_registry():
    name = "AbsTermsTest"
    assert name not in default_registry()
    reg = PhiRegistry()
    f = reg.register(name, 1, np.abs, steady=np.abs)
    assert f.name == name and f.arity == 1 and not f.builtin
    assert name in reg and name not in default_registry()
    assert reg.names() == sorted(["Phi1", "Phi2", name])
    assert [g.name for g in reg.user_functions()] == [name]
    np.testing.assert_array_equal(reg.get(name)(np.array([-2.0, 3.0])), [2.0, 3.0])
    assert reg.get(name).steady_value(-4.0) == 4.0
    t = parse_term(f"{name}(y[k-1])*Phi1(u[k-1],u[k-2])", registry=reg)
    assert str(t) == f"{name}(y[k-1])*Phi1(u[k-1],u[k-2])"     # Φ-calls by name
    assert t.phi_names == (name, "Phi1")
    with pytest.raises(TermError, match="unknown Φ-function"):
        parse_term(f"{name}(y[k-1])")                 # not in the default registry
    with pytest.raises(TermError, match=f"{name} takes 1 argument, got 2"):
        parse_term(f"{name}(y[k-1],y[k-2])", registry=reg)
    snap = reg.snapshot()
    reg.unregister(name)
    assert name not in reg and name in snap
    with pytest.raises(KeyError):
        reg.unregister(name)


def test_register_phi_on_default_registry_is_undone(monkeypatch):
    name = "TmpTermsTestPhi"
    narx.register_phi(name, 2, np.subtract, steady=0.0)
    try:
        assert str(parse_term(f"{name}(u[k-1],u[k-2])")) == f"{name}(u[k-1],u[k-2])"
        assert narx.get_phi(name).steady_value() == 0.0
    finally:
        narx.unregister_phi(name)
    assert name not in default_registry()


@pytest.mark.parametrize("name", ["", "1abc", "_x", "a-b", "a b", "Abs(", "k", 3, None,
                                  "é"])
def test_phi_name_validation(name):
    with pytest.raises(ValueError, match="name|reserved"):
        PhiRegistry().register(name, 1, np.abs, steady=0.0)


@pytest.mark.parametrize("arity", [0, -1, 1.5, True, "2", None])
def test_phi_arity_validation(arity):
    with pytest.raises(ValueError, match="arity"):
        PhiRegistry().register("F", arity, np.abs, steady=0.0)


def test_phi_func_and_steady_validation():
    reg = PhiRegistry()
    with pytest.raises(ValueError, match="callable"):
        reg.register("F", 1, "np.abs", steady=0.0)
    with pytest.raises(ValueError, match="steady"):
        reg.register("F", 1, np.abs, steady="zero")
    with pytest.raises(ValueError, match="steady"):
        reg.register("F", 1, np.abs, steady=None)
    assert "F" not in reg


@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
def test_phi_steady_must_be_finite(bad):
    with pytest.raises(ValueError, match="steady"):
        PhiRegistry().register("F", 1, np.abs, steady=bad)


def test_builtins_cannot_be_replaced_or_removed():
    reg = PhiRegistry()
    for name in ("Phi1", "Phi2"):
        with pytest.raises(ValueError, match="already registered"):
            reg.register(name, 2, np.add, steady=0.0)
        with pytest.raises(ValueError, match="already registered"):
            reg.register(name, 2, np.add, steady=0.0, overwrite=True)
        with pytest.raises(ValueError, match="built-in"):
            reg.unregister(name)
        assert reg.get(name).builtin
    np.testing.assert_array_equal(reg.get("Phi1")(np.array([3.0]), np.array([5.0])), [-2.0])
    np.testing.assert_array_equal(reg.get("Phi2")(np.array([3.0, 5, 4]),
                                                  np.array([5.0, 3, 4])), [-1.0, 1.0, 0.0])
    # a registry built from functions cannot smuggle a replacement either
    fake = narx.PhiFunction("Phi1", 2, np.add, 0.0)
    assert PhiRegistry([fake]).get("Phi1").func is not np.add


def test_user_phi_clash_needs_overwrite():
    reg = PhiRegistry()
    reg.register("G", 1, np.abs, steady=np.abs)
    with pytest.raises(ValueError, match="overwrite=True"):
        reg.register("G", 1, np.square, steady=np.square)
    g = reg.register("G", 1, np.square, steady=np.square, overwrite=True)
    assert reg.get("G") is g and reg.get("G").func is np.square


# --------------------------------------------------------------- package hygiene
def test_narx_sources_compile_without_warnings():
    """Invalid escapes in docstrings (e.g. LaTeX without r"...") warn at import."""
    import pathlib
    import warnings
    files = sorted(pathlib.Path(narx.__file__).parent.rglob("*.py"))
    assert len(files) >= 14
    for path in files:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            compile(path.read_text(encoding="utf-8"), str(path), "exec")


def test_lags_include_the_arguments_of_phi_calls_and_operators():
    from narx.language.terms import Signals, parse_term
    t = parse_term("u[k-1]*Play(u[k-3],0.1)*Phi1(y[k-1],y[k-2])", Signals("y", ("u",)))
    assert sorted(str(a) for a in t.lags) == ["u[k-1]", "u[k-3]", "y[k-1]", "y[k-2]"]
