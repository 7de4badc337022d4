"""The term language: parse and print canonical NARX term text.

A *term* is a product of factors; a factor is a lagged signal (``y[k-2]``,
``u[k-1]``, ``u2[k]``, a noise lag ``e[k-1]``) or a Φ-function of lagged
signals (``Phi1(u[k-1],u[k-3])``) or a memory operator of one lagged signal
with numeric parameters (``Play(u[k-1],0.3)``, ``DengTan(y[k-1])``; see
:mod:`narx.language.memory`). The empty product is the constant term ``1``. A model output is

.. math::  \\hat y_k = \\sum_i \\theta_i \\prod_{f \\in t_i} f_k .

Typical use::

    from narx.language.terms import parse_term, parse_terms
    t = parse_term("Phi2(u[k-1],u[k-3])*y[k-1]*u[k-2]^2")
    str(t)        # 'y[k-1]*u[k-2]*u[k-2]*Phi2(u[k-1],u[k-3])'
    t.max_lag     # 3

A Φ-call may take lags of different signals (``Phi1(u1[k-1],u2[k-1])``,
``Abs(y[k-1])``): a hand-written model is the user's choice. The structure
search of :mod:`mggp` only builds Φ-calls of lags of one and the same input.

Every term has one canonical text: factors sorted as output lags, input lags
(by input name), noise lags, Φ-calls (by name and arguments), then operator
calls (by name, argument and parameters); powers are written as repeated
factors, operator parameters as the shortest text that reads back to the
same float (``0.30`` prints ``0.3``, ``2.0`` prints ``2``). An operator
cannot take an operator or a Φ-call as its argument. Parsing is a small hand-written tokenizer and
recursive-descent parser; no text is ever evaluated.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Iterable, List, Optional, Sequence, Tuple, Union

from ..exceptions import TermError
from .memory import OperatorRegistry, default_operators
from .phi import PhiRegistry, default_registry

__all__ = ["Lag", "PhiCall", "OpCall", "Term", "TermError", "parse_term", "parse_terms",
           "Signals", "MAX_LAG"]

#: largest lag accepted in term text
MAX_LAG = 10_000

_ROLE_RANK = {"y": 0, "u": 1, "e": 2}


class HasSignals:
    """Mixin: ``inputs`` and ``output`` names from a ``signals`` attribute."""

    @property
    def inputs(self):
        return self.signals.inputs

    @property
    def output(self):
        return self.signals.output


def ascii_name(name: str) -> str:
    """A signal name for ``name`` made of ASCII letters, digits and ``_``:
    accents dropped (``é`` -> ``e``), each run of other characters ``_``,
    leading and trailing ``_`` stripped ('Voltage [V]' -> 'Voltage_V',
    'Displacement_µm' -> 'Displacement__m')."""
    import unicodedata
    folded = "".join(c for c in unicodedata.normalize("NFKD", name)
                     if not unicodedata.combining(c))
    return re.sub(r"[^A-Za-z0-9_]+", "_", folded).strip("_")


@dataclass(frozen=True)
class Signals:
    """Names of a model's signals: one output, inputs, and the noise name."""

    output: str = "y"
    inputs: Tuple[str, ...] = ("u",)
    noise: str = "e"

    def __post_init__(self):
        inputs = (self.inputs,) if isinstance(self.inputs, str) else tuple(self.inputs)
        object.__setattr__(self, "inputs", inputs)
        names = [self.output, *inputs, self.noise]
        for n in names:
            if not isinstance(n, str) or not re.match(r"^[A-Za-z_][A-Za-z0-9_]*$", n):
                hint = ascii_name(n) if isinstance(n, str) else ""
                hint = f" (e.g. {hint!r})" if hint and re.match(r"^[A-Za-z_]\w*$", hint) else ""
                raise TermError(f"signal names must be identifiers (ASCII letters, digits "
                                f"and _, not starting with a digit), got {n!r}: rename the "
                                f"column{hint}")
            if n == "k":
                raise TermError("signal name 'k' is reserved (it is the time index)")
        if len(set(names)) != len(names):
            raise TermError(f"signal names must be distinct: output={self.output!r}, "
                            f"inputs={list(inputs)!r}, noise={self.noise!r} (the noise "
                            f"signal of NARMAX terms): rename the column")
        if not inputs:
            raise TermError("a model needs at least one input")

    def role(self, name: str) -> Optional[str]:
        if name == self.output:
            return "y"
        if name in self.inputs:
            return "u"
        if name == self.noise:
            return "e"
        return None


@dataclass(frozen=True)
class Lag:
    """A lagged signal ``name[k-lag]``; role is 'y', 'u' or 'e'."""

    signal: str
    lag: int
    role: str

    def __str__(self):
        return f"{self.signal}[k]" if self.lag == 0 else f"{self.signal}[k-{self.lag}]"

    def sort_key(self):
        return (_ROLE_RANK[self.role], self.signal, self.lag)

    @property
    def input_only(self) -> bool:
        return self.role == "u"

    @property
    def max_lag(self) -> int:
        return self.lag

    def to_struct(self):
        return {"kind": "lag", "signal": self.signal, "lag": self.lag}


@dataclass(frozen=True)
class PhiCall:
    """A Φ-function applied to lagged signals, e.g. ``Phi1(u[k-1],u[k-3])``."""

    name: str
    args: Tuple[Lag, ...]

    def __str__(self):
        return f"{self.name}({','.join(str(a) for a in self.args)})"

    def sort_key(self):
        return (3, self.name, tuple(a.sort_key() for a in self.args))

    @property
    def input_only(self) -> bool:
        return all(a.role == "u" for a in self.args)

    @property
    def role(self) -> str:
        return "phi"

    @property
    def max_lag(self) -> int:
        return max(a.lag for a in self.args)

    def to_struct(self):
        return {"kind": "phi", "name": self.name,
                "args": [{"signal": a.signal, "lag": a.lag} for a in self.args]}


def format_param(x: float) -> str:
    """Canonical text of an operator parameter: the shortest text that
    reads back to the same float, without a trailing ``.0``."""
    t = repr(float(x) + 0.0)                 # + 0.0: -0.0 prints as 0
    return t[:-2] if t.endswith(".0") else t


@dataclass(frozen=True)
class OpCall:
    """A memory operator applied to one lagged signal, with parameters,
    e.g. ``Play(u[k-1],0.3)`` (see :mod:`narx.language.memory`)."""

    name: str
    arg: Lag
    params: Tuple[float, ...] = ()

    def __str__(self):
        ps = "".join("," + format_param(p) for p in self.params)
        return f"{self.name}({self.arg}{ps})"

    def sort_key(self):
        return (4, self.name, self.arg.sort_key(), self.params)

    @property
    def args(self) -> Tuple[Lag, ...]:
        return (self.arg,)

    @property
    def input_only(self) -> bool:
        return self.arg.role == "u"

    @property
    def role(self) -> str:
        return "op"

    @property
    def max_lag(self) -> int:
        return self.arg.lag

    def to_struct(self):
        return {"kind": "op", "name": self.name,
                "args": [{"signal": self.arg.signal, "lag": self.arg.lag}],
                "params": list(self.params)}


Factor = Union[Lag, PhiCall, OpCall]


class Term:
    """A product of factors in canonical order; hashable, prints canonically."""

    __slots__ = ("factors", "_text")

    def __init__(self, factors: Iterable[Factor] = ()):
        fs = tuple(sorted(factors, key=lambda f: f.sort_key()))
        self.factors: Tuple[Factor, ...] = fs
        self._text = "*".join(str(f) for f in fs) if fs else "1"

    def __str__(self):
        return self._text

    def __repr__(self):
        return f"Term({self._text!r})"

    def __eq__(self, other):
        return isinstance(other, Term) and other._text == self._text

    def __hash__(self):
        return hash(self._text)

    def __lt__(self, other):
        return self._text < other._text

    def __mul__(self, other: "Term") -> "Term":
        return Term(self.factors + other.factors)

    @property
    def text(self) -> str:
        return self._text

    @property
    def max_lag(self) -> int:
        return max((f.max_lag for f in self.factors), default=0)

    @property
    def lags(self) -> Tuple[Lag, ...]:
        """Every lagged signal of the term, the arguments of its Φ-calls and
        memory operators included: ``u[k-1]*Play(u[k-3],0.1)`` has
        ``u[k-1]`` and ``u[k-3]``."""
        return tuple(a for f in self.factors for a in ((f,) if isinstance(f, Lag) else f.args))

    @property
    def degree(self) -> int:
        """Number of factors (a Φ-call counts as one)."""
        return len(self.factors)

    @property
    def input_factors(self) -> Tuple[Factor, ...]:
        """Factors that depend on inputs only (computed once per data set)."""
        return tuple(f for f in self.factors if f.input_only)

    @property
    def output_factors(self) -> Tuple[Factor, ...]:
        """Factors that depend on the (simulated) output."""
        return tuple(f for f in self.factors
                     if not f.input_only and not _is_noise(f))

    @property
    def noise_factors(self) -> Tuple[Lag, ...]:
        return tuple(f for f in self.factors if _is_noise(f))

    @property
    def has_noise(self) -> bool:
        return any(_is_noise(f) for f in self.factors)

    @property
    def phi_names(self) -> Tuple[str, ...]:
        return tuple(f.name for f in self.factors if isinstance(f, PhiCall))

    @property
    def operator_factors(self) -> Tuple[OpCall, ...]:
        """The memory-operator factors (see :mod:`narx.language.memory`)."""
        return tuple(f for f in self.factors if isinstance(f, OpCall))

    def to_struct(self):
        """Neutral JSON-able structure (a list of factor dicts)."""
        return [f.to_struct() for f in self.factors]


def _is_noise(f) -> bool:
    if isinstance(f, Lag):
        return f.role == "e"
    return any(a.role == "e" for a in f.args)


# ---------------------------------------------------------------- parsing
_EXP = r"(?:[eE][+-]?[0-9]+)"
_TOKEN = re.compile(r"\s*(?:(?P<real>[0-9]*\.[0-9]+" + _EXP + r"?|[0-9]+\.[0-9]*" + _EXP
                    + r"?|[0-9]+" + _EXP + r")|(?P<num>[0-9]+)|(?P<name>[A-Za-z_][A-Za-z0-9_]*)"
                    r"|(?P<op>\*\*|[\[\]\(\),*^+\-]))")


def _tokenize(text: str):
    pos, out = 0, []
    while pos < len(text):
        if text[pos:].strip() == "":
            break
        m = _TOKEN.match(text, pos)
        if not m:
            raise TermError(f"malformed term {text!r}: unexpected character "
                            f"{text[pos:].lstrip()[0]!r} at position {pos}")
        kind = m.lastgroup
        out.append((kind, m.group(kind), m.start(kind)))
        pos = m.end()
    out.append(("end", "", len(text)))
    return out


class _Parser:
    def __init__(self, text, signals: Signals, registry: PhiRegistry,
                 operators: OperatorRegistry):
        self.text, self.sig, self.reg, self.ops = text, signals, registry, operators
        self.toks = _tokenize(text)
        self.i = 0

    def peek(self):
        return self.toks[self.i]

    def take(self, kind=None, value=None, what=None):
        tok = self.toks[self.i]
        if (kind and tok[0] != kind) or (value and tok[1] != value):
            got = "end of text" if tok[0] == "end" else repr(tok[1])
            raise TermError(f"malformed term {self.text!r}: expected "
                            f"{what or value or kind} at position {tok[2]}, got {got}")
        self.i += 1
        return tok

    def term(self) -> Term:
        if self.peek()[0] == "num" and self.peek()[1] == "1" and \
                self.toks[self.i + 1][0] == "end":
            self.i += 1
            return Term()
        factors: List[Factor] = []
        while True:
            f = self.factor()
            power = 1
            if self.peek()[1] in ("^", "**"):
                self.i += 1
                p = self.take("num", what="an integer power")[1]
                power = int(p)
                if not 1 <= power <= 10:
                    raise TermError(f"power must be 1..10 in term {self.text!r}, got {p}")
            factors.extend([f] * power)
            if self.peek()[1] == "*":
                self.i += 1
                continue
            break
        self.take("end", what="'*' or end of term")
        return Term(factors)

    def factor(self) -> Factor:
        tok = self.take("name", what="a signal such as y[k-1] or a Φ-call")
        name = tok[1]
        if self.peek()[1] == "(":
            if name in self.ops:
                return self.op_call(name)
            return self.phi_call(name)
        return self.lag(name, tok)

    def lag(self, name, tok) -> Lag:
        role = self.sig.role(name)
        if role is None:
            if name in self.reg or name in self.ops:
                what = "Φ-function" if name in self.reg else "operator"
                raise TermError(f"malformed term {self.text!r}: {what} "
                                f"{name!r} needs arguments in parentheses")
            raise TermError(f"unknown signal {name!r} in term {self.text!r} "
                            f"(output: {self.sig.output}, inputs: "
                            f"{', '.join(self.sig.inputs)}, noise: {self.sig.noise})")
        self.take("op", "[", what="'[' after a signal name")
        k = self.take("name", what="'k' as time index")
        if k[1] != "k":
            raise TermError(f"malformed term {self.text!r}: time index must be "
                            f"'k', got {k[1]!r} at position {k[2]}")
        lag = 0
        if self.peek()[1] == "-":
            self.i += 1
            digits = self.take("num", what="a lag (integer)")[1]
            if len(digits) > 6:                  # before int(): no huge conversion
                raise TermError(f"lag {digits[:12]}... of {name!r} exceeds the maximum "
                                f"{MAX_LAG} in term {self.text[:60]!r}")
            lag = int(digits)
        elif self.peek()[1] == "+":
            raise TermError(f"future sample in term {self.text!r}: "
                            f"{name}[k+...] is not causal")
        self.take("op", "]", what="']'")
        if lag > MAX_LAG:
            raise TermError(f"lag {lag} of {name!r} exceeds the maximum {MAX_LAG} "
                            f"in term {self.text!r}")
        if lag == 0 and role in ("y", "e"):
            raise TermError(f"{name}[k] at lag 0 on the right-hand side of term "
                            f"{self.text!r}: output and noise lags must be >= 1")
        return Lag(name, lag, role)

    def phi_call(self, name) -> PhiCall:
        if name not in self.reg:
            raise TermError(f"unknown Φ-function {name!r} in term {self.text!r} "
                            f"(registered: {', '.join(self.reg.names())}; memory "
                            f"operators: {', '.join(self.ops)}; register yours with "
                            f"narx.register_phi or narx.language.memory.register_operator, or "
                            f"give the mggp command --phi-module MODULE)")
        fn = self.reg.get(name)
        self.take("op", "(")
        args = []
        while True:
            t = self.take("name", what="a lagged signal argument")
            if self.peek()[1] == "(":
                raise TermError(f"nested Φ-calls are not allowed in term "
                                f"{self.text!r}: the argument of {name} must be a "
                                f"lagged signal, got {t[1]}(...)")
            args.append(self.lag(t[1], t))
            if self.peek()[1] == ",":
                self.i += 1
                continue
            break
        self.take("op", ")", what="',' or ')'")
        if len(args) != fn.arity:
            raise TermError(f"{name} takes {fn.arity} argument"
                            f"{'s' if fn.arity != 1 else ''}, got {len(args)} "
                            f"in term {self.text!r}")
        return PhiCall(name, tuple(args))

    def op_call(self, name) -> OpCall:
        op = self.ops.get(name)
        self.take("op", "(")
        t = self.take("name", what="a lagged signal argument")
        if self.peek()[1] == "(":
            raise TermError(f"nested calls are not allowed in term {self.text!r}: "
                            f"the argument of {name} must be a lagged signal, "
                            f"got {t[1]}(...)")
        arg = self.lag(t[1], t)
        if arg.role == "e":
            raise TermError(f"{name} of the noise signal in term {self.text!r}: "
                            f"operators take an input or an output lag")
        texts = []
        while self.peek()[1] == ",":
            self.i += 1
            texts.append(self.param_text())
        self.take("op", ")", what="',' or ')'")
        try:
            params = op.check_params(texts)
        except ValueError as exc:
            raise TermError(f"{exc} in term {self.text!r}") from None
        return OpCall(name, arg, params)

    def param_text(self) -> str:
        """Raw text of one operator parameter (a signed number, else the
        offending text for the error message)."""
        start = self.peek()[2]
        sign = ""
        if self.peek()[1] in ("-", "+"):
            sign = self.peek()[1]
            self.i += 1
        tok = self.peek()
        if tok[0] in ("real", "num"):
            self.i += 1
            return sign + tok[1]
        while self.peek()[0] != "end" and self.peek()[1] not in (",", ")"):
            self.i += 1
        return self.text[start:self.peek()[2]].strip() or "nothing"


def parse_term(text, signals: Optional[Signals] = None, *,
               registry: Optional[PhiRegistry] = None,
               operators: Optional[OperatorRegistry] = None) -> Term:
    """Parse term text into a canonical :class:`Term`.

    Parameters
    ----------
    text : str or Term
    signals : Signals, optional
        Signal names (default output ``y``, input ``u``, noise ``e``).
    registry : PhiRegistry, optional
        Φ-functions that may appear (default: process-wide registry).
    operators : OperatorRegistry, optional
        Memory operators that may appear (default: process-wide registry).

    Raises
    ------
    TermError
        Malformed text, unknown signal or Φ-function, wrong arity, an output
        at lag 0, a future sample, an operator parameter that is missing,
        not a number or outside its domain, a nested call.
    """
    if isinstance(text, Term):
        return text
    if not isinstance(text, str):
        raise TermError(f"a term must be text, got {type(text).__name__}: {text!r}")
    if not text.strip():
        raise TermError("empty term text")
    return _Parser(text, signals or Signals(), registry or default_registry(),
                   operators or default_operators()).term()


def parse_terms(texts: Sequence, signals: Optional[Signals] = None, *,
                registry: Optional[PhiRegistry] = None,
                operators: Optional[OperatorRegistry] = None,
                unique: bool = True) -> Tuple[Term, ...]:
    """Parse several terms; with ``unique`` a repeated term is an error."""
    if isinstance(texts, (str, Term)):
        texts = [texts]
    terms = tuple(parse_term(t, signals, registry=registry, operators=operators)
                  for t in texts)
    if unique:
        seen = {}
        for i, t in enumerate(terms):
            if t in seen:
                raise TermError(f"term {str(t)!r} appears twice (positions "
                                f"{seen[t] + 1} and {i + 1})")
            seen[t] = i
    return terms
