"""SIGTERM, SIGINT and a SIGKILLed parent: long commands stop cleanly; no worker outlives them.

Each test starts a real ``confocal`` process, waits for a sign that the work has started (a
printed trial, a temporary folder, worker processes), sends the signal and checks what is
left: one line on stderr, the exit status 128 + signal, no ``.tmp-`` folder, a readable log.
"""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from experiment.testing import make_stimulus_set
from tests.conftest import protocol_toml

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="Linux signals and /proc")

ROOT = Path(__file__).resolve().parents[1]

PROTOCOL = protocol_toml((1, 2), name="long", training=None)


def _start(args: list, cwd: Path) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(ROOT), COLUMNS="200")
    return subprocess.Popen(
        [sys.executable, "-m", "experiment.cli", *map(str, args)],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # a test run started in the background ignores SIGINT, and children inherit that
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


def _wait_for(cond, proc: subprocess.Popen, timeout_s: float = 60.0) -> None:
    end = time.monotonic() + timeout_s
    while not cond():
        if proc.poll() is not None:
            out, err = proc.communicate()
            pytest.fail(f"the command ended before the signal (exit {proc.returncode}): {err}")
        if time.monotonic() > end:
            proc.kill()
            pytest.fail("the command did not start its work in time")
        time.sleep(0.05)


def _children(pid: int) -> list[int]:
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")  # a zombie has stopped; only its exit status is left


def _left_after(pids: list[int], seconds: float) -> list[int]:
    """The processes still running after up to ``seconds`` (multiprocessing's resource tracker
    leaves when it reads the end of its pipe, a moment after the parent)."""
    end = time.monotonic() + seconds
    while [p for p in pids if _alive(p)] and time.monotonic() < end:
        time.sleep(0.05)
    return [p for p in pids if _alive(p)]


def _one_line(proc: subprocess.Popen, sig: signal.Signals) -> str:
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + sig, f"exit {proc.returncode}: {err}"
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    assert lines[0] == f"confocal: stopped by {sig.name}; the log is closed, nothing half-written"
    return lines[0]


LINE = "confocal: stopped by {}; the log is closed, nothing half-written"


def _imported(line: str) -> str:
    """The module a ``-X importtime`` line reports (its import has just ended), or ''."""
    return line.rsplit("|", 1)[-1].strip() if line.startswith("import time:") else ""


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_stop_signal_during_start_up_imports_ends_with_one_line(tmp_path, sig):
    """The signal lands while the command imports its modules (typer, the demo's stack)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), COLUMNS="200")
    proc = subprocess.Popen(
        [sys.executable, "-X", "importtime", "-m", "experiment.cli", "demo", "--out", "demo"],
        cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    assert proc.stderr is not None
    try:
        # the package's first module: its import ends before typer and the command's modules
        while _imported(proc.stderr.readline()) != "experiment.errors":
            assert proc.poll() is None, "the command ended before the signal"
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("import time:")]
    assert (proc.returncode, lines) == (128 + sig, [LINE.format(sig.name)]), err[-3000:]
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_stop_signal_as_the_command_exits_is_one_line_or_ignored(tmp_path, sig):
    """Sent as soon as the command's output is printed: it lands while the command returns or
    while Python exits; never a silent death by the signal."""
    for _ in range(3):
        proc = _start(["--version"], tmp_path)
        assert proc.stdout is not None
        assert proc.stdout.readline().startswith("confocal ")
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
        assert (proc.returncode, err) in ((0, ""), (128 + sig, LINE.format(sig.name) + "\n"))


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_stop_signal_during_a_session_keeps_the_committed_trials(tmp_path, sig):
    stim = make_stimulus_set(tmp_path / "stim", n_main=3, n_training=1, levels=(1, 2))
    proto = tmp_path / "long.toml"
    proto.write_text(PROTOCOL)
    db = tmp_path / "study.sqlite"
    proc = _start(
        ["session", "run", "--protocol", proto, "--stimuli", stim, "--subject", "S01",
         "--data", db, "--headless", "--seed", "1", "--hold-s", "0.3", "--progress-every", "1"],
        tmp_path,
    )  # fmt: skip
    assert proc.stdout is not None
    line = proc.stdout.readline()  # "trial 1/n": a trial is committed
    assert "trial" in line, line
    proc.send_signal(sig)
    _one_line(proc, sig)
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        n = con.execute("SELECT COUNT(*) FROM trials").fetchone()[0]
        events = [r[0] for r in con.execute("SELECT kind FROM events")]
    finally:
        con.close()
    assert n >= 1
    assert "abort" in events
    assert not list(tmp_path.glob("*-journal")), "a transaction was left open"


@pytest.fixture(scope="module")
def pairs(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("pairs") / "pairs"
    made = _start(["stimuli", "synth", "--objects", "20", "--size", "640x480", "--out", out],
                  out.parent)  # fmt: skip
    _, err = made.communicate(timeout=120)
    assert made.returncode == 0, err
    return out


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_stop_signal_during_a_build_leaves_no_temporary_folder(tmp_path, sig, pairs):
    out = tmp_path / "set"
    proc = _start(["stimuli", "build", pairs, "--out", out], tmp_path)
    _wait_for(lambda: any(tmp_path.glob(".set.tmp-*")), proc)
    time.sleep(0.2)  # the first stimuli are written into it
    proc.send_signal(sig)
    _one_line(proc, sig)
    assert list(tmp_path.iterdir()) == [], "temporary folder or partial set left"


#: A power simulation long enough to be stopped, on two worker processes.
POWER_2_WORKERS = ["analyze", "power", "--odds-ratio", "2", "--sims", "100000", "--subjects", "2",
                   "--processes", "2", "--seed", "1"]  # fmt: skip


def test_stop_signal_during_power_ends_the_workers(tmp_path):
    proc = _start(POWER_2_WORKERS, tmp_path)
    _wait_for(lambda: len(_children(proc.pid)) >= 2, proc)
    workers = _children(proc.pid)
    time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)
    try:
        _one_line(proc, signal.SIGTERM)
    finally:
        left = _left_after(workers, 5.0)
        for p in left:
            os.kill(p, signal.SIGKILL)
    assert not left, f"workers outlived the stopped command: {left}"


#: Drains a power grid through the command's progress loop and stops it there (not in the
#: pool's wait), keeping the grid alive in a reference cycle with the collector off: the pool must
#: end with the loop, not when (or if) the cycle is collected.
STOPPED_IN_THE_CONSUMER = """
import gc, sys
gc.disable()
from analysis.cli import _run_with_progress
from analysis.power import power_grid

class StopAfterTwo:
    def __init__(self, grid):
        self.grid, self.me, self.seen = grid, self, 0
    def __iter__(self):
        return self
    def __next__(self):
        self.seen += 1
        if self.seen > 2:
            raise KeyboardInterrupt
        return next(self.grid)
    def close(self):
        self.grid.close()

if __name__ == "__main__":  # spawned workers import this file
    grid = power_grid("odds_ratio", [2.0], [2], n_sims=100000, processes=2, seed=1)
    try:
        _run_with_progress(StopAfterTwo(grid), "power", 100000)
    except KeyboardInterrupt:
        print("stopped", flush=True)
"""


def test_power_stopped_outside_the_pools_wait_ends_its_workers_at_once(tmp_path):
    script = tmp_path / "stop_in_consumer.py"
    script.write_text(STOPPED_IN_THE_CONSUMER)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(
        [sys.executable, str(script)], cwd=tmp_path, env=env, text=True,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )  # fmt: skip
    try:
        out, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        for p in _children(proc.pid):
            os.kill(p, signal.SIGKILL)
        proc.kill()
        pytest.fail("the process went on simulating after its progress loop was stopped")
    assert proc.returncode == 0, err
    assert out.strip() == "stopped"


def test_sigkilled_power_takes_its_workers_with_it(tmp_path):
    proc = _start(POWER_2_WORKERS, tmp_path)
    _wait_for(lambda: len(_children(proc.pid)) >= 3, proc)  # two workers and the tracker
    time.sleep(1.0)  # the workers have run their initializer
    workers = _children(proc.pid)
    proc.send_signal(signal.SIGKILL)
    proc.wait(10)
    left = _left_after(workers, 5.0)
    for p in left:  # do not leave them computing on a shared machine
        os.kill(p, signal.SIGKILL)
    assert not left, f"workers outlived their SIGKILLed parent: {left}"


def test_sigkilled_session_takes_its_presenter_with_it(tmp_path):
    """A RemoteDisplay's child (a stand-in presenter that says ready, then waits) dies with it."""
    fake = tmp_path / "presenter.py"
    fake.write_text(
        "import json, sys, time\n"
        "print(json.dumps({'event': 'ready', 'protocol': 1}), flush=True)\n"
        "time.sleep(60)\n"
    )
    script = tmp_path / "parent.py"
    script.write_text(
        "import sys, time\n"
        "from experiment.presentation.process import RemoteDisplay\n"
        f"d = RemoteDisplay({{}}, command=[sys.executable, {str(fake)!r}])\n"
        "print(d.pid, flush=True)\n"
        "time.sleep(60)\n"
    )
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    parent = subprocess.Popen(
        [sys.executable, str(script)], stdout=subprocess.PIPE, text=True, env=env
    )
    assert parent.stdout is not None
    child = int(parent.stdout.readline())
    assert _alive(child)
    parent.send_signal(signal.SIGKILL)
    parent.wait(10)
    end = time.monotonic() + 5
    while _alive(child) and time.monotonic() < end:
        time.sleep(0.05)
    alive = _alive(child)
    if alive:
        os.kill(child, signal.SIGKILL)
    assert not alive, "the presenter outlived its SIGKILLed parent"


def test_ctrl_c_in_the_operator_console_saves_and_quits(tmp_path):
    """The console's terminal is in raw mode, so Ctrl-C arrives as a key, not as SIGINT: it is
    bound to "save and quit", as Ctrl+Q (the scored trial kept, the one on screen shown again)."""
    import asyncio

    from experiment.console import OperatorConsole
    from experiment.presentation.displays import NullDisplay
    from experiment.session.engine import Session
    from tests.experiment.conftest import console_session

    with console_session(tmp_path) as (session, clock, log):
        app = OperatorConsole(session, NullDisplay(clock))

        async def script() -> int:
            async with app.run_test() as pilot:
                await pilot.press("enter", "enter", "c", "u", "p", "f1", "enter")
                pending = app.trial.index  # trial 2 on screen, not scored
                await pilot.press("h", "a", "l", "f", "ctrl+c")
                await pilot.pause()
                assert not app.is_running, "Ctrl-C did not quit the console"
                return pending

        pending = asyncio.run(asyncio.wait_for(script(), timeout=60))
        assert app.return_value is not None and app.return_value.answered == 1
        session.close()
        assert log.answered_count(session.session_id) == 1
        assert "abort" in [e["kind"] for e in log.events(session.session_id)]
        resumed = Session.open(log, session.protocol, session.stimset, "S01", clock=clock)
        assert resumed.next_trial().index == pending
        resumed.close()


def test_every_console_binds_ctrl_c_as_its_quit_key():
    from experiment.console import OperatorConsole, ScoringApp
    from experiment.console.active import ActiveConsole

    for app in (OperatorConsole, ScoringApp, ActiveConsole):
        keys = {b.key: b for b in app.BINDINGS}
        assert keys["ctrl+c"].action == keys["ctrl+q"].action, app.__name__
        assert keys["ctrl+c"].priority, app.__name__  # before the response line's copy key


#: Draws "figures" that take a minute in save_all's worker process and in the process itself,
#: stopped by a signal.
_SLOW_FIGURES = """
import sys, time
from pathlib import Path
import analysis.figures as figures
from experiment.signals import Stopped, stop_on_signals

def slow(result, names, folder, *formats):
    print("drawing", flush=True)
    time.sleep(60)
    return []

figures._draw_and_save = slow
try:
    with stop_on_signals():
        figures.save_all(None, Path(sys.argv[1]))
except Stopped as stop:
    sys.exit(stop.exit_code)
"""


def test_stop_signal_while_figures_are_drawn_ends_their_workers_at_once(tmp_path):
    """The analysis step (``analyze run``, the demo's last step) draws a figure in a worker
    process while it draws the others; a stop had waited for the worker to finish drawing (a
    minute on a busy machine)."""
    script = tmp_path / "figures.py"
    script.write_text(_SLOW_FIGURES)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(
        [sys.executable, str(script), str(tmp_path)], env=env, stdout=subprocess.PIPE, text=True
    )
    assert proc.stdout is not None
    assert [proc.stdout.readline(), proc.stdout.readline()] == ["drawing\n"] * 2
    workers = _children(proc.pid)
    proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout=20)
    finally:
        proc.kill()
        left = _left_after(workers, 5.0)
        for p in left:
            os.kill(p, signal.SIGKILL)
    assert proc.returncode == 143
    assert not left, f"figure workers outlived the stop: {left}"


def test_stop_signal_during_the_demo_leaves_no_output_and_no_worker(tmp_path):
    """Stopped while its knowledge set is made in a worker process and the test set here."""
    proc = _start(["demo", "--out", "demo"], tmp_path)
    _wait_for(lambda: len(_children(proc.pid)) >= 1, proc)
    workers = _children(proc.pid)
    time.sleep(0.3)
    proc.send_signal(signal.SIGINT)
    try:
        _one_line(proc, signal.SIGINT)
    finally:
        left = _left_after(workers, 5.0)
        for p in left:
            os.kill(p, signal.SIGKILL)
    assert not left, f"workers outlived the stopped demo: {left}"
    assert list(tmp_path.iterdir()) == [], "the demo left an output or temporary folder"


def test_a_stop_inside_hold_stops_is_raised_where_the_block_ends():
    """A step that must not be cut in two finishes; the stop comes right after it."""
    from experiment.signals import Stopped, hold_stops, stop_on_signals

    steps = []
    with pytest.raises(Stopped) as stop, stop_on_signals():
        with hold_stops():
            with hold_stops():
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(0.01)  # the handler has run
                steps.append("renamed")
            steps.append("recorded")
        steps.append("after the block")
    assert steps == ["renamed", "recorded"]
    assert stop.value.exit_code == 143


def test_a_second_signal_ends_a_stop_that_was_lost(monkeypatch):
    """A stop that a library's ``except BaseException`` swallowed: a second signal within the
    grace period is ignored (clean-up must finish), one after it ends the process at once."""
    import experiment.signals as signals

    ended = []
    monkeypatch.setattr(signals, "_exit_now", ended.append)
    # SIGTERM throughout: a test worker may run with SIGINT ignored, which the block keeps
    with signals.stop_on_signals():
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.01)
        except signals.Stopped:
            pass  # swallowed
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.01)
        assert ended == []
        monkeypatch.setattr(signals, "SECOND_SIGNAL_GRACE_S", 0.0)
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.01)
    assert ended == [signal.SIGTERM]


_FORK_PROBE = """
import os, signal, sys
sys.argv[0] = "confocal"  # what the console script's process looks like to the package
from experiment.signals import stop_on_signals

with stop_on_signals():
    pid = os.fork()
    if pid == 0:
        ign = signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        dfl = signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
        os._exit(0 if ign and dfl else 1)
    print(os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]))
"""


def test_a_child_the_command_forks_leaves_stop_signals_to_it():
    """A pool worker ignores Ctrl-C and dies of SIGTERM from its first instruction, before its
    initializer runs (a Ctrl-C in between raised the parent's stop in it, with a traceback)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run(
        [sys.executable, "-c", _FORK_PROBE], env=env, capture_output=True, text=True, timeout=60
    )
    assert out.stdout.strip() == "0", out.stderr
