"""Protocols: loading, checking, round trips, shipped files and their SHA256SUMS (H10, H15)."""

from __future__ import annotations

import hashlib
import json
import math
import tomllib

import pytest

from experiment.protocol import (
    PROTOCOLS_DIR,
    BlockSpec,
    Condition,
    DisplaySpec,
    ProtocolError,
    ProtocolSpec,
    ScoringSpec,
    load_protocol,
)
from tests.conftest import protocol_toml

MINIMAL = protocol_toml((1, 2), name="mini", training=None)


def minimal_with(path: str, value: str | None) -> str:
    """Return :data:`MINIMAL` with one field set to the TOML text ``value``, or removed (None).

    ``path`` is ``table.key`` (``blocks`` is the main block), a bare key at top level, or a bare
    table name, which ``value=None`` removes whole.
    """
    parsed = tomllib.loads(MINIMAL)
    parsed["blocks"] = parsed["blocks"][0]
    tables = {"": {}} | {t: {k: json.dumps(v) for k, v in f.items()} for t, f in parsed.items()}
    table, _, key = path.rpartition(".")
    if value is None and path in tables:
        del tables[path]
    elif value is None:
        del tables[table][key]
    else:
        tables.setdefault(table, {})[key] = value
    lines = [f"{k} = {v}" for k, v in tables.pop("").items()]
    for name, fields in tables.items():
        lines += [f"[[{name}]]" if name == "blocks" else f"[{name}]"]
        lines += [f"{k} = {v}" for k, v in fields.items()]
    return "\n".join(lines) + "\n"


def write(tmp_path, text, name="p.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize("path", sorted(PROTOCOLS_DIR.glob("*.toml")), ids=lambda p: p.name)
def test_every_shipped_protocol_loads_and_round_trips(path):
    spec = load_protocol(path)
    again = ProtocolSpec.from_dict(spec.to_dict())
    assert again == spec
    assert again.content_sha256() == spec.content_sha256()
    assert spec.source_sha256 == hashlib.sha256(path.read_bytes()).hexdigest()


def test_protocol_files_match_sha256sums():
    sums = {}
    for line in (PROTOCOLS_DIR / "SHA256SUMS").read_text().splitlines():
        digest, name = line.split(maxsplit=1)
        sums[name.lstrip("*")] = digest
    files = sorted(p.name for p in PROTOCOLS_DIR.glob("*.toml"))
    assert sorted(sums) == files, "SHA256SUMS must list exactly the protocol files"
    for name in files:
        assert hashlib.sha256((PROTOCOLS_DIR / name).read_bytes()).hexdigest() == sums[name], name


def test_jung2015_settings_follow_the_paper():
    spec = load_protocol("jung2015")
    assert spec.pass_allowed_after_s == 60.0
    assert spec.feedback is False
    d = spec.display
    assert (d.screen_width_px, d.screen_height_px, d.viewing_distance_cm) == (1280, 1024, 80.0)
    assert (d.image_width_cm, d.image_height_cm) == (14.6, 9.7)
    assert d.border_rgb == (0, 0, 255)
    w_deg, h_deg = d.image_size_deg
    # Sec. 3.1 gives 10.4 x 6.9 deg: 2 atan(14.6 / 160) rad = 10.43 deg
    assert math.isclose(w_deg, 10.4, abs_tol=0.05) and math.isclose(h_deg, 6.9, abs_tol=0.05)
    sc = spec.scoring
    assert [s for s in ("named", "use", "shape", "wrong", "pass") if sc.is_recognized(s)] == [
        "named",
        "use",
    ]
    main = spec.main_blocks
    assert len(main) == 1
    assert main[0].levels == tuple(range(1, 9))
    assert main[0].conditions == (Condition.CLUTTERED, Condition.DECLUTTERED)
    assert main[0].level_order == "ascending" and main[0].trial_order == "random"
    training = [b for b in spec.blocks if b.part == "training"]
    # Sec. 3.1: "at full resolution ... conventional and confocal images were shown followed by
    # the edge-filtered and compressed images"
    assert training[0].conditions == ("colour_wide", "colour_confocal")
    assert training[0].levels == (8,) and training[1].levels == tuple(range(1, 9))


def test_load_by_bare_name_and_missing_file(tmp_path):
    assert load_protocol("jung2015").name == "jung2015"
    with pytest.raises(ProtocolError, match=r"nope\.toml: protocol file not found"):
        load_protocol(tmp_path / "nope.toml")


def test_defaults_fill_display_and_scoring(tmp_path):
    spec = load_protocol(write(tmp_path, MINIMAL))
    assert spec.display == DisplaySpec()
    assert spec.scoring == ScoringSpec()
    assert spec.blocks[0].group_by == "level_condition"


#: (field path, bad TOML value, the message that must name it)
BAD_FIELDS = [
    ("protocol.colour", "1", r"p\.toml: unknown key 'colour' in \[protocol\]"),
    ("extra", "1", r"unknown key 'extra' at top level"),
    ("blocks.level", "[1]", r"unknown key 'level' in \[blocks\[0\]\]"),
    ("display.screen_widht_px", "3", r"unknown key 'screen_widht_px' in \[display\]"),
    ("blocks.levels", '[1, "2"]', r"levels\[\] must be int, got str"),
    ("blocks.levels", "[1, 1]", r"levels lists a level twice"),
    ("blocks.levels", "[0]", r"levels must be >= 1, got 0"),
    ("blocks.levels", "[]", r"levels must be a non-empty list"),
    ("blocks.part", '"warmup"', r"part must be one of training, main, got 'warmup'"),
    ("blocks.conditions", '["blurry"]', r"conditions\[\] must be one of"),
    ("blocks.conditions", '["photo", "photo"]', r"lists a condition twice"),
    ("blocks.group_by", '"subject"', r"group_by must be one of"),
    ("blocks.level_order", '"up"', r"level_order must be one of"),
    ("blocks.condition_order", '"up"', r"condition_order must be one of"),
    ("blocks.trial_order", '"up"', r"trial_order must be one of"),
    ("blocks.block_order", '"up"', r"block_order must be one of"),
    ("blocks.repetitions", "0", r"repetitions must be >= 1, got 0"),
    ("blocks.repetitions", "1.5", r"repetitions must be int"),
    ("blocks.break_every_blocks", "-1", r"break_every_blocks must be >= 0"),
    ("blocks.objects", "[]", r"objects must be a role name or a list of ids"),
    ("blocks.objects", '""', r"objects must be a role name"),
    ("blocks.objects", '["a", "a"]', r"objects lists an object twice"),
    ("blocks.objects", '["a", 3]', r"objects\[\] must be str"),
    ("protocol.name", '""', r"protocol.name must not be empty"),
    ("protocol.name", "3", r"protocol.name must be str"),
    ("protocol.description", "2", r"protocol.description must be str"),
    ("protocol.pass_allowed_after_s", "-1", r"pass_allowed_after_s must be >= 0"),
    ("protocol.feedback", "1", r"protocol.feedback must be bool"),
    ("blocks.part", '"training"', r"at least one entry with part = 'main'"),
    ("display.screen_width_px", "0", r"display.screen_width_px must be >= 1"),
    ("display.screen_height_px", "1.5", r"display.screen_height_px must be int"),
    ("display.viewing_distance_cm", "0", r"viewing_distance_cm must be a positive number"),
    ("display.image_width_cm", "99", r"image_width_cm must be <= screen_width_cm"),
    ("display.image_height_cm", "-2", r"image_height_cm must be a positive number"),
    ("display.screen_width_cm", '"40"', r"screen_width_cm must be int or float"),
    ("display.border_rgb", "[0, 0, 256]", r"border_rgb must be 3 integers"),
    ("display.background_rgb", "[0, 0]", r"background_rgb must be 3 integers"),
    ("display.border_width_px", "-1", r"border_width_px must be >= 0"),
    ("display", "3", r"\[display\] must be a table"),
    ("scoring.recognized", "{ named = true }", r"scoring.recognized is missing score 'use'"),
    ("scoring.recognized", "{ named = true, guessed = true }", r"unknown score 'guessed'"),
    (
        "scoring.recognized",
        "{ named = 1, use = true, shape = false, wrong = false, pass = false }",
        r"scoring.recognized.named must be true or false",
    ),
    ("scoring.recognized", "3", r"scoring.recognized must be a table"),
    ("scoring.primary_rater", '" "', r"primary_rater must not be empty"),
]


@pytest.mark.parametrize(("path", "value", "match"), BAD_FIELDS)
def test_bad_protocol_names_the_field(tmp_path, path, value, match):
    with pytest.raises(ProtocolError, match=match):
        load_protocol(write(tmp_path, minimal_with(path, value)))


@pytest.mark.parametrize(
    ("path", "match"),
    [
        ("blocks.objects", r"\[blocks\[0\]\] is missing field objects"),
        ("protocol.name", r"\[protocol\] is missing field name"),
        ("protocol", r"missing table \[protocol\]"),
    ],
)
def test_missing_field_is_named(tmp_path, path, match):
    with pytest.raises(ProtocolError, match=match):
        load_protocol(write(tmp_path, minimal_with(path, None)))


def test_no_blocks_and_bad_toml(tmp_path):
    with pytest.raises(ProtocolError, match=r"missing \[\[blocks\]\]"):
        load_protocol(write(tmp_path, '[protocol]\nname = "x"\n'))
    with pytest.raises(ProtocolError, match=r"p\.toml: not valid TOML"):
        load_protocol(write(tmp_path, "[protocol\nname="))


def test_error_is_one_line(tmp_path):
    with pytest.raises(ProtocolError) as exc:
        load_protocol(write(tmp_path, MINIMAL.replace("[protocol]", "[protocol]\nfoo = 1")))
    assert "\n" not in str(exc.value)
    assert exc.value.exit_code == 2


def test_specs_are_frozen_and_checked_when_built():
    b = BlockSpec(part="main", objects="main", levels=(1,), conditions=("cluttered",))
    with pytest.raises(AttributeError):
        b.levels = (2,)  # type: ignore[misc]
    with pytest.raises(ProtocolError, match="repetitions must be >= 1"):
        BlockSpec(
            part="main", objects="main", levels=(1,), conditions=("cluttered",), repetitions=0
        )
    with pytest.raises(ProtocolError, match="blocks must hold BlockSpec"):
        ProtocolSpec(name="x", blocks=("nope",))  # type: ignore[arg-type]
    with pytest.raises(ProtocolError, match="display must be a DisplaySpec"):
        ProtocolSpec(name="x", blocks=(b,), display={})  # type: ignore[arg-type]
    with pytest.raises(ProtocolError, match="scoring must be a ScoringSpec"):
        ProtocolSpec(name="x", blocks=(b,), scoring={})  # type: ignore[arg-type]
    with pytest.raises(ProtocolError, match="a protocol must be a table"):
        ProtocolSpec.from_dict([])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="score must be one of"):
        ScoringSpec().is_recognized("maybe")


def test_content_hash_ignores_formatting_but_not_content(tmp_path):
    a = load_protocol(write(tmp_path, MINIMAL, "a.toml"))
    b = load_protocol(write(tmp_path, "# comment\n" + MINIMAL, "b.toml"))
    c = load_protocol(write(tmp_path, MINIMAL.replace("[1, 2]", "[1, 3]"), "c.toml"))
    assert a.content_sha256() == b.content_sha256() != c.content_sha256()
    assert a.source_sha256 != b.source_sha256


@pytest.mark.slow
def test_wheel_ships_the_protocols(tmp_path, repo_root) -> None:
    """A non-editable install finds the shipped protocols: the wheel carries every file of
    protocols/SHA256SUMS as data under share/confocal/protocols, where PROTOCOLS_DIR looks
    when there is no source checkout."""
    import subprocess
    import sys
    import zipfile

    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "-q",
            "--no-deps",
            "-w",
            str(tmp_path),
            str(repo_root),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    (wheel,) = tmp_path.glob("active_confocal-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    listed = [line.split()[1] for line in (PROTOCOLS_DIR / "SHA256SUMS").read_text().splitlines()]
    for name in [*listed, "SHA256SUMS"]:
        assert any(n.endswith(f".data/data/share/confocal/protocols/{name}") for n in names), name
    for layout in sorted((PROTOCOLS_DIR / "implants").glob("*.toml")):  # implant layouts
        want = f".data/data/share/confocal/protocols/implants/{layout.name}"
        assert any(n.endswith(want) for n in names), layout.name


def test_protocol_package_does_not_import_the_active_session():
    """The ``[task]`` table is part of the protocol: loading one needs nothing of
    ``experiment.active`` (which imports the protocol), so the two never import in a circle."""
    import subprocess
    import sys

    code = (
        "import sys; from experiment.protocol import load_protocol; "
        "spec = load_protocol('active_search'); "
        "print(type(spec.task).__module__, 'experiment.active' in sys.modules)"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == ["experiment.protocol.task", "False"]


def test_spec_fields_must_hold_their_spec_classes():
    b = BlockSpec(part="main", objects="main", levels=(1,), conditions=("cluttered",))
    with pytest.raises(ProtocolError, match="instructions must be an InstructionsSpec, got dict"):
        ProtocolSpec(name="x", blocks=(b,), instructions={})  # type: ignore[arg-type]
    with pytest.raises(ProtocolError, match="task must be an ActiveSearchSpec, got str"):
        ProtocolSpec(name="x", blocks=(b,), task="active_search")  # type: ignore[arg-type]
