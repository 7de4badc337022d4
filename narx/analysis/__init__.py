"""What a model does: steady states, quasi-static loops, inversion, comparison.

Typical use::

    from narx.analysis.quasistatic import quasistatic
    from narx.analysis.compensate import compensate

Modules: :mod:`~narx.analysis.steady` (term clusters and the
continuum-of-steady-states constraints), :mod:`~narx.analysis.quasistatic`
(the fixed points that form a loop), :mod:`~narx.analysis.inverse_check`
(step-by-step invertibility), :mod:`~narx.analysis.compensate` and
:mod:`~narx.analysis.compensate_args` (model-based compensation) and
:mod:`~narx.analysis.paired` (paired comparison of two models' losses).
"""
