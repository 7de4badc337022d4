"""The diagnose tests that run by default, one line each, in the order they run.

A new test is a module defining a :class:`~mggp.diagnose.registry.DiagnosticTest`
and one ``register`` line here (:mod:`mggp.diagnose.registry`). Typical use::

    from mggp.diagnose.registry import registered
    [t.name for t in registered()]       # the tests below, in this order

The Φ- and operator-augmentation tests (:mod:`.augmentation`) are not run
by default: the candidate extensions and their paired test
(:mod:`.verdict`) measure what they measured, out of sample, and they
cost most of the evidence's time (``register(augmentation.AUGMENTATION)``
adds one back).
"""
from . import bias, correlation, drift, loopgap, restlevels
from .registry import register

register(loopgap.LOOP_GAP)
register(restlevels.REST_LEVELS)
register(bias.PREDICTION_BIAS)
register(drift.DRIFT)
register(correlation.CORRELATION)
