"""Estimation of θ for a structure, and the scoring of structures in a search.

Typical use::

    from narx.estimation.estimate import least_squares
    from narx.estimation.fitness import StructureScorer

Modules: :mod:`~narx.estimation.estimate` (LS, CLS, extended LS),
:mod:`~narx.estimation.gram` (Gram entries in a fixed order),
:mod:`~narx.estimation.output_error` (output-error θ) and
:mod:`~narx.estimation.fitness` (a structure's score on one record).
"""
