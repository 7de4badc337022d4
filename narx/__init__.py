"""narx: polynomial NARX models with Φ-functions (the numerical layer of mggp).

Typical use::

    import narx
    m = narx.Model(["y[k-1]", "Phi1(u[k-1],u[k-2])"]).fit(u, y)
    res = m.simulate(u, y, mode="freerun")
    narx.mape(y, res.y_hat)

``narx`` never imports ``deap`` or ``mggp``.
"""
from .phi import (PhiFunction, PhiRegistry, register_phi, unregister_phi,
                  get_phi, default_registry)
from .terms import Lag, PhiCall, Term, TermError, Signals, parse_term, parse_terms

__version__ = "0.1.0"
