"""Every third-party module the packages import is provided by a declared dependency.

The sources of ``stimuli/``, ``experiment/`` and ``analysis/`` are parsed with :mod:`ast` (no
import is executed, so a module imported only inside a function counts too), and each top-level
module name is mapped to the distributions that provide it with
:func:`importlib.metadata.packages_distributions`. A module must come from the standard library,
from the project itself, or from a distribution named in ``pyproject.toml``: a core dependency,
or an optional extra (``audio``, ``p2p``, ...) when no import of it runs at import time (each
sits inside a function or under ``try: ... except ImportError``), so that importing the packages
never needs it. A module of an extra that is not installed here is matched by its name.
"""

from __future__ import annotations

import ast
import importlib.metadata as md
import re
import sys
import tomllib

import pytest

from tests.conftest import REPO_ROOT

PACKAGES = ("stimuli", "experiment", "analysis")


def _normalise(name: str) -> str:
    """PEP 503 normalised distribution name."""
    return re.sub(r"[-_.]+", "-", name).lower()


def _requirement_name(req: str) -> str:
    return _normalise(re.split(r"[\s<>=!~;\[(]", req.strip(), maxsplit=1)[0])


def _declared() -> tuple[set[str], set[str]]:
    """Return (core, optional) distribution names from pyproject.toml (dev extra excluded)."""
    project = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    core = {_requirement_name(r) for r in project["dependencies"]}
    optional = {
        _requirement_name(r)
        for extra, reqs in project.get("optional-dependencies", {}).items()
        if extra != "dev"
        for r in reqs
    }
    return core, optional


def _lazy(node: ast.AST, parents: dict[ast.AST, ast.AST]) -> bool:
    """True when ``node`` runs only when called (inside a function) or is guarded by a ``try``
    whose handlers catch ImportError."""
    child, parent = node, parents.get(node)
    while parent is not None:
        if isinstance(parent, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda):
            return True
        if isinstance(parent, ast.Try) and child in parent.body:
            for handler in parent.handlers:
                names = {
                    n.id if isinstance(n, ast.Name) else getattr(n, "attr", "")
                    for n in (
                        handler.type.elts if isinstance(handler.type, ast.Tuple) else [handler.type]
                    )
                    if n is not None
                }
                if handler.type is None or names & {"ImportError", "ModuleNotFoundError"}:
                    return True
        child, parent = parent, parents.get(parent)
    return False


def third_party_imports() -> dict[str, list[tuple[str, bool]]]:
    """Map each imported top-level module outside the stdlib and the project to its sites.

    Each site is ``("path:line", lazy)`` (see :func:`_lazy`).
    """
    found: dict[str, list[tuple[str, bool]]] = {}
    for package in PACKAGES:
        for path in sorted((REPO_ROOT / package).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
            parents = {c: p for p in ast.walk(tree) for c in ast.iter_child_nodes(p)}
            for node in ast.walk(tree):
                if isinstance(node, ast.Import):
                    names = [a.name for a in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    names = [node.module]
                else:
                    continue
                for name in names:
                    top = name.split(".")[0]
                    if top in sys.stdlib_module_names or top in PACKAGES or top == "__future__":
                        continue
                    site = f"{path.relative_to(REPO_ROOT)}:{node.lineno}"
                    found.setdefault(top, []).append((site, _lazy(node, parents)))
    return found


def test_the_scan_sees_known_imports() -> None:
    """The parser finds imports the packages are known to make (guards against a blind scan)."""
    found = third_party_imports()
    for module in ("numpy", "scipy", "typer", "moderngl", "emcee", "statsmodels", "skimage"):
        assert module in found, f"{module} not found by the import scan"
    assert "os" not in found and "stimuli" not in found


def test_every_third_party_import_is_declared() -> None:
    """Each third-party module comes from a distribution declared in pyproject.toml."""
    core, optional = _declared()
    providers = md.packages_distributions()
    problems = []
    for module, sites in sorted(third_party_imports().items()):
        dists = {_normalise(d) for d in providers.get(module, [])} or {_normalise(module)}
        if dists & core:
            continue
        eager = [site for site, lazy in sites if not lazy]
        if dists & optional and not eager:
            continue
        where = ", ".join(s for s, _ in (sites if not eager else [(e, 0) for e in eager])[:3])
        if dists & optional:
            problems.append(
                f"{module} (optional extra) is imported at import time at {where}: import it "
                "inside the function that needs it, or declare it a core dependency"
            )
        else:
            problems.append(f"{module} (imported at {where}) is not a declared dependency")
    assert not problems, "undeclared imports:\n" + "\n".join(problems)


def test_declared_dependencies_have_lower_bounds() -> None:
    """Every core dependency states the lowest version it is tested with (README, development)."""
    project = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    reqs = list(project["dependencies"])
    for extra in project.get("optional-dependencies", {}).values():
        reqs += extra
    missing = [r for r in reqs if ">=" not in r and "==" not in r]
    assert not missing, f"no lower bound: {missing}"


@pytest.mark.parametrize("module", ["click"])
def test_undeclared_module_is_caught(tmp_path, monkeypatch, module) -> None:
    """A stray import of an undeclared module is reported (the check can fail)."""
    pkg = tmp_path / "stimuli"
    pkg.mkdir()
    (pkg / "stray.py").write_text(f"import {module}\n", encoding="utf-8")
    for other in ("experiment", "analysis"):
        (tmp_path / other).mkdir()
    (tmp_path / "pyproject.toml").write_bytes((REPO_ROOT / "pyproject.toml").read_bytes())
    monkeypatch.setattr(sys.modules[__name__], "REPO_ROOT", tmp_path)
    monkeypatch.setattr(
        md, "packages_distributions", lambda: {module: ["some-dist"], "numpy": ["numpy"]}
    )
    with pytest.raises(AssertionError, match=f"{module}"):
        test_every_third_party_import_is_declared()
