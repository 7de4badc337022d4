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
__version__ = "0.1.0"


from .exceptions import (CheckpointError, CLIError, CLSRejectedWarning,  # noqa: F401
                         SearchPrecisionWarning, WorkerLostError)
from .exceptions import __all__ as _EXCEPTIONS

__all__ = ["MGGPRegressor", "versions", *_EXCEPTIONS]


def __getattr__(name):            # lazy: importing mggp stays cheap for the CLI
    if name == "MGGPRegressor":
        from .estimator import MGGPRegressor
        return MGGPRegressor
    raise AttributeError(f"module 'mggp' has no attribute {name!r}")


def versions() -> dict:
    """Versions of mggp and of the libraries a result depends on (saved in
    model files' ``meta``)."""
    import deap
    import numpy
    import scipy
    try:                                    # deap.__version__ says "1.4" for 1.4.4
        from importlib.metadata import version
        deap_version = version("deap")
    except Exception:                       # pragma: no cover
        deap_version = deap.__version__
    v = {"mggp": __version__, "deap": deap_version, "numpy": numpy.__version__,
         "scipy": scipy.__version__}
    try:
        import numba
        v["numba"] = numba.__version__
    except ImportError:                     # pragma: no cover
        pass
    return v
