"""One viewer model for ``confocal view`` and active search: one state machine, one renderer.

``tests/data/active_search_old_log.json.gz`` is an active-search session logged by the code that
still had a second model of its own (``experiment/active/engine.py``: ``ViewerState.depth_px``,
``SearchContext``, ``apply_action``, ``Renderer``), with that code's analysis of the log. Its
``made_by`` field names the commit and the call (``run_session`` of ``test_active.py`` with the
task in its ``task`` field, seed 5, the ``planes`` searcher).
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np
import pytest

from experiment.active import adapter
from experiment.viewer.reference import CpuRenderer, cpu_panes
from experiment.viewer.state import (
    ACTION_EVENTS,
    ACTIONS,
    ViewerModel,
    ViewerState,
    apply_action,
    apply_event,
)

OLD_LOG = Path(__file__).parents[1] / "data" / "active_search_old_log.json.gz"


@pytest.fixture(scope="module")
def old_log() -> dict:
    return json.loads(gzip.decompress(OLD_LOG.read_bytes()))


def _canonical(x) -> str:
    return json.dumps(x, sort_keys=True)


def test_old_active_search_log_analyses_the_same(old_log, tmp_path) -> None:
    """The event-log format is unchanged: an old log's rows give the old analysis exactly."""
    from analysis.active import analyze_active
    from experiment.active.eventlog import ActiveEventLog
    from experiment.log import TrialLog
    from tests.analysis.conftest import active_session

    db = tmp_path / "active_search_old.sqlite"  # the old file's name (the result lists it)
    log = TrialLog(db)
    events = ActiveEventLog(log, active_session(log))
    for r in old_log["rows"]:
        seq = events.append(
            r["kind"], r["payload"], r["t_s"], trial=r["trial"], attempt=r["attempt"]
        )
        assert seq == r["seq"]
    log.close()
    result, trials = analyze_active([db])
    want = old_log["analysis"]
    assert _canonical(result.to_dict()) == _canonical(want["result"])
    assert _canonical(json.loads(trials.to_json(orient="records"))) == _canonical(want["trials"])


def test_one_model_replays_the_old_search_exactly(old_log) -> None:
    """Every logged key, applied by the viewer's state machine and drawn by its renderer, gives
    the state and the implant view the old active-search model logged."""
    from experiment.active.session import _grid_hex

    plan = old_log["rows"][0]["payload"]
    task = plan["task"]
    scene = adapter.load_scene(
        task["scene"], shape_px=tuple(task["scene_shape_px"]), grid=tuple(task["scene_grid"])
    )
    assert scene.sha256 == plan["scene_sha256"]
    near, far = plan["scan_px"]
    model = adapter.search_model(
        plan["planes_px"], near, far, plan["depth_step_px"], scene.shape_px
    )
    conditions = {t["index"]: t["condition"] for t in plan["trials"]}
    renderers = {c: adapter.search_renderer(scene, task["grid_px"], c) for c in adapter.CONDITIONS}
    state = None
    n_keys = n_states = 0
    actions = set()
    for r in old_log["rows"][1:]:
        p = r["payload"]
        if r["kind"] == "trial_start":
            state = ViewerState(model.near_px, plane=model.plane_of(model.near_px))
        elif r["kind"] == "key" and p["action"] not in ("answer", "pass"):
            state = apply_action(model, state, p["action"], box=p.get("box"))
            actions.add(p["action"])
            n_keys += 1
        elif r["kind"] == "state":
            zoom = None if p["zoom"] is None else tuple(p["zoom"])
            assert (state.disparity_px, state.plane, state.zoom) == (
                p["depth_px"],
                p["plane"],
                zoom,
            )
            panes = renderers[conditions[r["trial"]]].render(state)
            assert _grid_hex(panes.grid) == p["implant"]
            assert int(panes.grid.sum()) == p["on_cells"]
            n_states += 1
    assert n_states > 40 and n_keys > 40
    assert {"plane_next", "depth_far", "zoom", "unzoom"} <= actions  # the log covers them


def test_viewer_and_search_draw_the_same_panes_through_one_renderer() -> None:
    """A state drawn by the viewer's call (cpu_panes with its layout) and by active search's
    renderer (a bare on/off grid, cached confocal images) gives the same panes."""
    from stimuli.implants import load_implant

    scene = adapter.load_scene("synthetic:three_plane", shape_px=(40, 50), grid=(3, 3))
    layout = load_implant("argus2")
    search = adapter.search_renderer(scene, layout.shape, "decluttered")
    for state in (
        ViewerState(3.0, "argus2"),
        ViewerState(1.5, "argus2", zoom=(4, 6, 30, 20), threshold=0.05),
    ):
        a = cpu_panes(scene.lightfield, state, layout)
        b = search.render(state)
        for name in ("source", "magnitude", "edges", "cells"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
        assert (a.threshold, a.grey_levels) == (b.threshold, b.grey_levels)
    # the cluttered condition starts from the centre view, as the viewer's panes show it
    clut = adapter.search_renderer(scene, layout.shape, "cluttered").render(ViewerState(3.0))
    np.testing.assert_array_equal(clut.source, scene.centre_view())
    # and the cache: the same image object for the same disparity
    r = CpuRenderer(scene.lightfield, (6, 10))
    assert r.confocal(2.0) is r.confocal(2.0) and r.has(2.0) and not r.has(2.5)


def test_actions_are_viewer_events() -> None:
    """Each active-search action is the viewer's event of the same effect."""
    model = ViewerModel((40, 50), (0.5, 10.0), 0.5, planes_px=(8.0, 4.0, 1.0))
    s = ViewerState(4.5, "argus2")
    for action in ACTIONS:
        ev = ACTION_EVENTS[action]
        box = [5, 6, 20, 10] if action == "zoom" else None
        got = apply_action(model, s, action, box=box)
        if ev is None:
            assert got == s
        else:
            payload = {"box": box} if action == "zoom" else ev[1]
            assert got == apply_event(model, s, ev[0], payload)
    off = ViewerModel((40, 50), (0.5, 10.0), 0.5, zoom_allowed=False)
    assert apply_event(off, s, "drag", {"box": [0, 0, 20, 20]}) == s


def test_viewer_log_states_written_before_grey_levels_still_read() -> None:
    """The viewer's logged states called the grey-level count ``levels``; they still read."""
    old = {"disparity_px": 3.0, "implant": "brainport", "levels": 4, "zoom": [1, 2, 30, 40]}
    s = ViewerState.from_dict(old)
    assert (s.grey_levels, s.zoom) == (4, (1, 2, 30, 40))
    assert "levels" not in s.to_dict() and s.to_dict()["grey_levels"] == 4
