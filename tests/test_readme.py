"""The README's code blocks run as written.

Every ```python and ```bash block of README.md runs alone, in an empty
folder, with this interpreter's ``python`` and ``mggp`` first on PATH (the
README says "the venv's"). Not run: the first bash block, the two set-up
commands (creating a venv and installing; CI runs the second one itself,
verbatim, in ``.ci/run``, and the first is the main job, which
``tests/test_study.py`` runs on a small budget), and ```text blocks
(synopses). No substitution is made: the blocks themselves use small
budgets and say what the published budget is.
"""
import os
import re
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
README = os.path.join(ROOT, "README.md")
SETUP = ('python3 -m venv .venv && .venv/bin/pip install -q -e ".[test]" && '
         '.venv/bin/python -m pytest -q')


def blocks(text: str):
    """(language, code) of every fenced block, in order."""
    return [(m.group(1), m.group(2)) for m in
            re.finditer(r"^```(\w*)\n(.*?)^```", text, flags=re.S | re.M)]


def runnable():
    found = blocks(open(README, encoding="utf-8").read())
    out = []
    for i, (lang, code) in enumerate(found):
        if lang == "bash" and "python3 -m venv" in code:
            continue
        if lang in ("python", "bash"):
            out.append(pytest.param(lang, code, id=f"block{i}-{lang}"))
    return out


def test_setup_commands_are_the_ci_commands():
    """The README's two commands are there verbatim; .ci/run runs the
    second (the test suite) as written."""
    setup = [code for lang, code in blocks(open(README, encoding="utf-8").read())
             if lang == "bash" and "python3 -m venv" in code]
    assert len(setup) == 1
    assert ('python3 -m venv .venv && .venv/bin/pip install -q -e ".[test]" && '
            '.venv/bin/python -m benchmarks.pem_vs_ms --out report') in setup[0]
    assert SETUP in setup[0]
    assert SETUP in open(os.path.join(ROOT, ".ci", "run")).read()


def test_every_block_is_found():
    """Control for the extraction: the README has Python and shell blocks."""
    langs = [p.values[0] for p in runnable()]
    assert langs.count("python") >= 3 and langs.count("bash") >= 1


@pytest.mark.parametrize("lang,code", runnable())
def test_readme_block_runs_alone(lang, code, tmp_path):
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    env["PYTHONPATH"] = ROOT + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH")
                                else "")
    env["MPLBACKEND"] = "Agg"
    if lang == "python":
        cmd = [sys.executable, "-c", code]
    else:
        bindir = tmp_path / "bin"                  # `python` is this interpreter
        bindir.mkdir()
        shim = bindir / "python"                   # a symlink would lose the venv
        shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" "$@"\n')
        shim.chmod(0o755)
        env["PATH"] = str(bindir) + os.pathsep + env["PATH"]
        cmd = ["bash", "-euo", "pipefail", "-c", code]
    r = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, f"{lang} block failed:\n{code}\n--- stderr:\n{r.stderr[-3000:]}"


def test_to_latex_of_row_0_is_the_simplest_structure():
    """What the README says of ``pareto_front_.to_latex(0)``: row 0, the
    structure with the fewest terms (rows count from 0); control: the last
    row is another, longer one."""
    import numpy as np
    from mggp import MGGPRegressor
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(2000, seed=1)
    front = MGGPRegressor(fitness="pem", population=30, generations=4, random_state=1,
                          n_jobs=1).fit(u, piezo_bouc_wen(u)).pareto_front_
    rows = list(front)
    assert len(rows) >= 2
    assert rows[0]["complexity"] == min(r["complexity"] for r in rows)
    assert front.to_latex(0) == front.model(0).to_latex(4)
    assert front.to_latex(0) != front.to_latex(len(rows) - 1)
    assert np.all(np.diff([r["complexity"] for r in rows]) > 0)
