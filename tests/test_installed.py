"""The installed package works, not only the checkout.

The wheel is built from the checkout, installed (not editable) into a fresh virtual environment,
and every command is run from an empty folder outside the checkout, so nothing can come from the
source tree: ``confocal --version``, ``confocal --help``, every sub-command's ``--help``, and a
reduced ``confocal demo`` that finds the protocols as installed data files.
"""

from __future__ import annotations

import os
import subprocess
import sys
import venv
from pathlib import Path

import pytest

from tests.conftest import REPO_ROOT

pytestmark = pytest.mark.slow


def _command_paths() -> list[list[str]]:
    """Every command path of the ``confocal`` app (groups and leaves), read from the checkout.

    The root lists its sub-commands lazily (:data:`experiment.cli.SUBCOMMANDS`); each is loaded
    here to walk its own sub-commands.
    """
    from experiment.cli import SUBCOMMANDS, load_subcommand

    paths: list[list[str]] = []

    def walk(cmd, prefix: list[str]) -> None:
        paths.append(prefix)
        for name, sub in sorted(getattr(cmd, "commands", {}).items()):
            walk(sub, [*prefix, name])

    for name in SUBCOMMANDS:
        walk(load_subcommand(name), [name])
    return paths


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> tuple[Path, dict[str, str], Path]:
    """A fresh venv with the wheel installed; returns (bin dir, env, empty working folder)."""
    base = tmp_path_factory.mktemp("wheel")
    wheels = base / "dist"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels)]
        + [str(REPO_ROOT)],
        check=True,
        capture_output=True,
        text=True,
    )
    (wheel,) = wheels.glob("active_confocal-*.whl")
    env_dir = base / "venv"
    venv.EnvBuilder(with_pip=True, system_site_packages=False).create(env_dir)
    bindir = env_dir / "bin"
    # without PYTHONPATH: a checkout on it (with its .egg-info) would look installed to pip
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "VIRTUAL_ENV"))}
    r = subprocess.run(
        [str(bindir / "python"), "-m", "pip", "install", "-q", str(wheel)],
        capture_output=True,
        text=True,
        env=env,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    env["PATH"] = f"{bindir}{os.pathsep}{env.get('PATH', '')}"
    env["MPLBACKEND"] = "Agg"
    env["PYTHONNOUSERSITE"] = "1"
    work = base / "empty"
    work.mkdir()
    return bindir, env, work


def _run(installed, program: str, *args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    """Run ``program`` of the venv's bin folder with ``args`` in the empty working folder."""
    bindir, env, work = installed
    argv = [str(bindir / program), *args]
    return subprocess.run(argv, cwd=work, env=env, capture_output=True, text=True, timeout=timeout)


def test_installed_package_is_not_the_checkout(installed) -> None:
    """The venv imports the packages from its own site-packages, not from the source tree."""
    code = "import stimuli, experiment, analysis; print(stimuli.__file__, experiment.__file__)"
    out = _run(installed, "python", "-c", code)
    assert out.returncode == 0, out.stderr
    assert str(REPO_ROOT) not in out.stdout and "site-packages" in out.stdout


def test_version_and_help(installed) -> None:
    """``--version`` and ``--help`` of the installed command."""
    r = _run(installed, "confocal", "--version")
    assert r.returncode == 0 and r.stdout.startswith("confocal "), r.stderr
    r = _run(installed, "confocal", "--help")
    assert r.returncode == 0 and "Usage" in r.stdout, r.stderr


def test_every_subcommand_help(installed) -> None:
    """Each sub-command documents itself in the installed package."""
    paths = _command_paths()
    assert len(paths) >= 10, paths
    failed = []
    for path in paths:
        r = _run(installed, "confocal", *path, "--help")
        if r.returncode != 0 or "Usage" not in r.stdout:
            failed.append(f"{' '.join(path)}: {r.returncode} {r.stderr.strip()[-300:]}")
    assert not failed, "\n".join(failed)


def test_reduced_demo_from_installed_data(installed) -> None:
    """A one-subject demo runs from an empty folder: protocols come from the installed data."""
    _, _, work = installed
    r = _run(installed, "confocal", "demo", "--subjects", "1", "--out", "demo", timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    assert (work / "demo" / "report" / "report.md").is_file()
    assert (work / "demo" / "report" / "results.json").is_file()
