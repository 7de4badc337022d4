"""The version of mggp and the versions of the libraries a result depends on.

Typical use::

    from mggp.version import __version__, versions
    versions()      # {"mggp": "0.1.0", "deap": "1.4.4", "numpy": ..., ...}

Model files record :func:`versions` in their ``meta``, so a result can be
traced to the code that produced it.
"""
from __future__ import annotations

__all__ = ["__version__", "versions"]

__version__ = "0.1.0"


def versions() -> dict:
    """Versions of mggp and of the libraries a result depends on.

    Returns
    -------
    dict
        ``{"mggp", "deap", "numpy", "scipy"}`` and ``"numba"`` when it is
        installed, each the installed version string (deap's from the
        package metadata, since ``deap.__version__`` gives only major.minor).
    """
    import deap
    import numpy
    import scipy
    try:
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
