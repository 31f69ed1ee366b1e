"""A protocol's ``[display] implant``: sessions show each stimulus as the implant does.

The headless session's shown images are checked against :func:`stimuli.compress.compress` /
``compress_grey`` of the stimulus files read directly (not through the session), the logged
display JSON against the layout file, and the presenter's phosphenes against the layout's fields.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from experiment.clock import FakeClock
from experiment.errors import ConfocalError
from experiment.interfaces import Answer
from experiment.log import TrialLog
from experiment.presentation.displays import NullDisplay
from experiment.protocol import DisplaySpec, ProtocolError, ProtocolSpec, load_protocol
from experiment.session.engine import Session, display_json
from experiment.session.stimset import StimulusSet
from experiment.testing import make_stimulus_set
from stimuli.compress import compress, compress_grey
from stimuli.implants import load_implant
from stimuli.io import load_gray, load_rgb

PROTOCOL = """
[protocol]
name = "implant"

[display]
{display}

[[blocks]]
part = "training"
objects = "training"
levels = [8]
conditions = ["colour_wide", "photo"]

[[blocks]]
part = "main"
objects = "main"
levels = [{levels}]
conditions = ["cluttered", "decluttered"]
"""


def write_protocol(path, display='implant = "argus2"', levels="5, 8"):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(PROTOCOL.format(display=display, levels=levels))
    return path


class Keeping(NullDisplay):
    """The headless display, keeping every image it is asked to show."""

    def __init__(self, clock):
        super().__init__(clock)
        self.images = []

    def show_stimulus(self, image):
        self.images.append(np.array(image))
        return super().show_stimulus(image)


class Seeing:
    """Answers 'pass' and keeps what the simulated subject was given."""

    def __init__(self):
        self.seen = []

    def respond(self, trial, image):
        self.seen.append((trial, np.array(image)))
        return Answer("", "pass", "operator", 1.0)


@pytest.fixture(scope="module")
def stim_dir(tmp_path_factory):
    # working size 33x49: level 5 (window 5) is 7x10, level 8 the 33x49 edge image
    root = tmp_path_factory.mktemp("stim")
    return make_stimulus_set(root / "stim", n_main=2, n_training=1, levels=(3, 5, 8))


def test_headless_session_shows_the_implant_grid_and_logs_the_layout(stim_dir, tmp_path) -> None:
    protocol = load_protocol(write_protocol(tmp_path / "p.toml"))
    stimset = StimulusSet.load(stim_dir)
    lay = load_implant("argus2")
    clock = FakeClock(10.0)
    display, subject = Keeping(clock), Seeing()
    with TrialLog(tmp_path / "s.sqlite") as log:
        s = Session.open(log, protocol, stimset, "S01", seed=3, clock=clock)
        s.run(display, subject)
        row = log.session(s.session_id)
    assert len(display.images) == len(s.schedule) == 2 + 2 * 2 * 2
    for (trial, seen), shown in zip(subject.seen, display.images, strict=True):
        np.testing.assert_array_equal(seen, shown)  # the subject is given what is shown
        path = stim_dir / trial.path
        if trial.condition == "colour_wide":  # training photos stay photos (as the presenter)
            np.testing.assert_allclose(shown, load_rgb(path), atol=1e-6)
            continue
        assert shown.shape == (6, 10), trial
        if trial.condition == "photo":
            expected = compress_grey(load_gray(path), (6, 10), grey_levels=lay.levels)
        else:  # edges: the paper's rule, window edge fraction > 1/13
            expected = compress(load_gray(path) > 0.5, (6, 10), edge_ratio=1 / 13)
        np.testing.assert_array_equal(shown, expected)
    logged = json.loads(row["display_json"])
    assert logged["implant"] == "argus2"
    assert logged["implant_layout"] == json.loads(json.dumps(lay.to_dict()))


def test_no_implant_keeps_the_display_json_and_content_hash(tmp_path) -> None:
    plain = load_protocol(write_protocol(tmp_path / "a.toml", display="gamma = 1.0"))
    assert plain.display.implant is None and plain.display.implant_layout is None
    # the keys a display had before implants existed, so old hashes and logs stay as they were
    assert sorted(plain.display.to_dict()) == [
        "background_rgb", "border_rgb", "border_width_px", "gamma", "image_height_cm",
        "image_width_cm", "screen_height_px", "screen_width_cm", "screen_width_px",
        "viewing_distance_cm",
    ]  # fmt: skip
    assert display_json(plain.display) == json.dumps(plain.display.to_dict(), sort_keys=True)
    assert plain.to_dict()["display"] == plain.display.to_dict()
    with_implant = load_protocol(write_protocol(tmp_path / "b.toml"))
    assert with_implant.content_sha256() != plain.content_sha256()
    again = ProtocolSpec.from_dict(with_implant.to_dict())
    assert again == with_implant and again.display.implant_layout == load_implant("argus2")


def test_implant_file_is_read_relative_to_the_protocol(tmp_path, monkeypatch) -> None:
    mine = tmp_path / "study" / "grids" / "mine.toml"
    mine.parent.mkdir(parents=True)
    mine.write_text(
        'label = "Mine"\nkind = "other"\nrows = 4\ncols = 5\nfov_width_deg = 10\n'
        "fov_height_deg = 8\n"
    )
    p = write_protocol(tmp_path / "study" / "p.toml", display='implant = "grids/mine.toml"')
    monkeypatch.chdir(tmp_path)  # not the protocol's folder
    spec = load_protocol(p)
    assert spec.display.implant == "grids/mine.toml"
    assert spec.display.implant_layout == load_implant(mine)


@pytest.mark.parametrize(
    ("display", "match"),
    [
        ('implant = "argus9"', r"p\.toml: \[display\] display\.implant: unknown implant 'argus9'"),
        (
            'implant = "none.toml"',
            r"\[display\] display\.implant: .*none\.toml: implant layout not",
        ),
        ("implant = 3", r"\[display\] display\.implant must be str, got int 3"),
        ('implant = "bad.toml"', r"display\.implant: .*bad\.toml: .*field 'rows' must be"),
    ],
)
def test_bad_implant_is_a_one_line_protocol_error(tmp_path, display, match) -> None:
    (tmp_path / "bad.toml").write_text(
        'label = "x"\nkind = "other"\nrows = 0\ncols = 3\nfov_width_deg = 5\nfov_height_deg = 5\n'
    )
    with pytest.raises(ProtocolError, match=match) as exc:
        load_protocol(write_protocol(tmp_path / "p.toml", display=display))
    assert "\n" not in str(exc.value)


def test_spec_level_implant_checks() -> None:
    with pytest.raises(ProtocolError, match="display.implant_layout needs display.implant"):
        DisplaySpec(implant_layout=load_implant("argus2"))
    with pytest.raises(ProtocolError, match="display.implant_layout must be an ImplantLayout"):
        DisplaySpec(implant="argus2", implant_layout="argus2")
    assert DisplaySpec(implant="brainport").implant_layout.shape == (20, 20)


def test_implant_finer_than_a_planned_level_is_refused_before_the_session(
    stim_dir, tmp_path
) -> None:
    protocol = load_protocol(write_protocol(tmp_path / "p.toml", levels="3, 8"))
    stimset = StimulusSet.load(stim_dir)
    with TrialLog(tmp_path / "s.sqlite") as log:
        with pytest.raises(
            ProtocolError, match=r"display.implant 'argus2': its 10x6 grid is finer"
        ):
            Session.open(log, protocol, stimset, "S01", seed=1)
        assert log.sessions() == []


def test_session_run_cli_with_implant_and_with_a_bad_one(stim_dir, tmp_path) -> None:
    code = "import sys; from experiment.cli import main; main(sys.argv[1:])"

    def run(proto, db):
        return subprocess.run(
            [sys.executable, "-c", code, "session", "run", "--protocol", str(proto),
             "--stimuli", str(stim_dir), "--subject", "S01", "--data", str(db), "--headless",
             "--seed", "2"],
            capture_output=True, text=True, timeout=120,
        )  # fmt: skip

    ok = run(write_protocol(tmp_path / "ok.toml"), tmp_path / "ok.sqlite")
    assert ok.returncode == 0, ok.stderr
    with TrialLog(tmp_path / "ok.sqlite", readonly=True) as log:
        (row,) = log.sessions()
        assert json.loads(log.session(row["session_id"])["display_json"])["implant"] == "argus2"
    bad = run(write_protocol(tmp_path / "bad.toml", display='implant = "argus9"'), tmp_path / "b")
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert bad.stderr.strip().splitlines() == [
        f"confocal: error: {tmp_path / 'bad.toml'}: [display] display.implant: unknown implant "
        "'argus9' (shipped: alpha_ims, argus2, brainport; or give a .toml file)"
    ]
    coarse = run(write_protocol(tmp_path / "c.toml", levels="3"), tmp_path / "c.sqlite")
    assert coarse.returncode == 2 and "grid is finer than the" in coarse.stderr
    assert not (tmp_path / "b").exists() and not (tmp_path / "c.sqlite").exists()


def test_console_draws_the_implants_phosphenes(stim_dir, tmp_path, monkeypatch) -> None:
    """run_console asks the presenter for the layout's phosphenes at its field of view."""
    import experiment.console.launch as console
    from experiment.presentation.presenter import PhospheneSpec

    asked = {}

    def fake_make_display(geometry, presenter, **kw):
        asked.update(kw)
        raise ConfocalError("no screen in this test")

    monkeypatch.setattr(console, "make_display", fake_make_display)
    protocol = load_protocol(write_protocol(tmp_path / "p.toml"))
    with TrialLog(tmp_path / "s.sqlite") as log:
        s = Session.open(log, protocol, StimulusSet.load(stim_dir), "S01", seed=1)
        with pytest.raises(ConfocalError, match="no screen"):
            console.run_console(s, presenter="offscreen")
    # Argus II: 6x10 Gaussians, FWHM half the spacing, 19.97 deg / 10 columns apart
    assert asked["phosphenes"] == PhospheneSpec("gaussian", 0.5, 0.0, 19.97 / 10, 0)


@pytest.mark.gl
def test_present_with_the_protocols_implant_draws_what_present_implant_draws(tmp_path) -> None:
    """``confocal present --protocol P`` shows P's implant view, the frame of ``--implant``."""
    from PIL import Image

    edges = np.zeros((60, 100), bool)
    edges[10:50:3, 20:70] = True
    stim = tmp_path / "edges.png"
    Image.fromarray(edges.astype(np.uint8) * 255).save(stim)
    code = "import sys; from experiment.cli import main; main(sys.argv[1:])"

    def present(*args):
        return subprocess.run(
            [sys.executable, "-c", code, "present", "--stimulus", str(stim), *map(str, args)],
            capture_output=True, text=True, timeout=120,
        )  # fmt: skip

    plain = write_protocol(tmp_path / "plain.toml", display="gamma = 1.0")
    a = present("--protocol", plain, "--implant", "argus2", "--screenshot", tmp_path / "a.png")
    if a.returncode != 0 and "OpenGL" in a.stderr:
        pytest.skip(f"no headless OpenGL context: {a.stderr.strip()}")
    assert a.returncode == 0, a.stderr
    b = present(
        "--protocol", write_protocol(tmp_path / "p.toml"), "--screenshot", tmp_path / "b.png"
    )
    assert b.returncode == 0, b.stderr
    assert "stimulus 10x6" in a.stdout and "stimulus 10x6" in b.stdout
    shot_a = np.asarray(Image.open(tmp_path / "a.png"))
    np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "b.png")), shot_a)
    c = present("--protocol", plain, "--screenshot", tmp_path / "c.png")
    assert c.returncode == 0 and "stimulus 100x60" in c.stdout  # no implant: the file itself
