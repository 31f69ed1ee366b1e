"""The output contract under generated path shapes and two writers at once.

Generated cases (``tests/output_contract_cases.py``): random layouts of folders, files and links
(to folders, files, inputs, a parent, dangling, loops), ``..`` after a link, relative and
absolute paths, ``--force`` or not, for every command in ``WRITING_COMMANDS``. Every file, folder
and link under the case's folders is hashed before and after each run: nothing outside the
command's own output may change, vanish or appear; a refusal is one line naming the path typed,
exit status 2, before the work starts. Most cases run a stand-in body that writes the way the
command does (the same library writer, the same guard); some run every real command.
"""

from __future__ import annotations

import os
import random
import shutil
import tempfile
from contextlib import redirect_stderr
from io import StringIO
from pathlib import Path

import pytest

from experiment.output_guard import output_lock
from experiment.outputs import WRITING_COMMANDS, write_manifest
from tests.conftest import run_cli
from tests.output_contract_cases import (
    REAL,
    Case,
    check_case,
    commands,
    generate,
    judge_race,
    make_world,
    race,
    real_argv,
    real_cases,
    run_real,
    run_stub,
    snapshot,
    tiny_demo,
)

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture
def fast_root():
    """A fresh folder on a memory file system where there is one (the cases are many)."""
    shm = Path("/dev/shm")
    base = shm if shm.is_dir() and os.access(shm, os.W_OK) else None
    root = Path(tempfile.mkdtemp(prefix="confocal-contract-", dir=base))
    yield root
    shutil.rmtree(root, ignore_errors=True)


def test_staging_twins_are_the_same_code():
    """``analysis`` may not import ``stimuli``: its copy of the staging rules must not drift."""
    a = (REPO / "stimuli" / "staging.py").read_text()
    b = (REPO / "analysis" / "staging.py").read_text()
    assert a == b


def test_a_staging_folder_is_removed_only_while_it_is_the_one_made(tmp_path):
    """Removal goes by device and inode: a folder put at the same path meanwhile is kept."""
    from stimuli.staging import new_staging, remove_own_tree

    tmp, ident = new_staging(tmp_path / "out")
    os.rename(tmp, tmp_path / "moved")
    tmp.mkdir()
    (tmp / "theirs.txt").write_text("someone else's\n")
    assert not remove_own_tree(tmp, ident)
    assert (tmp / "theirs.txt").is_file()
    assert remove_own_tree(tmp_path / "moved", ident)
    assert not (tmp_path / "moved").exists()


def test_publishing_never_replaces_a_target_that_appeared(tmp_path):
    from stimuli.staging import new_staging, publish

    out = tmp_path / "out"
    tmp, ident = new_staging(out)
    (tmp / "a.txt").write_text("new\n")
    out.mkdir()
    (out / "theirs.txt").write_text("appeared meanwhile\n")
    with pytest.raises(FileExistsError):
        publish(tmp, ident, out)
    assert (out / "theirs.txt").is_file() and (tmp / "a.txt").is_file()
    (out / "theirs.txt").unlink()  # an empty folder is taken (the kernel checks it is empty)
    publish(tmp, ident, out)
    assert (out / "a.txt").is_file() and not tmp.exists()


def test_a_link_then_dotdot_never_deletes_the_folder_it_leads_to(tmp_path, monkeypatch, capsys):
    """``work/link -> ../data/deep``: ``--out link/../thesis`` is ``data/thesis``, a user's folder:
    refused, and nothing of it is deleted (it was deleted, with everything in it)."""
    (tmp_path / "data" / "deep").mkdir(parents=True)
    (tmp_path / "data" / "thesis").mkdir()
    (tmp_path / "data" / "thesis" / "chapter1.tex").write_text("\\chapter{One}\n")
    (tmp_path / "work").mkdir()
    (tmp_path / "work" / "link").symlink_to("../data/deep")
    monkeypatch.chdir(tmp_path / "work")
    before = snapshot(tmp_path)
    capsys.readouterr()
    synth = ["stimuli", "synth", "--objects", "1", "--training", "0", "--size", "64x48"]
    assert run_cli([*synth, "--out", "link/../thesis"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "link/../thesis" in err and "chapter1.tex" in err, err
    assert snapshot(tmp_path) == before
    # and a new name there is written where the kernel puts it: beside the link's target
    assert run_cli([*synth, "--out", "link/../new"]) == 0
    assert (tmp_path / "data" / "new" / "objects.csv").is_file()
    assert not (tmp_path / "work" / "new").exists()


def test_a_loop_of_links_is_one_line(tmp_path, monkeypatch, capsys):
    (tmp_path / "a").symlink_to("b")
    (tmp_path / "b").symlink_to("a")
    monkeypatch.chdir(tmp_path)
    capsys.readouterr()
    code = run_cli(["analyze", "fit", "t.csv", "--x", "level", "--y", "c", "--out", "a/rep"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "loop of symbolic links" in err, err
    assert "Traceback" not in err


@pytest.mark.parametrize("chunk", range(6))
def test_generated_cases_harm_nothing(chunk, fast_root):
    """50 generated cases a chunk, over every writing command (stand-in bodies)."""
    rng = random.Random(1000 + chunk)
    problems = []
    for i in range(50):
        case = generate(rng)
        root = fast_root / f"c{i}"
        root.mkdir()
        outcome = check_case(case, root, run_stub)
        if outcome.problems:
            problems.append(
                f"{case.label()} -> {outcome.code} {outcome.message}: " + str(outcome.problems)
            )
    assert not problems, "\n".join(problems[:10])


def test_every_command_is_generated():
    rng = random.Random(1000)
    drawn = {generate(rng).command for _ in range(300)}
    assert drawn == set(commands())


# -- the real commands ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    return make_world(tmp_path_factory.mktemp("contract-inputs"))


#: The real commands; the analyses take ~11 s for their cases on 2 busy cores (slow).
REAL_PARAMS = [
    pytest.param(c, k, id=f"{c} {k}", marks=[pytest.mark.slow] if c.startswith("analyze") else [])
    for c, k in sorted(REAL)
]


@pytest.mark.parametrize(("command", "kind"), REAL_PARAMS)
def test_generated_cases_with_every_real_command(command, kind, world, tmp_path, monkeypatch):
    """Three generated cases a command (the first one accepted), the real command running."""
    monkeypatch.setenv("COLUMNS", "250")
    if command == "demo":
        tiny_demo(monkeypatch.setattr)

    problems = []
    accepted = 0
    for i, case in enumerate(real_cases(command, kind, 3)):
        root = tmp_path / f"c{i}"
        root.mkdir()
        case.fail = False
        outcome = check_case(case, root, lambda c, r: run_real(c, r, world), world["root"])
        accepted += outcome.code == 0
        if outcome.problems:
            problems.append(
                f"{case.label()} -> {outcome.code} {outcome.message}: " + str(outcome.problems)
            )
    assert not problems, "\n".join(problems)
    assert accepted >= 1, "no case ran the command"


# -- two writers ---------------------------------------------------------------------------------


@pytest.mark.parametrize(("command", "kind"), sorted(REAL), ids=[" ".join(k) for k in sorted(REAL)])
def test_a_second_writer_is_refused_before_the_work(command, kind, world, tmp_path, monkeypatch):
    """While one run holds an output, a second writer to it refuses with one line, exit 2, and
    changes nothing (the first run's lock is held here, as the first run holds it)."""
    monkeypatch.chdir(tmp_path)
    if command == "demo":
        tiny_demo(monkeypatch.setattr)
    name = {"lightfield synth": "lf.npz"}.get(command, "out.png") if kind == "file" else "out"
    out = tmp_path / name
    case = Case(command, commands()[command][0], name, kind)
    spec = next(s for s in WRITING_COMMANDS if s.command == command and s.out != "shots")
    case.spec = spec
    if kind == "folder":  # an earlier own output: the second writer must not touch it
        out.mkdir()
        (out / "r.txt").write_text("earlier\n")
        write_manifest(out, spec.name_of({"out": "x"}), ["r.txt"])
    before = snapshot(tmp_path)
    buf = StringIO()
    with output_lock(os.path.realpath(out), name), redirect_stderr(buf):
        code = run_cli(real_argv(case, tmp_path, world))
    err = buf.getvalue()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2 and len(lines) == 1, err
    assert "another confocal command" in lines[0] and name in lines[0], lines[0]
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize(
    "line",
    [
        "analyze fit {table} --x level --y correct --out rep --no-plots",
        "stimuli build {pairs} --out set --working-size 64x48",
    ],
    ids=["analyze fit", "stimuli build"],
)
def test_two_writers_at_once_lose_no_finished_output(line, world, tmp_path):
    """Two processes started together on one --out: no finished output is lost, a loser
    refuses with one line and exit 2, nothing is left beside the output."""
    argv = [w.format(**world) for w in line.split()]
    out = tmp_path / argv[argv.index("--out") + 1]
    results = race([argv, argv], tmp_path)
    assert not judge_race(results, out, "folder"), results
    assert any(code == 0 for code, _ in results), results


# -- single files: never through a link, nothing partial -----------------------------------------

SHOTS = {
    "present": "present --stimulus {stim_png} --screenshot {out} --force",
    "view": "view {lf} --cpu --planes 4 --screenshot {out} --force",
}


@pytest.mark.parametrize("command", sorted(SHOTS))
@pytest.mark.parametrize("target", ["a file", "dangling"])
def test_a_screenshot_is_never_written_through_a_link(command, target, world, tmp_path, capsys):
    """A link at --screenshot is refused before the work, even with --force: the file it points
    to is not overwritten, and a dangling link does not create a file outside the folder."""
    (tmp_path / "data").mkdir()
    victim = tmp_path / "data" / "victim.png"
    if target == "a file":
        victim.write_bytes(b"the user's picture\n")
    shot = tmp_path / "shot.png"
    shot.symlink_to(victim)
    before = snapshot(tmp_path)
    capsys.readouterr()
    code = run_cli([w.format(out=shot, **world) for w in SHOTS[command].split()])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "symbolic link" in err and str(shot) in err, err
    assert snapshot(tmp_path) == before


class _DiskFillsWhileWriting:
    """``open`` for writing returns a file whose writes stop with ENOSPC after ``room`` bytes."""

    def __init__(self, real_open, room: int) -> None:
        self.real_open, self.room = real_open, room

    def __call__(self, file, mode="r", *args, **kwargs):
        fh = self.real_open(file, mode, *args, **kwargs)
        if not any(c in mode for c in "wax+") or isinstance(file, int):
            return fh
        outer = self
        write = fh.write

        def limited(data):
            if len(data) > outer.room:
                write(data[: outer.room])
                outer.room = 0
                raise OSError(28, "No space left on device", str(file))
            outer.room -= len(data)
            return write(data)

        fh.write = limited
        return fh


@pytest.mark.parametrize("command", sorted(SHOTS))
def test_a_full_disk_leaves_no_partial_screenshot(command, world, tmp_path, monkeypatch, capsys):
    """The disk fills up while the PNG is written: one line, exit 2, no truncated file (which
    would block the next run without --force), an earlier screenshot kept whole, and the next
    run writes it."""
    import builtins
    import io

    shot = tmp_path / "shot.png"
    argv = [w.format(out=shot, **world) for w in SHOTS[command].split()]
    plain = [a for a in argv if a != "--force"]

    def full_disk_run(args: list[str]) -> int:
        full = _DiskFillsWhileWriting(builtins.open, 100)
        monkeypatch.setattr(builtins, "open", full)
        monkeypatch.setattr(io, "open", full)
        capsys.readouterr()
        try:
            return run_cli(args)
        finally:
            monkeypatch.undo()

    code = full_disk_run(plain)
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err, err
    assert [p.name for p in tmp_path.iterdir()] == [], "a partial file was left"
    assert run_cli(plain) == 0
    earlier = shot.read_bytes()
    assert earlier[:4] == b"\x89PNG"
    assert full_disk_run(argv) == 2  # --force: replacing it fails half-way
    assert [p.name for p in tmp_path.iterdir()] == ["shot.png"]
    assert shot.read_bytes() == earlier, "the earlier screenshot was truncated"
