"""``analyze fit --p COL``: a proportion outside its range is refused with one line.

A ``--p`` column is read as proportions (0-1), or as percentages (0-100) when any value exceeds 1.
A column with both -- values above 1 beside fractions between 0 and 1 -- is a typo (``1.5``
among proportions), not a column of percentages below 2 %: it is refused, naming the column and
the rows.
"""

from __future__ import annotations

import pandas as pd
import pytest

from analysis.errors import DataError
from analysis.psychometric import FitSpec, counts_by_group
from tests.conftest import run_cli


def _counts(p):
    df = pd.DataFrame({"x": [1.0, 2.0, 4.0], "p": p, "n": [10, 10, 10]})
    return counts_by_group(df, FitSpec(x="x", p="p", n="n"), "t.csv")


def test_mixed_scales_are_refused_naming_column_and_rows():
    with pytest.raises(DataError, match=r"t\.csv: `p` column 'p' mixes .*1\.5 at data row 2"):
        _counts([0.2, 1.5, 0.9])


@pytest.mark.parametrize(
    ("p", "k"),
    [([0.2, 0.5, 1.0], [2, 5, 10]), ([20, 50, 100], [2, 5, 10]), ([0, 50, 100], [0, 5, 10])],
)
def test_one_scale_is_read(p, k):
    ((_, x, kk, n),) = [tuple(g) for g in _counts(p)]
    assert list(kk) == pytest.approx(k)


def test_fit_refuses_with_exit_2(tmp_path, capsys):
    t = tmp_path / "t.csv"
    t.write_text("x,p,n\n1,0.2,10\n2,1.5,10\n4,0.9,10\n")
    code = run_cli(["analyze", "fit", t, "--x", "x", "--p", "p", "--n", "n", "--out",
                    tmp_path / "o", "--no-plots"])  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "'p'" in err[0] and "t.csv" in err[0], err
    assert not (tmp_path / "o").exists()


def test_fit_tables_are_bounded(tmp_path, monkeypatch):
    import analysis.logreader as logreader
    from analysis.psychometric import read_table

    t = tmp_path / "t.csv"
    t.write_text("x,k,n\n" + "1,2,10\n" * 6)
    assert len(read_table(t)) == 6
    monkeypatch.setattr(logreader, "MAX_INPUT_ROWS", 5)
    with pytest.raises(DataError, match=r"t\.csv: more than 5 rows"):
        read_table(t)
    monkeypatch.setattr(logreader, "MAX_INPUT_BYTES", 10)
    with pytest.raises(DataError, match=r"t\.csv: .* GiB is larger than"):
        read_table(t)
