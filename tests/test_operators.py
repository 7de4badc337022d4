"""Primitive set, decoding, safe tree parsing and genetic operators."""
import pickle
import random
import subprocess
import sys

import numpy as np
import pytest
from deap import gp

from narx.language.phi import PhiRegistry
from narx.language.terms import Lag, PhiCall, Signals, parse_term
from mggp.gp.individual import Individual
from mggp.gp.operators import (cx_high_level, cx_low_level, gen_tree,
                            mut_high_level, mut_low_level, random_individual,
                            remove_duplicate_genes, sel_tournament)
from mggp.gp.primitives import (Decoder, Expr, InputLag, LagSymbol, decode,
                             decode_individual, make_pset, max_lag_for_height,
                             tree_from_tokens, tree_to_tokens)

MAX_TERMS, MAX_HEIGHT = 6, 4


@pytest.fixture(scope="module")
def pset():
    return make_pset(Signals("y", ("u",)))


def T(pset, *tokens):
    return tree_from_tokens(list(tokens), pset)


def check_typed(tree, pset):
    """Every node has the type its parent expects (root: pset.ret)."""
    expected = [pset.ret]
    for node in tree:
        t = expected.pop()
        assert node.ret is t, f"{node.name} of type {node.ret.__name__} where {t.__name__} expected in {tree}"
        expected.extend(reversed(getattr(node, "args", ())))
    assert not expected


def check_phi_args(term):
    """Every Φ-call takes lags of one and the same input."""
    for f in term.factors:
        if isinstance(f, PhiCall):
            assert all(isinstance(a, Lag) and a.role == "u" for a in f.args), str(term)
            assert len({a.signal for a in f.args}) == 1, f"Φ mixing inputs in {term}"


# ------------------------------------------------------------ primitive set
def test_pset_contents(pset):
    prims = {(p.name, p.ret) for ps in pset.primitives.values() for p in ps}
    assert {("mul", Expr), ("q1", Expr), ("q3", Expr), ("Phi1", Expr), ("Phi2", Expr),
            ("q1", InputLag), ("q2", InputLag)} <= prims
    assert sorted(t.name for t in pset.terminals[Expr]) == ["u[k-1]", "y[k-1]"]
    assert [t.name for t in pset.terminals[InputLag]] == ["u[k-1]"]
    assert all(a is InputLag for p in pset.primitives[Expr] if p.name.startswith("Phi")
               for a in p.args)
    assert max_lag_for_height(5) == 16


def test_no_phi_and_multi_input_and_user_phi():
    plain = make_pset(use_phi=False)
    names = {p.name for ps in plain.primitives.values() for p in ps}
    assert names == {"mul", "q1", "q2", "q3"} and not plain.terminals.get(InputLag)
    two = make_pset(Signals("y", ("u1", "u2")))
    u1, u2 = two.lag_types["u1"], two.lag_types["u2"]     # one lagged-input type each
    assert not two.terminals.get(InputLag) and len(two.lag_types) == 2
    for name, t in two.lag_types.items():
        assert issubclass(t, InputLag) and t.__name__ == f"InputLag_{name}" and t.input == name
        assert [n.name for n in two.terminals[t]] == [f"{name}[k-1]"]
        assert [p.name for p in two.primitives[t]] == ["q1", "q2", "q3"]
    assert [(p.name, p.args) for p in two.primitives[Expr] if p.name.startswith("Phi")] \
        == [("Phi1", [u1, u1]), ("Phi1", [u2, u2]), ("Phi2", [u1, u1]), ("Phi2", [u2, u2])]
    assert make_pset().lag_types == {"u": InputLag}
    reg = PhiRegistry()
    reg.register("Abs", 1, np.abs, np.abs)
    ps = make_pset(registry=reg)
    abs_ = [p for p in ps.primitives[Expr] if p.name == "Abs"]
    assert len(abs_) == 1 and abs_[0].args == [InputLag]
    assert decode(T(ps, "mul", "Abs", "q2", "u[k-1]", "y[k-1]")).text == "y[k-1]*Abs(u[k-3])"
    assert make_pset(registry=reg, phi_names=["Phi2"]).phi_names == ("Phi2",)
    with pytest.raises(ValueError, match="unknown Φ-function 'Nope'"):
        make_pset(registry=reg, phi_names=["Nope"])


# ------------------------------------------------------------ decoding
def test_decode_by_hand(pset):
    # q^-1 of a product shifts every lag, Φ arguments included
    t = T(pset, "q1", "mul", "y[k-1]", "Phi1", "u[k-1]", "q1", "u[k-1]")
    assert decode(t).text == "y[k-2]*Phi1(u[k-2],u[k-3])"
    assert decode(T(pset, "Phi1", "q2", "u[k-1]", "u[k-1]")).text == "Phi1(u[k-3],u[k-1])"
    t = T(pset, "mul", "q3", "q3", "y[k-1]", "q2", "mul", "u[k-1]", "u[k-1]")
    assert decode(t).text == "y[k-7]*u[k-3]*u[k-3]"
    # a term of the published reference model
    t = T(pset, "q1", "mul", "Phi2", "u[k-1]", "q1", "u[k-1]",
          "mul", "Phi1", "u[k-1]", "q1", "u[k-1]", "u[k-1]")
    assert decode(t) == parse_term("Phi2(u[k-2],u[k-3])*Phi1(u[k-2],u[k-3])*u[k-2]")
    assert decode(T(pset, "y[k-1]"), Signals()).text == "y[k-1]"
    with pytest.raises(ValueError, match="not a signal"):
        decode(T(pset, "y[k-1]"), Signals("z", ("u",)))


def test_decoder_cache_and_duplicate_genes(pset):
    dec = Decoder(pset.signals)
    genes = [T(pset, "mul", "y[k-1]", "u[k-1]"), T(pset, "y[k-1]"),
             T(pset, "mul", "u[k-1]", "y[k-1]"),            # same term as gene 0
             T(pset, "q1", "u[k-1]"), T(pset, "y[k-1]")]
    ind = Individual(genes)
    terms = decode_individual(ind, dec)
    assert [t.text for t in terms] == ["y[k-1]*u[k-1]", "y[k-1]", "u[k-2]"]
    assert len(dec) == 4                                     # cached by tree text
    assert dec.decode(T(pset, "y[k-1]")) is terms[1]
    ind.append(T(pset, "q3", "y[k-1]"))                      # a change drops the cache
    assert [t.text for t in dec.decode_individual(ind)][-1] == "y[k-4]"
    ind.fitness.values = (1.0,)
    remove_duplicate_genes(ind, dec)
    assert len(ind) == 4 and ind.fitness.values == (1.0,)


# ------------------------------------------------------------ safe parsing
def test_tree_from_tokens_is_safe(pset):
    with pytest.raises(ValueError, match=r"unknown primitive or terminal \"__import__\('os'\)"):
        tree_from_tokens(["__import__('os').system('x')"], pset)
    with pytest.raises(ValueError, match="unknown primitive or terminal 'sin'"):
        tree_from_tokens(["mul", "sin", "y[k-1]"], pset)
    with pytest.raises(ValueError, match="unknown primitive or terminal 'x'"):
        tree_from_tokens(["x"], pset)
    with pytest.raises(ValueError, match="not allowed where InputLag"):
        tree_from_tokens(["Phi1", "y[k-1]", "u[k-1]"], pset)     # Φ of an output
    with pytest.raises(ValueError, match="incomplete"):
        tree_from_tokens(["mul", "y[k-1]"], pset)
    with pytest.raises(ValueError, match="trailing"):
        tree_from_tokens(["y[k-1]", "u[k-1]"], pset)
    with pytest.raises(ValueError, match="empty"):
        tree_from_tokens([], pset)


def test_tokens_round_trip(pset):
    rng = random.Random(3)
    for _ in range(300):
        t = gen_tree(pset, rng, 0, 5)
        back = tree_from_tokens(tree_to_tokens(t), pset)
        assert list(back) == list(t) and str(back) == str(t)


# ------------------------------------------------------------ generation
def test_gen_tree_heights_and_types(pset):
    rng = random.Random(0)
    heights = set()
    for _ in range(500):
        t = gen_tree(pset, rng, 1, MAX_HEIGHT)
        check_typed(t, pset)
        assert 1 <= t.height <= MAX_HEIGHT
        heights.add(t.height)
    assert heights == set(range(1, MAX_HEIGHT + 1))
    for _ in range(50):
        assert gen_tree(pset, rng, 3, 3, method="full").height == 3
    sub = gen_tree(pset, rng, 2, 2, type_=InputLag)
    assert all(n.ret is InputLag for n in sub) and sub.height == 2


def test_no_global_random_state(pset):
    random.seed(123)
    before = random.getstate()
    rng = random.Random(1)
    pop = [random_individual(pset, rng, MAX_TERMS, MAX_HEIGHT) for _ in range(10)]
    for _ in range(50):
        a, b = pop[rng.randrange(10)], pop[rng.randrange(10)]
        if a is not b:
            cx_high_level(a, b, rng, MAX_TERMS)
            cx_low_level(a, b, rng, MAX_HEIGHT)
        mut_high_level(a, pset, rng, MAX_TERMS, MAX_HEIGHT)
        mut_low_level(a, pset, rng, MAX_HEIGHT)
    for ind in pop:
        ind.fitness.values = (rng.random(),)
    sel_tournament(pop, 5, 3, rng)
    assert random.getstate() == before


# ------------------------------------------------------------ operators
def run_operators(pset, rng):
    """3000 random operator applications on a population of 30, checking
    limits, types and Φ arguments of every individual an operator returns."""
    dec = Decoder(pset.signals)
    pop = [random_individual(pset, rng, MAX_TERMS, MAX_HEIGHT) for _ in range(30)]
    counts = dict(cxh=0, cxl=0, muth=0, mutl=0)
    for step in range(3000):
        i, j = rng.sample(range(len(pop)), 2)
        a, b = pop[i], pop[j]
        for ind in (a, b):
            ind.fitness.values = (1.0,)
        op = rng.choice(list(counts))
        counts[op] += 1
        if op == "cxh":
            out = cx_high_level(a, b, rng, MAX_TERMS)
        elif op == "cxl":
            out = cx_low_level(a, b, rng, MAX_HEIGHT)
        elif op == "muth":
            out = mut_high_level(a, pset, rng, MAX_TERMS, MAX_HEIGHT)
        else:
            out = mut_low_level(a, pset, rng, MAX_HEIGHT)
        assert isinstance(out, tuple) and len(out) == (2 if op.startswith("cx") else 1)
        for ind in out:
            assert 1 <= len(ind) <= MAX_TERMS
            for g in ind:
                assert isinstance(g, gp.PrimitiveTree) and g.height <= MAX_HEIGHT
                check_typed(g, pset)
            for t in dec.decode_individual(ind):
                check_phi_args(t)
    # no gene list is shared between two individuals
    ids = [id(g) for ind in pop for g in ind]
    assert len(ids) == len(set(ids))
    assert min(counts.values()) > 500
    return pop


def test_operators_keep_limits_types_and_phi_args(pset):
    run_operators(pset, random.Random(42))


def test_high_level_crossover_changes_sizes(pset):
    rng = random.Random(7)
    changed, conserved = 0, 0
    for _ in range(200):
        a = random_individual(pset, rng, 8, 3)
        b = random_individual(pset, rng, 8, 3)
        na, nb = len(a), len(b)
        a.fitness.values = b.fitness.values = (1.0,)
        cx_high_level(a, b, rng, max_terms=16)        # no truncation possible
        assert not a.fitness.valid and not b.fitness.valid
        changed += (len(a), len(b)) != (na, nb)
        conserved += len(a) + len(b) == na + nb
    assert changed > 100 and conserved == 200
    for _ in range(200):                              # truncation to max_terms
        a = random_individual(pset, rng, 5, 3, min_terms=5)
        b = random_individual(pset, rng, 5, 3, min_terms=5)
        cx_high_level(a, b, rng, max_terms=5)
        assert 1 <= len(a) <= 5 and 1 <= len(b) <= 5


def test_low_level_crossover_static_limit(pset):
    rng = random.Random(11)
    deep = T(pset, "q1", "q1", "q1", "q1", "y[k-1]")          # height 4
    for _ in range(100):
        a = Individual([gp.PrimitiveTree(deep)])
        b = Individual([gen_tree(pset, rng, 3, 4)])
        cx_low_level(a, b, rng, max_height=4)
        assert a[0].height <= 4 and b[0].height <= 4


def test_high_level_mutation_actions(pset):
    rng = random.Random(5)
    for _ in range(100):
        full = random_individual(pset, rng, 4, 3, min_terms=4)
        mut_high_level(full, pset, rng, max_terms=4, max_height=3)
        assert len(full) in (3, 4)                        # never adds beyond max
        one = random_individual(pset, rng, 1, 3)
        mut_high_level(one, pset, rng, max_terms=4, max_height=3)
        assert len(one) in (1, 2)                         # never removes the last
    sizes = set()
    for _ in range(100):
        ind = random_individual(pset, rng, 3, 3, min_terms=3)
        mut_high_level(ind, pset, rng, max_terms=6, max_height=3)
        sizes.add(len(ind))
    assert sizes == {2, 3, 4}


def test_tournament(pset):
    rng = random.Random(0)
    pop = [random_individual(pset, rng, 3, 2) for _ in range(20)]
    for k, ind in enumerate(pop):
        ind.fitness.values = (float(k),)
    assert all(w is pop[0] for w in sel_tournament(pop, 10, 200, rng))
    a = sel_tournament(pop, 30, 2, random.Random(9))
    b = sel_tournament(pop, 30, 2, random.Random(9))
    assert [id(x) for x in a] == [id(x) for x in b]
    assert np.mean([x.fitness.values[0] for x in a]) < 9.5   # pressure towards low


# ------------------------------------------------------------ several inputs
def _hyst3(a, b, c):
    return a - 2 * b + c


@pytest.fixture(scope="module", params=["two", "three+user"])
def multi(request):
    """Two inputs (Phi1, Phi2), or three inputs with a user Φ of arity 3."""
    if request.param == "two":
        return make_pset(Signals("y", ("u1", "u2")))
    reg = PhiRegistry()
    reg.register("Hyst3", 3, _hyst3, 0.0)
    return make_pset(Signals("y", ("u1", "u2", "u3")), registry=reg)


def phi_inputs(terms):
    """Input names used by the Φ-calls of some terms."""
    return {a.signal for t in terms for f in t.factors if isinstance(f, PhiCall)
            for a in f.args}


def test_random_individuals_never_mix_inputs_in_phi(multi):
    rng, dec = random.Random(0), Decoder(multi.signals)
    terms = []
    for _ in range(300):
        ind = random_individual(multi, rng, MAX_TERMS, MAX_HEIGHT)
        for g in ind:
            check_typed(g, multi)
        terms += dec.decode_individual(ind)
    for t in terms:
        check_phi_args(t)
    # every input gets Φ-terms of its own, every Φ-function is used
    assert phi_inputs(terms) == set(multi.signals.inputs)
    used = {f.name for t in terms for f in t.factors if isinstance(f, PhiCall)}
    assert used == set(multi.phi_names)


def test_phi_share_does_not_grow_with_the_number_of_inputs():
    # a Φ-function is one choice of the generator, its input a second one:
    # the share of Φ among the Expr primitives drawn stays 2/6 (mul, q1..q3,
    # Phi1, Phi2), it would be 4/8 and 6/10 with a choice per input variant
    def share(inputs):
        ps, rng = make_pset(Signals("y", inputs)), random.Random(0)
        drawn = [n for _ in range(3000) for n in gen_tree(ps, rng, 0, MAX_HEIGHT)
                 if n.arity and n.ret is Expr]
        return sum(n.name in ps.phi_names for n in drawn) / len(drawn)
    one = share(("u",))
    assert one == pytest.approx(1 / 3, abs=0.02)
    assert share(("u1", "u2")) == pytest.approx(one, abs=0.02)
    assert share(("u1", "u2", "u3")) == pytest.approx(one, abs=0.02)


def test_operators_never_mix_inputs_in_phi(multi):
    pop = run_operators(multi, random.Random(42))
    assert phi_inputs(t for ind in pop for t in decode_individual(ind)) \
        == set(multi.signals.inputs)


def test_tokens_of_several_inputs():
    two = make_pset(Signals("y", ("u1", "u2")))
    rng = random.Random(3)
    for _ in range(300):
        t = gen_tree(two, rng, 0, 5)
        back = tree_from_tokens(tree_to_tokens(t), two)
        assert list(back) == list(t) and str(back) == str(t)
    t = T(two, "mul", "Phi1", "q1", "u2[k-1]", "u2[k-1]", "Phi2", "u1[k-1]", "q2", "u1[k-1]")
    assert decode(t).text == "Phi1(u2[k-2],u2[k-1])*Phi2(u1[k-1],u1[k-3])"
    with pytest.raises(ValueError, match="not allowed where InputLag_u1 is expected"):
        T(two, "Phi1", "u1[k-1]", "q1", "u2[k-1]")
    with pytest.raises(ValueError, match="not allowed where InputLag_u2 is expected"):
        T(two, "Phi2", "q3", "u2[k-1]", "y[k-1]")


def test_decode_refuses_phi_of_two_inputs():
    # a tree built by hand outside make_pset: the decoder still refuses it
    def lag(name):
        return gp.Terminal(LagSymbol(Lag(name, 1, "u")), False, InputLag)
    tree = gp.PrimitiveTree([gp.Primitive("Phi1", [InputLag, InputLag], Expr),
                             lag("u1"), lag("u2")])
    with pytest.raises(ValueError, match="lags of one input"):
        decode(tree)
    same = gp.PrimitiveTree([gp.Primitive("Phi1", [InputLag, InputLag], Expr),
                             lag("u2"), lag("u2")])
    assert decode(same).text == "Phi1(u2[k-1],u2[k-1])"
    # only the search is restricted: a hand-written term may mix inputs
    two = Signals("y", ("u1", "u2"))
    assert parse_term("Phi1(u1[k-1],u2[k-1])", two).text == "Phi1(u1[k-1],u2[k-1])"


def test_several_input_trees_pickle_into_a_fresh_process():
    two = make_pset(Signals("y", ("u1", "u2")))
    ind = random_individual(two, random.Random(1), 8, 4, min_terms=8)
    blob = pickle.dumps(ind)
    back = pickle.loads(blob)
    assert [list(g) for g in back] == [list(g) for g in ind]
    code = ("import pickle, sys; ind = pickle.loads(sys.stdin.buffer.read()); "
            "print(repr([str(g) for g in ind]))")
    r = subprocess.run([sys.executable, "-c", code], input=blob, capture_output=True)
    assert r.returncode == 0, r.stderr.decode()
    assert r.stdout.decode().strip() == repr([str(g) for g in ind])


def test_low_level_crossover_keeps_phi_on_one_input():
    # parents whose Φ-calls are all on one input stay so under subtree
    # crossover alone (an input-lag subtree only meets one of its input)
    two = make_pset(Signals("y", ("u1", "u2")))
    rng, dec = random.Random(8), Decoder(two.signals)

    def clean(ind):
        return all(len({a.signal for a in f.args}) == 1 for t in dec.decode_individual(ind)
                   for f in t.factors if isinstance(f, PhiCall))
    pop = [ind for ind in (random_individual(two, rng, MAX_TERMS, MAX_HEIGHT)
                           for _ in range(200)) if clean(ind)][:30]
    assert len(pop) == 30 and len(phi_inputs(t for i in pop for t in dec.decode_individual(i))) == 2
    for _ in range(2000):
        a, b = rng.sample(pop, 2)
        cx_low_level(a, b, rng, MAX_HEIGHT)
        assert clean(a) and clean(b)


def test_phi_outputs_adds_a_lag_type_for_the_output():
    """phi_outputs=True: Φ-terms of output lags are built (one type of their
    own: never an output lag and an input lag in one Φ-call); the default
    set never builds one (control)."""
    ps = make_pset(phi_outputs=True)
    assert set(ps.lag_types) == {"u", "y"} and ps.phi_outputs
    assert [n.name for n in ps.terminals[ps.lag_types["y"]]] == ["y[k-1]"]
    dec, rng = Decoder(ps.signals), random.Random(0)
    default, dec0 = make_pset(), Decoder(Signals())
    out_phi = mixed = 0
    for _ in range(200):
        for t in dec.decode_individual(random_individual(ps, rng, max_terms=15, max_height=5)):
            for f in t.factors:
                if isinstance(f, PhiCall):
                    roles = {a.role for a in f.args}
                    out_phi += roles == {"y"}
                    mixed += len(roles) > 1
        for t in dec0.decode_individual(random_individual(default, rng, max_terms=15,
                                                          max_height=5)):
            assert not any(isinstance(f, PhiCall) and any(a.role == "y" for a in f.args)
                           for f in t.factors)
    assert out_phi > 50 and mixed == 0
    assert not make_pset(use_phi=False, phi_outputs=True).phi_outputs
    for _ in range(50):                  # checkpoints: tokens back to the same typed tree
        for g in random_individual(ps, rng, max_terms=15, max_height=5):
            back = tree_from_tokens(tree_to_tokens(g), ps)
            assert str(back) == str(g) and [n.ret for n in back] == [n.ret for n in g]
