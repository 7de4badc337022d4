"""Every exception and warning that :mod:`mggp` raises or emits.

Typical use::

    import warnings
    from mggp import CLSRejectedWarning
    warnings.simplefilter("error", CLSRejectedWarning)   # a rejected CLS refit stops

Errors of the numerics (bad data, bad terms, model files) are
:mod:`narx`'s (``narx.records.data.DataError``, ``narx.language.terms.TermError``, ...).
Errors of a parameter out of its rule are ``ValueError`` naming the
parameter, the rule and the value given (:mod:`mggp.fit.params`).
"""
from __future__ import annotations

__all__ = ["CLIError", "CheckpointError", "WorkerLostError", "NotFittedError",
           "CLSRejectedWarning", "SearchPrecisionWarning"]


class CLIError(Exception):
    """A usage or input error of the command line, reported as one
    ``error:`` line on stderr with exit code 2."""


class CheckpointError(ValueError):
    """A checkpoint file cannot be resumed: unreadable, not a checkpoint,
    or written by a run with other settings, data or primitives."""


class WorkerLostError(RuntimeError):
    """Worker processes kept dying while a batch was scored."""


class NotFittedError(ValueError, AttributeError):
    """A fitted estimator's method called before ``fit``; a ValueError and
    an AttributeError, as scikit-learn's ``NotFittedError`` is (its checks
    and ``except`` clauses catch either)."""


class CLSRejectedWarning(UserWarning):
    """The CLS refit is not used by default: its free run diverges on the
    training record, or its error there is over twice the LS fit's
    (:func:`mggp.fit.stages.cls_rejection`)."""


class SearchPrecisionWarning(UserWarning):
    """The search's normal equations lose precision on the data (an offset
    dominates a signal)."""
