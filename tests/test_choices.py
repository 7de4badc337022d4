"""Automatic choices of MGGPRegressor (mggp.fit.choices): the model class (no Φ,
Φ, memory operators) and the constant term by held-out free-run error, the
selection by the constraints; recorded in choices_ and meta."""
import warnings

import numpy as np
import pytest

from mggp import MGGPRegressor
from mggp.fit.choices import CLASS_GAIN, SearchClass, class_choice, heldout_rmse
from narx.records.data import Data
from narx.systems.testsystems import system_by_name

from conftest import first_order_record
from test_constant import affine_record

PLAIN, PHI, OPS = (SearchClass("no Φ", False, ()), SearchClass("Φ", True, ()),
                   SearchClass("operators", False, ("play", "dengtan")))

_KW = dict(fitness="pem", population=16, generations=2, max_height=2, max_terms=5,
           random_state=1)


def phi_choice(err_plain, err_phi, holds_plain=None, holds_phi=None):
    holds = None if holds_phi is None else [holds_plain, holds_phi]
    return class_choice([PLAIN, PHI], [err_plain, err_phi], holds)


def test_phi_kept_only_for_a_clear_gain():
    assert phi_choice(1.0, 0.5).value is True
    assert phi_choice(1.0, 1.0 - CLASS_GAIN / 2).value is False         # within the margin
    assert phi_choice(0.5, 1.0).value is False
    assert phi_choice(float("inf"), 3.0).value is True            # plain diverges
    c = phi_choice(0.41, 0.58)
    assert c.why.startswith("no Φ: held-out free-run RMSE 0.41 against 0.58 with Φ")
    assert c.figures["heldout_rmse_phi"] == 0.58


def test_operators_class_taken_only_for_a_clear_gain():
    c = class_choice([PLAIN, PHI, OPS], [1.0, 0.8, 0.06])
    assert c.value is False and c.figures["class"] == "operators"
    assert c.figures["operators"] == ["play", "dengtan"]
    assert c.why.startswith("operators: held-out free-run RMSE 0.06 against 1 without Φ, "
                            "0.8 with Φ")
    # control: within the margin of Φ's error, the simpler class (Φ) stays
    c = class_choice([PLAIN, PHI, OPS], [1.0, 0.8, 0.8 * (1 - CLASS_GAIN / 2)])
    assert c.figures["class"] == "Φ" and c.value is True


def test_a_search_that_holds_wins_whatever_its_error():
    assert phi_choice(0.1, 1.0, holds_plain=False, holds_phi=True).value is True
    assert phi_choice(1.0, 0.1, holds_plain=True, holds_phi=False).value is False
    # control: both hold, the error decides
    assert phi_choice(1.0, 0.1, holds_plain=True, holds_phi=True).value is True


def test_heldout_rmse_is_measured_on_the_tail_only():
    d = system_by_name("S1", n=500, seed=0)
    data = Data(d.u, d.y)
    true = heldout_rmse(["y[k-1]", "y[k-2]", "u[k-1]", "u[k-2]"], data)
    wrong = heldout_rmse(["u[k-1]"], data)
    assert np.isfinite(true) and true < wrong


def test_defaults_choose_and_record_with_figures():
    d = system_by_name("S1", n=500, seed=0)
    est = MGGPRegressor(**_KW).fit(d.u, d.y)
    phi = est.choices_["use_phi"]
    assert isinstance(phi["value"], bool) and "held-out free-run RMSE" in phi["why"]
    assert {"heldout_rmse_phi", "heldout_rmse_no_phi"} <= set(phi["figures"])
    assert est.choices_["select"]["value"] == "fitness"
    meta = est.model_.meta
    assert meta["use_phi"] is phi["value"] and meta["select"] == "fitness"
    assert meta["choices"]["use_phi"]["why"] == phi["why"]
    assert {"heldout_rmse_operators", "class"} <= set(phi["figures"])
    assert meta["constant"] is est.choices_["constant"]["value"]


def test_chosen_class_is_the_uninterrupted_search_of_that_class():
    """The chosen class's pilot is continued to the full generations: the
    result is the one search of that class with the same seed (the other
    pilots change nothing but the choice)."""
    d = system_by_name("S1", n=500, seed=0)
    kw = dict(_KW, generations=5, size="search", constant=False)
    est = MGGPRegressor(**kw).fit(d.u, d.y)
    fig = est.choices_["use_phi"]["figures"]
    one = MGGPRegressor(use_phi=est.choices_["use_phi"]["value"],
                        operators=",".join(fig["operators"]) or "none", **kw).fit(d.u, d.y)
    assert [r["best"] for r in est.logbook_] == [r["best"] for r in one.logbook_]
    assert len(est.logbook_) == 6 and est.model_.term_texts == one.model_.term_texts
    # the pilots' structures are counted too
    assert est.n_evaluations_ > one.n_evaluations_


class _Phases:
    """A callback that records the searches it is told of and their generations."""

    def __init__(self):
        self.phases, self.generations, self.planned = [], [], None

    def plan(self, generations):
        self.planned = generations

    def phase(self, label, generations):
        self.phases.append((label, generations))

    def __call__(self, state):
        self.generations.append((self.phases[-1][0], state.generation))


def test_callbacks_are_told_which_search_runs():
    d = system_by_name("S1", n=500, seed=0)
    cb, plain = _Phases(), []
    kw = dict(_KW, generations=5, size="search", constant=False)
    est = MGGPRegressor(**dict(kw, callbacks=[cb, plain.append])).fit(d.u, d.y)
    chosen = est.choices_["use_phi"]["figures"]["class"]
    assert cb.phases == [("pilot 1/6 no Φ", 1), ("pilot 2/6 Φ", 1), ("pilot 3/6 Φ of outputs", 1),
                         ("pilot 4/6 operators", 1), ("pilot 5/6 Bouc–Wen", 1),
                         (f"pilot 6/6 {chosen}, powers uncapped", 1), (f"search {chosen}", 5)]
    # each generation is reported under the search it belongs to; the chosen
    # pilot's run continues from its last generation
    assert [g for lab, g in cb.generations if lab == f"search {chosen}"] == [2, 3, 4, 5]
    assert len(plain) == len(cb.generations)        # a plain callable still runs
    assert cb.planned == len(cb.generations) == 16  # the plan: every report of the fit
    # control: one class and the power cap asked for, one search
    one = _Phases()
    MGGPRegressor(**dict(kw, use_phi=False, max_power=3, callbacks=[one])).fit(d.u, d.y)
    assert one.phases == [("search no Φ", 5)]
    assert one.planned == len(one.generations) == 6


def test_the_progress_line_says_the_time_left_once_it_knows_the_plan():
    """With the fit's plan the progress line adds the time left at the pace
    so far; without a plan (a diagnosis's searches) it does not."""
    import io
    from types import SimpleNamespace
    from mggp.cli.fit import _Progress, _duration
    for plan, expect in ((12, True), (None, False)):
        out = io.StringIO()
        p = _Progress(5, out, False)
        if plan:
            p.plan(plan)
        p.phase("search no Φ", 5)
        for g in range(6):
            p(SimpleNamespace(generation=g, logbook=[{"best": 1.0, "best_terms": 3}]))
        assert ("left)" in out.getvalue()) == expect
    assert p.left(10.0) == "" and _duration(75) == "1 min 15 s" and _duration(4000) == "1 h 6 min"
    p.plan(12)
    assert p.left(12.0) == " (about 12 s left)"  # 6 of 12 reports in 12 s


def test_constant_kept_for_an_offset_only():
    """An output resting at an offset (y = 0.5 + 0.6 y[k-1] + 0.4 u[k-1])
    keeps the constant term; control: a record without one drops it."""
    kw = dict(_KW, population=40, generations=6, use_phi=False)
    est = MGGPRegressor(**kw).fit(*affine_record())
    c = est.choices_["constant"]
    assert c["value"] is True and "1" in est.model_.term_texts
    assert c["figures"]["heldout_rmse_constant"] < 0.5 * c["figures"]["heldout_rmse_no_constant"]
    assert est.model_.meta["constant"] is True
    ctl = MGGPRegressor(**kw).fit(*first_order_record(500, 0, noise=0.01))
    assert ctl.choices_["constant"]["value"] is False and "1" not in ctl.model_.term_texts
    assert ctl.choices_["constant"]["why"].startswith("no constant term: held-out")
    assert ctl.model_.meta["constant"] is False


def _gain(simple, rich, significant, p=0.01):
    """A :class:`mggp.fit.choices.Gain` by hand (its rule is tested on data below)."""
    from mggp.fit.choices import CONSTANT_ENDS, Gain
    return Gain(simple, rich, 0.004, p, 12, significant, CONSTANT_ENDS)


def test_constant_pilot_keeps_the_constant_only_for_a_significant_gain():
    from mggp.fit.choices import constant_pilot_choice
    assert constant_pilot_choice(_gain(1.0, 0.5, True), _gain(1.0, 0.5, True),
                                 "p").value is True
    c = constant_pilot_choice(_gain(0.0551, 0.0502, False, p=0.21), _gain(0.06, 0.0502, True),
                              "pilots")
    assert c.value is False
    assert c.why.startswith("no constant term: held-out RMSE 0.0502 vs 0.0551 (±0.004, "
                            "p = 0.21) without it: not significant, kept the simpler")
    assert c.figures["pilot_heldout_rmse_constant"] == 0.0502
    assert c.figures["pilot_heldout_rmse_no_constant"] == 0.0551
    assert c.figures["pilot_heldout_rmse_own_no_constant"] == 0.06
    assert c.figures["pilot_gain_p_value"] == 0.21 and c.figures["pilot_gain_level"] == 0.05
    worse = constant_pilot_choice(_gain(0.0551, 0.0586, False, p=0.9),
                                  _gain(0.06, 0.0586, False), "pilots")
    assert worse.value is False and "without it: no gain, kept the simpler" in worse.why


def test_constant_pilot_gain_must_come_from_the_constant_itself():
    """The pilot with the constant beats the one without, but its own
    structure does as well without the constant: the search drops it; the
    control, where dropping the constant from that structure costs, keeps it."""
    from mggp.fit.choices import constant_pilot_choice
    c = constant_pilot_choice(_gain(0.0676, 0.0523, True), _gain(0.0530, 0.0523, False, 0.4),
                              "pilots")
    assert c.value is False
    assert c.why.startswith("no constant term: held-out RMSE 0.0523 vs 0.0676 (±0.004, "
                            "p = 0.01) without it, but held-out RMSE 0.0523 vs 0.053")
    assert "the structure, not the constant, makes the gain" in c.why
    ctl = constant_pilot_choice(_gain(0.0676, 0.0523, True), _gain(0.07, 0.0523, True),
                                "pilots")
    assert ctl.value is True
    assert ctl.why.startswith("searched with the constant term: held-out RMSE 0.0523 vs "
                              "0.0676 (±0.004, p = 0.01) without it, and held-out RMSE "
                              "0.0523 vs 0.07")


def test_heldout_gain_takes_only_a_significant_gain_beyond_the_margin():
    """heldout_gain on a noisy S1 record: the exact structure over one that
    misses a term is a gain; controls: a spurious term over the exact
    structure is not (p above the level), nor a gain under the margin; a
    diverging simpler structure loses to any finite one; the seed fixes
    the figures."""
    from mggp.fit.choices import LEVEL, heldout_gain
    d = system_by_name("S1", n=500, seed=0, output_snr=30)
    data = Data(d.u, d.y)
    exact = list(d.terms)
    g = heldout_gain(exact[:-1], exact, data, seed=1)
    assert g.significant and g.p_value < LEVEL and g.rich < g.simple and g.block >= 1
    assert g.text().startswith("held-out RMSE ") and "(±" in g.text()
    again = heldout_gain(exact[:-1], exact, data, seed=1)
    assert (again.p_value, again.spread, again.block) == (g.p_value, g.spread, g.block)
    spurious = heldout_gain(exact, exact + ["u[k-3]*u[k-3]"], data, seed=1)
    assert not spurious.significant
    assert not heldout_gain(exact[:-1], exact, data, seed=1, margin=0.99).significant
    assert heldout_gain(["y[k-1]"], [], data).significant is False     # rich: nothing
    assert heldout_gain([], exact, data).significant is True           # simple: nothing


def test_the_search_drops_the_constant_when_its_pilot_gains_nothing():
    """constant='auto': the chosen class also has a pilot without the
    constant; on a record without an offset the search continues from it,
    which is the same run as a search with constant=False (same seed, same
    model); control: the offset record continues with the constant."""
    kw = dict(_KW, population=40, generations=6, use_phi=False, max_power=3)
    data = first_order_record(500, 0, noise=0.01)
    cb = _Phases()
    est = MGGPRegressor(**dict(kw, callbacks=[cb])).fit(*data)
    c = est.choices_["constant"]
    assert c["value"] is False and "pilots of 1 of 6 generations" in c["why"]
    assert cb.phases == [("pilot 1/2 no Φ", 1), ("pilot 2/2 no Φ, no constant", 1),
                         ("search no Φ", 6)]
    plain = MGGPRegressor(**dict(kw, constant=False)).fit(*data)
    assert est.model_.term_texts == plain.model_.term_texts
    np.testing.assert_array_equal(est.model_.theta, plain.model_.theta)
    off = MGGPRegressor(**kw).fit(*affine_record())
    assert off.choices_["constant"]["why"].startswith("searched with the constant term")
    assert "1" in off.model_.term_texts


def test_no_constant_under_the_steady_state_constraints():
    kw = dict(_KW, population=40, generations=4, use_phi=False)
    est = MGGPRegressor(constraints="steady-state", **kw).fit(*affine_record())
    assert est.choices_["constant"]["value"] is False
    assert "breaks the continuum of steady states" in est.choices_["constant"]["why"]
    assert all("1" not in row["terms"] for row in est.pareto_front_)


def test_explicit_values_disable_the_choices():
    d = system_by_name("S1", n=500, seed=0)
    est = MGGPRegressor(use_phi=False, select="fitness", screen="freerun", size="search",
                        constant=False, outliers="keep", max_power=3, refine="none",
                        extend="none", **_KW).fit(d.u, d.y)
    assert est.choices_ == {} and "choices" not in est.model_.meta


def test_constraints_resolve_select_to_hold():
    d = system_by_name("S1", n=500, seed=0)
    est = MGGPRegressor(use_phi=False, constraints="steady-state", **_KW).fit(d.u, d.y)
    assert est.choices_["select"]["value"] == "hold"
    assert est.choices_["select"]["figures"]["candidates"] >= 1


@pytest.mark.parametrize("argv", [["--phi", "--no-phi"]])
def test_cli_phi_and_no_phi_exclude_each_other(tmp_path, capsys, argv):
    from mggp.cli.app import main
    d = system_by_name("S1", n=200, seed=0)
    path = tmp_path / "d.csv"
    np.savetxt(path, np.column_stack([d.u, d.y]), delimiter=",", header="u,y", comments="")
    assert main(["fit", str(path)] + argv) == 2
    assert "--phi and --no-phi" in capsys.readouterr().err


def test_cli_constant_and_no_constant(tmp_path, capsys):
    import json
    from mggp.cli.app import main
    u, y = affine_record(300)
    path = tmp_path / "d.csv"
    np.savetxt(path, np.column_stack([u, y]), delimiter=",", header="u,y", comments="")
    assert main(["fit", str(path), "--constant", "--no-constant"]) == 2
    assert "--constant and --no-constant" in capsys.readouterr().err
    out = tmp_path / "m.json"
    assert main(["fit", str(path), "--no-constant", "--no-phi", "--population", "16",
                 "--generations", "2", "--max-height", "2", "--seed", "1", "--quiet",
                 "--out", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["meta"]["constant"] is False and "1" not in doc["terms"]
    assert "constant term" not in capsys.readouterr().err     # no automatic choice


def test_cli_prints_each_automatic_choice(tmp_path, capsys):
    from mggp.cli.app import main
    d = system_by_name("S1", n=300, seed=0)
    path = tmp_path / "d.csv"
    np.savetxt(path, np.column_stack([d.u, d.y]), delimiter=",", header="u,y", comments="")
    assert main(["fit", str(path), "--population", "16", "--generations", "2",
                 "--max-height", "2", "--seed", "1", "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "auto: " in err and "held-out free-run RMSE" in err and "auto: select" in err
    assert "auto: no constant term" in err or "auto: constant term" in err


def test_screen_follows_the_constraints():
    d = system_by_name("S1", n=500, seed=0)
    plain = MGGPRegressor(use_phi=False, **_KW).fit(d.u, d.y)
    held = MGGPRegressor(use_phi=False, constraints="steady-state", **_KW).fit(d.u, d.y)
    assert plain.choices_["screen"]["value"] == "freerun"
    assert held.choices_["screen"]["value"] == "hold" and held.model_.meta["screen"] == "hold"


def test_size_takes_the_fewest_terms_within_the_tolerance():
    from mggp.fit.choices import SIZE_TOLERANCE, size_choice
    big, small, tiny = ("a", "b", "c"), ("a", "b"), ("a",)
    within = 1.0 * (1 + SIZE_TOLERANCE / 2)
    c = size_choice([(3, 1.0, big), (2, within, small), (1, 2.0, tiny)])
    assert c.value == small and c.figures["terms"] == 2
    # control: the smaller one is clearly worse, the chosen structure stays
    assert size_choice([(3, 1.0, big), (2, 1.5, small)]).value == big


def test_heldout_ends_pool_the_errors_of_each_end(monkeypatch):
    """Both ends held out (the trial of ``HOLDOUT_ENDS``): the figure pools
    the head's and the tail's errors, each end with θ fitted on the rest,
    and the size choice counts the samples of both."""
    import mggp.fit.choices as ch
    d = system_by_name("S1", n=500, seed=0)
    data = Data(d.u, d.y)
    ts = ["y[k-1]", "u[k-1]"]                   # misses terms: errors well above noise
    tail = heldout_rmse(ts, data)
    monkeypatch.setattr(ch, "HOLDOUT_ENDS", ("head",))
    head = heldout_rmse(ts, data)
    assert ch.heldout_samples(500) == 150
    monkeypatch.setattr(ch, "HOLDOUT_ENDS", ("head", "tail"))
    both = heldout_rmse(ts, data)
    assert ch.heldout_samples(500) == 300
    # the head end scores its 150 samples but the initial condition y[0]
    pooled = np.sqrt((149 * head ** 2 + 150 * tail ** 2) / 299)
    assert head != tail and both == pytest.approx(pooled, rel=1e-12)


def test_size_tolerance_widens_on_a_short_held_out_part():
    from mggp.fit.choices import SIZE_TOLERANCE, heldout_samples, size_choice, size_tolerance
    big, small = ("a", "b", "c", "d"), ("a", "b")
    rows = [(4, 1.0, big), (2, 1.10, small)]
    # 150 held-out samples (a 500-sample record): a 10 % difference is
    # within the RMSE's sampling spread, the fewer terms are taken
    assert heldout_samples(500) == 150 and size_tolerance(150) > 0.10
    assert size_choice(rows, heldout_samples(500)).value == small
    # control: on a long record the same difference decides
    assert size_tolerance(heldout_samples(50_000)) == SIZE_TOLERANCE
    assert size_choice(rows, heldout_samples(50_000)).value == big


def test_search_classes_follow_the_overrides():
    from mggp.fit.choices import search_classes
    labels = lambda **kw: [(c.label, c.operators) for c in search_classes(MGGPRegressor(**kw))]
    assert labels() == [("no Φ", ()), ("Φ", ()), ("Φ of outputs", ()),
                        ("operators", ("play", "dengtan")), ("Bouc–Wen", ("boucwen",))]
    assert labels(operators="none") == [("no Φ", ()), ("Φ", ()), ("Φ of outputs", ())]
    assert labels(operators="play") == [("no Φ", ("play",)), ("Φ", ("play",)),
                                        ("Φ of outputs", ("play",))]
    assert labels(phi_outputs=True) == [("Φ", ())]                # one search, as asked
    assert labels(use_phi=False) == [("no Φ", ())]                 # operators 'auto': none
    assert labels(use_phi=True, operators="dengtan") == [("Φ", ("dengtan",))]
    # a checkpointed fit makes the same choices (its pilots are checkpointed too)
    assert labels(checkpoint="ck.json") == labels()


@pytest.mark.parametrize("seed", [0, 1])
def test_bouc_wen_class_chosen_for_a_piezo_record_not_for_a_linear_one(seed):
    """The automatic model class: a piezo Bouc–Wen record takes the
    Bouc–Wen class (its held-out error far below every other class's);
    control: a first-order linear record stays without Φ or operators."""
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(2000, seed=5)
    kw = dict(population=60, generations=10, random_state=seed)
    est = MGGPRegressor(**kw).fit(Data(u, piezo_bouc_wen(u)))
    fig = est.choices_["use_phi"]["figures"]
    assert fig["class"] == "Bouc–Wen" and fig["operators"] == ["boucwen"]
    others = [fig[k] for k in ("heldout_rmse_no_phi", "heldout_rmse_phi",
                               "heldout_rmse_phi_outputs", "heldout_rmse_operators")]
    assert fig["heldout_rmse_bouc_wen"] < 0.2 * min(others)
    assert any("BoucWen(" in t for t in est.model_.term_texts)
    assert est.model_.meta["use_phi"] is False and est.model_.meta["operators"] == ["boucwen"]
    assert est.model_.meta["operator_entry"] == "search"       # how the class used them
    ctl = MGGPRegressor(**kw).fit(*first_order_record(1000, seed, noise=0.01))
    assert ctl.choices_["use_phi"]["figures"]["class"] == "no Φ"
    assert not any("(" in t for t in ctl.model_.term_texts)


def test_bouc_wen_class_needs_half_the_error_of_the_class_before():
    """The Bouc–Wen class's own margin (BOUC_WEN_CLASS_GAIN): 40 % lower is
    not enough, 60 % lower is; control: the plays' class with the same
    40 % takes over under the common 15 % margin."""
    from mggp.fit.choices import BOUC_WEN_CLASS_GAIN, search_classes
    classes = search_classes(MGGPRegressor())
    assert [c.label for c in classes] == ["no Φ", "Φ", "Φ of outputs", "operators", "Bouc–Wen"]
    assert classes[-1].gain == BOUC_WEN_CLASS_GAIN == 0.5 and classes[3].gain == CLASS_GAIN
    pick = lambda errors: class_choice(classes, errors).figures["class"]
    assert pick([1.0, 1.0, 1.0, 1.0, 0.6]) == "no Φ"
    assert pick([1.0, 1.0, 1.0, 1.0, 0.4]) == "Bouc–Wen"
    assert pick([1.0, 1.0, 1.0, 0.6, 1.0]) == "operators"
    # Φ of the output's lags: its own margin, 30 % (PHI_OUTPUTS_CLASS_GAIN)
    assert pick([1.0, 1.0, 0.75, 1.0, 1.0]) == "no Φ"
    assert pick([1.0, 1.0, 0.65, 1.0, 1.0]) == "Φ of outputs"
    assert pick([1.0, 0.8, 0.6, 1.0, 1.0]) == "Φ"         # 25 % below the Φ class kept


def _coulomb_record(n=1500, seed=0, noise=0.002):
    """A damped mass with Coulomb friction on its own velocity:
    y = 1.5 y[k-1] - 0.6 y[k-2] + 0.1 u[k-1] - 0.03 sign(y[k-1] - y[k-2]),
    driven by smoothed random steps, white output noise of ``noise`` × std(y)."""
    rng = np.random.default_rng(seed)
    u = np.convolve(np.repeat(rng.uniform(-1, 1, n // 25 + 1), 25)[:n], np.ones(5) / 5,
                    mode="same")
    y = np.zeros(n)
    for k in range(2, n):
        y[k] = 1.5 * y[k - 1] - 0.6 * y[k - 2] + 0.1 * u[k - 1] - 0.03 * np.sign(
            y[k - 1] - y[k - 2])
    return u, y + noise * np.std(y) * rng.standard_normal(n)


def test_phi_of_output_lags_class_taken_for_friction_on_the_output():
    """Coulomb friction on the output's own velocity is a Φ of the output's
    lags (Phi2(y[k-1],y[k-2])), which no input class expresses: the
    automatic choice takes the class with Φ of the output's lags, over 30 %
    below the others held out, and the model keeps that term (a fixed
    seed). The control, a linear record staying without Φ, is in
    test_bouc_wen_class_chosen_for_a_piezo_record_not_for_a_linear_one."""
    u, y = _coulomb_record(seed=0)
    est = MGGPRegressor(population=100, generations=15, random_state=0).fit(Data(u, y))
    fig = est.choices_["use_phi"]["figures"]
    assert fig["class"] == "Φ of outputs"
    others = [v for k, v in fig.items() if k.startswith("heldout_rmse_")
              and k != "heldout_rmse_phi_outputs"]
    assert fig["heldout_rmse_phi_outputs"] < 0.7 * min(others)
    assert "Phi2(y[k-1],y[k-2])" in est.model_.term_texts


def _piroddi_noise_free(n=500, seed=0, noise=0.0):
    """y = 0.75 y[k-2] + 0.25 u[k-1] - 0.2 y[k-2] u[k-1] (Piroddi and Spinelli's
    S1 without its noise), white output noise of ``noise`` × std(y)."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1.0, 1.0, n)
    y = np.zeros(n)
    for k in range(2, n):
        y[k] = 0.75 * y[k - 2] + 0.25 * u[k - 1] - 0.2 * y[k - 2] * u[k - 1]
    return Data(u, y + noise * np.std(y) * rng.standard_normal(n))


PIRODDI = {"y[k-2]", "u[k-1]", "y[k-2]*u[k-1]"}


def test_heldout_errors_below_rounding_count_as_equal():
    """error_floor: on a noise-free record the exact structure and its
    supersets (a constant, a spurious lag) score the same floor, so no
    comparison ranks their rounding digits; control: with 1 % output noise
    heldout_rmse is the RMSE itself, decades above the floor."""
    from mggp.fit.choices import RESOLUTION, error_floor
    data = _piroddi_noise_free()
    floor = error_floor(data)
    assert floor == RESOLUTION * np.ptp(data.y)
    exact = sorted(PIRODDI)
    for ts in (exact, exact + ["1"], exact + ["y[k-3]"]):
        assert heldout_rmse(ts, data) == floor
    assert heldout_rmse(["y[k-2]", "u[k-1]"], data) > 1e3 * floor
    noisy = _piroddi_noise_free(noise=0.01)
    e = heldout_rmse(exact, noisy)
    assert e > 1e4 * error_floor(noisy)


@pytest.mark.parametrize("seed", [0, 1])
def test_defaults_return_the_exact_structure_of_a_noise_free_record(seed):
    """With every choice automatic, a noise-free Piroddi record gives its
    three terms: no constant with θ of 1e-17, no operator class won by
    rounding (both happened when the held-out errors of 1e-16 were
    ranked); control: with 1 % output noise the choices' figures are the
    measured errors, above the floor."""
    from mggp.fit.choices import error_floor
    kw = dict(population=100, generations=15, random_state=seed)
    est = MGGPRegressor(**kw).fit(_piroddi_noise_free())
    assert set(est.model_.term_texts) == PIRODDI
    figs = est.choices_["use_phi"]["figures"]
    if figs["class"] != "no Φ":           # a richer class, only by a margin above rounding
        from mggp.fit.choices import _key
        won = figs[f"heldout_rmse_{_key(figs['class'])}"]
        assert figs["heldout_rmse_no_phi"] - won > 100 * error_floor(_piroddi_noise_free())
    assert est.choices_["constant"]["value"] is False
    noisy = _piroddi_noise_free(noise=0.01)
    ctl = MGGPRegressor(**kw).fit(noisy)
    figs = ctl.choices_["use_phi"]["figures"]
    errs = [v for k, v in figs.items() if k.startswith("heldout_rmse_")]
    assert min(errs) > 100 * error_floor(noisy)


def test_phi_of_outputs_is_one_class_and_still_pilots_the_constant():
    """phi_outputs: one search with Φ, said in the use_phi choice line,
    even when a pilot without the constant runs beside it; control: with
    constant=False no pilot runs and the line is the same."""
    d = first_order_record(500, 0, noise=0.01)
    kw = dict(_KW, population=30, generations=5, phi_outputs=True, max_power=3)
    cb = _Phases()
    est = MGGPRegressor(**dict(kw, callbacks=[cb])).fit(*d)
    assert est.choices_["use_phi"]["why"].startswith("Φ: with Φ of outputs the fit is one "
                                                     "search with Φ")
    assert [p for p, _ in cb.phases] == ["pilot 1/2 Φ", "pilot 2/2 Φ, no constant", "search Φ"]
    assert "pilots of 1 of 5 generations" in est.choices_["constant"]["why"]
    one = _Phases()
    ctl = MGGPRegressor(**dict(kw, constant=False, callbacks=[one])).fit(*d)
    assert ctl.choices_["use_phi"]["why"] == est.choices_["use_phi"]["why"]
    assert [p for p, _ in one.phases] == ["search Φ"]


def test_a_held_out_part_without_excitation_is_said():
    """A step record whose last 30 % is the held input: every candidate
    settles alike there, so the automatic choices rest on little, and the
    fit says so; control: the same system on an input that moves to the
    end, and the same step record with every held-out choice fixed."""
    import warnings
    from mggp.fit.choices import holdout_message
    n = 600
    u = np.where(np.arange(n) < 200, 0.0, 1.0)
    u[:200] = np.random.default_rng(0).standard_normal(200)
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.8 * y[k - 1] + 0.5 * u[k - 1]
    step = Data(u, y)
    assert "held-out part" in holdout_message(step) and "u 0" in holdout_message(step)
    moving = np.random.default_rng(1).standard_normal(n)
    assert holdout_message(Data(moving, y)) == ""
    kw = dict(population=20, generations=2, random_state=0, n_jobs=1)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        MGGPRegressor(**kw).fit(step)
    assert any("barely moves the input" in str(x.message) for x in w)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        MGGPRegressor(use_phi=False, constant=False, size="search", **kw).fit(step)
    assert not any("barely moves the input" in str(x.message) for x in w)


def test_a_long_record_is_searched_on_the_part_that_covers_its_range():
    """With search_samples=1000 a 3,000-sample record whose first third holds
    its input is searched on a part from the moving two thirds, said in
    choices_ and the meta; the model's θ comes from that part, so it
    differs from the whole-record search's. Controls: 'all' (the default)
    and a part no shorter than the record search it whole."""
    from mggp.fit.choices import search_span
    from narx.records.data import Data
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(3000, seed=1)
    u[:1000] = u[1000]
    y = piezo_bouc_wen(u)
    a, b = search_span(Data(u, y), 1000)
    assert b - a == 1000 and a >= 1000
    kw = dict(population=20, generations=2, random_state=1, use_phi=False, constant=False,
              size="search", local_search=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        part = MGGPRegressor(search_samples=1000, **kw).fit(u, y)
        whole = MGGPRegressor(search_samples="all", **kw).fit(u, y)
        default = MGGPRegressor(search_samples=3000, **kw).fit(u, y)
    assert part.search_samples_ == (a, b)
    c = part.choices_["search_samples"]
    assert c["value"] == [a, b] and f"search on samples {a:,}–{b - 1:,} of 3,000" in c["why"]
    assert part.model_.meta["search_samples"] == [a, b]          # the part, not "1000"
    assert whole.search_samples_ == default.search_samples_ == (0, 3000)
    assert "search_samples" not in whole.choices_ and "search_samples" not in default.choices_
    same = part.model_.term_texts == whole.model_.term_texts
    assert not same or not np.allclose(part.model_.theta, whole.model_.theta)


def test_search_samples_takes_all_or_at_least_1000(capsys, tmp_path):
    for bad in (999, "some", 0, "auto"):
        with pytest.raises(ValueError, match="search_samples must be an integer >= 1000, "
                                             "or 'all'"):
            MGGPRegressor(search_samples=bad).fit(np.zeros(100), np.zeros(100))
    from mggp.cli.app import main
    path = tmp_path / "d.csv"
    np.savetxt(path, np.c_[np.arange(300.0) % 7, np.arange(300.0) % 5], delimiter=",",
               header="u,y", comments="")
    for bad, said in (("10", "error: --search-samples must be >= 1000, or all, got 10"),
                      ("lots", "invalid all or integer value: 'lots'")):
        try:
            rc = main(["fit", str(path), "--search-samples", bad])
        except SystemExit as e:                 # argparse's own type error
            rc = e.code
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 2 and len(err) == 1 and said in err[0]


def level_record(seed=0, level=20.0):
    """y = 0.4·level + 0.6 y[k-1] + 0.5 u[k-1] (+ white noise on y), u ~ U(-1, 1):
    the output stays within about ±1.5 of ``level``."""
    from benchmarks.offset import level_record as record
    return record(n=500, seed=seed, level=level, hold=1, square=0.0, lag2=0.0)


@pytest.mark.filterwarnings("ignore:an offset dominates")
@pytest.mark.parametrize("seed", [5, 7])
def test_an_output_at_a_level_keeps_the_constant_not_powers_of_y(seed):
    """At y ≈ 20 ± 1.5 a power of y[k-1] holds the level as well as the
    constant inside the record (y[k-1]² ≈ 40 y[k-1] − 400), so the held-out
    errors tie; the simpler structure, the constant's, is searched and the
    exact one found (these seeds took y[k-1]² without the constant before).
    Control: the same system at level 0 has no constant."""
    kw = dict(_KW, population=40, generations=6, use_phi=False, random_state=seed)
    est = MGGPRegressor(**kw).fit(level_record(seed=seed))
    c = est.choices_["constant"]
    assert c["value"] is True and sorted(est.model_.term_texts) == ["1", "u[k-1]", "y[k-1]"]
    assert c["why"].startswith("searched with the constant term")
    ctl = MGGPRegressor(**kw).fit(level_record(seed=seed, level=0.0))
    assert ctl.choices_["constant"]["value"] is False
    assert sorted(ctl.model_.term_texts) == ["u[k-1]", "y[k-1]"]


def test_constant_parsimony_rule_by_hand():
    """fewest_terms and constant_pilot_choice on rows built by hand
    (n_terms, held-out error, terms): the constant is kept on a tie when its
    structure is simpler and needs the constant; controls: the plain one is
    as simple, and the constant's structure does as well without it."""
    import narx
    from mggp.fit.choices import constant_pilot_choice, fewest_terms
    data = level_record()

    def row(texts, err):
        return (len(texts), err, tuple(narx.parse_terms(texts)))
    with_c = [row(["1", "y[k-1]", "u[k-1]"], 0.0100)]
    plain = [row(["y[k-1]*y[k-1]", "y[k-1]", "u[k-1]"], 0.0101),
             row(["y[k-1]", "u[k-1]", "y[k-2]", "y[k-1]*y[k-1]"], 0.0100)]
    f = fewest_terms(with_c, plain, data)
    assert f["simpler"] and (f["degree_constant"], f["degree_no_constant"]) == (2, 4)
    assert f["own"].significant                 # y[k-1], u[k-1] alone: far off
    assert f["heldout_rmse_own_no_constant"] > f["limit"]
    tie = _gain(0.0100, 0.0100, False, p=0.5)
    c = constant_pilot_choice(tie, tie, "p", f)
    assert c.value is True and "3 terms of total degree 2 with it" in c.why
    assert c.figures["pilot_fewest_gain_p_value"] == f["own"].p_value
    # control: a plain structure as accurate and simpler (2 terms)
    even = fewest_terms(with_c, plain + [row(["y[k-1]", "u[k-1]"], 0.0102)], data)
    assert not even["simpler"] and even["terms_no_constant"] == 2 and even["own"] is None
    assert constant_pilot_choice(tie, tie, "p", even).value is False
    # control: the constant's structure does as well without its constant
    f2 = dict(f, own=_gain(0.0101, 0.0100, False, p=0.3))
    assert constant_pilot_choice(tie, tie, "p", f2).value is False
    # control: the pilot without the constant has nothing within the tolerance:
    # not a tie, the gain over it must be significant
    alone = fewest_terms(with_c, [row(["y[k-1]", "u[k-1]"], 0.0300)], data)
    assert alone["simpler"] and np.isinf(alone["terms_no_constant"])
    assert constant_pilot_choice(tie, tie, "p", alone).value is False
    # control: the rows' errors differ by more than the tolerance: plain is better
    worse = fewest_terms([row(["1", "y[k-1]", "u[k-1]"], 0.0200)], plain, data)
    assert worse is None
