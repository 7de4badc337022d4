"""Simulation of NARX models: one-step-ahead, free run, k steps ahead, shooting.

Typical use::

    from narx.simulation.simulate import simulate
    res = simulate(terms, theta, data, "freerun")

Modules: :mod:`~narx.simulation.simulate` (the four modes),
:mod:`~narx.simulation.kernels` and :mod:`~narx.simulation.ms_kernel`
(compiled recursions) and :mod:`~narx.simulation.metrics` (errors).
"""
