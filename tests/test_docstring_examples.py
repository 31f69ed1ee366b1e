"""Every ``Examples`` section in the packages' docstrings runs, and prints what it says it prints.

The examples are found the way ``python -m doctest`` finds them (:class:`doctest.DocTestFinder` on
each module: the module, its functions, classes and methods) and run with doctest's default
options, one test per module, so that ``python -m pytest`` alone runs them. Only modules whose
source holds an example prompt are collected, by reading the files: collecting imports nothing.
"""

from __future__ import annotations

import doctest
import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("stimuli", "experiment", "analysis")

#: An example prompt at the start of a docstring line.
_PROMPT = re.compile(r"^\s*>>> ", re.M)
#: A module-level import of moderngl: such a module's examples need an OpenGL context.
_GL_IMPORT = re.compile(r"^(import moderngl|from moderngl\b)", re.M)


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules_with_examples() -> list[tuple[str, bool]]:
    found = []
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            text = path.read_text(encoding="utf-8")
            if _PROMPT.search(text):
                found.append((_module_name(path), bool(_GL_IMPORT.search(text))))
    return found


MODULES = _modules_with_examples()


def _skip_without_gl(module: str) -> None:
    try:
        import moderngl

        ctx = moderngl.create_standalone_context(require=330, backend="egl")
        ctx.release()
    except Exception as exc:  # no headless OpenGL on this machine
        pytest.skip(f"{module} imports moderngl and its examples need an OpenGL context: {exc}")


def test_examples_are_found() -> None:
    """The walk finds the packages' examples (a broken pattern would silently test nothing)."""
    assert len(MODULES) >= 30
    assert "stimuli.compress" in {m for m, _ in MODULES}


@pytest.mark.parametrize(("module", "needs_gl"), MODULES, ids=[m for m, _ in MODULES])
def test_docstring_examples_run(module: str, needs_gl: bool) -> None:
    """Run every docstring example of ``module``; a failure shows doctest's own report."""
    if needs_gl:
        _skip_without_gl(module)
    mod = importlib.import_module(module)
    tests = [t for t in doctest.DocTestFinder().find(mod, module) if t.examples]
    # Only docstrings of objects defined in the module are searched, so a prompt in the source
    # but no example found means the finder missed it (e.g. an example in a private nested scope).
    assert tests, f"{module}: its source has '>>> ' but doctest finds no example"
    runner = doctest.DocTestRunner(optionflags=0)
    report: list[str] = []
    for test in tests:
        runner.run(test, out=report.append)
    failed, attempted = runner.summarize(verbose=False)
    assert attempted > 0
    assert failed == 0, "".join(report)
