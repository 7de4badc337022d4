"""mggp: structure search for NARX models of hysteretic systems by MGGP.

Typical use::

    from mggp import MGGPRegressor
    est = MGGPRegressor(fitness="ms", population=100, generations=30,
                        random_state=0).fit(u, y)
    est.model_.equation()
    est.pareto_front_          # complexity against error

The numerics live in :mod:`narx`; this package decodes DEAP individuals
into narx terms, runs the evolution, and holds the command line (``mggp``).
Its subpackages, each importing only those listed before it (but
:mod:`mggp.gp.evolve` checks its settings by the rules of
:mod:`mggp.fit.params`):

- :mod:`mggp.gp`: the genetic programming (primitives, individuals,
  operators, the generational loop, batch evaluation, checkpoints, Pareto
  front);
- :mod:`mggp.fit`: :class:`MGGPRegressor`, its parameter table, its
  automatic choices and the stages after the search;
- :mod:`mggp.report`: figures and Markdown summaries;
- :mod:`mggp.diagnose`: what a model gets wrong, why, and the gain of fixing it;
- :mod:`mggp.cli`: the ``mggp`` command line.

:mod:`mggp.compensate` (compensation by MGGP), :mod:`mggp.exceptions` and
:mod:`mggp.version` stand beside them.
"""
import sys as _sys

from .exceptions import (CheckpointError, CLIError, CLSRejectedWarning,  # noqa: F401
                         NotFittedError, SearchPrecisionWarning, WorkerLostError)
from .exceptions import __all__ as _EXCEPTIONS
from .version import __version__, versions  # noqa: F401

__all__ = ["MGGPRegressor", "versions", *_EXCEPTIONS]


#: the module paths before the subpackages, each to its new home; they import
#: for one release with a DeprecationWarning (``mggp.cli`` and ``mggp.report``
#: are packages now: their ``__getattr__`` hands the old names on)
MOVED = {
    "mggp.primitives": "mggp.gp.primitives",
    "mggp.individual": "mggp.gp.individual",
    "mggp.operators": "mggp.gp.operators",
    "mggp.evolve": "mggp.gp.evolve",
    "mggp.evaluate": "mggp.gp.evaluate",
    "mggp.checkpoint": "mggp.gp.checkpoint",
    "mggp.pareto": "mggp.gp.pareto",
    "mggp.estimator": "mggp.fit.estimator",
    "mggp.params": "mggp.fit.params",
    "mggp.stages": "mggp.fit.stages",
    "mggp.choices": "mggp.fit.choices",
    "mggp.screen": "mggp.fit.screen",
    "mggp.selection": "mggp.fit.selection",
    "mggp.pruning": "mggp.fit.pruning",
    "mggp.local_search": "mggp.fit.local_search",
    "mggp.operator_stage": "mggp.fit.operator_stage",
    "mggp.noise": "mggp.fit.noise",
    "mggp.precision": "mggp.fit.precision",
    "mggp.extrapolation": "mggp.fit.extrapolation",
    "mggp.sklearn_api": "mggp.fit.sklearn_api",
    "mggp.cli_fit": "mggp.cli.fit",
    "mggp.cli_diagnose": "mggp.cli.diagnose",
    "mggp.cli_compensate": "mggp.cli.compensate",
    "mggp.cli_quasistatic": "mggp.cli.quasistatic",
    "mggp.quasistatic_report": "mggp.report.quasistatic",
    "mggp.plotting": "mggp.report.plotting",
}


class _OldPaths:
    """Finder of the paths of :data:`MOVED` (loads :mod:`narx` only when one is used)."""

    @staticmethod
    def find_spec(name, path=None, target=None):
        if name not in MOVED:
            return None
        from narx._moved import moved_spec
        return moved_spec(name, MOVED[name])


_sys.meta_path.insert(0, _OldPaths)   # before any finder of an installed copy


def __getattr__(name):            # lazy: importing mggp stays cheap for the CLI
    if name == "MGGPRegressor":
        from .fit.estimator import MGGPRegressor
        return MGGPRegressor
    raise AttributeError(f"module 'mggp' has no attribute {name!r}")
