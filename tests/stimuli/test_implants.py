"""Implant layouts in ``stimuli`` and ``stimuli build --implant``.

The resampled grids are checked against :func:`stimuli.compress.compress` of the edge images
read back from the set's own window-1 PNGs, the recorded hashes against ``hashlib`` of the files
on disk, and the phosphene PNGs against :func:`stimuli.implants.render_phosphenes` of the grid
PNGs read back (8-bit rounding, so exact to half a grey step).
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from experiment.cli import main
from stimuli import jung2015
from stimuli.compress import block_mean, compress, compress_grey
from stimuli.datadirs import PROTOCOLS_DIR
from stimuli.errors import InputError
from stimuli.implants import (
    IMPLANTS_DIR,
    ImplantError,
    ImplantLayout,
    load_implant,
    render_phosphenes,
    to_implant_grid,
)
from stimuli.io import load_gray
from stimuli.manifest import read_manifest
from stimuli.stimset import IMPLANT_PX_PER_ELECTRODE, BuildParams, build_stimulus_set
from tests.stimuli._build_fixtures import write_pairs_folder

#: Photo size of the test pairs (3:2, as in tests/stimuli/test_build.py).
SHAPE_PX = (344, 516)

MINE = (
    'label = "Mine"\nkind = "cortical"\nrows = 7\ncols = 9\nfov_width_deg = 12\n'
    'fov_height_deg = 9\nphosphene_shape = "disc"\nphosphene_size = 0.9\ndropout = 0.3\n'
    "seed = 4\n"
)


def _png(path: Path) -> np.ndarray:
    return np.asarray(Image.open(path))


# -- to_implant_grid ----------------------------------------------------------------------------


def test_binary_stimulus_is_compressed_by_the_papers_rule() -> None:
    rng = np.random.default_rng(3)
    edges = rng.random((60, 100)) < 0.1
    before = edges.copy()
    lay = load_implant("argus2")
    grid = to_implant_grid(edges, lay)
    # independent: the window edge fraction against 1/13 (Jung et al. 2015, Sec. 2.2)
    assert grid.dtype == bool and grid.shape == (6, 10)
    np.testing.assert_array_equal(grid, block_mean(edges, (6, 10)) > 1 / 13)
    np.testing.assert_array_equal(grid, compress(edges, (6, 10), edge_ratio=jung2015.EDGE_RATIO))
    np.testing.assert_array_equal(edges, before)  # input not modified (H6)
    other = to_implant_grid(edges, lay, edge_ratio=0.2)
    np.testing.assert_array_equal(other, block_mean(edges, (6, 10)) > 0.2)


def test_grey_stimulus_gets_the_implants_levels() -> None:
    img = np.linspace(0, 1, 40 * 60, dtype=np.float32).reshape(40, 60)
    lay = load_implant("argus2").with_(levels=4)
    grid = to_implant_grid(img, lay)
    assert grid.dtype == np.float32 and grid.shape == (6, 10)
    # independent: window means, level k = min(floor(4 * mean), 3), shown as k / 3
    k = np.minimum(np.floor(block_mean(img, (6, 10)).astype(np.float64) * 4), 3)
    np.testing.assert_allclose(grid, k / 3, atol=1e-6)
    np.testing.assert_array_equal(grid, compress_grey(img, (6, 10), grey_levels=4))


def test_grid_finer_than_the_stimulus_and_bad_images_are_refused() -> None:
    lay = load_implant("alpha_ims")
    with pytest.raises(ImplantError, match=r"'alpha_ims': its 39x39 grid is finer than the 30x20"):
        to_implant_grid(np.zeros((20, 30), bool), lay)
    with pytest.raises(InputError, match=r"image must be 2-D \(rows, cols\), got shape"):
        to_implant_grid(np.zeros((60, 60, 3), np.float32), lay)
    with pytest.raises(InputError, match=r"must be in \[0, 1\]"):
        to_implant_grid(np.full((60, 60), 2.0, np.float32), lay)
    with pytest.raises(TypeError, match="layout must be an ImplantLayout, got str"):
        to_implant_grid(np.zeros((60, 60), bool), "argus2")


def test_implant_error_is_an_input_error_with_exit_status_2() -> None:
    """The CLI prints stimuli's InputError family as one line and exits 2 (experiment.cli.main)."""
    assert issubclass(ImplantError, InputError) and ImplantError.exit_code == 2


def test_shipped_folders_are_found_beside_the_packages() -> None:
    assert PROTOCOLS_DIR == Path(__file__).resolve().parents[2] / "protocols"
    assert IMPLANTS_DIR == PROTOCOLS_DIR / "implants"
    from experiment.protocol import PROTOCOLS_DIR as EXPERIMENT_PROTOCOLS_DIR

    assert EXPERIMENT_PROTOCOLS_DIR == PROTOCOLS_DIR


def test_stimuli_implants_import_without_experiment_or_gl() -> None:
    code = (
        "import sys, stimuli.implants, stimuli.stimset, stimuli.cli\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('experiment', 'moderngl')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


# -- stimuli build --implant --------------------------------------------------------------------


@pytest.fixture(scope="module")
def pairs(tmp_path_factory) -> Path:
    return write_pairs_folder(tmp_path_factory.mktemp("pairs") / "pairs", 3, SHAPE_PX)


@pytest.fixture(scope="module")
def built(pairs, tmp_path_factory):
    root = tmp_path_factory.mktemp("implants")
    mine = root / "mine.toml"
    mine.write_text(MINE)
    layouts = [load_implant("argus2"), load_implant(mine)]
    result = build_stimulus_set(pairs, root / "set", workers=2, implants=layouts)
    plain = build_stimulus_set(pairs, root / "plain", workers=2)
    return result, plain, layouts


def test_implant_grids_equal_an_independent_compression_of_the_edge_images(built) -> None:
    result, _, layouts = built
    out = result.out_dir
    meta = json.loads((out / "stimulus_set.json").read_text())
    full = {
        (r.object, r.condition): r
        for r in read_manifest(out / "manifest.csv")
        if r.window == 1 and r.condition in ("cluttered", "decluttered")
    }
    assert [m["name"] for m in meta["implants"]] == ["argus2", "mine"]
    n_objects = len(result.objects)
    assert result.implants == ("argus2", "mine") and result.n_implant_views == 2 * 2 * n_objects
    for entry, lay in zip(meta["implants"], layouts, strict=True):
        assert len(entry["files"]) == 2 * n_objects
        assert entry["px_per_electrode"] == IMPLANT_PX_PER_ELECTRODE
        for f in entry["files"]:
            edges = _png(out / full[(f["object"], f["condition"])].path) > 127
            expected = compress(edges, lay.shape, edge_ratio=result.edge_ratio)
            grid = _png(out / f["grid"]["path"])
            np.testing.assert_array_equal(grid > 127, expected)
            assert set(np.unique(grid)) <= {0, 255}
            assert (f["grid"]["width"], f["grid"]["height"]) == (lay.cols, lay.rows)


def test_phosphene_pngs_are_the_drawing_of_the_grid(built) -> None:
    result, _, layouts = built
    out = result.out_dir
    meta = json.loads((out / "stimulus_set.json").read_text())
    px = IMPLANT_PX_PER_ELECTRODE
    for entry, lay in zip(meta["implants"], layouts, strict=True):
        for f in entry["files"][:4]:
            grid = _png(out / f["grid"]["path"]) > 127
            drawn = render_phosphenes(
                grid,
                (lay.rows * px, lay.cols * px),
                shape=lay.phosphene_shape,
                size=lay.phosphene_size,
                alive=lay.alive_mask(),
            )
            got = _png(out / f["phosphenes"]["path"]).astype(np.float32) / 255
            assert got.shape == (lay.rows * px, lay.cols * px)
            np.testing.assert_allclose(got, drawn, atol=0.5 / 255 + 1e-6)
    dead = ~layouts[1].alive_mask()
    assert dead.any(), "the user's layout has dead electrodes (dropout 0.3, seed 4)"


def test_every_implant_file_is_hashed_and_the_layout_is_recorded_whole(built) -> None:
    result, _, layouts = built
    out = result.out_dir
    meta = json.loads((out / "stimulus_set.json").read_text())
    listed = set()
    for entry, lay in zip(meta["implants"], layouts, strict=True):
        assert ImplantLayout.from_dict(entry["layout"]) == lay  # self-describing, even for mine
        for f in entry["files"]:
            for kind in ("grid", "phosphenes"):
                p = out / f[kind]["path"]
                assert f[kind]["sha256"] == hashlib.sha256(p.read_bytes()).hexdigest()
                listed.add(p)
    on_disk = {p for p in (out / "implants").rglob("*") if p.is_file()}
    assert on_disk == listed


def test_implant_views_leave_the_stimuli_and_manifest_unchanged(built) -> None:
    result, plain, _ = built
    a = (result.out_dir / "manifest.csv").read_bytes()
    b = (plain.out_dir / "manifest.csv").read_bytes()
    assert a == b
    assert result.set_id != plain.set_id
    meta = json.loads((plain.out_dir / "stimulus_set.json").read_text())
    assert "implants" not in meta and not (plain.out_dir / "implants").exists()
    assert plain.implants == () and plain.n_implant_views == 0


def test_grey_mode_views_are_window_means_at_the_implants_levels(pairs, tmp_path) -> None:
    lay = load_implant("argus2").with_(levels=4)
    r = build_stimulus_set(
        pairs, tmp_path / "grey", params=BuildParams(mode="grey"), workers=1, implants=[lay]
    )
    meta = json.loads((r.out_dir / "stimulus_set.json").read_text())
    (entry,) = meta["implants"]
    assert entry["edge_ratio"] is None and entry["layout"]["levels"] == 4
    for f in entry["files"]:
        if f["condition"] != "cluttered":
            continue
        # The view is made from the float working-size photo; photo.png holds it in 8 bits,
        # which moves a window mean by at most 0.5/255. Cells further than that from a level
        # boundary k / 4 (quantize: floor(4 * mean)) must agree exactly.
        photo = load_gray(r.out_dir / f["object"] / "photo.png")
        means = block_mean(photo, lay.shape)
        expected = compress_grey(photo, lay.shape, grey_levels=4)
        far = np.abs(means * 4 - np.round(means * 4)) > 4 * 0.6 / 255
        got = load_gray(r.out_dir / f["grid"]["path"])
        np.testing.assert_allclose(got[far], expected[far], atol=0.5 / 255)
        assert far.mean() > 0.8


def test_cli_build_with_shipped_and_own_implant(pairs, tmp_path, capsys) -> None:
    mine = tmp_path / "mine.toml"
    mine.write_text(MINE)
    out = tmp_path / "set"
    main_args = ["stimuli", "build", str(pairs), "--out", str(out)]
    with pytest.raises(SystemExit) as exc:
        main([*main_args, "--implant", "brainport", "--implant", str(mine), "--implant-px", "4"])
    assert exc.value.code in (0, None)
    assert "implant views (brainport, mine)" in capsys.readouterr().out
    meta = json.loads((out / "stimulus_set.json").read_text())
    assert [m["px_per_electrode"] for m in meta["implants"]] == [4, 4]
    assert _png(out / meta["implants"][0]["files"][0]["phosphenes"]["path"]).shape == (80, 80)


def test_cli_default_px_per_electrode_is_the_builds() -> None:
    import inspect

    from stimuli.cli import build_command

    default = inspect.signature(build_command).parameters["implant_px"].default
    assert default == IMPLANT_PX_PER_ELECTRODE


def test_bad_implant_arguments_are_refused_before_reading(pairs, tmp_path) -> None:
    out = tmp_path / "set"
    argus = load_implant("argus2")
    with pytest.raises(ImplantError, match=r"`implants` alpha_ims: its 39x39 grid is finer than"):
        build_stimulus_set(
            pairs,
            out,
            params=BuildParams(working_shape_px=(30, 45)),
            implants=[load_implant("alpha_ims")],
        )
    with pytest.raises(ImplantError, match="two layouts are named 'argus2'"):
        build_stimulus_set(pairs, out, implants=[argus, argus.with_(rows=3)])
    with pytest.raises(ImplantError, match=r"layout name '\.\./x' cannot name a folder"):
        build_stimulus_set(pairs, out, implants=[argus.with_(name="../x")])
    with pytest.raises(InputError, match="implants must hold ImplantLayout objects, got str"):
        build_stimulus_set(pairs, out, implants=["argus2"])
    with pytest.raises(InputError, match=r"implant_px_per_electrode must be an integer in \[1"):
        build_stimulus_set(pairs, out, implants=[argus], implant_px_per_electrode=0)
    assert not out.exists()


def test_an_object_named_implants_is_refused_with_implant_views(tmp_path) -> None:
    pairs = write_pairs_folder(tmp_path / "pairs", 1, SHAPE_PX)
    (only,) = [p for p in pairs.iterdir() if p.is_dir()]
    only.rename(pairs / "implants")
    with pytest.raises(InputError, match="an object is named 'implants'"):
        build_stimulus_set(pairs, tmp_path / "set", implants=[load_implant("argus2")])
    assert not (tmp_path / "set").exists()
