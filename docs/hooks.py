"""MkDocs hook: the pages' figures and generated blocks come from the code.

Registered in ``mkdocs.yml`` (``hooks: [docs/hooks.py]``). Before a page's
Markdown is converted, every placeholder ``{{ ... }}`` is replaced:

``{{ const mggp.fit.choices.GAIN }}``
    the value of a module attribute (numbers as ``:g``, tuples joined by
    ", "); filters after ``|``: ``percent`` (0.05 -> "5 %", as the
    command line writes it), ``complement`` (1 − x), ``first`` (the
    distinct first items of a tuple of tuples), ``span`` (a range's first
    and last values, "0–999").
``{{ call mggp.fit.choices.class_margins }}``, ``{{ call F ARG ... }}``
    the text a function returns; each argument is a dotted constant or a
    number.
``{{ default mggp.fit.precision.offsets factor }}``
    the default of a function's keyword, or of a row of a parameter table
    (``{{ default mggp.fit.params.DIAGNOSE_PARAMS holdout }}``).
``{{ params }}``
    the table of :data:`mggp.fit.params.PARAMS`: every keyword of
    ``MGGPRegressor``, its rule, default and flag.
``{{ help }}``, ``{{ help fit }}``
    ``mggp --help`` or ``mggp COMMAND --help`` as a text block, from the
    argparse parsers of ``mggp/cli*.py``.
``{{ include benchmarks/RESULTS.md }}``
    a file of the project, its headings one level down.

An unknown placeholder, or one whose name the code does not have, fails the
build with the page and the placeholder named. :func:`render` is the whole
substitution, so tests can call it on a page's text.
"""
from __future__ import annotations

import argparse
import importlib
import inspect
import io
import os
import re
import sys
from contextlib import redirect_stdout

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

PLACEHOLDER = re.compile(r"\{\{\s*(.*?)\s*\}\}", re.S)
#: width of the generated --help text
HELP_COLUMNS = 88


class PlaceholderError(ValueError):
    """A placeholder the hook does not know, or a name the code lacks."""


# ---------------------------------------------------------------- values
def _resolve(dotted: str):
    """The object a dotted name gives: the longest importable module
    prefix, then attributes."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for name in parts[i:]:
            if not hasattr(obj, name):
                raise PlaceholderError(f"{'.'.join(parts[:i])} has no attribute {name!r} "
                                       f"(in {dotted!r})")
            obj = getattr(obj, name)
        return obj
    raise PlaceholderError(f"no module in {dotted!r}")


def _text(v) -> str:
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, (tuple, list)):
        return ", ".join(_text(x) for x in v)
    return str(v)


def _percent(v) -> str:
    from mggp.fit.choices import percent
    return percent(v)


FILTERS = {
    "percent": _percent,
    "complement": lambda v: 1 - v,
    "first": lambda v: tuple(dict.fromkeys(x[0] for x in v)),
    "span": lambda v: f"{v[0]}–{v[-1]}",
}


def _argument(text: str):
    try:
        return float(text) if "." in text or "e" in text else int(text)
    except ValueError:
        return _resolve(text)


def _const(args, filters):
    if len(args) != 1:
        raise PlaceholderError("const takes one dotted name")
    return _filtered(_resolve(args[0]), filters)


def _call(args, filters):
    if not args:
        raise PlaceholderError("call takes a function and its arguments")
    return _filtered(_resolve(args[0])(*[_argument(a) for a in args[1:]]), filters)


def _filtered(v, filters) -> str:
    """``v`` through the named :data:`FILTERS`, as text."""
    for f in filters:
        if f not in FILTERS:
            raise PlaceholderError(f"unknown filter {f!r}; known: {', '.join(FILTERS)}")
        v = FILTERS[f](v)
    return _text(v)


def _default(args, filters):
    if len(args) != 2:
        raise PlaceholderError("default takes a function (or parameter table) and a name")
    obj, name = _resolve(args[0]), args[1]
    if isinstance(obj, dict):
        if name not in obj:
            raise PlaceholderError(f"{args[0]} has no row {name!r}")
        v = obj[name].default
    else:
        p = inspect.signature(obj).parameters.get(name)
        if p is None or p.default is inspect.Parameter.empty:
            raise PlaceholderError(f"{args[0]} has no keyword {name!r} with a default")
        v = p.default
    return _filtered(v, filters)


# ---------------------------------------------------------------- blocks
def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def params_table() -> str:
    """The Markdown table of :data:`mggp.fit.params.PARAMS`."""
    from mggp.fit.params import PARAMS
    rows = ["| parameter | default | rule | flag | what it does |",
            "|---|---|---|---|---|"]
    for p in PARAMS.values():
        flag = f"`{p.flag}`" if p.flag else ""
        rows.append(f"| `{p.name}` | `{p.default!r}` | {_cell(p.rule.words)} | {flag} "
                    f"| {_cell(p.help)} |")
    return "\n".join(rows)


def _subparsers(parser):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action.choices
    return {}


def help_text(command: str = "") -> str:
    """``mggp [COMMAND] --help`` as the parsers print it, at
    :data:`HELP_COLUMNS` columns."""
    from mggp.cli.app import build_parser
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(HELP_COLUMNS)
    try:
        parser = build_parser()
        if command:
            commands = _subparsers(parser)
            if command not in commands:
                raise PlaceholderError(f"mggp has no command {command!r}; it has "
                                       f"{', '.join(commands)}")
            parser = commands[command]
        out = io.StringIO()
        with redirect_stdout(out):
            parser.print_help()
    finally:
        if old is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = old
    return "```text\n" + out.getvalue().rstrip() + "\n```"


def include(path: str) -> str:
    """A file of the project, its headings one level down (it becomes a
    section of the page that includes it)."""
    full = os.path.normpath(os.path.join(ROOT, path))
    if not full.startswith(ROOT + os.sep) or not os.path.isfile(full):
        raise PlaceholderError(f"no file {path!r} in the project")
    text = open(full, encoding="utf-8").read()
    out, fence = [], False
    for line in text.splitlines():
        if line.startswith("```"):
            fence = not fence
        out.append("#" + line if not fence and re.match(r"#{1,5} ", line) else line)
    return "\n".join(out)


KINDS = {
    "const": _const,
    "call": _call,
    "default": _default,
    "params": lambda args, filters: params_table(),
    "help": lambda args, filters: help_text(*args),
    "include": lambda args, filters: include(*args),
}


def expand(placeholder: str) -> str:
    """The text of one placeholder (its inside, without the braces)."""
    head, *filters = [s.strip() for s in placeholder.split("|")]
    words = head.split()
    if not words or words[0] not in KINDS:
        raise PlaceholderError(f"unknown placeholder {{{{ {placeholder} }}}}; known kinds: "
                               f"{', '.join(KINDS)}")
    try:
        return KINDS[words[0]](words[1:], filters)
    except TypeError as exc:
        raise PlaceholderError(f"{{{{ {placeholder} }}}}: {exc}") from None


def render(markdown: str, where: str = "page") -> str:
    """``markdown`` with every placeholder replaced (``PlaceholderError``
    naming ``where`` and the placeholder otherwise)."""
    def one(m):
        try:
            return expand(m.group(1))
        except PlaceholderError as exc:
            raise PlaceholderError(f"{where}: {exc}") from None
    return PLACEHOLDER.sub(one, markdown)


# ---------------------------------------------------------------- MkDocs events
def on_page_markdown(markdown, page, config, files, **kwargs):
    from mkdocs.exceptions import PluginError
    try:
        return render(markdown, page.file.src_uri)
    except PlaceholderError as exc:
        raise PluginError(str(exc)) from None
