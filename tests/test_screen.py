"""Free-run stability screen (mggp.fit.screen) and MGGPRegressor(screen='freerun')."""
import math

import numpy as np
import pytest

from mggp import MGGPRegressor
from mggp.fit.screen import StabilityScreen
from narx.records.data import as_data
from narx.systems import piezo_bouc_wen, training_input
from narx.language.terms import parse_term


def _piezo():
    u = training_input(6000, seed=4, bandwidth=2.0)
    return u, piezo_bouc_wen(u)


def _band(y, start=0):
    y = y[start:]
    return np.max(np.abs(y)) + np.ptp(y)


class _Stub(StabilityScreen):
    """Screen whose verdicts come from a set of unstable term sets."""

    def __init__(self, top, unstable):
        self.top, self.unstable = top, unstable
        self.checked = self.rejected = 0
        self.seen = []

    def stable(self, terms):
        self.checked += 1
        self.seen.append(terms)
        ok = terms not in self.unstable
        self.rejected += not ok
        return ok


def test_screen_keeps_screening_until_the_leaders_pass():
    sets = [("a",), ("b",), ("c",), ("d",), ("e",)]
    values = [1.0, 2.0, 3.0, math.inf, 4.0]
    sc = _Stub(top=2, unstable={("a",), ("c",)})
    out = sc(sets, values)
    # a fails, b passes, then c (new second) fails, then e passes
    assert out == [math.inf, 2.0, math.inf, math.inf, 4.0]
    assert sc.seen == [("a",), ("b",), ("c",), ("e",)]
    assert sc.rejected == 2


def test_screen_of_a_real_record_rejects_a_diverging_structure():
    from benchmarks.casestudy import MODEL19
    u, y = _piezo()
    sc = StabilityScreen(as_data(u, y), start=16, top=1)
    for texts in (MODEL19["terms"], ["y[k-1]", "u[k-1]"]):
        assert sc.stable(tuple(parse_term(t) for t in texts)), texts
    # LS on this record gives y_k ~ 2.002 y_{k-1} - 1.002 y_{k-2}: a root
    # outside the unit circle, so the free run leaves the band
    bad = tuple(parse_term(t) for t in ("y[k-1]", "y[k-2]", "u[k-1]"))
    theta, _ = sc.scorer.fit(bad)
    assert np.max(np.abs(np.roots([1.0, -theta[0], -theta[1]]))) > 1.0
    assert not sc.stable(bad)
    assert (sc.checked, sc.rejected) == (3, 1)


@pytest.mark.parametrize("kw, text", [
    (dict(top=0), "top must be an integer >= 1, got 0"),
    (dict(top=2, band=-1.0), "band must be a finite number >= 0, got -1.0"),
])
def test_screen_bad_parameters(kw, text):
    u, y = _piezo()
    with pytest.raises(ValueError, match=text):
        StabilityScreen(as_data(u, y), start=16, **kw)


def test_estimator_rejects_unknown_screen():
    u, y = _piezo()
    with pytest.raises(ValueError, match="screen must be one of 'auto', 'freerun', 'hold', 'none', None, got 'x'"):
        MGGPRegressor(screen="x", population=4, generations=0).fit(u, y)


_KW = dict(fitness="ms", window=50, population=60, generations=10, max_terms=8, n_jobs=1,
           use_phi=True, size="search", local_search=False,   # the search result as it is
           constant=False, extend="none")


def test_screened_search_result_stays_in_band_where_the_plain_one_diverges():
    # seed 6: the plain MS search ends on a structure whose free run over the
    # training record diverges (windows of 50 samples never see it)
    u, y = _piezo()
    plain = MGGPRegressor(random_state=6, screen=None, **_KW).fit(u, y)
    r = plain.model_.simulate(u, y, "freerun")
    assert r.diverged or np.max(np.abs(r.y_hat[16:])) > _band(y, 16)
    screened = MGGPRegressor(random_state=6, screen="freerun", **_KW).fit(u, y)
    rs = screened.model_.simulate(u, y, "freerun")
    assert not rs.diverged
    assert np.max(np.abs(rs.y_hat[16:])) <= _band(y, 16)
    assert screened.screen_rejected_ > 0
    assert plain.screen_rejected_ is None


def test_screen_control_nothing_to_reject_leaves_the_search_alone():
    # a stable polynomial system: no leader leaves the band, nothing is
    # rejected, and the screened search is the plain one
    from narx.systems.testsystems import system_by_name
    d = system_by_name("S2", n=500, seed=0)
    kw = dict(fitness="ms", window=20, population=60, generations=10, max_terms=6,
              max_height=3, use_phi=False, n_jobs=1, random_state=1)
    plain = MGGPRegressor(screen=None, **kw).fit(d.u, d.y)
    screened = MGGPRegressor(screen="freerun", **kw).fit(d.u, d.y)
    assert screened.screen_rejected_ == 0
    assert screened.model_.term_texts == plain.model_.term_texts
    assert np.array_equal(screened.model_.theta, plain.model_.theta)


def test_screened_search_same_for_one_and_two_workers():
    u, y = _piezo()
    kw = dict(_KW, generations=4, population=40)
    a = MGGPRegressor(random_state=6, screen="freerun", **kw).fit(u, y)
    b = MGGPRegressor(random_state=6, screen="freerun", **dict(kw, n_jobs=2)).fit(u, y)
    assert a.model_.term_texts == b.model_.term_texts
    assert np.array_equal(a.model_.theta, b.model_.theta)
    assert a.screen_rejected_ == b.screen_rejected_


def test_fit_cli_screen(tmp_path, capsys):
    import json
    from mggp.cli.app import main
    u, y = _piezo()
    csv = tmp_path / "d.csv"
    csv.write_text("u,y\n" + "\n".join(f"{float(a)!r},{float(b)!r}" for a, b in zip(u[:2000], y[:2000])))
    out = tmp_path / "m.json"
    assert main(["fit", str(csv), "--screen", "freerun", "--population", "20",
                 "--generations", "2", "--seed", "1", "--quiet", "--out", str(out)]) == 0
    assert json.loads(out.read_text())["meta"]["screen"] == "freerun"
    assert main(["fit", str(csv), "--screen", "bogus"]) == 2
    assert "--screen" in capsys.readouterr().err


def test_select_hold_picks_a_structure_whose_cls_refit_holds():
    from mggp.fit.selection import select_hold
    from benchmarks.casestudy import MODEL19
    u, y = _piezo()
    d = as_data(u, y)
    # y[k-2] alone carries the output: its CLS refit (theta = 1) keeps a
    # period-2 oscillation when the input stops; model (19) holds
    period2 = tuple(parse_term(t) for t in ("y[k-2]", "Phi1(u[k-1],u[k-2])",
                                             "Phi1(u[k-2],u[k-3])"))
    m19 = tuple(parse_term(t) for t in MODEL19["terms"])
    sc = StabilityScreen(d, 16, 1, hold=True)
    assert not sc.holds(period2)
    assert sc.holds(m19)
    terms, table = select_hold([period2, m19], d, 16)
    assert terms == m19
    assert [ok for ok, _ in table] == [False, True]
    # control: nothing holds -> None, every verdict listed
    terms, table = select_hold([period2], d, 16)
    assert terms is None and table[0][0] is False


def test_hold_test_on_short_records():
    # stretches shrink with the record; a record too short says so
    from narx.systems.testsystems import system_by_name
    d = system_by_name("S2", n=500, seed=0)
    data = as_data(d.u, d.y)
    sc = StabilityScreen(data, start=4, top=1, hold=True)
    assert sc.hold.length == (500 - 4) // 4 + 400
    assert isinstance(sc.stable(tuple(parse_term(t) for t in ("y[k-1]", "u[k-1]"))), bool)
    with pytest.raises(ValueError, match="the hold test needs a record of at least 84 "
                                         "samples, got 60"):
        StabilityScreen(as_data(d.u[:60], d.y[:60]), start=4, top=1, hold=True)
    kw = dict(fitness="ms", window=20, population=30, generations=3, max_terms=6,
              max_height=3, use_phi=False, random_state=0)
    est = MGGPRegressor(select="hold", **kw).fit(d.u, d.y)
    assert est.selection_ and isinstance(est.selection_[0][0], bool)


def test_select_hold_warns_when_no_candidate_holds():
    import warnings
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(20000)
    y = piezo_bouc_wen(u)
    kw = dict(fitness="ms", window=500, population=60, generations=10,
              constraints="steady-state", select="hold", screen=None, use_phi=True,
              select_candidates=20)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        est = MGGPRegressor(random_state=1, **kw).fit(u, y)
    holds = [ok for ok, _ in est.selection_]
    said = [w for w in caught if "none of the" in str(w.message)]
    assert not any(holds) and len(said) == 1


def test_band_follows_an_output_offset():
    """Output around 1000: a static model of the input (ŷ near 0) leaves the
    band [min y - R, max y + R] (it used to pass: |ŷ| <= max|y| + R holds
    everything down to -(max|y| + R)); the true integrating structure stays
    in it (control)."""
    rng = np.random.default_rng(0)
    n = 3000
    u = np.repeat(rng.uniform(-1, 1, n // 30), 30)
    y = np.full(n, 1000.0)
    for k in range(2, n):
        y[k] = y[k - 1] + 0.5 * (u[k - 1] - u[k - 2])
    data = as_data(u, y)
    sc = StabilityScreen(data, start=2, top=1, band=1.0)
    static = (parse_term("u[k-1]", data.signals), parse_term("u[k-2]", data.signals))
    true = (parse_term("y[k-1]", data.signals),
            parse_term("Phi1(u[k-1],u[k-2])", data.signals))
    assert math.isfinite(sc.scorer.score(static))           # no divergence at all
    assert not sc.stable(static)
    assert sc.stable(true)
