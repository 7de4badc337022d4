"""Safe extrapolation: training ranges recorded and warned of, stress inputs, power cap.

A model fitted inside a range of its inputs may explode outside it: a
measured MR damper's default model held v[k-1]^9 and v[k-1]^7 and ran to an
RMSE 90 times the force's standard deviation on a test record whose
velocity left the training range on 0.3 % of its samples. Every model
file records the training ranges and the simulations name the inputs that
leave them (narx.records.ranges); the search refuses structures whose free run is
unbounded on stress inputs, and caps the power of one signal at 3 unless a
pilot asks for more (mggp.fit.extrapolation).
"""
import json
import warnings

import numpy as np
import pytest

import narx
from narx import Model, ModelFileError, load_model
from narx.records.data import Data
from narx.records.ranges import (ExtrapolationWarning, excursions, range_line, range_warning,
                         recorded_ranges, signal_ranges)
from narx.language.terms import parse_term
from mggp.cli.app import main
from mggp.fit.extrapolation import (POWER_CAP, STRESS_BAND, STRESS_SCALE, StressCheck,
                                bounded_first, signal_power, stress_records)
from mggp.fit.choices import power_choice


def _saturating(n, seed, scale=1.0):
    """A static saturation with short dynamics, y = tanh(3 u[k-1]) +
    0.2 tanh(3 u[k-2]), driven by white noise uniform in ±``scale``."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1.0, 1.0, n) * scale
    y = np.zeros(n)
    y[1:] = np.tanh(3 * u[:-1])
    y[2:] += 0.2 * np.tanh(3 * u[:-2])
    return u, y


def _csv(path, u, y):
    np.savetxt(path, np.c_[u, y], delimiter=",", header="u,y", comments="")
    return path


# ----------------------------------------------------------------- ranges
def test_fit_records_ranges_and_the_file_keeps_them(tmp_path):
    u, y = _saturating(300, 0)
    m = Model(["y[k-1]", "u[k-1]"]).fit(u, y)
    assert m.meta["ranges"] == {"u": [float(u.min()), float(u.max())],
                                "y": [float(y.min()), float(y.max())]}
    m.save(tmp_path / "m.json")
    back = load_model(tmp_path / "m.json")
    assert recorded_ranges(back) == {k: tuple(v) for k, v in m.meta["ranges"].items()}


def test_range_line_counts_and_measures_in_half_widths():
    ranges = {"u": (-1.0, 1.0), "w": (0.0, 2.0)}
    inside = Data(np.c_[np.linspace(-1, 1, 50), np.linspace(0, 2, 50)], np.zeros(50),
                  inputs=("u", "w"))
    assert excursions(ranges, inside) == [] and range_line(ranges, inside) == ""
    u = np.linspace(-1, 1, 50)
    u[[3, 7]] = [1.6, -1.2]
    d = Data(np.c_[u, np.linspace(0, 2, 50)], np.zeros(50), inputs=("u", "w"))
    (e,) = excursions(ranges, d)
    assert (e.signal, e.count, e.n) == ("u", 2, 50) and e.reach == pytest.approx(1.6)
    line = range_line(ranges, d)
    assert line.startswith("input u leaves the training range [-1, 1] on 2 of 50 samples "
                           "(up to 1.6× its half-width") and "\n" not in line
    w = np.linspace(0, 2, 50)
    w[0] = 3.0                                  # 2 half-widths from the middle 1
    two = Data(np.c_[u, w], np.zeros(50), inputs=("u", "w"))
    line = range_line(ranges, two)
    assert line.startswith("inputs leave their training ranges: u [-1, 1] on 2 of 50")
    assert "w [0, 2] on 1 of 50 samples (up to 2× its half-width" in line


def test_a_hair_beyond_the_ends_is_not_named():
    """A new realisation of the training input passes its extremes by a
    hair (within MARGIN half-widths): no line; control: 5 % beyond is named."""
    from narx.records.ranges import MARGIN
    ranges = {"u": (-1.0, 1.0)}
    u = np.linspace(-1, 1, 50)
    u[5] = 1.0 + MARGIN / 2
    assert range_line(ranges, Data(u, np.zeros(50))) == ""
    u[5] = 1.05
    assert range_line(ranges, Data(u, np.zeros(50))).startswith("input u leaves")


@pytest.mark.parametrize("ranges, rule", [
    ([0, 1], "must be an object"),
    ({"q": [0, 1]}, "is no signal of the model"),
    ({"u": [1, 0]}, "low <= high"),
    ({"u": [0, "inf"]}, "two finite numbers"),
    ({"u": [0, 1, 2]}, "[low, high]"),
])
def test_malformed_ranges_are_refused(tmp_path, ranges, rule):
    d = {"output": "y", "inputs": ["u"], "terms": ["y[k-1]", "u[k-1]"], "theta": [0.5, 1.0],
         "meta": {"ranges": ranges}}
    p = tmp_path / "m.json"
    p.write_text(json.dumps(d))
    with pytest.raises(ModelFileError, match="'meta'.'ranges'") as exc:
        load_model(p)
    assert rule in str(exc.value)


def _simulate_cli(capsys, model, data):
    code = main(["simulate", str(model), str(data)])
    out = capsys.readouterr()
    assert code == 0, out.err
    return [ln for ln in out.err.splitlines() if ln.startswith("warning:")]


def test_simulate_names_inputs_beyond_the_training_range(tmp_path, capsys):
    """A record whose input reaches 1.6 times the training range's
    half-width gets one warning line; the training record (control) none."""
    u, y = _saturating(600, 0)
    m = Model(["y[k-1]", "u[k-1]"]).fit(u, y)
    m.save(tmp_path / "m.json")
    train = _csv(tmp_path / "train.csv", u, y)
    assert _simulate_cli(capsys, tmp_path / "m.json", train) == []
    big = 1.6 * u / max(abs(u.min()), u.max())
    test = _csv(tmp_path / "test.csv", big, y)
    (line,) = _simulate_cli(capsys, tmp_path / "m.json", test)
    beyond = int(np.sum((big < u.min()) | (big > u.max())))
    assert f"input u leaves the training range [{u.min():.3g}, {u.max():.3g}] on {beyond} " \
           f"of 600 samples (up to 1.6" in line


def test_old_model_file_without_ranges_loads_and_simulates_silently(tmp_path, capsys):
    d = {"format": "mggp-narx-model", "version": 1, "output": "y", "inputs": ["u"],
         "terms": ["y[k-1]", "u[k-1]"], "theta": [0.5, 1.0],
         "meta": {"fitness": "pem", "estimation": "ls"}}
    (tmp_path / "old.json").write_text(json.dumps(d))
    m = load_model(tmp_path / "old.json")
    assert recorded_ranges(m) == {}
    u, y = _saturating(200, 1, scale=5.0)
    assert range_warning(m, Data(u, y)) == ""
    assert _simulate_cli(capsys, tmp_path / "old.json",
                         _csv(tmp_path / "d.csv", u, y)) == []


# ----------------------------------------------------------------- the rules
def test_signal_power_counts_factors_of_one_signal_at_any_lag():
    p = {t: signal_power(parse_term(t)) for t in
         ("u[k-1]", "u[k-1]*u[k-1]*u[k-2]", "y[k-1]*y[k-1]*u[k-1]", "1",
          "Phi1(u[k-1],u[k-2])*u[k-1]")}
    assert p == {"u[k-1]": 1, "u[k-1]*u[k-1]*u[k-2]": 3, "y[k-1]*y[k-1]*u[k-1]": 2,
                 "1": 0, "Phi1(u[k-1],u[k-2])*u[k-1]": 1}


def test_stress_records_scale_reverse_and_hold():
    u, y = _saturating(400, 0)
    recs = dict(stress_records(Data(u, y)))
    scaled, rev, held = recs.values()
    assert np.allclose(scaled.U[0] - u.mean(), STRESS_SCALE * (u - u.mean()))
    assert np.array_equal(rev.U[0], u[::-1]) and np.array_equal(rev.y, y[::-1])
    tail = held.U[0, 400:]
    assert held.n == 400 + 3 * 100
    assert set(tail[:100]) == {u[-1]} and set(tail[100:200]) == {u.max()} \
        and set(tail[200:]) == {u.min()}


def _odd(*powers):
    """The structure u[k-1]^p for each p."""
    return tuple(parse_term("*".join(["u[k-1]"] * p)) for p in powers)


def _noisy_saturation():
    """The saturation of 1,000 samples with white output noise of 0.1 (4 %
    of its range), and the test record: the input scaled to 1.6 times the
    training range's half-width."""
    u, y = _saturating(1000, 0)
    y = y + 0.1 * np.random.default_rng(5).standard_normal(y.size)
    uv, yv = _saturating(1000, 1, scale=1.6)
    return Data(u, y), Data(uv, yv)


def _reach(terms, train, test):
    """How far the LS fit's free run on ``test`` goes from the training
    output's mean, in training output ranges (inf: diverges)."""
    r = Model(terms).fit(train).simulate(test)
    if r.diverged:
        return float("inf")
    return float(np.max(np.abs(r.y_hat[r.valid] - train.y.mean())) / np.ptp(train.y))


def test_stress_check_refuses_high_powers_and_passes_a_cubic():
    """Odd polynomials of u[k-1] fitted to the saturation: degree 7 and 9
    leave the output's mean ± 3 ranges on the input scaled by 1.5 and are
    refused; the cubic and the linear model stay inside (controls)."""
    train, _ = _noisy_saturation()
    check = StressCheck(train)
    assert "leaves the output's mean ± 3 ranges when the input is scaled 1.5×" in \
        check(_odd(1, 3, 5, 7))
    assert check(_odd(1, 9)) != ""
    assert check(_odd(1)) == "" and check(_odd(1, 3)) == ""
    assert check.checked == 4


def test_old_rule_takes_a_fifth_power_that_explodes_and_the_cap_does_not():
    """The size choice over a Pareto front holding u^1..u^7 and u^1..u^5
    (least held-out error) takes, by the old rule (no power cap), the
    fifth-power structure, whose free run on the 1.6× record goes beyond 3
    output ranges. Under the cap of 3 the search scores both as u, u^3,
    whose free run there stays within 1 range; the pilot with the cap
    lifted gains less than the size tolerance, so the cap stays."""
    from mggp import MGGPRegressor
    from mggp.fit.choices import heldout_rmse, heldout_samples, size_choice, size_tolerance
    train, test = _noisy_saturation()
    rows = [(len(s), heldout_rmse(s, train), s) for s in (_odd(1, 3, 5, 7), _odd(1, 3, 5))]
    n_held = heldout_samples(train.n)
    old = size_choice(rows, n_held).value
    assert max(signal_power(t) for t in old) >= 5
    assert _reach(old, train, test) > STRESS_BAND
    est = MGGPRegressor()
    est.max_power_ = POWER_CAP
    capped = {est._structure(s, constant=False) for _, _, s in rows}
    assert capped == {_odd(1, 3)}
    assert _reach(_odd(1, 3), train, test) < 1.0
    err_capped = heldout_rmse(_odd(1, 3), train)
    err_free = min(r[1] for r in rows)
    assert err_free < err_capped                      # the powers do fit better inside
    assert power_choice(err_capped, err_free, size_tolerance(n_held)).value == POWER_CAP


def test_default_fit_stays_bounded_beyond_the_training_range():
    """The default search (small budget) on the noisy saturation: no term
    holds a power above 3, its free run on the 1.6× record stays within 3
    output ranges of the training output's mean, and simulating it there
    warns of the input beyond the training range (on the training record:
    no warning, the control)."""
    from mggp import MGGPRegressor
    train, test = _noisy_saturation()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        est = MGGPRegressor(population=40, generations=8, random_state=0).fit(train)
    assert est.choices_["max_power"]["value"] == POWER_CAP
    assert max(signal_power(t) for t in est.model_.terms) <= POWER_CAP
    assert "max power 3 of one signal" in est.choices_["max_power"]["why"]
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        r = est.simulate(test)
    outside = [w for w in said if issubclass(w.category, ExtrapolationWarning)]
    assert len(outside) == 1 and "input u leaves the training range" in str(outside[0].message)
    assert not r.diverged
    assert np.max(np.abs(r.y_hat[r.valid] - train.y.mean())) < STRESS_BAND * np.ptp(train.y)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        est.predict(train)
    assert not [w for w in said if issubclass(w.category, ExtrapolationWarning)]


def test_bounded_first_refuses_only_when_a_bounded_row_is_within_tolerance():
    rows = [(5, 1.0, "A"), (3, 1.04, "B"), (2, 1.5, "C")]
    bad = {"A": "diverges", "B": "", "C": ""}
    i, refused, all_fail = bounded_first(rows, [1, 0], 0.05, bad.get)
    assert (i, refused, all_fail) == (1, [], [])              # B first: passes
    i, refused, all_fail = bounded_first(rows, [0, 1], 0.05, bad.get)
    assert (i, refused) == (1, [(0, "diverges")])
    bad["B"] = "leaves"                                        # none within 5 % passes
    i, refused, all_fail = bounded_first(rows, [0, 1, 2], 0.05, bad.get)
    assert (i, refused, [w for _, w in all_fail]) == (0, [], ["diverges", "leaves"])
    assert bounded_first(rows, [0, 1], 0.05, None) == (0, [], [])


def test_bounded_first_beyond_the_tolerance_takes_a_bounded_row_within_its_margin():
    """When every row within the tolerance fails, ``beyond`` takes the
    least-error row that passes within that margin of the least (here C at
    1.5, not D at 1.3 which fails); a margin too narrow for any passing row
    (control) keeps the old all-fail answer."""
    rows = [(5, 1.0, "A"), (3, 1.04, "B"), (2, 1.5, "C"), (4, 1.3, "D"), (1, 3.0, "E")]
    bad = {"A": "diverges", "B": "leaves", "C": "", "D": "diverges", "E": ""}
    i, refused, all_fail = bounded_first(rows, [1, 0], 0.05, bad.get, beyond=0.6)
    assert i == 2 and all_fail == []
    assert [j for j, _ in refused] == [1, 0, 3]                  # every row checked before it
    i, refused, all_fail = bounded_first(rows, [1, 0], 0.05, bad.get, beyond=0.4)
    assert (i, refused, [j for j, _ in all_fail]) == (1, [], [1, 0])


def test_power_cap_lifted_only_beyond_the_tolerance():
    assert power_choice(1.0, 0.95, 0.09).value == POWER_CAP
    assert power_choice(1.0, 0.8, 0.09).value is None
    assert power_choice(float("inf"), 2.0, 0.09).value is None
    assert power_choice(1.0, 0.5, 0.09, unbounded="diverges").value == POWER_CAP


def test_size_choice_line_names_the_refused_structures():
    """The size choice skips the 2-term structure that fails the stress
    inputs for the 3-term one within the tolerance and says why; when every
    one within the tolerance fails it keeps the old choice and says so."""
    from mggp.fit.choices import size_choice
    rows = [(4, 1.0, "A"), (2, 1.01, "B"), (3, 1.02, "C")]
    c = size_choice(rows, 1600, {"A": "", "B": "diverges when the input is reversed in time",
                                 "C": ""}.get)
    assert c.value == "C" and "refused on the stress inputs" in c.why
    assert "2 terms (RMSE 1.01): diverges when the input is reversed in time" in c.why
    c = size_choice(rows, 1600, {"A": "x", "B": "y", "C": "z"}.get)
    assert c.value == "B" and "so none is refused" in c.why
    wider = rows + [(5, 1.2, "D"), (1, 1.4, "E")]     # D within STRESS_BEYOND, E beyond it
    c = size_choice(wider, 1600, {"A": "x", "B": "y", "C": "z", "D": "", "E": ""}.get)
    assert c.value == "D" and c.figures["beyond_tolerance"]
    assert "beyond the tolerance: every structure within it fails" in c.why
    c = size_choice(rows + [(1, 1.4, "E")], 1600,
                    {"A": "x", "B": "y", "C": "z", "E": ""}.get)
    assert c.value == "B" and "so none is refused" in c.why      # control: E too far
    assert size_choice(rows, 1600).value == "B"                # no check: the old rule


def test_diagnose_names_records_beyond_the_ranges(capsys):
    """mggp diagnose: with a model, each record beyond its ranges gets a line;
    without one, the validation record against the training record's."""
    from argparse import Namespace
    from mggp.cli.diagnose import _say_ranges
    u, y = _saturating(300, 0)
    train = Data(u, y)
    big = Data(1.6 * u, y)
    m = Model(["y[k-1]", "u[k-1]"]).fit(train)
    _say_ranges(Namespace(train="T.csv", validation="V.csv"), m, train, big)
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("warning: V.csv: input u leaves the training")
    _say_ranges(Namespace(train="T.csv", validation="V.csv"), None, train, big)
    assert capsys.readouterr().err.startswith("warning: V.csv: input u leaves")
    _say_ranges(Namespace(train="T.csv", validation=None), None, train, None)
    _say_ranges(Namespace(train="T.csv", validation="V.csv"), m, train, train)
    assert capsys.readouterr().err == ""
