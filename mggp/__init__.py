"""mggp: structure search for NARX models of hysteretic systems by MGGP.

Typical use::

    from mggp import MGGPRegressor
    est = MGGPRegressor(fitness="ms", population=100, generations=30,
                        random_state=0).fit(u, y)
    est.model_.equation()
    est.pareto_front_          # complexity against error

The numerics live in :mod:`narx`; this package decodes DEAP individuals
into narx terms, runs the evolution, and holds the command line (``mggp``).
"""
from .exceptions import (CheckpointError, CLIError, CLSRejectedWarning,  # noqa: F401
                         NotFittedError, SearchPrecisionWarning, WorkerLostError)
from .exceptions import __all__ as _EXCEPTIONS
from .version import __version__, versions  # noqa: F401

__all__ = ["MGGPRegressor", "versions", *_EXCEPTIONS]


def __getattr__(name):            # lazy: importing mggp stays cheap for the CLI
    if name == "MGGPRegressor":
        from .estimator import MGGPRegressor
        return MGGPRegressor
    raise AttributeError(f"module 'mggp' has no attribute {name!r}")
