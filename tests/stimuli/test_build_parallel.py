"""``confocal stimuli build --processes N / --cluster ADDRESS``: the per-object work elsewhere.

Each object (a light-field capture or a photo pair) is read, de-cluttered, compressed and drawn
in a worker; the set that comes back must be the one a serial build writes, byte for byte (only
``built_utc`` in ``stimulus_set.json`` differs), and a failing capture must end as a serial
build does: one line naming it, exit status 2, nothing written.
"""

from __future__ import annotations

import errno
import hashlib
import json
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from experiment.cli import main
from stimuli.errors import InputError
from stimuli.lfbatch import run_per_capture
from stimuli.lfsynth import render_camera_array, three_plane_scene
from stimuli.stimset import BuildParams, build_stimulus_set
from tests.stimuli._build_fixtures import make_pair, write_png

_SMALL = ["--working-size", "123x82"]
_SMALL_PARAMS = BuildParams(working_shape_px=(82, 123))


@pytest.fixture(scope="module")
def pairs(tmp_path_factory) -> Path:
    """Two light-field captures and two photo pairs (one a training object), as object folders."""
    root = tmp_path_factory.mktemp("mixed")
    for i, base in enumerate((0.03, 0.02)):
        lf = render_camera_array(
            three_plane_scene((64, 96)), grid=(3, 3), shape_px=(64, 96), baseline_m=base
        )
        (root / f"lf{i}").mkdir()
        np.savez(root / f"lf{i}" / "lightfield.npz", views=lf.views)
    for i in range(2):
        wide, narrow, _ = make_pair(i, (82, 123))
        write_png(wide, root / f"photo{i}" / "wide.png")
        write_png(narrow, root / f"photo{i}" / "narrow.png")
    (root / "objects.csv").write_text("object,role\nphoto1,training\n")
    return root


def _hashes(folder: Path) -> dict[str, str]:
    """sha256 of every file of a set; ``stimulus_set.json`` without its build time."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if not p.is_file():
            continue
        data = p.read_bytes()
        if p.name == "stimulus_set.json":
            meta = json.loads(data)
            assert meta.pop("built_utc")
            data = json.dumps(meta, sort_keys=True).encode()
        out[p.relative_to(folder).as_posix()] = hashlib.sha256(data).hexdigest()
    return out


def _run(args: list[str]) -> int:
    try:
        main(args)
    except SystemExit as exc:
        return int(exc.code or 0)
    return 0


def _no_staging_left(parent: Path) -> bool:
    return not [p for p in parent.iterdir() if ".tmp-" in p.name]


@pytest.fixture(scope="module")
def serial(pairs, tmp_path_factory) -> dict[str, str]:
    out = tmp_path_factory.mktemp("serial") / "set"
    assert _run(["stimuli", "build", str(pairs), "--out", str(out), *_SMALL]) == 0
    return _hashes(out)


def test_two_processes_write_the_serial_set_byte_for_byte(pairs, serial, tmp_path, capsys):
    out = tmp_path / "set"
    rc = _run(["stimuli", "build", str(pairs), "--out", str(out), *_SMALL, "--processes", "2"])
    assert rc == 0, capsys.readouterr().err
    assert "for 4 objects" in capsys.readouterr().out
    got = _hashes(out)
    assert sorted(got) == sorted(serial)
    assert any(k.startswith("lf1/") for k in got) and "photo1/colour_wide.png" in got
    assert {k for k in got if got[k] != serial[k]} == set()


def test_progress_advances_once_per_finished_object(pairs, tmp_path):
    calls: list[tuple[str, int, int]] = []
    build_stimulus_set(
        pairs,
        tmp_path / "set",
        params=_SMALL_PARAMS,
        progress=lambda stage, done, total: calls.append((stage, done, total)),
        processes=2,
    )
    for stage in ("read", "write"):
        assert [(d, n) for s, d, n in calls if s == stage] == [(k, 4) for k in range(5)]


def test_a_corrupt_capture_is_one_line_naming_it_and_nothing_is_written(pairs, tmp_path, capsys):
    import shutil

    bad = tmp_path / "pairs"
    shutil.copytree(pairs, bad)
    (bad / "lf1" / "lightfield.npz").write_bytes(b"not a light field")
    out = tmp_path / "set"
    rc = _run(["stimuli", "build", str(bad), "--out", str(out), *_SMALL, "--processes", "2"])
    lines = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(lines) == 1, lines
    assert "lf1/lightfield.npz" in lines[0] and "Traceback" not in lines[0]
    assert not out.exists() and _no_staging_left(tmp_path)


def test_a_full_disk_while_workers_run_removes_the_partial_set(pairs, tmp_path, monkeypatch):
    import stimuli.stimset.write as write

    real = write._save_rendered
    saved: list[str] = []

    def fill_up(rendered, work, *args):
        if saved:
            raise OSError(errno.ENOSPC, "No space left on device")
        saved.append(work.info.object)
        return real(rendered, work, *args)

    monkeypatch.setattr(write, "_save_rendered", fill_up)
    out = tmp_path / "set"
    with pytest.raises(InputError, match="the disk is full"):
        build_stimulus_set(pairs, out, params=_SMALL_PARAMS, processes=2)
    assert saved and not out.exists() and _no_staging_left(tmp_path)


def _odd_square(x: int) -> int:
    warnings.warn(f"capture {x}: an object may lie beyond the scanned range", stacklevel=1)
    return x * x


def test_a_warning_in_a_worker_is_raised_here():
    with pytest.warns(UserWarning) as caught:
        got = dict(run_per_capture(_odd_square, [(2,), (3,)], processes=2))
    assert got == {0: 4, 1: 9}
    assert sorted(str(w.message)[:9] for w in caught) == ["capture 2", "capture 3"]


@pytest.mark.parametrize(
    "options, message",
    [
        (["--processes", "0"], "--processes must be >= 1, got 0"),
        (["--processes", "-3"], "--processes must be >= 1, got -3"),
        (["--processes", "2", "--cluster", "tcp://127.0.0.1:1"], "exclude each other"),
    ],
)
def test_bad_pool_options_are_one_line_before_any_work(pairs, tmp_path, capsys, options, message):
    out = tmp_path / "set"
    rc = _run(["stimuli", "build", str(pairs), "--out", str(out), *options])
    lines = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(lines) == 1 and message in lines[0], lines
    assert not out.exists() and _no_staging_left(tmp_path)


def test_cluster_without_dask_names_the_extra(pairs, tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "dask.distributed", None)
    out = tmp_path / "set"
    rc = _run(["stimuli", "build", str(pairs), "--out", str(out), "--cluster", "tcp://h:8786"])
    lines = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(lines) == 1 and "install the 'dask' extra" in lines[0], lines
    assert not out.exists()


def test_a_dask_cluster_writes_the_serial_set(pairs, serial, tmp_path):
    distributed = pytest.importorskip(
        "dask.distributed", reason="the optional 'dask' extra is not installed"
    )
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None
    ) as cluster:
        out = tmp_path / "set"
        address = cluster.scheduler_address
        args = ["stimuli", "build", str(pairs), "--out", str(out), *_SMALL, "--cluster", address]
        assert _run(args) == 0
    assert _hashes(out) == serial
