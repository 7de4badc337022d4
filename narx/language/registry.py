"""The base of the registries of named built-ins and user plug-ins.

:class:`narx.language.phi.PhiRegistry` (Φ-functions) and
:class:`narx.language.memory.OperatorRegistry` (memory operators) hold their entries
by name; built-ins (entries whose ``builtin`` is true) are always there and
can be neither replaced nor removed. This class holds the lookups and the
rules they share; each registry adds its own ``register``. Typical use::

    reg = narx.PhiRegistry()              # a NamedRegistry of Φ-functions
    reg.register("Abs", 1, np.abs, steady=np.abs)
    "Abs" in reg, reg.get("Phi1").builtin   # (True, True)
"""
from __future__ import annotations

from typing import Dict, Iterator

__all__ = ["NamedRegistry"]


class NamedRegistry:
    """Mapping name -> entry with built-ins that stay; ``what`` names an
    entry in messages (``"Φ-function"``, ``"memory operator"``)."""

    what = "entry"

    def __init__(self, builtins=()):
        self._items: Dict[str, object] = {e.name: e for e in builtins}

    def _add(self, entry, overwrite: bool):
        """Store a new plug-in and return it; ``ValueError`` when its name
        is taken by a built-in, or by a plug-in and ``overwrite`` is false."""
        old = self._items.get(entry.name)
        if old is not None and (old.builtin or not overwrite):
            raise ValueError(f"{self.what} {entry.name!r} is already registered"
                             + ("" if old.builtin else " (pass overwrite=True to replace it)"))
        self._items[entry.name] = entry
        return entry

    def unregister(self, name: str) -> None:
        """Remove a plug-in (``KeyError`` if unknown, ``ValueError`` for a built-in)."""
        if self.get(name).builtin:
            raise ValueError(f"cannot unregister built-in {self.what} {name!r}")
        del self._items[name]

    def get(self, name: str):
        try:
            return self._items[name]
        except KeyError:
            raise KeyError(f"unknown {self.what} {name!r} (registered: "
                           f"{', '.join(sorted(self._items))})") from None

    def __contains__(self, name) -> bool:
        return name in self._items

    def __iter__(self) -> Iterator[str]:
        return iter(sorted(self._items))

    def names(self):
        return sorted(self._items)

    def user_entries(self):
        """The plug-ins, in registration order."""
        return [e for e in self._items.values() if not e.builtin]

    def snapshot(self):
        """An independent copy (shipped to worker processes)."""
        return type(self)(self.user_entries())
