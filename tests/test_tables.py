"""Formula-safe CSV/TSV cells: both copies of the rule agree, round-trip, and every writer uses it.

The rule (OWASP "CSV injection"): a text cell starting with ``=``, ``+``, ``-``, ``@``, a tab or
a carriage return that is not a plain number is written behind a single quote; the readers take
it off. ``stimuli/tables.py`` and ``analysis/tables.py`` are two copies because the packages may
not import each other (house style H1).
"""

from __future__ import annotations

import csv
import io

import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

import analysis.tables as at
import stimuli.tables as stt

#: Text that often starts with a trigger or with quotes before one, and has separators inside.
_PIECES = st.sampled_from(
    ["=", "+", "-", "@", "\t", "\r", "'", "''", "'=", ";", ",", "|", "1", "a"]
)
CELLS = st.one_of(
    st.text(),
    st.builds(lambda a, b: a + b, _PIECES, st.text()),
    st.lists(st.one_of(_PIECES, st.text(max_size=3)), max_size=12).map("".join),
    # fmt: skip
)

HOSTILE = ['=HYPERLINK("http://x","cup")', "+1+cmd", "-2+3", "@SUM(A1)", "\tx", "\rx", "'=x"]

#: One table of cases for both copies of the rule: (text, as written). A trigger after a
#: separator (``;``, ``,``, tab, ``|``) inside a cell is escaped too: a spreadsheet whose list
#: separator is ``;`` splits ``cup;=1+1`` into ``cup`` and a live formula.
CASES = [
    ("cup", "cup"),
    ("=1+1", "'=1+1"),
    ("-1.5", "-1.5"),
    ("+3", "+3"),
    ("cup;=1+1", "cup;'=1+1"),
    ("cup,=1+1", "cup,'=1+1"),
    ("cup\t=1+1", "cup\t'=1+1"),
    ("cup|=1+1", "cup|'=1+1"),
    ("a;+cmd|calc", "a;'+cmd|calc"),
    ("a;@SUM(A1)", "a;'@SUM(A1)"),
    ("a;\rx", "a;'\rx"),
    ("a;-2", "a;-2"),
    ("1,-2", "1,-2"),
    ("a;-2;=3", "a;'-2;'=3"),
    ("a|-1;=2", "a|'-1;'=2"),
    ("=a;=b", "'=a;'=b"),
    ("\t=1", "'\t'=1"),
    ("'=x", "''=x"),
    ("a;'=x", "a;''=x"),
    ("a;'b", "a;'b"),
    ("it's;ok", "it's;ok"),
    ("a;", "a;"),
    (";", ";"),
    ("", ""),
]


@pytest.mark.parametrize("module", [stt, at], ids=["stimuli", "analysis"])
@pytest.mark.parametrize(("text", "written"), CASES)
def test_shared_cases(module, text, written):
    assert module.escape_cell(text) == written
    assert module.unescape_cell(written) == text


@given(CELLS)
def test_both_copies_agree_and_round_trip(text):
    assert stt.escape_cell(text) == at.escape_cell(text)
    assert stt.unescape_cell(text) == at.unescape_cell(text)
    assert stt.unescape_cell(stt.escape_cell(text)) == text
    assert at.unescape_cell(at.escape_cell(text)) == text


@given(CELLS)
def test_an_escaped_cell_never_starts_a_formula(text):
    out = stt.escape_cell(text)
    # whatever list separator the spreadsheet splits on, no piece starts a formula
    for sep in (None, ";", ",", "\t", "|"):
        for piece in [out] if sep is None else out.split(sep):
            if piece[:1] in ("=", "+", "-", "@", "\t", "\r"):
                assert _is_number(piece), (text, out, piece)


@given(st.one_of(st.integers(), st.floats(allow_nan=False, allow_infinity=False)))
def test_numbers_are_untouched(x):
    for text in (repr(x), f"{x:g}" if isinstance(x, float) else str(x)):
        assert stt.escape_cell(text) == text == at.escape_cell(text)


@pytest.mark.parametrize("text", ["-1.5", "+3", "1e-3", "-.5", "+2E+10", "0"])
def test_signed_numbers_stay_numbers(text):
    assert stt.escape_cell(text) == text == at.escape_cell(text)


@pytest.mark.parametrize("text", HOSTILE)
def test_formulas_get_a_quote(text):
    assert stt.escape_cell(text) == "'" + text == at.escape_cell(text)


def test_table_text_and_frames_agree():
    rows = [{"a": t, "b": 1.5} for t in HOSTILE]
    text = stt.table_text(rows, ["a", "b"])
    df = at.escape_frame(pd.DataFrame(rows))
    assert list(df["a"]) == [stt.escape_cell(t) for t in HOSTILE]
    back = at.unescape_frame(pd.read_csv(io.StringIO(text), dtype=str, keep_default_na=False))
    assert list(back["a"]) == HOSTILE
    read = [stt.unescape_row(r) for r in csv.DictReader(io.StringIO(text, newline=""))]
    assert [r["a"] for r in read] == HOSTILE
    tsv = stt.table_text(rows, ["a", "b"], delimiter="\t")
    read = [stt.unescape_row(r) for r in csv.DictReader(io.StringIO(tsv), delimiter="\t")]
    assert [r["a"] for r in read] == HOSTILE


# -- each writer -------------------------------------------------------------------------------


def _cells(path):
    with open(path, newline="", encoding="utf-8") as f:
        delim = "\t" if path.suffix == ".tsv" else ","
        return [c for row in csv.reader(f, delimiter=delim) for c in row]


def _no_formula(path):
    for c in _cells(path):
        starts_formula = c[:1] in ("=", "@", "\t", "\r", "+", "-") and not _is_number(c)
        assert not starts_formula, (path.name, c)


def _is_number(c):
    try:
        float(c)
    except ValueError:
        return False
    return True


def test_objects_and_manifest_csv(tmp_path):
    from stimuli.manifest import (
        ObjectInfo,
        StimulusRecord,
        read_manifest,
        read_objects_csv,
        write_manifest,
        write_objects_csv,
    )

    objs = [ObjectInfo("cup", name=HOSTILE[0], synonyms=("+mug",), uses=("@drink",))]
    write_objects_csv(objs, tmp_path / "objects.csv")
    _no_formula(tmp_path / "objects.csv")
    assert read_objects_csv(tmp_path / "objects.csv") == objs
    rec = StimulusRecord(
        object="cup", role="main", condition="cluttered", level=1, window=40, width=12,
        height=8, pixels=96, path="cup/x.png", sha256="0" * 64, sobel_threshold=0.1,
        edge_ratio=None, source="-cmd.png", source_sha256="1" * 64, mode="binary",
    )  # fmt: skip
    write_manifest([rec], tmp_path / "manifest.csv")
    _no_formula(tmp_path / "manifest.csv")
    assert read_manifest(tmp_path / "manifest.csv") == [rec]


def test_tune_keeps_other_columns_formula_safe(tmp_path):
    from stimuli.manifest import ObjectInfo, read_objects_csv, write_objects_csv
    from stimuli.tune import write_thresholds

    write_objects_csv([ObjectInfo("cup", name=HOSTILE[0])], tmp_path / "objects.csv")
    write_thresholds(tmp_path / "objects.csv", {"cup": 0.25})
    _no_formula(tmp_path / "objects.csv")
    (o,) = read_objects_csv(tmp_path / "objects.csv")
    assert o.name == HOSTILE[0] and o.sobel_threshold == 0.25


def test_active_trials_csv(tmp_path):
    from analysis.tables import frame_csv_text, unescape_frame

    df = pd.DataFrame({"searcher": HOSTILE, "rt_s": [-1.5] * len(HOSTILE)})
    (tmp_path / "active_trials.csv").write_text(frame_csv_text(df), encoding="utf-8")
    _no_formula(tmp_path / "active_trials.csv")
    back = unescape_frame(pd.read_csv(tmp_path / "active_trials.csv", dtype=str))
    assert list(back["searcher"]) == HOSTILE and set(back["rt_s"]) == {"-1.5"}
