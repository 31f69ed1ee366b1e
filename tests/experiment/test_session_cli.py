"""``confocal session``: run, status, export; bad input (exit 2, no data lost); round trip."""

from __future__ import annotations

import csv
import json
import sys

import pytest

from experiment.data.psychds import EXPORT_COLUMNS
from experiment.log import TrialLog
from experiment.observers import LogisticParams
from experiment.testing import make_stimulus_set
from tests.conftest import protocol_toml
from tests.experiment.conftest import confocal, make_study
from tests.experiment.conftest import session_run_args as run_args

PROTOCOL = protocol_toml((1, 2, 8))
N_TRIALS = 1 + 3 * 3 * 2


@pytest.fixture()
def study(tmp_path):
    return make_study(tmp_path, (1, 2, 8))


def snapshot(db):
    with TrialLog(db, readonly=True) as log:
        return log.tidy_trials(), [s["session_id"] for s in log.sessions()], log.events()


def test_headless_run_status_and_export(study, tmp_path, capsys):
    stim, proto, db = study
    code, out, err = confocal(run_args(stim, proto, db, "S01", "--headless", "--seed", "4"), capsys)
    assert code == 0, err
    assert f"{N_TRIALS}/{N_TRIALS} trials answered - complete" in out
    code, out, _ = confocal(
        run_args(stim, proto, db, "S02", "--headless", "--observer", "model",
                 "--progress-every", "5"), capsys)  # fmt: skip
    assert code == 0 and "trial 5/19" in out
    # a second rater re-scores S01's first trial and disagrees
    with TrialLog(db) as log:
        log.add_score(1, 0, "wrong", False, "B")
        log.add_score(1, 1, log.tidy_trials()[1]["score"], True, "B")

    code, out, _ = confocal(["session", "status", db], capsys)
    assert code == 0
    lines = out.strip().splitlines()
    assert lines[0].split()[:3] == ["session", "1", "S01"] and "completed" in lines[0]
    assert "19/19" in lines[1]
    assert any("Cohen's kappa" in ln and "on 2 trials" in ln for ln in lines)

    code, out, _ = confocal(["session", "status", db, "--json"], capsys)
    rep = json.loads(out)
    assert [s["left"] for s in rep["sessions"]] == [0, 0]
    assert {"rater_a", "rater_b", "kappa", "n"} <= set(rep["kappa"][0])

    target = tmp_path / "export"
    code, out, _ = confocal(["session", "export", db, "--out", target], capsys)
    assert code == 0 and "simulated session(s): 1, 2" in out
    files = sorted((target / "data").iterdir())
    assert [f.name for f in files] == [
        "study-study_subject-S01_session-1_data.csv",
        "study-study_subject-S02_session-2_data.csv",
    ]
    rows = []
    for f in files:
        with open(f, newline="") as fh:
            rows += list(csv.DictReader(fh))
    assert tuple(rows[0]) == EXPORT_COLUMNS
    assert len(rows) == 2 * N_TRIALS
    assert {r["subject"] for r in rows} == {"S01", "S02"}
    assert rows[0]["rater"] == "sim:logistic", "the primary score, not rater B's"
    assert {r["simulated"] for r in rows} == {"1"}
    desc = json.loads((target / "dataset_description.json").read_text())
    assert desc["@type"] == "Dataset" and desc["schemaVersion"].startswith("Psych-DS")
    assert [v["name"] for v in desc["variableMeasured"]] == list(EXPORT_COLUMNS)
    sessions = json.loads((target / "documentation" / "sessions.json").read_text())["sessions"]
    assert [s["seed"] for s in sessions][0] == "4"


def test_status_shows_what_is_left(study, capsys):
    stim, proto, db = study
    with TrialLog(db) as log:
        from experiment.protocol import load_protocol
        from experiment.session.engine import Session
        from experiment.session.stimset import StimulusSet

        s = Session.open(log, load_protocol(proto), StimulusSet.load(stim), "S07")
        s.close()
    code, out, _ = confocal(["session", "status", db], capsys)
    assert code == 0
    assert "0/19" in out and "left   19" in out and "next: #0 training block 1 level 8 photo" in out


@pytest.mark.parametrize(
    ("case", "match"),
    [
        ("unknown_key", r"small\.toml: unknown key 'colour' in \[protocol\]"),
        ("missing_level", r"blocks\[1\]\.levels: level 5 is not in stimulus set"),
        ("missing_object", r"blocks\[1\]\.objects: object 'teapot' is not in stimulus set"),
        ("read_only_db", r"study\.sqlite: trial log is read-only"),
        ("corrupt_db", r"study\.sqlite: not a readable SQLite trial log"),
        ("changed_file", r"obj01_decluttered_L2\.png: stimulus file changed"),
        ("no_stimuli", r"nowhere: stimulus set folder not found"),
        ("bad_manifest", r"manifest\.csv: missing column 'sha256'"),
        ("observer_without_headless", r"--observer needs --headless"),
        (
            "unknown_observer",
            r"--observer must be one of calibrated, exemplar, logistic, model, got 'oracle'",
        ),
        ("resume_other_seed", r"unfinished session 2 with seed 11, not 12"),
        ("bad_observer_param", r"--observer-param: unknown parameter 'lapsy' for observer"),
        ("observer_param_syntax", r"--observer-param must be KEY=VALUE, got 'lapse'"),
    ],
)
def test_bad_input_one_line_exit_2_no_data_lost(study, tmp_path, capsys, case, match):
    stim, proto, db = study
    assert confocal(run_args(stim, proto, db, "S01", "--headless"), capsys)[0] == 0
    args = run_args(stim, proto, db, "S09", "--headless")
    if case == "unknown_key":
        proto.write_text(PROTOCOL.replace("[protocol]", "[protocol]\ncolour = 'blue'"))
    elif case == "missing_level":
        proto.write_text(PROTOCOL.replace("levels = [1, 2, 8]", "levels = [1, 5]"))
    elif case == "missing_object":
        proto.write_text(PROTOCOL.replace('objects = "main"', 'objects = ["obj01", "teapot"]'))
    elif case == "read_only_db":
        db.chmod(0o444)
    elif case == "corrupt_db":
        db.write_bytes(b"\0garbage" * 512)
    elif case == "changed_file":
        p = stim / "images" / "obj01_decluttered_L2.png"
        p.write_bytes(p.read_bytes()[:-4])
    elif case == "no_stimuli":
        args = run_args(tmp_path / "nowhere", proto, db, "S09", "--headless")
    elif case == "bad_manifest":
        text = (stim / "manifest.csv").read_text().replace(",sha256", ",hash", 1)
        (stim / "manifest.csv").write_text(text)
    elif case == "observer_without_headless":
        args = run_args(stim, proto, db, "S09", "--observer", "logistic")
    elif case == "unknown_observer":
        args = run_args(stim, proto, db, "S09", "--headless", "--observer", "oracle")
    elif case == "bad_observer_param":
        args = [*args, "--observer-param", "lapsy=0.1"]
    elif case == "observer_param_syntax":
        args = [*args, "--observer-param", "lapse"]
    elif case == "resume_other_seed":
        with TrialLog(db) as log:
            from experiment.protocol import load_protocol
            from experiment.session.engine import Session
            from experiment.session.stimset import StimulusSet

            Session.open(log, load_protocol(proto), StimulusSet.load(stim), "S09", seed=11).close()
        args = run_args(stim, proto, db, "S09", "--headless", "--seed", "12")
    before = None if case == "corrupt_db" else snapshot(db)
    raw = db.read_bytes() if case == "corrupt_db" else None
    try:
        code, out, err = confocal(args, capsys)
    finally:
        db.chmod(0o644)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("confocal: error: "), err
    assert "Traceback" not in err
    import re

    assert re.search(match, lines[0]), lines[0]
    if case == "corrupt_db":
        assert db.read_bytes() == raw
    else:
        assert snapshot(db) == before, "no data lost, nothing added"


def test_status_and_export_refuse_bad_files(tmp_path, capsys):
    bad = tmp_path / "x.sqlite"
    bad.write_bytes(b"not sqlite at all" * 64)
    code, _, err = confocal(["session", "status", bad], capsys)
    assert code == 2 and "not a readable SQLite trial log" in err
    code, _, err = confocal(["session", "export", tmp_path / "none.sqlite", "--out",
                             tmp_path / "ds"], capsys)  # fmt: skip
    assert code == 2 and "trial log not found" in err


def test_without_headless_the_console_is_called_or_refused(study, monkeypatch, capsys):
    stim, proto, db = study
    monkeypatch.setitem(sys.modules, "experiment.console", None)
    code, _, err = confocal(run_args(stim, proto, db), capsys)
    assert code == 2 and "the operator console is unavailable" in err

    calls = []

    class FakeConsole:
        @staticmethod
        def run_console(session, **options):
            calls.append((session.subject, session.progress()))

    monkeypatch.setitem(sys.modules, "experiment.console", FakeConsole)
    code, out, _ = confocal(run_args(stim, proto, db), capsys)
    assert code == 0 and calls == [("S01", (0, N_TRIALS))]
    assert "0/19 trials answered" in out


@pytest.mark.slow  # ~30 s: 10 sessions of 371 trials, then the Weibull MCMC of the analysis
def test_round_trip_logistic_observer_through_confocal_analyze(tmp_path, capsys):
    """Headless sessions with the logistic observer; `confocal analyze` recovers its odds ratios."""
    pytest.importorskip("analysis.pipeline")
    stim = make_stimulus_set(
        tmp_path / "stim", n_main=20, n_training=3, working_shape_px=(327, 492), rng=3
    )  # the paper's pixel counts
    db = tmp_path / "study.sqlite"
    n_subjects = 10
    for i in range(n_subjects):
        code, _, err = confocal(
            ["session", "run", "--protocol", "jung2015", "--stimuli", stim, "--subject",
             f"S{i + 1:02d}", "--data", db, "--headless", "--observer", "logistic",
             "--seed", 1000 + i], capsys)  # fmt: skip
        assert code == 0, err
    report = tmp_path / "R"
    code, _, err = confocal(["analyze", db, "--out", report, "--seed", "1"], capsys)
    assert code == 0, err
    results = json.loads((report / "results.json").read_text())
    odds = results["logistic"]["odds_ratios"]
    bg, px = odds["background"]["or"], odds["log10_pixels"]["or"]
    truth = LogisticParams()
    print(
        f"round trip ({n_subjects} subjects x 320 trials): OR background {bg:.2f} "
        f"(generating {truth.or_background}), OR per log10 px {px:.1f} "
        f"(generating {truth.or_per_log10_px})"
    )
    # The analysis has no subject term, so the subject effect (SD 0.5 logit) and the 2 % lapse
    # attenuate both coefficients slightly (~5 %, Zeger et al. 1988); with 3,200 trials the SE
    # of log OR is ~0.1 (background) and ~0.12 (slope). Allow +-0.35 on the log scale (~3 SE).
    assert abs(__import__("math").log(bg / truth.or_background)) < 0.35
    assert abs(__import__("math").log(px / truth.or_per_log10_px)) < 0.35


def test_integration_with_a_built_stimulus_set(tmp_path, capsys):
    """`confocal stimuli synth` + `build` (the stimulus builder's real output) runs jung2015."""
    pairs, stim, db = tmp_path / "PAIRS", tmp_path / "STIM", tmp_path / "study.sqlite"
    code, _, err = confocal(["stimuli", "synth", "--objects", 4, "--training", 3, "--out", pairs,
                             "--size", "246x164"], capsys)  # fmt: skip
    assert code == 0, err
    code, _, err = confocal(["stimuli", "build", pairs, "--out", stim], capsys)
    assert code == 0, err
    for subject, observer in (("S01", "model"), ("S02", "logistic")):
        code, out, err = confocal(
            ["session", "run", "--protocol", "jung2015", "--stimuli", stim, "--subject", subject,
             "--data", db, "--headless", "--observer", observer], capsys)  # fmt: skip
        assert code == 0, err
        assert "complete" in out
    with TrialLog(db, readonly=True) as log:
        rows = log.tidy_trials()
    main = [r for r in rows if r["part"] == "main"]
    assert len(main) == 2 * 4 * 8 * 2
    # training: colour photos (wide, then confocal), then 8 x 2 each (Sec. 3.1)
    assert len(rows) - len(main) == 2 * (2 * 3 + 3 * 8 * 2)
    assert {r["pixels"] for r in main} == {96, 486, 950, 3290, 6370, 17876, 40344, 160884}
