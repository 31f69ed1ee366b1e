"""Bad input, measured: every command, fed bad files, options and protocols.

Each row runs ``confocal ...`` in-process and asserts: exit status 2; one message on stderr that
names the file, field or option and what was expected (one ``confocal: error:`` line, or typer's
usage box for an option value); no traceback; and no new or changed file anywhere under the
study folder or the row's own folder (a snapshot of names, sizes, mtimes and hashes before and
after). The counts by command are printed at the end of the run of this file.
"""

from __future__ import annotations

import errno
import hashlib
import os
import re
import shutil
import sqlite3
import struct
import zlib
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from experiment import cli
from tests.conftest import StudyInputs, make_study_inputs, run_cli

HUGE = "1000000x1000000"  # 10^12 px: refused by the memory check on any machine


@dataclass(frozen=True)
class World(StudyInputs):
    csv: Path  # the Psych-DS export of the study's log
    png: Path  # one stimulus image


@pytest.fixture(scope="module")
def world(tmp_path_factory) -> World:
    root = tmp_path_factory.mktemp("study")
    inputs = make_study_inputs(root, "--objects", "2", "--training", "1", "--size", "120x80")
    assert run_cli(["session", "export", inputs.db, "--out", root / "dataset"]) == 0
    (csv_path,) = (root / "dataset" / "data").glob("*_data.csv")
    return World(**vars(inputs), csv=csv_path, png=next(inputs.stim.rglob("*.png")))


def snapshot(*folders: Path) -> dict[str, tuple]:
    """Every path under ``folders``: kind, size, mtime and content hash (files)."""
    out = {}
    for top in folders:
        for dirpath, dirnames, filenames in os.walk(top):
            for name in dirnames + filenames:
                p = Path(dirpath) / name
                st = p.lstat()
                digest = ""
                if p.is_file() and not p.is_symlink():
                    digest = hashlib.sha256(p.read_bytes()).hexdigest()
                out[str(p)] = (p.is_dir(), st.st_size, st.st_mtime_ns, digest)
    return out


# -- bad files ---------------------------------------------------------------------------------


def text_file(path: Path, text: str = "hello, not an image\n") -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def png_header(path: Path, cols: int, rows: int) -> Path:
    """A PNG whose header claims ``cols x rows`` px, with a tiny (truncated) body."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = struct.pack(">I", zlib.crc32(kind + data))
        return struct.pack(">I", len(data)) + kind + data + crc

    ihdr = struct.pack(">IIBBBBB", cols, rows, 8, 0, 0, 0, 0)
    body = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 64))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(body)
    return path


def pairs_with(t: Path, w: World, wide: Callable[[Path], Path] | None = None, name="pairs"):
    """A copy of the good pairs folder; ``wide`` replaces the first object's wide photo."""
    p = t / name
    shutil.copytree(w.pairs, p)
    if wide is not None:
        first = sorted(d for d in p.iterdir() if d.is_dir())[0]
        (first / "wide.png").unlink()
        wide(first / "wide.png")
    return p


def one_px(path: Path) -> Path:
    from PIL import Image

    Image.new("L", (1, 1), 128).save(path)
    return path


def truncated_png(src: Path) -> Callable[[Path], Path]:
    def make(path: Path) -> Path:
        data = src.read_bytes()
        path.write_bytes(data[: len(data) // 2])
        return path

    return make


def pairs_csv(t: Path, w: World, wide: str, name: str = "list.csv") -> Path:
    d = t / "csvpairs"
    d.mkdir(exist_ok=True)
    first = sorted(x for x in w.pairs.iterdir() if x.is_dir())[0]
    shutil.copy(first / "narrow.png", d / "narrow.png")
    return text_file(d / name, f"object,wide,narrow\nobj01,{wide},narrow.png\n")


#: An implant layout with a bad field (rows must be >= 1).
_BAD_GRID = (
    'label = "x"\nkind = "other"\nrows = 0\ncols = 3\nfov_width_deg = 5\nfov_height_deg = 5\n'
)


def protocol(t: Path, text: str) -> Path:
    return text_file(t / "p.toml", text)


def block(**fields) -> str:
    base = {
        "part": '"main"',
        "objects": '"main"',
        "levels": "[1, 2]",
        "conditions": '["cluttered", "decluttered"]',
    }
    base.update(fields)
    body = "".join(f"{k} = {v}\n" for k, v in base.items() if v is not None)
    return f'[protocol]\nname = "bad"\n\n[[blocks]]\n{body}'


def stim_copy(t: Path, w: World, *, outside: str | None = None, symlink: bool = False) -> Path:
    """A copy of the stimulus set; its first manifest path reaches outside the set."""
    s = t / "stim"
    shutil.copytree(w.stim, s)
    manifest = s / "manifest.csv"
    lines = manifest.read_text().splitlines()
    header = lines[0].split(",")
    row = lines[1].split(",")
    k = header.index("path")
    target = s / row[k]
    ext = t / "outside.png"
    shutil.copy(target, ext)
    if symlink:
        target.unlink()
        target.symlink_to(ext)
    else:
        row[k] = outside or "../outside.png"
        lines[1] = ",".join(row)
        manifest.write_text("\n".join(lines) + "\n")
    return s


def newer_schema(t: Path, w: World) -> Path:
    db = t / "newer.sqlite"
    shutil.copy(w.db, db)
    con = sqlite3.connect(db)
    con.execute("INSERT INTO schema_migrations VALUES (999, 'from the future', 'x')")
    con.commit()
    con.close()
    assert not Path(f"{db}-wal").exists()
    return db


def truncated_db(t: Path, w: World) -> Path:
    db = t / "cut.sqlite"
    data = w.db.read_bytes()
    db.write_bytes(data[:100] + b"\0" * 50)
    return db


def csv_table(t: Path, w: World, edit: Callable[[list[str], list[list[str]]], None]) -> Path:
    import csv

    with open(w.csv, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    edit(header, body)
    out = t / "edited.csv"
    with open(out, "w", newline="") as f:
        csv.writer(f).writerows([header, *body])
    return out


def drop_col(name: str):
    def edit(header, body):
        k = header.index(name)
        del header[k]
        for r in body:
            del r[k]

    return edit


def set_col(name: str, value: str):
    def edit(header, body):
        k = header.index(name)
        body[0][k] = value

    return edit


def under_a_file(t: Path, name: str) -> Path:
    """A path whose parent is a regular file: no one can write there, not even root."""
    return text_file(t / "plain.txt") / name


def readonly_dir(t: Path, *, mode_bits_checked: bool = False) -> Path:
    """A folder without write permission; ``mode_bits_checked``: the command checks the mode
    bits itself (the trial log does), so the row holds for root too."""
    if os.geteuid() == 0 and not mode_bits_checked:
        pytest.skip("running as root: a read-only folder does not stop root writing")
    d = t / "ro"
    d.mkdir()
    d.chmod(0o555)
    return d


# -- the table ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Row:
    command: str
    name: str
    argv: Callable[[World, Path], list]
    expect: tuple[str, ...]


def R(command: str, name: str, argv, *expect: str) -> Row:
    return Row(command, name, argv, expect)


def session(w: World, t: Path, *extra, proto=None, stim=None, data=None, subject="S09"):
    return [
        "session",
        "run",
        "--protocol",
        proto or w.proto,
        "--stimuli",
        stim or w.stim,
        "--subject",
        subject,
        "--data",
        data or t / "new.sqlite",
        "--headless",
        *extra,
    ]


def synth(w, t, *extra):
    return ["stimuli", "synth", "--out", t / "out", *extra]


def build(w, t, pairs, *extra):
    return ["stimuli", "build", pairs, "--out", t / "set", *extra]


def scan(w, t, *extra, lf=None):
    return ["lightfield", "scan", lf or w.lf, "--out", t / "scan", *extra]


def refocus(w, t, *extra, lf=None):
    return ["lightfield", "refocus", lf or w.lf, "--out", t / "img.png", *extra]


def present(w, t, *extra, stimulus=None):
    return ["present", "--stimulus", stimulus or w.png, "--screenshot", t / "shot.png", *extra]


def analyze(w, t, *files, extra=()):
    return ["analyze", *files, "--out", t / "report", "--no-figures", *extra]


# fmt: off
ROWS: list[Row] = [
    # stimuli synth
    R("stimuli synth", "huge size", lambda w, t: synth(w, t, "--size", HUGE), "--size", "memory"),
    R("stimuli synth", "negative seed", lambda w, t: synth(w, t, "--seed", "-1"), "--seed",
      "greater than or equal to 0|x>=0|0<=x"),
    R("stimuli synth", "negative objects", lambda w, t: synth(w, t, "--objects", "-3"),
      "--objects", "greater than or equal to 1|x>=1"),
    R("stimuli synth", "zero objects", lambda w, t: synth(w, t, "--objects", "0"), "--objects"),
    R("stimuli synth", "1x1 size", lambda w, t: synth(w, t, "--size", "1x1"), "shape_px", "32"),
    R("stimuli synth", "size not a size", lambda w, t: synth(w, t, "--size", "big"),
      "--size", "WIDTHxHEIGHT"),
    R("stimuli synth", "too many objects", lambda w, t: synth(w, t, "--objects", "100000"),
      "n_objects", "<="),
    R("stimuli synth", "out is an existing file",
      lambda w, t: ["stimuli", "synth", "--out", text_file(t / "f.txt")], "f.txt", "not a folder"),
    R("stimuli synth", "out under a file",
      lambda w, t: ["stimuli", "synth", "--out", under_a_file(t, "pairs"), "--objects", "1",
                    "--training", "0", "--size", "40x40"], "plain.txt"),
    # stimuli build
    R("stimuli build", "missing pairs", lambda w, t: build(w, t, t / "nope"), "nope", "not found"),
    R("stimuli build", "empty pairs folder",
      lambda w, t: build(w, t, (t / "empty").mkdir() or t / "empty"), "empty", "no object"),
    R("stimuli build", "wide photo is text",
      lambda w, t: build(w, t, pairs_with(t, w, text_file)), "wide.png", "not a readable image"),
    R("stimuli build", "wide photo empty",
      lambda w, t: build(w, t, pairs_with(t, w, lambda p: text_file(p, ""))), "wide.png",
      "not a readable image"),
    R("stimuli build", "wide photo truncated",
      lambda w, t: build(w, t, pairs_with(t, w, truncated_png(next(w.pairs.glob("*/wide.png"))))),
      "wide.png", "not a readable image"),
    R("stimuli build", "decompression bomb header",
      lambda w, t: build(w, t, pairs_with(t, w, lambda p: png_header(p, 100000, 100000))),
      "wide.png", "decompression bomb"),
    R("stimuli build", "bomb warning size, truncated body",
      lambda w, t: build(w, t, pairs_with(t, w, lambda p: png_header(p, 10000, 10000))),
      "wide.png"),
    R("stimuli build", "1x1 photos", lambda w, t: build(w, t, _one_px_pair(t, w)),
      "1x1 px", "at least 13x9"),
    R("stimuli build", "unicode and spaces in a path",
      lambda w, t: build(w, t, pairs_with(t, w, text_file, name="paires d'été ü")),
      "paires d'été ü", "wide.png"),
    R("stimuli build", "objects.csv missing column",
      lambda w, t: build(w, t, _objects_csv(t, w, "name,role\ncup,main\n")), "objects.csv",
      "object"),
    R("stimuli build", "objects.csv NaN threshold",
      lambda w, t: build(w, t, _objects_csv(t, w, "object,sobel_threshold\nobj01_cup,nan\n")),
      "objects.csv", "sobel_threshold"),
    R("stimuli build", "objects.csv string threshold",
      lambda w, t: build(w, t, _objects_csv(t, w, "object,sobel_threshold\nobj01_cup,high\n")),
      "objects.csv", "sobel_threshold"),
    R("stimuli build", "pairs csv names a missing photo",
      lambda w, t: build(w, t, pairs_csv(t, w, "gone.png")), "gone.png", "not found"),
    R("stimuli build", "pairs csv photo is a folder",
      lambda w, t: build(w, t, pairs_csv(t, w, ".")), "csvpairs"),
    R("stimuli build", "pairs csv missing column",
      lambda w, t: build(w, t, text_file(t / "l.csv", "object,wide\na,b.png\n")), "l.csv",
      "expected columns"),
    R("stimuli build", "huge working size",
      lambda w, t: build(w, t, w.pairs, "--working-size", HUGE), "--working-size", "memory"),
    R("stimuli build", "zero working size",
      lambda w, t: build(w, t, w.pairs, "--working-size", "0x0"), "--working-size"),
    R("stimuli build", "NaN threshold", lambda w, t: build(w, t, w.pairs, "--threshold", "nan"),
      "--threshold", "[0, 1]"),
    R("stimuli build", "negative threshold",
      lambda w, t: build(w, t, w.pairs, "--threshold", "-1"), "--threshold", "[0, 1]"),
    R("stimuli build", "edge ratio 2", lambda w, t: build(w, t, w.pairs, "--edge-ratio", "2"),
      "--edge-ratio", "[0, 1)"),
    R("stimuli build", "NaN edge ratio",
      lambda w, t: build(w, t, w.pairs, "--edge-ratio", "nan"), "--edge-ratio", "[0, 1)"),
    R("stimuli build", "unknown mode", lambda w, t: build(w, t, w.pairs, "--mode", "colour"),
      "mode", "edges"),
    R("stimuli build", "grey levels 1000",
      lambda w, t: build(w, t, w.pairs, "--grey-levels", "1000"), "--grey-levels", "256"),
    R("stimuli build", "unknown threshold method",
      lambda w, t: build(w, t, w.pairs, "--threshold-method", "magic"), "threshold_method"),
    R("stimuli build", "unknown implant",
      lambda w, t: build(w, t, w.pairs, "--implant", "argus9"), "argus9", "unknown implant"),
    R("stimuli build", "implant file missing",
      lambda w, t: build(w, t, w.pairs, "--implant", t / "mine.toml"), "mine.toml", "not found"),
    R("stimuli build", "implant file with a bad field",
      lambda w, t: build(w, t, w.pairs, "--implant", text_file(t / "grid.toml", _BAD_GRID)),
      "grid.toml", "'rows'"),
    R("stimuli build", "implant finer than the working size",
      lambda w, t: build(w, t, w.pairs, "--implant", "alpha_ims", "--working-size", "30x20"),
      "alpha_ims", "finer than"),
    R("stimuli build", "out is an existing file",
      lambda w, t: ["stimuli", "build", w.pairs, "--out", text_file(t / "set.txt")], "set.txt",
      "not a folder"),
    R("stimuli build", "out in a read-only folder",
      lambda w, t: ["stimuli", "build", w.pairs, "--out", readonly_dir(t) / "set"], "ro"),
    R("stimuli build", "out under a file",
      lambda w, t: ["stimuli", "build", w.pairs, "--out", under_a_file(t, "set")], "plain.txt"),
    # lightfield synth
    R("lightfield synth", "huge size",
      lambda w, t: ["lightfield", "synth", "--size", HUGE, "--out", t / "lf.npz"], "--size",
      "memory"),
    R("lightfield synth", "zero size",
      lambda w, t: ["lightfield", "synth", "--size", "0x5", "--out", t / "lf.npz"], "--grid"),
    R("lightfield synth", "unknown kind",
      lambda w, t: ["lightfield", "synth", "--kind", "mirror", "--out", t / "lf.npz"], "--kind"),
    R("lightfield synth", "png with camera kind",
      lambda w, t: ["lightfield", "synth", "--kind", "camera", "--out", t / "lf.png"],
      "--kind lens"),
    R("lightfield synth", "folder output is an existing file",
      lambda w, t: ["lightfield", "synth", "--size", "40x32", "--out", text_file(t / "views")],
      "views", "folder"),
    R("lightfield synth", "negative seed",
      lambda w, t: ["lightfield", "synth", "--seed", "-2", "--out", t / "lf.npz"], "--seed"),
    # lightfield scan
    R("lightfield scan", "missing light field", lambda w, t: scan(w, t, lf=t / "none.npz"),
      "none.npz"),
    R("lightfield scan", "truncated npz",
      lambda w, t: scan(w, t, lf=_truncated(w.lf, t / "cut.npz")), "cut.npz", "not a readable"),
    R("lightfield scan", "empty npz", lambda w, t: scan(w, t, lf=text_file(t / "e.npz", "")),
      "e.npz"),
    R("lightfield scan", "text as elemental image",
      lambda w, t: scan(w, t, lf=text_file(t / "lf.png")), "lf.png"),
    R("lightfield scan", "bad threshold", lambda w, t: scan(w, t, "--threshold", "lots"),
      "--threshold"),
    R("lightfield scan", "edge ratio 2", lambda w, t: scan(w, t, "--edge-ratio", "2"),
      "--edge-ratio", "< 1"),
    R("lightfield scan", "NaN edge ratio", lambda w, t: scan(w, t, "--edge-ratio", "nan"),
      "--edge-ratio", "finite"),
    R("lightfield scan", "huge plane count", lambda w, t: scan(w, t, "--planes", "10" * 7),
      "--planes", "memory"),
    R("lightfield scan", "two planes", lambda w, t: scan(w, t, "--planes", "2"), "--planes"),
    R("lightfield scan", "zero grid", lambda w, t: scan(w, t, "--grid", "0x0"), "--grid"),
    R("lightfield scan", "grid not a grid", lambda w, t: scan(w, t, "--grid", "big"), "--grid"),
    R("lightfield scan", "equal disparities", lambda w, t: scan(w, t, "--disparities", "1:1"),
      "--disparities"),
    R("lightfield scan", "near beyond far", lambda w, t: scan(w, t, "--near", "5", "--far", "1"),
      "--near"),
    R("lightfield scan", "zero binning", lambda w, t: scan(w, t, "--binning", "0"), "--binning"),
    R("lightfield scan", "out is an existing file",
      lambda w, t: ["lightfield", "scan", w.lf, "--out", text_file(t / "scan.txt")], "scan.txt"),
    R("lightfield scan", "bad view crop", lambda w, t: scan(w, t, "--view-crop", "1,2"),
      "--view-crop"),
    # lightfield refocus
    R("lightfield refocus", "bad grid", lambda w, t: refocus(w, t, "--disparity", "0",
                                                             "--grid", "axb"), "--grid"),
    R("lightfield refocus", "bad threshold with grid",
      lambda w, t: refocus(w, t, "--disparity", "0", "--grid", "38x25", "--threshold", "-3"),
      "--threshold"),
    R("lightfield refocus", "no plane", lambda w, t: refocus(w, t), "--depth", "--disparity"),
    R("lightfield refocus", "NaN disparity", lambda w, t: refocus(w, t, "--disparity", "nan"),
      "--disparity", "finite"),
    R("lightfield refocus", "infinite depth", lambda w, t: refocus(w, t, "--depth", "inf"),
      "--depth", "finite"),
    R("lightfield refocus", "bad zoom", lambda w, t: refocus(w, t, "--disparity", "0",
                                                             "--zoom", "a,b"), "--zoom"),
    R("lightfield refocus", "zoom outside",
      lambda w, t: refocus(w, t, "--disparity", "0", "--zoom", "0,0,900,900"), "--zoom"),
    R("lightfield refocus", "negative edge ratio",
      lambda w, t: refocus(w, t, "--disparity", "0", "--edge-ratio", "-1"), "--edge-ratio"),
    R("lightfield refocus", "huge stack",
      lambda w, t: ["lightfield", "refocus", w.lf, "--out", t / "stack", "--stack",
                    "--planes", "10" * 7], "--planes", "memory"),
    R("lightfield refocus", "out is an existing folder",
      lambda w, t: ["lightfield", "refocus", w.lf, "--disparity", "0", "--out",
                    (t / "d.png").mkdir() or t / "d.png"], "d.png", "folder"),
    # present
    R("present", "missing stimulus", lambda w, t: present(w, t, stimulus=t / "no.png"), "no.png",
      "not found"),
    R("present", "stimulus is text", lambda w, t: present(w, t, stimulus=text_file(t / "s.png")),
      "s.png", "not a readable image"),
    R("present", "dropout 2 with phosphenes",
      lambda w, t: present(w, t, "--phosphenes", "disc", "--dropout", "2"), "--dropout", "< 1"),
    R("present", "dropout 2 without phosphenes", lambda w, t: present(w, t, "--dropout", "2"),
      "--dropout", "< 1"),
    R("present", "dropout without phosphenes", lambda w, t: present(w, t, "--dropout", "0.5"),
      "--dropout", "--phosphenes"),
    R("present", "NaN gamma", lambda w, t: present(w, t, "--gamma", "nan"), "--gamma", "finite"),
    R("present", "negative distance", lambda w, t: present(w, t, "--distance-cm", "-5"),
      "--distance-cm", "> 0"),
    R("present", "huge screen", lambda w, t: present(w, t, "--screen-px", "100000x100000"),
      "screen", "memory"),
    R("present", "zero screen", lambda w, t: present(w, t, "--screen-px", "0x0"),
      "display geometry"),
    R("present", "screen not a size", lambda w, t: present(w, t, "--screen-px", "wide"),
      "--screen-px", "WIDTHxHEIGHT"),
    R("present", "unknown phosphenes", lambda w, t: present(w, t, "--phosphenes", "stars"),
      "kind"),
    R("present", "border colour out of range",
      lambda w, t: present(w, t, "--border-rgb", "300,0,0"), "border_rgb"),
    R("present", "screenshot is a folder",
      lambda w, t: ["present", "--stimulus", w.png, "--screenshot", (t / "shots").mkdir() or
                    t / "shots"], "--screenshot", "folder"),
    R("present", "infinite seconds", lambda w, t: present(w, t, "--seconds", "inf"), "--seconds"),
    # session run
    R("session run", "missing protocol", lambda w, t: session(w, t, proto=t / "none.toml"),
      "none.toml", "not found"),
    R("session run", "empty protocol", lambda w, t: session(w, t, proto=protocol(t, "")),
      "p.toml"),
    R("session run", "protocol not TOML", lambda w, t: session(w, t, proto=protocol(t, "[[[x")),
      "p.toml", "TOML"),
    R("session run", "unknown block field",
      lambda w, t: session(w, t, proto=protocol(t, block(colour='"red"'))), "colour"),
    R("session run", "mistyped levels",
      lambda w, t: session(w, t, proto=protocol(t, block(levels='"one"'))), "levels"),
    R("session run", "no levels", lambda w, t: session(w, t, proto=protocol(t, block(levels="[]"))),
      "levels", "non-empty"),
    R("session run", "missing level",
      lambda w, t: session(w, t, proto=protocol(t, block(levels="[7]"))), "level 7"),
    R("session run", "missing role",
      lambda w, t: session(w, t, proto=protocol(t, block(objects='"practice"'))), "practice"),
    R("session run", "missing object",
      lambda w, t: session(w, t, proto=protocol(t, block(objects='["unicorn"]'))), "unicorn"),
    R("session run", "huge repetition count",
      lambda w, t: session(w, t, proto=protocol(t, block(repetitions="1000000000000"))),
      "memory"),
    R("session run", "unknown implant",
      lambda w, t: session(w, t, proto=protocol(t, block() + '[display]\nimplant = "argus9"\n')),
      "display.implant", "argus9"),
    R("session run", "implant finer than a planned level",
      lambda w, t: session(w, t, proto=protocol(t, block() + '[display]\nimplant = "argus2"\n')),
      "display.implant", "finer than"),
    R("session run", "empty subject", lambda w, t: session(w, t, subject=""), "--subject"),
    R("session run", "blank subject", lambda w, t: session(w, t, subject="   "), "--subject"),
    R("session run", "negative seed", lambda w, t: session(w, t, "--seed", "-1"), "--seed"),
    R("session run", "infinite hold", lambda w, t: session(w, t, "--hold-s", "inf"), "--hold-s",
      "finite"),
    R("session run", "NaN hold", lambda w, t: session(w, t, "--hold-s", "nan"), "--hold-s"),
    R("session run", "data not SQLite", lambda w, t: session(w, t, data=text_file(t / "x.sqlite")),
      "x.sqlite", "SQLite"),
    R("session run", "data of a newer schema",
      lambda w, t: session(w, t, data=newer_schema(t, w)), "newer.sqlite", "newer"),
    R("session run", "data is a folder",
      lambda w, t: session(w, t, data=(t / "d.sqlite").mkdir() or t / "d.sqlite"), "--data"),
    R("session run", "data under a file", lambda w, t: session(w, t, data=under_a_file(t, "s.db")),
      "plain.txt"),
    R("session run", "data in a read-only folder",
      lambda w, t: session(w, t, data=readonly_dir(t, mode_bits_checked=True) / "s.sqlite"),
      "read-only"),
    R("session run", "missing stimulus set", lambda w, t: session(w, t, stim=t / "nostim"),
      "nostim", "not found"),
    R("session run", "stimulus path with ..", lambda w, t: session(w, t, stim=stim_copy(t, w)),
      "manifest.csv", "outside"),
    R("session run", "stimulus path absolute",
      lambda w, t: session(w, t, stim=stim_copy(t, w, outside=str(t / "outside.png"))),
      "manifest.csv", "outside"),
    R("session run", "stimulus symlink outside",
      lambda w, t: session(w, t, stim=stim_copy(t, w, symlink=True)), "manifest.csv", "outside"),
    R("session run", "unknown observer", lambda w, t: session(w, t, "--observer", "oracle"),
      "--observer"),
    R("session run", "bad observer param",
      lambda w, t: session(w, t, "--observer-param", "nonsense"), "--observer-param"),
    R("session run", "negative progress", lambda w, t: session(w, t, "--progress-every", "-1"),
      "--progress-every"),
    R("session run", "unicode path of a missing set",
      lambda w, t: session(w, t, stim=t / "Sätze mit Leerzeichen"), "Sätze mit Leerzeichen"),
    # session status
    R("session status", "missing", lambda w, t: ["session", "status", t / "no.sqlite"],
      "no.sqlite", "not found"),
    R("session status", "not SQLite", lambda w, t: ["session", "status", text_file(t / "x.db")],
      "x.db", "SQLite"),
    R("session status", "empty file",
      lambda w, t: ["session", "status", text_file(t / "e.sqlite", "")], "e.sqlite", "empty"),
    R("session status", "newer schema",
      lambda w, t: ["session", "status", newer_schema(t, w)], "newer.sqlite", "newer"),
    R("session status", "truncated database",
      lambda w, t: ["session", "status", truncated_db(t, w)], "cut.sqlite"),
    R("session status", "SQLite but not a trial log",
      lambda w, t: ["session", "status", _other_sqlite(t)], "other.sqlite", "not a confocal"),
    # session export
    R("session export", "newer schema",
      lambda w, t: ["session", "export", newer_schema(t, w), "--out", t / "o.csv"], "newer"),
    R("session export", "not SQLite",
      lambda w, t: ["session", "export", text_file(t / "x.db"), "--out", t / "o.csv"], "x.db"),
    R("session export", "out is a file",
      lambda w, t: ["session", "export", w.db, "--out", text_file(t / "o.csv")], "o.csv",
      "folder"),
    R("session export", "missing log",
      lambda w, t: ["session", "export", t / "none.sqlite", "--out", t / "o.csv"], "none.sqlite",
      "not found"),
    R("session export", "out under a file",
      lambda w, t: ["session", "export", w.db, "--out", under_a_file(t, "o.csv")], "plain.txt"),
    # score
    R("score", "session 999", lambda w, t: ["score", w.db, "--rater", "B", "--session", "999"],
      "--session 999", "expected one of 1"),
    R("score", "missing log", lambda w, t: ["score", t / "no.sqlite", "--rater", "B"],
      "no.sqlite", "not found"),
    R("score", "not SQLite", lambda w, t: ["score", text_file(t / "x.sqlite"), "--rater", "B"],
      "x.sqlite", "SQLite"),
    R("score", "blank rater", lambda w, t: ["score", w.db, "--rater", " "], "--rater"),
    R("score", "newer schema", lambda w, t: ["score", newer_schema(t, w), "--rater", "B"],
      "newer"),
    # analyze run
    R("analyze run", "missing file", lambda w, t: analyze(w, t, t / "no.csv"), "no.csv",
      "not found"),
    R("analyze run", "empty CSV", lambda w, t: analyze(w, t, text_file(t / "e.csv", "")),
      "e.csv", "empty"),
    R("analyze run", "CSV missing a column",
      lambda w, t: analyze(w, t, csv_table(t, w, drop_col("pixels"))), "pixels"),
    R("analyze run", "CSV NaN in a numeric column",
      lambda w, t: analyze(w, t, csv_table(t, w, set_col("pixels", "nan"))), "pixels"),
    R("analyze run", "CSV string in a numeric column",
      lambda w, t: analyze(w, t, csv_table(t, w, set_col("pixels", "many"))), "pixels"),
    R("analyze run", "CSV string in recognized",
      lambda w, t: analyze(w, t, csv_table(t, w, set_col("recognized", "maybe"))), "recognized"),
    R("analyze run", "not SQLite", lambda w, t: analyze(w, t, text_file(t / "x.sqlite")),
      "x.sqlite"),
    R("analyze run", "SQLite but not a trial log", lambda w, t: analyze(w, t, _other_sqlite(t)),
      "other.sqlite", "not a confocal"),
    R("analyze run", "out is an existing file",
      lambda w, t: ["analyze", w.csv, "--out", text_file(t / "rep.txt")], "rep.txt", "file"),
    R("analyze run", "pc 2", lambda w, t: analyze(w, t, w.csv, extra=("--pc", "2")), "--pc",
      "(0, 1)"),
    R("analyze run", "NaN pc", lambda w, t: analyze(w, t, w.csv, extra=("--pc", "nan")), "--pc"),
    R("analyze run", "negative guess", lambda w, t: analyze(w, t, w.csv, extra=("--guess", "-1")),
      "--guess"),
    R("analyze run", "bad lapse prior",
      lambda w, t: analyze(w, t, w.csv, extra=("--lapse-prior", "x")), "--lapse-prior"),
    R("analyze run", "negative seed", lambda w, t: analyze(w, t, w.csv, extra=("--seed", "-1")),
      "--seed"),
    # analyze power
    R("analyze power", "power 2", lambda w, t: ["analyze", "power", "--odds-ratio", "2",
                                                "--power", "2"], "--power", "(0, 1)"),
    R("analyze power", "odds ratio inf", lambda w, t: ["analyze", "power", "--odds-ratio", "inf"],
      "--odds-ratio", "(0, inf)", "finite"),
    R("analyze power", "odds ratio NaN", lambda w, t: ["analyze", "power", "--odds-ratio", "nan"],
      "--odds-ratio"),
    R("analyze power", "negative odds ratio",
      lambda w, t: ["analyze", "power", "--odds-ratio", "-2"], "--odds-ratio", "(0, inf)"),
    R("analyze power", "huge subject count",
      lambda w, t: ["analyze", "power", "--odds-ratio", "2", "--subjects", "1000000000"],
      "--subjects", "memory"),
    R("analyze power", "zero subjects",
      lambda w, t: ["analyze", "power", "--odds-ratio", "2", "--subjects", "0"], "--subjects"),
    R("analyze power", "subjects not numbers",
      lambda w, t: ["analyze", "power", "--odds-ratio", "2", "--subjects", "a,b"], "--subjects"),
    R("analyze power", "zero sims",
      lambda w, t: ["analyze", "power", "--odds-ratio", "2", "--sims", "0"], "--sims"),
    R("analyze power", "alpha 2",
      lambda w, t: ["analyze", "power", "--odds-ratio", "2", "--alpha", "2"], "--alpha"),
    R("analyze power", "both effects",
      lambda w, t: ["analyze", "power", "--odds-ratio", "2", "--threshold-ratio", "2"],
      "exactly one"),
    # demo
    R("demo", "out is an existing file", lambda w, t: ["demo", "--out", text_file(t / "d.txt")],
      "d.txt"),
    R("demo", "zero subjects", lambda w, t: ["demo", "--out", t / "d", "--subjects", "0"],
      "--subjects"),
    R("demo", "negative seed", lambda w, t: ["demo", "--out", t / "d", "--seed", "-1"], "--seed"),
    R("demo", "out not empty",
      lambda w, t: ["demo", "--out", text_file(t / "full" / "keep.txt").parent], "full",
      "did not write: keep.txt"),
    R("demo", "out not empty, with --force",
      lambda w, t: ["demo", "--out", text_file(t / "full" / "keep.txt").parent, "--force"],
      "full", "did not write: keep.txt"),
    R("analyze run", "out is the working folder",
      lambda w, t: ["analyze", w.csv, "--out", ".", "--no-figures"], "current working folder"),
    R("stimuli build", "out is the input PAIRS, with --force",
      lambda w, t: ["stimuli", "build", w.pairs, "--out", w.pairs, "--force"], "is the input"),
    # what leaves the lab is safe to share
    R("session run", "identifying participant field",
      lambda w, t: session(w, t, "--participant", "age=30,email=a@b.org", data=w.db),
      "--participant email", "--allow-identifying"),
    R("session run", "subject code colliding with one in the log",
      lambda w, t: session(w, t, data=w.db, subject="S-01"), "'S-01'", "'S01'"),
    R("session run", "subject code without a letter or digit",
      lambda w, t: session(w, t, subject="__"), "--subject", "no letter or digit"),
    R("session export", "bad --dates",
      lambda w, t: ["session", "export", w.db, "--out", t / "o", "--dates", "week"], "--dates"),
    # foreign files are only read (the trial log's application_id and schema)
    R("session run", "data of another program with its own schema_migrations",
      lambda w, t: session(w, t, data=_other_with_migrations(t)), "theirs.sqlite",
      "not a confocal trial log"),
    R("active run", "data of another program", lambda w, t: ["active", "run", "active_search",
      "--data", _other_with_migrations(t), "--subject", "S1"], "theirs.sqlite",
      "not a confocal trial log"),
    R("session run", "new session without a reason",
      lambda w, t: session(w, t, "--new-session", " "), "--new-session", "reason"),
    # hostile values: nesting, headers and numbers that would exhaust the stack or memory
    R("session run", "protocol nested 10000 deep",
      lambda w, t: session(w, t, proto=protocol(t, "x = " + "[" * 10000 + "]" * 10000)),
      "p.toml", "nested too deeply"),
    R("session run", "protocol with 10000 nested inline tables",
      lambda w, t: session(w, t, proto=protocol(t, "x = " + "{a=" * 10000 + "1" + "}" * 10000)),
      "p.toml", "nested too deeply"),
    R("lightfield scan", "npy header claims 10^14 values",
      lambda w, t: scan(w, t, lf=_huge_npy(t / "huge.npy")), "huge.npy", "header claims"),
    R("lightfield scan", "npz member header claims 10^14 values",
      lambda w, t: scan(w, t, lf=_huge_npz(t)), "huge.npz", "header claims"),
    R("analyze power", "sims 10^12",
      lambda w, t: ["analyze", "power", "--odds-ratio", "2", "--sims", str(10**12)], "--sims",
      "1000000"),
    R("analyze power", "sims 1e12",
      lambda w, t: ["analyze", "power", "--odds-ratio", "2", "--sims", "1e12"], "--sims"),
    R("analyze power", "zero processes",
      lambda w, t: ["analyze", "power", "--odds-ratio", "2", "--processes", "0"], "--processes"),
    R("analyze power", "unreachable cluster",
      lambda w, t: ["analyze", "power", "--odds-ratio", "2", "--sims", "1", "--cluster",
                    "tcp://127.0.0.1:9"], "--cluster", "127.0.0.1:9"),
    R("score", "no terminal", lambda w, t: ["score", w.db, "--rater", "B"], "not a terminal"),
    R("session run", "subject id of 300 characters",
      lambda w, t: session(w, t, subject="S" * 300), "--subject", "at most 64"),
    R("score", "rater id of 300 characters", lambda w, t: ["score", w.db, "--rater", "R" * 300],
      "--rater", "at most 64"),
    R("stimuli build", "object id of 200 characters",
      lambda w, t: build(w, t, _long_object_id(t, w)), "at most 64"),
    R("stimuli build", "threshold 1e308", lambda w, t: build(w, t, w.pairs, "--threshold", "1e308"),
      "--threshold", "[0, 1]"),
    R("lightfield scan", "threshold 1e308", lambda w, t: scan(w, t, "--threshold", "1e308"),
      "--threshold", "[0, 1]"),
]
# fmt: on


def _long_object_id(t: Path, w: World) -> Path:
    p = pairs_with(t, w)
    first = sorted(d for d in p.iterdir() if d.is_dir())[0]
    first.rename(p / ("o" * 200))
    return p


def _huge_npy(path: Path) -> Path:
    """An ``.npy`` file whose header claims 10^14 float32 values; 1 KiB of data follows."""
    from numpy.lib import format as npy_format

    with open(path, "wb") as f:
        header = {"descr": "<f4", "fortran_order": False, "shape": (10**4, 10**4, 10**3, 10**3)}
        npy_format.write_array_header_1_0(f, header)
        f.write(bytes(1024))
    return path


def _huge_npz(t: Path) -> Path:
    import zipfile

    npy = _huge_npy(t / "member.npy")
    with zipfile.ZipFile(t / "huge.npz", "w") as z:
        z.write(npy, "views.npy")
    npy.unlink()
    return t / "huge.npz"


def _objects_csv(t: Path, w: World, text: str) -> Path:
    p = pairs_with(t, w)
    (p / "objects.csv").write_text(text)
    return p


def _one_px_pair(t: Path, w: World) -> Path:
    p = pairs_with(t, w, one_px)
    first = sorted(d for d in p.iterdir() if d.is_dir())[0]
    one_px(first / "narrow.png")
    return p


def _truncated(src: Path, dst: Path) -> Path:
    data = src.read_bytes()
    dst.write_bytes(data[: len(data) // 2])
    return dst


def _other_with_migrations(t: Path) -> Path:
    p = t / "theirs.sqlite"
    con = sqlite3.connect(p)
    con.execute("CREATE TABLE schema_migrations (version INTEGER PRIMARY KEY, name TEXT, x TEXT)")
    con.execute("INSERT INTO schema_migrations VALUES (1, 'their first', 'x')")
    con.execute("CREATE TABLE sessions (id INTEGER PRIMARY KEY)")
    con.commit()
    con.close()
    return p


def _other_sqlite(t: Path) -> Path:
    p = t / "other.sqlite"
    con = sqlite3.connect(p)
    con.execute("CREATE TABLE notes (x TEXT)")
    con.commit()
    con.close()
    return p


_BOX = re.compile(r"[│╭╮╰╯─]")
_PASSED: Counter = Counter()


@pytest.mark.parametrize("row", ROWS, ids=[f"{r.command}: {r.name}" for r in ROWS])
def test_bad_input_is_one_line_and_exit_2(row: Row, world: World, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "250")
    monkeypatch.setenv("TERMINAL_WIDTH", "250")
    monkeypatch.chdir(tmp_path)
    argv = [str(a) for a in row.argv(world, tmp_path)]
    capsys.readouterr()
    before = snapshot(world.root, tmp_path)
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    err = capsys.readouterr().err
    after = snapshot(world.root, tmp_path)
    assert exc.value.code == 2, f"exit {exc.value.code}; stderr: {err}"
    assert "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert lines, "no message on stderr"
    if lines[0].startswith("confocal: error:"):
        assert len(lines) == 1, err
        text = lines[0]
    else:  # typer's usage box for an option value
        assert "Usage:" in err and "Error" in err, err
        text = " ".join(_BOX.sub(" ", err).split())
    for want in row.expect:  # "a|b": either wording (click's wording differs between versions)
        assert any(w.lower() in text.lower() for w in want.split("|")), f"{want!r} not in: {text}"
    changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    assert not changed, f"files created or changed: {changed}"
    _PASSED[row.command] += 1


def test_the_table_covers_every_command_with_80_rows():
    commands = Counter(r.command for r in ROWS)
    assert len(ROWS) >= 80
    assert len({(r.command, r.name) for r in ROWS}) == len(ROWS), "row names repeat"
    for c in (
        "stimuli synth",
        "stimuli build",
        "lightfield synth",
        "lightfield scan",
        "lightfield refocus",
        "present",
        "session run",
        "session status",
        "session export",
        "score",
        "analyze run",
        "analyze power",
        "demo",
    ):
        assert commands[c] >= 1, c
    print("bad-input rows by command: " + ", ".join(f"{c} {n}" for c, n in commands.items()))


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("confocal: error:"), err
    return lines[0]


@pytest.mark.gl
def test_screen_larger_than_the_gl_framebuffer_is_one_line(world, tmp_path, capsys):
    """A screen the GL driver cannot allocate (once an incomplete-framebuffer traceback)."""
    from experiment.presentation.presenter import Presenter, PresenterError, ScreenGeometry

    try:
        p = Presenter.offscreen(
            ScreenGeometry.jung2015(screen_shape_px=(8, 8), image_size_cm=(0.1, 0.1))
        )
    except PresenterError as exc:
        pytest.skip(f"no headless OpenGL context: {exc}")
    limit = int(p.ctx.info.get("GL_MAX_RENDERBUFFER_SIZE", 0) or 0)
    p.close()
    if not limit:
        pytest.skip("the GL driver does not report GL_MAX_RENDERBUFFER_SIZE")
    before = snapshot(tmp_path)
    with pytest.raises(SystemExit) as exc:
        cli.main(
            [
                "present",
                "--stimulus",
                str(world.png),
                "--screen-px",
                f"{limit + 1}x{limit + 1}",
                "--screenshot",
                str(tmp_path / "s.png"),
            ]
        )
    assert exc.value.code == 2
    line = _one_error_line(capsys)
    assert f"{limit + 1}x{limit + 1} px" in line
    # refused by the driver's limit, or before that by the memory check on a small machine
    assert f"largest framebuffer ({limit}x{limit} px)" in line or "memory" in line
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("command", ["status", "export", "analyze"])
def test_reading_a_log_leaves_no_wal_or_shm_files(world, tmp_path, command, capsys):
    """Read-only commands open the database read-only: nothing appears beside it."""
    db = tmp_path / "copy.sqlite"
    shutil.copy(world.db, db)
    argv = {
        "status": ["session", "status", str(db)],
        "export": ["session", "export", str(db), "--out", str(tmp_path / "out" / "dataset")],
        "analyze": [
            "analyze",
            str(db),
            "--out",
            str(tmp_path / "out"),
            "--no-figures",
            "--seed",
            "1",
        ],
    }[command]
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    assert exc.value.code in (0, None), capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir() if p.name != "out") == ["copy.sqlite"]


def test_full_disk_while_analyze_writes_its_report(world, tmp_path, monkeypatch, capsys):
    """ENOSPC in the middle of the report: one line, exit 2, no partial report folder."""
    real = Path.write_text

    def full(self, *a, **kw):
        if self.name == "report.md":
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, *a, **kw)

    monkeypatch.setattr(Path, "write_text", full)
    out = tmp_path / "report"
    with pytest.raises(SystemExit) as exc:
        cli.main(["analyze", str(world.csv), "--out", str(out), "--no-figures", "--seed", "1"])
    assert exc.value.code == 2
    line = _one_error_line(capsys)
    assert "disk is full" in line and str(out) in line
    assert list(tmp_path.iterdir()) == [], "no partial report and no temporary folder"
