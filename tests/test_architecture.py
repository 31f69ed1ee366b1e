"""Package-level rules: dependency direction (H1), documented public API (H24), CLI errors."""

from __future__ import annotations

import ast
import functools
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
    out |= _named_imports_of(name, path, mods)
    out.discard(name)
    return out


def _named_imports_of(name: str, path: Path, mods: dict[str, Path]) -> set[str]:
    """The project modules that ``name`` imports by name rather than by an import statement.

    - ``lazy_loader.attach(__name__, submodules=[...], submod_attrs={...})``: each submodule named
      there, relative to the package;
    - any other string (not a docstring) that is a project module's dotted name, or its
      ``module:attribute`` form: the tables handed to ``importlib.import_module`` (the root
      command's sub-command table, a package's lazy ``_HOME`` table, a worker's target).
    """
    tree = ast.parse(path.read_text(encoding="utf-8"))
    docstrings = {
        id(node.body[0].value)
        for node in ast.walk(tree)
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
        and node.body
        and isinstance(node.body[0], ast.Expr)
        and isinstance(node.body[0].value, ast.Constant)
    }
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and _called_name(node.func) == "attach":
            for kw in node.keywords:
                if kw.arg == "submodules" and isinstance(kw.value, (ast.List, ast.Tuple)):
                    subs = [e.value for e in kw.value.elts if isinstance(e, ast.Constant)]
                elif kw.arg == "submod_attrs" and isinstance(kw.value, ast.Dict):
                    subs = [k.value for k in kw.value.keys if isinstance(k, ast.Constant)]
                else:
                    continue
                out.update(f"{name}.{sub}" for sub in subs if f"{name}.{sub}" in mods)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            target = node.value.split(":", 1)[0]
            if id(node) not in docstrings and "." in target and target in mods:
                out.add(target)
    return out


def _called_name(func: ast.expr) -> str | None:
    if isinstance(func, ast.Attribute):
        return func.attr
    return func.id if isinstance(func, ast.Name) else None


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


@functools.cache
def _import_graph() -> dict[str, frozenset[str]]:
    """Every project module -> the project modules it imports (statements and by name)."""
    mods = _project_modules()
    return {m: frozenset(_imports_of(m, p, mods)) for m, p in mods.items()}


def test_no_import_cycles() -> None:
    """No two project modules need each other, directly or through others, even inside functions."""
    graph = _import_graph()
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


# --- rooms: no circle between the sub-packages of a tower ----------------------------------------


def _room(module: str, mods: dict[str, Path]) -> str:
    """The room a module lives in: its tower's first sub-folder, or the tower's own top module.

    ``experiment.session.engine`` -> ``experiment/session``; ``experiment.outputs`` ->
    ``experiment/outputs.py``; ``experiment`` (the package itself) -> ``experiment/__init__.py``.
    """
    parts = module.split(".")
    if len(parts) == 1:
        return f"{parts[0]}/__init__.py"
    if len(parts) > 2 or mods[module].name == "__init__.py":
        return f"{parts[0]}/{parts[1]}"
    return f"{parts[0]}/{parts[1]}.py"


def _room_graph(
    tower: str, skip: frozenset[tuple[str, str]] = frozenset()
) -> tuple[dict[str, set[str]], dict[tuple[str, str], list[tuple[str, str]]]]:
    """The rooms of ``tower`` and which rooms each imports, with the module imports behind each.

    ``skip`` holds module imports ``(importer, imported)`` left out, and ``(importer, "*")`` for
    every import of one module.
    """
    mods = _project_modules()
    graph = _import_graph()
    rooms: dict[str, set[str]] = {}
    behind: dict[tuple[str, str], list[tuple[str, str]]] = {}
    for a in mods:
        if a.split(".")[0] != tower:
            continue
        ra = _room(a, mods)
        rooms.setdefault(ra, set())
        if (a, "*") in skip:
            continue
        for b in sorted(graph[a]):
            if b.split(".")[0] != tower or (a, b) in skip:
                continue
            rb = _room(b, mods)
            if rb != ra:
                rooms[ra].add(rb)
                behind.setdefault((ra, rb), []).append((a, b))
    for targets in list(rooms.values()):
        for rb in targets:
            rooms.setdefault(rb, set())
    return rooms, behind


def _knot_report(tower: str) -> str:
    rooms, behind = _room_graph(tower)
    lines = []
    for cycle in _cycles(rooms):
        inside = set(cycle)
        for (ra, rb), pairs in sorted(behind.items()):
            if ra in inside and rb in inside:
                lines.append(f"{ra} -> {rb}: " + ", ".join(f"{a} -> {b}" for a, b in pairs))
    return "\n".join(lines)


@pytest.mark.parametrize(
    "tower",
    [
        "stimuli",
        "analysis",
        "experiment",
    ],
)
def test_no_room_cycles(tower: str) -> None:
    """No two rooms (first sub-folders or top modules) of a tower import each other in a circle."""
    rooms, _ = _room_graph(tower)
    assert not _cycles(rooms), f"{tower}: rooms import each other in a circle:\n" + _knot_report(
        tower
    )


def test_rooms_and_named_imports_are_seen() -> None:
    """The room check sees a room's top module, packages, and imports made by name."""
    mods = _project_modules()
    assert _room("experiment.session.engine", mods) == "experiment/session"
    assert _room("experiment.outputs", mods) == "experiment/outputs.py"
    assert _room("experiment.log", mods) == "experiment/log"
    root_cli = _imports_of("experiment.cli", mods["experiment.cli"], mods)
    assert {"stimuli.cli", "analysis.cli", "experiment.demos.study"} <= root_cli  # import_module
    analysis = _imports_of("analysis", mods["analysis"], mods)
    assert {"analysis.pipeline", "analysis.report"} <= analysis  # lazy_loader.attach
    active = _named_imports_of("experiment.active", mods["experiment.active"], mods)
    assert "experiment.viewer.state" in active  # a lazy table of names
