"""``confocal --help``/``--version`` start without the heavy modules; help pages render cleanly.

Start-up time itself is measured in ``benchmarks/bench_startup.py`` (a ratio
against ``python -c pass``), not asserted here.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest

from experiment import cli

HEAVY = ("numpy", "pandas", "scipy", "matplotlib", "moderngl", "stimuli", "analysis", "textual")

_PROBE = """
import json, sys
from experiment import cli
try:
    cli.main({argv!r})
except SystemExit:
    pass
print(json.dumps(sorted(m for m in {heavy!r} if m in sys.modules)))
"""


@pytest.mark.parametrize("argv", [["--help"], ["--version"], []])
def test_root_help_and_version_import_nothing_heavy(argv):
    code = _PROBE.format(argv=argv, heavy=HEAVY)
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True
    ).stdout
    assert json.loads(out.strip().splitlines()[-1]) == []


def test_a_sub_command_is_imported_when_it_runs(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["session", "status", "/nonexistent/study.sqlite"])
    assert exc.value.code == 2
    assert "trial log not found" in capsys.readouterr().err


def test_every_registered_command_is_in_the_table():
    """A module that registers a new top-level command must list it in SUBCOMMANDS."""
    import importlib

    import typer

    for module in sorted({m for m, _ in cli.SUBCOMMANDS.values()}):
        holder = typer.Typer()
        importlib.import_module(module).register(holder)
        names = set(typer.main.get_group(holder).commands)
        assert names <= set(cli.SUBCOMMANDS), f"{module} registers {names - set(cli.SUBCOMMANDS)}"
        assert {n for n, (m, _) in cli.SUBCOMMANDS.items() if m == module} <= names


def test_listing_matches_the_modules():
    """The static table's one-line helps are those of the commands it stands in for."""
    for name, (_, short) in cli.SUBCOMMANDS.items():
        real = cli.load_subcommand(name)
        assert real.name == name
        first = " ".join((real.help or "").split("\n\n")[0].split())
        assert first == short, name


def test_unknown_command_still_suggests(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["sesion"])
    assert exc.value.code == 2
    assert "session" in capsys.readouterr().err


def _all_commands():
    out = []

    def walk(path, cmd):
        out.append((path, cmd))
        for name, sub in getattr(cmd, "commands", {}).items():
            walk([*path, name], sub)

    for name in cli.SUBCOMMANDS:
        walk([name], cli.load_subcommand(name))
    return out


def _help(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main([*argv, "--help"])
    assert exc.value.code == 0
    return capsys.readouterr().out


def test_help_pages_have_no_glitches(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "400")  # one line per option: bracketed words stay whole
    root = _help([], capsys)
    assert "<bool>" not in root
    for path, cmd in _all_commands():
        page = _help(path, capsys)
        assert "<bool>" not in page, path
        texts = [cmd.help or ""] + [getattr(p, "help", None) or "" for p in cmd.params]
        for text in texts:
            # rich markup swallows an unescaped [word]; an escaped \[word] prints as [word]
            for token in re.findall(r"\\?\[[^\]\s]+\]", text):
                shown = token.lstrip("\\")
                assert shown in page, f"{' '.join(path)}: {shown} missing from --help"
        assert not re.search(r"\d\.\d{9,}", page), f"{' '.join(path)}: unrounded default"


def test_present_help_shows_display_section(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "400")
    assert "[display] sets the geometry" in _help(["present"], capsys)


def test_edge_ratio_default_is_readable(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "400")
    page = _help(["lightfield", "refocus"], capsys)
    assert "1/13 ≈ 0.077" in page and "0.0769230" not in page


#: What no sub-command's ``--help`` may load. Each takes from 0.02 s (Pillow) to most of a second
#: to import, and the command that needs one imports it when it runs; option types, defaults and
#: help texts need none of them. pydantic comes with typer 0.29 (pyproject.toml keeps typer below).
HEAVY_FOR_HELP = (
    "numpy",
    "scipy",
    "pandas",
    "PIL",
    "skimage",
    "numba",
    "emcee",
    "statsmodels",
    "matplotlib",
    "pydantic",
    "moderngl",
    "textual",
    "dask",
)

_PROBE_EVERY_HELP = """
import json, sys
from experiment import cli
found = {{}}
for path in {paths!r}:
    before = {{m for m in {heavy!r} if m in sys.modules}}
    try:
        cli.main([*path, "--help"])
    except SystemExit as exc:
        if exc.code:
            found[" ".join(path)] = f"exit status {{exc.code}}"
            continue
    new = sorted(m for m in {heavy!r} if m in sys.modules and m not in before)
    if new:
        found[" ".join(path)] = new
print(json.dumps(found))
"""


def test_every_help_page_imports_nothing_heavy():
    """``confocal CMD --help`` stays fast: the libraries a command needs load when it runs.

    Every page of the command tree is shown in one fresh process, one after another: a module
    that any page imports stays in ``sys.modules``, so none can hide behind another page's
    imports. A failure names the first page that loaded each module.
    """
    paths = [path for path, _ in _all_commands()]
    code = _PROBE_EVERY_HELP.format(paths=paths, heavy=HEAVY_FOR_HELP)
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    ).stdout
    assert json.loads(out.strip().splitlines()[-1]) == {}
