"""Kill test, short: SIGKILLs at random times across ``session run`` and ``active run``.

The same harness as ``benchmarks/bench_kill_recovery.py`` (10,000 kills), with 30 kills: every
kill is followed by the same command again until the subject's command ends by itself; then no
trial may be lost or duplicated, no subject may have a second session, and no completed session
may be opened again.
"""

from __future__ import annotations

import warnings

from experiment.kill_recovery import KillReport, check_logs, run_kill_recovery


def test_random_sigkills_lose_duplicate_and_rerun_nothing(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        report = run_kill_recovery(tmp_path, kills=30, workers=2, seed=20150611, active_share=0.3)
    print("\n".join(report.lines()))
    assert report.kills >= 30
    assert report.static_subjects and report.active_subjects
    assert report.trials_checked > 0
    assert report.ok, report.failures


def test_the_check_finds_a_second_session_and_a_lost_trial(tmp_path):
    """The checker itself can fail: a subject run twice, and a trial missing."""
    from types import SimpleNamespace

    from experiment import cli

    stim = tmp_path / "stim"
    from experiment.kill_recovery import STATIC_PROTOCOL
    from experiment.testing import make_stimulus_set

    make_stimulus_set(stim, n_main=3, n_training=1, levels=(1, 2))
    proto = tmp_path / "p.toml"
    proto.write_text(STATIC_PROTOCOL)
    db = tmp_path / "log.sqlite"
    argv = ["session", "run", "--protocol", str(proto), "--stimuli", str(stim), "--subject",
            "S1", "--data", str(db), "--headless", "--seed", "1"]  # fmt: skip
    for extra in ([], ["--new-session", "by mistake"]):
        try:
            cli.main([*argv, *extra])
        except SystemExit as exc:
            assert not exc.code
    checked = check_logs([SimpleNamespace(code="S1", kind="static", log=db)])
    assert checked["extra_sessions"] == 1
    assert not KillReport(extra_sessions=1).ok
    import sqlite3

    con = sqlite3.connect(db)
    con.execute("DROP TRIGGER trials_no_delete")
    con.execute("DELETE FROM trials WHERE session_id = 1 AND trial_index = 3")
    con.commit()
    con.close()
    assert check_logs([SimpleNamespace(code="S1", kind="static", log=db)])["lost"] == 1
