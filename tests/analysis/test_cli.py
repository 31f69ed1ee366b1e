"""``confocal analyze``: report folder, results.json keys, exit status 2 on bad data, power."""

from __future__ import annotations

import json

import pytest

from analysis.data import file_record
from experiment.cli import main
from experiment.outputs import write_manifest

PASS_KEYS = {
    "p50_pixels",
    "ci95",
    "mle_p50_pixels",
    "alpha",
    "beta",
    "lapse",
    "converged",
    "tau_max",
}


@pytest.fixture(scope="module")
def report(tmp_path_factory, small_csv):
    out = tmp_path_factory.mktemp("rep") / "report"
    out.mkdir()
    (out / "stale.txt").write_text("old report")
    write_manifest(out, "analyze run", ["stale.txt"])  # an earlier report of this command
    with pytest.raises(SystemExit) as exc:
        main(["analyze", str(small_csv), "--out", str(out), "--seed", "1"])
    assert exc.value.code in (0, None)
    return out


def test_report_folder_contents(report):
    names = {p.name for p in report.iterdir()}
    assert "stale.txt" not in names  # replaced as a whole, atomically
    assert {"results.json", "report.md"} <= names
    for stem in (
        "fig8_recognition_vs_pixels",
        "fig9_subject_thresholds",
        "figS2_subject_curves",
        "figS3_object_difficulty",
    ):
        for ext in ("png", "pdf"):  # the default formats; SVG only when asked for
            assert (report / f"{stem}.{ext}").stat().st_size > 1000
    leftovers = [p.name for p in report.parent.iterdir() if p.name.startswith(".report")]
    assert leftovers == []


def test_results_json_keys(report, small_trials):
    r = json.loads((report / "results.json").read_text())
    assert r["n_trials"] == len(small_trials)
    assert r["n_recognized"] == int(small_trials["recognized"].sum())
    assert set(r["thresholds"]) == {"cluttered", "decluttered"}
    for c in ("cluttered", "decluttered"):
        t = r["thresholds"][c]
        assert PASS_KEYS <= set(t)
        assert t["ci95"][0] < t["p50_pixels"] < t["ci95"][1]
    assert set(r["subject_thresholds"]) == {"s1", "s2"}
    assert PASS_KEYS <= set(r["subject_thresholds"]["s2"]["decluttered"])
    ors = r["logistic"]["odds_ratios"]
    for term in ("background", "log10_pixels", "object:2", "object:20"):
        assert set(ors[term]) == {"or", "ci95", "p"}
    assert "object:1" not in ors
    assert set(r["logistic"]["classification"]) == {
        "recognized_correct_pct",
        "not_recognized_correct_pct",
        "cutoff",
    }
    p = r["predictions"]
    o = r["logistic"]["intervals"]["background"]["or"]  # the reported (Firth) odds ratio
    assert p["decluttered_if_cluttered_50pct"] == pytest.approx(o / (1 + o), rel=1e-12)


def test_report_sentences(report):
    text = (report / "report.md").read_text()
    assert "- cluttered: 50 % threshold " in text and "95 % CrI" in text and "ML " in text
    assert "By Eq. 1, if the cluttered recognition rate is 50 %" in text
    assert "## First recognised level per subject" in text


def test_help_documents_run_and_power(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["analyze", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "TRIALS" in out and "power" in out and "run" in out


def _bad(tmp_path, text):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    return p


HEADER = "subject,object,condition,pixels,recognized\n"


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("", "file is empty"),
        ("subject,object,pixels,recognized\ns1,1,96,0\n", "missing required column"),
        (HEADER + "s1,1,cluttered,abc,0\n", "'pixels' must be numeric"),
        (HEADER + "s1,1,cluttered,-5,0\n", "'pixels' must be > 0"),
        (HEADER + "s1,1,cluttered,96,\n", "'recognized' has a missing value"),
    ],
)
def test_bad_data_exits_2_with_one_line(tmp_path, capsys, text, needle):
    p = _bad(tmp_path, text)
    with pytest.raises(SystemExit) as exc:
        main(["analyze", str(p), "--out", str(tmp_path / "rep")])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("confocal: error:") and needle in err and "\n" not in err
    assert not (tmp_path / "rep").exists()


def test_power_command(capsys):
    with pytest.raises(SystemExit) as exc:
        main("analyze power --odds-ratio 20 --subjects 2 --sims 4 --seed 1".split())
    assert exc.value.code in (0, None)
    out = capsys.readouterr().out
    assert "subjects needed for power 0.8: 2" in out


def test_power_needs_one_effect(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["analyze", "power", "--sims", "2"])
    assert exc.value.code == 2


def test_sqlite_and_csv_pooled_options_first(tmp_path, small_trials, capsys):
    """Options before TRIALS, explicit 'run', a SQLite log pooled with a CSV, --mixed, --pc."""
    from tests.analysis.trial_logs import write_trial_log

    half = len(small_trials) // 2
    db = tmp_path / "session.sqlite"
    write_trial_log(db, small_trials.iloc[:half])
    csv = tmp_path / "rest.csv"
    small_trials.iloc[half:].to_csv(csv, index=False)
    out = tmp_path / "rep"
    with pytest.raises(SystemExit) as exc:
        main(
            [
                "analyze",
                "run",
                "--out",
                str(out),
                "--by",
                "none",
                "--mixed",
                "--no-figures",
                "--pc",
                "0.75",
                "--lapse-prior",
                "1,20",
                "--seed",
                "2",
                str(db),
                str(csv),
            ]
        )
    assert exc.value.code in (0, None)
    r = json.loads((out / "results.json").read_text())
    assert r["n_trials"] == len(small_trials)
    assert r["sources"] == [file_record(db), file_record(csv)]
    assert [s["file"] for s in r["sources"]] == [db.name, csv.name]
    assert str(tmp_path) not in (out / "results.json").read_text(), "no host path"
    assert r["subject_thresholds"] == {}
    assert set(r["logistic"]["mixed"]["odds_ratios"]) == {"background", "log10_pixels"}
    assert r["thresholds"]["cluttered"]["pc"] == 0.75
    assert r["prior"]["cluttered"]["lapse_b"] == 20.0
    stdout = capsys.readouterr().out
    assert "50% threshold" in stdout and "odds ratio   background" in stdout
    assert f"report: {out / 'report.md'}" in stdout
