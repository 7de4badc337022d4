"""Checks of :class:`mggp.MGGPRegressor`'s parameters, made before a search
starts so that a typo does not cost a whole run.

Typical use (inside ``fit``)::

    from mggp.params import check_params
    check_params(est)        # ValueError naming the parameter, rule, value

Every message names the parameter, the rule and the value given, as
scikit-learn's do.
"""
from __future__ import annotations

import numbers

__all__ = ["check_params"]


def _is_int(v) -> bool:
    return isinstance(v, numbers.Integral) and not isinstance(v, bool)


def _int_at_least(name, v, lo, optional=False):
    if optional and v is None:
        return
    if not _is_int(v) or v < lo:
        rule = f"an integer >= {lo}" + (" or None" if optional else "")
        raise ValueError(f"{name} must be {rule}, got {v!r}")


def _one_of(name, v, allowed):
    if not any(v is a or (type(v) is type(a) and v == a) for a in allowed):
        text = ", ".join(repr(a) for a in allowed)
        raise ValueError(f"{name} must be one of {text}, got {v!r}")


def check_params(est) -> None:
    """Raise ``ValueError`` for the first parameter of ``est`` out of its rule."""
    _int_at_least("population", est.population, 2)
    for name in ("max_terms", "max_height", "window", "k"):
        _int_at_least(name, getattr(est, name), 1)
    _int_at_least("generations", est.generations, 0)
    _int_at_least("noise_lags", est.noise_lags, 0)
    _int_at_least("select_candidates", est.select_candidates, 1)
    _int_at_least("max_lag", est.max_lag, 1, optional=True)
    _int_at_least("max_degree", est.max_degree, 1, optional=True)
    _int_at_least("screen_top", est.screen_top, 1, optional=True)
    _one_of("constraints", est.constraints, (None, "steady-state"))
    _one_of("search_constraints", est.search_constraints, (None, "steady-state"))
    _one_of("select", est.select, ("fitness", "freerun", "hold"))
    _one_of("prune", est.prune, (False, None, "bic", "t"))
    _one_of("screen", est.screen, (None, "freerun", "hold"))
    _one_of("refine", est.refine, (None, "ms", "freerun"))
    _one_of("phi_outputs", est.phi_outputs, (False, True))
    _one_of("constant", est.constant, (False, True))
    if est.phi_outputs and not est.use_phi:
        raise ValueError("phi_outputs=True needs Φ-functions in the search, got use_phi=False")
    _int_at_least("refine_window", est.refine_window, 1, optional=True)
    t = est.t_threshold
    if t is not None and not (isinstance(t, numbers.Real) and not isinstance(t, bool)
                              and t > 0 and t < float("inf")):
        raise ValueError(f"t_threshold must be a finite number > 0 or None, got {t!r}")
