"""Generated cases of the output contract, shared by ``tests/test_output_contract.py`` and
``benchmarks/bench_output_contract.py``.

A case is a random layout of folders, files and symbolic links (to folders, to files, to the
inputs, to a parent, dangling, loops) under a root ``T`` with the working folder ``T/work``; an
output path typed in one of many shapes (``..`` after a link, through a link, a link itself,
relative or absolute, a trailing slash); inputs typed the same ways; ``--force`` or not. Each run
hashes every file, folder and link under the roots before and after, and :func:`harms` names
anything that changed, vanished or appeared outside the command's own output (where the kernel
puts it, found by :func:`kernel_path`, a resolver written here independently of the project's).

The project's commands can run on a case (:func:`run_real`), or a stub command with the same
options and the same library writer as each real command (:func:`stub_command`), wrapped by the
same guard: fast enough for thousands of cases.
"""

from __future__ import annotations

import hashlib
import os
import random
import zlib
from dataclasses import dataclass, field
from pathlib import Path

from experiment.outputs import MANIFEST_NAME, WRITING_COMMANDS, WritingCommand, write_manifest

#: Output path shapes; ``{n}`` is a name from :data:`FOLDER_NAMES` or :data:`FILE_NAMES`.
FORMS = (
    "{n}",
    "../data/{n}",
    "link/../{n}",
    "link/{n}",
    "plink/data/{n}",
    "inlink/../{n}",
    "inlink/{n}",
    "loop1/{n}",
    "link/../../data/{n}",
    "selflink/{n}",
    "{n}/",
    "link/../{n}/",
    "dlink/{n}",
    "flink/{n}",
    "../data/file.txt/{n}",
)
#: Output paths that are a link, a loop, or a folder the contract refuses, whatever the name.
WHOLE = (
    "link",
    "dangling",
    "dlink",
    "flink",
    "inlink",
    "ownlink",
    "selflink",
    "loop1",
    ".",
    "..",
    "plink",
    "link/..",
    "link/../own",
    "link/",
    "inlink/..",
)
FOLDER_NAMES = ("thesis", "empty", "own", "other", "file.txt", "input", "in.npz", "new1", "deep")
FILE_NAMES = ("shot.png", "file.txt", "new.png", "in.npz", "input", "empty", "own")
#: Input path shapes (folder inputs; a file input uses ``in.npz`` the same ways).
INPUT_FORMS = ("../data/{i}", "inlink", "link/../{i}", "plink/data/{i}")


@dataclass
class Case:
    """One generated case: the command, its output and inputs as typed, and its options."""

    command: str
    spec: WritingCommand
    out: str
    kind: str  # 'folder' or 'file'
    inputs: dict[str, str] = field(default_factory=dict)
    force: bool = False
    fail: bool = False  # the (stub) command fails after writing part of its output
    links: tuple[str, ...] = ()
    extra: tuple[str, ...] = ()  # more options (``--stack``)

    def label(self) -> str:
        """One line describing the case."""
        opts = " ".join(f"--{k} {v}" for k, v in self.inputs.items())
        return (
            f"{self.command} --{self.spec.out} {self.out} {opts} {' '.join(self.extra)}"
            f"{' --force' if self.force else ''}{' [fails]' if self.fail else ''}"
            f" links={','.join(self.links)}"
        )


def commands() -> dict[str, list[WritingCommand]]:
    """The writing commands, each with its rows of :data:`WRITING_COMMANDS`."""
    out: dict[str, list[WritingCommand]] = {}
    for s in WRITING_COMMANDS:
        out.setdefault(s.command, []).append(s)
    return out


LINKS = {
    "link": "../data/deep",
    "plink": "..",
    "flink": "../data/file.txt",
    "dangling": "../data/nothing.png",
    "dlink": "../data/newdir",
    "loop1": "loop2",
    "loop2": "loop1",
    "inlink": "../data/input",
    "ownlink": "../data/own",
    "selflink": ".",
}


def make_layout(root: Path, rng: random.Random, manifest_command: str) -> tuple[str, ...]:
    """Write the folders, files and links of one case under ``root``; return the links made.

    ``data/own`` is an earlier output of ``manifest_command`` (its manifest lists its files).
    """
    data, work = root / "data", root / "work"
    for d in ("deep", "thesis", "empty", "own", "other", "input"):
        (data / d).mkdir(parents=True, exist_ok=True)
    work.mkdir(exist_ok=True)
    (data / "deep" / "d.txt").write_text("deep\n")
    (data / "thesis" / "chapter1.tex").write_text("\\chapter{One}\n")
    (data / "file.txt").write_text("a user's file\n")
    (data / "shot.png").write_bytes(b"\x89PNG user\n")
    (data / "in.npz").write_bytes(b"an input file\n")
    (data / "input" / "a.png").write_bytes(b"an input image\n")
    (data / "own" / "r.txt").write_text("earlier output\n")
    (data / "own" / "sub").mkdir()
    (data / "own" / "sub" / "s.txt").write_text("earlier output\n")
    write_manifest(data / "own", manifest_command, ["r.txt", "sub/s.txt"])
    (data / "other" / "x.txt").write_text("another command's\n")
    write_manifest(data / "other", "some other command", ["x.txt"])
    (work / "keep.txt").write_text("the user's notes\n")
    (work / "own").mkdir()  # an own output in the working folder too
    (work / "own" / "r.txt").write_text("earlier output\n")
    write_manifest(work / "own", manifest_command, ["r.txt"])
    names = [n for n in LINKS if n not in ("loop2",)]
    chosen = [n for n in names if n == "link" or rng.random() < 0.8]
    if "loop1" in chosen:
        chosen.append("loop2")
    for n in chosen:
        os.symlink(LINKS[n], work / n)
    # a staging leftover that is a link (never followed): beside the own output
    if rng.random() < 0.3:
        os.symlink("../thesis", data / ".own.old-1-dead")
    return tuple(chosen)


def generate(rng: random.Random, command: str | None = None) -> Case:
    """Draw one case (for ``command``, or any writing command)."""
    table = commands()
    name = command or rng.choice(sorted(table))
    specs = table[name]
    spec = rng.choice(specs)
    extra: tuple[str, ...] = ()
    if spec.command == "lightfield refocus":
        kind = rng.choice(("file", "folder"))
        extra = ("--stack",) if kind == "folder" else ()
    elif spec.command == "lightfield synth":
        kind = rng.choice(("file", "folder"))
    else:
        kind = spec.kind if isinstance(spec.kind, str) else "folder"
    if rng.random() < 0.3:
        out = rng.choice(WHOLE)
    else:
        names = FOLDER_NAMES if kind == "folder" else FILE_NAMES
        out = rng.choice(FORMS).format(n=rng.choice(names))
    if spec.command == "lightfield synth":
        # the output's suffix decides its kind: .npz a file, none a folder
        out = out.rstrip("/") + ".npz" if kind == "file" and not out.endswith(".npz") else out
    if rng.random() < 0.3 and out not in (".", ".."):
        out = "{work}/" + out
    inputs = {}
    for p in spec.inputs:
        if p in ("script", "protocol"):
            continue
        i = "in.npz" if p in ("lightfield", "stimulus", "trials", "table") else "input"
        if p in ("pairs", "data"):
            i = "input"
        form = rng.choice(INPUT_FORMS)
        inputs[p] = form.format(i=i) if i == "input" or "{i}" in form else f"../data/{i}"
    return Case(
        command=name,
        spec=spec,
        out=out,
        kind=kind,
        inputs=inputs,
        force=rng.random() < 0.5,
        fail=rng.random() < 0.25,
        extra=extra,
    )


def kernel_path(path: str, cwd: Path) -> Path | None:
    """Where the kernel's lookup of ``path`` from ``cwd`` leads: each component in turn, a link
    replaced by its target where it is met, ``..`` taken on the folder reached so far. None for
    a loop or a ``..`` after a missing folder. (Written here on purpose, not with
    ``os.path.realpath``: an independent oracle.)"""
    cur = Path("/") if path.startswith("/") else cwd
    todo = [p for p in path.split("/") if p]
    hops = 0
    while todo:
        name = todo.pop(0)
        if name == ".":
            continue
        if name == "..":
            if not os.path.isdir(cur):
                return None  # the kernel takes '..' only from a folder that is there
            cur = cur.parent
            continue
        nxt = cur / name
        if os.path.islink(nxt):
            hops += 1
            if hops > 40:
                return None
            target = os.readlink(nxt)
            if target.startswith("/"):
                cur = Path("/")
            todo = [p for p in target.split("/") if p] + todo
            continue
        cur = nxt
    return cur


def snapshot(*tops: Path) -> dict[str, tuple]:
    """Every folder, file (its SHA-256) and link (its target) under ``tops``; links not followed."""
    out: dict[str, tuple] = {}
    for top in tops:
        for dirpath, dirnames, filenames in os.walk(top):
            for n in dirnames + filenames:
                p = os.path.join(dirpath, n)
                if os.path.islink(p):
                    out[p] = ("link", os.readlink(p))
                elif os.path.isdir(p):
                    out[p] = ("dir",)
                else:
                    with open(p, "rb") as f:
                        out[p] = ("file", hashlib.sha256(f.read()).hexdigest())
    return out


def _inside(p: str, region: str) -> bool:
    return p == region or p.startswith(region.rstrip("/") + "/")


def harms(
    before: dict[str, tuple],
    after: dict[str, tuple],
    region: Path | None,
    succeeded: bool,
    own_files: set[str],
    extra_allowed: tuple[str, ...] = (),
) -> list[str]:
    """Name every change the contract forbids.

    Parameters
    ----------
    before, after : dict
        :func:`snapshot` before and after the run.
    region : Path or None
        Where the kernel puts the output (None: a loop).
    succeeded : bool
        The command ended with status 0: its output may have replaced its own earlier files.
    own_files : set of str
        Paths of the files the earlier output's manifest lists (replaceable on success).
    extra_allowed : tuple of str
        Paths that may change (the manifest of a folder updated in place, a leftover link).
    """
    found = []
    reg = os.fspath(region) if region is not None else None
    for p, v in before.items():
        if succeeded and reg is not None and _inside(p, reg):
            if p in own_files or os.path.basename(p) == MANIFEST_NAME or v == ("dir",):
                continue
            if p == reg:  # the output file itself (replaced with --force)
                continue
        if p in extra_allowed:
            continue
        if p not in after:
            found.append(f"vanished: {p}")
        elif after[p] != v:
            found.append(f"changed: {p}")
    for p in after:
        if p in before:
            continue
        if succeeded and reg is not None and (_inside(p, reg) or _inside(reg, p)):
            continue  # the output, or a parent folder made for it
        found.append(f"appeared: {p}")
    return found


def region_and_own(case: Case, root: Path) -> tuple[Path | None, set[str]]:
    """Where the kernel puts the case's output, and the files of an earlier output there."""
    typed = case.out.format(work=root / "work")
    region = kernel_path(typed, root / "work")
    own: set[str] = set()
    if region is not None and (region / MANIFEST_NAME).is_file():
        import json

        files = json.loads((region / MANIFEST_NAME).read_text()).get("files", [])
        own = {os.fspath(region / f) for f in files}
    return region, own


# -- running a case --------------------------------------------------------------------------------

#: What the stub commands did in the last run: ``ran`` (the body started), ``fail`` (fail midway).
STUB = {"ran": False, "fail": False}


def _stub_write(spec: WritingCommand, kind: str, path: Path, fail: bool) -> None:
    from analysis.report import atomic_folder
    from experiment.output_guard import DIRECT_WRITERS
    from experiment.outputs import require_missing_or_empty
    from stimuli.errors import InputError
    from stimuli.io import atomic_path, staged_folder

    def half(folder: Path) -> None:
        (folder / "a.txt").write_text("new output\n")
        (folder / "sub").mkdir(exist_ok=True)
        (folder / "sub" / "b.txt").write_text("new output\n")
        if fail:
            raise InputError(f"{path}: stub failure")

    if kind == "file":
        with atomic_path(path) as tmp:
            tmp.write_bytes(b"new output\n")
            if fail:
                raise InputError(f"{path}: stub failure")
    elif spec.mode == "update-in-place":
        with staged_folder(path, merge=True) as tmp:
            half(tmp)
    elif spec.command in DIRECT_WRITERS:
        require_missing_or_empty(path)
        path.mkdir(parents=True, exist_ok=True)
        half(path)
    elif spec.command.startswith("analyze"):
        with atomic_folder(path) as tmp:
            half(tmp)
    else:
        with staged_folder(path) as tmp:
            half(tmp)


_STUBS: dict[str, object] = {}


def stub_command(command: str):
    """A click command with the options of ``command``'s rows and a body that writes its output
    the way the real command does (the same library writer), wrapped by the same guard."""
    if command in _STUBS:
        return _STUBS[command]
    import click

    from experiment.output_guard import guard_command

    specs = commands()[command]
    params, seen = [], set()

    def add(name: str, **kw) -> None:
        if name not in seen:
            seen.add(name)
            params.append(click.Option([f"--{name}"], **kw))

    for s in specs:
        for name in (s.out, *s.inputs):
            add(name, default="confocal-demo" if command == "demo" and name == "out" else None)
        if s.force and not s.add_force:
            add("force", is_flag=True)
        if s.passes_aside:
            add(s.passes_aside, default=None, hidden=True)
    if command == "lightfield refocus":
        add("stack", is_flag=True)

    def body(**kwargs) -> None:
        STUB["ran"] = True
        for s in specs:
            if kwargs.get(s.out) is None and s.default_out is None:
                continue
            path = s.path_of(kwargs)
            if path is not None:
                _stub_write(s, s.kind_of(kwargs), Path(path), STUB["fail"])

    cmd = click.Command(command.replace(" ", "-"), params=params, callback=body)
    guard_command(cmd, command)
    _STUBS[command] = cmd
    return cmd


def typed_out(case: Case, root: Path) -> str:
    """The output path as the case types it."""
    return case.out.format(work=root / "work")


def run_stub(case: Case, root: Path) -> tuple[int, str, bool]:
    """Run the stub of ``case.command`` in ``root/work``; return (status, message, body ran)."""
    cmd = stub_command(case.command)
    argv = [f"--{case.spec.out}", typed_out(case, root)]
    for k, v in case.inputs.items():
        argv += [f"--{k}", v]
    argv += list(case.extra)
    if case.force and case.spec.force:
        argv.append("--force")
    STUB.update(ran=False, fail=case.fail)
    here = os.getcwd()
    os.chdir(root / "work")
    try:
        cmd.main(argv, standalone_mode=False, prog_name="confocal")
        return 0, "", STUB["ran"]
    except Exception as exc:  # noqa: BLE001 - classified as the root command does
        if getattr(exc, "exit_code", None) == 2:
            return 2, "confocal: error: " + " ".join(str(exc).split()), STUB["ran"]
        raise
    finally:
        os.chdir(here)


@dataclass
class Outcome:
    """What one case did and what was wrong with it."""

    case: Case
    code: int
    message: str
    problems: list[str]


def check_case(case: Case, root: Path, run, *extra_roots: Path) -> Outcome:
    """Lay out ``case`` under ``root`` (made by the caller, empty), run it with ``run(case,
    root) -> (status, message, body ran)`` and return what the contract says of the outcome."""
    rng = random.Random(zlib.crc32(case.label().encode()))
    name_of = case.spec.name_of({"out": "x"})
    case.links = make_layout(root, rng, name_of)
    region, own = region_and_own(case, root)
    before = snapshot(root, *extra_roots)
    code, message, ran = run(case, root)
    after = snapshot(root, *extra_roots)
    extra = ()
    if region is not None and case.spec.mode == "update-in-place":
        extra = (os.fspath(region.parent / MANIFEST_NAME),)
    if region is not None:  # a staging leftover that is a link is removed (never followed)
        leftovers = (f".{region.name}.old-", f".{region.name}.tmp-")
        gone = [p for p in before if os.path.basename(p).startswith(leftovers)]
        extra += tuple(p for p in gone if before[p][0] == "link" and p not in after)
    problems = harms(before, after, region, code == 0, own, extra)
    typed = typed_out(case, root).rstrip("/") or "/"
    failed_itself = "stub failure" in message
    if code not in (0, 2):
        problems.append(f"exit status {code}")
    if code == 2 and not failed_itself:
        if "\n" in message.strip() or "Traceback" in message:
            problems.append(f"not one line: {message!r}")
        if typed not in message and os.path.normpath(typed) not in message:
            problems.append(f"the message does not name the path typed: {message!r}")
        if ran and "appeared while" not in message:
            problems.append(f"refused after the work started: {message!r}")
    said = message.replace(".own.old-1-dead", "")  # a user-visible leftover the layout plants
    if ".tmp-" in said or ".old-" in said:
        problems.append(f"a staging name in the message: {message!r}")
    link_at_out = os.path.islink(os.path.join(root / "work", typed))
    if code == 0 and link_at_out:
        problems.append("wrote through a link at the output")
    if code == 0 and region is None:
        problems.append("accepted a loop of links or '..' after a missing folder")
    left = [p for p in after if ".tmp-" in os.path.basename(p) and p not in before]
    if left:
        problems.append(f"staging left: {left}")
    return Outcome(case, code, message, problems)


# -- the real commands --------------------------------------------------------------------------

SYNTH = "stimuli synth --objects 1 --training 0 --size 64x48"

#: Each command at its cheapest; ``{out}`` and the inputs (``{db}``, ``{lf}``, ...) filled in.
REAL = {
    ("analyze run", "folder"): "analyze {db} --out {out} --no-figures --seed 1",
    ("analyze fit", "folder"): "analyze fit {table} --x level --y correct --out {out} --no-plots",
    ("stimuli build", "folder"): "stimuli build {pairs} --out {out} --working-size 64x48",
    ("stimuli synth", "folder"): SYNTH + " --out {out}",
    ("stimuli tune", "file"): "stimuli tune {pairs} --sheet {out} --working-size 64x48 --dry-run",
    ("lightfield scan", "folder"): "lightfield scan {lf} --out {out} --planes 4",
    ("lightfield refocus", "folder"): "lightfield refocus {lf} --stack --planes 3 --out {out}",
    ("lightfield refocus", "file"): "lightfield refocus {lf} --disparity 0 --out {out}",
    ("lightfield synth", "folder"): "lightfield synth --size 40x32 --out {out}",
    ("lightfield synth", "file"): "lightfield synth --size 40x32 --out {out}",
    ("session export", "folder"): "session export {db} --out {out}",
    ("demo", "folder"): "demo --out {out}",
    ("view", "file"): "view {lf} --cpu --planes 4 --screenshot {out}",
    ("present", "file"): "present --stimulus {stim_png} --screenshot {out}",
}


def _tiny_run_demo(out_dir, **_):
    """The whole demo study takes ~25 s: a stand-in that writes straight into --out like it."""
    from experiment.outputs import require_missing_or_empty

    out = Path(out_dir)
    require_missing_or_empty(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "report.md").write_text("# demo\n")


def tiny_demo(setattr_=setattr) -> None:
    """Put the stand-in demo in place (``setattr_``: pytest's ``monkeypatch.setattr`` in tests)."""
    import experiment.demos.study as study

    setattr_(study, "run_demo", _tiny_run_demo)
    setattr_(study, "summary_lines", lambda result: ["demo written"])


def real_argv(case: Case, root: Path, world: dict) -> list[str]:
    """The real command line of ``case``."""
    line = REAL[(case.command, case.kind)]
    argv = [w.format(out=typed_out(case, root), **world) for w in line.split()]
    spec_force = case.spec.force is not None
    return [*argv, "--force"] if case.force and spec_force else argv


def make_world(root: Path) -> dict[str, Path]:
    """Write the inputs of every real command under ``root``; return them by name."""
    from tests.conftest import make_study_inputs

    inputs = make_study_inputs(root, *SYNTH.split()[2:])
    table = root / "table.csv"
    rows = ["level,correct"] + [
        f"{lv},{int((i * 7 + lv) % 6 < lv)}" for lv in range(1, 6) for i in range(8)
    ]
    table.write_text("\n".join(rows) + "\n")
    fields = dict(vars(inputs), table=table, stim_png=inputs.pairs / "obj01_cup" / "wide.png")
    return {k: v for k, v in fields.items() if isinstance(v, Path)}


def real_cases(command: str, kind: str, n: int, seed: int = 0) -> list[Case]:
    """``n`` generated cases of a real command; the first writes a new name beside a link's
    target (``link/../new``), so the command runs."""
    rng = random.Random(f"{command} {kind} {seed}")
    cases: list[Case] = []
    while len(cases) < n:
        case = generate(rng, command)
        if case.kind != kind or case.spec.out == "shots":
            continue
        if not cases:
            new = "new.npz" if case.command == "lightfield synth" and kind == "file" else "new"
            case.out = f"link/../{new}.png" if kind == "file" and new == "new" else f"link/../{new}"
            case.force = False
        case.fail = False
        cases.append(case)
    return cases


def run_real(case: Case, root: Path, world: dict) -> tuple[int, str, bool]:
    """Run the real command of ``case`` in ``root/work``; return (status, error line, False)."""
    from contextlib import redirect_stderr
    from io import StringIO

    from tests.conftest import run_cli

    here = os.getcwd()
    os.chdir(root / "work")
    buf = StringIO()
    try:
        with redirect_stderr(buf):
            code = run_cli(real_argv(case, root, world))
    finally:
        os.chdir(here)
    lines = [ln for ln in buf.getvalue().splitlines() if ln.startswith("confocal: error:")]
    return code, "\n".join(lines), False


# -- two writers at once ---------------------------------------------------------------------------


def _race_child(argv: list[str], log: str, cwd: Path, setup, go) -> None:
    import sys

    fd = os.open(log, os.O_WRONLY | os.O_TRUNC)
    os.dup2(fd, 2)
    sys.stderr = open(2, "w", closefd=False)  # noqa: SIM115 - the child ends with os._exit
    os.chdir(cwd)
    if setup is not None:
        setup()
    from tests.conftest import run_cli

    try:
        go.wait(120)
    except Exception:  # noqa: BLE001 - a broken barrier: start anyway
        pass
    try:
        code = run_cli(argv)
    except BaseException:  # noqa: BLE001 - a traceback is a finding: status 99
        import traceback

        traceback.print_exc()
        code = 99
    sys.stderr.flush()
    os._exit(code)


def race(
    argvs: list[list[str]], cwd: Path, *, setup=None, start: str = "fork"
) -> list[tuple[int, str]]:
    """Start ``confocal ARGV`` for each of ``argvs`` at the same moment in child processes from
    ``cwd``; return each (status, stderr).

    ``start='fork'`` reuses the parent's imports (no start-up cost); ``'spawn'`` starts fresh
    interpreters (for commands that open a GL context, which a forked child cannot). ``setup``
    (a module-level function) runs in each child before the command (a stand-in demo, say).
    """
    import multiprocessing as mp
    import tempfile

    ctx = mp.get_context(start)
    go = ctx.Barrier(len(argvs))  # every child ready, then all start at once
    logs = [tempfile.NamedTemporaryFile(prefix="race-", suffix=".err", delete=False) for _ in argvs]
    procs = [
        ctx.Process(target=_race_child, args=(a, f.name, cwd, setup, go))
        for a, f in zip(argvs, logs, strict=True)
    ]
    for p in procs:
        p.start()
    out = []
    for p, f in zip(procs, logs, strict=True):
        p.join(300)
        if p.is_alive():
            p.kill()
            p.join()
        f.close()
        with open(f.name, encoding="utf-8", errors="replace") as fh:
            err = fh.read()
        os.unlink(f.name)
        out.append((p.exitcode if p.exitcode is not None else -1, err))
    return out


def output_complete(folder: Path) -> bool:
    """Whether ``folder`` holds a finished output: a manifest and every file it lists."""
    import json

    m = folder / MANIFEST_NAME
    if not m.is_file():
        return False
    files = json.loads(m.read_text()).get("files", [])
    return bool(files) and all((folder / f).exists() for f in files if not f.endswith("/"))


def judge_race(results: list[tuple[int, str]], out: Path, kind: str) -> list[str]:
    """Name what is wrong after two writers raced to ``out``: a finished output lost, a loser
    that did not refuse with one line and status 2, or a staging folder left."""
    problems = []
    won = [c for c, _ in results if c == 0]
    for code, err in results:
        if code == 0:
            continue
        lines = [ln for ln in err.splitlines() if ln.startswith("confocal: error:")]
        if code != 2 or len(lines) != 1 or "Traceback" in err:
            problems.append(f"the loser ended with status {code}: {err.strip()[-300:]!r}")
    if won:
        if kind == "folder" and not output_complete(out):
            problems.append(f"a finished output was lost: {out} is not complete")
        if kind == "file" and not out.is_file():
            problems.append(f"a finished output was lost: {out} is missing")
    left = [p.name for p in out.parent.iterdir() if ".tmp-" in p.name or ".old-" in p.name]
    if left:
        problems.append(f"left beside the output: {left}")
    return problems
