"""The registry of diagnose tests and the runner that applies them.

A diagnose test is a :class:`DiagnosticTest`: a name, the effects of
:data:`~mggp.diagnose.findings.VOCABULARY` it is evidence for, and a
function ``run(ctx) -> Outcome`` of the :class:`~mggp.diagnose.context.Context`.
Its :class:`Outcome` holds its :class:`~mggp.diagnose.findings.Check` s
(statistic, threshold, and why a check without power has none), the
measurement itself for reports, and, when it could not measure anything,
one phrase saying why. :func:`run_tests` runs every registered test in
order; the findings are named from the checks by
:func:`~mggp.diagnose.findings.name_findings`.

Adding a test is one module and one line::

    # mggp/diagnose/mytest.py
    from .findings import Check
    from .registry import DiagnosticTest, Outcome

    def _run(ctx):
        stat = ...                                  # from ctx.model, ctx.fit, ...
        thr = max(bound, ctx.floor)
        return Outcome([Check("my test", "hysteresis", stat, thr, "what was measured")])

    MY_TEST = DiagnosticTest("my test", ("hysteresis",), _run)

    # mggp/diagnose/catalogue.py (the tests that run by default, in order)
    register(mytest.MY_TEST)

A test registered at run time (``register(test)``; ``unregister(name)``
removes it) runs in every later diagnosis.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from importlib import import_module
from typing import Any, Callable, Dict, Iterable, List, Optional, Sequence, Tuple

from .context import Context
from .findings import VOCABULARY, Check
from .thresholds import calibrated

__all__ = ["DiagnosticTest", "Outcome", "Evidence", "register", "unregister", "registered",
           "run_tests"]


@dataclass(frozen=True)
class Outcome:
    """What a test returns.

    Attributes
    ----------
    checks : sequence of Check
        Its statistics against their thresholds (none when it could not run).
    result : object
        The measurement itself (for reports and figures), or None.
    missing : str
        When nothing could be measured: the kind of evidence and why, in one
        phrase (e.g. ``'operator augmentation (no reversal of the input long enough)'``).
    """

    checks: Sequence[Check] = ()
    result: Any = None
    missing: str = ""


@dataclass(frozen=True)
class DiagnosticTest:
    """A diagnose test: ``name``, the ``effects`` its checks may name, and
    ``run(ctx) -> Outcome``."""

    name: str
    effects: Tuple[str, ...]
    run: Callable[[Context], Outcome]

    def __post_init__(self):
        unknown = [e for e in self.effects if e not in VOCABULARY]
        if not self.effects or unknown:
            raise ValueError(f"DiagnosticTest {self.name!r}: effects must be one or more of "
                             f"{list(VOCABULARY)}, got {list(self.effects)}")


_TESTS: Dict[str, DiagnosticTest] = {}


def _builtin():
    """Register the built-in tests (:mod:`.catalogue`) before any other."""
    import_module(__name__.rsplit(".", 1)[0] + ".catalogue")


def register(test: DiagnosticTest) -> DiagnosticTest:
    """Add ``test`` after those registered so far; returns it.

    Raises
    ------
    ValueError
        If a test of that name is registered already.
    """
    if not isinstance(test, DiagnosticTest):
        raise TypeError(f"register: test must be a DiagnosticTest, got {type(test).__name__}")
    _builtin()
    if test.name in _TESTS:
        raise ValueError(f"register: a diagnose test named {test.name!r} is registered "
                         f"already")
    _TESTS[test.name] = test
    return test


def unregister(name: str) -> DiagnosticTest:
    """Remove the test ``name`` and return it.

    Raises
    ------
    KeyError
        If no test of that name is registered.
    """
    _builtin()
    if name not in _TESTS:
        raise KeyError(f"unregister: no diagnose test named {name!r} (registered: "
                       f"{list(_TESTS)})")
    return _TESTS.pop(name)


def registered() -> Tuple[DiagnosticTest, ...]:
    """The registered tests, in the order they run."""
    _builtin()
    return tuple(_TESTS.values())


def _measured(name: str, default=None) -> property:
    return property(lambda self: self.result(name, default),
                    doc=f"The measurement of the test {name!r} ({default!r} if none).")


def _of_context(attr: str) -> property:
    return property(lambda self: getattr(self.context, attr),
                    doc=f"``context.{attr}``.")


@dataclass(frozen=True)
class Evidence:
    """Everything the tests measured on the model: each test's
    :class:`Outcome` by name, in the order they ran, and the context.

    The properties name the measurements of the tests reports know for reports
    (empty, or None, when the test is not registered or measured nothing).
    """

    context: Context
    outcomes: Dict[str, Outcome] = field(default_factory=dict)

    @property
    def checks(self) -> List[Check]:
        """Every test's checks, in the order the tests ran."""
        return [c for o in self.outcomes.values() for c in o.checks]

    @property
    def missing(self) -> List[str]:
        """What could not be measured, one phrase per test, in order."""
        return [o.missing for o in self.outcomes.values() if o.missing]

    def result(self, name: str, default=None):
        """The measurement of test ``name`` (``default`` if none)."""
        o = self.outcomes.get(name)
        return default if o is None or o.result is None else o.result

    # the registrable tests' measurements and the settings, as reports read them
    augmentation = _measured("Φ-augmentation")
    holds = _of_context("holds")
    alpha = _of_context("alpha")
    resolution = _of_context("resolution")
    floor = _of_context("floor")
    osa_rms = _of_context("osa_rms")


def run_tests(ctx: Context, tests: Optional[Iterable[DiagnosticTest]] = None) -> Evidence:
    """Run ``tests`` (default: :func:`registered`) on ``ctx``, in order;
    every threshold is calibrated (:func:`~mggp.diagnose.thresholds.calibrated`).

    Raises
    ------
    ValueError
        If a test returns a check of an effect it does not declare, or a
        check name another check already has.
    """
    out: Dict[str, Outcome] = {}
    names = set()
    for t in registered() if tests is None else tests:
        o = t.run(ctx)
        o = replace(o, checks=[calibrated(c) for c in o.checks])
        for c in o.checks:
            if c.effect not in t.effects:
                raise ValueError(f"diagnose test {t.name!r} returned check {c.test!r} of "
                                 f"effect {c.effect!r}; it declares {list(t.effects)}")
            if c.test in names:
                raise ValueError(f"diagnose test {t.name!r} returned check {c.test!r}, a "
                                 f"name another check has already")
            names.add(c.test)
        out[t.name] = o
    return Evidence(ctx, out)
