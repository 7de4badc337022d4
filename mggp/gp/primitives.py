"""Typed DEAP primitive set for NARX terms, safe tree parsing and decoding.

Typical use::

    from narx.language.terms import Signals
    from mggp.gp.primitives import make_pset, tree_from_tokens, Decoder

    pset = make_pset(Signals("y", ("u",)))
    tree = tree_from_tokens(["q1", "mul", "y[k-1]", "Phi1", "u[k-1]", "q1",
                             "u[k-1]"], pset)
    str(tree)                       # 'q1(mul(y[k-1], Phi1(u[k-1], q1(u[k-1]))))'
    Decoder(pset.signals).decode(tree).text
    # 'y[k-2]*Phi1(u[k-2],u[k-3])'

Type design
-----------
DEAP selects candidates by type; the types are:

``Expr``
    A monomial (product of factors); the type of every gene root. Terminals
    ``y[k-1]`` and ``u[k-1]`` (one per input: ``u1[k-1]``, ``u2[k-1]``);
    primitives ``mul(Expr, Expr)``, the back-shifts ``q1, q2, q3 (Expr)``
    (q⁻¹..q⁻³, shifting every lag inside their argument, Φ arguments
    included) and the Φ-functions ``Phi1, Phi2, <user> (InputLag, ...)``.
``InputLag``
    A single lagged input, the only thing a Φ-function accepts. Terminal:
    the input ``u[k-1]`` again; primitives: the back-shifts ``q1, q2, q3
    (InputLag)``. An ``InputLag`` subtree is a chain of back-shifts over one
    input terminal, so ``Phi1(q2(u[k-1]), u[k-1])`` is
    ``Phi1(u[k-3],u[k-1])``; Φ of an output is never built, unless
    ``phi_outputs``: the output then has a lag type of its own, as below.
``InputLag_u1``, ``InputLag_u2``, ... (several inputs)
    One lagged-input type per input (:func:`input_lag_type`, subclasses of
    ``InputLag``, which is then unused), each with its own terminal
    ``u1[k-1]`` and back-shifts; every Φ-function is registered once per
    input type: ``Phi1 (InputLag_u1, InputLag_u1)``, ``Phi1 (InputLag_u2,
    InputLag_u2)``, ... So the arguments of a Φ-call are lags of one and
    the same input, in random trees and after every crossover and mutation
    (they exchange or regrow subtrees of one type): ``Phi1(u2[k-8],u1[k-7])``
    would compare signals of different units and is never built. The
    generator draws a Φ-function as one choice and then its input
    (:func:`mggp.gp.operators.gen_tree`), so Φ-calls are not drawn more often
    with more inputs. With one input the set is the historical one (type
    ``InputLag``, same nodes in the same order): single-input searches are
    unchanged draw for draw.
    Only the search is restricted: a hand-written model (``narx.Model``,
    ``mggp estimate``) may still use a Φ-call mixing inputs.

Memory operators (``operators``, see :mod:`narx.language.memory`) are primitives
``(OperatorArg_<input>) -> Expr`` (:func:`operator_arg_type`, one type
per input) whose argument is the terminal ``u[k-1]`` alone:
``Play@0.2(u[k-1])`` decodes to ``Play(u[k-1],0.2)``, and only a
back-shift of the whole monomial delays it (``q1(Play@0.2(u[k-1]))`` is
``Play(u[k-2],0.2)``). Lagged copies of one operator column differ by
one step of a slowly varying signal; as separate regressors their
differences act as rate features of large, cancelling coefficients,
which the training record does not pin down (the free run then spikes
where the input stops). One column per operator and parameter, delayed
as a whole, avoids offering them. The
node name is the operator's name, then ``@`` and its parameters (a play
once per radius of :func:`play_radii`); the plays of all radii are one
choice for the tree generator (:mod:`mggp.gp.operators`), so adding radii does
not make plays more frequent. Operators take lagged inputs only: their
columns depend on the input alone and are computed once per record.

Back-shifts, input terminals and Φ-functions exist once per type under the
same name; the type of a node follows from its parent's argument type, and
the type of a Φ-call from its first argument's input terminal, so a tree's
text (and its list of node names) identifies it uniquely. That is why
:func:`tree_from_tokens` resolves names by the type expected at each
position, and never calls ``eval`` (unlike ``PrimitiveTree.from_string``).

Heights follow DEAP (a lone terminal has height 0). A path of ``h``
back-shifts adds at most ``3 h`` to the lag of a terminal at ``k-1``, so the
largest lag a tree of height ``H`` can express is ``1 + 3 H`` (16 for the
published ``H = 5``). With ``use_phi=False`` the set is ``{mul, q1, q2, q3}``
over ``Expr`` only (plain polynomial NARX, ``--no-phi``).
"""
from __future__ import annotations

from typing import Dict, Iterable, List, Optional, Sequence, Tuple

from deap import gp

from narx.language.memory import OPERATOR_BUILTINS, default_operators, operator_table
from narx.language.memory import BOUC_WEN_SHAPES, PLAY_RADIUS_FRACTIONS  # noqa: F401 (re-exported)
from narx.language.phi import PhiRegistry, default_registry
from narx.language.terms import Lag, OpCall, PhiCall, Signals, Term, format_param

__all__ = ["Expr", "InputLag", "input_lag_type", "LagSymbol", "SHIFTS", "make_pset",
           "tree_from_tokens", "tree_to_tokens", "decode", "Decoder",
           "decode_individual", "max_lag_for_height", "reachable_lag", "play_radii",
           "OPERATOR_CHOICES",
           "operator_node_name", "search_operators", "operator_names", "bouc_wen_shapes",
           "BOUC_WEN_SHAPES", "PLAY_RADIUS_FRACTIONS", "AUTO_OPERATORS", "auto_classes",
           "operator_choices", "operator_grid",
           "operator_arg_type"]

#: the built-in operators by their command-line name (the operator's name in
#: lower case); :func:`operator_choices` adds the registered plug-ins
OPERATOR_CHOICES = {op.name.lower(): op.name for op in OPERATOR_BUILTINS}


def _class_names(label: str) -> Tuple[str, ...]:
    """Command-line names of the built-ins whose ``auto_class`` is ``label``."""
    return tuple(op.name.lower() for op in OPERATOR_BUILTINS if op.auto_class == label)


#: operators of the model class "operators" that ``operators='auto'`` pilots:
#: the rate-independent ones (``auto_class`` 'operators' in
#: :data:`narx.language.memory.OPERATOR_BUILTINS`). The Bouc–Wen variables are a
#: class of their own (:func:`mggp.fit.choices.search_classes`): in this one they
#: won the pilots on Prandtl–Ishlinskii, MR damper and Bouc–Wen oscillator
#: records whose validation they then simulated worse
#: (``benchmarks/results/defaults.md``)
AUTO_OPERATORS = _class_names("operators")


def auto_classes() -> Dict[str, Tuple[str, ...]]:
    """Model class -> command-line names of the operators it pilots, for
    ``operators='auto'`` (``auto_class`` of the operator table, classes in
    the order of their first operator): ``{'operators': ('play', 'dengtan'),
    'Bouc–Wen': ('boucwen',)}``."""
    out: Dict[str, Tuple[str, ...]] = {}
    for op in OPERATOR_BUILTINS:
        if op.auto_class is not None:
            out[op.auto_class] = _class_names(op.auto_class)
    return out


def operator_choices() -> Dict[str, str]:
    """Command-line name -> operator name of every registered operator
    (:func:`narx.language.memory.operator_table`: built-ins, then plug-ins)."""
    return {op.name.lower(): op.name for op in operator_table()}


def _span(u) -> float:
    import numpy as np
    return float(np.max(u) - np.min(u))


def operator_grid(name: str, u) -> Tuple[Tuple[float, ...], ...]:
    """Parameter tuples the search offers of operator ``name`` (its name
    or command-line name) for an input ``u``: the operator table's
    :meth:`narx.language.memory.MemoryOperator.search_grid` of its range
    ``max(u) - min(u)``."""
    return default_operators().get(operator_choices().get(name, name)).search_grid(_span(u))


def play_radii(u) -> Tuple[float, ...]:
    """Play radii of the search for an input ``u``
    (:func:`operator_grid`: :data:`narx.language.memory.PLAY_RADIUS_FRACTIONS` of
    its range, two significant digits; empty for a constant input)."""
    return tuple(p[0] for p in operator_grid("Play", u))


def bouc_wen_shapes(u) -> Tuple[Tuple[float, float], ...]:
    """Bouc–Wen parameters (β, γ) of the search for an input ``u``
    (:func:`operator_grid`: one pair per shape of
    :data:`narx.language.memory.BOUC_WEN_SHAPES`; empty for a constant input)."""
    return operator_grid("BoucWen", u)


def operator_names(names, searchable: bool = True) -> Tuple[str, ...]:
    """Command-line operator names (keys of :func:`operator_choices`) from
    None, a sequence of names or comma-separated text, lower-cased.

    Raises
    ------
    ValueError
        An unknown name, with ``searchable`` an operator the search cannot
        offer (parameters and no search grid), or a value of another kind.
    """
    if names is None:
        return ()
    if isinstance(names, str):
        names = [n for n in names.split(",") if n.strip()] or [names]
    if not isinstance(names, (list, tuple)) or not all(isinstance(n, str) for n in names):
        raise ValueError(f"operators must be None, names or comma-separated text, "
                         f"got {names!r}")
    out = tuple(n.strip().lower() for n in names)
    choices = operator_choices()
    bad = [n for n in out if n not in choices]
    if bad:
        raise ValueError(f"operators must name some of {', '.join(choices)}, "
                         f"got {bad[0]!r}")
    for n in out if searchable else ():
        op = default_operators().get(choices[n])
        if not op.searchable:
            op.search_grid(1.0)                   # raises: no search grid
    return out


def search_operators(names, U):
    """The ``operators`` argument of :func:`make_pset` for operator names
    (:func:`operator_names`) and the inputs ``U`` (rows): each operator's
    :func:`operator_grid` of the widest input (plays of
    :func:`play_radii`, Bouc-Wen variables of :func:`bouc_wen_shapes`,
    Deng-Tan once).

    Raises
    ------
    ValueError
        An unknown name, an operator without a search grid.
    """
    import numpy as np
    U = np.atleast_2d(U)
    widest = U[int(np.argmax(np.ptp(U, axis=1)))]
    choices = operator_choices()
    return {choices[n]: list(operator_grid(choices[n], widest))
            for n in operator_names(names)}


def operator_node_name(name: str, params: Sequence[float]) -> str:
    """Node name of an operator primitive: ``Play@0.2``, ``DengTan``."""
    return name + "".join("@" + format_param(p) for p in params)

#: the back-shift operators q⁻¹..q⁻³, by node name
SHIFTS = {"q1": 1, "q2": 2, "q3": 3}
_RESERVED = ("mul",) + tuple(SHIFTS)


class Expr:
    """GP type of a monomial (any subtree usable as a factor product)."""


class InputLag:
    """GP type of one lagged input: the only argument type of Φ-functions.

    With several inputs each has its own subclass (:func:`input_lag_type`);
    ``input`` is then that input's name (None for this base class).
    """

    input: Optional[str] = None


_INPUT_LAG_TYPES: Dict[str, type] = {}
_TYPE_PREFIX = "InputLag_"


def input_lag_type(name: str) -> type:
    """The GP type of the lags of input ``name`` in a several-input set.

    One class per name and process, ``InputLag_<name>``, a subclass of
    :class:`InputLag`. It is reachable as ``mggp.gp.primitives.InputLag_<name>``
    (created on first access), so trees and individuals holding it pickle
    and load in another process.

    Parameters
    ----------
    name : str
        Input name (an identifier, see :class:`narx.language.terms.Signals`).

    Returns
    -------
    type
    """
    return _per_input_type(_INPUT_LAG_TYPES, _TYPE_PREFIX, name,
                           f"GP type of one lag of input {name!r}.")


def _per_input_type(cache: Dict[str, type], prefix: str, name: str, doc: str) -> type:
    """The subclass ``<prefix><name>`` of :class:`InputLag`, made once per
    process and kept in ``cache``."""
    t = cache.get(name)
    if t is None:
        if not name.isidentifier():
            raise ValueError(f"input name must be an identifier, got {name!r}")
        t = type(prefix + name, (InputLag,),
                 {"__module__": __name__, "input": name, "__doc__": doc})
        cache[name] = t
    return t


_OPERATOR_ARG_TYPES: Dict[str, type] = {}
_OP_PREFIX = "OperatorArg_"


def operator_arg_type(name: str) -> type:
    """The GP type of the argument of a memory operator of input ``name``.

    One class per name and process, ``OperatorArg_<name>``, a subclass of
    :class:`InputLag` whose only node is the terminal ``name[k-1]``: no
    back-shift applies inside an operator, so a gene holds the operator
    column of ``name[k-1]`` (a back-shift of the whole monomial still
    delays it). Reachable as ``mggp.gp.primitives.OperatorArg_<name>`` for
    pickling.

    Parameters
    ----------
    name : str
        Input name (an identifier).

    Returns
    -------
    type
    """
    return _per_input_type(_OPERATOR_ARG_TYPES, _OP_PREFIX, name,
                           f"GP type of the operator argument {name}[k-1].")


def __getattr__(attr):
    # module attribute lookup used by pickle for the per-input types
    if attr.startswith(_TYPE_PREFIX) and attr[len(_TYPE_PREFIX):].isidentifier():
        return input_lag_type(attr[len(_TYPE_PREFIX):])
    if attr.startswith(_OP_PREFIX) and attr[len(_OP_PREFIX):].isidentifier():
        return operator_arg_type(attr[len(_OP_PREFIX):])
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")


def _lag_types(inputs: Sequence[str]) -> Dict[str, type]:
    """Input name -> lagged-input type: ``InputLag`` for a single input."""
    if len(inputs) == 1:
        return {inputs[0]: InputLag}
    return {name: input_lag_type(name) for name in inputs}


class LagSymbol:
    """Value of a terminal node: a :class:`narx.language.terms.Lag` that prints as
    its term text (``y[k-1]``), so trees print readably and decode without
    any name lookup."""

    __slots__ = ("lag",)

    def __init__(self, lag: Lag):
        self.lag = lag

    def __repr__(self):
        return str(self.lag)

    __str__ = __repr__

    def __eq__(self, other):
        if not isinstance(other, LagSymbol):
            return NotImplemented
        return self.lag == other.lag

    def __hash__(self):
        return hash(("LagSymbol", self.lag))

    def __getstate__(self):
        return (self.lag.signal, self.lag.lag, self.lag.role)

    def __setstate__(self, st):
        self.lag = Lag(*st)


# Primitive callables: the set is never compiled, these only give DEAP a
# unique object per name (the same object is registered for both types).
def _symbolic(name):
    def f(*args):
        raise TypeError(f"NARX primitive {name!r} is symbolic; decode the tree "
                        "with mggp.gp.primitives.decode instead of compiling it")
    f.__name__ = name
    return f


_PRIM_FUNCS = {n: _symbolic(n) for n in _RESERVED}


def make_pset(signals: Optional[Signals] = None,
              registry: Optional[PhiRegistry] = None, use_phi: bool = True,
              phi_names: Optional[Iterable[str]] = None,
              phi_outputs: bool = False,
              operators: Optional[Dict[str, Sequence[Tuple[float, ...]]]] = None
              ) -> gp.PrimitiveSetTyped:
    """Build the typed primitive set for NARX terms.

    Parameters
    ----------
    signals : narx.language.terms.Signals, optional
        Output and input names (default ``y`` and ``u``).
    registry : narx.language.phi.PhiRegistry, optional
        Where Φ-functions come from (default: the process-wide registry).
    use_phi : bool
        False gives the plain polynomial set ``{mul, q1, q2, q3}``.
    phi_names : iterable of str, optional
        The Φ-functions to include (default: every function in the
        registry, built-ins and user plug-ins, in sorted name order).
    phi_outputs : bool
        Φ-functions of output lags too (``Phi1(y[k-1],y[k-2])``: hysteresis
        driven by a velocity); default False, the published setup.
    operators : dict, optional
        Memory operators of the inputs: operator name -> parameter tuples,
        one primitive each, e.g. ``{"Play": [(0.1,), (0.2,)], "DengTan":
        [()]}`` (see :func:`play_radii`); default none.

    Returns
    -------
    deap.gp.PrimitiveSetTyped
        Root type :class:`Expr`; extra attributes ``signals`` and
        ``phi_names`` (tuple) record how it was built, ``lag_types`` maps
        each input name to its lagged-input type (:class:`InputLag` for a
        single input, :func:`input_lag_type` for several; empty without Φ).

    Notes
    -----
    Every Φ-function is added once per lagged-input type, all its
    arguments of that type: the search only builds Φ-calls whose arguments
    are lags of one and the same input (see the module notes).

    Raises
    ------
    ValueError
        Unknown Φ name, or a Φ/input name clashing with ``mul``/``q1..q3``.
    """
    signals = signals if signals is not None else Signals()
    registry = registry if registry is not None else default_registry()
    if use_phi:
        names = registry.names() if phi_names is None else list(phi_names)
        phis = []
        for n in names:
            if n not in registry:
                raise ValueError(f"unknown Φ-function {n!r} (registered: "
                                 f"{', '.join(registry.names())})")
            if n in _RESERVED:
                raise ValueError(f"Φ-function name {n!r} clashes with a GP primitive")
            if n in (signals.output, *signals.inputs):
                raise ValueError(f"Φ-function name {n!r} clashes with a signal name")
            if all(p.name != n for p in phis):
                phis.append(registry.get(n))
    else:
        phis = []
    pset = gp.PrimitiveSetTyped("NARX", [], Expr)
    pset.addTerminal(LagSymbol(Lag(signals.output, 1, "y")), Expr)
    for name in signals.inputs:
        pset.addTerminal(LagSymbol(Lag(name, 1, "u")), Expr)
    pset.addPrimitive(_PRIM_FUNCS["mul"], [Expr, Expr], Expr, name="mul")
    for q in SHIFTS:
        pset.addPrimitive(_PRIM_FUNCS[q], [Expr], Expr, name=q)
    ops = []
    for name, plist in (operators or {}).items():
        op = default_operators().get(name)
        for params in plist:
            ops.append((op.name, op.check_params(tuple(params))))
    phi_signals = list(signals.inputs) + ([signals.output] if phi_outputs and phis else [])
    lag_types = _lag_types(phi_signals) if phis else {}
    # one input: the historical order (terminal, q1..q3, Φs) on InputLag
    for name, t in lag_types.items():
        pset.addTerminal(LagSymbol(Lag(name, 1, "y" if name == signals.output else "u")), t)
        for q in SHIFTS:
            pset.addPrimitive(_PRIM_FUNCS[q], [t], t, name=q)
    for f in phis:
        for t in lag_types.values():
            pset.addPrimitive(f.func, [t] * f.arity, Expr, name=f.name)
    op_types = {n: operator_arg_type(n) for n in signals.inputs} if ops else {}
    for name, t in op_types.items():
        pset.addTerminal(LagSymbol(Lag(name, 1, "u")), t)
    for name, params in ops:
        node = operator_node_name(name, params)
        func = _PRIM_FUNCS.setdefault(node, _symbolic(node))
        for iname, t in op_types.items():
            pset.addPrimitive(func, [t], Expr, name=node)
    pset.signals = signals
    pset.lag_types = lag_types
    pset.phi_names = tuple(f.name for f in phis)
    pset.phi_outputs = bool(phi_outputs and phis)
    pset.operator_nodes = tuple(operator_node_name(n, p) for n, p in ops)
    return pset


def max_lag_for_height(height: int) -> int:
    """Largest lag a tree of DEAP height ``height`` can express: ``1 + 3h``."""
    return 1 + max(SHIFTS.values()) * height


#: largest max_height: a back-shift chain q⁻³ per level reaches lag 1 + 3h,
#: 61 samples at 20, and the trees (products of up to 2^h factors) take
#: time exponential in h to draw and decode (seconds at 40, a hang at 100);
#: a longer memory is for hand-written terms (``mggp estimate``) or the
#: memory operators (--operators)
MAX_HEIGHT = 20


def reachable_lag(height: int, max_lag=None) -> int:
    """Largest lag a search's terms can have: what trees of ``height`` reach
    (:func:`max_lag_for_height`), capped by ``max_lag`` when given."""
    reach = max_lag_for_height(height)
    return reach if max_lag is None else min(max_lag, reach)


def _index(pset) -> Dict[Tuple[type, str], list]:
    """(type, name) -> nodes; several only for a Φ-function of several inputs."""
    idx: Dict[Tuple[type, str], list] = {}
    for table in (pset.primitives, pset.terminals):
        for t, nodes in table.items():
            for node in nodes:
                same = idx.setdefault((t, node.name), [])
                if node not in same:
                    same.append(node)
    return idx


def _by_first_input(nodes, tokens, pos, pset):
    """Of Φ nodes alike but for their input type, the one whose first
    argument takes the next input terminal after ``pos`` (an input-lag
    subtree is back-shifts over one terminal); else the first node."""
    terminals = {n.name for ns in pset.terminals.values() for n in ns}
    nxt = next((tok for tok in tokens[pos + 1:]
                if isinstance(tok, str) and tok in terminals), None)
    for node in nodes:
        if any(n.name == nxt for n in pset.terminals.get(node.args[0], ())):
            return node
    return nodes[0]


def tree_from_tokens(tokens: Sequence[str], pset, type_=None) -> gp.PrimitiveTree:
    """Rebuild a tree from its node names (prefix order) without ``eval``.

    Parameters
    ----------
    tokens : sequence of str
        Node names, e.g. ``["mul", "y[k-1]", "u[k-1]"]``.
    pset : deap.gp.PrimitiveSetTyped
        The set the names are looked up in (by name and expected type).
    type_ : type, optional
        Root type (default ``pset.ret``).

    Raises
    ------
    ValueError
        ``unknown primitive or terminal 'X'``, a node of the wrong type at
        its position, an incomplete tree, or trailing tokens.
    """
    idx = _index(pset)
    known = {name for (_, name) in idx}
    expected = [type_ if type_ is not None else pset.ret]
    nodes = []
    for pos, tok in enumerate(tokens):
        if not isinstance(tok, str):
            raise ValueError(f"node names must be text, got {tok!r} at position {pos}")
        if not expected:
            raise ValueError(f"trailing node {tok!r} at position {pos}: the tree "
                             "was already complete")
        t = expected.pop()
        cands = idx.get((t, tok))
        if cands is None:
            if tok in known:
                if t.__name__.startswith(_OP_PREFIX):
                    hint = " (a memory operator's argument is the input at k-1)"
                elif getattr(t, "input", None) is not None:
                    hint = " (a Φ-function's arguments are lags of one input)"
                else:
                    hint = ""
                raise ValueError(f"{tok!r} at position {pos} is not allowed where "
                                 f"{t.__name__} is expected{hint}")
            raise ValueError(f"unknown primitive or terminal {tok!r}")
        if len(cands) > 1 and not any(hasattr(n, "args") for n in cands):
            # a terminal of a subtype listed under its supertype too (an
            # operator's argument u[k-1] is also an input lag): the exact one
            cands = [n for n in cands if n.ret is t] or cands[:1]
        node = cands[0] if len(cands) == 1 else _by_first_input(cands, tokens, pos, pset)
        nodes.append(node)
        expected.extend(reversed(getattr(node, "args", ())))
    if not nodes:
        raise ValueError("empty tree: no node names")
    if expected:
        raise ValueError(f"incomplete tree {list(tokens)!r}: {len(expected)} "
                         "argument(s) missing")
    return gp.PrimitiveTree(nodes)


def tree_to_tokens(tree) -> List[str]:
    """Node names of a tree in prefix order (inverse of :func:`tree_from_tokens`)."""
    return [node.name for node in tree]


def _shift(factors, d):
    out = []
    for f in factors:
        if isinstance(f, Lag):
            out.append(Lag(f.signal, f.lag + d, f.role))
        elif isinstance(f, OpCall):
            out.append(OpCall(f.name, Lag(f.arg.signal, f.arg.lag + d, f.arg.role), f.params))
        else:
            out.append(PhiCall(f.name, tuple(Lag(a.signal, a.lag + d, a.role)
                                             for a in f.args)))
    return tuple(out)


def decode(tree, signals: Optional[Signals] = None) -> Term:
    """Reduce a tree to its monomial (no caching; see :class:`Decoder`).

    Parameters
    ----------
    tree : deap.gp.PrimitiveTree
        A tree of the set built by :func:`make_pset`.
    signals : narx.language.terms.Signals, optional
        If given, every terminal must be one of these signals.

    Returns
    -------
    narx.language.terms.Term

    Raises
    ------
    ValueError
        A terminal that is not a lagged signal of ``signals``, a Φ argument
        that is not a lagged input or output, Φ arguments that are lags of
        different signals (trees of :func:`make_pset` never have them; a
        hand-written term may), or a malformed tree.
    """
    stack = []  # values: tuple of factors (Expr) or a Lag (InputLag)
    for node in reversed(tree):
        if node.arity == 0:
            value = node.value
            if not isinstance(value, LagSymbol):
                raise ValueError(f"terminal {node.name!r} is not a lagged signal")
            lag = value.lag
            if signals is not None and signals.role(lag.signal) != lag.role:
                raise ValueError(f"terminal {node.name!r} is not a signal of "
                                 f"{signals}")
            stack.append(lag if issubclass(node.ret, InputLag) else (lag,))
            continue
        if len(stack) < node.arity:
            raise ValueError(f"malformed tree {tree!s}")
        args = [stack.pop() for _ in range(node.arity)]
        name = node.name
        if name == "mul":
            stack.append(args[0] + args[1])
        elif name in SHIFTS:
            a, d = args[0], SHIFTS[name]
            stack.append(Lag(a.signal, a.lag + d, a.role) if isinstance(a, Lag)
                         else _shift(a, d))
        elif name.split("@")[0] in default_operators():
            a = args[0]
            if not (isinstance(a, Lag) and a.role == "u"):
                raise ValueError(f"{name} argument must be a lagged input in {tree!s}")
            op, *params = name.split("@")
            stack.append((OpCall(op, a, tuple(float(p) for p in params)),))
        else:
            if not all(isinstance(a, Lag) and a.role in ("u", "y") for a in args):
                raise ValueError(f"{name} arguments must be lagged signals in {tree!s}")
            if len({a.signal for a in args}) > 1:
                raise ValueError(f"{name} arguments must be lags of one input (or of the "
                                 f"output, with phi_outputs) in {tree!s}")
            stack.append((PhiCall(name, tuple(args)),))
    if len(stack) != 1 or isinstance(stack[0], Lag):
        raise ValueError(f"malformed tree {tree!s}")
    return Term(stack[0])


class Decoder:
    """Tree -> term decoder with a cache keyed by the tree's node names.

    A prefix sequence of node names identifies a tree, since every
    primitive has a fixed arity and a name unique up to its type, which
    the names around it determine (see the module notes; the primitive set
    has no ephemeral constants); building that tuple is several times
    faster than ``str(tree)``.

    Parameters
    ----------
    signals : narx.language.terms.Signals, optional
        Passed to :func:`decode` for validation.
    maxsize : int
        The cache is emptied when it holds this many entries.
    """

    def __init__(self, signals: Optional[Signals] = None, maxsize: int = 200_000):
        self.signals = signals
        self.maxsize = int(maxsize)
        self._cache: Dict[tuple, Term] = {}

    def __len__(self):
        return len(self._cache)

    def clear(self):
        self._cache.clear()

    def decode(self, tree) -> Term:
        """The term of one tree (cached)."""
        key = tuple([node.name for node in tree])
        term = self._cache.get(key)
        if term is None:
            term = decode(tree, self.signals)
            if len(self._cache) >= self.maxsize:
                self._cache.clear()
            self._cache[key] = term
        return term

    def first_genes(self, genes):
        """(term, gene) for the first gene of each distinct term, in order."""
        seen, out = set(), []
        for gene in genes:
            t = self.decode(gene)
            if t not in seen:
                seen.add(t)
                out.append((t, gene))
        return out

    def decode_individual(self, ind) -> Tuple[Term, ...]:
        """Distinct terms of an individual's genes, first occurrence first.

        The result is cached on the individual (``ind._terms``) until it
        changes (see :class:`mggp.gp.individual.Individual`).
        """
        cached = getattr(ind, "_terms", None)
        if cached is not None:
            return cached
        terms = tuple(t for t, _ in self.first_genes(ind))
        if hasattr(ind, "_terms"):
            ind._terms = terms
        return terms


def decode_individual(ind, decoder: Optional[Decoder] = None) -> Tuple[Term, ...]:
    """Distinct terms of an individual in first-occurrence order.

    Genes decoding to the same term count once. ``decoder`` supplies the
    tree cache; without it a throw-away :class:`Decoder` is used.
    """
    return (decoder if decoder is not None else Decoder()).decode_individual(ind)


def identically_zero(term, registry) -> bool:
    """A Φ-call whose arguments are all the same lagged signal and whose
    value at equal arguments is 0 (Phi1, Phi2) makes the term vanish."""
    for f in term.factors:
        if isinstance(f, PhiCall) and len(set(f.args)) == 1:
            fn = registry.get(f.name)
            if fn.steady_is_constant and fn.steady_value() == 0.0:
                return True
    return False
