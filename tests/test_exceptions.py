"""narx.exceptions holds every exception and warning class of narx, once;
the modules that raise them re-export the same objects."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

import narx
import narx.exceptions as ex

ROOT = Path(__file__).resolve().parents[1]

#: where each class was importable from before it moved, and still is
WHERE = {"TermError": ["narx.language.terms"], "DataError": ["narx.records.data"],
         "EstimationError": ["narx.estimation.estimate"], "ModelFileError": ["narx.modelio",
                                                                  "narx.model"],
         "RankWarning": ["narx.model"],
         "NonMinimumPhaseWarning": ["narx.analysis.inverse_check", "narx.analysis.compensate"],
         "ExtrapolationWarning": ["narx.records.ranges"],
         "SeedLeakError": ["narx.systems.zoo"]}


def _defined_classes(path):
    """Names of the classes a file defines that derive from an exception or
    a warning (by the base's name)."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ClassDef):
            bases = [b.id if isinstance(b, ast.Name) else getattr(b, "attr", "")
                     for b in node.bases]
            if any(b.endswith(("Error", "Warning", "Exception")) for b in bases):
                out.append(node.name)
    return out


def test_every_class_is_listed_and_defined_in_exceptions():
    assert sorted(ex.__all__) == sorted(WHERE)
    for name in ex.__all__:
        cls = getattr(ex, name)
        assert cls.__module__ == "narx.exceptions"
        assert issubclass(cls, ValueError if name.endswith("Error") else UserWarning)
        assert getattr(narx, name) is cls


@pytest.mark.parametrize("name", sorted(WHERE))
def test_old_import_paths_give_the_same_class(name):
    import importlib
    for mod in WHERE[name]:
        assert getattr(importlib.import_module(mod), name) is getattr(ex, name), mod


def test_no_other_narx_module_defines_an_exception():
    found = {str(p.relative_to(ROOT / "narx")): _defined_classes(p)
             for p in (ROOT / "narx").rglob("*.py")}
    assert sorted(found.pop("exceptions.py")) == sorted(ex.__all__)   # control: finds them
    assert {k: v for k, v in found.items() if v} == {}
