"""The documentation runs as written: README.md and every page of docs/.

Every ```python and ```bash block of README.md and docs/**/*.md runs alone,
in an empty folder, with this interpreter's ``python`` and ``mggp`` first on
PATH (the pages say "the venv's"). Not run: the blocks holding the two
set-up commands (creating a venv and installing; CI runs the second one
itself, verbatim, in ``.ci/run``, and the first is the main job, which
``tests/test_study.py`` runs on a small budget), and ```text blocks
(synopses, generated ``--help``). No substitution is made: the blocks
themselves use small budgets and say what the published budget is.

The site builds with ``mkdocs build --strict`` (a warning fails it), its
placeholders (``docs/hooks.py``) give the code's values and an unknown one
fails the build, and every figure a page shows exists, is small and has a
caption.
"""
import glob
import os
import re
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOCS = os.path.join(ROOT, "docs")
README = os.path.join(ROOT, "README.md")
PAGES = [README] + sorted(glob.glob(os.path.join(DOCS, "**", "*.md"), recursive=True))
MAIN_JOB = ('python3 -m venv .venv && .venv/bin/pip install -q -e ".[test]" && '
            '.venv/bin/python -m benchmarks.pem_vs_ms --out report')
SETUP = ('python3 -m venv .venv && .venv/bin/pip install -q -e ".[test]" && '
         '.venv/bin/python -m pytest -q')
FIGURE_BYTES = 200_000


def _name(path: str) -> str:
    return os.path.relpath(path, ROOT)


def blocks(text: str):
    """(language, code) of every fenced block, in order."""
    return [(m.group(1), m.group(2)) for m in
            re.finditer(r"^```(\w*)\n(.*?)^```", text, flags=re.S | re.M)]


def _read(path: str) -> str:
    return open(path, encoding="utf-8").read()


def is_setup(lang: str, code: str) -> bool:
    """A block of the two set-up commands (not run here)."""
    return lang == "bash" and "python3 -m venv" in code


def runnable():
    out = []
    for path in PAGES:
        for i, (lang, code) in enumerate(blocks(_read(path))):
            if lang in ("python", "bash") and not is_setup(lang, code):
                out.append(pytest.param(lang, code, id=f"{_name(path)}:block{i}-{lang}"))
    return out


@pytest.mark.parametrize("path", [README, os.path.join(DOCS, "getting-started.md")],
                         ids=_name)
def test_setup_commands_are_the_ci_commands(path):
    """The two commands are there verbatim, in one block; .ci/run runs the
    second (the test suite) as written."""
    setup = [code for lang, code in blocks(_read(path)) if is_setup(lang, code)]
    assert len(setup) == 1
    assert MAIN_JOB in setup[0] and SETUP in setup[0]
    assert SETUP in _read(os.path.join(ROOT, ".ci", "run"))


def test_every_block_is_found():
    """Control for the extraction: the README and the pages have Python and
    shell blocks, and a ```text block is not taken."""
    langs = [p.values[0] for p in runnable()]
    assert langs.count("python") >= 10 and langs.count("bash") >= 8
    assert set(langs) == {"python", "bash"}
    assert any(lang == "text" for path in PAGES for lang, _ in blocks(_read(path)))


def test_runnable_blocks_hold_no_placeholder():
    """Blocks run as written: a placeholder of the hook would reach the shell."""
    for p in runnable():
        assert "{{" not in p.values[1], p.id


def run_block(lang: str, code: str, folder) -> subprocess.CompletedProcess:
    """Run one block alone in ``folder`` (empty), ``python`` and ``mggp``
    being this interpreter's."""
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    env["PYTHONPATH"] = ROOT + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH")
                                else "")
    env["MPLBACKEND"] = "Agg"
    if lang == "python":
        cmd = [sys.executable, "-c", code]
    else:
        bindir = folder / "bin"                    # `python` is this interpreter
        bindir.mkdir()
        shim = bindir / "python"                   # a symlink would lose the venv
        shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" "$@"\n')
        shim.chmod(0o755)
        env["PATH"] = str(bindir) + os.pathsep + env["PATH"]
        cmd = ["bash", "-euo", "pipefail", "-c", code]
    return subprocess.run(cmd, cwd=folder, env=env, capture_output=True, text=True,
                          timeout=300)


@pytest.fixture(scope="module")
def block_runs(request, tmp_path_factory):
    """The selected blocks, run side by side, one per core (each is one
    process in its own folder): ``{(lang, code): CompletedProcess}``."""
    from concurrent.futures import ThreadPoolExecutor
    selected = {(item.callspec.params["lang"], item.callspec.params["code"])
                for item in request.session.items
                if item.originalname == "test_block_runs_alone"}
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:
        futures = {key: pool.submit(run_block, *key, tmp_path_factory.mktemp("block"))
                   for key in selected}
        return {key: f.result() for key, f in futures.items()}


@pytest.mark.parametrize("lang,code", runnable())
def test_block_runs_alone(lang, code, block_runs):
    r = block_runs[(lang, code)]
    assert r.returncode == 0, f"{lang} block failed:\n{code}\n--- stderr:\n{r.stderr[-3000:]}"


# ---------------------------------------------------------------- the site
def test_site_builds_strictly(tmp_path):
    """``mkdocs build --strict``: a broken link, a missing figure, an
    unknown placeholder or a docstring mkdocstrings cannot read fails."""
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    env["PYTHONPATH"] = ROOT + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH")
                                else "")
    r = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file",
                        os.path.join(ROOT, "mkdocs.yml"), "--site-dir", str(tmp_path / "site")],
                       cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-4000:]
    fit = (tmp_path / "site" / "guide" / "fit" / "index.html").read_text(encoding="utf-8")
    assert "{{" not in fit
    from mggp.fit.choices import HOLDOUT, percent
    assert percent(HOLDOUT).replace(" ", "") in fit.replace(" ", "").replace("&nbsp;", "")
    cli = (tmp_path / "site" / "reference" / "cli" / "index.html").read_text(encoding="utf-8")
    assert "usage: mggp fit" in cli and "--search-samples" in cli


def _hooks():
    sys.path.insert(0, DOCS)
    try:
        import hooks
    finally:
        sys.path.remove(DOCS)
    return hooks


def test_placeholders_give_the_code_values():
    """A threshold in a page is the constant's value; control: another
    constant gives another text."""
    from mggp.fit.choices import CLASS_GAIN, GAIN, HEIGHT, percent
    from mggp.fit.params import DIAGNOSE_PARAMS
    from mggp.gp.primitives import max_lag_for_height
    render = _hooks().render
    assert render("{{ const mggp.fit.choices.GAIN | percent }}") == percent(GAIN)
    assert render("{{ const mggp.fit.choices.CLASS_GAIN | percent }}") == percent(CLASS_GAIN)
    assert percent(GAIN) != percent(CLASS_GAIN)
    assert render("{{ const mggp.fit.choices.HEIGHT }}") == str(HEIGHT)
    assert (render("{{ call mggp.gp.primitives.max_lag_for_height mggp.fit.choices.HEIGHT }}")
            == str(max_lag_for_height(HEIGHT)))
    assert (render("{{ default mggp.fit.params.DIAGNOSE_PARAMS alpha }}")
            == f"{DIAGNOSE_PARAMS['alpha'].default:g}")
    assert "usage: mggp diagnose" in render("{{ help diagnose }}")
    assert "| `window` | `100` |" in render("{{ params }}")


@pytest.mark.parametrize("text", ["{{ nonsense }}", "{{ const mggp.fit.choices.NO_SUCH }}",
                                  "{{ const mggp.fit.choices.GAIN | nope }}", "{{ help nocmd }}",
                                  "{{ include no/such/file.md }}"])
def test_unknown_placeholder_fails_the_build(text):
    from mkdocs.exceptions import PluginError
    hooks = _hooks()

    class Page:
        class file:
            src_uri = "guide/x.md"
    with pytest.raises(PluginError, match="guide/x.md"):
        hooks.on_page_markdown(f"a {text} b", Page, {}, None)


def test_every_page_is_in_the_nav():
    import yaml

    class Loader(yaml.SafeLoader):              # the slugify tag of mkdocs.yml: not needed
        pass
    Loader.add_multi_constructor("", lambda loader, suffix, node: None)
    config = yaml.load(_read(os.path.join(ROOT, "mkdocs.yml")), Loader=Loader)

    def leaves(node):
        if isinstance(node, dict):
            for v in node.values():
                yield from leaves(v)
        elif isinstance(node, list):
            for v in node:
                yield from leaves(v)
        else:
            yield node
    nav = set(leaves(config["nav"]))
    pages = {os.path.relpath(p, DOCS) for p in PAGES if p != README}
    assert pages == nav


# ---------------------------------------------------------------- figures
FIGURE = re.compile(r"!\[[^\]]*\]\(([^)]+\.png)\)\n\n\*([^\n]|\n(?!\n))+\*")


def test_every_figure_exists_is_small_and_has_a_caption():
    """Each PNG a page shows is under docs/figures, under 200 kB, followed
    by an italic caption; every PNG there is shown."""
    shown = set()
    for path in PAGES[1:]:
        text = _read(path)
        images = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
        captioned = [m.group(1) for m in FIGURE.finditer(text)]
        assert images == captioned, f"{_name(path)}: figures without a caption"
        for img in images:
            full = os.path.normpath(os.path.join(os.path.dirname(path), img))
            assert os.path.dirname(full) == os.path.join(DOCS, "figures"), img
            assert os.path.getsize(full) < FIGURE_BYTES, img
            shown.add(full)
    assert shown == set(glob.glob(os.path.join(DOCS, "figures", "*.png")))
    assert len(shown) >= 4


# ---------------------------------------------------------------- the README
def test_readme_is_the_front_door():
    """At most 150 lines; its links into the site are relative links to
    pages that exist (they work on GitHub too)."""
    text = _read(README)
    assert len(text.splitlines()) <= 150
    links = re.findall(r"\]\((docs/[^)#]+)", text)
    assert len(links) >= 5
    for link in links:
        assert os.path.isfile(os.path.join(ROOT, link)), link
    assert "mkdocs serve" in text


def headline_numbers(text: str):
    """The numbers of the README's headline table (its second column)."""
    table = text.split("## Headline figures", 1)[1].split("\n## ", 1)[0]
    cells = [row.split("|")[2] for row in table.splitlines()
             if row.startswith("|") and not row.startswith("|---")][1:]
    return [n for c in cells for n in re.findall(r"\d[\d,.]*\d|\d", c)]


def test_readme_headline_figures_are_those_of_results():
    """Every number of the headline table is one of benchmarks/RESULTS.md;
    control: a number RESULTS.md does not hold is found out."""
    results = _read(os.path.join(ROOT, "benchmarks", "RESULTS.md"))
    numbers = headline_numbers(_read(README))
    assert len(numbers) >= 10
    assert [n for n in numbers if n not in results] == []
    fake = "## Headline figures\n\n| claim | figure |\n|---|---|\n| x | 0.98765 % |\n"
    assert [n for n in headline_numbers(fake) if n not in results] == ["0.98765"]


def test_to_latex_of_row_0_is_the_simplest_structure():
    """What the case study says of ``pareto_front_.to_latex(0)``: row 0, the
    structure with the fewest terms (rows count from 0); control: the last
    row is another, longer one."""
    import numpy as np
    from mggp import MGGPRegressor
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(2000, seed=1)
    front = MGGPRegressor(fitness="pem", population=30, generations=4, random_state=1,
                          use_phi=True, constant=False,         # no pilots: one search
                          n_jobs=1).fit(u, piezo_bouc_wen(u)).pareto_front_
    rows = list(front)
    assert len(rows) >= 2
    assert rows[0]["complexity"] == min(r["complexity"] for r in rows)
    assert front.to_latex(0) == front.model(0).to_latex(4)
    assert front.to_latex(0) != front.to_latex(len(rows) - 1)
    assert np.all(np.diff([r["complexity"] for r in rows]) > 0)
