"""The fit of :class:`mggp.MGGPRegressor`: parameters, automatic choices, stages.

Typical use::

    from mggp.fit.estimator import MGGPRegressor
    from mggp.fit.params import PARAMS          # the table of parameters

Modules: :mod:`~mggp.fit.estimator` (the estimator; it assigns every fitted
attribute), :mod:`~mggp.fit.params` (one row per parameter),
:mod:`~mggp.fit.choices` (every automatic choice, with its record),
:mod:`~mggp.fit.stages` (the stages after the search, each returning its
decision), and the stages' own modules: :mod:`~mggp.fit.screen`,
:mod:`~mggp.fit.selection`, :mod:`~mggp.fit.pruning`,
:mod:`~mggp.fit.local_search`, :mod:`~mggp.fit.operator_stage`,
:mod:`~mggp.fit.noise`, :mod:`~mggp.fit.precision`,
:mod:`~mggp.fit.extrapolation`; :mod:`~mggp.fit.sklearn_api` holds the
scikit-learn conventions.
"""
