"""Active search as a study: protocol task, state machine, event log,
simulated searcher end to end, crash and resume."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from experiment.active.adapter import search_model, search_renderer
from experiment.active.eventlog import ActiveEventLog
from experiment.active.searcher import Action, EdgeRecogniser, ScriptedSearcher, SimulatedSearcher
from experiment.active.session import ActiveSession
from experiment.active.task import plan_trials
from experiment.clock import FakeClock
from experiment.log import ResumeMismatch, TrialLog, TrialLogError
from experiment.protocol import ProtocolError, ProtocolSpec, load_protocol
from experiment.protocol.task import ActiveSearchSpec, task_from_table
from experiment.viewer.state import ACTIONS, KEYMAP, ViewerState, apply_action
from tests.analysis.conftest import active_session

#: A small scene keeps every test in seconds (the shipped protocol uses the paper's 308x385).
SMALL = {
    "type": "active_search",
    "scene": "synthetic:three_plane",
    "targets": ["pedestrian", "tree"],
    "conditions": ["decluttered", "cluttered"],
    "scene_shape_px": [154, 192],
    "n_planes": 60,
    "time_limit_s": 40.0,
}


def small_protocol(**task) -> ProtocolSpec:
    """The shipped protocol with a smaller scene (and any task fields overridden)."""
    data = load_protocol("active_search").to_dict()
    data["task"] = {**SMALL, **task}
    return ProtocolSpec.from_dict(data)


def run_session(log: TrialLog, protocol: ProtocolSpec, *, seed: int = 5, strategy="planes"):
    s = ActiveSession.open(log, protocol, "S01", seed=seed, clock=FakeClock())
    sim = SimulatedSearcher(
        EdgeRecogniser(s.scene, protocol.task.grid_px, rng=seed), strategy, rng=seed
    )
    events = s.run(sim)
    s.close()
    return s, events


# -- the protocol's [task] table ----------------------------------------------------------------


def test_shipped_active_protocol_loads_and_round_trips() -> None:
    spec = load_protocol("active_search")
    assert isinstance(spec.task, ActiveSearchSpec)
    assert spec.blocks == ()
    assert spec.task.grid_px == (28, 35)  # Jung 2015 Fig. 13: 980 cells
    again = ProtocolSpec.from_dict(spec.to_dict())
    assert again == spec and again.content_sha256() == spec.content_sha256()


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"type": "free_viewing"}, r"task.type must be one of active_search"),
        ({"colour": "red"}, r"unknown key 'colour' in \[task\]"),
        ({"targets": []}, r"task.targets must be a non-empty list"),
        ({"targets": ["tree", "tree"]}, r"task.targets lists a target twice"),
        ({"targets": [3]}, r"task.targets\[\] must be str"),
        ({"conditions": ["photo"]}, r"task.conditions\[\] must be one of decluttered"),
        ({"conditions": []}, r"task.conditions must be a non-empty list"),
        ({"conditions": ["cluttered", "cluttered"]}, r"lists a condition twice"),
        ({"grid_px": [28]}, r"task.grid_px must be 2 integers >= 1"),
        ({"zoom_allowed": "yes"}, r"task.zoom_allowed must be bool"),
        ({"time_limit_s": 0}, r"task.time_limit_s must be > 0"),
        ({"n_planes": 2}, r"task.n_planes must be >= 3"),
        ({"depth_step_px": -1.0}, r"task.depth_step_px must be > 0"),
        ({"scene_shape_px": [8, 8]}, r"task.scene_shape_px must be 2 integers >= 16"),
        ({"scene_grid": [0, 3]}, r"task.scene_grid must be 2 integers >= 1"),
        ({"repetitions": 0}, r"task.repetitions must be >= 1"),
        ({"trial_order": "sorted"}, r"task.trial_order must be one of random, listed"),
        ({"scene": " "}, r"task.scene must name a scene"),
    ],
)
def test_bad_task_field_names_the_field(change, match) -> None:
    with pytest.raises(ProtocolError, match=match):
        task_from_table({**SMALL, **change})


def test_task_table_shape_errors() -> None:
    with pytest.raises(ProtocolError, match=r"\[task\] must be a table"):
        task_from_table(["active_search"])
    with pytest.raises(ProtocolError, match=r"\[task\] is missing field type"):
        task_from_table({"scene": "x"})
    with pytest.raises(ProtocolError, match=r"\[task\] is missing field scene"):
        task_from_table({"type": "active_search", "targets": ["tree"]})


def test_bad_task_in_protocol_file_is_one_line_naming_file(tmp_path) -> None:
    text = load_protocol("active_search").source_path or ""
    raw = open(text, encoding="utf-8").read().replace("n_planes = 200", "n_planes = 1")
    p = tmp_path / "bad.toml"
    p.write_text(raw)
    with pytest.raises(ProtocolError, match=r"bad.toml: .*task.n_planes must be >= 3"):
        load_protocol(p)


def test_static_schedule_refuses_an_active_protocol() -> None:
    from experiment.session.schedule import build_schedule

    with pytest.raises(ProtocolError, match=r"runs with 'confocal active run'"):
        build_schedule(load_protocol("active_search"), stimset=None, rng=0)


def test_plan_is_every_target_by_condition_and_seeded() -> None:
    task = task_from_table({**SMALL, "repetitions": 2})
    a, b = plan_trials(task, 1), plan_trials(task, 1)
    assert a == b
    assert [t.index for t in a] == list(range(8))
    for rep in (0, 1):
        pairs = sorted((t.target, t.condition) for t in a if t.repetition == rep)
        assert pairs == sorted((t, c) for t in SMALL["targets"] for c in SMALL["conditions"])
    listed = plan_trials(replace(task, trial_order="listed"), 0)
    assert [(t.target, t.condition) for t in listed[:2]] == [
        ("pedestrian", "decluttered"),
        ("tree", "decluttered"),
    ]


# -- the viewer's state machine -----------------------------------------------------------------

CTX = search_model((8.0, 4.0, 1.0), 10.0, 0.5, 0.5, (40, 50))


def test_plane_jumps_and_depth_keys() -> None:
    s = ViewerState(10.0)
    s = apply_action(CTX, s, "plane_next")
    assert (s.disparity_px, s.plane) == (8.0, 0)
    s = apply_action(CTX, s, "plane_next")
    assert (s.disparity_px, s.plane) == (4.0, 1)
    s = apply_action(CTX, s, "depth_near")  # between planes: no plane index
    assert (s.disparity_px, s.plane) == (4.5, None)
    assert apply_action(CTX, s, "plane_prev").plane == 0  # nearer: 8.0
    assert apply_action(CTX, s, "plane_next").plane == 1  # farther: 4.0 (first < 4.5)
    end = ViewerState(1.0, plane=2)
    assert apply_action(CTX, end, "plane_next") == end  # no plane beyond the last
    assert apply_action(CTX, ViewerState(0.5), "depth_far").disparity_px == 0.5  # clamped
    assert apply_action(CTX, ViewerState(10.0), "depth_near").disparity_px == 10.0
    assert apply_action(CTX, ViewerState(7.5), "depth_near").plane == 0  # lands on a plane


@given(
    st.lists(
        st.sampled_from(["depth_near", "depth_far", "plane_next", "plane_prev", "unzoom"]),
        max_size=30,
    ),
    st.floats(0.5, 10.0),
)
def test_state_stays_in_range_and_plane_matches_depth(actions, start) -> None:
    s = ViewerState(start, plane=CTX.plane_of(start))
    for a in actions:
        s = apply_action(CTX, s, a)
        assert CTX.far_px <= s.disparity_px <= CTX.near_px
        assert s.plane == CTX.plane_of(s.disparity_px)


def test_zoom_and_its_errors() -> None:
    s = apply_action(CTX, ViewerState(8.0, plane=0), "zoom", box=(5, 6, 20, 10))
    assert s.zoom == (5, 6, 20, 10)
    assert apply_action(CTX, s, "unzoom").zoom is None
    off = replace(CTX, zoom_allowed=False)
    assert apply_action(off, ViewerState(8.0), "zoom", box=(0, 0, 4, 4)).zoom is None
    with pytest.raises(ValueError, match=r"zoom needs a box"):
        apply_action(CTX, ViewerState(8.0), "zoom")
    with pytest.raises(ValueError, match=r"must be at least 2x2 px inside the 50x40 view"):
        apply_action(CTX, ViewerState(8.0), "zoom", box=(40, 0, 20, 10))
    with pytest.raises(ValueError, match=r"box must be \(x, y, w, h\)"):
        apply_action(CTX, ViewerState(8.0), "zoom", box="big")
    with pytest.raises(ValueError, match=r"action must be one of"):
        apply_action(CTX, ViewerState(8.0), "jump")


# -- the event log -------------------------------------------------------------------------------


def test_event_log_is_append_only_and_checks_input(tmp_path) -> None:
    log = TrialLog(tmp_path / "e.sqlite")
    sid = active_session(log, "S")
    ev = ActiveEventLog(log, sid)
    assert ev.append("key", {"key": "Up", "action": "depth_near"}, 1.5, trial=0) == 0
    assert ev.append("state", {"depth_px": 1.0}, 1.5, trial=0) == 1
    with pytest.raises(ValueError, match=r"kind must be one of"):
        ev.append("mouse", {}, 2.0, trial=0)
    with pytest.raises(ValueError, match=r"payload must be a dict"):
        ev.append("key", ["Up"], 2.0, trial=0)
    with pytest.raises(ValueError, match=r"t_s must be finite"):
        ev.append("key", {}, float("nan"), trial=0)
    with pytest.raises(TrialLogError, match=r"query failed|append-only"):
        log.execute("UPDATE active_events SET kind = 'x'")
    with pytest.raises(Exception, match=r"append-only"):
        log._con.execute("DELETE FROM active_events")
    other = ActiveEventLog(log, sid)  # a second writer with a stale counter
    other._next_seq = 1
    with pytest.raises(TrialLogError, match=r"cannot append active event 1"):
        other.append("key", {}, 3.0, trial=0)
    assert [r["seq"] for r in ev.rows()] == [0, 1]
    log.close()


# -- end to end with the simulated searcher ------------------------------------------------------


@pytest.fixture(scope="module")
def protocol() -> ProtocolSpec:
    return small_protocol()


def test_headless_session_log_matches_generated_events(tmp_path, protocol) -> None:
    log = TrialLog(tmp_path / "a.sqlite")
    s, events = run_session(log, protocol)
    rows = ActiveEventLog(log, s.session_id).rows()
    assert rows[0]["kind"] == "plan"
    assert [r["seq"] for r in rows] == list(range(len(rows)))  # no gap, no duplicate
    assert rows[1:] == events  # every generated event, exactly, in order
    answers = [e for e in events if e["kind"] == "answer"]
    assert sorted(e["trial"] for e in answers) == list(range(len(s.trials)))
    assert log.session(s.session_id)["status"] == "completed"
    for e in events:
        if e["kind"] == "trial_start":
            assert e["payload"]["searcher"] == "sim:planes"  # labelled simulated
    # every displayed state is what the CPU pipeline shows for it (re-rendered from the log)
    from experiment.active.session import _grid_hex

    plan = {t.index: t for t in s.trials}
    for e in events:
        if e["kind"] == "state":
            p = e["payload"]
            r = search_renderer(s.scene, protocol.task.grid_px, plan[e["trial"]].condition)
            zoom = tuple(p["zoom"]) if p["zoom"] else None
            v = r.render(ViewerState(p["depth_px"], plane=p["plane"], zoom=zoom))
            assert _grid_hex(v.grid) == p["implant"]
            assert int(v.grid.sum()) == p["on_cells"]
    log.close()


def test_analysis_reads_the_log_while_a_session_writes_it(tmp_path, protocol) -> None:
    """A read-only reader (analysis) sees every committed event of a running session (H22)."""
    from analysis.active import read_active_events

    db = tmp_path / "live.sqlite"
    log = TrialLog(db)
    s = ActiveSession.open(log, protocol, "S01", seed=2, clock=FakeClock())
    sim = SimulatedSearcher(EdgeRecogniser(s.scene, protocol.task.grid_px, rng=2), "ordered", rng=2)
    seen = []
    for ev in s.iter_run(sim):
        seen.append(ev)
        if len(seen) == 7:
            break
    read = read_active_events([db])
    # the plan, the 7 events so far, and any event committed with the 7th (a key's new state)
    assert list(read["seq"]) == list(range(len(read))) and 8 <= len(read) <= 9
    assert list(read["kind"])[1:8] == [e["kind"] for e in seen]
    s.close()
    log.close()


def test_memory_and_sqlite_logs_give_identical_events(tmp_path, protocol) -> None:
    a = TrialLog(":memory:")
    b = TrialLog(tmp_path / "b.sqlite")
    _, ea = run_session(a, protocol, seed=9, strategy="ordered")
    _, eb = run_session(b, protocol, seed=9, strategy="ordered")
    assert ea == eb
    a.close()
    b.close()


def test_scripted_search_logs_each_key_and_state(protocol) -> None:
    """A scripted search: the logged states follow the state machine, and the implant view is
    the one computed directly with stimuli (refocus, Sobel + Otsu, compress)."""
    from stimuli import jung2015
    from stimuli.compress import compress
    from stimuli.declutter import auto_threshold, declutter
    from stimuli.refocus import refocus

    p = small_protocol(conditions=["decluttered"], targets=["tree"], trial_order="listed")
    log = TrialLog(":memory:")
    s = ActiveSession.open(log, p, "S09", seed=0, clock=FakeClock())
    script = [
        Action("PageDown", "plane_next", 1.0),
        Action("Down", "depth_far", 0.5),
        Action("drag", "zoom", 0.5, box=(10, 20, 80, 60)),
        Action("Escape", "unzoom", 0.5),
        Action("Enter", "answer", 2.0, response="a tree"),
    ]
    events = s.run(ScriptedSearcher(script))
    keys = [e["payload"]["action"] for e in events if e["kind"] == "key"]
    assert keys == ["plane_next", "depth_far", "zoom", "unzoom", "answer"]
    states = [e["payload"] for e in events if e["kind"] == "state"]
    ctx = s.model
    expect = [ViewerState(ctx.near_px, plane=ctx.plane_of(ctx.near_px))]
    for a in script[:-1]:
        expect.append(apply_action(ctx, expect[-1], a.action, box=a.box))
    assert [(st["depth_px"], st["plane"], st["zoom"]) for st in states] == [
        (e.disparity_px, e.plane, list(e.zoom) if e.zoom else None) for e in expect
    ]
    zoomed = states[3]
    img = refocus(s.scene.lightfield, zoomed["depth_px"])[20:80, 10:90]
    edges = declutter(img, threshold=auto_threshold(img))
    grid = compress(edges, (28, 35), edge_ratio=jung2015.EDGE_RATIO)
    assert np.packbits(grid.ravel()).tobytes().hex() == zoomed["implant"]
    ans = next(e for e in events if e["kind"] == "answer")
    assert ans["payload"]["rt_s"] == pytest.approx(4.5)  # the script's delays, FakeClock
    score = next(e for e in events if e["kind"] == "score")["payload"]
    assert (score["score"], score["recognized"]) == ("named", True)
    s.rescore(0, "shape", "operator")
    last = ActiveEventLog(log, s.session_id).rows()[-1]
    assert last["payload"] == {
        "score": "shape",
        "recognized": False,
        "rater": "operator",
        "primary": True,
    }
    with pytest.raises(ValueError, match=r"score must be one of"):
        s.rescore(0, "great", "operator")
    log.close()


def test_time_limit_ends_a_trial_with_a_pass() -> None:
    p = small_protocol(conditions=["cluttered"], targets=["tree"], time_limit_s=3.0)
    log = TrialLog(":memory:")
    s = ActiveSession.open(log, p, "S02", seed=0, clock=FakeClock())
    events = s.run(ScriptedSearcher([Action("Down", "depth_far", 1.0)] * 10))
    ans = next(e for e in events if e["kind"] == "answer")
    assert ans["payload"]["response"] == "" and ans["payload"]["rt_s"] == pytest.approx(3.0)
    assert [e["payload"]["key"] for e in events if e["kind"] == "key"][-1] == "timeout"
    log.close()


def test_open_refuses_bad_protocols_and_mismatched_resume(tmp_path) -> None:
    log = TrialLog(":memory:")
    with pytest.raises(ProtocolError, match=r"not an active-search protocol"):
        ActiveSession.open(log, load_protocol("jung2015"), "S01")
    with pytest.raises(ProtocolError, match=r"task.targets: 'dog' is not an object"):
        ActiveSession.open(log, small_protocol(targets=["dog"]), "S01")
    p = small_protocol(targets=["tree"], conditions=["cluttered"])
    s = ActiveSession.open(log, p, "S01", seed=1, clock=FakeClock())
    s.close()
    with pytest.raises(ResumeMismatch, match=r"with seed 1, not 2"):
        ActiveSession.open(log, p, "S01", seed=2)
    with pytest.raises(ResumeMismatch, match=r"resume it with that protocol"):
        ActiveSession.open(log, small_protocol(targets=["pedestrian"]), "S01")
    with pytest.raises(ValueError, match=r"no trial is running"):
        s.press("Up", "depth_near")
    log.close()


# -- crash and resume ----------------------------------------------------------------------------

_CHILD = textwrap.dedent(
    """
    import json, os, signal, sys
    from experiment.active.eventlog import ActiveEventLog
    from experiment.active.searcher import EdgeRecogniser, SimulatedSearcher
    from experiment.active.session import ActiveSession
    from experiment.clock import FakeClock
    from experiment.protocol import ProtocolSpec
    from experiment.log import TrialLog

    db, kill_after, proto = sys.argv[1], int(sys.argv[2]), json.loads(sys.argv[3])
    original = ActiveEventLog.append

    def append(self, *a, **k):
        seq = original(self, *a, **k)
        if seq + 1 >= kill_after and self.log._depth == 0:  # committed: die right here
            os.kill(os.getpid(), signal.SIGKILL)
        return seq

    ActiveEventLog.append = append
    spec = ProtocolSpec.from_dict(proto)
    log = TrialLog(db)
    s = ActiveSession.open(log, spec, "S01", seed=5, clock=FakeClock())
    sim = SimulatedSearcher(EdgeRecogniser(s.scene, spec.task.grid_px, rng=5), "planes", rng=5)
    s.run(sim)
    """
)


def _by_trial(rows):
    """Answered attempt of each trial: (kind, payload, t_s - onset) per event."""
    out = {}
    ans = {(r["trial"], r["attempt"]) for r in rows if r["kind"] == "answer"}
    for r in rows:
        if (r["trial"], r["attempt"]) in ans:
            out.setdefault(r["trial"], []).append(r)
    return {
        k: [(r["kind"], r["payload"], round(r["t_s"] - v[0]["t_s"], 9)) for r in v]
        for k, v in out.items()
    }


def test_resume_after_kill_keeps_events_exact(tmp_path, protocol) -> None:
    ref_log = TrialLog(tmp_path / "ref.sqlite")
    ref, _ = run_session(ref_log, protocol)
    ref_rows = ActiveEventLog(ref_log, ref.session_id).rows()
    ref_log.close()
    # kill inside the second trial, after its first displayed state (before its answer)
    second = next(r["seq"] for r in ref_rows if r["kind"] == "trial_start" and r["trial"] == 1)
    kill_after = second + 2
    assert ref_rows[kill_after - 1]["kind"] == "state"
    assert "answer" not in {r["kind"] for r in ref_rows[second:kill_after]}
    db = tmp_path / "crash.sqlite"
    child = subprocess.run(
        [sys.executable, "-c", _CHILD, str(db), str(kill_after), json.dumps(protocol.to_dict())],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONWARNINGS": "ignore"},
    )
    assert child.returncode == -signal.SIGKILL, child.stderr
    log = TrialLog(db)
    sid = log.sessions()[0]["session_id"]
    before = ActiveEventLog(log, sid).rows()
    assert [r["seq"] for r in before] == list(range(kill_after))  # every committed event
    assert [(r["kind"], r["payload"]) for r in before] == [
        (r["kind"], r["payload"]) for r in ref_rows[:kill_after]
    ]
    s = ActiveSession.open(log, protocol, "S01", clock=FakeClock())  # resume
    assert s.next_trial().index == 1
    sim = SimulatedSearcher(EdgeRecogniser(s.scene, protocol.task.grid_px, rng=5), "planes", rng=5)
    s.run(sim)
    s.close()
    rows = ActiveEventLog(log, sid).rows()
    assert rows[:kill_after] == before  # nothing committed was changed
    assert [r["seq"] for r in rows] == list(range(len(rows)))  # no loss, no duplication
    abandoned = [r for r in rows if r["kind"] == "attempt_abandoned"]
    assert [(r["trial"], r["attempt"]) for r in abandoned] == [(1, 0)]
    assert sum(r["kind"] == "answer" for r in rows) == len(s.trials)  # one answer per trial
    assert _by_trial(rows) == _by_trial(ref_rows)  # the resumed trial replays exactly
    assert {e["kind"] for e in log.events(sid)} >= {"crash", "resume", "complete"}
    log.close()


# -- every other refusal names what was wrong (H11) ----------------------------------------------


def test_scene_and_component_errors(tmp_path) -> None:
    from experiment.active import adapter
    from stimuli.errors import InputError

    assert set(KEYMAP.values()) <= set(ACTIONS)
    with pytest.raises(InputError, match=r"scene must be one of synthetic:three_plane, "):
        adapter.load_scene("synthetic:forest")
    with pytest.raises(InputError, match=r"nowhere.npy: light field not found"):
        adapter.load_scene(str(tmp_path / "nowhere.npy"))
    views = np.random.default_rng(0).random((3, 3, 20, 24)).astype(np.float32)
    np.save(tmp_path / "lf.npy", views)
    plain = adapter.load_scene(str(tmp_path / "lf.npy"))
    assert plain.shape_px == (20, 24) and not plain.objects
    with pytest.raises(ValueError, match=r"needs a synthetic scene or a light field with a scene"):
        EdgeRecogniser(plain, (4, 5))
    with pytest.raises(ValueError, match=r"condition must be decluttered or cluttered"):
        search_renderer(plain, (4, 5), "photo")
    scene = adapter.load_scene("synthetic:three_plane", shape_px=(40, 50), grid=(3, 3))
    with pytest.raises(ValueError, match=r"strategy must be one of planes, ordered"):
        SimulatedSearcher(EdgeRecogniser(scene, (4, 5)), "random")


def test_session_api_refusals(protocol) -> None:
    log = TrialLog(":memory:")
    with pytest.raises(ValueError, match=r"subject must be a non-empty string"):
        ActiveSession.open(log, protocol, " ")
    with pytest.raises(ValueError, match=r"seed must be a non-negative integer"):
        ActiveSession.open(log, protocol, "S01", seed=-3)
    p = small_protocol(targets=["tree"], conditions=["cluttered"])
    s = ActiveSession.open(log, p, "S01", seed=0, clock=FakeClock())
    with pytest.raises(ValueError, match=r"no trial is running; call start_trial"):
        s.answer("tree")
    with pytest.raises(ValueError, match=r"trial 0 has no answer to re-score"):
        s.rescore(0, "named", "operator")
    s.start_trial()
    with pytest.raises(ValueError, match=r"use answer\(\) for answer and pass"):
        s.press("Enter", "answer")
    with pytest.raises(ValueError, match=r"score must be one of"):
        s.answer("tree", score="perfect")
    s.answer("tree", score="named", rater="operator")
    with pytest.raises(ValueError, match=r"rater must be a non-empty string"):
        s.rescore(0, "use", "")
    with pytest.raises(ValueError, match=r"session \d+ is finished; no trial to start"):
        s.start_trial()
    assert log.session(s.session_id)["status"] == "completed"
    s2 = ActiveSession.open(log, p, "S02", seed=0, clock=FakeClock())
    stuck = ScriptedSearcher([Action("Up", "depth_near", 0.0)] * 5)
    with pytest.raises(RuntimeError, match=r"did not finish trial 0"):
        list(s2.iter_run(stuck, max_actions=3))
    with pytest.raises(ProtocolError, match=r"task must be an ActiveSearchSpec"):
        replace(p, task={"type": "active_search"})
    log.close()


def test_cli_user_errors_are_one_line(tmp_path) -> None:
    exe = os.path.join(os.path.dirname(sys.executable), "confocal")
    lines = open(load_protocol("active_search").source_path, encoding="utf-8").read()
    np.save(tmp_path / "lf.npy", np.zeros((3, 3, 20, 24), np.float32))
    scene_line = next(x for x in lines.splitlines() if x.startswith("scene = "))
    (tmp_path / "rec.toml").write_text(
        lines.replace(scene_line, f'scene = "{tmp_path / "lf.npy"}"')
    )
    for args, msg in [
        (["active_search", "--searcher", "robot"], "--searcher must be one of sim:planes"),
        # a person needs the operator's console in a terminal; here stdin is a pipe
        (["active_search", "--searcher", "person"], "stdin and stdout must be a terminal"),
        (["active_search", "--searcher", "person", "--rater", " "], "--rater must not be blank"),
        (["jung2015"], "jung2015: not an active-search protocol"),
        ([str(tmp_path / "rec.toml")], "is a light field without a scene description"),
    ]:
        r = subprocess.run(
            [exe, "active", "run", *args, "--data", str(tmp_path / "x.sqlite"), "--subject", "S"],
            capture_output=True,
            text=True,
            stdin=subprocess.DEVNULL,
        )
        assert r.returncode == 2 and "Traceback" not in r.stderr
        assert r.stderr.strip().count("\n") == 0 and msg in r.stderr
    assert not (tmp_path / "x.sqlite").exists()  # nothing written
