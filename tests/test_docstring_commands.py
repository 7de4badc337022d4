"""Every ``python -m benchmarks.X ...`` command in a benchmark's module
docstring names options its parser accepts (parsed, not run: the studies
take minutes)."""
import argparse
import ast
import glob
import os
import re
import runpy
import shlex

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def docstring_commands():
    out = []
    for path in sorted(glob.glob(os.path.join(ROOT, "benchmarks", "*.py"))):
        doc = ast.get_docstring(ast.parse(open(path, encoding="utf-8").read())) or ""
        for line in re.sub(r"\\\n\s*", " ", doc).splitlines():
            m = re.search(r"python -m (benchmarks\.\w+)([^#]*)", line)
            if m:
                args = shlex.split(m.group(2).strip().rstrip("`").strip())
                out.append(pytest.param(m.group(1), args, id=f"{m.group(1)} {' '.join(args)}"))
    return out


class _Parsed(Exception):
    pass


def test_commands_are_found():
    assert len(docstring_commands()) >= 20          # control for the extraction


@pytest.mark.filterwarnings("ignore:.*found in sys.modules:RuntimeWarning")
@pytest.mark.parametrize("module,args", docstring_commands())
def test_docstring_command_parses(module, args, monkeypatch):
    original = argparse.ArgumentParser.parse_args

    def parse_then_stop(self, argv=None, namespace=None):
        original(self, argv, namespace)             # exits 2 on a bad option
        raise _Parsed

    monkeypatch.setattr(argparse.ArgumentParser, "parse_args", parse_then_stop)
    monkeypatch.setattr("sys.argv", [module] + args)
    with pytest.raises(_Parsed):
        runpy.run_module(module, run_name="__main__", alter_sys=False)
