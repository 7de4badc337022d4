"""The genetic programming of mggp: typed gene trees of NARX terms and their evolution.

Typical use::

    from mggp.gp.primitives import make_pset
    from mggp.gp.evolve import evolve

Modules: :mod:`~mggp.gp.primitives` (the typed primitive set, safe tree
parsing, decoding to terms), :mod:`~mggp.gp.individual` (individuals and
their fitness), :mod:`~mggp.gp.operators` (tree generation, crossover,
mutation), :mod:`~mggp.gp.evolve` (the generational loop),
:mod:`~mggp.gp.evaluate` (batch evaluation of term sets),
:mod:`~mggp.gp.checkpoint` (evolution state and its JSON files) and
:mod:`~mggp.gp.pareto` (the front of complexity against loss).
"""
