"""Files written atomically get the user's umask, not mkstemp's private 0600."""

from __future__ import annotations

import os
import stat

import numpy as np
import pytest

from stimuli.io import atomic_path, current_umask, default_mode, save_png


@pytest.fixture(params=[0o022, 0o002], ids=["umask022", "umask002"])
def umask(request):
    old = os.umask(request.param)
    try:
        yield request.param
    finally:
        os.umask(old)


def mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def test_current_umask_reads_without_changing(umask):
    assert current_umask() == umask
    assert current_umask() == umask  # unchanged by reading
    assert default_mode() == 0o666 & ~umask
    assert default_mode(directory=True) == 0o777 & ~umask


def test_atomic_path_and_png_follow_umask(tmp_path, umask):
    with atomic_path(tmp_path / "a.txt") as tmp:
        tmp.write_text("x")
    save_png(np.zeros((2, 3), bool), tmp_path / "b.png")
    # reference: what a plain open() gives under the same umask
    (tmp_path / "plain.txt").write_text("x")
    expected = mode(tmp_path / "plain.txt")
    assert expected == 0o666 & ~umask
    assert mode(tmp_path / "a.txt") == expected
    assert mode(tmp_path / "b.png") == expected


def test_overwrite_keeps_umask_and_content_is_atomic(tmp_path, umask):
    target = tmp_path / "t.csv"
    target.write_text("old")
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("boom")
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]
    with atomic_path(target) as tmp:
        tmp.write_text("new")
    assert target.read_text() == "new" and mode(target) == 0o666 & ~umask


def test_report_folder_and_files_follow_umask(tmp_path, umask):
    from analysis.data import read_trials
    from analysis.pipeline import AnalysisOptions, analyze
    from analysis.report import write_report
    from analysis.simulate import simulate_weibull_trials
    from tests.analysis.conftest import TRUTH

    trials = simulate_weibull_trials(TRUTH, n_subjects=1, rng=1)
    csv_path = tmp_path / "t.csv"
    trials.to_csv(csv_path, index=False)
    result = list(analyze(read_trials([csv_path]), AnalysisOptions(seed=1)))[-1].result
    out = write_report(result, tmp_path / "rep", figures=False)
    assert mode(out) == 0o777 & ~umask
    assert mode(out / "results.json") == 0o666 & ~umask
