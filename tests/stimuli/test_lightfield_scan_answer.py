"""``confocal lightfield scan`` prints its answer before it writes, and draws no plot on request."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from experiment.cli import main
from stimuli.lightfield_steps import LoaderOptions, scan_one


@pytest.fixture(scope="module")
def sim_png(tmp_path_factory):
    out = tmp_path_factory.mktemp("lfanswer") / "sim.png"
    try:
        main(["lightfield", "synth", "--out", str(out), "--size", "96x77"])
    except SystemExit as exc:
        assert exc.code in (0, None)
    return out


def _opts(**kw):
    return {
        "planes": 40,
        "near": 0.5,
        "far": 12.0,
        "disparities": None,
        "grid": "19x15",
        "method": "agreement",
        "binning": 1,
        "fast": False,
        "declutter_mode": "auto",
        "threshold": "auto",
        "edge_ratio": 1 / 13,
    } | kw


def test_answer_is_emitted_before_the_folder_is_written(sim_png, tmp_path):
    out = tmp_path / "scan"
    seen = []

    def emit(line):
        seen.append((line, out.exists()))

    closing = scan_one(sim_png, out, _opts(), LoaderOptions(), emit)
    planes = [line for line, _ in seen if re.match(r"plane\d\d: ", line)]
    assert planes, seen
    assert not any(written for _, written in seen)  # every answer line came before the folder
    first_edges = next(i for i, (line, _) in enumerate(seen) if " edges: threshold " in line)
    assert all(not line.startswith("plane") or " edges: " in line for line, _ in seen[first_edges:])
    assert len(closing) == 1 and closing[0].startswith(f"{len(planes)} object plane(s)")
    assert (out / "scores.png").exists() and (out / "planes.csv").exists()


def test_without_emit_every_line_is_returned(sim_png, tmp_path):
    lines = scan_one(sim_png, tmp_path / "scan", _opts(), LoaderOptions())
    assert lines[0].startswith("plane01") and "object plane(s)" in lines[-1]


def test_no_plot_skips_the_figure_and_matplotlib(sim_png, tmp_path):
    out = tmp_path / "scan"
    code = (
        "import sys\n"
        "from experiment.cli import main\n"
        "try:\n"
        f"    main(['lightfield', 'scan', {str(sim_png)!r}, '--out', {str(out)!r}, '--planes',"
        " '40', '--near', '0.5', '--far', '12', '--binning', '1', '--no-plot'])\n"
        "except SystemExit as exc:\n"
        "    assert exc.code in (0, None), exc.code\n"
        "print('matplotlib' in sys.modules)\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert res.stdout.strip().splitlines()[-1] == "False"
    assert (out / "planes.csv").exists() and not (out / "scores.png").exists()


def test_the_answer_reads_the_scan_views_only_and_needs_no_compiled_code(tmp_path):
    """Before its answer, a scan of a folder of views reads only the views the agreement scan
    uses and runs no compiled code (numba's start-up, about 0.75 s, comes after the answer)."""
    import numpy as np
    from PIL import Image

    from stimuli.agreementscan import scan_views
    from stimuli.lfsynth import render_camera_array, three_plane_scene

    shape, grid = (70, 100), (5, 5)
    lf = render_camera_array(three_plane_scene(shape), grid=grid, shape_px=shape, baseline_m=0.03)
    folder = tmp_path / "views"
    folder.mkdir()
    for u in range(grid[0]):
        for v in range(grid[1]):
            a = np.round(lf.views[u, v] * 255).astype(np.uint8)
            Image.fromarray(a).save(folder / f"view_{u}_{v}.png")
    out = tmp_path / "scan"
    code = (
        "import sys\n"
        "import typer\n"
        "import stimuli.lfload as lfload\n"
        "reads = []\n"
        "read_all = lfload._read_all\n"
        "def counted(paths):\n"
        "    reads.append(len(paths))\n"
        "    return read_all(paths)\n"
        "lfload._read_all = counted\n"
        "echo = typer.echo\n"
        "def answer(message=None, *args, **kwargs):\n"
        "    if str(message).startswith('stimuli build --plane auto'):\n"
        "        print('AT-ANSWER', reads, 'numba' in sys.modules, flush=True)\n"
        "    return echo(message, *args, **kwargs)\n"
        "typer.echo = answer\n"
        "from experiment.cli import main\n"
        "try:\n"
        f"    main(['lightfield', 'scan', {str(folder)!r}, '--out', {str(out)!r}, '--no-plot'])\n"
        "except SystemExit as exc:\n"
        "    assert exc.code in (0, None), exc.code\n"
        "print('AT-EXIT', reads)\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    lines = res.stdout.splitlines()
    at_answer = next(line for line in lines if line.startswith("AT-ANSWER"))
    n_scan = len(scan_views(grid))
    assert at_answer == f"AT-ANSWER [{n_scan}] False", res.stdout
    assert lines[-1] == f"AT-EXIT [{n_scan}, {grid[0] * grid[1] - n_scan}]"  # then the others
    assert (out / "plane01_confocal.png").exists()


def test_a_folder_of_one_view_is_refused_naming_the_folder(tmp_path, capsys):
    import numpy as np
    from PIL import Image

    folder = tmp_path / "one"
    folder.mkdir()
    Image.fromarray(np.full((30, 40), 128, np.uint8)).save(folder / "view_0_0.png")
    with pytest.raises(SystemExit) as exc:
        main(["lightfield", "scan", str(folder), "--out", str(tmp_path / "scan")])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and str(folder) in err and "at least two views" in err
    assert not (tmp_path / "scan").exists()
