"""The diagnose tests that run by default, one line each, in the order they run: none.

A new test is a module defining a :class:`~mggp.diagnose.registry.DiagnosticTest`
and one ``register`` line here (:mod:`mggp.diagnose.registry`). Typical use::

    from mggp.diagnose import augmentation
    from mggp.diagnose.registry import register, registered
    [t.name for t in registered()]       # [] by default
    register(augmentation.AUGMENTATION)  # a test runs in every later diagnosis

The effect a diagnosis names, its gain, the model it recommends and its
note on one-amplitude records come from the candidate extensions and their
paired held-out test (:mod:`.verdict`), not from residual statistics.
Each residual check that ran here by default (loop gap, rest levels,
prediction bias, holds, Billings–Voon correlations) was measured on 150
development draws of the zoo (``python -m benchmarks.zoo ablate``):
removing it changed no outcome on any draw, so none is run. The Φ- and
operator-augmentation tests (:mod:`.augmentation`) stay registrable; the
candidates measure what they measured, out of sample.
"""
from .registry import register  # noqa: F401  (the line a default test would use)
