"""A folder of light-field captures: discovered one per sub-folder or file, scanned each into its
own output folder, in this process, in worker processes or on a Dask cluster."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from experiment.cli import main
from stimuli.errors import InputError
from stimuli.lfbatch import discover_captures, is_capture_folder, run_per_capture
from stimuli.lfsynth import render_camera_array, three_plane_scene


def _ok(args):
    try:
        main(args)
    except SystemExit as exc:
        assert exc.code in (0, None), exc.code


@pytest.fixture(scope="module")
def captures(tmp_path_factory):
    root = tmp_path_factory.mktemp("captures")
    for name, base in (("near", 0.03), ("far", 0.02)):
        lf = render_camera_array(
            three_plane_scene((64, 96)), grid=(3, 3), shape_px=(64, 96), baseline_m=base
        )
        np.save(root / f"{name}.npy", lf.views)
    (root / "notes.txt").write_text("not a capture")
    return root


def test_a_folder_of_captures_is_found(captures, tmp_path):
    assert is_capture_folder(captures)
    assert [p.name for p in discover_captures(captures)] == ["far.npy", "near.npy"]
    assert not is_capture_folder(captures / "near.npy")
    with pytest.raises(InputError, match="no light-field capture found"):
        discover_captures(tmp_path)


def test_scan_of_a_folder_writes_one_folder_per_capture(captures, tmp_path, capsys):
    out = tmp_path / "scans"
    _ok(["lightfield", "scan", str(captures), "--out", str(out), "--processes", "1"])
    text = capsys.readouterr().out
    assert (out / "near" / "planes.csv").is_file() and (out / "far" / "planes.csv").is_file()
    assert "scanned 2 capture(s)" in text and "near: " in text and "far: " in text


def _square(x):
    return x * x


def test_run_per_capture_in_worker_processes():
    got = dict(run_per_capture(_square, [(2,), (3,)], processes=2))
    assert got == {0: 4, 1: 9}


def test_cluster_without_dask_is_one_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "dask.distributed", None)
    with pytest.raises(InputError, match="`cluster` needs Dask: install the 'dask' extra"):
        list(run_per_capture(_square, [(2,)], cluster="tcp://127.0.0.1:1"))


def test_processes_below_one_is_refused():
    with pytest.raises(InputError, match="`processes` must be >= 1, got 0"):
        list(run_per_capture(_square, [(2,)], processes=0))


def test_build_reads_a_folder_of_captures_as_objects(captures):
    from stimuli.stimset.pairs import read_pairs

    pairs = read_pairs(captures)
    assert [s.object for s in pairs.sources] == ["far", "near"]
    assert all(s.kind == "lightfield" for s in pairs.sources)
    assert pairs.sources[1].lightfield == captures / "near.npy"
