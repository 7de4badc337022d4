"""The diagnose tests that run by default, one line each, in the order they run.

A new test is a module defining a :class:`~mggp.diagnose.registry.DiagnosticTest`
and one ``register`` line here (:mod:`mggp.diagnose.registry`).
"""
from . import augmentation, bias, correlation, drift, loopgap, restlevels
from .registry import register

register(loopgap.LOOP_GAP)
register(augmentation.AUGMENTATION)
register(augmentation.OPERATOR_AUGMENTATION)
register(restlevels.REST_LEVELS)
register(bias.PREDICTION_BIAS)
register(drift.DRIFT)
register(correlation.CORRELATION)
