"""Model files: the JSON format, checked field by field, nothing executed.

Typical use (through :class:`narx.Model` and :func:`narx.load_model`)::

    from narx import load_model, save_model
    save_model(model, "model.json")
    model = load_model("model.json")

This module holds the file format without the model class: it turns a
model into the dict of its file (:func:`model_to_dict`) and back into the
checked arguments of :class:`narx.Model` (:func:`model_fields`), and reads a
file's JSON under the limits below (:func:`read_model_json`);
:mod:`narx.model` builds the model from them.

A model file holds ``{"output": "y", "inputs": ["u"], "terms": [TERM, ...],
"theta": [number, ...]}`` plus metadata (``format``, ``version``, ``meta``:
fitness mode, seed, package versions, and ``ranges``: the training range
``[low, high]`` of each signal, :mod:`narx.records.ranges`; a file without it
loads, and its models warn of no record). Loading parses JSON with the standard
library and each term with the term parser (:mod:`narx.language.terms`), which
never evaluates text; every problem raises :class:`ModelFileError` naming
the file, the key (``'terms'[3]``) and the rule. Saving is atomic
(temporary file, then ``os.replace``), so an interrupted save never leaves a
half-written file.

Hostile files are bounded before any work is done: at most ``MAX_BYTES``
bytes, ``MAX_TERMS`` terms of at most ``MAX_TERM_CHARS`` characters and
``MAX_DEGREE`` factors, integers of at most ``MAX_DIGITS`` digits, lags up
to :data:`narx.language.terms.MAX_LAG`; nesting too deep for the JSON parser is an
error, not a crash. Nothing in a file is ever evaluated or imported.
"""
from __future__ import annotations

import json
import math
import os

from .atomic import atomic_write_text
from .exceptions import ModelFileError, TermError
from .language.phi import default_registry
from .language.terms import Signals, parse_term
from .version import __version__

__all__ = ["ModelFileError", "model_to_dict", "model_fields", "model_json",
           "read_model_json", "fail", "atomic_write_text", "FORMAT"]

FORMAT = "mggp-narx-model"
#: newest model-file version this code reads and the one it writes
VERSION = 1
#: the keys of a model file (``format``, ``version``, ``noise``, ``meta``
#: optional, so a hand-written file needs only the other four)
KEYS = ("format", "version", "output", "inputs", "noise", "terms", "theta", "meta")
MAX_BYTES = 20 * 2**20
MAX_TERMS = 256
MAX_TERM_CHARS = 1000
MAX_DEGREE = 64
MAX_DIGITS = 400


def model_to_dict(model) -> dict:
    """The dict of ``model``'s file (``ValueError`` without parameters)."""
    import numpy, scipy
    if model.theta is None:
        raise ValueError("cannot save a model without parameters: fit it or give theta")
    meta = dict(model.meta)
    meta.setdefault("versions", {"narx": __version__, "numpy": numpy.__version__,
                                 "scipy": scipy.__version__})
    return {"format": FORMAT, "version": VERSION, "output": model.output,
            "inputs": list(model.inputs), "noise": model.signals.noise,
            "terms": model.term_texts,
            "theta": None if model.theta is None else [float(v) for v in model.theta],
            "meta": _plain(meta)}


def _plain(v):
    """``v`` with non-finite floats as the strings 'inf', '-inf', 'nan' (a
    file must be standard JSON) and numpy scalars and tuples as plain ones."""
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if hasattr(v, "item") and callable(v.item) and getattr(v, "ndim", 1) == 0:
        v = v.item()                                   # numpy scalar
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if v != v else ("inf" if v > 0 else "-inf")
    return v


def fail(source, msg):
    """Raise :class:`ModelFileError` ``'<source>: <msg>'``."""
    raise ModelFileError(f"{source}: {msg}")


def _show(v, n=60) -> str:
    """Short JSON text of a value (type name if it cannot be shown)."""
    try:
        text = json.dumps(v)
    except (TypeError, ValueError, RecursionError):
        return type(v).__name__
    return text if len(text) <= n else text[:n - 3] + "..."


def _finite(v) -> bool:
    try:
        return math.isfinite(v)
    except OverflowError:
        return False


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _parse_terms(source, terms, signals, registry):
    """Parse each term text, naming ``'terms'[i]`` in any error."""
    reg = registry or default_registry()
    out, seen = [], {}
    for i, text in enumerate(terms):
        where = f"'terms'[{i}]"
        if not isinstance(text, str):
            fail(source, f"'terms' must be a non-empty list of strings: {where} is "
                          f"{_show(text)}")
        if len(text) > MAX_TERM_CHARS:
            fail(source, f"{where} is {len(text)} characters long, more than the "
                          f"{MAX_TERM_CHARS} allowed")
        try:
            t = parse_term(text, signals, registry=reg)
        except (TermError, ValueError) as exc:
            fail(source, f"{where}: {exc}")
        if t.degree > MAX_DEGREE:
            fail(source, f"{where} has {t.degree} factors, more than the {MAX_DEGREE} "
                          "allowed")
        if t in seen:
            fail(source, f"{where}: term {str(t)!r} appears twice ('terms'[{seen[t]}] "
                          f"and {where})")
        seen[t] = i
        out.append(t)
    return out


def model_fields(d, source: str = "model", registry=None) -> dict:
    """The keyword arguments of :class:`narx.Model` from the dict of a model
    file, every field checked (:class:`ModelFileError` names the first bad
    one)."""
    if not isinstance(d, dict):
        fail(source, f"top level must be a JSON object, got {type(d).__name__}")
    for key in ("output", "inputs", "terms", "theta"):
        if key not in d:
            fail(source, f"missing key {key!r}")
    unknown = [k for k in d if k not in KEYS]
    if unknown:
        fail(source, f"unknown key {_show(unknown[0], 40)} (a model file has "
                      f"{', '.join(KEYS)})")
    if "format" in d and d["format"] != FORMAT:
        fail(source, f"'format' must be {FORMAT!r}, got {_show(d['format'], 40)}")
    if "version" in d and not (_is_number(d["version"]) and d["version"] in range(1, VERSION + 1)):
        fail(source, f"unsupported 'version' {_show(d['version'], 20)} (this mggp reads "
                      f"versions 1 to {VERSION}; a newer mggp wrote it?)")
    out, inputs, terms, theta = d["output"], d["inputs"], d["terms"], d["theta"]
    if not isinstance(out, str):
        fail(source, f"'output' must be a string, got {_show(out)}")
    if isinstance(inputs, str):
        inputs = [inputs]
    if not isinstance(inputs, list) or not inputs:
        fail(source, f"'inputs' must be a non-empty list of strings, got {_show(inputs)}")
    for i, name in enumerate(inputs):
        if not isinstance(name, str):
            fail(source, f"'inputs' must be a non-empty list of strings: 'inputs'[{i}] "
                          f"is {_show(name)}")
    if not isinstance(terms, list) or not terms:
        fail(source, f"'terms' must be a non-empty list of strings, got {_show(terms)}")
    if len(terms) > MAX_TERMS:
        fail(source, f"'terms' has {len(terms)} entries, more than the {MAX_TERMS} allowed")
    if not isinstance(theta, list):
        fail(source, f"'theta' must be a list of numbers, got {_show(theta)}")
    for i, v in enumerate(theta):
        if not _is_number(v):
            fail(source, f"'theta' must be a list of numbers: 'theta'[{i}] is {_show(v)}")
        if not _finite(v):
            fail(source, f"'theta'[{i}] is not finite ({_show(v, 30)})")
    if len(theta) != len(terms):
        fail(source, f"'theta' has {len(theta)} values but 'terms' has {len(terms)}")
    noise = d.get("noise", "e")
    if not isinstance(noise, str):
        fail(source, f"'noise' must be a string, got {_show(noise)}")
    meta = d.get("meta", {})
    if not isinstance(meta, dict):
        fail(source, f"'meta' must be an object, got {type(meta).__name__}")
    for key, name in [("output", out), ("noise", noise)] + [
            (f"inputs'[{i}", n) for i, n in enumerate(inputs)]:
        if name.startswith("__"):
            fail(source, f"'{key}': signal name {_show(name, 30)} must not start with '__'")
    try:
        signals = Signals(out, tuple(inputs), noise)
    except (TermError, ValueError) as exc:
        fail(source, f"'output'/'inputs'/'noise': {exc}")
    _check_ranges(source, meta.get("ranges"), [out] + list(inputs))
    parsed = _parse_terms(source, terms, signals, registry)
    return dict(terms=parsed, theta=theta, inputs=inputs, output=out, noise=noise,
                meta=meta, registry=registry)


def _check_ranges(source, ranges, names) -> None:
    """``meta['ranges']``, the training range of each signal
    (:func:`narx.records.ranges.signal_ranges`): absent (an older file, or one
    written by hand), or an object whose keys are among the model's signal
    ``names`` and whose values are ``[low, high]``, two finite numbers with
    low <= high."""
    if ranges is None:
        return
    where = "'meta'.'ranges'"
    if not isinstance(ranges, dict):
        fail(source, f"{where} must be an object {{signal: [low, high]}}, got "
                      f"{_show(ranges)}")
    for name, v in ranges.items():
        if name not in names:
            fail(source, f"{where}: {_show(name, 30)} is no signal of the model (its "
                          f"signals are {', '.join(names)})")
        if not (isinstance(v, list) and len(v) == 2 and all(_is_number(x) and _finite(x)
                                                           for x in v) and v[0] <= v[1]):
            fail(source, f"{where}.{_show(name, 30)} must be [low, high], two finite "
                          f"numbers with low <= high, got {_show(v)}")


def model_json(model) -> str:
    """The text of ``model``'s file (standard JSON, indented)."""
    return json.dumps(model_to_dict(model), indent=2, allow_nan=False) + "\n"


def read_model_json(path) -> dict:
    """The JSON object of a model file, read under the size, digit and
    nesting limits; any problem raises :class:`ModelFileError`."""
    path = os.fspath(path)
    try:
        size = os.path.getsize(path)
    except OSError as exc:
        raise ModelFileError(f"{path}: cannot read model file ({exc.strerror})") from None
    if size > MAX_BYTES:
        fail(path, f"file is {size} bytes, over the {MAX_BYTES}-byte limit")

    def no_duplicates(pairs):
        seen = set()
        for k, _ in pairs:
            if k in seen:
                fail(path, f"key {_show(k, 40)} appears more than once in an object")
            seen.add(k)
        return dict(pairs)

    def integer(text):
        if len(text.lstrip("-")) > MAX_DIGITS:
            fail(path, f"an integer of {len(text.lstrip('-'))} digits (at most "
                        f"{MAX_DIGITS} are accepted)")
        return int(text)
    try:
        with open(path, encoding="utf-8") as fh:
            d = json.load(fh, object_pairs_hook=no_duplicates, parse_int=integer,
                          parse_constant=lambda c: fail(
                              path, f"non-standard JSON constant {c}"))
    except UnicodeDecodeError:
        fail(path, "not UTF-8 text")
    except json.JSONDecodeError as exc:
        fail(path, f"invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}")
    except RecursionError:
        fail(path, "JSON nested too deeply")
    except OSError as exc:
        fail(path, f"cannot read model file ({exc.strerror or exc})")
    except ModelFileError:
        raise
    except ValueError as exc:                      # e.g. a number Python cannot hold
        fail(path, f"invalid JSON ({' '.join(str(exc).split())[:120]})")
    return d
