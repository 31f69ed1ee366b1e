"""Every remaining ``raise`` in the analysis package, with its message (house style H11)."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.data import read_trial_file
from analysis.errors import DataError
from analysis.power import iter_power
from analysis.simulate import design
from analysis.weibull import PsychometricPrior, aggregate
from experiment.cli import main


def test_folder_is_not_a_trial_file(tmp_path):
    with pytest.raises(DataError, match="is a folder, expected a trial file"):
        read_trial_file(tmp_path)


def test_garbage_parquet(tmp_path):
    p = tmp_path / "t.parquet"
    p.write_bytes(b"not parquet at all")
    with pytest.raises(DataError, match=r"t\.parquet: not a readable Parquet file"):
        read_trial_file(p)


def test_binary_csv(tmp_path):
    p = tmp_path / "t.csv"
    p.write_bytes(b"\xff\xfe\xfa\x00\x81" * 50)
    with pytest.raises(DataError, match=r"t\.csv: (not a readable CSV trial table|missing)"):
        read_trial_file(p)


def test_corrupt_sqlite(tmp_path):
    p = tmp_path / "s.sqlite"
    p.write_bytes(b"SQLite format 3\x00" + b"\x00\x01garbage" * 100)
    with pytest.raises(DataError, match=r"s\.sqlite: cannot (open|read) SQLite"):
        read_trial_file(p)


def test_prior_checks():
    with pytest.raises(ValueError, match=r"lapse_max must be in \(0, 1\), got 1.0"):
        PsychometricPrior((0, 1), (0, 1), lapse_max=1.0)
    with pytest.raises(ValueError, match=r"lapse_a and lapse_b must be > 0, got \(0, 10\)"):
        PsychometricPrior((0, 1), (0, 1), lapse_a=0, lapse_b=10)


def test_aggregate_checks():
    with pytest.raises(ValueError, match="x must contain at least one trial, got 0"):
        aggregate([], [])
    with pytest.raises(ValueError, match="x must be finite, got NaN or inf"):
        aggregate([np.nan], [1])


def test_design_and_power_checks():
    with pytest.raises(ValueError, match=r"n_subjects and n_objects must be >= 1, got \(0, 20\)"):
        design(n_subjects=0)
    with pytest.raises(ValueError, match=r"n_sims must be in \[1, 1000000\], got 0"):
        next(iter_power("odds_ratio", 2.0, [1], n_sims=0))
    with pytest.raises(ValueError, match=r"alpha must be in \(0, 1\), got 1.5"):
        next(iter_power("odds_ratio", 2.0, [1], alpha=1.5))


def test_report_over_a_file(tmp_path, small_result):
    from analysis.report import write_report

    f = tmp_path / "x"
    f.write_text("a file")
    with pytest.raises(DataError, match="exists and is not a folder; expected a report folder"):
        write_report(small_result, f, figures=False)


def test_report_never_replaces_a_non_empty_folder(tmp_path, small_result):
    from analysis.report import write_report

    (tmp_path / "thesis").mkdir()
    (tmp_path / "thesis" / "chapter1.tex").write_text("mine")
    with pytest.raises(DataError, match="thesis: folder is not empty"):
        write_report(small_result, tmp_path / "thesis", figures=False)
    assert (tmp_path / "thesis" / "chapter1.tex").read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["thesis"]


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--lapse-prior", "a,b"], "--lapse-prior must be 'a,b'"),
        (["--pc", "1.5"], "pc must be in (0, 1)"),
    ],
)
def test_cli_bad_options(tmp_path, small_csv, capsys, args, needle):
    with pytest.raises(SystemExit) as exc:
        main(["analyze", str(small_csv), "--out", str(tmp_path / "r"), *args])
    assert exc.value.code == 2
    assert needle in capsys.readouterr().err


def test_power_cli_bad_subjects(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["analyze", "power", "--odds-ratio", "2", "--subjects", "x"])
    assert exc.value.code == 2
    assert "--subjects must be integers" in capsys.readouterr().err
