"""Every command shown in README.md runs, in order, in one scratch folder.

The README's fenced ``bash`` blocks are the source: nothing here lists the commands again. The
set-up command's ``pip install`` half is what ``.ci/run`` has just executed, so only its
``confocal demo`` half runs here; ``python -m pytest`` is checked to be the command ``.ci/run``
runs rather than run recursively. The operator console and the second rater's scorer are
interactive: they run in a pseudo-terminal with scripted keystrokes (the subject's screen is
the offscreen presenter through ``CONFOCAL_PRESENTER=offscreen``), and the trial log must then
hold exactly what was typed and scored.
"""

from __future__ import annotations

import json
import os
import pty
import re
import shlex
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import REPO_ROOT
from tests.ptyread import read_pty

README = REPO_ROOT / "README.md"


def readme_commands() -> list[str]:
    """Return the README's shell commands, in order (one per line of each ``bash`` block)."""
    text = README.read_text(encoding="utf-8")
    cmds = []
    for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S):
        for line in block.splitlines():
            line = line.strip()
            if line and not line.startswith("#"):
                cmds.append(line)
    return cmds


COMMANDS = readme_commands()


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    """One scratch folder shared by all README commands (they build on each other, in order: the
    suite runs each test file on one worker, ``--dist loadfile``)."""
    return tmp_path_factory.mktemp("readme")


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["MPLBACKEND"] = "Agg"
    env["CONFOCAL_PRESENTER"] = "offscreen"
    env["PYTHONUNBUFFERED"] = "1"
    return env


def _run(cmd: str, cwd: Path, timeout_s: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run(
        shlex.split(cmd), cwd=cwd, env=_env(), capture_output=True, text=True, timeout=timeout_s
    )


KEY = {"enter": "\r", "f1": "\x1bOP", "f4": "\x1bOS", "ctrl+q": "\x11"}


ANSI = re.compile(r"\x1b\[[0-9;?]*[ -/]*[@-~]|\x1b[()][0-9A-Za-z]|\x1b[=>]")


def _drive_tty(
    cmd: str, cwd: Path, ready: str, script: list[tuple[str, str]], timeout_s: float = 120
) -> str:
    """Run ``cmd`` in a pseudo-terminal, wait for ``ready`` on its screen, then type ``script``.

    Each step types ``text`` and presses ``key``, letting the app settle after each. The
    program must then exit by itself with status 0 (the script's last key quits it). Returns
    the screen output, escape sequences removed.
    """
    pid, fd = pty.fork()
    if pid == 0:  # child: become the command
        os.chdir(cwd)
        env = _env()
        env.update(TERM="xterm-256color", COLUMNS="120", LINES="40")
        argv = shlex.split(cmd)
        os.execvpe(argv[0], argv, env)
    out = bytearray()
    deadline = time.monotonic() + timeout_s

    def pump(seconds: float) -> None:
        read_pty(fd, out, min(deadline, time.monotonic() + seconds))

    def screen() -> str:
        return ANSI.sub("", out.decode(errors="replace"))

    status = None
    try:
        while ready not in screen():
            if time.monotonic() > deadline:
                raise AssertionError(f"{cmd!r}: {ready!r} never appeared:\n{screen()[-3000:]}")
            pump(0.2)
        pump(0.5)
        for text, key in script:
            for ch in text:
                os.write(fd, ch.encode())
                pump(0.02)
            pump(0.3)
            os.write(fd, KEY[key].encode())
            pump(1.0)
        while time.monotonic() < deadline:
            wpid, status = os.waitpid(pid, os.WNOHANG)
            if wpid:
                break
            pump(0.2)
        else:
            os.kill(pid, 9)
            os.waitpid(pid, 0)
            raise AssertionError(f"{cmd!r} did not exit; screen:\n{screen()[-3000:]}")
    finally:
        os.close(fd)
    assert os.waitstatus_to_exitcode(status) == 0, screen()[-3000:]
    return screen()


def _db_rows(db: Path, sql: str, *args) -> list[tuple]:
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        return con.execute(sql, args).fetchall()
    finally:
        con.close()


def _check_demo(out: Path, stdout: str) -> None:
    """The demo's report exists and agrees with its own SQLite trial log."""
    results = json.loads((out / "report" / "results.json").read_text())
    assert (out / "report" / "report.md").is_file()
    assert list((out / "report").glob("*.png")) and list((out / "report").glob("*.pdf"))
    db = out / "study.sqlite"
    n, k = _db_rows(db, "SELECT COUNT(*), SUM(recognized) FROM tidy_trials WHERE part = 'main'")[0]
    assert results["n_trials"] == n == 6 * 320  # six subjects x the paper's 320 main trials
    assert results["n_recognized"] == k
    subjects = {r[0] for r in _db_rows(db, "SELECT DISTINCT subject FROM tidy_trials")}
    assert set(results["subject_thresholds"]) == subjects
    for cond in ("cluttered", "decluttered"):
        t = results["thresholds"][cond]
        assert t["ci95"][0] <= t["p50_pixels"] <= t["ci95"][1]
        # the printed summary is the computed one
        assert f"{t['p50_pixels']:,.0f} px" in stdout


@pytest.mark.slow
@pytest.mark.parametrize("cmd", COMMANDS, ids=[c[:60] for c in COMMANDS])
def test_readme_command(cmd: str, workdir: Path) -> None:
    """Run one README command (in README order) and check what it promises."""
    if cmd == "python -m pytest":
        ci = (REPO_ROOT / ".ci" / "run").read_text()
        assert re.search(r"^python -m pytest$", ci, flags=re.M), ".ci/run must run the README's"
        return
    if cmd.startswith("python -m pip install"):
        # .ci/run ran the install half; run the rest here.
        parts = [p.strip() for p in cmd.split("&&")]
        assert parts[0] == "python -m pip install -e '.[dev]'"
        assert "python -m pip install -e '.[dev]'" in (REPO_ROOT / ".ci" / "run").read_text()
        for part in parts[1:]:
            r = _run(part, workdir)
            assert r.returncode == 0, r.stderr[-3000:]
            if part == "confocal demo":
                _check_demo(workdir / "confocal-demo", r.stdout)
        return
    argv = shlex.split(cmd)
    if argv[:3] == ["confocal", "session", "run"] and "--headless" not in argv:
        # The operator: Enter past the "Training part" screen, Enter to show the first stimulus,
        # scores "scissors" as named, Enter for the next trial, "a hat" as wrong, then quits.
        _drive_tty(
            cmd,
            workdir,
            "Press Enter",
            [
                ("", "enter"),
                ("", "enter"),
                ("scissors", "f1"),
                ("", "enter"),
                ("a hat", "f4"),
                ("", "ctrl+q"),
            ],
        )
        db = workdir / argv[argv.index("--data") + 1]
        rows = _db_rows(
            db,
            "SELECT response, score, rater FROM tidy_trials WHERE subject = ? ORDER BY trial_index",
            argv[argv.index("--subject") + 1],
        )
        assert rows == [("scissors", "named", "operator"), ("a hat", "wrong", "operator")]
        return
    if argv[:3] == ["confocal", "active", "run"] and "person" in argv:
        # The operator starts the first search and scores the subject's words (no subject keys:
        # the offscreen presenter has no keyboard), then quits.
        _drive_tty(cmd, workdir, "Enter starts", [("", "enter"), ("a tree", "f4"), ("", "ctrl+q")])
        db = workdir / argv[argv.index("--data") + 1]
        rows = _db_rows(
            db,
            "SELECT kind, json_extract(payload, '$.response'), json_extract(payload, '$.score'), "
            "json_extract(payload, '$.rater') FROM active_events WHERE kind IN ('answer', 'score') "
            "ORDER BY seq",
        )
        rater = argv[argv.index("--rater") + 1]
        assert rows == [("answer", "a tree", None, None), ("score", None, "wrong", rater)]
        return
    if argv[:2] == ["confocal", "score"]:
        db = workdir / argv[2]
        before = _db_rows(db, "SELECT COUNT(*) FROM scores")[0][0]
        _drive_tty(cmd, workdir, "f1", [("", "f1"), ("", "f4"), ("", "ctrl+q")])
        rater = argv[argv.index("--rater") + 1]
        new = _db_rows(db, "SELECT score FROM scores WHERE rater = ? ORDER BY rowid", rater)
        assert [s for (s,) in new] == ["named", "wrong"]
        assert _db_rows(db, "SELECT COUNT(*) FROM scores")[0][0] == before + 2
        return
    r = _run(cmd, workdir)
    assert r.returncode == 0, f"{cmd}\n{r.stdout[-2000:]}\n{r.stderr[-3000:]}"
    if argv[:2] == ["confocal", "demo"] and not {"--lightfield", "--active"} & set(argv):
        _check_demo(workdir / "confocal-demo", r.stdout)
    if "--out" in argv or "--screenshot" in argv:
        flag = "--out" if "--out" in argv else "--screenshot"
        assert (workdir / argv[argv.index(flag) + 1]).exists(), f"{cmd} wrote nothing"


def test_readme_has_the_two_fresh_machine_commands() -> None:
    """The README's first two commands are the set-up + demo and the tests."""
    assert COMMANDS[0] == "python -m pip install -e '.[dev]' && confocal demo"
    assert COMMANDS[1] == "python -m pytest"


if __name__ == "__main__":  # pragma: no cover
    print("\n".join(COMMANDS), file=sys.stdout)
