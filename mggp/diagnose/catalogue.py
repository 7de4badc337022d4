"""The diagnose tests that run by default, one line each, in the order they run.

A new test is a module defining a :class:`~mggp.diagnose.registry.DiagnosticTest`
and one ``register`` line here (:mod:`mggp.diagnose.registry`). Typical use::

    from mggp.diagnose.registry import registered
    [t.name for t in registered()]       # the tests below, in this order
"""
from . import augmentation, bias, correlation, drift, loopgap, restlevels
from .registry import register

register(loopgap.LOOP_GAP)
register(augmentation.AUGMENTATION)
register(augmentation.HELD_OUT_AUGMENTATION)
register(augmentation.OPERATOR_AUGMENTATION)
register(restlevels.REST_LEVELS)
register(bias.PREDICTION_BIAS)
register(drift.DRIFT)
register(correlation.CORRELATION)
