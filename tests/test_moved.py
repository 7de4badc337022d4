"""The module paths from before the subpackages still import, for one release.

Each old path warns (DeprecationWarning naming the new one) and gives the
very module of its new path; a module that became a package hands its old
names on with the same warning. The package faces (``from mggp import
MGGPRegressor``, ``import narx``) do not warn, and no module of the project
imports an old path (each is imported alone with the warning an error).
"""
import importlib
import subprocess
import sys

import pytest

import mggp
import narx

OLD_PATHS = sorted({**mggp.MOVED, **narx.MOVED}.items())

#: modules that became packages of the same name: (old module, new module, a name it held)
OLD_PACKAGES = [("mggp.cli", "mggp.cli.app", "main"),
                ("mggp.cli", "mggp.cli.app", "build_parser"),
                ("mggp.report", "mggp.report.summary", "write_fit_report")]


@pytest.mark.parametrize("old,new", OLD_PATHS)
def test_old_path_warns_and_is_the_new_module(old, new):
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=rf"{old} is deprecated.*import {new}$"):
        module = importlib.import_module(old)
    assert module is importlib.import_module(new)
    assert module.__spec__.name == new                 # its own spec, not the old path's


@pytest.mark.parametrize("old,new,name", OLD_PACKAGES)
def test_old_module_names_come_from_the_package(old, new, name):
    package = importlib.import_module(old)
    vars(package).pop(name, None)
    with pytest.warns(DeprecationWarning, match=rf"{old}.{name} is deprecated"):
        value = getattr(package, name)
    assert value is getattr(importlib.import_module(new), name)
    with pytest.raises(AttributeError):
        package.no_such_name


def test_no_old_path_is_used_by_the_project():
    """The faces and every module of the project import without a deprecation warning."""
    code = ("import importlib, pkgutil, mggp, narx\n"
            "from mggp import MGGPRegressor\n"
            "from narx import Model\n"
            "for pkg in (narx, mggp):\n"
            "    for m in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + '.'):\n"
            "        if not m.name.endswith('__main__'):\n"
            "            importlib.import_module(m.name)\n")
    res = subprocess.run([sys.executable, "-W", "error::DeprecationWarning", "-c", code],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr[-2000:]


def test_an_unknown_old_looking_path_still_fails():
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("mggp.no_such_module")
