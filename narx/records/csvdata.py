"""Read measured records from CSV files, with one-line errors.

Typical use::

    from narx.records.csvdata import read_csv
    data = read_csv("DATA.csv")                               # columns u, y
    data = read_csv("damper.csv", inputs=["v", "E"], output="f")
    data = read_csv("ref.csv", inputs=["r"], output=None)     # no output
    data = read_csv("train.csv", min_samples=40, varying_inputs=True)  # to identify

The file has a header row; the named columns must each appear once and hold
finite numbers (plain ASCII decimal notation, as ``float`` reads it, without
``_`` separators) on every data row; the field separator is ``,``, ``;`` or
a tab, whichever splits the header row into the most fields outside quotes
(``,`` on a tie), and in
a ``;`` or tab separated file a decimal comma is read as a point
(``1,5e-3``), as spreadsheet programs of many locales write them; other columns are ignored (their
content is not checked), blank lines are skipped, rows must all have the
header's number of fields (empty fields after the last are ignored). Every problem raises
:class:`~narx.records.data.DataError` with the file, the line (1-based, header =
line 1), the column and the rule. Memory is linear in the number of rows
(8 bytes per value read, no per-row Python objects kept).
"""
from __future__ import annotations

import csv
import math
import re
import os
import warnings
from array import array
from typing import Iterator, List, Optional, Sequence, Tuple

import numpy as np

from ..atomic import atomic_writer
from .data import MAX_ABS, Data
from ..exceptions import DataError

__all__ = ["read_csv", "read_columns", "iter_rows", "write_with_column", "time_column",
           "sampling_message", "GAP_FACTOR"]

MAX_FIELD = 1 << 20
#: field separators recognised in the header row, the first wins a tie
DELIMITERS = (",", ";", "\t")


def _open(path):
    try:
        return open(path, newline="", encoding="utf-8-sig")
    except OSError as exc:
        raise DataError(f"{path}: cannot read file ({exc.strerror})") from None


def _best_delimiter(line: str) -> str:
    """The candidate that splits ``line`` into the most fields, among those
    that leave no stray quote inside a field (quotes respected)."""
    best, key = ",", None
    for d in DELIMITERS:
        fields = next(csv.reader([line], delimiter=d), [])
        k = (not any('"' in f for f in fields), len(fields))
        if key is None or k > key:
            best, key = d, k
    return best


def delimiter(path) -> str:
    """Field separator of a CSV file: whichever of ``,``, ``;`` and tab splits
    its first non-blank line into the most fields, quotes respected (``,``
    on a tie)."""
    path = os.fspath(path)
    with _open(path) as fh:
        number = 0
        try:
            while True:                  # a bounded read: a header is short
                number += 1
                line = fh.readline(MAX_FIELD)
                if not line:
                    break
                if line.strip():
                    return _best_delimiter(line)
        except UnicodeDecodeError:
            raise DataError(f"{path}: not UTF-8 text (near line {number})") from None
    return ","


def _records(path, sep: str = ",") -> Iterator[Tuple[int, int, List[str]]]:
    """Yield (first line, last line, fields) of non-blank records."""
    path = os.fspath(path)
    csv.field_size_limit(MAX_FIELD)
    fh = _open(path)
    with fh:
        reader = csv.reader(fh, delimiter=sep)
        end = 0
        try:
            for fields in reader:
                first, end = end + 1, reader.line_num
                if not fields or all(not f.strip() for f in fields):
                    continue
                yield first, end, fields
        except UnicodeDecodeError:
            raise DataError(f"{path}: not UTF-8 text (near line {reader.line_num + 1})") from None
        except csv.Error as exc:
            where = (f"line {end + 1}" if reader.line_num <= end + 1 else
                     f"lines {end + 1}-{reader.line_num} (an unclosed quote?)")
            raise DataError(f"{path}: {where}: malformed CSV ({exc})") from None


def _trim(fields: List[str], width: int) -> List[str]:
    """``fields`` without empty fields after the ``width``-th (trailing
    separators, as LabVIEW and spreadsheets write them)."""
    if len(fields) > width and not any(f.strip() for f in fields[width:]):
        return fields[:width]
    return fields


def iter_rows(path, sep: Optional[str] = None) -> Iterator[Tuple[int, List[str]]]:
    """Yield (line number, fields) of non-blank rows, header included.

    The line number is where the row starts (a quoted field may span lines);
    ``sep`` defaults to the file's :func:`delimiter`.
    """
    for first, _, fields in _records(path, delimiter(path) if sep is None else sep):
        yield first, fields


def _number(path, line, col, text, decimal_comma: bool = False) -> float:
    s = text.strip()
    if decimal_comma and s.count(",") == 1 and "." not in s:
        s = s.replace(",", ".")
    try:
        v = float(s)
        if "_" in s or not s.isascii():
            raise ValueError(s)
    except ValueError:
        shown = s if len(s) <= 40 else s[:37] + "..."
        hint = ("" if line > 2 or not s or s[0] in "+-.0123456789" else
                " (a row of units or comments under the header? remove it)")
        raise DataError(f"{path}: line {line}, column {col!r}: {shown!r} is not a "
                        f"number{hint}") from None
    if not math.isfinite(v):
        raise DataError(f"{path}: line {line}, column {col!r}: value {s!r} is not finite "
                        f"(NaN and inf are not allowed)")
    if abs(v) > MAX_ABS:
        raise DataError(f"{path}: line {line}, column {col!r}: value {s!r} is too large to "
                        f"model (|values| up to {MAX_ABS:.0e} are accepted): rescale the data")
    return v


def read_columns(path, names: Sequence[str]) -> Tuple[np.ndarray, List[str]]:
    """Read the named columns as a float array (N, len(names)) and the header."""
    path = os.fspath(path)
    sep = delimiter(path)
    rows = _records(path, sep)
    try:
        line, _, header = next(rows)
    except StopIteration:
        raise DataError(f"{path}: empty file (no header row)") from None
    header = [h.strip() for h in header]
    idx = []
    for name in names:
        hits = [i for i, h in enumerate(header) if h == name]
        if not hits and header and header[0].startswith("#"):
            raise DataError(f"{path}: line {line} starts with '#', a comment: comment "
                            f"lines before the header row are not supported; remove them")
        if not hits:
            shown = ", ".join(h if h.isprintable() else repr(h)
                              for h in header if h)[:200] or "(none)"
            sep_name = {",": "','", ";": "';'", "\t": "tab"}[sep]
            raise DataError(f"{path}: line {line} (header): no column {name!r} "
                            f"(columns: {shown}; fields separated by {sep_name})",
                            column=name)
        if len(hits) > 1:
            raise DataError(f"{path}: column {name!r} appears {len(hits)} times in the "
                            f"header (fields {', '.join(str(i + 1) for i in hits)})")
        idx.append(hits[0])
    if len(set(names)) != len(names):
        raise DataError(f"{path}: the same column is named twice among {list(names)}")
    width = len(header)
    values = array("d")
    pairs = list(zip(names, idx))
    for line, end, fields in rows:
        fields = _trim(fields, width)
        if len(fields) != width:
            span = "" if end == line else f" (the row runs to line {end}: an unclosed quote?)"
            raise DataError(f"{path}: line {line} has {len(fields)} fields but the "
                            f"header has {width}{span}")
        for name, i in pairs:
            values.append(_number(path, line, name, fields[i], sep != ","))
    if not values:
        raise DataError(f"{path}: no data rows after the header")
    arr = np.frombuffer(values, dtype=np.float64).reshape(-1, len(names))
    return arr.copy() if not arr.flags.writeable else arr, header


def time_column(header: Sequence[str], taken: Sequence[str] = ()) -> Optional[str]:
    """The header's time column, if any: the first field not in ``taken``
    named ``t`` or with ``time`` in its name (``time``, ``Time (s)``,
    ``sampling_time``, ``timestamp``; case ignored)."""
    for h in header:
        k = h.strip().lower()
        if h not in taken and (k == "t" or "time" in k):
            return h
    return None


#: a time step over this many times the median is a gap (samples missing)
GAP_FACTOR = 1.5


def sampling_message(t: np.ndarray, name: str) -> str:
    """A sentence when the time column ``t`` (named ``name``) says the
    samples are not consecutive and evenly spaced, which NARX lags assume:
    a step that is not positive (rows out of order, or records joined), or
    steps over :data:`GAP_FACTOR` times the median (samples missing); ''
    when the sampling is even."""
    t = np.asarray(t, dtype=float)
    if t.size < 3:
        return ""
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        i = int(bad[0])
        return (f"column {name!r} does not increase at data row {i + 2} ({t[i]:g} then "
                f"{t[i + 1]:g}; {bad.size} such step(s)): the rows may be out of order or "
                f"several records joined, and a model's lags assume consecutive samples")
    med = float(np.median(dt))
    gaps = np.flatnonzero(dt > GAP_FACTOR * med)
    if not gaps.size:
        return ""
    i = int(gaps[np.argmax(dt[gaps])])
    return (f"column {name!r} has {gaps.size} gap(s) in its sampling (step {med:g}; the "
            f"largest {dt[i]:g}, {dt[i] / med:.3g} steps, after data row {i + 1}): samples "
            f"are missing there, and a model's lags across a gap mix samples that are not "
            f"one step apart; fit the stretches between gaps separately, or fill them")


def read_csv(path, inputs: Optional[Sequence[str]] = None, output: Optional[str] = "y",
             *, min_samples: int = 2, varying_inputs: bool = False,
             purpose: str = "", varying_output: str = "") -> Data:
    """Read a record; ``output=None`` reads inputs only. A time column
    (:func:`time_column`) is read too, and a warning names a sampling that
    is not even (:func:`sampling_message`).

    Parameters
    ----------
    path : str or os.PathLike
    inputs : sequence of str, optional
        Input column names (default ``['u']``).
    output : str or None
        Output column name (default ``'y'``); None reads no output.
    min_samples : int
        Fewer data rows raise :class:`DataError`.
    varying_inputs : bool
        Reject an input column that holds one value on every row (nothing
        can be identified from it); simulation accepts it.
    purpose : str
        Said in the too-few-rows message (e.g. ``"for lags up to 16"``).
    varying_output : str
        If given, reject an output column that holds one value on every row
        (:meth:`narx.records.data.Data.require_varying_output`, as
        :meth:`mggp.MGGPRegressor.fit` does); the text says why.
    """
    inputs = ["u"] if inputs is None else ([inputs] if isinstance(inputs, str) else list(inputs))
    names = inputs + ([output] if output else [])
    tcol = None
    try:
        _, header = next(iter_rows(path))
        tcol = time_column([h.strip() for h in header], names)
    except Exception:                             # read_columns below says what is wrong
        pass
    try:
        try:
            arr, _ = read_columns(path, names + ([tcol] if tcol else []))
        except DataError as exc:                  # a time column of text: not checked
            if tcol is None or f"column {tcol!r}:" not in str(exc):
                raise
            tcol = None
            arr, _ = read_columns(path, names)
    except DataError as exc:
        if exc.column is not None:                # which signal the missing column holds
            exc.role = "output" if exc.column == output else "input"
        raise
    said = ""
    if tcol is not None:                          # said once the record is accepted
        said = sampling_message(arr[:, -1], tcol)
        arr = arr[:, :-1]
    n = arr.shape[0]
    if n < min_samples:
        raise DataError(f"{os.fspath(path)}: {n} data row(s); at least {min_samples} are "
                        f"needed{' ' + purpose if purpose else ''}")
    m = len(inputs)
    if varying_inputs:
        for j, name in enumerate(inputs):
            col = arr[:, j]
            if n > 1 and col.min() == col.max():
                raise DataError(f"{os.fspath(path)}: input {name!r} is constant (column "
                                f"{name!r} holds {col[0]:g} on all {n} data rows): an "
                                f"input must vary to identify a model")
    from ..language.terms import TermError
    try:
        data = Data(arr[:, :m], arr[:, m] if output else None, inputs=inputs,
                    output=output or "y")
    except TermError as exc:                      # a column name is no signal name
        raise DataError(f"{os.fspath(path)}: {exc}") from None
    if varying_output:
        try:
            data.require_varying_output(varying_output)
        except DataError as exc:
            raise DataError(f"{os.fspath(path)}: {exc}") from None
    if said:
        warnings.warn(f"{os.fspath(path)}: {said}", UserWarning, stacklevel=2)
    return data


def write_with_column(src, dst, name: str, values: np.ndarray) -> None:
    """Copy CSV ``src`` to ``dst`` (atomically, streaming) adding a column,
    with ``src``'s field separator."""
    sep = delimiter(src)
    comma = None                              # decimal commas in the source?
    with atomic_writer(dst, newline="") as fh:
        w = csv.writer(fh, delimiter=sep)
        rows = iter_rows(src, sep)
        _, header = next(rows)
        header = [h.strip() for h in header]
        while len(header) > 1 and not header[-1]:     # trailing separators
            header.pop()
        w.writerow(header + [name])
        width = len(header)
        for i, (_, fields) in enumerate(rows):
            v = values[i]
            fields = _trim(fields, width)
            if comma is None:
                comma = sep != "," and any(re.fullmatch(r"\s*[-+]?\d*,\d+([eE][-+]?\d+)?\s*", f)
                                           for f in fields)
            text = "" if not np.isfinite(v) else repr(float(v))
            w.writerow(fields + [text.replace(".", ",") if comma else text])
