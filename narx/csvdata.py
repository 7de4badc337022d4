"""Read measured records from CSV files, with one-line errors.

Typical use::

    from narx.csvdata import read_csv
    data = read_csv("DATA.csv")                               # columns u, y
    data = read_csv("damper.csv", inputs=["v", "E"], output="f")
    data = read_csv("ref.csv", inputs=["r"], output=None)     # no output

The file has a header row; the named columns must each appear once and hold
finite numbers on every data row; other columns are ignored (their content
is not checked), blank lines are skipped, rows must all have the header's
number of fields. Every problem raises :class:`~narx.data.DataError` with
the file, the line (1-based, header = line 1), the column and the rule.
"""
from __future__ import annotations

import csv
import math
import os
from typing import Iterator, List, Optional, Sequence, Tuple

import numpy as np

from .atomic import atomic_writer
from .data import Data, DataError

__all__ = ["read_csv", "read_columns", "iter_rows", "write_with_column"]

MAX_FIELD = 1 << 20


def iter_rows(path) -> Iterator[Tuple[int, List[str]]]:
    """Yield (line number, fields) of non-blank rows, header included."""
    path = os.fspath(path)
    csv.field_size_limit(MAX_FIELD)
    try:
        fh = open(path, newline="", encoding="utf-8-sig")
    except OSError as exc:
        raise DataError(f"{path}: cannot read file ({exc.strerror})") from None
    with fh:
        reader = csv.reader(fh)
        try:
            for fields in reader:
                if not fields or all(not f.strip() for f in fields):
                    continue
                yield reader.line_num, fields
        except UnicodeDecodeError:
            raise DataError(f"{path}: not UTF-8 text (near line {reader.line_num + 1})") from None
        except csv.Error as exc:
            raise DataError(f"{path}: line {reader.line_num}: malformed CSV ({exc})") from None


def _number(path, line, col, text) -> float:
    s = text.strip()
    try:
        v = float(s)
    except ValueError:
        shown = s if len(s) <= 40 else s[:37] + "..."
        raise DataError(f"{path}: line {line}, column {col!r}: {shown!r} is not a number") from None
    if not math.isfinite(v):
        raise DataError(f"{path}: line {line}, column {col!r}: value {s!r} is not finite "
                        f"(NaN and inf are not allowed)")
    return v


def read_columns(path, names: Sequence[str]) -> Tuple[np.ndarray, List[str]]:
    """Read the named columns as a float array (N, len(names)) and the header."""
    path = os.fspath(path)
    rows = iter_rows(path)
    try:
        line, header = next(rows)
    except StopIteration:
        raise DataError(f"{path}: empty file (no header row)") from None
    header = [h.strip() for h in header]
    idx = []
    for name in names:
        hits = [i for i, h in enumerate(header) if h == name]
        if not hits:
            shown = ", ".join(h for h in header if h) or "(none)"
            raise DataError(f"{path}: no column {name!r} (columns: {shown})")
        if len(hits) > 1:
            raise DataError(f"{path}: column {name!r} appears {len(hits)} times in the "
                            f"header (fields {', '.join(str(i + 1) for i in hits)})")
        idx.append(hits[0])
    if len(set(names)) != len(names):
        raise DataError(f"{path}: the same column is named twice among {list(names)}")
    width = len(header)
    out: List[List[float]] = []
    for line, fields in rows:
        if len(fields) != width:
            raise DataError(f"{path}: line {line} has {len(fields)} fields but the "
                            f"header has {width}")
        out.append([_number(path, line, names[j], fields[i]) for j, i in enumerate(idx)])
    if not out:
        raise DataError(f"{path}: no data rows after the header")
    return np.asarray(out, dtype=np.float64).reshape(len(out), len(names)), header


def read_csv(path, inputs: Optional[Sequence[str]] = None, output: Optional[str] = "y",
             *, min_samples: int = 2) -> Data:
    """Read a record; ``output=None`` reads inputs only."""
    inputs = ["u"] if inputs is None else ([inputs] if isinstance(inputs, str) else list(inputs))
    names = inputs + ([output] if output else [])
    arr, _ = read_columns(path, names)
    if arr.shape[0] < min_samples:
        raise DataError(f"{os.fspath(path)}: {arr.shape[0]} data row(s); at least "
                        f"{min_samples} are needed")
    m = len(inputs)
    return Data(arr[:, :m], arr[:, m] if output else None, inputs=inputs,
                output=output or "y")


def write_with_column(src, dst, name: str, values: np.ndarray) -> None:
    """Copy CSV ``src`` to ``dst`` (atomically, streaming) adding a column."""
    with atomic_writer(dst, newline="") as fh:
        w = csv.writer(fh)
        rows = iter_rows(src)
        _, header = next(rows)
        w.writerow([h.strip() for h in header] + [name])
        for i, (_, fields) in enumerate(rows):
            v = values[i]
            w.writerow(fields + ["" if not np.isfinite(v) else repr(float(v))])
