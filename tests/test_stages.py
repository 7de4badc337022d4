"""The stages of fit return their decisions, and a stage-time automatic
choice is taken, recorded and read through the settings the stages see."""
from types import SimpleNamespace

from mggp.fit import choices, stages


def test_a_stage_choice_is_taken_recorded_and_read(monkeypatch):
    monkeypatch.setitem(choices.STAGE_CHOICES, "noise_lags",
                        lambda ctx: choices.Choice("noise_lags", 2, "toy rule", {}))
    ctx = SimpleNamespace(est=SimpleNamespace(noise_lags="auto", prune=False), choices={})
    stages.resolve_stage_choices(ctx)
    assert ctx.choices["noise_lags"].why == "toy rule"
    assert ctx.est.noise_lags == 2 and ctx.est.prune is False    # the rest as set
    # control: a parameter set by hand is not chosen, and the settings are the estimator's
    est = SimpleNamespace(noise_lags=1)
    ctx = SimpleNamespace(est=est, choices={})
    stages.resolve_stage_choices(ctx)
    assert ctx.choices == {} and ctx.est is est


def test_latest_reads_the_last_decision_that_has_the_field():
    ctx = stages.FitContext(SimpleNamespace(), None, None, 0, None)
    first, second = object(), object()
    ctx.decided["qr_refit"] = stages.Refitted((), first, 1)
    ctx.decided["cls_refit"] = stages.ClsRefitted((), None, None)
    assert ctx.latest("model") is first
    ctx.decided["refine"] = stages.Refined((), None, second, None)
    assert ctx.latest("model") is second and ctx.latest("model_cls") is None
    assert ctx.latest("no_such_field", "default") == "default"
