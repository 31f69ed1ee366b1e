"""Every numeric option of every command, fed NaN, infinities, 1e308, -1 and 10^308.

The walk goes through the click tree that ``confocal`` builds, so a new command or option is
covered without editing this file. Each run must end in option validation or at a missing input
file: exit status 2, one ``confocal: error:`` line or typer's usage box, no traceback, and
quickly (required paths point at files that do not exist, so an accepted value cannot start
any work). NaN and the infinities are never a valid count or size: the message must name the
option, i.e. the value was refused while the options were parsed, before any file was read.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import pytest

from experiment import cli

FLOAT_VALUES = ("nan", "inf", "-inf", "1e308", "-1")
INT_VALUES = ("-1", "1" + "0" * 308)

#: Extra arguments a command needs before its numbers are looked at (the effect to simulate).
EXTRA: dict[str, tuple[str, ...]] = {"analyze power": ("--odds-ratio", "2", "--sims", "1")}


#: click's names of its number types (ranges included) -> the values to try.
_NUMBER_TYPES = {"int": "int", "int range": "int", "float": "float", "float range": "float"}


def _walk(cmd, path):
    if hasattr(cmd, "commands"):
        for name, sub in cmd.commands.items():
            yield from _walk(sub, [*path, name])
    else:
        yield path, cmd


def _cases():
    out = []
    for name in cli.SUBCOMMANDS:
        for path, cmd in _walk(cli.load_subcommand(name), [name]):
            for p in cmd.params:
                if p.param_type_name != "option" or p.is_flag:
                    continue
                kind = _NUMBER_TYPES.get(getattr(p.type, "name", None))
                values = {"float": FLOAT_VALUES, "int": INT_VALUES}.get(kind, ())
                for v in values:
                    out.append((" ".join(path), p.opts[0], v))
    return out


CASES = _cases()
_BOX = re.compile(r"[│╭╮╰╯─]")


def _required(command: str, t: Path, option: str) -> list[str]:
    """The command's required arguments, as paths that do not exist (or a non-empty --out)."""
    full = t / "full"
    full.mkdir(exist_ok=True)
    (full / "keep.txt").write_text("x")
    path, cmd = next((p, c) for p, c in _walk_all() if " ".join(p) == command)
    args: list[str] = []
    for p in cmd.params:
        if not p.required or (p.param_type_name == "option" and p.opts[0] == option):
            continue
        value = str(t / "missing" / (p.name or "x"))
        if p.param_type_name == "option":
            args += [p.opts[0], value if p.name not in ("subject", "rater", "x") else "A"]
        else:
            args.append(value)
    if command in ("demo", "stimuli synth", "lightfield synth"):
        args += ["--out", str(full if command != "lightfield synth" else full / "keep.txt")]
    return [*path, *args]


def _walk_all():
    for name in cli.SUBCOMMANDS:
        yield from _walk(cli.load_subcommand(name), [name])


def test_the_walk_finds_the_numeric_options():
    options = {(c, o) for c, o, _ in CASES}
    assert ("analyze power", "--sims") in options
    assert ("lightfield scan", "--background") in options
    assert ("stimuli build", "--implant-px") in options
    assert len(options) >= 60


@pytest.mark.parametrize(("command", "option", "value"), CASES)
def test_hostile_number_is_refused_with_one_line(command, option, value, tmp_path, capsys,
                                                 monkeypatch):  # fmt: skip
    monkeypatch.setenv("COLUMNS", "250")
    monkeypatch.chdir(tmp_path)
    path = _required(command, tmp_path, option)
    n = len(command.split())
    argv = [*path[:n], *EXTRA.get(command, ()), option, value, *path[n:]]
    capsys.readouterr()
    t0 = time.monotonic()
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    seconds = time.monotonic() - t0
    err = capsys.readouterr().err
    assert exc.value.code == 2, f"{argv}: exit {exc.value.code}; stderr: {err}"
    assert "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if lines[0].startswith("confocal: error:"):
        assert len(lines) == 1, err
        text = lines[0]
    else:
        assert "Usage:" in err, err
        text = " ".join(_BOX.sub(" ", err).split())
    if value in ("nan", "inf", "-inf"):
        assert option in text, f"{option} {value} not refused while parsing options: {text}"
    assert seconds < 10, f"{argv} took {seconds:.1f} s"
