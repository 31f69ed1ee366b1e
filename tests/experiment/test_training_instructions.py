"""Training and instructions as in the paper.

Jung et al. 2015, Sec. 3.1: "First, at full resolution (160,884 pixels, 492x327), conventional
and confocal images were shown followed by the edge-filtered and compressed (decreased
resolution) images. The subjects were informed of the categories of objects presented ..., the
average size of objects ..., and the position of objects in the images (bottom center)."
"""

from __future__ import annotations

import asyncio
import tomllib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from experiment.clock import FakeClock
from experiment.console import OperatorConsole
from experiment.log import TrialLog
from experiment.presentation.displays import NullDisplay
from experiment.protocol import (
    PROTOCOLS_DIR,
    InstructionsSpec,
    ProtocolError,
    ProtocolSpec,
    load_protocol,
)
from experiment.session.engine import Session
from experiment.session.stimset import StimulusSet
from experiment.testing import make_stimulus_set
from stimuli.io import load_gray
from stimuli.manifest import read_manifest
from stimuli.stimset import aspect_crop_box, build_stimulus_set


def _jung_dict() -> dict:
    return tomllib.loads((PROTOCOLS_DIR / "jung2015.toml").read_text())


def test_jung2015_instructions_state_what_the_subjects_were_told() -> None:
    ins = load_protocol("jung2015").instructions
    text = ins.training.lower()
    for told in ("household items", "office equipment", "bottom centre", "smaller than"):
        assert told in text, told
    assert "pass after 1 minute" in text and "pass after 1 minute" in ins.main.lower()
    assert ins != InstructionsSpec()


def test_instructions_round_trip_and_default_keeps_hash() -> None:
    spec = load_protocol("jung2015")
    again = ProtocolSpec.from_dict(spec.to_dict())
    assert again == spec and again.instructions == spec.instructions
    d = _jung_dict()
    del d["instructions"]
    plain = ProtocolSpec.from_dict(d)
    assert plain.instructions == InstructionsSpec()
    assert "instructions" not in plain.to_dict()  # protocols without the table keep their hash
    assert plain.content_sha256() != spec.content_sha256()


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"welcome": "hi"}, r"unknown key 'welcome' in \[instructions\]"),
        ({"main": ""}, "instructions.main must not be empty"),
        ({"rest": 3}, "instructions.rest must be str, got int 3"),
        ({"end": "x" * 71}, "instructions.end line 1 must have at most 70 characters"),
        ({"wait": "\n".join("a" * 17)}, "instructions.wait must have at most 16 lines"),
    ],
)
def test_bad_instructions_are_refused(change, match) -> None:
    d = _jung_dict()
    d["instructions"] = {**d["instructions"], **change}
    with pytest.raises(ProtocolError, match=match):
        ProtocolSpec.from_dict(d)


def test_bad_instructions_in_a_file_one_line_exit_2(tmp_path: Path, capsys) -> None:
    from experiment.cli import main

    text = (PROTOCOLS_DIR / "jung2015.toml").read_text().replace('rest = "Break"', "rest = 1")
    (tmp_path / "p.toml").write_text(text)
    with pytest.raises(SystemExit) as exc:
        main(
            [
                "session",
                "run",
                "--protocol",
                str(tmp_path / "p.toml"),
                "--stimuli",
                str(tmp_path / "none"),
                "--subject",
                "S01",
                "--data",
                str(tmp_path / "d.sqlite"),
                "--headless",
            ]
        )
    err = capsys.readouterr().err.strip().splitlines()
    assert exc.value.code == 2 and len(err) == 1 and "instructions.rest" in err[0], err


def test_console_training_shows_protocol_text_then_colour_photos(tmp_path: Path) -> None:
    """The console puts the protocol's texts and the colour photos on the subject's screen."""
    stimset = StimulusSet.load(make_stimulus_set(tmp_path / "set", n_main=2, n_training=2))
    spec = load_protocol("jung2015")
    clock = FakeClock(10.0)
    log = TrialLog(tmp_path / "study.sqlite")
    session = Session.open(log, spec, stimset, "S01", seed=1, clock=clock)
    display = NullDisplay(clock)
    app = OperatorConsole(session, display)

    async def script() -> None:
        async with app.run_test(size=(100, 30)) as pilot:
            assert display.texts[-1] == spec.instructions.wait
            await pilot.press("enter")
            assert display.texts[-1] == spec.instructions.training
            await pilot.press("enter")
            assert app.trial.condition == "colour_wide"
            assert len(display.shown[-1]) == 3 and display.shown[-1][2] == 3
            await pilot.press("f1")
            await pilot.press("enter")
            await pilot.press("f1")
            await pilot.press("enter")
            assert app.trial.condition == "colour_confocal"
            await pilot.press("f1", "f8")
            assert display.texts[-1] == spec.instructions.pause
            await pilot.press("ctrl+q")

    try:
        asyncio.run(asyncio.wait_for(script(), timeout=60))
    finally:
        session.close()
        log.close()


def test_headless_session_shows_the_protocol_texts(tmp_path: Path) -> None:
    from experiment.observers import make_observer

    stimset = StimulusSet.load(make_stimulus_set(tmp_path / "set", n_main=2, n_training=1))
    spec = load_protocol("jung2015")
    log = TrialLog(tmp_path / "study.sqlite")
    session = Session.open(log, spec, stimset, "S01", seed=1, responder="sim:logistic")
    display = NullDisplay()
    try:
        session.run(display, make_observer("logistic", stimset, "S01", rng=0))
    finally:
        session.close()
        log.close()
    assert display.texts[0] == spec.instructions.training
    assert spec.instructions.main in display.texts
    assert display.texts[-1] == spec.instructions.end
    assert display.shown[0][2:] == (3,) and display.shown[1][2:] == (3,)


def _colour_pair(root: Path, shape_px=(200, 300)) -> Path:
    """One training object whose photos are colour: a red disc on a green/blue background."""
    rows, cols = shape_px
    yy, xx = np.mgrid[0:rows, 0:cols]
    disc = (yy - 0.7 * rows) ** 2 + (xx - 0.5 * cols) ** 2 < (0.2 * rows) ** 2
    bg = np.stack(
        [0.1 + 0.0 * xx, 0.4 + 0.3 * ((xx // 7) % 2), 0.3 + 0.5 * ((yy // 9) % 2)], axis=-1
    )
    wide = np.where(disc[..., None], [0.9, 0.1, 0.1], bg)
    narrow = np.where(disc[..., None], [0.9, 0.1, 0.1], 0.5 * bg + 0.2)
    for name, img in (("wide", wide), ("narrow", narrow)):
        (root / "obj00").mkdir(parents=True, exist_ok=True)
        Image.fromarray(np.round(img * 255).astype(np.uint8)).save(root / "obj00" / f"{name}.png")
    (root / "objects.csv").write_text("object,role\nobj00,training\n")
    return root


def test_build_writes_colour_photos_for_training_objects(tmp_path: Path) -> None:
    pairs = _colour_pair(tmp_path / "pairs")
    build_stimulus_set(pairs, tmp_path / "set", workers=1)
    recs = {r.condition: r for r in read_manifest(tmp_path / "set" / "manifest.csv")}
    assert {"colour_wide", "colour_confocal", "photo"} <= set(recs)
    for cond in ("colour_wide", "colour_confocal"):
        r = recs[cond]
        assert (r.level, r.window, r.height, r.width, r.pixels) == (8, 1, 327, 492, 160884)
    wide = np.asarray(Image.open(tmp_path / "set" / recs["colour_wide"].path))
    assert wide.shape == (327, 492, 3) and wide.dtype == np.uint8
    # the disc is red in colour, not grey
    assert wide[230, 246, 0] > 200 and wide[230, 246, 1] < 60
    # independent check: the grey photo is the luminance of the same crop and resize (resize and
    # the Rec. 709 weighting are both linear, so they commute up to 8-bit rounding)
    grey = load_gray(tmp_path / "set" / recs["photo"].path)
    lum = (wide.astype(np.float32) / 255) @ np.array([0.2125, 0.7154, 0.0721], np.float32)
    assert np.abs(lum - grey).max() <= 3 / 255
    assert recs["colour_confocal"].source.endswith("narrow.png")
    assert aspect_crop_box((200, 300), (327, 492)) is not None  # the photos were centre-cropped
