"""What leaves the lab is safe to share: formula-safe tables end to end, no host paths.

A hostile object name goes from ``objects.csv`` through ``stimuli build``, a headless simulated
session, ``session export`` and ``analyze`` back into Python unchanged, while every CSV/TSV on
the way shows it to a spreadsheet as text; and no file those commands write holds the folder
they ran in or the home directory.
"""

from __future__ import annotations

import csv
import dataclasses
import os
from pathlib import Path

import pytest

from experiment import cli
from stimuli.manifest import read_objects_csv, write_objects_csv
from tests.conftest import protocol_toml

#: An object name a spreadsheet would run as a live link (CSV injection).
HOSTILE = '=HYPERLINK("http://evil.example/x","cup")'

PROTOCOL = protocol_toml((7, 8), name="tiny", training=None)


def confocal(*args) -> None:
    try:
        cli.main([str(a) for a in args])
    except SystemExit as exc:
        assert not exc.code, f"confocal {' '.join(map(str, args))} exited {exc.code}"


def _text_files(root: Path):
    for p in sorted(root.rglob("*")):
        if p.is_file() and p.suffix in (".csv", ".tsv", ".json", ".md", ".txt", ".toml"):
            yield p


@pytest.fixture(scope="module")
def pipeline(tmp_path_factory):
    """synth -> hostile objects.csv -> build -> headless session -> export -> analyze."""
    root = tmp_path_factory.mktemp("sharing")
    pairs = root / "pairs"
    confocal("stimuli", "synth", "--objects", "2", "--training", "1", "--size", "120x80",
             "--out", pairs)  # fmt: skip
    objects = read_objects_csv(pairs / "objects.csv")
    first_main = next(i for i, o in enumerate(objects) if o.role == "main")
    objects[first_main] = dataclasses.replace(objects[first_main], name=HOSTILE)
    write_objects_csv(objects, pairs / "objects.csv")
    stim = root / "stim"
    confocal("stimuli", "build", pairs, "--out", stim)
    proto = root / "tiny.toml"
    proto.write_text(PROTOCOL)
    db = root / "study.sqlite"
    confocal("session", "run", "--protocol", proto, "--stimuli", stim, "--subject", "S01",
             "--data", db, "--headless", "--seed", "3",
             "--observer-param", "lapse=0")  # fmt: skip
    dataset = root / "dataset"
    confocal("session", "export", db, "--out", dataset)
    report = root / "report"
    confocal("analyze", db, "--out", report, "--no-figures", "--by", "none", "--seed", "1")
    confocal("analyze", "fit", db, "--x", "pixels", "--y", "recognized", "--out", root / "fits",
             "--no-plots")  # fmt: skip
    return root, objects[first_main].object


def test_hostile_object_name_is_text_in_every_table_and_reads_back(pipeline):
    root, oid = pipeline
    from analysis.data import read_trials
    from experiment.session.stimset import StimulusSet

    for table in (root / "pairs" / "objects.csv", root / "stim" / "objects.csv"):
        raw = table.read_text(encoding="utf-8")
        assert "'" + HOSTILE.replace('"', '""') in raw, table
        for line in raw.splitlines():
            for cell in next(csv.reader([line])):
                assert not cell.startswith("="), (table, cell)
    assert StimulusSet.load(root / "stim").objects[oid].name == HOSTILE
    (data_file,) = (root / "dataset" / "data").glob("*_data.csv")
    with open(data_file, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    names = {r["object_name"] for r in rows if r["object"] == oid}
    assert names == {"'" + HOSTILE}, "a spreadsheet shows it as text"
    answered = [r["response"] for r in rows if r["response"] == "'" + HOSTILE]
    assert answered, "the simulated observer named the hostile object at least once"
    for r in rows:
        for cell in r.values():
            assert cell[:1] not in ("=", "@") or cell == "", cell
    # the project's reader gives the original text back
    table = read_trials([data_file]).trials
    assert HOSTILE in set(table["response"])
    assert not any(str(v).startswith("'=") for v in table["response"])


def test_no_host_path_in_any_shared_file(pipeline):
    root, _ = pipeline
    home = os.path.expanduser("~")
    needles = {str(root), str(root.resolve())}
    if home not in ("/", "") and len(home) > 1:
        needles.add(home)
    checked = 0
    for folder in ("pairs", "stim", "dataset", "report", "fits"):
        for p in _text_files(root / folder):
            text = p.read_text(encoding="utf-8")
            for needle in needles:
                assert needle not in text, f"{p.relative_to(root)} holds {needle}"
            checked += 1
    assert checked >= 10
    import json

    meta = json.loads((root / "stim" / "stimulus_set.json").read_text())
    assert meta["pairs"]["name"] == "pairs" and meta["pairs"]["synth"]["generator"]
    assert meta["objects_csv"]["file"] == "objects.csv" and len(meta["objects_csv"]["sha256"]) == 64
    results = json.loads((root / "report" / "results.json").read_text())
    assert [s["file"] for s in results["sources"]] == ["study.sqlite"]
    assert len(results["sources"][0]["sha256"]) == 64
    fit = json.loads((root / "fits" / "results.json").read_text())
    assert fit["source"] == "study.sqlite" and len(fit["source_sha256"]) == 64


def test_exemplar_knowledge_keeps_its_synth_provenance_without_a_path(pipeline):
    """The exemplar observer logs which synthetic renderings it learned from; it used to follow
    the set's absolute ``pairs`` path to ``synth.json``, which a shared set no longer holds."""
    from experiment.observers.exemplar import _synth_provenance
    from experiment.session.stimset import StimulusSet

    root, _ = pipeline
    info = StimulusSet.load(root / "stim").info
    assert _synth_provenance(info) == {
        "generator": "stimuli.synth.write_pairs",
        "seed": 0,
        "version": info["pairs"]["synth"]["version"],
    }
