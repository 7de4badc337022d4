"""Every module of narx and mggp imports alone, and neither has an import cycle.

An import cycle works or fails depending on which module of the cycle is
imported first; importing each module alone, first, in an interpreter that
has loaded no module of the project, finds such failures. The interpreter
is forked from one that has loaded only the third-party dependencies, so
the check takes seconds, not a minute. The cycle check reads every import
statement of narx and of mggp with ``ast`` in two graphs: the imports
that run (also those inside functions, which run when the function does;
imports under ``if TYPE_CHECKING:`` never run and are left out), and the
top-level imports alone (module and class bodies, those under ``if
TYPE_CHECKING:`` included: a type checker follows them, and a cycle there
is a tangle of the modules however it is imported). Run as a script it
prints the cycles of each kind, and those that only imports inside
functions close::

    python tests/test_imports.py
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


#: which import statements a graph holds: those that run (anywhere but under
#: ``if TYPE_CHECKING:``), or those at top level (outside function bodies,
#: ``if TYPE_CHECKING:`` included)
SCOPES = ("run-time", "top-level")


def _imports(module, path, scope="run-time"):
    """Project modules that ``module`` (file ``path``) imports in ``scope``
    (:data:`SCOPES`)."""
    is_pkg = path.name == "__init__.py"
    base = module if is_pkg else module.rpartition(".")[0]
    out = set()
    tree = ast.parse(path.read_text(encoding="utf-8"))
    nodes = _run_time_nodes(tree) if scope == "run-time" else _top_level_nodes(tree)
    for node in nodes:
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


def _top_level_nodes(node):
    """Every node under ``node`` outside function bodies (what runs when the
    module is imported, and what a type checker reads under ``if
    TYPE_CHECKING:``)."""
    yield node
    for child in ast.iter_child_nodes(node):
        if not isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            yield from _top_level_nodes(child)


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


def _graph(*packages, scope="run-time"):
    """Module -> the project modules it imports in ``scope`` (:data:`SCOPES`)."""
    mods = [m for package in packages for m in _modules(package)]
    paths = {m: ROOT.joinpath(*m.split(".")) for m in mods}
    paths = {m: (p / "__init__.py" if p.is_dir() else p.with_suffix(".py"))
             for m, p in paths.items()}
    return {m: sorted(i for i in _imports(m, paths[m], scope) if i in paths and i != m)
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
    assert len(graph) > 20 and "narx.simulation.kernels" in graph["narx.simulation.simulate"]
    assert _cycles(graph) == []


def test_mggp_has_no_import_cycle():
    graph = _graph("mggp")
    assert len(graph) > 40 and "mggp.fit.stages" in graph["mggp.fit.estimator"]
    assert "mggp.fit.estimator" in graph["mggp"]          # the lazy attribute is read
    assert _cycles(graph) == []


def test_top_level_graph_reads_type_checking_and_skips_functions(tmp_path):
    # control: the top-level graph holds a TYPE_CHECKING import and one in a
    # class body, not one inside a function or a method
    path = tmp_path / "m.py"
    path.write_text("from typing import TYPE_CHECKING\n"
                    "if TYPE_CHECKING:\n    from .a import A\n"
                    "class C:\n    from .b import B\n"
                    "    def f(self):\n        from .c import C\n"
                    "def g():\n    import pkg.d\n", encoding="utf-8")
    found = _imports("pkg.m", path, "top-level")
    assert {"pkg.a", "pkg.b"} <= found
    assert not {"pkg.c", "pkg.d"} & found
    # a cycle closed only under TYPE_CHECKING is one of the top-level graph
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "x.py").write_text("from .y import Y\nX = 1\n", encoding="utf-8")
    (pkg / "y.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                              "    from .x import X\nY = 2\n", encoding="utf-8")
    top = {m: sorted(i for i in _imports(m, pkg / f"{m[4:]}.py", "top-level")
                     if i in ("pkg.x", "pkg.y") and i != m) for m in ("pkg.x", "pkg.y")}
    run = {m: sorted(i for i in _imports(m, pkg / f"{m[4:]}.py")
                     if i in ("pkg.x", "pkg.y") and i != m) for m in ("pkg.x", "pkg.y")}
    assert _cycles(top) == [["pkg.x", "pkg.y"]] and _cycles(run) == []


def test_no_cycle_of_top_level_imports():
    """narx and mggp together, top-level imports only, TYPE_CHECKING ones
    included (the diagnosis's Budget once closed augmentation -> registry ->
    context -> extend -> augmentation that way)."""
    graph = _graph("narx", "mggp", scope="top-level")
    assert "mggp.diagnose.budget" in graph["mggp.diagnose.context"]
    assert "narx.simulation.kernels" in graph["narx.simulation.simulate"]
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


if __name__ == "__main__":
    top = _cycles(_graph("narx", "mggp", scope="top-level"))
    run = _cycles(_graph("narx", "mggp"))
    print("cycles of top-level imports (TYPE_CHECKING included):", top or "none")
    print("cycles of run-time imports (inside functions included):", run or "none")
    only = [c for c in run if c not in top]
    print("closed only by imports inside functions:", only or "none")
