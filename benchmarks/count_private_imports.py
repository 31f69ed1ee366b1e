"""Count the private names that cross module boundaries, by ``from X import _y`` statements.

A private name (one leading underscore, not a dunder) belongs to its module. Each
``from X import _y`` in a module other than ``X`` is one crossing: another module reaches into
``X``'s internals. A second count covers names taken from a private module (``X`` with a
``_``-prefixed part, such as ``pkg._core``) by a module outside the package that holds it.

Usage::

    python benchmarks/count_private_imports.py                 # totals, per folder
    python benchmarks/count_private_imports.py --list          # every crossing
    python benchmarks/count_private_imports.py --under analysis/weibull

Counts the source folders (``stimuli``, ``experiment``, ``analysis``) by default; ``--with-tests``
adds ``tests`` and ``benchmarks``. Imports made by name (``importlib``, attribute access such as
``mod._y``) are not seen.
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections import Counter
from pathlib import Path

__all__ = ["crossings", "main"]

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ("stimuli", "experiment", "analysis")
EXTRA = ("tests", "benchmarks")


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _resolve(node: ast.ImportFrom, module: str, is_package: bool) -> str:
    if not node.level:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join([*base, *([node.module] if node.module else [])])


def crossings(
    root: Path = ROOT, folders: tuple[str, ...] = SOURCE
) -> list[tuple[str, str, str, str]]:
    """Return every crossing as ``(importing file, source module, name, kind)`` rows.

    Parameters
    ----------
    root : Path
        The repository root.
    folders : tuple of str
        Folders under ``root`` to scan.

    Returns
    -------
    list of tuple
        ``(file, module, name, kind)``, ``kind`` ``"private name"`` (``from X import _y``) or
        ``"private module"`` (a name from ``pkg._mod`` taken outside ``pkg``).
    """
    rows = []
    for folder in folders:
        for path in sorted((root / folder).rglob("*.py")):
            module = _module_name(path, root)
            tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
            for node in ast.walk(tree):
                if not isinstance(node, ast.ImportFrom):
                    continue
                src = _resolve(node, module, path.name == "__init__.py")
                if not src or src == module:
                    continue
                rel = str(path.relative_to(root))
                parts = src.split(".")
                private_at = next((i for i, p in enumerate(parts) if _private(p)), None)
                for alias in node.names:
                    if _private(alias.name):
                        rows.append((rel, src, alias.name, "private name"))
                    elif private_at is not None:
                        owner = ".".join(parts[:private_at])
                        if not (module == owner or module.startswith(owner + ".")):
                            rows.append((rel, src, alias.name, "private module"))
    return rows


def main(argv: list[str] | None = None) -> int:
    """Print the counts (and with ``--list`` every crossing); return 0."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--list", action="store_true", help="print every crossing")
    ap.add_argument("--with-tests", action="store_true", help="also scan tests/ and benchmarks/")
    ap.add_argument("--under", default="", help="only importing files under this path")
    args = ap.parse_args(argv)
    rows = crossings(ROOT, SOURCE + (EXTRA if args.with_tests else ()))
    if args.under:
        rows = [r for r in rows if r[0].startswith(args.under.rstrip("/") + "/")]
    if args.list:
        for r in rows:
            print(f"{r[0]}: from {r[1]} import {r[2]}  ({r[3]})")
    by_folder = Counter(r[0].split("/")[0] for r in rows)
    per = ", ".join(f"{k} {v}" for k, v in sorted(by_folder.items()))
    print(f"crossings: {len(rows)}  ({per})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
