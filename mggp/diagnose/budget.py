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

    The defaults are the published population of 500 and 100 generations.
    ``mggp diagnose`` on a 10,000-sample record without a validation record
    searches the baseline on 4,900 samples: 27 s wall with ``jobs=2`` on
    the 2-core development machine at load 1.4; the diagnosis beyond the
    search (evidence, the candidate extensions, their tests) took 2.1 s of
    CPU.
    """

    population: int = 500
    generations: int = 100
    max_terms: int = 15
    max_height: int = 5
    max_degree: int = 3
    window: int = 100
    shifts: int = 99
