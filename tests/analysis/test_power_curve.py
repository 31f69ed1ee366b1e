"""``analyze power --out``: a power-curve figure and the table, whose recommended numbers of
subjects are the console's."""

from __future__ import annotations

import csv
import json
import re

from tests.conftest import run_cli


def test_power_out_writes_the_curve_and_the_table_with_the_consoles_advice(tmp_path, capsys):
    out = tmp_path / "plan"
    argv = ["analyze", "power", "--odds-ratio", "1,30", "--subjects", "1,2", "--sims", "3"]
    argv += ["--objects", "10", "--levels", "4", "--seed", "5", "--processes", "1"]
    assert run_cli([*argv, "--out", out]) == 0
    console = capsys.readouterr().out
    advice = {}
    for size, rest in re.findall(r"^size (\S+), 4 levels, 10 objects: (.*)$", console, re.M):
        m = re.match(r"subjects needed for power 0.8: (\d+) ", rest)
        advice[float(size)] = int(m.group(1)) if m else None
    assert advice.keys() == {1.0, 30.0} and advice[30.0] is not None and advice[1.0] is None

    data = json.loads((out / "power.json").read_text())
    assert data["simulated"] is True and data["seed"] == 5 and data["target_power"] == 0.8
    assert {c["design"]["size"]: c["n_required"] for c in data["curves"]} == advice
    with (out / "power.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4 and {r["n_sims"] for r in rows} == {"3"}
    flagged = {float(r["size"]): int(r["n_subjects"]) for r in rows if r["recommended"] == "1"}
    assert flagged == {s: n for s, n in advice.items() if n is not None}

    assert (out / "power_curve.png").stat().st_size > 0
    svg = (out / "power_curve.svg").read_text()
    assert f"n = {advice[30.0]}" in svg and "SIMULATED" in svg and "target power 0.8" in svg
    assert "size 1, 4 levels, 10 objects (none reached it)" in svg
    assert f"power curve: {out / 'power_curve.png'}" in console.replace("\n", "")


def test_power_out_refuses_a_folder_holding_other_files(tmp_path, capsys):
    mine = tmp_path / "thesis"
    mine.mkdir()
    (mine / "chapter1.tex").write_text("mine\n")
    argv = ["analyze", "power", "--odds-ratio", "30", "--subjects", "1", "--sims", "1"]
    assert run_cli([*argv, "--out", mine]) == 2
    err = capsys.readouterr().err
    assert "did not write: chapter1.tex" in err and "Traceback" not in err
    assert sorted(p.name for p in mine.iterdir()) == ["chapter1.tex"]
