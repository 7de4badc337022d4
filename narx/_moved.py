"""Old module paths that moved, kept for one release with a DeprecationWarning.

A package lists its moved modules as ``{old path: new path}`` and installs a
finder for them; a module that became a package of the same name hands its
old names on through the package's ``__getattr__``. Typical use (in a
package's ``__init__.py``)::

    from narx._moved import install
    install({"narx.simulate": "narx.simulation.simulate"})

``import narx.simulate`` then warns ``narx.simulate is deprecated: import
narx.simulation.simulate`` and binds the very module object of the new
path, so its functions, classes and constants are the same objects. No file
stands at an old path: git follows each move as a rename.
"""
from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import pkgutil
import sys
import types
import warnings

__all__ = ["install", "moved_spec", "moved_attribute", "warn_moved", "keep_functions"]


def warn_moved(old: str, new: str, stacklevel: int = 3) -> None:
    """Warn that ``old`` is deprecated and name ``new``."""
    warnings.warn(f"{old} is deprecated and goes in the next release: import {new}",
                  DeprecationWarning, stacklevel=stacklevel)


class _Loader(importlib.abc.Loader):
    def __init__(self, old: str, new: str):
        self.old, self.new = old, new

    def create_module(self, spec):
        warn_moved(self.old, self.new)   # importlib's own frames are not counted
        module = importlib.import_module(self.new)
        self.spec = module.__spec__                    # importlib sets the old one
        return module

    def exec_module(self, module):                     # the new module has run already:
        module.__spec__ = self.spec                    # give it its own spec back


def moved_spec(old: str, new: str):
    """The module spec that binds the old path ``old`` to the module ``new``."""
    return importlib.util.spec_from_loader(old, _Loader(old, new))


class _Finder(importlib.abc.MetaPathFinder):
    def __init__(self, table: dict):
        self.table = table

    def find_spec(self, name, path=None, target=None):
        new = self.table.get(name)
        return None if new is None else moved_spec(name, new)


def install(table: dict) -> None:
    """Let every old path of ``table`` (``{old: new}``) import its new module."""
    sys.meta_path.insert(0, _Finder(table))   # before any finder of an installed copy


def moved_attribute(old: str, new: str, name: str):
    """Attribute ``name`` of the module ``old``, now a package: read from ``new``
    with a warning (for the package's ``__getattr__``)."""
    package = sys.modules[old]
    if name.startswith("__") or name in {m.name for m in pkgutil.iter_modules(package.__path__)}:
        raise AttributeError(f"module {old!r} has no attribute {name!r}")
    module = importlib.import_module(new)
    if not hasattr(module, name):
        raise AttributeError(f"module {old!r} has no attribute {name!r}")
    warn_moved(f"{old}.{name}", f"{new}.{name}", stacklevel=4)
    value = getattr(module, name)
    setattr(package, name, value)                      # warned once: now a plain name
    return value


class _Face(types.ModuleType):
    """A package whose functions no module binds over (see :func:`keep_functions`)."""

    def __setattr__(self, name, value):
        old = self.__dict__.get(name)
        if isinstance(value, types.ModuleType) and callable(old) \
                and not isinstance(old, types.ModuleType):
            return
        super().__setattr__(name, value)

    def __reduce__(self):                              # pickled by name, as a module is
        return importlib.import_module, (self.__name__,)


def keep_functions(package: str) -> None:
    """Keep the functions of ``package`` that share a name with a moved module
    (``narx.simulate``): importing the old path binds the module on its
    parent, which would hide the function."""
    sys.modules[package].__class__ = _Face
