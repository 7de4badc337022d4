"""The scikit-learn conventions of :class:`mggp.MGGPRegressor`.

Typical use::

    from sklearn.model_selection import TimeSeriesSplit, cross_val_score
    from mggp import MGGPRegressor
    est = MGGPRegressor(population=40, generations=5, random_state=0)
    cross_val_score(est, u, y, cv=TimeSeriesSplit(3))       # free-run R² per fold
    est.fit(df[["u1", "u2"]], df["y"]).feature_names_in_    # the inputs' names

This module holds what makes the estimator a scikit-learn regressor
without importing scikit-learn at run time: its tags (:func:`sklearn_tags`,
scikit-learn imported only when they are asked for), the reading of the
input signals as scikit-learn passes them (arrays, pandas DataFrames; the
number and the names of the features, :func:`fit_inputs`,
:func:`predict_inputs`) and the estimator checks a time-series model
cannot meet, each with the reason (:data:`EXPECTED_FAILED_CHECKS`).
"""
from __future__ import annotations

import warnings
from functools import lru_cache
from typing import Optional, Tuple

import numpy as np

from narx.records.data import Data, DataError

from ..exceptions import NotFittedError

__all__ = ["sklearn_tags", "fit_inputs", "fit_output", "predict_inputs", "not_fitted",
           "EXPECTED_FAILED_CHECKS", "NO_Y"]

#: scikit-learn's words for a missing target (its estimator checks look for them)
NO_Y = "requires y to be passed, but the target y is None"

def _few(n: int, also: str = "") -> str:
    return (f"the check fits {n} samples: a structure search needs at least 21 (its largest "
            f"lag, at least 1, plus 4 rows per term of max_terms, at least 20), and refuses "
            f"fewer naming both figures{also}")


#: the checks of :func:`sklearn.utils.estimator_checks.parametrize_with_checks`
#: that a structure search of a time series cannot pass, and why
EXPECTED_FAILED_CHECKS = {
    "check_methods_subset_invariance": _few(
        20, "; on more samples it fails too, as sample order matters: a subset of rows is "
        "not a sub-sample of a time series, and the free run of a batch of rows depends on "
        "the rows before them"),
    "check_methods_sample_order_invariance": _few(
        20, "; on more samples it fails too, as sample order matters: the rows are the "
        "samples of a time series, and the free run of shuffled rows is that of another "
        "input signal"),
    "check_fit2d_predict1d": _few(20, "; and a 1-D u is one input signal of n samples, "
                                  "which predict accepts"),
    "check_estimators_dtypes": _few(20),
    "check_dict_unchanged": _few(20),
    "check_dont_overwrite_parameters": _few(20),
    "check_f_contiguous_array_estimator": _few(20),
    "check_n_features_in_after_fitting": _few(15),
    "check_estimators_nan_inf": _few(10, " (NaN and inf are refused, naming the sample)"),
    "check_fit2d_1feature": _few(10, ", not '1 feature(s)'"),
    "check_regressors_no_decision_function": _few(10),
}


def sklearn_tags(est):
    """The tags of ``est`` (:class:`sklearn.utils.Tags`): a single-output
    regressor that needs y, of dense 2-D input (1-D: one input signal)
    without NaN, whose score on independent samples is poor (its terms are
    lagged signals: the i.i.d. rows of scikit-learn's test data have no
    dynamics to find)."""
    from sklearn.utils import InputTags, RegressorTags, Tags, TargetTags
    return Tags(estimator_type="regressor",
                target_tags=TargetTags(required=True, single_output=True),
                regressor_tags=RegressorTags(poor_score=True),
                input_tags=InputTags(one_d_array=False, two_d_array=True, allow_nan=False,
                                     sparse=False),
                requires_fit=True)


def _names(u) -> Optional[Tuple[str, ...]]:
    """The column names of a DataFrame ``u`` when they are all strings (as
    scikit-learn takes feature names), else None."""
    cols = getattr(u, "columns", None)
    if cols is None or not all(isinstance(c, str) for c in cols):
        return None
    return tuple(cols)


def _dense(u, what: str = "u"):
    """``u`` as an array; ``TypeError`` for a sparse matrix or values that
    are no numbers, ``ValueError`` for complex values and for no column."""
    if hasattr(u, "toarray") or type(u).__module__.startswith("scipy.sparse"):
        raise TypeError(f"{what} is a sparse matrix: the signals must be dense arrays "
                        f"(sparse data is not supported; u.toarray() makes one)")
    arr = np.asarray(u)
    if np.iscomplexobj(arr):
        raise DataError(f"{what} holds complex values: Complex data not supported")
    if arr.dtype == object:
        try:
            arr = arr.astype(np.float64)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{what} must be numeric: {exc}") from None
    if arr.ndim == 2 and arr.shape[1] == 0:
        raise DataError(f"{what} has 0 feature(s) (shape={arr.shape}) while a minimum of 1 "
                        f"is required: a model needs an input signal")
    return arr


def not_fitted(message: str) -> Exception:
    """:class:`mggp.NotFittedError` with ``message``; also scikit-learn's
    ``NotFittedError`` when scikit-learn is installed (its checks and
    ``except`` clauses look for that class)."""
    return _not_fitted_class()(message)


@lru_cache(maxsize=1)
def _not_fitted_class():
    try:
        from sklearn.exceptions import NotFittedError as theirs
    except ImportError:                         # scikit-learn is optional
        return NotFittedError
    return type("NotFittedError", (NotFittedError, theirs),
                {"__module__": NotFittedError.__module__, "__doc__": NotFittedError.__doc__})


def _n_features(arr) -> int:
    return 1 if arr.ndim <= 1 else arr.shape[1]


def fit_inputs(est, u):
    """The input signals of ``fit(u, y)`` and their names: ``(u, inputs)``,
    ``u`` a narx.Data or an array, ``inputs`` the names to give them (the
    columns of a DataFrame, else the estimator's ``inputs``). Sets
    ``n_features_in_`` and, for a DataFrame with string column names,
    ``feature_names_in_``; a DataFrame whose columns differ from a given
    ``inputs`` is refused."""
    if isinstance(u, Data):
        est.n_features_in_ = len(u.inputs)
        return u, est.inputs
    names = _names(u)
    arr = _dense(u)
    est.n_features_in_ = _n_features(arr)
    if names is None:
        return arr, est.inputs
    if est.inputs is not None and tuple(est.inputs) != names:
        raise ValueError(f"inputs={list(est.inputs)} differ from the columns of the "
                         f"DataFrame u, {list(names)}: the columns are the inputs (give "
                         f"u[inputs], or inputs=None)")
    est.feature_names_in_ = np.asarray(names, dtype=object)
    return arr, list(names)


def fit_output(y):
    """The measured output of ``fit``: a 1-D array (a column vector is
    raveled with scikit-learn's ``DataConversionWarning``); a missing y is
    refused in scikit-learn's words (:data:`NO_Y`)."""
    if y is None:
        raise ValueError(f"MGGPRegressor {NO_Y}: give the measured output y (or a "
                         f"narx.Data record holding it)")
    arr = _dense(y, "y")
    if arr.ndim == 2 and arr.shape[1] == 1:
        try:
            from sklearn.exceptions import DataConversionWarning as kind
        except ImportError:                     # scikit-learn is optional
            kind = UserWarning
        warnings.warn("A column-vector y was passed when a 1d array was expected: y is "
                      "taken as its one column", kind, stacklevel=3)
        arr = arr[:, 0]
    return arr


def predict_inputs(est, u):
    """``u`` of ``predict``/``score``/``simulate`` checked against the fit:
    the number of features (``ValueError``) and their names (a DataFrame
    of other columns is refused; names given to a fit without them, or
    missing where the fit had them, warn as scikit-learn does). Returns a
    narx.Data unchanged, else an array."""
    if isinstance(u, Data):
        return u
    names = _names(u)
    arr = _dense(u)
    n, seen = _n_features(arr), getattr(est, "n_features_in_", None)
    fitted = getattr(est, "feature_names_in_", None)
    cls = type(est).__name__
    if fitted is not None and names is not None and tuple(fitted) != names:
        raise ValueError(f"The feature names should match those that were passed during "
                         f"fit: u has the columns {list(names)}, the fit had "
                         f"{list(fitted)}")
    if fitted is not None and names is None:
        warnings.warn(f"X does not have valid feature names, but {cls} was fitted with "
                      f"feature names: the columns of u are taken as {list(fitted)}",
                      UserWarning, stacklevel=3)
    if fitted is None and names is not None and seen is not None:
        warnings.warn(f"X has feature names, but {cls} was fitted without feature names",
                      UserWarning, stacklevel=3)
    if seen is not None and n != seen:
        raise ValueError(f"X has {n} features, but {cls} is expecting {seen} features as "
                         f"input (u must hold the {seen} input signal(s) of the fit)")
    return arr
