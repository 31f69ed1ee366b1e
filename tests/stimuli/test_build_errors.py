"""Bad input to the stimulus builder: one clear line, exit status 2, STIM_DIR untouched.

Every case runs through the command line with ``--force`` into an existing stimulus-set folder,
so the build *would* replace it if it got that far: the folder must come out byte-identical and
no temporary folder may be left beside it. Every ``raise`` of the builder modules also has a
direct test below (house style H11).
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from experiment.cli import main
from stimuli.contact import contact_sheet
from stimuli.declutter import auto_threshold, declutter
from stimuli.errors import InputError
from stimuli.manifest import (
    ObjectInfo,
    StimulusRecord,
    check_object_id,
    parse_crop,
    read_manifest,
    read_objects_csv,
)
from stimuli.stimset import (
    BuildParams,
    PairSource,
    build_stimulus_set,
    edge_fraction,
    parse_edge_ratio,
    parse_threshold,
    parse_working_size,
    read_pairs,
    zoom_crop,
)
from tests.stimuli._build_fixtures import make_pair, write_pairs_folder, write_png


def _snapshot(folder: Path) -> dict[str, bytes] | None:
    if not folder.exists():
        return None
    return {
        p.relative_to(folder).as_posix(): p.read_bytes() for p in folder.rglob("*") if p.is_file()
    }


def _existing_set(tmp_path: Path) -> Path:
    """A folder that already holds a (different) stimulus set an earlier build wrote."""
    from experiment.outputs import write_manifest

    out = tmp_path / "stimset"
    out.mkdir()
    (out / "stimulus_set.json").write_text(json.dumps({"set_id": "0" * 64}))
    (out / "manifest.csv").write_text("object,condition\nold,cluttered\n")
    write_manifest(out, "stimuli build", ["stimulus_set.json", "manifest.csv"])
    return out


def _pairs(tmp_path: Path, n: int = 2) -> Path:
    return write_pairs_folder(tmp_path / "pairs", n, (100, 150))


def _missing_narrow(tmp_path):
    p = _pairs(tmp_path)
    (p / "obj01" / "narrow.png").unlink()
    return [str(p)], r"obj01: missing narrow\.\* \(narrow depth-of-field photo\)"


def _missing_in_csv(tmp_path):
    _pairs(tmp_path)
    (tmp_path / "pairs.csv").write_text(
        "object,wide,narrow\nmug,pairs/obj00/wide.png,pairs/obj00/gone.png\n"
    )
    return [str(tmp_path / "pairs.csv")], r"gone\.png: narrow photo of object 'mug' not found"


def _garbage(tmp_path):
    p = _pairs(tmp_path)
    (p / "obj00" / "wide.png").write_bytes(b"this is not an image at all")
    return [str(p)], r"obj00/wide\.png: not a readable image"


def _truncated_png(tmp_path):
    p = _pairs(tmp_path)
    data = (p / "obj01" / "narrow.png").read_bytes()
    (p / "obj01" / "narrow.png").write_bytes(data[: len(data) // 2])
    return [str(p)], r"obj01/narrow\.png: not a readable image"


def _truncated_jpeg(tmp_path):
    from PIL import Image

    p = _pairs(tmp_path, 1)
    wide, _, _ = make_pair(0, (100, 150))
    (p / "obj00" / "wide.png").unlink()
    Image.fromarray((wide * 255).astype(np.uint8)).save(p / "obj00" / "wide.jpg", quality=90)
    data = (p / "obj00" / "wide.jpg").read_bytes()
    (p / "obj00" / "wide.jpg").write_bytes(data[: len(data) // 3])
    return [str(p)], r"obj00/wide\.jpg: not a readable image"


def _empty_folder(tmp_path):
    (tmp_path / "empty").mkdir()
    return [str(tmp_path / "empty")], r"empty: no object sub-folders"


def _duplicate_ids(tmp_path):
    _pairs(tmp_path)
    (tmp_path / "pairs.csv").write_text(
        "object,wide,narrow\n"
        "mug,pairs/obj00/wide.png,pairs/obj00/narrow.png\n"
        "Mug,pairs/obj01/wide.png,pairs/obj01/narrow.png\n"
    )
    return [str(tmp_path / "pairs.csv")], r"duplicate object id 'Mug' \(also 'mug'\)"


def _threshold_not_a_number(tmp_path):
    return [str(_pairs(tmp_path)), "--threshold", "high"], (
        r"--threshold must be 'auto' or a number in \[0, 1\].*, got 'high'"
    )


def _objects_csv_threshold_not_a_number(tmp_path):
    p = _pairs(tmp_path)
    (p / "objects.csv").write_text("object,sobel_threshold\nobj00,0.1\nobj01,high\n")
    return [str(p)], r"objects\.csv, line 3: field sobel_threshold: expected a number, got 'high'"


def _crop_outside(tmp_path):
    p = _pairs(tmp_path)
    (p / "objects.csv").write_text('object,crop\nobj01,"100,20,90,60"\n')
    return [str(p)], (
        r"object 'obj01' .*field crop: crop box x,y,w,h = 100,20,90,60 lies outside the "
        r"150x100 image"
    )


def _crop_outside_fast_decode(tmp_path):
    args, match = _crop_outside(tmp_path)
    return [*args, "--fast-decode"], match


def _sizes_differ(tmp_path):
    p = _pairs(tmp_path, 1)
    wide, _, _ = make_pair(0, (50, 75))
    write_png(wide, p / "obj00" / "narrow.png")
    return [str(p)], r"must have the same pixel size \(use --allow-resize"


def _pairs_not_found(tmp_path):
    return [str(tmp_path / "nowhere")], r"nowhere: PAIRS not found"


def _bad_working_size(tmp_path):
    return [str(_pairs(tmp_path)), "--working-size", "492"], r"--working-size must be WIDTHxHEIGHT"


def _bad_edge_ratio(tmp_path):
    return [str(_pairs(tmp_path)), "--edge-ratio", "1.5"], r"--edge-ratio must be 'auto' or a"


def _bad_mode(tmp_path):
    return [str(_pairs(tmp_path)), "--mode", "colour"], r"mode must be one of \('edges', 'grey'\)"


def _depth_on_photo_pairs(tmp_path):
    return (
        [str(_pairs(tmp_path)), "--declutter", "depth"],
        r"--declutter depth needs light fields, but object 'obj00' is a photo pair",
    )


def _bad_plane(tmp_path):
    return [str(_pairs(tmp_path)), "--plane", "middle"], r"--plane must be one of auto, strongest"


def _roi_on_photo_pair(tmp_path):
    p = _pairs(tmp_path)
    (p / "objects.csv").write_text('object,roi\nobj00,"1,2,30,20"\n')
    return [str(p)], r"object 'obj00': field roi chooses a light field's plane"


CASES = {
    "depth de-clutter on photo pairs": _depth_on_photo_pairs,
    "bad --plane": _bad_plane,
    "roi on a photo pair": _roi_on_photo_pair,
    "missing photo (folder)": _missing_narrow,
    "missing photo (csv)": _missing_in_csv,
    "unreadable image": _garbage,
    "truncated png": _truncated_png,
    "truncated jpeg": _truncated_jpeg,
    "empty folder": _empty_folder,
    "duplicate ids": _duplicate_ids,
    "non-numeric --threshold": _threshold_not_a_number,
    "non-numeric objects.csv threshold": _objects_csv_threshold_not_a_number,
    "crop outside image": _crop_outside,
    "crop outside image (--fast-decode)": _crop_outside_fast_decode,
    "pair sizes differ": _sizes_differ,
    "PAIRS not found": _pairs_not_found,
    "bad working size": _bad_working_size,
    "bad edge ratio": _bad_edge_ratio,
    "bad mode": _bad_mode,
}


def _run(args: list[str], capsys) -> tuple[int, str]:
    with pytest.raises(SystemExit) as exc:
        main(args)
    return exc.value.code, capsys.readouterr().err


@pytest.mark.parametrize("case", list(CASES))
def test_bad_input_one_line_exit_2_stimdir_untouched(case, tmp_path: Path, capsys) -> None:
    """Each bad input: exit 2, one line on stderr naming the problem, STIM_DIR byte-identical."""
    args, match = CASES[case](tmp_path)
    out = _existing_set(tmp_path)
    before = _snapshot(out)
    code, err = _run(["stimuli", "build", *args, "--out", str(out), "--force"], capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("confocal: error: "), err
    assert "Traceback" not in err
    import re

    assert re.search(match, lines[0]), lines[0]
    assert _snapshot(out) == before
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".stimset")) == []


def test_out_folder_with_a_different_set_is_refused_unless_force(tmp_path: Path, capsys) -> None:
    """An existing different set is refused (exit 2, untouched); --force replaces it."""
    out = _existing_set(tmp_path)
    before = _snapshot(out)
    pairs = str(_pairs(tmp_path))
    code, err = _run(["stimuli", "build", pairs, "--out", str(out)], capsys)
    assert code == 2
    assert "already holds a different stimulus set" in err and "--force" in err
    assert _snapshot(out) == before
    code, _ = _run(["stimuli", "build", pairs, "--out", str(out), "--force"], capsys)
    assert code == 0
    assert {r.object for r in read_manifest(out / "manifest.csv")} == {"obj00", "obj01"}


def test_out_folder_with_other_files_is_refused(tmp_path: Path) -> None:
    """A non-empty folder is never replaced by the library, set or not."""
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "thesis.tex").write_text("precious")
    with pytest.raises(InputError, match=r"mine: --out folder is not empty; confocal never"):
        build_stimulus_set(_pairs(tmp_path), tmp_path / "mine")
    assert (tmp_path / "mine" / "thesis.tex").read_text() == "precious"
    out = _existing_set(tmp_path)
    before = _snapshot(out)
    with pytest.raises(InputError, match=r"stimset: --out folder is not empty"):
        build_stimulus_set(_pairs(tmp_path), out, force=True)
    assert _snapshot(out) == before


def test_cli_refuses_a_folder_with_other_files_even_with_force(tmp_path: Path, capsys) -> None:
    """`stimuli build --force` replaces only a set it wrote, never a folder holding other files."""
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "thesis.tex").write_text("precious")
    pairs = str(_pairs(tmp_path))
    code, err = _run(
        ["stimuli", "build", pairs, "--out", str(tmp_path / "mine"), "--force"], capsys
    )
    assert code == 2 and "holds files confocal did not write: thesis.tex" in err
    assert (tmp_path / "mine" / "thesis.tex").read_text() == "precious"
    code, err = _run(["stimuli", "build", pairs, "--out", pairs, "--force"], capsys)
    assert code == 2 and "is the input" in err


def test_out_is_a_file(tmp_path: Path) -> None:
    """--out naming a file is refused."""
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match=r"f: --out exists and is not a folder"):
        build_stimulus_set(_pairs(tmp_path), tmp_path / "f")


def test_subprocess_error_has_no_traceback(tmp_path: Path) -> None:
    """The installed command prints one line and exits 2 (no traceback)."""
    (tmp_path / "empty").mkdir()
    r = subprocess.run(
        [
            sys.executable,
            "-c",
            "from experiment.cli import main; main()",
            "stimuli",
            "build",
            str(tmp_path / "empty"),
            "--out",
            str(tmp_path / "s"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "no object sub-folders" in r.stderr
    assert not (tmp_path / "s").exists()


# ---------------------------------------------------------------- every raise, directly


def _csv(tmp_path: Path, name: str, text: str | bytes) -> Path:
    p = tmp_path / name
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text)
    return p


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: parse_working_size("0x5"), r"--working-size must be WIDTHxHEIGHT"),
        (
            lambda: parse_threshold("-1"),
            r"--threshold must be 'auto' or a number in \[0, 1\].*got '-1'",
        ),
        (lambda: parse_threshold([1]), r"--threshold must be 'auto' or a number"),
        (lambda: parse_edge_ratio("x"), r"--edge-ratio must be 'auto' or a number in \[0, 1\)"),
        (lambda: BuildParams(working_shape_px=(0, 5)), r"working_shape_px must be"),
        (lambda: BuildParams(threshold=float("nan")), r"threshold must be None or a number"),
        (lambda: BuildParams(threshold_method="canny"), r"threshold_method must be one of"),
        (lambda: BuildParams(edge_ratio=1.0), r"edge_ratio must be None or in \[0, 1\)"),
        (lambda: BuildParams(grey_levels=1), r"grey_levels must be an integer in \[2, 256\]"),
        (lambda: BuildParams(windows_px=(1, 2.5)), r"windows_px must be positive integers"),
        (lambda: BuildParams(windows_px=(1, 1)), r"windows_px must not repeat a window"),
        (lambda: zoom_crop(np.zeros((10, 10)), (0, 0, 11, 5)), r"lies outside the 10x10 image"),
        (lambda: edge_fraction(np.zeros((2, 2))), r"edges must be a bool image"),
        (lambda: auto_threshold(np.zeros((4, 4), np.float32), method="canny"), r"method must be"),
        (lambda: auto_threshold(np.full((4, 4), 2.0)), r"image must be in \[0, 1\]"),
        (lambda: declutter(np.zeros((4, 4)), threshold="high"), r"threshold must be a number"),
        (lambda: declutter(np.zeros((4, 4)), threshold=-0.1), r"finite number >= 0"),
        (lambda: check_object_id("../x", where="w"), r"w: object id must be letters"),
        (lambda: parse_crop("1,2,3", where="w"), r"w: crop must be 'x,y,w,h'"),
        (lambda: parse_crop("1,2,0,3", where="w"), r"w: crop must have x, y >= 0 and w, h > 0"),
        (lambda: ObjectInfo("a", role="test"), r"role must be one of \('main', 'training'\)"),
        (lambda: ObjectInfo("a", sobel_threshold=-1.0), r"sobel_threshold must be a number >= 0"),
        (lambda: ObjectInfo("a", plane_depth_m=0.0), r"plane_depth_m must be > 0"),
        (lambda: ObjectInfo.from_row({"object": "a", "role": "x"}, where="f"), r"f: field role"),
        (
            lambda: ObjectInfo.from_row({"object": "a", "plane_depth_m": "inf"}, where="f"),
            r"f: field plane_depth_m: expected a finite number",
        ),
        (
            lambda: StimulusRecord(
                "a", "main", "Blurred", 1, 1, 2, 2, 4, "p", "s", None, None, "src", "h", "edges"
            ),
            r"condition must be one of",
        ),
        (
            lambda: StimulusRecord(
                "a", "main", "photo", 1, 1, 2, 2, 5, "p", "s", None, None, "src", "h", "edges"
            ),
            r"pixels must equal width \* height, got 5 for 2x2",
        ),
        (lambda: contact_sheet([]), r"needs at least one row"),
        (lambda: contact_sheet([("a", [np.zeros((2, 2))])], cell_shape_px=(0, 2)), r"positive"),
        (lambda: contact_sheet([("a", [np.zeros(3)])]), r"must be 2-D"),
        (lambda: contact_sheet([("a", [np.full((2, 2), 3.0)])]), r"finite and in \[0, 1\]"),
        (lambda: contact_sheet([("a", [np.zeros((2, 2), np.int16)])]), r"bool, uint8 or float"),
    ],
)
def test_every_raise(call, match) -> None:
    """Each check raises InputError naming the field and what was expected (H11)."""
    with pytest.raises(InputError, match=match):
        call()


_MANIFEST_HEADER = (
    "object,role,condition,level,window,width,height,pixels,path,"
    "sha256,sobel_threshold,edge_ratio,source,source_sha256,mode,crop\n"
)

#: (reader, file name, its content or None for a missing file, what the message says after
#: the file name)
_BAD_FILES = [
    (read_objects_csv, "objects.csv", None, r" not found"),
    (read_objects_csv, "o1.csv", "name\nmug\n", r": missing column\(s\) object"),
    (read_objects_csv, "o2.csv", "object\nmug\nMUG\n", r", line 3: duplicate object id 'MUG'"),
    (read_objects_csv, "o3.csv", b"object\n\xff\xfe\n", r": not a UTF-8 text CSV file"),
    (read_manifest, "manifest.csv", None, r" not found"),
    (read_manifest, "m.csv", _MANIFEST_HEADER + "a,main,photo,eight,1,2,2,4,p,s,,,src,h,edges,\n",
     r", line 2: field level: expected an integer"),
    (read_pairs, "p1.csv", "object,wide\na,w.png\n", r": expected columns object,wide,narrow"),
    (read_pairs, "p2.csv", "object,wide,narrow\na,w.png,\n", r", line 2: field narrow is empty"),
    (read_pairs, "p3.csv", "object,wide,narrow\n", r": no object rows"),
    (read_pairs, "p4.csv", b"object,wide,narrow\n\xff,a,b\n", r": not a UTF-8 text CSV file"),
]  # fmt: skip


@pytest.mark.parametrize(("reader", "name", "text", "message"), _BAD_FILES)
def test_file_level_raises(tmp_path: Path, reader, name: str, text, message: str) -> None:
    """CSV readers name the file (and line) and what was expected."""
    path = tmp_path / name if text is None else _csv(tmp_path, name, text)
    with pytest.raises(InputError, match=re.escape(name) + message):
        reader(path)


def test_image_and_folder_raises(tmp_path: Path) -> None:
    """Image and PAIRS-folder readers name the file or folder and what was expected."""
    from stimuli.io import image_shape_px

    with pytest.raises(InputError, match=r"nope\.jpg: image file not found"):
        image_shape_px(tmp_path / "nope.jpg")
    (tmp_path / "bad.jpg").write_bytes(b"garbage")
    with pytest.raises(InputError, match=r"bad\.jpg: not a readable image"):
        image_shape_px(tmp_path / "bad.jpg")
    (tmp_path / "two" / "a").mkdir(parents=True)
    (tmp_path / "two" / "a" / "wide.png").write_bytes(b"")
    (tmp_path / "two" / "a" / "wide.jpg").write_bytes(b"")
    with pytest.raises(InputError, match=r"a: more than one wide\.\* file"):
        read_pairs(tmp_path / "two")
    (tmp_path / "bad id" / "a b").mkdir(parents=True)
    with pytest.raises(InputError, match=r"folder name: object id must be"):
        read_pairs(tmp_path / "bad id")


def test_lightfield_raises(tmp_path: Path) -> None:
    """Light-field sources: missing path, empty folder."""
    (tmp_path / "p1.csv").write_text("object,lightfield\nbust,lf.npz\n")
    with pytest.raises(InputError, match=r"lf\.npz: light field of object 'bust' not found"):
        build_stimulus_set(tmp_path / "p1.csv", tmp_path / "s")
    (tmp_path / "lfdir").mkdir()
    (tmp_path / "p2.csv").write_text("object,lightfield\nbust,lfdir\n")
    with pytest.raises(InputError, match=r"lfdir: light-field folder is empty"):
        build_stimulus_set(tmp_path / "p2.csv", tmp_path / "s")
    assert not (tmp_path / "s").exists()


def test_build_argument_raises(tmp_path: Path) -> None:
    """params of the wrong type; a set where every pixel is an edge (edge ratio 1)."""
    pairs = _pairs(tmp_path, 1)
    with pytest.raises(InputError, match=r"params must be a BuildParams, got dict"):
        build_stimulus_set(pairs, tmp_path / "s", params={"mode": "grey"})
    noise = (np.indices((100, 150)).sum(axis=0) % 2).astype(np.float32)  # checkerboard
    write_png(noise, pairs / "obj00" / "wide.png")
    with pytest.raises(InputError, match=r"edge ratio from the set is 1\.0"):
        build_stimulus_set(pairs, tmp_path / "s", params=BuildParams(threshold=0.0))
    assert PairSource("x", lightfield=tmp_path).kind == "lightfield"
