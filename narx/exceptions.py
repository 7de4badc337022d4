"""The exceptions and warnings of narx, each defined here once.

Typical use::

    import warnings
    from narx.exceptions import DataError, RankWarning
    try:
        model.fit(u, y)
    except DataError as exc:          # bad measured data: one line says why
        print(exc)
    warnings.simplefilter("error", RankWarning)

Every error is a ``ValueError`` (bad input: text, data, files, an
ill-posed estimation), so ``except ValueError`` catches them all; every
warning is a ``UserWarning``. The modules that raise them re-export them
(``narx.language.terms.TermError`` is ``narx.exceptions.TermError``).
"""
from __future__ import annotations

__all__ = ["TermError", "DataError", "EstimationError", "ModelFileError",
           "RankWarning", "NonMinimumPhaseWarning", "ExtrapolationWarning", "SeedLeakError"]


class TermError(ValueError):
    """Invalid term text or a term that does not fit the model's signals."""


class DataError(ValueError):
    """Invalid measured data (shape, length, non-finite values, names).
    ``column``: the name the data has no column of, when that is the
    problem (None otherwise), and ``role``: 'input' or 'output' when the
    reader knows which signal that column was to hold, so that a caller
    can say how to name it."""

    def __init__(self, *args, column=None, role=None):
        super().__init__(*args)
        self.column, self.role = column, role


class EstimationError(ValueError):
    """The estimation problem is ill-posed (constraints, shapes, data)."""


class ModelFileError(ValueError):
    """A model file that cannot be loaded."""


class RankWarning(UserWarning):
    """The regressor matrix of a fit is rank-deficient (dependent terms)."""


class NonMinimumPhaseWarning(UserWarning):
    """The model's linear input part has zeros outside the unit circle."""


class ExtrapolationWarning(UserWarning):
    """A record's inputs leave the range the model was fitted on
    (:func:`narx.records.ranges.range_warning`)."""


class SeedLeakError(ValueError):
    """An evaluation seed of the system zoo was drawn inside
    :func:`narx.systems.zoo.tuning` (tuning may use development seeds only)."""
