"""The command-line options a study shares: seeds, search budget, workers.

Typical use::

    p = argparse.ArgumentParser(description="a study")
    add_budget_args(p, seeds=[1])
    a = p.parse_args(argv)
    MGGPRegressor(random_state=a.seeds[0], n_jobs=a.jobs, **budget(a))

Without ``--population``/``--generations`` the fits run at ``mggp fit``'s
own defaults (the keywords are left out, not copied here).
"""
from __future__ import annotations

import argparse

__all__ = ["add_budget_args", "budget"]


def add_budget_args(p: argparse.ArgumentParser, seeds=(1,), jobs: int = 2) -> None:
    """Add ``--seeds``, ``--population``, ``--generations`` and ``--jobs`` to ``p``."""
    p.add_argument("--seeds", type=int, nargs="+", default=list(seeds))
    p.add_argument("--population", type=int, help="default: mggp fit's")
    p.add_argument("--generations", type=int, help="default: mggp fit's")
    p.add_argument("--jobs", type=int, default=jobs)


def budget(a: argparse.Namespace) -> dict:
    """The MGGPRegressor keywords of the budget options given (none: the defaults)."""
    return {k: getattr(a, k) for k in ("population", "generations")
            if getattr(a, k) is not None}
