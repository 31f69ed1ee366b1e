"""Package-level rules: dependency direction (H1), documented public API (H24), CLI errors."""

from __future__ import annotations

import ast
import importlib
import inspect
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGES = ("stimuli", "experiment", "analysis")


@pytest.mark.parametrize(
    ("package", "forbidden"),
    [
        ("stimuli", ("experiment", "analysis", "moderngl")),
        ("analysis", ("experiment", "stimuli", "moderngl")),
    ],
)
def test_dependency_direction(package: str, forbidden: tuple[str, ...]) -> None:
    """Importing a package and all its modules never pulls in the packages it must not use."""
    code = (
        "import importlib, json, pkgutil, sys\n"
        f"pkg = importlib.import_module({package!r})\n"
        "for m in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + '.'):\n"
        "    importlib.import_module(m.name)\n"
        "print(json.dumps(sorted(sys.modules)))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    loaded = set(json.loads(out))
    bad = sorted(m for m in loaded if m.split(".")[0] in forbidden)
    assert not bad, f"{package} imports {bad}"


def _public_modules():
    import pkgutil

    for name in PACKAGES:
        pkg = importlib.import_module(name)
        yield pkg
        for m in pkgutil.walk_packages(pkg.__path__, name + "."):
            yield importlib.import_module(m.name)


def test_public_api_documented() -> None:
    """Every module declares ``__all__`` and every name in it has a docstring."""
    missing = []
    for mod in _public_modules():
        if not hasattr(mod, "__all__"):
            missing.append(f"{mod.__name__} (no __all__)")
            continue
        for name in mod.__all__:
            obj = getattr(mod, name)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                if not (obj.__doc__ or "").strip():
                    missing.append(f"{mod.__name__}.{name}")
    assert not missing, f"undocumented public names: {missing}"


def test_cli_help_and_version() -> None:
    """The console script runs and documents itself."""
    r = subprocess.run(["confocal", "--help"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "confocal" in r.stdout
    r = subprocess.run(["confocal", "--version"], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.startswith("confocal ")


def test_cli_user_error_is_one_line_exit_2(tmp_path, monkeypatch) -> None:
    """A user error raised inside a command prints one line, no traceback, exit status 2."""
    import typer

    from experiment import cli
    from stimuli.errors import InputError

    probe = typer.Typer()

    @probe.command()
    def boom() -> None:
        raise InputError("photo.jpg: image file not found")

    monkeypatch.setattr(cli, "app", probe)
    with pytest.raises(SystemExit) as exc:
        cli.main(["boom"])
    assert exc.value.code == 2


def test_json_roundtrip_of_constants() -> None:
    """Paper constants are plain data (serialisable into provenance files)."""
    from stimuli import jung2015

    json.dumps({k: getattr(jung2015, k) for k in jung2015.__all__})


# --- the layout: no import cycles, small modules, names instead of history -----------------------


def _project_modules() -> dict[str, Path]:
    """Every module of the three packages: dotted name -> file."""
    root = Path(__file__).resolve().parents[1]
    mods: dict[str, Path] = {}
    for pkg in PACKAGES:
        for p in sorted((root / pkg).rglob("*.py")):
            parts = list(p.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            mods[".".join(parts)] = p
    return mods


def _imports_of(name: str, path: Path, mods: dict[str, Path]) -> set[str]:
    """The project modules that ``name`` imports anywhere in its body (functions included)."""

    def known(dotted: str) -> str | None:
        while dotted and dotted not in mods:
            dotted = dotted.rpartition(".")[0]
        return dotted or None

    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.update(filter(None, (known(a.name) for a in node.names)))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")
                if path.name != "__init__.py":
                    base = base[:-1]
                base = base[: len(base) - (node.level - 1)]
                full = ".".join(base + ([node.module] if node.module else []))
            else:
                full = node.module or ""
            for a in node.names:
                sub = f"{full}.{a.name}"
                hit = sub if sub in mods else known(full)
                if hit:
                    out.add(hit)
    out.discard(name)
    return out


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = 0
    for start in graph:
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            v, children = work[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        found.append(sorted(comp))
    return found


def test_no_import_cycles() -> None:
    """No two project modules need each other, directly or through others, even inside functions."""
    mods = _project_modules()
    graph = {m: _imports_of(m, p, mods) for m, p in mods.items()}
    assert not _cycles(graph), f"import cycles: {_cycles(graph)}"


def test_cycle_finder_finds_a_cycle() -> None:
    """The cycle check itself can fail: a hand-made circle a -> b -> c -> a is found."""
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


MAX_MODULE_LINES = 800


def test_modules_are_small() -> None:
    """No module of the three packages is over 800 lines (one job per module)."""
    long = {
        m: n
        for m, p in _project_modules().items()
        if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES
    }
    assert not long, f"modules over {MAX_MODULE_LINES} lines: {long}"


def test_no_history_in_names() -> None:
    """Code, tests, protocols and docs say what a thing does, not which ticket asked for it."""
    root = Path(__file__).resolve().parents[1]
    pattern = re.compile(r"\bissues?[ _#-]?\d+", re.IGNORECASE)
    files = [root / "README.md", *root.glob("docs/*.md")]
    for folder in (*PACKAGES, "tests", "benchmarks", "protocols"):
        files += [p for p in (root / folder).rglob("*") if p.suffix in {".py", ".toml", ".md"}]
    hits = [
        f"{p.relative_to(root)}:{i}"
        for p in files
        for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if pattern.search(line) or pattern.search(p.name)
    ]
    assert not hits, f"history in names: {hits[:20]}"


def test_project_warnings_are_one_line(monkeypatch, capsys) -> None:
    """A warning from the project's code reaches the user as one line, without a source path."""
    import warnings

    import typer

    from experiment import cli
    from stimuli import planes

    probe = typer.Typer()

    @probe.command()
    def warn() -> None:
        warnings.warn_explicit(
            "a scan hit its range;\n  widen it", UserWarning, planes.__file__, 10, module="x"
        )

    monkeypatch.setattr(cli, "app", probe)
    with warnings.catch_warnings(), pytest.raises(SystemExit) as done:
        warnings.simplefilter("always")
        cli.main([])
    assert done.value.code in (0, None)
    err = capsys.readouterr().err
    assert err == "warning: a scan hit its range; widen it\n"
