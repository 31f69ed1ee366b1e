"""Package-level rules: dependency direction (H1), documented public API (H24), CLI errors."""

from __future__ import annotations

import importlib
import inspect
import json
import subprocess
import sys

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
