"""Model files: JSON in, JSON out, nothing executed.

Typical use::

    from narx.modelio import save_model, load_model
    save_model(model, "model.json")
    model = load_model("model.json")

A model file holds ``{"output": "y", "inputs": ["u"], "terms": [TERM, ...],
"theta": [number, ...]}`` plus metadata (``format``, ``version``, ``meta``:
fitness mode, seed, package versions). Loading parses JSON with the standard
library and each term with the term parser (:mod:`narx.terms`), which
never evaluates text; every problem raises :class:`ModelFileError` naming
the file, the key and the rule. Saving is atomic (temporary file, then
``os.replace``), so an interrupted save never leaves a half-written file.
"""
from __future__ import annotations

import json
import math
import os

from .atomic import atomic_write_text
from .terms import TermError

__all__ = ["ModelFileError", "model_to_dict", "model_from_dict", "save_model",
           "load_model", "atomic_write_text", "FORMAT"]

FORMAT = "mggp-narx-model"
MAX_BYTES = 20 * 2**20


class ModelFileError(ValueError):
    """A model file that cannot be loaded."""


def model_to_dict(model) -> dict:
    import numpy, scipy
    if model.theta is None:
        raise ValueError("cannot save a model without parameters: fit it or give theta")
    from . import __version__
    meta = dict(model.meta)
    meta.setdefault("versions", {"narx": __version__, "numpy": numpy.__version__,
                                 "scipy": scipy.__version__})
    return {"format": FORMAT, "version": 1, "output": model.output,
            "inputs": list(model.inputs), "noise": model.signals.noise,
            "terms": model.term_texts,
            "theta": None if model.theta is None else [float(v) for v in model.theta],
            "meta": meta}


def _fail(source, msg):
    raise ModelFileError(f"{source}: {msg}")


def model_from_dict(d, source: str = "model", registry=None):
    from .model import Model
    if not isinstance(d, dict):
        _fail(source, f"top level must be a JSON object, got {type(d).__name__}")
    for key in ("output", "inputs", "terms", "theta"):
        if key not in d:
            _fail(source, f"missing key {key!r}")
    out, inputs, terms, theta = d["output"], d["inputs"], d["terms"], d["theta"]
    if not isinstance(out, str):
        _fail(source, f"'output' must be a string, got {json.dumps(out)[:60]}")
    if isinstance(inputs, str):
        inputs = [inputs]
    if not isinstance(inputs, list) or not inputs or not all(isinstance(s, str) for s in inputs):
        _fail(source, f"'inputs' must be a non-empty list of strings, got {json.dumps(inputs)[:60]}")
    if not isinstance(terms, list) or not terms or not all(isinstance(s, str) for s in terms):
        _fail(source, f"'terms' must be a non-empty list of strings, got {json.dumps(terms)[:60]}")
    if not isinstance(theta, list) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in theta):
        _fail(source, f"'theta' must be a list of numbers, got {json.dumps(theta)[:60]}")
    def finite(v):
        try:
            return math.isfinite(v)
        except OverflowError:
            return False
    bad = [i for i, v in enumerate(theta) if not finite(v)]
    if bad:
        _fail(source, f"'theta'[{bad[0]}] is not finite ({theta[bad[0]]})")
    if len(theta) != len(terms):
        _fail(source, f"'theta' has {len(theta)} values but 'terms' has {len(terms)}")
    noise = d.get("noise", "e")
    if not isinstance(noise, str):
        _fail(source, f"'noise' must be a string, got {json.dumps(noise)[:60]}")
    meta = d.get("meta", {})
    if not isinstance(meta, dict):
        _fail(source, f"'meta' must be an object, got {type(meta).__name__}")
    try:
        return Model(terms, theta, inputs=inputs, output=out, noise=noise, meta=meta,
                     registry=registry)
    except (TermError, ValueError) as exc:
        _fail(source, str(exc))


def save_model(model, path) -> None:
    atomic_write_text(path, json.dumps(model_to_dict(model), indent=2) + "\n")


def load_model(path, registry=None):
    path = os.fspath(path)
    try:
        size = os.path.getsize(path)
    except OSError as exc:
        raise ModelFileError(f"{path}: cannot read model file ({exc.strerror})") from None
    if size > MAX_BYTES:
        _fail(path, f"file is {size} bytes, over the {MAX_BYTES}-byte limit")
    def no_duplicates(pairs):
        keys = [k for k, _ in pairs]
        dup = next((k for k in keys if keys.count(k) > 1), None)
        if dup is not None:
            _fail(path, f"key {dup!r} appears more than once")
        return dict(pairs)
    try:
        with open(path, encoding="utf-8") as fh:
            d = json.load(fh, object_pairs_hook=no_duplicates,
                          parse_constant=lambda c: _fail(
                              path, f"non-standard JSON constant {c}"))
    except UnicodeDecodeError:
        _fail(path, "not UTF-8 text")
    except json.JSONDecodeError as exc:
        _fail(path, f"invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}")
    except RecursionError:
        _fail(path, "JSON nested too deeply")
    except OSError as exc:
        _fail(path, f"cannot read model file ({exc.strerror or exc})")
    return model_from_dict(d, path, registry)
