"""The parameters of a structure search: one table, one row per parameter.

Typical use::

    from mggp.fit.params import PARAMS, check_params
    PARAMS["window"].help            # 'multiple-shooting window in samples ...'
    check_params(est)                # ValueError naming the parameter, rule, value

Each :class:`Param` row holds a parameter's name (the keyword of
:class:`mggp.MGGPRegressor`), its rule (type, range or choices), its
default, a help line in a control engineer's words, its command-line flag
and ``--help`` group, and whether it enters the checkpoint context (the
fitness values depend on it, so a checkpoint written with another value
is not resumed) and the model's ``meta``. The table drives the estimator's
validation and ``get_params``, the options of ``mggp fit`` and the budget
options of ``mggp diagnose`` (:func:`add_options`), the checkpoint context
(:func:`context_of`) and the model meta (:func:`meta_of`). Adding a fit
option is one row here plus the code that uses the value.

Every message names the parameter, the rule and the value given, as
scikit-learn's do; on the command line the parameter is named by its flag.
"""
from __future__ import annotations

import math
import numbers
import textwrap
from dataclasses import dataclass
from typing import Any, Callable, Dict, Iterable, Optional, Sequence, Tuple

from narx.language.memory import OPERATOR_BUILTINS
from narx.records.outliers import ARX_SIGMAS, SPIKE_BAND, SPIKE_WIDTH
from narx.estimation.output_error import BURN_IN, ESTIMATORS, NOISE_ORDER, OE_ESTIMATORS

from ..gp.checkpoint import CHECKPOINT_SHARE
from .choices import (GAIN, HEIGHT, LEVEL, PILOT, SIZE_TOLERANCE, class_margins,
                      heldout_samples, holdout_words, percent, size_tolerance)
from .extrapolation import POWER_CAP, stress_words
from .operator_stage import OPERATOR_GAIN
from ..gp.primitives import MAX_HEIGHT, auto_classes, max_lag_for_height

__all__ = ["MAX_HEIGHT", "Param", "Rule", "Int", "Real", "OneOf", "Bool", "Seed", "Kind", "PARAMS",
           "DIAGNOSE_PARAMS", "GROUPS", "TIERS", "check_params", "unknown_keyword",
           "check_value", "context_of", "meta_of", "add_options", "options_given",
           "check_options", "params_doc"]


# ---------------------------------------------------------------- rules
def _integer(v) -> bool:
    return isinstance(v, numbers.Integral) and not isinstance(v, bool)


def _number(v) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


class Rule:
    """What values a parameter takes. ``words`` completes "must be ..." in
    the estimator's messages, ``cli_words`` on the command line, where
    argparse has already parsed the type."""

    words = "valid"
    cli_words = None
    argtype: Optional[Callable] = str
    choices: Optional[Tuple] = None

    def ok(self, v) -> bool:
        raise NotImplementedError

    def check(self, name: str, v, cli: bool = False) -> None:
        """Raise ``ValueError``: ``'{name} must be {rule}, got {v!r}'``."""
        if not self.ok(v):
            words = (self.cli_words or self.words) if cli else self.words
            raise ValueError(f"{name} must be {words}, got {v if cli else repr(v)}")


class Int(Rule):
    """An integer ``>= lo`` and, if ``hi`` is given, ``<= hi`` (or one of
    ``also``; or None if ``none``); ``why`` completes the message of a
    bounded rule (what the bound comes from)."""

    argtype = int

    def __init__(self, lo: int, none: bool = False, also: Tuple[int, ...] = (),
                 hi: Optional[int] = None, why: str = ""):
        self.lo, self.hi, self.none, self.also = lo, hi, none, tuple(also)
        extra = "".join(f" or {a}" for a in self.also)
        bound = f">= {lo}" if hi is None else f"between {lo} and {hi}"
        why = f" ({why})" if why else ""
        self.cli_words = f"{bound}{extra}{why}"
        self.words = f"an integer {bound}{extra}" + (" or None" if none else "") + why

    def ok(self, v) -> bool:
        if v is None:
            return self.none
        return _integer(v) and ((v >= self.lo and (self.hi is None or v <= self.hi))
                                or v in self.also)


class IntOrWords(Int):
    """One of ``names`` (e.g. 'auto') or an integer as :class:`Int` takes it."""

    def __init__(self, lo: int, hi: Optional[int] = None, why: str = "",
                 names: Tuple[str, ...] = ("auto",)):
        super().__init__(lo, hi=hi, why=why)
        self.names = tuple(names)

        def argtype(text: str):
            return text if text in self.names else int(text)
        argtype.__name__ = " or ".join(self.names) + " or integer"   # argparse's message
        self.argtype = argtype
        self.cli_words += (", or " if len(self.names) == 1 else ", ") + " or ".join(self.names)
        self.words += (", or " if len(self.names) == 1 else ", ") + " or ".join(
            f"'{w}'" for w in self.names)

    def ok(self, v) -> bool:
        return (isinstance(v, str) and v in self.names) or super().ok(v)


class Real(Rule):
    """A finite number in an interval (or None if ``none``)."""

    argtype = float

    def __init__(self, lo: float = -math.inf, hi: float = math.inf, *, lo_open=False,
                 hi_open=False, none=False, words: Optional[str] = None):
        self.lo, self.hi, self.lo_open, self.hi_open, self.none = lo, hi, lo_open, hi_open, none
        if words is None:
            if math.isinf(hi):
                words = f"a finite number {'>' if lo_open else '>='} {lo:g}"
            else:
                words = (f"a number in {'(' if lo_open else '['}{lo:g}, {hi:g}"
                         f"{')' if hi_open else ']'}")
        self.cli_words = words
        self.words = words + (" or None" if none else "")

    def ok(self, v) -> bool:
        if v is None:
            return self.none
        if not _number(v) or not math.isfinite(v):
            return False
        above = v > self.lo if self.lo_open else v >= self.lo
        below = v < self.hi if self.hi_open else v <= self.hi
        return above and below


class OneOf(Rule):
    """One of ``values`` (compared by type and value: ``0`` is not False);
    ``aliases`` are accepted as well without being listed."""

    def __init__(self, values: Sequence, aliases: Sequence = ()):
        self.values, self.aliases = tuple(values), tuple(aliases)
        self.words = "one of " + ", ".join(repr(a) for a in self.values)
        shown = [v for v in self.values if isinstance(v, str)]
        self.cli_words = "one of " + ", ".join(shown)
        self.choices = tuple(shown) or None

    def ok(self, v) -> bool:
        return any(v is a or (type(v) is type(a) and v == a)
                   for a in self.values + self.aliases)


class Bool(OneOf):
    """``False`` or ``True``."""

    argtype = None

    def __init__(self):
        super().__init__((False, True))


class Seed(Rule):
    """None, an integer >= 0, or a numpy ``Generator``."""

    argtype = int
    words = "None, an integer >= 0 or a numpy Generator"
    cli_words = ">= 0"

    def ok(self, v) -> bool:
        if v is None or (_integer(v) and v >= 0):
            return True
        import numpy as np
        return isinstance(v, np.random.Generator)


class Kind(Rule):
    """Anything ``test`` accepts (a type, a list of names...); ``words``
    says what."""

    def __init__(self, words: str, test: Callable[[Any], bool], argtype=str,
                 cli_words: Optional[str] = None):
        self.words, self.test, self.argtype = words, test, argtype
        self.cli_words = cli_words

    def ok(self, v) -> bool:
        return bool(self.test(v))


def _names(v) -> bool:
    return v is None or (isinstance(v, (list, tuple)) and all(isinstance(x, str) for x in v))


def _path(v) -> bool:
    import os
    return v is None or isinstance(v, (str, os.PathLike))


class OperatorNames(Rule):
    """'auto', None, 'none' or names of registered memory operators that
    the search can offer (:func:`mggp.gp.primitives.operator_names`); the
    names listed are those registered when the rule is checked."""

    argtype = str

    def ok(self, v) -> bool:
        from ..gp.primitives import operator_names
        if v in ("auto", "none"):
            return True
        try:
            operator_names(v, searchable=False)
        except ValueError:
            return False
        return True

    @staticmethod
    def _names() -> str:
        from ..gp.primitives import operator_choices
        return ", ".join(operator_choices())

    @property
    def words(self) -> str:
        return (f"'auto', None, 'none' or names among {self._names()} (a list, or "
                "comma-separated text)")

    @property
    def cli_words(self) -> str:
        return f"auto, none, or comma-separated names among {self._names()}"

    def check(self, name: str, v, cli: bool = False) -> None:
        """As :meth:`Rule.check`; a registered operator without a search
        grid is refused with the reason."""
        super().check(name, v, cli)
        if v not in ("auto", "none"):
            from ..gp.primitives import operator_names
            try:
                operator_names(v)
            except ValueError as exc:
                raise ValueError(f"{name}: {exc}") from None


ANY = Kind("anything", lambda v: True)
OPERATORS = OperatorNames()
NAMES = Kind("None or a list of names", _names)
PATH = Kind("None or a path", _path)


# ---------------------------------------------------------------- rows
@dataclass(frozen=True)
class Param:
    """One parameter.

    Attributes
    ----------
    name : str
        Keyword of :class:`mggp.MGGPRegressor` (or, with ``estimator=False``,
        the name of a command-line option that is not one).
    default :
        Its default.
    rule : Rule
    help : str
        What it does, in a control engineer's words.
    group : str
        Heading of ``mggp fit --help`` (one of :data:`GROUPS`).
    flag : str, optional
        Command-line flag (None: not on the command line).
    context : bool or 'if set'
        Whether it enters the checkpoint context; ``'if set'``: only when
        it differs from its default, so checkpoints written without the
        parameter still resume.
    meta : bool
        Whether it is recorded in the model's ``meta``.
    flag_help : str, optional
        Help of the flag when it differs from ``help`` (``--no-phi``).
    default_text : str, optional
        The default as ``--help`` shows it (default: the value).
    const :
        For a flag that takes no value: the value it sets.
    nargs, metavar : argparse's.
    estimator : bool
        False for a command-line option that is no estimator parameter.
    tier : str
        'common' (one of the ten most users set: shown first in the
        signature, the docstring's *Parameters* and ``mggp fit --help``)
        or 'expert' (the docstring's *Other Parameters*, the expert groups
        of ``--help``); :data:`TIERS`.
    """

    name: str
    default: Any
    rule: Rule
    help: str
    group: str
    flag: Optional[str] = None
    context: Any = False
    meta: bool = False
    flag_help: Optional[str] = None
    default_text: Optional[str] = None
    const: Any = None
    nargs: Optional[str] = None
    metavar: Optional[str] = None
    estimator: bool = True
    tier: str = "expert"

    def check(self, v, cli: bool = False) -> None:
        self.rule.check(self.flag if cli else self.name, v, cli)


#: headings of ``mggp fit --help``, in order
GROUPS = {
    "data": "data (DATA.csv has a header row; other columns are ignored)",
    "budget": "search budget",
    "model class": "model class (which terms a model may hold)",
    "selection": "selection (how structures are scored, chosen and estimated)",
    "parallelism": "parallelism and reproducibility",
    "output": "output",
    "tests": "tests of the diagnosis",
}

#: the tiers of the parameters, in the order shown, with the heading of
#: ``mggp fit --help`` for the common one (the expert ones keep their
#: topic's heading of :data:`GROUPS`, marked as expert)
TIERS = {"common": "common options (the ones most runs set)",
         "expert": "expert options"}

_FITNESS = ("ms", "pem", "freerun", "ksa")


#: the figures of the automatic choices as the help texts say them, from
#: the constants of :mod:`mggp.fit.choices`, :mod:`mggp.gp.primitives` and
#: :mod:`mggp.fit.operator_stage` (the one place each is set)
_HELD_OUT = holdout_words()
_PILOT = f"{percent(PILOT)} of the generations"
_CLASS_MARGINS = class_margins()
_KEPT_GAIN = (f"by over {percent(GAIN)}, significant at p < {LEVEL:g} (a block bootstrap of "
              f"the held-out errors; the tail and the head of the record held out in turn),")
_OPERATOR_TEXT = ", ".join(f"{op.name.lower()} ({op.search_text()})"
                           for op in OPERATOR_BUILTINS)
_AUTO_TEXT = ", or ".join("with " + " and ".join(names) for names in auto_classes().values())
_N_EXAMPLE = heldout_samples(500)
_SIZE_TEXT = (f"within {percent(SIZE_TOLERANCE)} of the least (2/√n on n held-out samples "
              f"when larger: {percent(round(size_tolerance(_N_EXAMPLE), 2))} on {_N_EXAMPLE})")
_STRESS_TEXT = stress_words()
_HEIGHT_WHY = (f"trees of height h reach lags up to 1 + 3h, {max_lag_for_height(MAX_HEIGHT)} "
               f"at {MAX_HEIGHT}, and grow exponentially with h")
_ROWS = (
    Param("fitness", "ms", OneOf(_FITNESS, aliases=("osa",)),
          "simulation whose mean squared error scores a structure: multiple shooting "
          "(ms), one step ahead (pem; alias osa), free run (freerun) or k steps ahead "
          "(ksa)", "selection", "--fitness", context=True, meta=True, tier="common"),
    Param("window", 100, Int(1), "multiple-shooting window in samples: each window is "
          "simulated in free run from measured initial conditions (--fitness ms)",
          "selection", "--window", context=True, meta=True),
    Param("k", 10, Int(1), "prediction horizon in samples of --fitness ksa", "selection",
          "--k", context=True, meta=True),
    Param("criterion", "mse", OneOf(("mse", "bic", "aic")),
          "fitness: the mean squared error, or an information criterion (BIC, AIC) that "
          "penalises each term", "selection", "--criterion", context=True, meta=True),
    Param("constraints", None, OneOf((None, "steady-state")),
          "also refit the chosen structure by constrained least squares so that every "
          "constant output is an equilibrium when the input is held (continuum of steady "
          "states)", "model class", "--constraints", context="if set",
          default_text="least squares only", tier="common"),
    Param("search_constraints", None, OneOf((None, "steady-state")),
          "score every structure of the search by its constrained fit (continuum of "
          "steady states) instead of least squares", "selection", "--search-constraints",
          context=True, meta=True, default_text="least squares"),
    Param("population", 500, Int(2), "structures per generation", "budget", "--population",
          meta=True, tier="common"),
    Param("generations", 200, Int(0), "generations after the initial population",
          "budget", "--generations", meta=True, tier="common"),
    Param("search_samples", "all", IntOrWords(1000, names=("all",)), "samples of the record "
          "the structure search runs on: 'all' the whole record; N a part of N samples (of ten "
          "evenly spread parts, the one whose signals cover most of their range), for a long "
          "record: every θ is estimated on that part, free-run figures are on the whole "
          "record (a simulated piezo record of 10⁶ samples searched on 100,000: 16× faster, "
          "validation error 1.8× larger)", "budget", "--search-samples", meta=True,
          metavar="all|N"),
    Param("cxpb", 0.8, Real(0, 1), "crossover probability", "budget"),
    Param("mutpb", 0.2, Real(0, 1), "mutation probability", "budget"),
    Param("high_level_cx_rate", 0.5, Real(0, 1),
          "share of crossovers that exchange whole terms", "budget"),
    Param("high_level_mut_rate", 0.5, Real(0, 1),
          "share of mutations that replace whole terms", "budget"),
    Param("tournament_size", 2, Int(1), "structures compared per tournament", "budget"),
    Param("elite_fraction", 0.1, Real(0, 1),
          "share of each generation copied unchanged (the best)", "budget"),
    Param("max_terms", 15, Int(1), "largest number of terms of any model the fit scores, "
          "chooses or returns: the constant term and the noise terms of --noise-lags count",
          "model class",
          "--max-terms", meta=True, tier="common"),
    Param("max_height", "auto", IntOrWords(1, hi=MAX_HEIGHT, why=_HEIGHT_WHY), "height of "
          f"the GP trees; a tree of height h reaches lags up to 1 + 3h; at most {MAX_HEIGHT}; "
          f"'auto': {HEIGHT} (lags up to {1 + 3 * HEIGHT}), raised to reach an input that acts "
          "on the output only beyond them (a dead time found by a linear ARX scan)",
          "model class", "--max-height", meta=True,
          default_text=f"auto ({HEIGHT}, or what reaches a dead time)"),
    Param("use_phi", "auto", OneOf((True, False, "auto")), "terms may hold Φ-functions "
          "of lagged inputs (input increments and their signs, which model hysteresis); "
          "'auto': a pilot search of each model class (no Φ, Φ, Φ of the output's lags "
          "too, and with operators='auto' plays with Deng–Tan, then Bouc–Wen variables) "
          "at full population for "
          f"{_PILOT}; the class whose structure has the least held-out free-run error "
          f"({_HELD_OUT}; {_CLASS_MARGINS}) continues to the full generations",
          "model class", "--no-phi",
          context=True, meta=True, const=False,
          flag_help="plain polynomial terms only: no Φ-functions (--phi: Φ-functions "
          "allowed; neither: pilots of the classes no Φ, Φ, Φ of the output's lags too, "
          "plays with Deng–Tan, and Bouc–Wen variables, the one with the lowest held-out "
          "free-run error continued)",
          default_text="chosen by held-out free-run error", tier="common"),
    Param("phi_names", None, NAMES, "Φ-functions the search uses (default: all "
          "registered)", "model class", context=True, meta=True),
    Param("phi_outputs", False, Bool(), "Φ-terms of output lags too, e.g. "
          "Phi1(y[k-1],y[k-2]) (hysteresis driven by the output's rate), in one search "
          "with Φ (use_phi='auto' pilots this class among the others when not set)",
          "model class", "--phi-outputs", context="if set", meta=True, const=True,
          default_text="inputs only, or piloted by use_phi='auto'"),
    Param("operators", "auto", OPERATORS, "memory operators of the inputs, "
          f"comma-separated: {_OPERATOR_TEXT}, or a plug-in's name in lower case (one "
          "registered by --phi-module with a search grid), entering as --operator-entry "
          "says; none: no operators; auto: the model classes of the automatic choice of "
          f"--phi/--no-phi (searches {_AUTO_TEXT}, in the primitive set, without "
          "Φ), none when --phi or "
          "--no-phi is given", "model class", "--operators", context="if set",
          metavar="NAMES", default_text="a class of the automatic choice"),
    Param("operator_entry", "stage", OneOf(("stage", "search")),
          "how operators named by --operators enter the model: stage (after the search, "
          f"each operator term that lowers the fitness by {percent(OPERATOR_GAIN)} is added, "
          "then terms it made redundant are dropped) or search (operators join the "
          "search's primitive set)",
          "model class", "--operator-entry", context="if set", meta=True),
    Param("constant", "auto", OneOf((True, False, "auto")), "every structure also holds "
          "the constant term 1 (an intercept), for an output that rests at an offset the "
          "lag terms cannot express; 'auto': a pilot search with it and one without "
          f"({_PILOT}); offered to every structure only when its pilot's held-out free-run "
          f"error is lower {_KEPT_GAIN} than both the other pilot's and its own "
          "structure's without the constant, or when the pilots tie and the simplest "
          "structure that ties (fewest terms, then lowest total degree) needs the constant "
          "(powers of y holding an offset), then kept in the result on the first rule; never "
          "with the steady-state constraints (it breaks the continuum of steady states)",
          "model class", "--constant", context="if set", meta=True, const=True,
          flag_help="every structure holds the constant term 1 (an intercept) "
          "(--no-constant: never; neither: searched with it when a pilot with it has "
          f"a held-out free-run error lower {_KEPT_GAIN} than one without and than its "
          "own structure without the constant, or when the pilots tie and the simplest "
          "structure that ties needs the constant, and kept on the first rule; never with "
          "--constraints steady-state)",
          default_text="chosen by held-out free-run error"),
    Param("max_lag", None, Int(1, none=True), "largest lag a term may use, in samples",
          "model class", "--max-lag", context=True, meta=True,
          default_text="what --max-height reaches"),
    Param("max_degree", None, Int(1, none=True), "largest polynomial degree of a term",
          "model class", "--max-degree", context=True, meta=True, default_text="none"),
    Param("max_power", "auto", IntOrWords(1, names=("auto", "none")), "largest power of "
          "one signal in a term (factors v[k-i] of one signal v at any lags: v[k-1]^7 has "
          "7), which sets how fast a model grows outside its training range; none: no cap; "
          f"auto: {POWER_CAP}, lifted when a pilot search without the cap (one more pilot, "
          f"{_PILOT}) has a held-out free-run error ({_HELD_OUT}) lower by more than the "
          "size tolerance (no pilot when --max-degree is at most "
          f"{POWER_CAP})", "model class", "--max-power", context="if set", meta=True,
          metavar="auto|none|N", default_text=f"auto ({POWER_CAP}, or lifted by a pilot)"),
    Param("select", "auto", OneOf(("auto", "fitness", "freerun", "hold")),
          "the result among the best distinct structures of the run: the best fitness, "
          "the least free-run error over the training record, or (hold) the best whose "
          "constrained refit holds its output on a held input; auto: hold with "
          "--constraints steady-state, else fitness", "selection", "--select",
          meta=True),
    Param("size", "auto", OneOf(("auto", "search")),
          "number of terms: search (the chosen structure as it is), or auto: the "
          "smallest structure of the run's Pareto front (complexity against fitness) whose "
          f"held-out free-run error ({_HELD_OUT}) is {_SIZE_TEXT}; the hold selection "
          "keeps its structure",
          "selection", "--size", meta=True),
    Param("stress", True, Bool(), "the final choices (model class, each pilot's structure, "
          "size, --select freerun, the local search's moves) refuse a structure whose "
          "least-squares free run is "
          f"unbounded on stress inputs made from the training record ({_STRESS_TEXT}); the "
          "choice line names the structures refused, or says that all within the tolerance "
          "fail (then none is)", "selection", "--no-stress", meta=True, const=False,
          flag_help="no stress test of the final choices: a structure is taken on its "
          "held-out error alone, however it extrapolates", default_text="on"),
    Param("local_search", True, Bool(), "after the search, improve the chosen structure "
          "one term at a time (drop a term, or replace, drop or add one lagged-signal "
          "factor of a term) while the fitness improves; the moves are kept only when the "
          f"held-out free-run error ({_HELD_OUT}) stays within the size choice's tolerance",
          "selection", "--no-local-search",
          meta=True, const=False, flag_help="keep the structure the search chose, without "
          "the one-term improvements", default_text="on"),
    Param("extend", "auto", OneOf(("auto", "none")), "after the structure is chosen, "
          "try the extensions that mggp diagnose tries (plays and Prandtl–Ishlinskii "
          "operators, Bouc–Wen variables, Φ of the inputs and of the output lags, linear "
          "dynamics driven by operators or with operators of y[k-1] in the feedback, and "
          "memory-free rivals: more lags, more degree, rate terms), each fitted on the part "
          f"of the record the other choices fit on; auto: one is taken when its free-run "
          f"error on the held-out part ({_HELD_OUT}) beats the chosen structure's by "
          "mggp diagnose's paired block-bootstrap test at its --level (Holm over the "
          "extensions; a memory extension must also beat the best memory-free one's error "
          "by a margin, unless "
          "that one's free run leaves the range on the probe inputs) and its "
          "free run stays bounded on probe and stress inputs, then refitted on the whole "
          "record (θ by free-run simulation error when it won so); none: the structure as "
          "chosen; never with --constraints steady-state", "selection", "--extend",
          meta=True, default_text="auto (an extension taken when it wins the test)"),
    Param("operator_params", "auto", OneOf(("auto", "none")), "after the structure is "
          "chosen and extended, estimate its memory operators' parameters (play radii, "
          "Bouc–Wen β and γ) by the free-run error, θ by least squares at each trial, instead "
          "of keeping the search's grid of them; auto: estimated when the held-out free-run "
          f"error ({_HELD_OUT}) is lower so, then estimated on the whole record; none: the "
          "grid's parameters; never with --constraints steady-state", "selection",
          "--operator-params", meta=True,
          default_text="auto (estimated when the held-out error is lower)"),
    Param("select_candidates", 50, Int(1), "structures compared by --select freerun and "
          "hold", "selection"),
    Param("screen", "auto", OneOf(("auto", "freerun", "hold", "none", None)),
          "stability screen in every generation: the leaders whose free run over the "
          "training record leaves the output band get no fitness (hold: also those whose "
          "constrained refit does not hold its output on a held input; none: no screen; "
          "auto: hold with --constraints steady-state, else freerun)",
          "selection", "--screen", context=True, meta=True),
    Param("screen_top", None, Int(1, none=True), "leaders screened per generation "
          "(default: the elite size)", "selection", context=True),
    Param("screen_band", 1.0, Real(0), "widening of the screen's band beyond [min y, max "
          "y], in output ranges", "selection", context=True),
    Param("prune", False, OneOf((False, None, "bic", "t")),
          "drop terms of the chosen structure by BIC of the fitness or by t-statistics",
          "selection", "--prune", meta=True, default_text="keep all"),
    Param("noise_lags", 0, Int(0), "Q: select moving-average noise terms e[k-1]..e[k-Q] "
          "by extended least squares after the search (NARMAX, for coloured noise), as many "
          "as --max-terms leaves room for beside the process terms",
          "model class", "--noise-lags", meta=True, metavar="Q"),
    Param("t_threshold", None, Real(0, lo_open=True, none=True),
          "|t| below which a term is pruned (default: Bonferroni over the candidate "
          "monomials)", "selection"),
    Param("estimator", "ls", OneOf(ESTIMATORS),
          "θ of every structure scored in the search: least squares (ls), or output error "
          "(oe: instrumental variables, then Gauss-Newton on the simulation error), which "
          "white measurement noise on the output does not bias; oe needs --fitness ms or "
          f"freerun and scores each window from its {BURN_IN}th step (ms: at most half a "
          "window); bj: oe, with the simulation error whitened by an autoregressive noise "
          f"model (order by BIC, at most {NOISE_ORDER}) before its mean square is taken, for "
          "equation noise that the dynamics colour",
          "selection", "--estimator", context="if set", meta=True),
    Param("refine", "auto", OneOf(("auto", "compare", "freerun", "ms", "none", None)),
          "refine θ by minimising the simulation error (ms: windows of --refine-window "
          "samples) instead of the one-step error of least squares, which is biased by "
          "output noise; auto: the final model's θ are refined in free run when that "
          "refit simulates the held-out part better than least squares (never with "
          "--constraints steady-state); compare: auto, and the structures the automatic "
          "choices compare also take their free-run refit where it simulates the held-out "
          "part better; none: least squares (auto, compare and none: also in free run "
          "when the extension --extend took won so)",
          "selection", "--refine", meta=True),
    Param("refine_window", None, Int(1, none=True), "multiple-shooting window in samples "
          "of --refine ms", "selection", "--refine-window", metavar="W",
          default_text="--window"),
    Param("random_state", None, Seed(), "seed: fixes the run whatever the number of "
          "workers", "parallelism", "--seed", default_text="drawn, and reported",
          tier="common"),
    Param("n_jobs", 1, Int(1, also=(-1,)), "worker processes, -1 for all cores",
          "parallelism", "--jobs", tier="common"),
    Param("backend", "loky", OneOf(("loky", "threading", "sequential", "dask")),
          "joblib backend of the evaluator", "parallelism", "--backend"),
    Param("scheduler", None, ANY, "dask scheduler address (or client) for --backend dask",
          "parallelism", "--scheduler", metavar="ADDRESS", default_text="none"),
    Param("inputs", None, NAMES, "input column name(s) (in Python the column names of a "
          "pandas DataFrame u are taken when this is not given)", "data", "--input", nargs="+",
          metavar="NAME", default_text="u", tier="common", flag_help="input column name(s)"),
    Param("output", "y", Kind("a name", lambda v: isinstance(v, str)), "output column "
          "name", "data", "--output", metavar="NAME", tier="common"),
    Param("outliers", "auto", OneOf(("auto", "keep")), "isolated glitches of the "
          f"measured signals: 'auto' repairs every run of at most {SPIKE_WIDTH} samples that "
          "lies on one side of both its neighbours, beyond the rest of its signal's range "
          f"by over {percent(SPIKE_BAND)} of it, and, in the output, over {ARX_SIGMAS:g} "
          "robust standard deviations from a linear ARX prediction, in an input, one the "
          f"output does not answer (an ARX prediction over {ARX_SIGMAS:g} standard "
          "deviations worse with it than with values inside the input's range, which fit "
          "the output); the straight line between its neighbours replaces it "
          "(narx.records.outliers); 'keep': fit every sample as measured",
          "data", "--outliers", context="if set", meta=True,
          default_text="auto (repair isolated glitches of the output and inputs)"),
    Param("checkpoint", None, PATH, "save the search state to this file after a "
          "generation, as often as "
          f"keeps the writes within about {percent(CHECKPOINT_SHARE)} of the run's time; "
          "the pilots of the automatic choices are saved beside it (FILE.pilot-*), and "
          "the fit is the one it would be without a checkpoint",
          "output", "--checkpoint", metavar="FILE", default_text="none"),
    Param("resume", False, Bool(), "continue the run saved in --checkpoint", "output",
          "--resume", const=True, default_text="start anew"),
    Param("callbacks", None, Kind("None or a list of callables",
                                  lambda v: v is None or all(callable(c) for c in v)),
          "functions f(state) called every generation; one with a method "
          "phase(label, generations) is told which search runs next (a model class's "
          "pilot or the full search)", "output"),
    Param("registry", None, ANY, "Φ-functions (default: the registered ones)",
          "model class"),
)

#: every parameter of :class:`mggp.MGGPRegressor`, in the order of its
#: signature: the common tier first, each tier in the order of the table
PARAMS: Dict[str, Param] = {p.name: p for p in sorted(_ROWS, key=lambda p: list(TIERS).index(
    p.tier))}


def unknown_keyword(name: str, owner: str = "MGGPRegressor") -> str:
    """The message of a keyword that is no parameter: it names the keyword
    and the closest parameter (:func:`difflib.get_close_matches`), e.g.
    ``"MGGPRegressor got an unexpected keyword argument 'populaton': did you
    mean 'population'?"``."""
    import difflib
    close = difflib.get_close_matches(str(name), list(PARAMS), n=1, cutoff=0.6)
    hint = (f"did you mean {close[0]!r}?" if close else
            f"the parameters are the rows of mggp.fit.params.PARAMS: {', '.join(PARAMS)}")
    return f"{owner} got an unexpected keyword argument {name!r}: {hint}"


def _diagnose_row(name: str, **changes) -> Param:
    from dataclasses import replace
    return replace(PARAMS[name], **changes)


#: options of ``mggp diagnose``: the search budget (rows of :data:`PARAMS`
#: with the diagnosis's defaults) and the tests' own settings
DIAGNOSE_PARAMS: Dict[str, Param] = {p.name: p for p in (
    _diagnose_row("random_state", default=0, default_text=None),
    _diagnose_row("n_jobs"),
    _diagnose_row("population"),
    _diagnose_row("generations", default=100),
    _diagnose_row("max_terms", group="budget"),
    _diagnose_row("max_height", group="budget", default=HEIGHT,
                  rule=Int(1, hi=MAX_HEIGHT, why=_HEIGHT_WHY), default_text=None,
                  help=f"height of the GP trees; a tree of height h reaches lags up to "
                  f"1 + 3h; at most {MAX_HEIGHT}"),
    _diagnose_row("max_degree", default=3, group="budget", default_text=None),
    _diagnose_row("window", group="budget", help="multiple-shooting window in samples of "
                  "the baseline search"),
    _diagnose_row("outliers", context=False, meta=False),
    Param("shifts", 99, Int(1), "placebo shifts of the Φ-augmentation test", "budget",
          "--shifts", estimator=False),
    Param("holdout", 0.3, Real(0, 1, lo_open=True, hi_open=True,
                               words="a fraction between 0 and 1"),
          "tail fraction of TRAIN.csv that measures the gain without --validation", "tests",
          "--holdout", estimator=False),
    Param("alpha", 0.01, Real(0, 0.5, lo_open=True, hi_open=True,
                              words="between 0 and 0.5"),
          "false-alarm probability of each residual test (the evidence)", "tests", "--alpha",
          estimator=False),
    Param("level", 0.05, Real(0, 0.5, lo_open=True, hi_open=True,
                              words="between 0 and 0.5"),
          "level of the paired held-out test that names an effect (family-wise over the "
          "candidate extensions, Holm)", "tests", "--level", estimator=False),
    Param("resolution", 0.005, Real(0, 1, hi_open=True), "smallest effect named, as a "
          "fraction of the output range", "tests", "--resolution", estimator=False),
)}


# ---------------------------------------------------------------- checks
def check_value(name: str, v, label: Optional[str] = None) -> None:
    """Check ``v`` against the rule of parameter ``name``; the message
    names it ``label`` (e.g. ``population_size`` in ``mggp.gp.evolve``)."""
    PARAMS[name].rule.check(label or name, v)


#: rules that combine parameters: (test, message, message on the command line)
_COMBINED = (
    (lambda e: not (e.phi_outputs and not e.use_phi),
     lambda e: f"phi_outputs=True needs Φ-functions in the search, got use_phi={e.use_phi}",
     "--phi-outputs needs Φ-functions in the search: drop --no-phi"),
    (lambda e: e.estimator not in OE_ESTIMATORS or e.fitness in ("ms", "freerun"),
     lambda e: f"estimator={e.estimator!r} needs a simulation fitness ('ms' or 'freerun'), got "
               f"fitness={e.fitness!r}",
     "--estimator oe and bj need --fitness ms or freerun"),
    (lambda e: not (e.constant is True and e.max_terms < 2),
     lambda e: f"constant=True needs max_terms >= 2 (the constant term and a searched one), "
               f"got max_terms={e.max_terms}",
     "--constant needs --max-terms 2 or more (the constant term and a searched one)"),
    (lambda e: e.estimator not in OE_ESTIMATORS or e.search_constraints is None,
     lambda e: f"estimator={e.estimator!r} estimates unconstrained θ, got "
               f"search_constraints={e.search_constraints!r}",
     "--estimator oe and bj estimate unconstrained θ: drop --search-constraints"),
)


def check_params(est, cli: bool = False) -> None:
    """Raise ``ValueError`` for the first parameter of ``est`` out of its
    rule, then for the first combination of parameters that is refused
    (``cli``: named by their flags)."""
    for p in PARAMS.values():
        p.check(getattr(est, p.name), cli=cli and p.flag is not None)
    for ok, message, cli_message in _COMBINED:
        if not ok(est):
            raise ValueError(cli_message if cli else message(est))


def context_of(est) -> dict:
    """The parameters the fitness values depend on (checkpoint context)."""
    return {p.name: getattr(est, p.name) for p in PARAMS.values()
            if p.context is True or (p.context == "if set" and not _is_default(p, est))}


def _is_default(p: Param, est) -> bool:
    v = getattr(est, p.name)
    return v is p.default or (type(v) is type(p.default) and v == p.default)


def meta_of(est) -> dict:
    """The parameters recorded in a model's ``meta``."""
    out = {}
    for p in PARAMS.values():
        if p.meta:
            v = getattr(est, p.name)
            out[p.name] = bool(v) if isinstance(p.rule, Bool) else v
    return out


# ---------------------------------------------------------------- command line
def _shown(p: Param) -> str:
    if p.default_text is not None:
        return p.default_text
    return str(p.default).lower() if isinstance(p.default, bool) else str(p.default)


def add_options(parser, rows: Iterable[Param], groups: Optional[dict] = None,
                tiers: bool = False) -> dict:
    """Add the rows with a flag to ``parser``, in argument groups by
    :attr:`Param.group`, each help line ending with its default. With
    ``tiers`` the common rows come first in a group of their own
    (:data:`TIERS`), and each topic group of the others is headed as
    expert. Every option's value is None unless given
    (:func:`options_given`). Returns the argument groups by name, for
    options added by hand."""
    groups = {} if groups is None else groups
    rows = [p for p in rows if p.flag is not None]

    def group_of(p: Param) -> str:
        return "common" if tiers and p.tier == "common" else p.group
    titles = dict(GROUPS)
    if tiers:
        titles = {"common": TIERS["common"],
                  **{k: f"{TIERS['expert']}: {v}" for k, v in GROUPS.items()}}
    for name, title in titles.items():         # headings in this order
        if name not in groups and any(group_of(p) == name for p in rows):
            groups[name] = parser.add_argument_group(title)
    for p in rows:
        help_ = f"{p.flag_help or p.help} (default: {_shown(p)})".replace("%", "%%")
        kw = dict(dest=p.name, default=None, help=help_)
        if p.const is not None:
            kw.update(action="store_const", const=p.const)
        else:
            metavar = p.metavar or p.flag.lstrip("-").upper().replace("-", "_")
            if p.metavar is None and p.rule.choices is not None:
                metavar = "{" + ",".join(p.rule.choices) + "}"
            kw.update(type=p.rule.argtype, choices=p.rule.choices, nargs=p.nargs,
                      metavar=metavar)
        groups[group_of(p)].add_argument(p.flag, **kw)
    return groups


def options_given(args, rows: Iterable[Param]) -> dict:
    """``{name: value}`` of the options given on the command line."""
    return {p.name: getattr(args, p.name) for p in rows
            if p.flag is not None and getattr(args, p.name, None) is not None}


def check_options(args, rows: Iterable[Param], fill: bool = True) -> None:
    """Check every given option by its row's rule (``ValueError``: '--flag
    must be ..., got v'); with ``fill``, set those not given to their
    defaults."""
    for p in rows:
        if p.flag is None:
            continue
        v = getattr(args, p.name, None)
        if v is None:
            if fill:
                setattr(args, p.name, p.default)
        elif p.const is None and p.nargs is None:
            p.check(v, cli=True)


def params_doc() -> str:
    """The numpydoc *Parameters* (common tier) and *Other Parameters*
    (expert tier) sections of the estimator rows."""
    lines = []
    for tier, heading in (("common", "Parameters"), ("expert", "Other Parameters")):
        lines += ["", f"    {heading}", "    " + "-" * len(heading)]
        for p in (p for p in PARAMS.values() if p.tier == tier):
            lines.append(f"    {p.name} : {p.rule.words}, default {p.default!r}")
            text = p.help[0].upper() + p.help[1:] + (f" (``{p.flag}``)." if p.flag else ".")
            lines += textwrap.wrap(text, 78, initial_indent=" " * 8,
                                   subsequent_indent=" " * 8)
    return "\n".join(lines) + "\n"
