"""The effort of a diagnosis: search budget and sample sizes of the statistics.

Typical use::

    from mggp.diagnose.budget import Budget
    Budget(population=100, generations=20)      # a quick diagnosis

:class:`Budget` is read by the baseline search and the extension
(:mod:`mggp.diagnose.extend`), the tests (:mod:`mggp.diagnose.context`)
and the calibration; it imports nothing of the package, so every module
can import it without a cycle.
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Budget"]


@dataclass(frozen=True)
class Budget:
    """Search effort and sample sizes of the statistics.

    The defaults (the published population of 500, 100 generations) take
    about 40 s for 10,000 samples on 2 cores (``jobs=2``) and about 2.5 min
    per model for the 50,000-sample piezo record.
    """

    population: int = 500
    generations: int = 100
    max_terms: int = 15
    max_height: int = 5
    max_degree: int = 3
    window: int = 100
    shifts: int = 99
    bootstrap: int = 199
    corr_lags: int = 20
