"""Monitor profiles: named monitor files override the protocol's display, recorded in the log."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import re

import pytest

from experiment.commands.present import geometry_from_options
from experiment.data.monitors import (
    MONITORS_DIR,
    MonitorError,
    MonitorProfile,
    apply_monitor,
    load_monitor,
    shipped_monitors,
)
from experiment.log import TrialLog
from experiment.protocol import DisplaySpec, load_protocol
from experiment.session.engine import Session
from experiment.session.stimset import StimulusSet
from experiment.testing import make_stimulus_set
from tests.conftest import protocol_toml
from tests.experiment.conftest import confocal

PROTOCOL = protocol_toml((1, 8), conditions=("cluttered",), training=None)

GOOD = """[monitor]
name = "lab"
screen_width_cm = 52.0
viewing_distance_cm = 57.0
screen_width_px = 1920
screen_height_px = 1080
gamma = 2.2
"""


def test_shipped_profiles_load_and_are_listed_with_sha256():
    sums = {}
    for line in (MONITORS_DIR / "SHA256SUMS").read_text().splitlines():
        digest, name = line.split()
        sums[name] = digest
    files = sorted(p.name for p in MONITORS_DIR.glob("*.toml"))
    assert sorted(sums) == files and files
    for name in shipped_monitors():
        profile, record = load_monitor(name)
        raw = (MONITORS_DIR / f"{name}.toml").read_bytes()
        assert record["sha256"] == hashlib.sha256(raw).hexdigest() == sums[f"{name}.toml"]
        assert profile.name == name
        assert MonitorProfile.from_dict(profile.to_dict()) == profile


def test_the_papers_monitor_leaves_the_papers_protocol_unchanged():
    display = load_protocol("jung2015").display
    assert apply_monitor(display, load_monitor("jung2015_crt")[0]) == display


def test_profile_overrides_screen_but_not_the_image_size(tmp_path):
    f = tmp_path / "lab.toml"
    f.write_text(GOOD)
    shown = apply_monitor(DisplaySpec(), load_monitor(f)[0])
    assert (shown.screen_width_px, shown.screen_height_px) == (1920, 1080)
    assert (shown.screen_width_cm, shown.viewing_distance_cm, shown.gamma) == (52.0, 57.0, 2.2)
    assert (shown.image_width_cm, shown.image_height_cm) == (14.6, 9.7)
    g = geometry_from_options(None, monitor=str(f))
    assert g.screen_shape_px == (1080, 1920)
    assert g.px_per_cm == pytest.approx(1920 / 52.0)  # closed form: pixels over width
    # a single-value option still wins over the profile
    assert geometry_from_options(None, monitor=str(f), distance_cm=100.0).viewing_distance_cm == 100


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda t: t.replace('name = "lab"\n', ""), "missing field name"),
        (lambda t: t + "colour = 1\n", "unknown key 'colour'"),
        (lambda t: t.replace("52.0", '"52"'), "screen_width_cm must be a number"),
        (lambda t: t.replace("57.0", "-57.0"), "viewing_distance_cm must be > 0"),
        (lambda t: t.replace("1920", "1920.5"), "screen_width_px must be an integer"),
        (lambda t: t.replace("1080", "true"), "screen_height_px must be an integer"),
        (lambda t: t.replace("2.2", "0.1"), r"gamma must be in \[0.2, 5\]"),
        (lambda t: t.replace("[monitor]", "[screen]"), r"one table, \[monitor\]"),
        (lambda t: t.replace("= 2.2", "= "), "not valid TOML"),
        (lambda t: t.replace("52.0", "10.0"), "does not fit the protocol: display.image_width"),
    ],
)
def test_bad_profiles_one_line_exit_2_nothing_written(tmp_path, capsys, edit, match):
    stim = make_stimulus_set(tmp_path / "stim", n_main=2, n_training=0, levels=(1, 8))
    proto = tmp_path / "p.toml"
    proto.write_text(PROTOCOL)
    f = tmp_path / "bad.toml"
    f.write_text(edit(GOOD))
    db = tmp_path / "study.sqlite"
    code, _, err = confocal(["session", "run", "--protocol", proto, "--stimuli", stim,
                             "--subject", "S01", "--data", db, "--headless",
                             "--monitor", f], capsys)  # fmt: skip
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert "bad.toml" in lines[0] or "monitor 'lab'" in lines[0]
    assert re.search(match, lines[0]), lines[0]
    assert not db.exists()


def test_unknown_name_lists_the_shipped_ones():
    with pytest.raises(MonitorError, match="not found .*jung2015_crt"):
        load_monitor("no_such_monitor")


def test_session_records_the_monitor_and_resumes_with_it(tmp_path, capsys):
    stim = make_stimulus_set(tmp_path / "stim", n_main=2, n_training=0, levels=(1, 8))
    proto = tmp_path / "p.toml"
    proto.write_text(PROTOCOL)
    db = tmp_path / "study.sqlite"
    base = ["session", "run", "--protocol", proto, "--stimuli", stim, "--subject", "S01",
            "--data", db, "--headless", "--seed", "1"]  # fmt: skip
    # a session left unfinished with the example LCD profile
    profile, record = load_monitor("example_lcd_24in")
    spec = load_protocol(proto)
    spec = dataclasses.replace(spec, display=apply_monitor(spec.display, profile))
    with TrialLog(db) as log:
        Session.open(log, spec, StimulusSet.load(stim), "S01", seed=1, responder="sim:logistic",
                     monitor=record).close()  # fmt: skip
    code, _, err = confocal(base, capsys)  # resumed without the monitor: refused
    assert code == 2 and "another display geometry" in err and "--monitor" in err
    code, out, err = confocal([*base, "--monitor", "example_lcd_24in"], capsys)
    assert code == 0 and "complete" in out, err
    with TrialLog(db, readonly=True) as log:
        (row,) = log.sessions()
    mon = json.loads(row["monitor_json"])
    assert mon["name"] == "example_lcd_24in" and len(mon["sha256"]) == 64
    shown = json.loads(row["display_json"])
    assert (shown["screen_width_px"], shown["screen_width_cm"], shown["gamma"]) == (
        1920,
        51.84,
        2.2,
    )
