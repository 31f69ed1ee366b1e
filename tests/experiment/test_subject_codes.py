"""Subject codes follow one rule at ``session run`` and ``active run``: they name nobody and are
safe as a file-name part (an e-mail, a phone number, a full name, a path are refused)."""

from __future__ import annotations

import pytest

from experiment.data.psychds import identifying_reason
from experiment.data.subjects import SubjectCodeError, check_subject_code, subject_code_problem
from tests.experiment.conftest import confocal

#: Codes the rule refuses, and a word of the reason the message gives.
REFUSED = {
    "ann@example.org": "@",
    "Ann Smith": "space",
    "Ann_Smith": "name",
    "Ann.Smith": "name",
    "+44 20 7946 0958": "space",
    "02079460958": "phone",
    "1970-01-02": "looks like",
    "born 1970-01-02": "space",
    "S-1970-01-02": "date",
    "../x": "path",
    "a/b": "path",
    "a\\b": "path",
    "x..y": "path",
    "S01\x1b[2J": "control",
    "S01\tx": "control",
    "S" * 65: "at most 64",
    "": "empty",
    " S01": "spaces around",
    "__": "no letter or digit",
}

#: Codes labs use, which the rule keeps.
ACCEPTED = ["S01", "P-017", "pilot_3", "site2.s14", "s1", "S" * 64, "AB12", "Ctrl_01"]


@pytest.mark.parametrize("code", ACCEPTED)
def test_lab_codes_pass(code):
    assert subject_code_problem(code) is None
    assert check_subject_code(code) == code


@pytest.mark.parametrize("code", REFUSED)
def test_rule_refuses(code):
    with pytest.raises(SubjectCodeError) as exc:
        check_subject_code(code)
    msg = str(exc.value)
    assert msg.startswith("--subject ") and "\n" not in msg
    assert REFUSED[code] in msg


def test_same_patterns_as_participant_values():
    """The identifying patterns are --participant's own: what it refuses as a value is refused
    as a code."""
    for value in ("ann@example.org", "02079460958", "1970-01-02"):
        assert identifying_reason("note", value) is not None
        assert subject_code_problem(value) is not None


@pytest.mark.parametrize("code", ["ann@example.org", "Ann Smith", "../x", "a/b", "02079460958"])
def test_session_run_refuses_before_anything(tmp_path, capsys, code):
    db = tmp_path / "study.sqlite"
    code_, _, err = confocal(
        ["session", "run", "--protocol", "jung2015", "--stimuli", tmp_path / "none",
         "--subject", code, "--data", db, "--headless"],
        capsys,
    )  # fmt: skip
    assert code_ == 2 and len(err.strip().splitlines()) == 1, err
    assert "--subject" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == [], "nothing written"


@pytest.mark.parametrize("code", ["ann@example.org", "Ann Smith", "../x", "a/b", "02079460958"])
def test_active_run_refuses_before_anything(tmp_path, capsys, code):
    db = tmp_path / "study.sqlite"
    code_, _, err = confocal(
        ["active", "run", "active_search", "--data", db, "--subject", code], capsys
    )
    assert code_ == 2 and len(err.strip().splitlines()) == 1, err
    assert "--subject" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == [], "nothing written"
