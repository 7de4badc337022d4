"""Term text <-> neutral structure, and <-> the published toolbox's GP trees.

The peers never import ``narx``; this tiny parser keeps them independent (it
does not replace ``narx.language.terms``). The neutral structure of a term is a list
of factors, each ``{"kind": "lag", "signal": "u", "lag": 1}`` or ``{"kind":
"phi", "name": "Phi2", "args": [{"signal": "u", "lag": 4}, {"signal": "u",
"lag": 1}]}``; ``[]`` is the constant term ``1``. ``Phi1(a,b) = a - b``,
``Phi2(a,b) = sign(a - b)``.

Typical use::

    from benchmarks.peers.terms import parse_term, term_text, to_toolbox
    t = parse_term("y[k-2]*u[k-1]*Phi2(u[k-4],u[k-1])")
    term_text(t)             # 'y[k-2]*u[k-1]*Phi2(u[k-4],u[k-1])'
    to_toolbox(t)            # 'mul(mul(q1(y1), u1), Phi2(q3(u1), u1))'

Printing sorts factors as ``narx`` does (output lags, input lags by name,
then Φ-calls by name and arguments), so texts usually come out canonical;
re-parse them with ``narx`` when in doubt. ``u[k]`` is lag 0; ``x^2`` and
``x**2`` are accepted and printed as repeated factors. Nothing is evaluated.

The toolbox's trees (DEAP prefix strings) use ``mul``, back-shifts
``q1..q3`` (``q_i(x)`` is ``x`` delayed by i samples) and terminals that are
one-step-lagged signals (``y1`` = y[k-1], ``u1`` = u[k-1]); it has no lag-0
terminal, so a factor ``u[k]`` is mapped to an extra variable ``u0`` holding
``u`` one sample ahead (``u0[k-1] = u[k]``). See :func:`toolbox_variables`.
"""
from __future__ import annotations

import re
from typing import Dict, List, Optional, Sequence, Union

__all__ = ["parse_term", "parse_terms", "as_struct", "term_text", "signals_of", "max_lag",
           "toolbox_variables", "to_toolbox", "from_toolbox", "TermSyntaxError"]

Struct = List[dict]
TermLike = Union[str, Sequence[dict]]
_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_TOKEN = re.compile(r"\s*(?:(?P<num>\d+)|(?P<name>[A-Za-z_][A-Za-z0-9_]*)"
                    r"|(?P<op>\*\*|[\[\]\(\),*^+\-]))")


class TermSyntaxError(ValueError):
    """Term text or structure that cannot be read."""


def _tokens(text: str):
    pos, out = 0, []
    text = text.strip()
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if not m or m.end() == pos:
            raise TermSyntaxError(f"unexpected character {text[pos:pos + 1]!r} at "
                                  f"{pos} in {text!r}")
        kind = m.lastgroup
        out.append((kind, m.group(kind)))
        pos = m.end()
    return out


class _Reader:
    def __init__(self, text: str):
        self.text, self.toks, self.i = text, _tokens(text), 0

    def peek(self, value=None):
        if self.i >= len(self.toks):
            return None
        tok = self.toks[self.i]
        return tok if value is None or tok[1] == value else None

    def take(self, value=None, kind=None):
        tok = self.peek()
        if tok is None or (value is not None and tok[1] != value) or \
                (kind is not None and tok[0] != kind):
            want = value or kind
            got = tok[1] if tok else "end of text"
            raise TermSyntaxError(f"expected {want!r}, got {got!r} in {self.text!r}")
        self.i += 1
        return tok[1]

    def lagref(self) -> dict:
        sig = self.take(kind="name")
        self.take("[")
        if self.take(kind="name") != "k":
            raise TermSyntaxError(f"time index must be k in {self.text!r}")
        lag = 0
        if self.peek("-"):
            self.take("-")
            lag = int(self.take(kind="num"))
        elif self.peek("+"):
            raise TermSyntaxError(f"future samples are not allowed in {self.text!r}")
        self.take("]")
        return {"signal": sig, "lag": lag}

    def factor(self) -> List[dict]:
        tok = self.peek()
        if tok and tok[0] == "num":
            if self.take() != "1":
                raise TermSyntaxError(f"the only number allowed is 1 in {self.text!r}")
            return []
        name = self.take(kind="name")
        if self.peek("("):
            self.take("(")
            args = [self.lagref()]
            while self.peek(","):
                self.take(",")
                args.append(self.lagref())
            self.take(")")
            base = [{"kind": "phi", "name": name, "args": args}]
        else:
            self.i -= 1
            base = [dict(kind="lag", **self.lagref())]
        if self.peek("^") or self.peek("**"):
            self.take()
            power = int(self.take(kind="num"))
            if power < 1:
                raise TermSyntaxError(f"power must be >= 1 in {self.text!r}")
            base = base * power
        return base

    def term(self) -> Struct:
        factors = self.factor()
        while self.peek("*"):
            self.take("*")
            factors += self.factor()
        if self.peek() is not None:
            raise TermSyntaxError(f"unexpected {self.peek()[1]!r} in {self.text!r}")
        return factors


def _check_lag(d: dict, where: str) -> dict:
    sig, lag = d.get("signal"), d.get("lag")
    if not isinstance(sig, str) or not _IDENT.match(sig) or sig == "k":
        raise TermSyntaxError(f"bad signal name {sig!r} in {where}")
    if isinstance(lag, bool) or not isinstance(lag, int) or lag < 0:
        raise TermSyntaxError(f"lag must be an int >= 0, got {lag!r} in {where}")
    return {"signal": sig, "lag": lag}


def as_struct(term: TermLike) -> Struct:
    """Validated neutral structure of a term given as text or structure."""
    if isinstance(term, str):
        return _Reader(term).term()
    out = []
    for f in term:
        kind = f.get("kind") if isinstance(f, dict) else None
        if kind == "lag":
            out.append(dict(kind="lag", **_check_lag(f, repr(term))))
        elif kind == "phi":
            name, args = f.get("name"), f.get("args")
            if not isinstance(name, str) or not _IDENT.match(name) or not args:
                raise TermSyntaxError(f"bad Φ factor {f!r}")
            out.append({"kind": "phi", "name": name,
                        "args": [_check_lag(a, repr(f)) for a in args]})
        else:
            raise TermSyntaxError(f"factor must be a dict with kind 'lag' or 'phi': {f!r}")
    return out


def parse_term(text: str) -> Struct:
    """``"y[k-1]*Phi2(u[k-2],u[k-3])"`` -> list of factor dicts (``"1"`` -> [])."""
    if not isinstance(text, str):
        raise TypeError(f"term text must be a str, got {type(text).__name__}")
    return as_struct(text)


def parse_terms(terms: Sequence[TermLike]) -> List[Struct]:
    """Each term (text or structure) as a validated structure."""
    if isinstance(terms, str):
        raise TypeError("give a list of terms, not one string")
    return [as_struct(t) for t in terms]


def _lag_text(a: dict) -> str:
    return f"{a['signal']}[k]" if a["lag"] == 0 else f"{a['signal']}[k-{a['lag']}]"


def _key(f: dict, output: str):
    if f.get("kind", "lag") == "lag" or "name" not in f:
        return (0 if f["signal"] == output else 1, f["signal"], f["lag"])
    return (3, f["name"], tuple(_key(a, output) for a in f["args"]))


def term_text(term: TermLike, output: str = "y") -> str:
    """Text of a term, factors sorted like ``narx``'s canonical form."""
    fs = sorted(as_struct(term), key=lambda f: _key(f, output))
    parts = [_lag_text(f) if f["kind"] == "lag" else
             f"{f['name']}({','.join(_lag_text(a) for a in f['args'])})" for f in fs]
    return "*".join(parts) if parts else "1"


def signals_of(terms: Sequence[TermLike]) -> Dict[str, int]:
    """Signal name -> smallest lag it appears with, over all terms."""
    out: Dict[str, int] = {}
    for t in parse_terms(terms):
        for f in t:
            for a in ([f] if f["kind"] == "lag" else f["args"]):
                out[a["signal"]] = min(out.get(a["signal"], a["lag"]), a["lag"])
    return out


def max_lag(terms: Sequence[TermLike]) -> int:
    """Largest lag in a term set (0 for constants only)."""
    lags = [a["lag"] for t in parse_terms(terms) for f in t
            for a in ([f] if f["kind"] == "lag" else f["args"])]
    return max(lags, default=0)


# ------------------------------------------------------- the toolbox's trees
_PRIMS = {"mul", "q1", "q2", "q3", "Phi1", "Phi2"}


def toolbox_variables(terms: Sequence[TermLike], output: str = "y",
                      inputs: Sequence[str] = ("u",)) -> List[dict]:
    """The toolbox's argument list for a term set (output first, as it requires).

    Each entry is ``{"arg": "u1", "signal": "u", "lead": False}``; an input
    used at lag 0 also gets ``{"arg": "u0", "signal": "u", "lead": True}``
    (the caller feeds it ``u`` advanced by one sample).
    """
    used = signals_of(terms) if terms else {}
    if used.get(output, 1) == 0:
        raise TermSyntaxError(f"{output}[k] cannot be a regressor of {output}[k]")
    unknown = set(used) - {output, *inputs}
    if unknown:
        raise TermSyntaxError(f"terms use unknown signals {sorted(unknown)}; "
                              f"output {output!r}, inputs {list(inputs)}")
    out = [{"arg": f"{output}1", "signal": output, "lead": False}]
    out += [{"arg": f"{s}1", "signal": s, "lead": False} for s in inputs]
    out += [{"arg": f"{s}0", "signal": s, "lead": True} for s in inputs if used.get(s) == 0]
    names = [v["arg"] for v in out]
    if len(set(names)) != len(names) or _PRIMS & set(names):
        raise TermSyntaxError(f"signal names {names} clash in the toolbox's tree language")
    return out


def _lag_tree(a: dict) -> str:
    if a["lag"] == 0:
        return f"{a['signal']}0"
    expr, shift = f"{a['signal']}1", a["lag"] - 1
    while shift > 0:
        step = min(3, shift)
        expr, shift = f"q{step}({expr})", shift - step
    return expr


def to_toolbox(term: TermLike) -> str:
    """A term as the toolbox's tree string (left-nested ``mul``; ``"1"`` for constant)."""
    parts = [_lag_tree(f) if f["kind"] == "lag" else
             f"{f['name']}({', '.join(_lag_tree(a) for a in f['args'])})"
             for f in as_struct(term)]
    if not parts:
        return "1"
    expr = parts[0]
    for p in parts[1:]:
        expr = f"mul({expr}, {p})"
    return expr


def _tree(text: str):
    toks = re.findall(r"[A-Za-z_][A-Za-z0-9_]*|\d+(?:\.\d+)?|[(),]", text)
    pos = 0

    def node():
        nonlocal pos
        name = toks[pos]
        pos += 1
        kids = []
        if pos < len(toks) and toks[pos] == "(":
            pos += 1
            kids.append(node())
            while toks[pos] == ",":
                pos += 1
                kids.append(node())
            if toks[pos] != ")":
                raise TermSyntaxError(f"bad tree {text!r}")
            pos += 1
        return name, kids
    tree = node()
    if pos != len(toks):
        raise TermSyntaxError(f"trailing text in tree {text!r}")
    return tree


def _shift(fs: Struct, i: int) -> Struct:
    out = []
    for f in fs:
        if f["kind"] == "lag":
            out.append(dict(f, lag=f["lag"] + i))
        else:
            out.append(dict(f, args=[dict(a, lag=a["lag"] + i) for a in f["args"]]))
    return out


def from_toolbox(tree: str, variables: Sequence[dict]) -> Optional[Struct]:
    """The term a toolbox tree computes, or None if our language cannot say it.

    ``q_i`` over any subtree is pushed down to the lags (it delays the whole
    subexpression); Φ-calls must have plain lagged signals as arguments.
    """
    by_arg = {v["arg"]: v for v in variables}

    def ev(node) -> Optional[Struct]:
        name, kids = node
        if not kids:
            if name == "1":
                return []
            v = by_arg.get(name)
            if v is None:
                raise TermSyntaxError(f"unknown terminal {name!r} in {tree!r}")
            return [{"kind": "lag", "signal": v["signal"], "lag": 0 if v["lead"] else 1}]
        vals = [ev(k) for k in kids]
        if any(v is None for v in vals):
            return None
        if re.fullmatch(r"q\d+", name) and len(vals) == 1:
            return _shift(vals[0], int(name[1:]))
        if name == "mul":
            return [f for v in vals for f in v]
        if re.fullmatch(r"Phi\d*", name):
            if not all(len(v) == 1 and v[0]["kind"] == "lag" for v in vals):
                return None
            return [{"kind": "phi", "name": name,
                     "args": [{"signal": v[0]["signal"], "lag": v[0]["lag"]} for v in vals]}]
        return None
    return ev(_tree(tree))
