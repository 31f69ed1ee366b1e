"""``confocal demo --active``: a simulated search drawn from its log."""

from __future__ import annotations

import json
import sqlite3

import numpy as np
import pytest
from PIL import Image

from experiment.active import demo as active_demo
from experiment.errors import ConfocalError

SHAPE = (154, 192)


@pytest.fixture(scope="module")
def demo_dir(tmp_path_factory):
    """``confocal demo --active --out DIR``, run once through the CLI (small scene for speed)."""
    from experiment import cli

    out = tmp_path_factory.mktemp("active-demo") / "d"
    real = active_demo.run_active_demo
    lines: list[str] = []

    def small(path, **kw):
        lines.extend(real(path, shape_px=SHAPE, **kw))
        return lines

    mp = pytest.MonkeyPatch()
    mp.setattr(active_demo, "run_active_demo", small)
    try:
        with pytest.raises(SystemExit) as exc:
            cli.main(["demo", "--active", "--out", str(out)])
    finally:
        mp.undo()
    assert exc.value.code in (0, None)
    return out, lines


def test_demo_writes_animation_contact_sheet_log_and_report(demo_dir) -> None:
    out, lines = demo_dir
    con = sqlite3.connect(out / "active.sqlite")
    n_states = con.execute("SELECT count(*) FROM active_events WHERE kind = 'state'").fetchone()[0]
    n_answers = con.execute("SELECT count(*) FROM active_events WHERE kind = 'answer'").fetchone()[
        0
    ]
    con.close()
    assert n_answers == 3  # pedestrian, tree, building
    for name in ("search.gif", "search.png"):
        im = Image.open(out / name)
        assert im.n_frames == n_states  # one frame per logged displayed state
    first = np.asarray(Image.open(out / "search.png").convert("L"))
    assert first.std() > 10  # not a blank frame
    sheet = Image.open(out / "contact_sheet.png")
    assert sheet.width > 500 and sheet.height > 100
    results = json.loads((out / "report" / "results.json").read_text())
    assert results["active_search"]["simulated"] is True
    assert results["active_search"]["n_trials"] == 3
    assert "SIMULATED" in (out / "report" / "report.md").read_text()
    summary = json.loads((out / "active_demo.json").read_text())
    assert summary["frames"] == n_states and summary["simulated"] is True
    assert any("SIMULATED" in line for line in lines)


def test_render_frame_draws_four_panes_and_phosphenes() -> None:
    centre = np.full((40, 50), 0.5, np.float32)
    grid = np.zeros((4, 5), bool)
    grid[1, 2] = True
    frame = active_demo.render_frame(centre, centre, centre > 1, grid, "status", pane_px=(40, 50))
    a = np.asarray(frame.convert("L"))
    assert frame.size == (4 * 50 + 5 * 6, 40 + 34 + 6)
    implant = a[34 : 34 + 40, 6 + 3 * 56 : 6 + 3 * 56 + 50]
    # one lit phosphene in cell (1, 2): bright at its centre, dim at an unlit cell's centre
    assert implant[15, 25] > 200 and implant[5, 5] < 60


def test_demo_refuses_non_empty_folder(tmp_path) -> None:
    (tmp_path / "x.txt").write_text("keep")
    with pytest.raises(ConfocalError, match=r"--out folder is not empty; confocal never replaces"):
        active_demo.run_active_demo(tmp_path)
    with pytest.raises(ConfocalError, match=r"^seed must be an integer >= 0"):
        active_demo.run_active_demo(tmp_path / "new", seed=-1)
    assert (tmp_path / "x.txt").read_text() == "keep"
