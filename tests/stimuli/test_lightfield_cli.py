"""``confocal lightfield synth | scan | refocus`` through the real entry point."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from PIL import Image

from experiment.cli import main
from stimuli.lightfield import load_lightfield
from stimuli.lightfield_cli import parse_grid, parse_zoom
from stimuli.planes import PlaneScan


def _ok(args):
    """Run ``confocal ARGS``; success ends with SystemExit(0) (typer's standalone mode)."""
    try:
        main(args)
    except SystemExit as exc:
        assert exc.code in (0, None), exc.code


def _run(args, capsys):
    _ok(args)
    return capsys.readouterr().out


@pytest.fixture(scope="module")
def sim_png(tmp_path_factory):
    out = tmp_path_factory.mktemp("lfcli") / "sim.png"
    _ok(["lightfield", "synth", "--out", str(out), "--size", "96x77"])
    return out


def test_synth_writes_an_elemental_image_with_geometry(sim_png):
    assert Image.open(sim_png).size == (960, 770)
    text = sim_png.with_suffix(".toml").read_text()
    assert 'kind = "lens_array"' in text and "pitch_px = 10" in text
    lf = load_lightfield(sim_png)
    assert lf.grid == (10, 10) and lf.shape_px == (77, 96)
    assert lf.geometry.relay_minification == 40.0


def test_synth_folder_and_npz(tmp_path, capsys):
    _run(
        [
            "lightfield",
            "synth",
            "--out",
            str(tmp_path / "cam"),
            "--kind",
            "camera",
            "--size",
            "40x30",
        ],
        capsys,
    )
    lf = load_lightfield(tmp_path / "cam")
    assert lf.grid == (9, 9) and lf.geometry.kind == "camera_array"
    _run(["lightfield", "synth", "--out", str(tmp_path / "s.npz"), "--size", "40x30"], capsys)
    default = load_lightfield(tmp_path / "s.npz")
    # one convention for the three-plane scene: the camera array, pedestrian +12 px/view
    assert default.geometry.kind == "camera_array"
    np.testing.assert_allclose([default.disparity_px(z) for z in (1, 4, 9)], [12, 3, 4 / 3])
    lens = ["lightfield", "synth", "--out", str(tmp_path / "l.npz"), "--size", "40x30"]
    _run([*lens, "--kind", "lens"], capsys)
    assert load_lightfield(tmp_path / "l.npz").geometry.kind == "lens_array"


# The 77x96 px test views leave 10 edge pixels per Haar sub-band: the scan warns, as it should.
@pytest.mark.filterwarnings("ignore:only .* edge pixels per Haar sub-band")
def test_scan_writes_planes_csv_plot_and_plane_images(sim_png, tmp_path, capsys):
    out = tmp_path / "scan"
    text = _run(
        [
            "lightfield",
            "scan",
            str(sim_png),
            "--out",
            str(out),
            "--planes",
            "40",
            "--near",
            "0.5",
            "--far",
            "12",
            "--binning",
            "1",
            "--grid",
            "19x15",
        ],
        capsys,
    )
    with open(out / "planes.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 40
    # planes.csv holds the scan's rows (PlaneScan.rows, whose columns test_planes pins)
    scan = PlaneScan.from_dict(json.loads((out / "scan.json").read_text()))
    assert rows == [{k: str(v) for k, v in r.items()} for r in scan.rows()]
    assert float(rows[0]["depth_m"]) == pytest.approx(0.5)
    n_peaks = sum(int(r["peak"]) for r in rows)
    assert n_peaks >= 1 and f"{n_peaks} object plane(s) in 40 planes" in text
    assert Image.open(out / "scores.png").size == (700, 360)
    assert json.loads((out / "scan.json").read_text())["binning"] == 1
    grid = np.asarray(Image.open(out / "plane01_grid.png"))
    assert grid.shape == (15, 19)
    assert Image.open(out / "plane01_edges.png").size == (96, 77)


def test_refocus_zoom_grid_and_stack(sim_png, tmp_path, capsys):
    img = tmp_path / "r.png"
    _run(
        [
            "lightfield",
            "refocus",
            str(sim_png),
            "--depth",
            "1",
            "--out",
            str(img),
            "--zoom",
            "10,5,40,50",
            "--grid",
            "10x12",
        ],
        capsys,
    )
    assert Image.open(img).size == (40, 50)
    assert np.asarray(Image.open(tmp_path / "r_grid.png")).shape == (12, 10)
    _run(
        [
            "lightfield",
            "refocus",
            str(sim_png),
            "--stack",
            "--out",
            str(tmp_path / "st"),
            "--planes",
            "4",
            "--disparities=-0.5:-3",
        ],
        capsys,
    )
    assert len(list((tmp_path / "st").glob("plane*.png"))) == 4


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["refocus", "{lf}", "--depth", "30", "--out", "{tmp}/x.png"], "outside the geometry"),
        (["refocus", "{lf}", "--out", "{tmp}/x.png"], "exactly one of --depth"),
        (
            ["refocus", "{lf}", "--disparity", "1", "--zoom", "1,2,3", "--out", "{tmp}/x.png"],
            "--zoom must be",
        ),
        (["scan", "{lf}", "--out", "{tmp}/s", "--near", "1"], "--near and --far go together"),
        (["scan", "{tmp}/missing", "--out", "{tmp}/s"], "light field not found"),
        (["scan", "{lf}", "--out", "{tmp}/s", "--grid", "38by25"], "--grid must be COLSxROWS"),
        (["synth", "--out", "{tmp}/x.png", "--kind", "mirror"], "--kind must be"),
    ],
)
def test_bad_input_exits_2_with_one_line(sim_png, tmp_path, capsys, args, message):
    argv = ["lightfield"] + [a.format(lf=sim_png, tmp=tmp_path) for a in args]
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err


def test_too_few_lenslets_exits_2(tmp_path, capsys):
    Image.fromarray(np.zeros((15, 41), np.uint8)).save(tmp_path / "ei.png")
    with pytest.raises(SystemExit) as exc:
        main(
            [
                "lightfield",
                "refocus",
                str(tmp_path / "ei.png"),
                "--pitch",
                "10",
                "--disparity",
                "0",
                "--out",
                str(tmp_path / "o.png"),
            ]
        )
    assert exc.value.code == 2
    assert "ei.png: lenslet pitch 10 px leaves fewer than 2x2" in capsys.readouterr().err


def test_parsers():
    assert parse_grid("38x25") == (25, 38)
    assert parse_zoom("1,2,30,40", (100, 100)) == (slice(2, 42), slice(1, 31))
