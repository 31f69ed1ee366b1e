"""De-clutter methods as a registry, and builds whose conditions are method names."""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from stimuli.declutter import declutter
from stimuli.errors import InputError
from stimuli.methods import MethodInput, available_methods, get_method, parse_conditions
from tests.conftest import run_cli
from tests.stimuli._build_fixtures import make_pair, write_png

SHAPE = (120, 180)
WORK = "120x80"


def _inp(seed=0, **kw):
    wide, narrow, mask = make_pair(seed, SHAPE)
    return MethodInput("obj", wide, narrow, 0.1, mask=mask, **kw), mask


def _pairs(root: Path, n: int = 2, masks: bool = True) -> Path:
    for i in range(n):
        wide, narrow, mask = make_pair(i, SHAPE)
        write_png(wide, root / f"obj{i:02d}" / "wide.png")
        write_png(narrow, root / f"obj{i:02d}" / "narrow.png")
        if masks:
            write_png(mask.astype(np.float32), root / f"obj{i:02d}" / "mask.png")
    return root


def _conditions(manifest: Path) -> dict[str, int]:
    with open(manifest, newline="") as f:
        rows = list(csv.DictReader(f))
    out: dict[str, int] = {}
    for r in rows:
        out[r["condition"]] = out.get(r["condition"], 0) + 1
    return out


def test_listed_methods(capsys):
    assert run_cli(["stimuli", "methods"]) == 0
    out = capsys.readouterr().out
    for name in ("sobel", "depth", "mask", "segment", "saliency", "cluttered"):
        assert any(line.startswith(name + " ") for line in out.splitlines()), name
    assert "alias: decluttered" in out


def test_sobel_is_the_papers_declutter():
    inp, _ = _inp()
    r = get_method("decluttered").run(inp)
    assert np.array_equal(r.edges, declutter(inp.narrow, threshold=0.1))


def test_region_methods_keep_the_object():
    """Mask edges all lie on or next to the object; they keep its outline; segment and saliency
    return edge images of the working size."""
    from scipy.ndimage import binary_dilation, binary_erosion

    inp, mask = _inp(1)
    near = binary_dilation(mask, iterations=1)
    outline = mask & ~binary_erosion(mask)
    e = get_method("mask").run(inp).edges
    assert e.any() and not (e & ~near).any()
    assert (binary_dilation(e) & outline).sum() >= 0.9 * outline.sum()
    for name in ("segment", "saliency"):
        r = get_method(name).run(inp)
        assert r.edges.dtype == bool and r.edges.shape == SHAPE
        assert 0 <= r.measured["region_share"] <= 1


def test_missing_inputs_are_one_line():
    inp, _ = _inp()
    with pytest.raises(InputError, match="depth needs a light field"):
        get_method("depth").run(inp)
    no_mask = MethodInput("cup", inp.wide, inp.narrow, 0.1)
    with pytest.raises(InputError, match="'cup' has no mask"):
        get_method("mask").run(no_mask)


def test_parse_conditions():
    assert parse_conditions(None) == ("cluttered", "decluttered")
    assert parse_conditions("cluttered,sobel,mask") == ("cluttered", "sobel", "mask")
    for bad, msg in (("cluttered,sobel,decluttered", "repeats"), ("x", "unknown condition")):
        with pytest.raises(InputError, match=msg):
            parse_conditions(bad)


def test_build_four_conditions(tmp_path):
    """The issue's build: every condition at every level; the paper's condition the same images
    as in a default build; the record names each condition's method and version."""
    pairs = _pairs(tmp_path / "pairs")
    out = tmp_path / "set"
    argv = ["stimuli", "build", pairs, "--out", out, "--working-size", WORK]
    assert run_cli([*argv, "--conditions", "cluttered,decluttered,mask,segment"]) == 0
    counts = _conditions(out / "manifest.csv")
    assert {c: counts[c] for c in ("cluttered", "decluttered", "mask", "segment")} == dict.fromkeys(
        ("cluttered", "decluttered", "mask", "segment"), 16
    )
    meta = json.loads((out / "stimulus_set.json").read_text())
    assert meta["conditions"]["segment"]["method"] == "segment"
    assert meta["conditions"]["decluttered"]["alias_of"] == "sobel"
    assert meta["conditions"]["mask"]["version"]
    assert set(meta["conditions"]["mask"]["measured"]) == {"obj00", "obj01"}
    assert meta["parameters"]["conditions"] == ["cluttered", "decluttered", "mask", "segment"]
    base = tmp_path / "base"
    assert run_cli(["stimuli", "build", pairs, "--out", base, "--working-size", WORK]) == 0
    assert "conditions" not in json.loads((base / "stimulus_set.json").read_text())
    for name in ("cluttered_L1_w40.png", "decluttered_L8_w01.png", "decluttered_L3_w13.png"):
        assert (out / "obj01" / name).read_bytes() == (base / "obj01" / name).read_bytes()
    assert meta["set_id"] != json.loads((base / "stimulus_set.json").read_text())["set_id"]


def test_missing_mask_names_the_object(tmp_path, capsys):
    pairs = _pairs(tmp_path / "pairs")
    (pairs / "obj01" / "mask.png").unlink()
    out = tmp_path / "set"
    argv = ["stimuli", "build", pairs, "--out", out, "--working-size", WORK]
    assert run_cli([*argv, "--conditions", "cluttered,mask"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'obj01' has no mask" in err[0]
    assert not out.exists()
    assert run_cli([*argv, "--conditions", "cluttered,depth"]) == 2
    assert "photo pair" in capsys.readouterr().err
    assert run_cli([*argv, "--conditions", "cluttered,mask", "--mode", "grey"]) == 2


TOY = '''
import numpy as np
from stimuli.methods import MethodResult


def top_half(images):
    """Keep the Sobel edges of the narrow photo in the top half (a toy plug-in)."""
    from stimuli.declutter import declutter

    e = declutter(images.narrow, threshold=images.threshold)
    e[e.shape[0] // 2 :] = False
    return MethodResult(e, {"rows_kept": int(e.shape[0] // 2)})
'''


def test_plugin_builds_a_set(tmp_path, monkeypatch, capsys):
    """A distribution that registers a method in confocal.declutter is listed and builds a set."""
    site = tmp_path / "site"
    (site / "toy_declutter.py").parent.mkdir(parents=True)
    (site / "toy_declutter.py").write_text(TOY)
    info = site / "toy_declutter-1.2.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: toy-declutter\nVersion: 1.2\n")
    (info / "entry_points.txt").write_text(
        "[confocal.declutter]\ntophalf = toy_declutter:top_half\n"
    )
    monkeypatch.syspath_prepend(str(site))
    assert "tophalf" in available_methods()[0]
    assert run_cli(["stimuli", "methods"]) == 0
    assert "toy plug-in" in capsys.readouterr().out
    pairs = _pairs(tmp_path / "pairs", masks=False)
    out = tmp_path / "set"
    argv = ["stimuli", "build", pairs, "--out", out, "--working-size", WORK]
    assert run_cli([*argv, "--conditions", "cluttered,tophalf"]) == 0
    assert _conditions(out / "manifest.csv")["tophalf"] == 16
    rec = json.loads((out / "stimulus_set.json").read_text())["conditions"]["tophalf"]
    assert rec["version"] == "1.2" and rec["measured"]["obj00"]["rows_kept"] == 40
    from PIL import Image

    full = np.asarray(Image.open(out / "obj00" / "tophalf_L8_w01.png"))
    assert full.any() and not full[40:].any()
    sys.modules.pop("toy_declutter", None)


@pytest.mark.slow
def test_depth_condition_of_a_light_field(tmp_path):
    """The depth method through the registry gives the build's own depth de-clutter, bit for
    bit; a light field de-cluttered by Sobel (no in-focus mask) refuses it in one line."""
    from stimuli.lfsynth import render_camera_array, three_plane_scene
    from stimuli.stimset import BuildParams, build_stimulus_set

    field = render_camera_array(
        three_plane_scene((120, 180)), grid=(1, 5), shape_px=(120, 180), baseline_m=0.03
    )
    np.savez(
        tmp_path / "scene.npz",
        views=field.views,
        geometry=json.dumps(field.geometry.to_dict()),
    )
    (tmp_path / "pairs.csv").write_text("object,lightfield\ntree,scene.npz\n")
    (tmp_path / "objects.csv").write_text("object,plane_depth_m\ntree,4.0\n")
    conds = ("cluttered", "decluttered", "depth")
    build_stimulus_set(
        tmp_path / "pairs.csv",
        tmp_path / "set",
        params=BuildParams(declutter="depth", conditions=conds, working_shape_px=(80, 120)),
        workers=1,
    )
    for name in ("L8_w01", "L3_w13"):
        depth = (tmp_path / "set" / "tree" / f"depth_{name}.png").read_bytes()
        assert depth == (tmp_path / "set" / "tree" / f"decluttered_{name}.png").read_bytes()
    with pytest.raises(InputError, match="de-cluttered by sobel"):
        build_stimulus_set(
            tmp_path / "pairs.csv",
            tmp_path / "set2",
            params=BuildParams(declutter="sobel", conditions=conds, working_shape_px=(80, 120)),
            workers=1,
        )
    assert not (tmp_path / "set2").exists()
