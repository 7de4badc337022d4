"""Every module of narx and mggp imports alone, and neither has an import cycle.

An import cycle works or fails depending on which module of the cycle is
imported first; importing each module alone, first, in an interpreter that
has loaded no module of the project, finds such failures. The interpreter
is forked from one that has loaded only the third-party dependencies, so
the check takes seconds, not a minute. The cycle check reads every import
statement of narx and of mggp with ``ast``, also those inside functions
(they run when the function does); imports under ``if TYPE_CHECKING:``
never run and are left out.
"""
from __future__ import annotations

import ast
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _modules(package):
    out = []
    for path in sorted((ROOT / package).rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        out.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return out


def _imports(module, path):
    """Project modules that ``module`` (file ``path``) imports, anywhere in it."""
    is_pkg = path.name == "__init__.py"
    base = module if is_pkg else module.rpartition(".")[0]
    out = set()
    for node in _run_time_nodes(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                parts = base.split(".")
                parts = parts[:len(parts) - node.level + 1]
                target = ".".join(parts + ([node.module] if node.module else []))
            else:
                target = node.module
            out.add(target)
            out.update(f"{target}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def _type_checking(test):
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or \
        (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _run_time_nodes(node):
    """Every node under ``node`` except the bodies of ``if TYPE_CHECKING:``."""
    yield node
    if isinstance(node, ast.If) and _type_checking(node.test):
        children = [node.test, *node.orelse]
    else:
        children = ast.iter_child_nodes(node)
    for child in children:
        yield from _run_time_nodes(child)


def _cycles(graph):
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def _graph(package):
    mods = _modules(package)
    paths = {m: ROOT.joinpath(*m.split(".")) for m in mods}
    paths = {m: (p / "__init__.py" if p.is_dir() else p.with_suffix(".py"))
             for m, p in paths.items()}
    return {m: sorted(i for i in _imports(m, paths[m]) if i in paths and i != m)
            for m in mods}


def test_cycle_finder_finds_a_cycle():
    # control: the check can fail
    assert _cycles({"a": ["b"], "b": ["c"], "c": ["a"], "d": ["a"]}) == [["a", "b", "c"]]
    assert _cycles({"a": ["b"], "b": []}) == []


def test_imports_under_type_checking_are_left_out(tmp_path):
    # control: a run-time import is read, in a function too; a TYPE_CHECKING one is not
    path = tmp_path / "m.py"
    path.write_text("from typing import TYPE_CHECKING\nimport typing\n"
                    "if TYPE_CHECKING:\n    from .a import A\nelse:\n    from .b import B\n"
                    "if typing.TYPE_CHECKING:\n    import pkg.c\n"
                    "def f():\n    from .d import D\n", encoding="utf-8")
    found = _imports("pkg.m", path)
    assert {"pkg.b", "pkg.d"} <= found
    assert not {"pkg.a", "pkg.a.A", "pkg.c"} & found


def test_narx_has_no_import_cycle():
    graph = _graph("narx")
    assert len(graph) > 20 and "narx.kernels" in graph["narx.simulate"]
    assert _cycles(graph) == []


def test_mggp_has_no_import_cycle():
    graph = _graph("mggp")
    assert len(graph) > 40 and "mggp.stages" in graph["mggp.estimator"]
    assert "mggp.estimator" in graph["mggp"]          # the lazy attribute is read
    assert _cycles(graph) == []


_CHILD = textwrap.dedent("""
    import importlib, os, sys
    import numpy, scipy, scipy.linalg, scipy.signal, scipy.optimize, scipy.stats, numba
    import deap, joblib, matplotlib
    matplotlib.use("Agg")

    def child(name):
        code = 0
        try:
            if any(m.split(".")[0] in ("narx", "mggp") for m in sys.modules):
                code = 3
            else:
                importlib.import_module(name)
        except BaseException as exc:
            sys.stderr.write(f"{name}: {type(exc).__name__}: {exc}\\n")
            code = 1
        sys.stderr.flush()
        os._exit(code)

    running, failed = {}, []
    for name in sys.argv[1:] + [None] * 4:
        if name is not None:
            pid = os.fork()
            if pid == 0:
                child(name)
            running[pid] = name
        while running and (name is None or len(running) >= 4):
            pid, status = os.wait()
            if status:
                failed.append(running[pid])
            del running[pid]
    print(" ".join(sorted(failed)))
""")


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")
def test_every_module_imports_alone():
    mods = [m for m in _modules("narx") + _modules("mggp") if not m.endswith("__main__")]
    assert len(mods) > 40
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               MPLBACKEND="Agg")
    # control: a module that does not exist is reported
    res = subprocess.run([sys.executable, "-c", _CHILD, *mods, "narx.no_such_module"],
                         capture_output=True, text=True, env=env, cwd=str(ROOT), timeout=600)
    assert res.returncode == 0, res.stderr
    assert res.stdout.split() == ["narx.no_such_module"], res.stderr
