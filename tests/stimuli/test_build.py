"""Stimulus builder: sizes, manifest, provenance, determinism, conditions, CLI."""

from __future__ import annotations

import json
import sys
import types
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from experiment.cli import main
from stimuli import jung2015
from stimuli.compress import block_mean
from stimuli.contact import contact_sheet
from stimuli.declutter import auto_threshold, declutter
from stimuli.io import load_gray, sha256_file
from stimuli.manifest import (
    MANIFEST_COLUMNS,
    OBJECTS_COLUMNS,
    ObjectInfo,
    read_manifest,
    read_objects_csv,
    write_manifest,
    write_objects_csv,
)
from stimuli.stimset import (
    BuildParams,
    aspect_crop_box,
    build_stimulus_set,
    edge_fraction,
    edge_ladder,
    grey_ladder,
    read_pairs,
    to_working_size,
    zoom_crop,
)
from tests.stimuli._build_fixtures import make_pair, write_pairs_folder, write_png

#: Photo size of the test pairs: 516x344 (3:2), so the builder centre-crops to 492:327 and
#: down-samples, as it does for camera photos.
SHAPE_PX = (344, 516)

OBJECTS_CSV = (
    "object,name,synonyms,uses,role,sobel_threshold,crop\n"
    "obj00,mug,cup;beaker,drinking,main,,\n"
    "obj01,lamp,,reading;lighting,main,,\n"
    "obj02,key,,,training,,\n"
)


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory):
    """One small set (3 objects, 1 of them training) with default parameters."""
    root = tmp_path_factory.mktemp("build")
    pairs = write_pairs_folder(root / "pairs", 3, SHAPE_PX, OBJECTS_CSV)
    result = build_stimulus_set(pairs, root / "set", workers=2)
    return pairs, result, root / "set"


def _stim(out: Path, rec) -> np.ndarray:
    return np.asarray(Image.open(out / rec.path))


def test_sizes_equal_the_papers_and_files_match_manifest(built) -> None:
    """Sec. 3.1: 8 levels per condition, sizes 492x327 ... 12x8, PNGs at native size."""
    _, result, out = built
    records = read_manifest(out / "manifest.csv")
    # per object a grey photo and 2 x 8 edge stimuli; the training object also its two colour
    # photos (wide and confocal, Sec. 3.1 training)
    assert len(records) == result.n_stimuli == 3 * (1 + 2 * 8) + 2
    paper = dict(zip(jung2015.WINDOWS_PX, jung2015.RESOLUTIONS_PX, strict=True))
    for cond in ("cluttered", "decluttered"):
        rows = sorted(
            (r for r in records if r.object == "obj01" and r.condition == cond),
            key=lambda r: r.level,
        )
        assert [r.level for r in rows] == list(range(1, 9))
        assert [r.window for r in rows] == [40, 18, 13, 7, 5, 3, 2, 1]
        assert [r.pixels for r in rows] == sorted(jung2015.PIXEL_COUNTS)
        for r in rows:
            assert (r.height, r.width) == paper[r.window]
            img = _stim(out, r)
            assert img.shape == (r.height, r.width) and img.dtype == np.uint8
            assert set(np.unique(img)) <= {0, 255}
            assert sha256_file(out / r.path) == r.sha256
    photos = [r for r in records if r.condition == "photo"]
    assert len(photos) == 3 and all((p.level, p.window, p.pixels) == (8, 1, 160884) for p in photos)
    assert len(np.unique(_stim(out, photos[0]))) > 2  # a grey photo, not an edge image
    roles = {r.object: r.role for r in records}
    assert roles == {"obj00": "main", "obj01": "main", "obj02": "training"}


def test_manifest_round_trip(built, tmp_path: Path) -> None:
    """read_manifest(write_manifest(x)) == x, and rewriting gives the same bytes."""
    _, _, out = built
    records = read_manifest(out / "manifest.csv")
    header = (out / "manifest.csv").read_text().splitlines()[0].split(",")
    assert tuple(header) == MANIFEST_COLUMNS
    write_manifest(records, tmp_path / "m.csv")
    assert read_manifest(tmp_path / "m.csv") == records
    assert (tmp_path / "m.csv").read_bytes() == (out / "manifest.csv").read_bytes()


def test_objects_csv_carried_and_round_trip(built, tmp_path: Path) -> None:
    """objects.csv is carried into the set with all columns, and round-trips; the ``roi``
    column (light fields' regions of interest) only when an object has one."""
    _, _, out = built
    objs = read_objects_csv(out / "objects.csv")
    assert objs[0] == ObjectInfo("obj00", "mug", ("cup", "beaker"), ("drinking",))
    assert objs[2].role == "training"
    header = tuple((out / "objects.csv").read_text().splitlines()[0].split(","))
    assert header == OBJECTS_COLUMNS[:-1] and OBJECTS_COLUMNS[-1] == "roi"
    write_objects_csv(objs, tmp_path / "o.csv")
    assert read_objects_csv(tmp_path / "o.csv") == objs


def test_objects_csv_defaults_when_absent(tmp_path: Path) -> None:
    """Without objects.csv in PAIRS, the set still gets one, filled with defaults."""
    pairs = write_pairs_folder(tmp_path / "p", 1, (200, 300))
    build_stimulus_set(pairs, tmp_path / "s", workers=1)
    (o,) = read_objects_csv(tmp_path / "s" / "objects.csv")
    assert (o.object, o.display_name, o.role, o.sobel_threshold) == ("obj00", "obj00", "main", None)


def test_provenance_json(built) -> None:
    """stimulus_set.json: version, parameters, input hashes, edge ratio, levels (H15)."""
    pairs, result, out = built
    meta = json.loads((out / "stimulus_set.json").read_text())
    from stimuli import __version__

    assert meta["software"]["version"] == __version__
    assert "git_commit" in meta["software"]
    # a set of photo pairs records the mode 'auto' applies to them (and keeps its old id)
    assert BuildParams.from_dict(meta["parameters"]) == BuildParams(declutter="sobel")
    assert meta["set_id"] == result.set_id
    assert meta["edge_ratio"] == result.edge_ratio
    assert [lv["pixels"] for lv in meta["levels"]] == sorted(jung2015.PIXEL_COUNTS)
    o = meta["objects"][0]
    assert o["sources"]["wide"]["sha256"] == sha256_file(pairs / "obj00" / "wide.png")
    assert o["sources"]["narrow"]["path"] == "obj00/narrow.png"
    assert o["aspect_crop"] == [0, 0, 516, 343]  # 516 / (492 / 327) = 342.96
    assert meta["manifest_sha256"] == sha256_file(out / "manifest.csv")
    assert any("centre-cropped 3 of 3" in n for n in meta["notes"])


def test_auto_edge_ratio_is_mean_wide_edge_fraction_of_main_objects(built) -> None:
    """Step 4: r = mean edge fraction of the main objects' wide-DOF (level 8) edge images."""
    _, result, out = built
    recs = read_manifest(out / "manifest.csv")
    fracs = [
        (_stim(out, r) > 0).mean()
        for r in recs
        if r.condition == "cluttered" and r.level == 8 and r.role == "main"
    ]
    assert len(fracs) == 2
    assert result.edge_ratio == pytest.approx(np.mean(fracs), abs=1e-12)
    assert all(r.edge_ratio == result.edge_ratio for r in recs)


EDGES = ("cluttered", "decluttered")


def test_decluttered_has_less_edge_mass_outside_the_object_at_every_level(built) -> None:
    """The blurred background drops out: fewer 'on' cells outside the object mask."""
    _, _, out = built
    recs = read_manifest(out / "manifest.csv")
    for i in range(3):
        _, _, mask = make_pair(i, SHAPE_PX)
        x, y, w, h = aspect_crop_box(SHAPE_PX, jung2015.WORKING_SHAPE_PX)
        m = to_working_size(mask[y : y + h, x : x + w].astype(np.float32), (327, 492))
        for level in range(1, 9):
            outside = {}
            for r in recs:
                if r.object == f"obj{i:02d}" and r.level == level and r.condition in EDGES:
                    grid = block_mean(m, (r.height, r.width)) > 0.5
                    outside[r.condition] = int(((_stim(out, r) > 0) & ~grid).sum())
            assert outside["decluttered"] < outside["cluttered"], (i, level, outside)


def test_thresholds_per_object_global_and_auto(tmp_path: Path) -> None:
    """objects.csv value wins, then the global value; auto (method otsu) is Otsu on narrow."""
    csv_text = "object,sobel_threshold\nobj00,0.2\n"
    pairs = write_pairs_folder(tmp_path / "p", 2, (200, 300), csv_text)
    r = build_stimulus_set(pairs, tmp_path / "g", params=BuildParams(threshold=0.05), workers=1)
    got = {o.object: (o.sobel_threshold, o.threshold_source) for o in r.objects}
    assert got == {"obj00": (0.2, "objects.csv"), "obj01": (0.05, "global")}
    r = build_stimulus_set(
        pairs, tmp_path / "a", workers=1, params=BuildParams(threshold_method="otsu")
    )
    narrow = load_gray(pairs / "obj01" / "narrow.png")
    x, y, w, h = aspect_crop_box(narrow.shape, (327, 492))
    expected = auto_threshold(to_working_size(narrow[y : y + h, x : x + w], (327, 492)))
    assert r.objects[1].sobel_threshold == pytest.approx(expected, abs=0)
    assert r.objects[1].threshold_source == "auto:otsu"
    recs = read_manifest(tmp_path / "a" / "manifest.csv")
    assert {x.threshold_source for x in recs if x.object == "obj00"} == {"objects.csv"}


def test_build_is_deterministic(tmp_path: Path) -> None:
    """Two builds of the same input give byte-identical stimuli and manifests."""
    pairs = write_pairs_folder(tmp_path / "p", 2, (200, 300))
    a = build_stimulus_set(pairs, tmp_path / "a", workers=2)
    b = build_stimulus_set(pairs, tmp_path / "b", workers=1)
    assert a.set_id == b.set_id
    assert (tmp_path / "a/manifest.csv").read_bytes() == (tmp_path / "b/manifest.csv").read_bytes()
    for p in sorted((tmp_path / "a").rglob("*.png")):
        assert p.read_bytes() == (tmp_path / "b" / p.relative_to(tmp_path / "a")).read_bytes()


def test_same_set_rebuilds_in_place_without_force(tmp_path: Path) -> None:
    """The command replaces a set it wrote (same set_id) without --force."""
    pairs = write_pairs_folder(tmp_path / "p", 1, (200, 300))
    for _ in range(2):
        with pytest.raises(SystemExit) as exc:
            main(["stimuli", "build", str(pairs), "--out", str(tmp_path / "s")])
        assert exc.value.code == 0
        (tmp_path / "s" / "obj00" / "photo.png").unlink()
    build = ["stimuli", "build", str(pairs), "--out", str(tmp_path / "s")]
    with pytest.raises(SystemExit) as exc:  # the own folder, one file short: still its own
        main(build)
    assert exc.value.code == 0
    assert (tmp_path / "s" / "obj00" / "photo.png").is_file()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".s.")]  # no leftovers


def test_zoom_crop_equals_building_from_a_cropped_photo(tmp_path: Path) -> None:
    """A crop box in objects.csv is the same as cropping the photos first (full resolution)."""
    wide, narrow, _ = make_pair(5, SHAPE_PX)
    box = (90, 120, 300, 200)  # x, y, w, h; 3:2 like the photo
    write_png(wide, tmp_path / "z/obj/wide.png")
    write_png(narrow, tmp_path / "z/obj/narrow.png")
    (tmp_path / "z/objects.csv").write_text('object,crop\nobj,"90,120,300,200"\n')
    x, y, w, h = box
    write_png(wide[y : y + h, x : x + w], tmp_path / "c/obj/wide.png")
    write_png(narrow[y : y + h, x : x + w], tmp_path / "c/obj/narrow.png")
    build_stimulus_set(tmp_path / "z", tmp_path / "zs", workers=1)
    build_stimulus_set(tmp_path / "c", tmp_path / "cs", workers=1)
    rz = read_manifest(tmp_path / "zs/manifest.csv")
    rc = read_manifest(tmp_path / "cs/manifest.csv")
    assert [r.sha256 for r in rz] == [r.sha256 for r in rc]
    assert {r.crop for r in rz} == {"90,120,300,200"} and {r.crop for r in rc} == {""}


def test_csv_input_gives_the_same_stimuli_as_a_folder(tmp_path: Path, built) -> None:
    """PAIRS as a CSV (paths relative to it, crop column optional) equals the folder form."""
    pairs, _, out = built
    lines = ["object,wide,narrow,crop"] + [
        f"obj{i:02d},../{pairs.name}/obj{i:02d}/wide.png,../{pairs.name}/obj{i:02d}/narrow.png,"
        for i in range(3)
    ]
    csv_dir = pairs.parent / "csvdir"
    csv_dir.mkdir(exist_ok=True)
    (csv_dir / "pairs.csv").write_text("\n".join(lines) + "\n")
    (csv_dir / "objects.csv").write_text(OBJECTS_CSV)
    build_stimulus_set(csv_dir / "pairs.csv", tmp_path / "s", workers=2)
    a = read_manifest(out / "manifest.csv")
    b = read_manifest(tmp_path / "s" / "manifest.csv")
    assert [r.sha256 for r in a] == [r.sha256 for r in b]


def test_grey_mode_quantizes_the_photos(tmp_path: Path) -> None:
    """--mode grey: both conditions are grey-level compressions of the photos (Fig. 2)."""
    pairs = write_pairs_folder(tmp_path / "p", 1, (200, 300))
    build_stimulus_set(pairs, tmp_path / "s", params=BuildParams(mode="grey", grey_levels=4))
    recs = read_manifest(tmp_path / "s" / "manifest.csv")
    allowed = {round(k * 255 / 3) for k in range(4)}
    for r in recs:
        if r.condition != "photo":
            assert set(np.unique(_stim(tmp_path / "s", r))) <= allowed
            assert (r.mode, r.grey_levels, r.sobel_threshold, r.edge_ratio) == (
                "grey",
                4,
                None,
                None,
            )


def test_lightfield_object_goes_through_confocal_pair(tmp_path: Path, monkeypatch) -> None:
    """A lightfield column: centre view = cluttered, confocal image = de-cluttered."""
    import stimuli.stimset.prepare
    from stimuli.stimset.lightfield import ConfocalPairImages

    wide, narrow, _ = make_pair(1, (200, 300))
    calls = []

    def fake(src, info, params):
        calls.append((Path(src.lightfield).name, info.plane_depth_m, info.plane_disparity_px))
        return ConfocalPairImages(wide, narrow, "disparity=1.5px,disparity_px", None)

    monkeypatch.setattr(stimuli.stimset.prepare, "load_confocal_pair", fake)
    (tmp_path / "lf.npz").write_bytes(b"not read by the fake")
    (tmp_path / "pairs.csv").write_text("object,lightfield\nbust,lf.npz\n")
    (tmp_path / "objects.csv").write_text("object,plane_disparity_px\nbust,1.5\n")
    build_stimulus_set(tmp_path / "pairs.csv", tmp_path / "s", workers=1)
    assert calls == [("lf.npz", None, 1.5)]
    recs = read_manifest(tmp_path / "s" / "manifest.csv")
    assert {r.source for r in recs} == {
        "lf.npz#centre",
        "lf.npz#confocal@disparity=1.5px,disparity_px",
    }
    assert recs[1].source_sha256 == sha256_file(tmp_path / "lf.npz")


def test_pure_steps_do_not_modify_input() -> None:
    """H6: functions never modify their input."""
    wide, narrow, _ = make_pair(0, (120, 180))
    edges = declutter(narrow, threshold=0.1)
    args = [wide.copy(), narrow.copy(), edges.copy()]
    zoom_crop(args[0], (1, 2, 30, 20))
    to_working_size(args[0], (40, 60))
    edge_ladder(args[2], edge_ratio=0.05)
    grey_ladder(args[1], grey_levels=4)
    auto_threshold(args[1])
    edge_fraction(args[2])
    for a, b in zip(args, [wide, narrow, edges], strict=True):
        np.testing.assert_array_equal(a, b)


def test_edge_ladder_window_one_is_the_edge_image() -> None:
    """Level 8 (window 1) is the edge image itself; all-zero edges give all-off cells."""
    e = np.zeros((327, 492), bool)
    lad = edge_ladder(e, edge_ratio=0.0)
    assert [lv for lv, _, _ in lad] == list(range(1, 9)) and not any(s.any() for _, _, s in lad)
    e[100:110, 200:300] = True
    assert np.array_equal(edge_ladder(e, edge_ratio=0.077)[-1][2], e)


def test_contact_sheet_magnifies_with_nearest_neighbour() -> None:
    """A 2x3 stimulus shows as exact blocks (np.kron) in its cell."""
    stim = np.array([[1, 0, 1], [0, 1, 0]], bool)
    sheet = contact_sheet([("a", [stim])], cell_shape_px=(20, 30))
    expected = np.kron(stim, np.ones((10, 10), bool)).astype(np.uint8) * 255
    found = [
        (r, c)
        for r in range(sheet.shape[0] - 19)
        for c in range(sheet.shape[1] - 29)
        if sheet[r, c] == 255 and np.array_equal(sheet[r : r + 20, c : c + 30], expected)
    ]
    assert len(found) == 1


def test_contact_sheets_written(built) -> None:
    """One sheet per object (2 conditions x 8 levels) plus an overview of all objects."""
    _, _, out = built
    names = sorted(p.name for p in (out / "contact").iterdir())
    assert names == ["all.png", "obj00.png", "obj01.png", "obj02.png"]
    im = Image.open(out / "contact" / "obj00.png")
    assert im.width > 8 * 164 and im.height > 2 * 109


def test_read_pairs_folder_orders_and_skips_hidden(tmp_path: Path) -> None:
    """Object folders are read in name order; hidden folders are ignored."""
    pairs = write_pairs_folder(tmp_path / "p", 2, (50, 75))
    (pairs / ".cache").mkdir()
    inp = read_pairs(pairs)
    assert [s.object for s in inp.sources] == ["obj00", "obj01"]
    assert inp.objects_csv is None


def test_allow_resize_accepts_pairs_of_different_sizes(tmp_path: Path) -> None:
    """--allow-resize: a pair whose photos differ in size is built, with a note."""
    wide, narrow, _ = make_pair(0, (200, 300))
    write_png(wide, tmp_path / "p/o/wide.png")
    write_png(narrow[::2, ::2], tmp_path / "p/o/narrow.png")
    r = build_stimulus_set(tmp_path / "p", tmp_path / "s", params=BuildParams(allow_resize=True))
    assert any("resized each on its own" in n for n in r.notes)


def test_cli_build_prints_summary(tmp_path: Path, capsys) -> None:
    """confocal stimuli build PAIRS --out STIM_DIR: exit 0, a summary line on stdout."""
    pairs = write_pairs_folder(tmp_path / "p", 1, (200, 300))
    with pytest.raises(SystemExit) as exc:
        main(["stimuli", "build", str(pairs), "--out", str(tmp_path / "s"), "--edge-ratio", "0.1"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "wrote 17 stimuli for 1 objects" in out and "edge ratio 0.1000 (given)" in out
    assert read_manifest(tmp_path / "s" / "manifest.csv")[1].edge_ratio == 0.1


def test_cli_synth_calls_write_pairs(tmp_path: Path, monkeypatch, capsys) -> None:
    """confocal stimuli synth passes its options to stimuli.synth.write_pairs."""
    calls = []

    def write_pairs(out_dir, *, n_objects=20, n_training=3, seed=0, shape_px=(327, 492)):
        calls.append((Path(out_dir), n_objects, n_training, seed, shape_px))
        Path(out_dir).mkdir()
        return Path(out_dir)

    out = tmp_path / "pairs"
    monkeypatch.setitem(
        sys.modules, "stimuli.synth", types.SimpleNamespace(write_pairs=write_pairs)
    )
    with pytest.raises(SystemExit) as exc:
        main(["stimuli", "synth", "--out", str(out), "--objects", "5", "--size", "300x200"])
    assert exc.value.code == 0
    assert calls == [(out, 5, 3, 0, (200, 300))]
    with pytest.raises(SystemExit) as exc:
        main(["stimuli", "synth", "--out", str(out), "--force"])
    assert exc.value.code == 0
    assert calls[-1] == (out, 20, 3, 0, (327, 492))


def _jpeg_pairs(root: Path, n: int, shape_px: tuple[int, int]) -> Path:
    for i in range(n):
        wide, narrow, _ = make_pair(i, shape_px, blur_px=6.0)
        for name, img in (("wide", wide), ("narrow", narrow)):
            (root / f"obj{i:02d}").mkdir(parents=True, exist_ok=True)
            Image.fromarray(np.round(img * 255).astype(np.uint8)).save(
                root / f"obj{i:02d}" / f"{name}.jpg", quality=92
            )
    return root


def test_load_gray_draft_decodes_jpeg_at_reduced_size(tmp_path: Path) -> None:
    """draft_shape_px: the smallest DCT scale (1/2, 1/4, 1/8) still >= the request; EXIF honoured;
    other formats ignore it."""
    wide, _, _ = make_pair(0, (400, 600))
    u8 = np.round(wide * 255).astype(np.uint8)
    Image.fromarray(u8).save(tmp_path / "a.jpg", quality=92)
    Image.fromarray(u8).save(tmp_path / "a.png")
    assert load_gray(tmp_path / "a.jpg", draft_shape_px=(90, 140)).shape == (100, 150)
    assert load_gray(tmp_path / "a.jpg", draft_shape_px=(101, 150)).shape == (200, 300)
    assert load_gray(tmp_path / "a.png", draft_shape_px=(90, 140)).shape == (400, 600)
    exif = Image.Exif()
    exif[0x0112] = 6  # rotate 90: stored 600 wide, shown 400 wide
    Image.fromarray(u8).save(tmp_path / "r.jpg", quality=92, exif=exif)
    from stimuli.io import image_shape_px

    assert image_shape_px(tmp_path / "r.jpg") == (600, 400)
    assert load_gray(tmp_path / "r.jpg", draft_shape_px=(140, 90)).shape == (150, 100)


def test_fast_decode_is_close_to_full_decode(tmp_path: Path) -> None:
    """--fast-decode: same sizes and crop semantics, pixels close to the full decode."""
    pairs = _jpeg_pairs(tmp_path / "p", 2, (400, 600))
    (pairs / "objects.csv").write_text('object,crop\nobj01,"60,80,360,240"\n')
    small = (82, 123)
    full = build_stimulus_set(pairs, tmp_path / "a", params=BuildParams(working_shape_px=small))
    fast = build_stimulus_set(
        pairs, tmp_path / "b", params=BuildParams(working_shape_px=small, fast_decode=True)
    )
    assert [o.decoded_shape_px for o in full.objects] == [(400, 600), (400, 600)]
    # obj00 needs >= 82 rows of 400 -> 1/4; obj01's 240-row crop needs 82 -> 1/2
    assert [o.decoded_shape_px for o in fast.objects] == [(100, 150), (200, 300)]
    for oid in ("obj00", "obj01"):
        a = load_gray(tmp_path / "a" / oid / "photo.png")
        b = load_gray(tmp_path / "b" / oid / "photo.png")
        assert a.shape == b.shape == small
        assert np.abs(a - b).mean() < 0.02, oid
    ra, rb = (read_manifest(tmp_path / d / "manifest.csv") for d in ("a", "b"))
    assert [(r.width, r.height, r.crop) for r in ra] == [(r.width, r.height, r.crop) for r in rb]
    assert json.loads((tmp_path / "b" / "stimulus_set.json").read_text())["parameters"][
        "fast_decode"
    ]


@pytest.mark.slow
def test_synthetic_set_end_to_end(tmp_path: Path) -> None:
    """The 20-object synthetic set through `confocal stimuli synth` and `build`: for every
    object and level, fewer de-cluttered than cluttered cells are on outside the object (cells
    that touch the object's mask excluded). The mean wide-DOF edge ratio is printed (0.096 with
    the synthetic scenes of 2026-11-21; the paper's photos gave 0.077)."""
    for args in (
        ["stimuli", "synth", "--out", str(tmp_path / "pairs"), "--training", "0"],
        ["stimuli", "build", str(tmp_path / "pairs"), "--out", str(tmp_path / "set")],
    ):
        with pytest.raises(SystemExit) as exc:
            main(args)
        assert exc.value.code == 0, args
    out = tmp_path / "set"
    recs = read_manifest(out / "manifest.csv")
    objects = sorted({r.object for r in recs})
    assert len(objects) == 20
    meta = json.loads((out / "stimulus_set.json").read_text())
    print(f"synthetic set: mean wide-DOF edge ratio {meta['mean_wide_edge_fraction']:.4f}")
    for oid in objects:
        mask = load_gray(tmp_path / "pairs" / oid / "mask.png") > 0
        for level in range(1, 9):
            on_outside = {}
            for r in recs:
                if r.object == oid and r.level == level and r.condition != "photo":
                    outside = block_mean(mask, (r.height, r.width)) == 0
                    on_outside[r.condition] = int(((_stim(out, r) > 0) & outside).sum())
            assert on_outside["decluttered"] < on_outside["cluttered"], (oid, level, on_outside)


def test_lightfield_subfolder_in_a_pairs_folder(tmp_path: Path, monkeypatch) -> None:
    """Folder form: an object folder holding lightfield.npz (or lightfield/) is a light field."""
    import stimuli.stimset.prepare
    from stimuli.stimset.lightfield import ConfocalPairImages

    wide, narrow, _ = make_pair(2, (200, 300))
    monkeypatch.setattr(
        stimuli.stimset.prepare,
        "load_confocal_pair",
        lambda src, info, params: ConfocalPairImages(wide, narrow, "disparity=0px,auto", None),
    )
    (tmp_path / "p" / "bust").mkdir(parents=True)
    (tmp_path / "p" / "bust" / "lightfield.npz").write_bytes(b"x")
    (tmp_path / "p" / "doll" / "lightfield").mkdir(parents=True)
    (tmp_path / "p" / "doll" / "lightfield" / "view0.png").write_bytes(b"y")
    inp = read_pairs(tmp_path / "p")
    assert [(s.object, s.kind, s.lightfield.name) for s in inp.sources] == [
        ("bust", "lightfield", "lightfield.npz"),
        ("doll", "lightfield", "lightfield"),
    ]
    r = build_stimulus_set(tmp_path / "p", tmp_path / "s", workers=1)
    assert r.n_stimuli == 2 * 17
