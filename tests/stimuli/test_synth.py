"""Synthetic photo pairs: object kinds, scenes, the PAIRS folder, and the de-cluttering claim."""

from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np
import pytest

import stimuli.declutter as declutter_mod
from stimuli import jung2015, synth
from stimuli.compress import block_mean, compress, grid_shape
from stimuli.declutter import declutter, sobel_magnitude
from stimuli.errors import InputError
from stimuli.io import load_gray
from stimuli.scene import ThinLensCamera
from stimuli.synth import (
    BACKGROUND_DEPTHS_M,
    OBJECTS_CSV_COLUMNS,
    ObjectKind,
    make_scene,
    object_kinds,
    object_mask,
    object_width_px,
    write_pairs,
)

SMALL_CAM = ThinLensCamera(shape_px=(82, 123))


@pytest.fixture(scope="module")
def pairs(tmp_path_factory) -> Path:
    """The default set: 20 main + 3 training objects at 492x327, seed 0."""
    return write_pairs(tmp_path_factory.mktemp("synth") / "PAIRS")


def _read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _threshold(narrow: np.ndarray) -> float:
    """The builder's automatic threshold when it exists, else the narrow image's 90th percentile."""
    auto = getattr(declutter_mod, "auto_threshold", None)
    if auto is not None:
        return float(auto(narrow))
    return float(np.percentile(sobel_magnitude(narrow), 90))


# --- object kinds -----------------------------------------------------------------------------


def test_there_are_23_distinct_nameable_kinds_with_answers() -> None:
    kinds = object_kinds()
    assert len(kinds) >= 23
    assert all(isinstance(k, ObjectKind) for k in kinds)
    assert len({k.name for k in kinds}) == len(kinds)
    assert len({k.display_name for k in kinds}) == len(kinds)
    for k in kinds:
        assert k.synonyms and k.uses, k.name
        assert all(s and ";" not in s and "," not in s for s in (*k.synonyms, *k.uses)), k.name
    scissors = next(k for k in kinds if k.name == "scissors")
    assert "shears" in scissors.synonyms and "cutting" in scissors.uses


def test_object_kinds_is_a_copy() -> None:
    object_kinds().clear()
    assert len(object_kinds()) >= 23


def test_the_answer_tables_and_the_drawers_name_the_same_kinds() -> None:
    from stimuli.objects import registry

    names = [k.name for k in object_kinds()]
    assert list(registry._USES) == names
    assert set(registry._DISPLAY_NAMES) <= set(names)
    assert set(registry.DRAWERS) == set(names)


# --- scenes -----------------------------------------------------------------------------------


def test_scene_is_deterministic_by_seed() -> None:
    a = make_scene("mug", rng=5, camera=SMALL_CAM)
    b = make_scene("mug", rng=np.random.default_rng(5), camera=SMALL_CAM)
    c = make_scene("mug", rng=6, camera=SMALL_CAM)
    assert [la.name for la in a] == [la.name for la in b]
    for la, lb in zip(a, b, strict=True):
        np.testing.assert_array_equal(la.texture, lb.texture)
        np.testing.assert_array_equal(la.alpha, lb.alpha)
        assert la.depth_m == lb.depth_m
    assert any(
        la.texture.shape != lc.texture.shape or not np.array_equal(la.texture, lc.texture)
        for la, lc in zip(a, c, strict=True)
    )


@pytest.mark.parametrize("kind", [k.name for k in object_kinds()])
def test_scene_layers_depths_and_object_placement(kind) -> None:
    cam = ThinLensCamera()
    layers = make_scene(kind, rng=0, camera=cam)
    obj = [la for la in layers if la.name.startswith("object:")]
    assert [la.name for la in obj] == [f"object:{kind}"]
    assert obj[0].depth_m == cam.focus_m
    background = [la for la in layers if not la.name.startswith("object:")]
    assert len(background) >= 3
    assert len({la.depth_m for la in background}) == len(background)
    for la in background:
        assert BACKGROUND_DEPTHS_M[0] <= la.depth_m <= BACKGROUND_DEPTHS_M[1]
        assert la.texture.dtype == np.float32 and la.texture.shape[0] > cam.shape_px[0]
    # Together the background layers cover the whole image (no holes to black).
    cover = np.zeros(layers[0].alpha.shape)
    for la in background:
        cover = la.alpha + (1 - la.alpha) * cover
    assert cover.min() > 0.999

    mask = object_mask(layers, cam) > 0.5
    rows, cols = np.nonzero(mask)
    h, w = cam.shape_px
    assert mask.mean() > 0.01
    assert rows.max() > 0.9 * h, "object does not reach the bottom of the image"
    assert abs((cols.min() + cols.max()) / 2 - (w - 1) / 2) < 0.12 * w, "object not centred"
    # About 10 deg wide: thin objects (utensils) are narrower, none wider than ~1.4x.
    width = cols.max() - cols.min() + 1
    assert 0.3 * object_width_px(cam) < width < 1.4 * object_width_px(cam)
    assert rows.min() > 0.05 * h, "object leaves the top of the image"


def test_object_width_is_ten_degrees() -> None:
    cam = ThinLensCamera()
    # 10 deg of a 25 deg field on 492 px, by the pinhole model: tan ratio, not angle ratio.
    expected = 492 * np.tan(np.radians(5.0)) / np.tan(np.radians(12.5))
    assert object_width_px(cam) == pytest.approx(expected)


def test_make_scene_rejects_bad_arguments() -> None:
    with pytest.raises(InputError, match="kind must be one of"):
        make_scene("unicorn", rng=0)
    with pytest.raises(InputError, match="margin_px"):
        make_scene("mug", rng=0, camera=SMALL_CAM, margin_px=-1)
    with pytest.raises(InputError, match="camera must be a ThinLensCamera"):
        make_scene("mug", rng=0, camera=(327, 492))


def test_object_mask_needs_an_object_layer() -> None:
    layers = make_scene("key", rng=0, camera=SMALL_CAM)
    with pytest.raises(InputError, match="object:<kind>"):
        object_mask(layers[:-1], SMALL_CAM)


def test_make_scene_does_not_touch_global_random_state() -> None:
    # The legacy global generator is exactly what H18 forbids touching.
    np.random.seed(1)  # noqa: NPY002
    before = np.random.random()  # noqa: NPY002
    np.random.seed(1)  # noqa: NPY002
    make_scene("cup", rng=3, camera=SMALL_CAM)
    assert np.random.random() == before  # noqa: NPY002


# --- PAIRS folder -----------------------------------------------------------------------------


def test_pairs_folder_layout_and_objects_csv(pairs: Path) -> None:
    rows = _read_csv(pairs / "objects.csv")
    assert list(rows[0].keys()) == list(OBJECTS_CSV_COLUMNS)
    assert [r["role"] for r in rows] == ["main"] * 20 + ["training"] * 3
    assert len({r["object"] for r in rows}) == 23
    assert len({r["name"] for r in rows}) == 23
    kinds = object_kinds()
    for r, k in zip(rows, kinds, strict=False):
        assert r["object"].endswith("_" + k.name)
        assert r["name"] == k.display_name
        assert r["synonyms"].split(";") == list(k.synonyms)
        assert r["uses"].split(";") == list(k.uses)
        for col in ("sobel_threshold", "crop", "plane_depth_m", "plane_disparity_px"):
            assert r[col] == ""
        d = pairs / r["object"]
        assert sorted(p.name for p in d.iterdir()) == ["mask.png", "narrow.png", "wide.png"]
    assert rows[0]["object"] == "obj01_cup" and rows[20]["object"] == "train01_screwdriver"
    assert sorted(p.name for p in pairs.iterdir() if p.is_file()) == ["objects.csv", "synth.json"]


def test_pairs_images_have_the_working_size_and_the_masks_are_bottom_centre(pairs: Path) -> None:
    for r in _read_csv(pairs / "objects.csv"):
        d = pairs / r["object"]
        wide, narrow, mask = (load_gray(d / f"{n}.png") for n in ("wide", "narrow", "mask"))
        assert wide.shape == narrow.shape == mask.shape == jung2015.WORKING_SHAPE_PX
        m = mask > 0.5
        assert 0.01 < m.mean() < 0.5, r["object"]
        rows, cols = np.nonzero(m)
        assert (
            rows.max() > 0.9 * m.shape[0] and abs(cols.mean() - m.shape[1] / 2) < 0.12 * m.shape[1]
        )
        # Inside the mask the two photos agree (the object is in focus at both apertures),
        # away from its outline where the blurred background bleeds in.
        core = m.copy()
        for axis in (0, 1):
            core &= np.roll(m, 3, axis) & np.roll(m, -3, axis)
        opaque = core & (mask > 0.99)
        assert np.abs(wide[opaque] - narrow[opaque]).max() <= 1.5 / 255


def test_write_pairs_is_deterministic_and_independent_of_the_count(pairs: Path, tmp_path) -> None:
    small = write_pairs(tmp_path / "two", n_objects=2, n_training=1, seed=0)
    assert sorted(p.name for p in small.iterdir() if p.is_dir()) == [
        "obj01_cup",
        "obj02_mug",
        "train01_screwdriver",
    ]
    for name in ("obj01_cup", "obj02_mug", "train01_screwdriver"):
        for f in ("wide.png", "narrow.png", "mask.png"):
            assert (small / name / f).read_bytes() == (pairs / name / f).read_bytes()
    other = write_pairs(tmp_path / "seed1", n_objects=1, n_training=0, seed=1)
    assert (other / "obj01_cup" / "wide.png").read_bytes() != (
        pairs / "obj01_cup" / "wide.png"
    ).read_bytes()


@pytest.mark.parametrize(("n_main", "n_training"), [(20, 3), (2, 1), (26, 0), (1, 25), (23, 3)])
def test_every_object_written_is_a_different_kind(n_main, n_training) -> None:
    main, training = synth._assign_kinds(n_main, n_training)
    assert len(main) == n_main and len(training) == n_training
    assert len({k.name for k in main + training}) == n_main + n_training
    if n_training <= 3:
        assert [k.name for k in training] == ["screwdriver", "shoe", "chair"][:n_training]


def test_write_pairs_larger_shape_scales_the_scene(tmp_path) -> None:
    out = write_pairs(tmp_path / "big", n_objects=1, n_training=0, shape_px=(654, 984))
    mask = load_gray(out / "obj01_cup" / "mask.png") > 0.5
    assert mask.shape == (654, 984)
    small = write_pairs(tmp_path / "small", n_objects=1, n_training=0)
    m_small = load_gray(small / "obj01_cup" / "mask.png") > 0.5
    assert mask.mean() == pytest.approx(m_small.mean(), rel=0.05)


def test_write_pairs_never_replaces_a_non_empty_folder(tmp_path) -> None:
    out = tmp_path / "PAIRS"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    with pytest.raises(InputError, match="not empty"):
        write_pairs(out, n_objects=1, n_training=0)
    assert (out / "keep.txt").read_text() == "x"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["PAIRS"]
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"]


def test_write_pairs_accepts_an_empty_existing_folder(tmp_path) -> None:
    out = tmp_path / "PAIRS"
    out.mkdir()
    write_pairs(out, n_objects=1, n_training=0)
    assert (out / "objects.csv").is_file()


def test_write_pairs_leaves_nothing_behind_on_failure(tmp_path, monkeypatch) -> None:
    real = synth.render_pair
    calls = []

    def failing_render(layers, *, camera):
        calls.append(1)
        if len(calls) == 2:
            raise RuntimeError("disk on fire")
        return real(layers, camera=camera)

    monkeypatch.setattr(synth, "render_pair", failing_render)
    with pytest.raises(RuntimeError, match="disk on fire"):
        write_pairs(tmp_path / "PAIRS", n_objects=3, n_training=0)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_objects": 0}, "n_objects must be an integer >= 1"),
        ({"n_objects": 2.5}, "n_objects must be an integer >= 1"),
        ({"n_training": -1}, "n_training must be an integer >= 0"),
        ({"n_objects": 20, "n_training": 7}, "n_objects \\+ n_training must be <= 26"),
        ({"seed": -3}, "seed must be an integer >= 0"),
        ({"shape_px": (327,)}, "shape_px must be \\(rows, cols\\)"),
        ({"shape_px": "big"}, "shape_px must be \\(rows, cols\\)"),
        ({"shape_px": (16, 492)}, "shape_px must be at least"),
    ],
)
def test_write_pairs_rejects_bad_arguments(tmp_path, kwargs, match) -> None:
    with pytest.raises(InputError, match=match):
        write_pairs(tmp_path / "PAIRS", **kwargs)
    assert not (tmp_path / "PAIRS").exists()


def test_write_pairs_refuses_a_file_as_out_dir(tmp_path) -> None:
    f = tmp_path / "PAIRS"
    f.write_text("x")
    with pytest.raises(InputError, match="is not a folder"):
        write_pairs(f, n_objects=1, n_training=0)


# --- the claim: de-cluttering removes background edges at every level ------------------------


def _outside_edge_counts(edges: np.ndarray, mask: np.ndarray, edge_ratio: float) -> list[int]:
    """On-cells outside the object, at every paper window (cells touching the mask excluded)."""
    counts = []
    for w in jung2015.WINDOWS_PX:
        shape = grid_shape(edges.shape, w)
        cells = compress(edges, shape, edge_ratio=edge_ratio) if w > 1 else edges
        outside = block_mean(mask, shape) == 0
        counts.append(int(cells[outside].sum()))
    return counts


def test_decluttered_stimuli_have_less_background_edge_mass_at_every_level(
    pairs: Path,
) -> None:
    rows = [r for r in _read_csv(pairs / "objects.csv") if r["role"] == "main"]
    assert len(rows) == 20
    images = []
    for r in rows:
        d = pairs / r["object"]
        wide, narrow = load_gray(d / "wide.png"), load_gray(d / "narrow.png")
        mask = load_gray(d / "mask.png") > 0.5
        t = _threshold(narrow)
        images.append(
            (r["object"], declutter(wide, threshold=t), declutter(narrow, threshold=t), mask)
        )
    # Edge ratio as the paper defines it: mean edge fraction of the wide-DOF edge images.
    edge_ratio = float(np.mean([ew.mean() for _, ew, _, _ in images]))
    print(f"\nmean wide-DOF edge ratio of the synthetic set: {edge_ratio:.4f}")
    assert 0.03 < edge_ratio < 0.3
    for name, ew, en, mask in images:
        cluttered = _outside_edge_counts(ew, mask, edge_ratio)
        decluttered = _outside_edge_counts(en, mask, edge_ratio)
        print(f"{name}: cluttered {cluttered} decluttered {decluttered}")
        assert all(dc < c for dc, c in zip(decluttered, cluttered, strict=True)), name
        # The object itself survives de-cluttering at full resolution.
        assert en[mask].mean() > 0.5 * ew[mask].mean(), name


def test_pairs_folder_is_written_atomically_with_no_temporary_left(pairs: Path) -> None:
    leftovers = [p for p in pairs.parent.iterdir() if p.name.startswith(".")]
    assert leftovers == []
    assert os.access(pairs / "objects.csv", os.R_OK)
