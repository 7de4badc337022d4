"""MGGPRegressor parameters are checked before the search starts."""
import numpy as np
import pytest

from mggp import MGGPRegressor
from narx.records.data import DataError

from conftest import first_order_record


@pytest.fixture(scope="module")
def record():
    return first_order_record()


@pytest.mark.parametrize("param, value, text", [
    ("select", "foo", "select must be one of 'auto', 'fitness', 'freerun', 'hold', got 'foo'"),
    ("prune", "foo", "prune must be one of False, None, 'bic', 't', got 'foo'"),
    ("noise_lags", "x", "noise_lags must be an integer >= 0, got 'x'"),
    ("noise_lags", -1, "noise_lags must be an integer >= 0, got -1"),
    ("noise_lags", 1.5, "noise_lags must be an integer >= 0, got 1.5"),
    ("max_lag", -1, "max_lag must be an integer >= 1 or None, got -1"),
    ("max_degree", 0, "max_degree must be an integer >= 1 or None, got 0"),
    ("t_threshold", -1, "t_threshold must be a finite number > 0 or None, got -1"),
    ("select_candidates", 0, "select_candidates must be an integer >= 1, got 0"),
    ("search_constraints", "foo", "search_constraints must be one of None, 'steady-state'"),
    ("generations", -1, "generations must be an integer >= 0, got -1"),
    ("population", 1, "population must be an integer >= 2, got 1"),
    ("screen", "fast", "screen must be one of 'auto', 'freerun', 'hold', 'none', None, got 'fast'"),
    ("phi_outputs", "yes", "phi_outputs must be one of False, True, got 'yes'"),
    ("phi_outputs", True, "phi_outputs=True needs Φ-functions in the search, got use_phi=False"),
])
def test_bad_parameter_fails_before_any_generation(record, param, value, text):
    seen = []
    kw = dict(population=10, generations=2, max_height=2, use_phi=False, fitness="pem",
              random_state=0, callbacks=[seen.append])
    kw[param] = value
    est = MGGPRegressor(**kw)
    with pytest.raises(ValueError) as exc:
        est.fit(*record)
    assert text in str(exc.value)
    assert seen == []                       # no generation ran


def test_valid_edge_values_are_accepted(record):
    est = MGGPRegressor(population=10, generations=0, max_height=2, use_phi=False,
                        fitness="pem", random_state=0, prune=None, max_lag=1,
                        max_degree=1).fit(*record)
    assert est.model_.n_terms >= 1


def test_constant_output_is_rejected(record):
    u, _ = record
    with pytest.raises(DataError, match="output 'y' is constant"):
        MGGPRegressor(population=10, generations=1, fitness="pem").fit(u, np.full(300, 3.0))


def test_refit_leaves_nothing_from_the_earlier_fit(record):
    est = MGGPRegressor(population=10, generations=1, max_height=2, use_phi=False,
                        fitness="pem", random_state=0, select="freerun",
                        select_candidates=3).fit(*record)
    assert hasattr(est, "selection_")
    est.set_params(select="fitness").fit(*record)
    assert not hasattr(est, "selection_")


def test_repr_shows_the_parameters_that_differ_from_the_defaults():
    assert repr(MGGPRegressor()) == "MGGPRegressor()"
    assert repr(MGGPRegressor(fitness="pem", population=10, use_phi=False)) == \
        "MGGPRegressor(fitness='pem', population=10, use_phi=False)"


def test_max_lag_beyond_height_warns():
    """--max-lag only restricts: a value above what max_height trees reach
    (1 + 3 × height) used to be accepted silently and change nothing."""
    import warnings
    import numpy as np
    rng = np.random.default_rng(0)
    u = rng.standard_normal(300)
    y = np.zeros(300)
    for k in range(1, 300):
        y[k] = 0.5 * y[k - 1] + u[k - 1]
    with pytest.warns(UserWarning, match=r"max_lag=20 has no effect.*up to 7 only"):
        MGGPRegressor(population=4, generations=0, max_height=2, max_lag=20,
                      fitness="pem", random_state=0).fit(u, y)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        MGGPRegressor(population=4, generations=0, max_height=2, max_lag=7,
                      fitness="pem", random_state=0).fit(u, y)


def test_max_lag_beyond_height_leaves_the_t_threshold_alone():
    """The warning says max_lag=20 has no effect with max_height=2: the
    Bonferroni t threshold of prune='t' counts the candidate monomials of
    the lags the trees reach (it counted lags up to 20)."""
    import warnings
    import numpy as np
    rng = np.random.default_rng(0)
    u = rng.standard_normal(300)
    y = np.zeros(300)
    for k in range(1, 300):
        y[k] = 0.5 * y[k - 1] + u[k - 1] + 0.1 * rng.standard_normal()
    kw = dict(population=4, generations=0, max_height=2, prune="t", fitness="pem",
              random_state=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = [MGGPRegressor(max_lag=m, **kw).fit(u, y).t_threshold_ for m in (None, 7, 20)]
    assert t[0] == t[1] == t[2]


def test_signature_and_table_agree():
    """MGGPRegressor.__init__ takes exactly the table's parameters, in its
    order, with its defaults (get_params and repr read the table)."""
    import inspect
    from mggp.fit.params import PARAMS
    sig = inspect.signature(MGGPRegressor.__init__).parameters
    names = [n for n in sig if n != "self"]
    assert names == list(PARAMS)
    for name in names:
        assert sig[name].kind is inspect.Parameter.KEYWORD_ONLY
        assert sig[name].default == PARAMS[name].default, name
        assert type(sig[name].default) is type(PARAMS[name].default), name
    assert list(MGGPRegressor().get_params()) == names
    for p in PARAMS.values():                   # every default obeys its own rule
        p.check(p.default)


def test_checkpoint_context_and_meta_keep_their_names():
    """Checkpoints written before the table resume: the context holds the
    same keys (phi_outputs and constant only when set)."""
    from mggp.fit.params import context_of, meta_of
    old = {"fitness", "window", "k", "criterion", "search_constraints", "use_phi",
           "phi_names", "max_lag", "max_degree", "screen", "screen_top", "screen_band"}
    assert set(context_of(MGGPRegressor())) == old
    assert set(context_of(MGGPRegressor(constant=True, phi_outputs=True))) == \
        old | {"phi_outputs", "constant"}
    meta = meta_of(MGGPRegressor(phi_outputs=1 == 1))
    assert meta["phi_outputs"] is True and meta["select"] == "auto"
    assert {"population", "generations", "prune", "noise_lags", "refine"} <= set(meta)


@pytest.mark.parametrize("param, value, text", [
    ("fitness", "fast", "fitness must be one of 'ms', 'pem', 'freerun', 'ksa', got 'fast'"),
    ("cxpb", 1.5, "cxpb must be a number in [0, 1], got 1.5"),
    ("n_jobs", 0, "n_jobs must be an integer >= 1 or -1, got 0"),
    ("random_state", -3, "random_state must be None, an integer >= 0 or a numpy "
                         "Generator, got -3"),
    ("use_phi", "no", "use_phi must be one of True, False, 'auto', got 'no'"),
    ("inputs", "u", "inputs must be None or a list of names, got 'u'"),
    ("max_height", 100, "max_height must be an integer between 1 and 20 (trees of height h "
                        "reach lags up to 1 + 3h, 61 at 20, and grow exponentially with h), "
                        "or 'auto', got 100"),
])
def test_every_parameter_is_checked_by_its_row(record, param, value, text):
    with pytest.raises(ValueError) as exc:
        MGGPRegressor(**{param: value}).fit(*record)
    assert text in str(exc.value)
    MGGPRegressor(**{param: MGGPRegressor().get_params()[param]})   # control: default


def test_fit_builds_one_scorer_per_setting(record, monkeypatch):
    """The search (in this process) and every stage after it share one
    scorer of the search's settings; select='freerun' adds one free-run
    scorer (several were built: one only to check the settings)."""
    import narx.estimation.fitness
    import mggp.gp.evaluate
    import mggp.fit.estimator
    import mggp.fit.stages
    built = []
    real = narx.estimation.fitness.StructureScorer

    class Counting(real):
        def __init__(self, *a, **k):
            built.append(a[1] if len(a) > 1 else k.get("fitness", "ms"))
            super().__init__(*a, **k)
    for mod in (mggp.gp.evaluate, mggp.fit.estimator, mggp.fit.stages):
        monkeypatch.setattr(mod, "StructureScorer", Counting)
    kw = dict(population=10, generations=2, max_height=2, use_phi=False, fitness="ms",
              window=20, random_state=0, prune="bic")
    MGGPRegressor(**kw).fit(*record)
    assert built == ["ms"]
    built.clear()
    MGGPRegressor(select="freerun", select_candidates=3, **kw).fit(*record)
    assert built == ["ms", "freerun"]


def test_help_texts_state_the_figures_of_the_constants_they_describe():
    """The help of the automatic choices is written from the constants of
    mggp.fit.choices, narx.language.memory (the operator table's search grids) and
    mggp.fit.operator_stage: changed there,
    the help follows (a fresh interpreter, the constants set before the
    table is built again); control: the shipped values in the shipped help."""
    import subprocess
    import sys
    from mggp.fit.params import PARAMS
    assert "within 5 % of the least" in PARAMS["size"].help
    assert "by over 5 %" in PARAMS["constant"].help
    assert ("over 15 % lower, Φ of the output's lags too over 30 %, Bouc–Wen variables "
            "over 50 %") in PARAMS["use_phi"].help
    assert "p < 0.05" in PARAMS["constant"].help and "p < 0.05" not in PARAMS["use_phi"].help
    code = ("import importlib, mggp.fit.choices as c, narx.language.memory as m, "
            "mggp.fit.operator_stage as o, mggp.fit.params as p\n"
            "c.GAIN, c.CLASS_GAIN, c.SIZE_TOLERANCE, c.PILOT = 0.07, 0.25, 0.08, 0.3\n"
            "c.LEVEL = 0.01\n"
            "m.PLAY_RADIUS_FRACTIONS, o.OPERATOR_GAIN = (0.1, 0.4), 0.02\n"
            "p = importlib.reload(p)\n"
            "print(p.PARAMS['constant'].help, p.PARAMS['use_phi'].help, "
            "p.PARAMS['size'].help, p.PARAMS['operators'].help, "
            "p.PARAMS['operator_entry'].help, sep='\\n')\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert "Φ over" not in out                  # the one margin for Φ, not a second
    assert "p < 0.01" in out and "p < 0.05" not in out
    for text in ("by over 7 %", "over 25 % lower", "30 % of the generations",
                 "within 8 % of the least", "radii 0.1, 0.4 ×", "lowers the fitness by 2 %"):
        assert text in out, text


def test_parameters_in_tiers_common_first():
    """The ten parameters of the common tier (a column of the one table)
    come first in the signature, make the docstring's *Parameters* (the
    rest its *Other Parameters*) and the first group of `mggp fit --help`,
    whose expert groups hold the others."""
    import inspect
    from mggp.cli.app import build_parser
    from mggp.fit.params import PARAMS, TIERS
    common = [n for n, p in PARAMS.items() if p.tier == "common"]
    assert len(common) == 10 and {p.tier for p in PARAMS.values()} == set(TIERS)
    names = [n for n in inspect.signature(MGGPRegressor.__init__).parameters if n != "self"]
    assert names[:10] == common
    doc = MGGPRegressor.__doc__
    head, other = doc.split("    Other Parameters\n", 1)
    section = head.split("    Parameters\n", 1)[1]
    listed = [ln.split(" : ")[0].strip() for ln in section.splitlines() if " : " in ln
              and ln.startswith("    ") and not ln.startswith("     ")]
    assert listed == common
    assert all(f"\n    {n} : " in other for n in PARAMS if n not in common)
    assert "\n    population : " not in other            # control: common ones not twice
    sub = next(a for a in build_parser()._actions if a.dest == "command").choices["fit"]
    groups = [g for g in sub._action_groups if g._group_actions
              and g.title not in ("positional arguments", "options")]
    assert groups[0].title == TIERS["common"]
    first = {a.dest for a in groups[0]._group_actions}
    assert {n for n in common} <= first
    assert all(g.title.startswith(TIERS["expert"]) for g in groups[1:])
    assert not any(a.dest in common for g in groups[1:] for a in g._group_actions)


def test_misspelt_keyword_suggests_the_closest_parameter():
    from mggp.fit.params import unknown_keyword
    with pytest.raises(TypeError, match="'max_term': did you mean 'max_terms'"):
        MGGPRegressor(max_term=5)
    assert "did you mean" not in unknown_keyword("qqqq")     # control: nothing close
