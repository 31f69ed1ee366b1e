"""A build carries out its plan: the plan's ladder, each source read once, frozen step results."""

from __future__ import annotations

import dataclasses
import pickle
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

import stimuli.io
from stimuli.manifest import read_manifest
from stimuli.stimset import BuildParams
from stimuli.stimset.plan import plan_build
from stimuli.stimset.run import run_plan
from tests.stimuli._build_fixtures import make_pair, write_png

_PARAMS = BuildParams(working_shape_px=(82, 123))


@pytest.fixture(scope="module")
def pairs(tmp_path_factory) -> Path:
    """Two small photo pairs, the second a training object (its colour photos are written)."""
    root = tmp_path_factory.mktemp("pairs")
    for i in range(2):
        wide, narrow, _ = make_pair(i, (82, 123))
        write_png(wide, root / f"obj{i}" / "wide.png")
        write_png(narrow, root / f"obj{i}" / "narrow.png")
    (root / "objects.csv").write_text("object,role\nobj1,training\n")
    return root


def _plan(pairs: Path, out: Path):
    return plan_build(
        pairs,
        out,
        params=_PARAMS,
        force=False,
        replaces=None,
        workers=1,
        implants=(),
        implant_px_per_electrode=8,
    )


def test_the_build_decodes_each_source_photo_once(pairs: Path, tmp_path: Path, monkeypatch):
    """Every decode goes through stimuli.io's one opener; count it per file.

    A training object's colour photos are made from the decode of its grey photos, not read
    again in the write step.
    """
    opened: Counter[str] = Counter()
    real = stimuli.io._open

    def counting(path, *args, **kwargs):
        p = Path(path)
        opened[p.relative_to(pairs).as_posix() if p.is_relative_to(pairs) else str(p)] += 1
        return real(path, *args, **kwargs)

    monkeypatch.setattr(stimuli.io, "_open", counting)
    result = run_plan(_plan(pairs, tmp_path / "set"))
    sources = {f"obj{i}/{k}.png" for i in range(2) for k in ("wide", "narrow")}
    assert {k: opened[k] for k in sources} == dict.fromkeys(sources, 1), opened
    conditions = {r.condition for r in read_manifest(tmp_path / "set" / "manifest.csv")}
    assert {"colour_wide", "colour_confocal"} <= conditions and result.n_stimuli > 0


def test_the_rendered_levels_are_the_plans_ladder(pairs: Path, tmp_path: Path) -> None:
    """A plan whose ladder differs from what params.windows_px gives: the ladder is used."""
    plan = _plan(pairs, tmp_path / "set")
    assert sorted(w for _, w, _ in plan.ladder) == sorted(_PARAMS.windows_px)
    custom = ((1, 18, plan.ladder[1][2]), (2, 1, plan.ladder[-1][2]))  # two levels only
    run_plan(dataclasses.replace(plan, ladder=custom))
    recs = [
        r
        for r in read_manifest(tmp_path / "set" / "manifest.csv")
        if r.condition in ("cluttered", "decluttered")
    ]
    got = sorted({(r.level, r.window, (r.height, r.width)) for r in recs})
    assert got == sorted(custom)
    photo = [r for r in read_manifest(tmp_path / "set" / "manifest.csv") if r.condition == "photo"]
    assert {r.level for r in photo} == {2}  # the photo sits at the ladder's top level


def test_step_results_are_frozen_and_pickle(pairs: Path) -> None:
    """Each step returns a new frozen result (dataclasses.replace); the input is unchanged."""
    from stimuli.stimset.edges import declutter_object
    from stimuli.stimset.pairs import read_pairs
    from stimuli.stimset.prepare import prepare_object

    inp = read_pairs(pairs)
    prepared = prepare_object(inp.sources[1], inp.objects[1], _PARAMS)
    assert prepared.colour is not None and prepared.colour[0].shape == (82, 123, 3)
    with pytest.raises(dataclasses.FrozenInstanceError):
        prepared.threshold = 0.1  # type: ignore[misc]
    edged = declutter_object(prepared, _PARAMS)
    assert edged is not prepared and prepared.wide_edges is None and prepared.threshold is None
    assert edged.wide_edges.dtype == bool and edged.wide is prepared.wide
    back = pickle.loads(pickle.dumps(edged))
    assert np.array_equal(back.narrow_edges, edged.narrow_edges)
    assert back.info == edged.info and back.threshold == edged.threshold


def test_the_library_names_the_parameter_and_the_command_its_flag(pairs, tmp_path, capsys):
    """``declutter='depth'`` on photo pairs: the same refusal, in Python's words and the CLI's."""
    from stimuli.errors import InputError
    from tests.conftest import run_cli

    with pytest.raises(InputError) as caught:
        plan_build(
            pairs,
            tmp_path / "set",
            params=dataclasses.replace(_PARAMS, declutter="depth"),
            force=False,
            replaces=None,
            workers=1,
            implants=(),
            implant_px_per_electrode=8,
        )
    said = str(caught.value)
    assert "`declutter='depth'` needs light fields" in said and "--" not in said
    assert "use `declutter='auto'` or `declutter='sobel'`" in said
    argv = ["stimuli", "build", pairs, "--out", tmp_path / "cli", "--declutter", "depth"]
    assert run_cli(argv) == 2
    err = capsys.readouterr().err
    assert "--declutter depth needs light fields" in err and "`" not in err
    assert "use --declutter auto or --declutter sobel" in err
