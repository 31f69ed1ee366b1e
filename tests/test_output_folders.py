"""The output contract (experiment/outputs.py), measured on every command that writes.

Each writing command runs against the folders a user could hand it by mistake: (a) a folder with
the user's own file, (b) ``.``, the working folder, (c) the input itself, (d) a parent of the
input, (e) a folder inside the input, (f) a folder the same command wrote before (allowed), and
(g) a folder another command wrote. Every file under the test's folders is hashed before and
after: a refusal (exit 2, one line, no traceback) changes nothing, and a run changes nothing
outside its own output.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from experiment import cli
from experiment.outputs import (
    MANIFEST_NAME,
    STAGING_MARKER,
    WRITING_COMMANDS,
    OutputFolderError,
    check_file,
    check_folder,
    clean_leftovers,
    read_manifest,
    write_manifest,
)
from tests.conftest import StudyInputs, make_study_inputs, run_cli

#: The cheapest PAIRS folder: one object, no training object, small photos.
SYNTH_OPTIONS = ("--objects", "1", "--training", "0", "--size", "64x48")
SYNTH = "stimuli synth " + " ".join(SYNTH_OPTIONS)


@dataclass(frozen=True)
class World(StudyInputs):
    table: Path  # a CSV of level,correct rows for 'analyze fit'
    stim_png: Path  # one photo


@pytest.fixture(scope="module")
def world(tmp_path_factory) -> World:
    root = tmp_path_factory.mktemp("inputs")
    inputs = make_study_inputs(root, *SYNTH_OPTIONS)
    table = root / "table.csv"
    rows = ["level,correct"] + [
        f"{lv},{int((i * 7 + lv) % 6 < lv)}" for lv in range(1, 6) for i in range(8)
    ]
    table.write_text("\n".join(rows) + "\n")
    return World(**vars(inputs), table=table, stim_png=inputs.pairs / "obj01_cup" / "wide.png")


# -- the table of writing commands --------------------------------------------------------------


@dataclass(frozen=True)
class Cmd:
    """A writing command at its cheapest: its command line and what its input is."""

    name: str  # the manifest's command name
    line: str  # after 'confocal'; {out} and the World's fields ({db}, {lf}, ...) are filled in
    input: str | None = None  # the World field it reads
    out_name: str | None = None  # a file output's name (its suffix matters); None: a folder
    force: bool = False  # a second run into its own output folder needs --force (a file's always)
    cannot_run: str = ""  # why it cannot run here (its second run is skipped)

    @property
    def kind(self) -> str:
        """``'file'`` or ``'folder'``: what its output is."""
        return "folder" if self.out_name is None else "file"

    @property
    def again(self) -> tuple[str, ...]:
        """The flag a second run into its own output needs."""
        return ("--force",) if self.force or self.kind == "file" else ()

    def argv(self, w: World, out: Path | str) -> list[str]:
        """Return the command's arguments for the inputs of ``w`` and the output ``out``."""
        return [word.format(out=out, **vars(w)) for word in self.line.split()]


def _tiny_demo(monkeypatch) -> None:
    """The whole study takes ~25 s: the table runs a stand-in that writes like it does."""
    import experiment.demos.study as study
    from experiment.outputs import require_missing_or_empty

    def run_demo(out_dir, **_):
        out = Path(out_dir)
        require_missing_or_empty(out)
        (out / "report").mkdir(parents=True, exist_ok=True)
        (out / "report" / "report.md").write_text("# demo\n")
        return None

    monkeypatch.setattr(study, "run_demo", run_demo)
    monkeypatch.setattr(study, "summary_lines", lambda result: ["demo written"])


CMDS: list[Cmd] = [
    Cmd("analyze run", "analyze {db} --out {out} --no-figures --seed 1", "db"),
    Cmd("analyze fit", "analyze fit {table} --x level --y correct --out {out} --no-plots", "table"),
    Cmd(
        "analyze power", "analyze power --odds-ratio 30 --subjects 1 --sims 1 --seed 1 --out {out}"
    ),
    Cmd("stimuli build", "stimuli build {pairs} --out {out} --working-size 64x48", "pairs"),
    Cmd("stimuli synth", f"{SYNTH} --out {{out}}", force=True),
    Cmd(
        "stimuli tune",
        "stimuli tune {pairs} --sheet {out} --working-size 64x48 --dry-run",
        "pairs",
        out_name="sheet.png",
    ),
    Cmd("lightfield scan", "lightfield scan {lf} --out {out} --planes 4", "lf"),
    Cmd(
        "lightfield refocus --stack", "lightfield refocus {lf} --stack --planes 3 --out {out}", "lf"
    ),
    Cmd(
        "lightfield refocus",
        "lightfield refocus {lf} --disparity 0 --out {out}",
        "lf",
        out_name="img.png",
    ),
    Cmd("lightfield synth", "lightfield synth --size 40x32 --out {out}"),
    Cmd("lightfield synth .npz", "lightfield synth --size 40x32 --out {out}", out_name="lf2.npz"),
    Cmd("session export", "session export {db} --out {out}", "db"),
    Cmd("demo", "demo --out {out}", force=True),
    Cmd("demo --lightfield", "demo --lightfield --out {out}", force=True),
    Cmd("demo --active", "demo --active --out {out}", force=True),
    Cmd(
        "view --screenshot",
        "view {lf} --cpu --planes 4 --screenshot {out}",
        "lf",
        out_name="shot.png",
    ),
    Cmd(
        "view --shots",
        "view {lf} --cpu --shots {out}",
        "lf",
        cannot_run="--shots saves frames of a window; none in CI",
    ),
    Cmd(
        "present --screenshot",
        "present --stimulus {stim_png} --screenshot {out}",
        "stim_png",
        out_name="shot.png",
    ),
]

CASES = [
    "user file",
    "working folder",
    "the input",
    "parent of the input",
    "inside the input",
    "own earlier output",
    "another command's folder",
]


def _hashes(*tops: Path) -> dict[str, str]:
    out = {}
    for top in tops:
        for dirpath, _, filenames in os.walk(top):
            for name in filenames:
                p = Path(dirpath) / name
                out[str(p)] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def _case_out(cmd: Cmd, case: str, w: World, t: Path) -> tuple[Path | str, Path | None]:
    """Return (the --out to give, the folder to run in) for ``case``; skip what cannot apply."""
    inp = getattr(w, cmd.input) if cmd.input else None
    if case in ("the input", "parent of the input", "inside the input") and inp is None:
        pytest.skip(f"{cmd.name} reads no input")
    if case == "user file":
        if cmd.kind == "file":
            p = t / cmd.out_name
            p.write_text("my own file\n")
            return p, None
        (t / "thesis").mkdir()
        (t / "thesis" / "chapter1.tex").write_text("\\chapter{One}\n")
        return t / "thesis", None
    if case == "working folder":
        work = t / "work"
        work.mkdir()
        (work / "notes.txt").write_text("mine\n")
        return ".", work
    if case == "the input":
        return inp, None
    if case == "parent of the input":
        return inp.parent, None
    if case == "inside the input":
        return inp / ("sub" if cmd.kind == "folder" else "obj01_cup/wide.png"), None
    if case == "another command's folder":
        other = t / ("other" if cmd.kind == "folder" else cmd.out_name)
        other.mkdir()
        (other / "results.json").write_text("{}\n")
        write_manifest(other, "some other command", ["results.json"])
        return other, None
    raise AssertionError(case)


def _expected(cmd: Cmd, case: str) -> str:
    if cmd.kind == "file":
        return {
            "user file": "exists; use --force",
            "working folder": "is a folder|current working folder",  # '.' has no file suffix
            "the input": "is an input|is a folder",
            "inside the input": "inside the input|exists; use --force",
        }.get(case, "is a folder")
    return {
        "user file": "did not write: chapter1.tex",
        "working folder": "current working folder",
        "the input": "is the input",
        "parent of the input": "holds the input",
        "inside the input": "inside the input",
        "another command's folder": "was written by 'confocal some other command'",
    }[case]


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("cmd", CMDS, ids=[c.name for c in CMDS])
def test_writing_command_never_touches_what_it_did_not_write(
    cmd: Cmd, case: str, world: World, tmp_path, monkeypatch, capsys
):
    monkeypatch.setenv("COLUMNS", "250")
    _tiny_demo(monkeypatch)
    t = tmp_path
    monkeypatch.chdir(t)
    if case == "own earlier output":
        if cmd.cannot_run:
            pytest.skip(cmd.cannot_run)
        out = t / (cmd.out_name if cmd.kind == "file" else "out")
        assert run_cli(cmd.argv(world, out)) == 0, capsys.readouterr().err
        if cmd.kind == "folder":
            assert read_manifest(out)["command"] == cmd.name.split(" .")[0].replace(
                "refocus --stack", "refocus"
            )
        (t / "keep.txt").write_text("beside the output\n")
        before = _hashes(world.root, t)
        code = run_cli([*cmd.argv(world, out), *cmd.again])
        err = capsys.readouterr().err
        assert code == 0, err
        after = _hashes(world.root, t)
        gone = [k for k in before if k not in after and not k.startswith(str(out))]
        changed = [
            k for k in before if k in after and before[k] != after[k] and not k.startswith(str(out))
        ]
        assert not gone and not changed, (gone, changed)
        assert not [p for p in t.iterdir() if ".tmp-" in p.name or ".old-" in p.name]
        return
    out, cwd = _case_out(cmd, case, world, t)
    if cwd is not None:
        monkeypatch.chdir(cwd)
    capsys.readouterr()
    before = _hashes(world.root, t)
    # --force never opens a refused folder; for a file it would replace it, so only with inputs
    forced = cmd.again and (cmd.kind == "folder" or case == "the input")
    code = run_cli([*cmd.argv(world, out), *cmd.again] if forced else cmd.argv(world, out))
    err = capsys.readouterr().err
    assert code == 2, f"exit {code}; stderr: {err}"
    assert "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("confocal: error:"), err
    assert any(x in lines[0] for x in _expected(cmd, case).split("|")), lines[0]
    assert _hashes(world.root, t) == before


def test_without_force_an_own_output_is_refused_where_the_command_needs_it(
    world, tmp_path, monkeypatch, capsys
):
    monkeypatch.chdir(tmp_path)
    assert run_cli([*SYNTH.split(), "--out", tmp_path / "p"]) == 0
    before = _hashes(tmp_path)
    capsys.readouterr()
    assert run_cli([*SYNTH.split(), "--out", tmp_path / "p"]) == 2
    assert "use --force to replace it" in capsys.readouterr().err
    assert _hashes(tmp_path) == before


def test_table_covers_every_out_and_screenshot_option():
    """A new command with --out/--screenshot cannot skip the contract (walks the click tree)."""
    listed = {(s.command, s.out) for s in WRITING_COMMANDS}
    found = set()

    def walk(cmd, path):
        if hasattr(cmd, "commands"):
            for name, sub in cmd.commands.items():
                walk(sub, f"{path} {name}")
            return
        for p in cmd.params:
            if {"--out", "--screenshot", "--shots"} & set(getattr(p, "opts", ())):
                found.add((path, p.name))

    for name in cli.SUBCOMMANDS:
        walk(cli.load_subcommand(name), name)
    assert found, "no writing command found: the walk is broken"
    assert found <= listed, f"not in experiment.outputs.WRITING_COMMANDS: {found - listed}"
    tested = {c.name.split(" --")[0].split(" .")[0] for c in CMDS}
    assert {s.command for s in WRITING_COMMANDS} <= tested


def test_refused_build_leaves_the_earlier_set_in_place(world, tmp_path, monkeypatch, capsys):
    """A different set without --force is refused and the earlier set is renamed back."""
    monkeypatch.chdir(tmp_path)
    build = ["stimuli", "build", world.pairs, "--out", tmp_path / "s"]
    assert run_cli([*build, "--working-size", "64x48"]) == 0
    before = _hashes(tmp_path)
    capsys.readouterr()
    assert run_cli([*build, "--working-size", "64x42"]) == 2
    assert "different stimulus set" in capsys.readouterr().err
    assert _hashes(tmp_path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s"]
    assert run_cli([*build, "--working-size", "64x42", "--force"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s"]


def test_tune_updates_its_sheet_in_the_pairs_folder_and_keeps_synth_able_to_replace_it(
    world, tmp_path, monkeypatch
):
    """tune edits its input folder by design; its files join the folder's manifest."""
    monkeypatch.chdir(tmp_path)
    pairs = tmp_path / "pairs"
    shutil.copytree(world.pairs, pairs)
    tune = ["stimuli", "tune", pairs, "--working-size", "64x48"]
    assert run_cli(tune) == 0
    assert run_cli(tune) == 0  # its own default sheet: no --force needed
    assert "tune_sheet.png" in read_manifest(pairs)["files"]
    assert run_cli([*SYNTH.split(), "--out", pairs, "--force"]) == 0


# -- the rule itself -----------------------------------------------------------------------------


def _own(folder: Path, command: str = "analyze run") -> Path:
    folder.mkdir(parents=True)
    (folder / "report.md").write_text("x")
    write_manifest(folder, command, ["report.md"])
    return folder


def _with(path: Path, name: str) -> Path:
    """``path`` as a file (``name`` empty) or a folder holding the file ``name``."""
    if not name:
        path.write_text("x")
        return path
    path.mkdir(exist_ok=True)
    (path / name).write_text("x")
    return path


@pytest.mark.parametrize(
    ("make", "kwargs", "match"),
    [
        (lambda t: t, {}, "is the current working folder"),
        (lambda t: t.parent, {}, "holds the current working folder"),
        (lambda t: t / "in", {"inputs": ["in"]}, "is the input in"),
        (lambda t: t / "in" / "x", {"inputs": ["in"]}, "is inside the input in"),
        (lambda t: t / "a", {"inputs": ["a/b/log.sqlite"]}, "holds the input a/b/log.sqlite"),
        (lambda t: _with(t / "f", ""), {}, "is a file, not a folder"),
        (
            lambda t: _with(t / "d", ".hidden"),
            {},
            r"holds files confocal did not write: \.hidden; choose a new or empty folder",
        ),
        (
            lambda t: _own(t / "o", "stimuli build"),
            {},
            "was written by 'confocal stimuli build', not 'confocal analyze run'",
        ),
        (lambda t: _with(_own(t / "o"), "mine.txt"), {}, "did not write: mine.txt"),
        (lambda t: _own(t / "o"), {"needs_force": True}, "use `force=True` to replace it"),
    ],
    ids=[
        "cwd",
        "holds cwd",
        "input",
        "inside input",
        "holds input",
        "a file",
        "hidden file",
        "other command",
        "own plus a user file",
        "own without force",
    ],
)
def test_check_folder_refuses(make, kwargs, match, tmp_path, monkeypatch):
    work = tmp_path / "w"
    work.mkdir()
    monkeypatch.chdir(work)
    out = make(work)
    with pytest.raises(OutputFolderError, match=match):
        check_folder(out, command="analyze run", **kwargs)


def test_check_folder_accepts_new_empty_and_own(tmp_path):
    assert check_folder(tmp_path / "new", command="c", cwd=tmp_path) == "new"
    (tmp_path / "empty").mkdir()
    assert check_folder(tmp_path / "empty", command="c", cwd=tmp_path) == "empty"
    own = _own(tmp_path / "own", "c")
    assert check_folder(own, command="c", cwd=tmp_path) == "own"
    assert check_folder(own, command="c", cwd=tmp_path, needs_force=True, force=True) == "own"


def test_check_folder_resolves_symlinks_and_dots(tmp_path):
    (tmp_path / "data").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "data")
    with pytest.raises(OutputFolderError, match="is the input"):
        check_folder(f"{tmp_path}/link/.", command="c", inputs=[tmp_path / "data"], cwd="/")
    with pytest.raises(OutputFolderError, match="is inside the input"):
        check_folder(tmp_path / "link" / "x", command="c", inputs=[tmp_path / "data"], cwd="/")
    with pytest.raises(OutputFolderError, match="is a symbolic link"):  # the link itself
        check_folder(tmp_path / "link", command="c", cwd="/")
    with pytest.raises(OutputFolderError, match="holds the input"):
        check_folder(tmp_path / "data" / "..", command="c", inputs=[tmp_path / "data"], cwd="/")


def test_check_file_refuses(tmp_path):
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "a.png").write_text("x")
    (tmp_path / "b.png").write_text("x")
    with pytest.raises(OutputFolderError, match="is a folder; expected a file path"):
        check_file(tmp_path / "in")
    with pytest.raises(OutputFolderError, match="is an input of this command"):
        check_file(tmp_path / "b.png", inputs=[tmp_path / "b.png"], force=True)
    with pytest.raises(OutputFolderError, match="is inside the input"):
        check_file(tmp_path / "in" / "new.png", inputs=[tmp_path / "in"], force=True)
    with pytest.raises(OutputFolderError, match="exists; use `force=True` to replace it"):
        check_file(tmp_path / "b.png")
    assert check_file(tmp_path / "b.png", force=True) is True
    assert check_file(tmp_path / "c.png") is False


# -- stale leftovers of killed runs --------------------------------------------------------------


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_leftover_aside_folder_is_restored_not_deleted(tmp_path, monkeypatch, capsys):
    """A run killed after moving its own folder aside: the next run puts the folder back."""
    monkeypatch.chdir(tmp_path)
    aside = _own(tmp_path / ".rep.old-1234")
    (aside / STAGING_MARKER).write_text(json.dumps({"pid": _dead_pid()}))
    done = clean_leftovers(tmp_path / "rep")
    assert done and "restored" in done[0]
    assert (tmp_path / "rep" / "report.md").read_text() == "x"
    assert not (tmp_path / "rep" / STAGING_MARKER).exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_leftover_aside_folder_of_a_running_process_is_left_alone(tmp_path):
    aside = _own(tmp_path / ".rep.old-1234")
    (aside / STAGING_MARKER).write_text(json.dumps({"pid": os.getpid()}))
    assert clean_leftovers(tmp_path / "rep") == []
    assert aside.is_dir()


def test_leftover_staging_folder_is_deleted_only_with_a_dead_marker(tmp_path):
    dead = tmp_path / ".rep.tmp-aaaa"
    dead.mkdir()
    (dead / "half.png").write_text("x")
    (dead / STAGING_MARKER).write_text(json.dumps({"pid": _dead_pid()}))
    alive = tmp_path / ".rep.tmp-bbbb"
    alive.mkdir()
    (alive / STAGING_MARKER).write_text(json.dumps({"pid": os.getpid()}))
    unmarked = tmp_path / ".rep.tmp-cccc"
    unmarked.mkdir()
    (unmarked / "mine.txt").write_text("x")
    clean_leftovers(tmp_path / "rep")
    assert not dead.exists()
    assert alive.is_dir() and (unmarked / "mine.txt").is_file()


def test_next_run_of_a_command_restores_a_killed_runs_output(world, tmp_path, monkeypatch):
    """End to end: `analyze fit` finds its earlier report aside, restores it, then replaces it."""
    monkeypatch.chdir(tmp_path)
    fit = ["analyze", "fit", world.table, "--x", "level", "--y", "correct", "--no-plots"]
    assert run_cli([*fit, "--out", tmp_path / "rep"]) == 0
    aside = tmp_path / ".rep.old-dead"
    os.replace(tmp_path / "rep", aside)
    (aside / STAGING_MARKER).write_text(json.dumps({"pid": _dead_pid()}))
    assert run_cli([*fit, "--out", tmp_path / "rep"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]
    assert read_manifest(tmp_path / "rep")["command"] == "analyze fit"


def test_manifest_names_the_command_and_its_files_only(world, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "ds"
    assert run_cli(["session", "export", world.db, "--out", out]) == 0
    m = json.loads((out / MANIFEST_NAME).read_text())
    assert set(m) == {"command", "files"} and m["command"] == "session export"
    assert "participants.tsv" in m["files"] and not any(str(tmp_path) in f for f in m["files"])
