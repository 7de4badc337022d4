"""Modules and lines of each subpackage of mggp and narx: the layout in one table.

Typical use::

    python -m benchmarks.layout                  # this checkout
    python -m benchmarks.layout --root OTHER     # another checkout, e.g. of an older commit

Each row is one folder of ``narx/`` or ``mggp/`` (a package's own top-level
modules are the row of the package itself): its modules (``.py`` files,
``__init__.py`` included) and their lines that are not blank. A deprecated
old path kept for one release is no file, so it is counted nowhere.
"""
from __future__ import annotations

import argparse
from pathlib import Path

PACKAGES = ("narx", "mggp")


def layout(root: Path) -> list:
    """Rows ``(folder, modules, non-blank lines, names)`` of every package
    folder under ``root``, in path order."""
    rows = []
    for package in PACKAGES:
        for folder in sorted({p.parent for p in (root / package).rglob("*.py")}):
            files = sorted(folder.glob("*.py"))
            lines = sum(1 for f in files
                        for line in f.read_text(encoding="utf-8").splitlines() if line.strip())
            names = ", ".join(f.stem for f in files if f.stem != "__init__")
            rows.append((folder.relative_to(root).as_posix() + "/", len(files), lines, names))
    return rows


def table(rows) -> str:
    """The rows as a Markdown table, with a total for each package."""
    out = ["| folder | modules | lines | modules by name |", "| --- | ---: | ---: | --- |"]
    out += [f"| `{f}` | {n} | {lines} | {names} |" for f, n, lines, names in rows]
    for package in PACKAGES:
        mine = [r for r in rows if r[0].split("/")[0] == package]
        out.append(f"| **{package} total** | {sum(r[1] for r in mine)} | "
                   f"{sum(r[2] for r in mine)} | {len(mine)} folders |")
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--root", type=Path, default=Path(__file__).resolve().parents[1],
                   help="the checkout to measure (default: this one)")
    print(table(layout(p.parse_args(argv).root)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
