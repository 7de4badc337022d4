"""Φ-functions: the table of built-ins, their compiled value, user plug-ins.

A Φ-function is a named, vectorised function of lagged signals that can
appear as a factor of a NARX term, e.g. ``Phi1(u[k-1],u[k-2])``. The
built-ins are the ones of the published hysteresis models [1]_:

.. math::

    \\Phi_1(a, b) = a - b, \\qquad \\Phi_2(a, b) = \\operatorname{sign}(a - b).

They form one table, :data:`BUILTINS`, that every part of :mod:`narx` reads:
a row gives the name, the kernel code, the arity, the vectorised numpy
function, the steady value, the *form* and what the function computes. The
form tells compensation and the inverse check how the function depends on
an argument: ``"difference"`` (:math:`a - b`, linear in each argument),
``"sign"`` (:math:`\\operatorname{sign}(a - b)`, constant on each side of
its breakpoint) or ``None`` (neither). Every compiled kernel evaluates a
built-in through the one function :func:`phi_value`, which computes the
row's numpy function of two floats bit for bit and raises ``ValueError`` on
a code not in the table.

Adding a compiled built-in is a row of :data:`BUILTINS` and a branch of
:func:`phi_value`. numba caches each kernel by its own source file, so the
compiled kernels keep the old :func:`phi_value` until their caches
(``narx/__pycache__/*.nbi``, ``*.nbc``) are deleted; the test that checks
every kernel against the table fails on such a stale cache.

Typical use, registering a plug-in whose argument is an output (the
``|h|`` regressor of a discretised Bouc-Wen model)::

    import numpy as np
    from narx import register_phi
    register_phi("Abs", arity=1, func=np.abs, steady=np.abs)
    # now "Phi1(u[k-1],u[k-2])*Abs(y[k-1])" is a valid term

``steady`` is the value of the function when all its arguments are equal
(the steady state with the signals held); a number, or a callable of that
common value when it depends on it. It is what steady-state analysis and the
derived CLS constraints use. A plug-in runs in numpy (no code, no form).

References
----------
.. [1] Abreu, P. E. O. G. B., Tavares, L. A., Teixeira, B. O. S., Aguirre,
   L. A., "Identification and nonlinearity compensation of hysteresis using
   NARX models", Nonlinear Dynamics, 2020.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Callable, Optional, Union

import numpy as np
from numba import njit

from .registry import NamedRegistry

__all__ = ["PhiFunction", "PhiRegistry", "register_phi", "unregister_phi",
           "get_phi", "default_registry", "BUILTINS", "BUILTIN_KERNEL_CODES",
           "phi_value", "builtin", "builtin_code", "check_codes", "FORMS"]

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")

#: forms of a built-in as compensation and the inverse check read them
FORMS = ("difference", "sign", None)


@dataclass(frozen=True)
class PhiFunction:
    """A Φ-function: name, arity, vectorised callable and steady value.

    Parameters
    ----------
    name : str
        Identifier used in term text (letters, digits, underscore).
    arity : int
        Number of lagged-signal arguments (>= 1).
    func : callable
        ``func(*arrays) -> array``, elementwise on float64 arrays.
    steady : float or callable
        Value when all arguments are equal: a number, or ``steady(x)`` of
        the common value ``x`` (vectorised).
    doc : str
        What the function computes.
    code : int or None
        Kernel code of a built-in (its branch of :func:`phi_value`); None
        for a plug-in.
    form : {'difference', 'sign', None}
        How the function depends on an argument (module docstring).
    """

    name: str
    arity: int
    func: Callable
    steady: Union[float, Callable]
    doc: str = ""
    code: Optional[int] = None
    form: Optional[str] = None

    @property
    def builtin(self) -> bool:
        """True for a row of :data:`BUILTINS` (compiled in every kernel)."""
        return self.code is not None

    @property
    def steady_is_constant(self) -> bool:
        return not callable(self.steady)

    def steady_value(self, x=None):
        """Value of the function with every argument equal to ``x``."""
        if callable(self.steady):
            return self.steady(x)
        return float(self.steady)

    def __call__(self, *args):
        return self.func(*args)


def _phi1(a, b):
    return np.subtract(a, b)


def _phi2(a, b):
    return np.sign(np.subtract(a, b))


#: the built-in Φ-functions, one row each; :func:`phi_value` computes
#: ``func`` of two floats for the row's code
BUILTINS = (
    PhiFunction("Phi1", 2, _phi1, 0.0, "difference a - b", code=1, form="difference"),
    PhiFunction("Phi2", 2, _phi2, 0.0, "sign of the difference a - b: +1, -1 or 0 "
                "(NaN stays NaN, as numpy.sign)", code=2, form="sign"),
)

#: built-in name -> kernel code
BUILTIN_KERNEL_CODES = {f.name: f.code for f in BUILTINS}
_BY_NAME = {f.name: f for f in BUILTINS}


@njit(cache=True, nogil=True)
def phi_value(code, a, b):
    """Value of the built-in of kernel ``code`` at ``(a, b)``.

    The one compiled dispatch of the built-ins: every kernel calls it, so
    each computes :data:`BUILTINS`' numpy functions bit for bit
    (:math:`\\Phi_1 = a - b`; :math:`\\Phi_2 = \\operatorname{sign}(a - b)`:
    +1, -1, +0, or NaN for NaN). Raises ``ValueError`` on any other code.
    """
    d = a - b
    if code == 1:
        return d
    if code == 2:
        # branch-free select, so the kernels' loops vectorise
        s = (1.0 if d > 0.0 else 0.0) - (1.0 if d < 0.0 else 0.0)
        return s if d == d else d
    raise ValueError("unknown built-in Φ-function code (narx.language.phi.BUILTINS)")


def builtin(name: str) -> Optional[PhiFunction]:
    """The row of :data:`BUILTINS` named ``name``, or None."""
    return _BY_NAME.get(name)


def builtin_code(name: str) -> Optional[int]:
    """Kernel code of the built-in ``name``; None for any other name."""
    f = _BY_NAME.get(name)
    return None if f is None else f.code


def check_codes(codes) -> None:
    """Raise ``ValueError`` unless every code is one of :data:`BUILTINS`."""
    known = {f.code for f in BUILTINS}
    bad = sorted({int(c) for c in np.ravel(codes)} - known)
    if bad:
        raise ValueError(f"unknown built-in Φ-function code(s) {bad}; the table "
                         f"narx.language.phi.BUILTINS has {sorted(known)}")


class PhiRegistry(NamedRegistry):
    """Mapping name -> :class:`PhiFunction`; the :data:`BUILTINS` are always there."""

    what = "Φ-function"

    def __init__(self, functions=None):
        super().__init__(BUILTINS)
        for f in (functions or ()):
            if f.builtin and f.name not in self._items:
                raise ValueError(f"Φ-function {f.name!r} has kernel code {f.code!r} but "
                                 f"is not in narx.language.phi.BUILTINS")
            if f.name not in self._items:
                self._items[f.name] = f

    def register(self, name: str, arity: int, func: Callable,
                 steady: Union[float, Callable], *, doc: str = "",
                 overwrite: bool = False) -> PhiFunction:
        """Register a user Φ-function and return it.

        Raises
        ------
        ValueError
            On an invalid name or arity, a non-callable ``func``, a steady
            value that is neither a number nor callable, or a clash with an
            existing function (unless ``overwrite``; built-ins never).
        """
        if not isinstance(name, str) or not _NAME.match(name):
            raise ValueError(f"Φ-function name must be an identifier "
                             f"(letters, digits, _; starting with a letter), "
                             f"got {name!r}")
        if name in ("k",):
            raise ValueError(f"Φ-function name {name!r} is reserved")
        if not isinstance(arity, (int, np.integer)) or isinstance(arity, bool) \
                or arity < 1:
            raise ValueError(f"arity must be an integer >= 1, got {arity!r}")
        if not callable(func):
            raise ValueError(f"func must be callable, got {type(func).__name__}")
        if not callable(steady):
            try:
                steady = float(steady)
            except (TypeError, ValueError):
                raise ValueError("steady must be a number or a callable, got "
                                 f"{steady!r}") from None
            if not np.isfinite(steady):
                raise ValueError(f"steady must be finite, got {steady!r}")
        return self._add(PhiFunction(name, int(arity), func, steady, doc), overwrite)

    def user_functions(self):
        return self.user_entries()


_DEFAULT = PhiRegistry()


def default_registry() -> PhiRegistry:
    """The process-wide registry used when no registry is passed."""
    return _DEFAULT


def register_phi(name: str, arity: int, func: Callable,
                 steady: Union[float, Callable], *, doc: str = "",
                 overwrite: bool = False,
                 registry: Optional[PhiRegistry] = None) -> PhiFunction:
    """Register a user Φ-function in ``registry`` (default: process-wide)."""
    return (registry or _DEFAULT).register(name, arity, func, steady, doc=doc,
                                           overwrite=overwrite)


def unregister_phi(name: str, registry: Optional[PhiRegistry] = None) -> None:
    (registry or _DEFAULT).unregister(name)


def get_phi(name: str, registry: Optional[PhiRegistry] = None) -> PhiFunction:
    return (registry or _DEFAULT).get(name)
