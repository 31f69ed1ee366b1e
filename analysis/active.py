"""Active-search metrics: time to recognition, planes visited and zoom use, per condition.

Reads the ``active_events`` table of a trial log (SQLite) through its documented schema
(``experiment/log/schema.py``, migration 3; payloads in ``experiment/active/eventlog.py``) and
imports neither ``experiment`` nor ``stimuli``.

Per answered trial (the attempt that holds the ``answer`` row; attempts cut by a crash are left
out):

==========================  =====================================================================
column                      meaning
==========================  =====================================================================
``subject, session``        from ``sessions``
``trial, attempt``          plan index and the answered attempt
``target, condition``       from ``trial_start``
``searcher``                who searched (``sim:...`` = simulated)
``rt_s``                    answer time - onset time (session clock), seconds
``recognized, score``       the trial's latest primary ``score`` row
``time_to_recognition_s``   ``rt_s`` when recognised, else empty
``planes_visited``          distinct depths (``depth_px``) shown, the first view included
``detected_planes_visited`` distinct detected planes (``plane`` not null) shown
``depth_keys``              depth and plane-jump inputs
``zooms``                   zoom inputs; ``zoomed``: at least one
``zoom_time_s``             time a zoomed view was on screen, seconds
``at_target_plane``         the answer was given within one depth step of the target's true
                            plane (synthetic scenes, where the plan records it), else empty
==========================  =====================================================================
"""

from __future__ import annotations

import json
import math
import os
import sqlite3
import tempfile
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from analysis.data import connect_readonly
from analysis.errors import DataError
from analysis.tables import frame_csv_text

__all__ = [
    "TRIAL_COLUMNS",
    "ConditionSummary",
    "ActiveSearchResult",
    "has_active_events",
    "read_active_events",
    "active_trials",
    "summarize_active",
    "analyze_active",
    "render_active_markdown",
    "summary_lines",
    "add_active_results",
    "only_active",
    "write_active_report",
]

#: Columns of :func:`active_trials` (see the module docstring).
TRIAL_COLUMNS: tuple[str, ...] = (
    "subject",
    "session",
    "trial",
    "attempt",
    "target",
    "condition",
    "searcher",
    "rt_s",
    "recognized",
    "score",
    "time_to_recognition_s",
    "planes_visited",
    "detected_planes_visited",
    "depth_keys",
    "zooms",
    "zoomed",
    "zoom_time_s",
    "at_target_plane",
)

_DEPTH_ACTIONS = ("depth_near", "depth_far", "plane_next", "plane_prev")


def _connect(path: Path) -> sqlite3.Connection:
    if not path.is_file():
        raise DataError(f"{path}: file not found")
    return connect_readonly(path)


def has_active_events(path: str | Path) -> bool:
    """Return whether ``path`` is an SQLite trial log with at least one active-search event."""
    p = Path(path)
    try:
        with open(p, "rb") as fh:
            if fh.read(16) != b"SQLite format 3\x00":
                return False
    except OSError:
        return False
    con = _connect(p)
    try:
        names = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        if "active_events" not in names:
            return False
        return con.execute("SELECT count(*) FROM active_events").fetchone()[0] > 0
    except sqlite3.DatabaseError as exc:
        raise DataError(f"{p}: cannot read SQLite trial log ({exc})") from None
    finally:
        con.close()


def only_active(paths: Iterable[str | Path]) -> bool:
    """Return whether every file is a trial log with active-search events and no static trials."""
    paths = [Path(p) for p in paths]
    if not paths or not all(has_active_events(p) for p in paths):
        return False
    for p in paths:
        con = _connect(p)
        try:
            n = con.execute("SELECT count(*) FROM trials").fetchone()[0]
        except sqlite3.DatabaseError:
            n = 0
        finally:
            con.close()
        if n:
            return False
    return True


def read_active_events(paths: Iterable[str | Path]) -> pd.DataFrame:
    """Read the ``active_events`` rows of one or more trial logs.

    Returns
    -------
    DataFrame
        Columns ``source, subject, session, trial, attempt, seq, t_s, kind, payload`` (payload
        decoded to a dict), ordered by source, session and seq.

    Raises
    ------
    DataError
        A file that is missing, not SQLite, or lacks the ``active_events`` table.
    """
    frames = []
    for path in (Path(p) for p in paths):
        con = _connect(path)
        try:
            names = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
            if "active_events" not in names or "sessions" not in names:
                raise DataError(
                    f"{path}: not an active-search trial log (no 'active_events' table)"
                )
            df = pd.read_sql_query(
                "SELECT s.subject AS subject, e.session_id AS session, e.trial AS trial, "
                "e.attempt AS attempt, e.seq AS seq, e.t_s AS t_s, e.kind AS kind, "
                "e.payload AS payload FROM active_events e "
                "JOIN sessions s ON s.session_id = e.session_id ORDER BY e.session_id, e.seq",
                con,
            )
        except sqlite3.DatabaseError as exc:
            raise DataError(f"{path}: cannot read SQLite trial log ({exc})") from None
        finally:
            con.close()
        try:
            df["payload"] = [json.loads(p) for p in df["payload"]]
        except json.JSONDecodeError as exc:
            raise DataError(f"{path}: an active_events payload is not JSON ({exc})") from None
        df.insert(0, "source", str(path))
        frames.append(df)
    if not frames:
        raise DataError("no trial files given")
    return pd.concat(frames, ignore_index=True)


def _trial_row(rows: pd.DataFrame, plan: dict[str, Any] | None) -> dict[str, Any] | None:
    answers = rows[rows["kind"] == "answer"]
    if answers.empty:
        return None
    ans = answers.iloc[-1]
    att = rows[rows["attempt"] == ans["attempt"]]
    start = att[att["kind"] == "trial_start"]
    if start.empty:
        raise DataError(
            f"session {ans['session']} trial {ans['trial']}: answer without trial_start"
        )
    start = start.iloc[0]
    t0, t1 = float(start["t_s"]), float(ans["t_s"])
    scores = rows[rows["kind"] == "score"]
    prim = [r for r in scores.itertuples() if r.payload.get("primary", True)]
    if not prim:
        raise DataError(f"session {ans['session']} trial {ans['trial']}: answer without score")
    sc = prim[-1].payload
    states = att[(att["kind"] == "state") & (att["seq"] < ans["seq"])]
    keys = att[(att["kind"] == "key") & (att["seq"] <= ans["seq"])]
    actions = [p.get("action") for p in keys["payload"]]
    depths = {round(float(p["depth_px"]), 6) for p in states["payload"]}
    detected = {p["plane"] for p in states["payload"] if p.get("plane") is not None}
    zoom_time = 0.0
    st = list(states.itertuples())
    for i, r in enumerate(st):
        end = st[i + 1].t_s if i + 1 < len(st) else t1
        if r.payload.get("zoom") is not None:
            zoom_time += float(end) - float(r.t_s)
    target = start["payload"].get("target")
    at_plane = None
    if plan is not None and target in plan.get("objects_px", {}):
        d_ans = ans["payload"].get("state", {}).get("depth_px")
        if d_ans is not None:
            tol = float(plan.get("depth_step_px", 0.0)) + 1e-9
            at_plane = bool(abs(float(d_ans) - float(plan["objects_px"][target])) <= tol)
    rt = t1 - t0
    recognized = bool(sc["recognized"])
    return {
        "subject": ans["subject"],
        "session": int(ans["session"]),
        "trial": int(ans["trial"]),
        "attempt": int(ans["attempt"]),
        "target": target,
        "condition": start["payload"].get("condition"),
        "searcher": start["payload"].get("searcher", ""),
        "rt_s": rt,
        "recognized": recognized,
        "score": sc["score"],
        "time_to_recognition_s": rt if recognized else None,
        "planes_visited": len(depths),
        "detected_planes_visited": len(detected),
        "depth_keys": sum(a in _DEPTH_ACTIONS for a in actions),
        "zooms": sum(a == "zoom" for a in actions),
        "zoomed": any(a == "zoom" for a in actions),
        "zoom_time_s": zoom_time,
        "at_target_plane": at_plane,
    }


def active_trials(events: pd.DataFrame) -> pd.DataFrame:
    """Return one row per answered active-search trial (columns :data:`TRIAL_COLUMNS`)."""
    out = []
    for (_, _), ses in events.groupby(["source", "session"], sort=False):
        plans = ses[ses["kind"] == "plan"]
        plan = plans.iloc[0]["payload"] if not plans.empty else None
        trial_rows = ses[ses["trial"].notna()]
        for _, rows in trial_rows.groupby("trial", sort=True):
            r = _trial_row(rows, plan)
            if r is not None:
                out.append(r)
    return pd.DataFrame(out, columns=list(TRIAL_COLUMNS))


def _num(v: Any) -> float | None:
    if v is None:
        return None
    f = float(v)
    return None if math.isnan(f) else f


@dataclass(frozen=True)
class ConditionSummary:
    """Active-search metrics of one condition.

    Attributes
    ----------
    condition : str
    n_trials, n_recognized : int
    recognition_rate : float
    time_to_recognition_median_s, time_to_recognition_mean_s : float or None
        Over recognised trials, seconds.
    planes_visited_mean, planes_visited_median : float
        Distinct depths shown per trial.
    depth_keys_mean : float
    zoom_use_rate : float
        Share of trials with at least one zoom.
    zooms_mean : float
        Zoom inputs per trial.
    zoom_time_mean_s : float
        Seconds zoomed per trial.
    at_target_plane_rate : float or None
        Share of recognised trials answered at the target's true plane (None: unknown).
    """

    condition: str
    n_trials: int
    n_recognized: int
    recognition_rate: float
    time_to_recognition_median_s: float | None
    time_to_recognition_mean_s: float | None
    planes_visited_mean: float
    planes_visited_median: float
    depth_keys_mean: float
    zoom_use_rate: float
    zooms_mean: float
    zoom_time_mean_s: float
    at_target_plane_rate: float | None

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ConditionSummary:
        """Inverse of :meth:`to_dict`."""
        return cls(**d)


@dataclass(frozen=True)
class ActiveSearchResult:
    """Active-search results of one analysis.

    Attributes
    ----------
    conditions : dict of str to ConditionSummary
    n_trials : int
    simulated : bool
        Whether any trial was searched by a simulated searcher (``sim:...``).
    searchers : tuple of str
    sources : tuple of str
    """

    conditions: dict[str, ConditionSummary]
    n_trials: int
    simulated: bool
    searchers: tuple[str, ...] = ()
    sources: tuple[str, ...] = field(default=())

    def to_dict(self) -> dict[str, Any]:
        """Return the ``results.json`` ``active_search`` entry."""
        return {
            "n_trials": self.n_trials,
            "simulated": self.simulated,
            "searchers": list(self.searchers),
            "sources": list(self.sources),
            "conditions": {k: v.to_dict() for k, v in self.conditions.items()},
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ActiveSearchResult:
        """Inverse of :meth:`to_dict`."""
        return cls(
            conditions={k: ConditionSummary.from_dict(v) for k, v in d["conditions"].items()},
            n_trials=int(d["n_trials"]),
            simulated=bool(d["simulated"]),
            searchers=tuple(d.get("searchers", ())),
            sources=tuple(d.get("sources", ())),
        )


def summarize_active(trials: pd.DataFrame, sources: tuple[str, ...] = ()) -> ActiveSearchResult:
    """Return the per-condition metrics of :func:`active_trials` rows."""
    conds: dict[str, ConditionSummary] = {}
    for cond, g in trials.groupby("condition", sort=True):
        rec = g[g["recognized"].astype(bool)]
        ttr = rec["rt_s"].astype(float)
        known = rec["at_target_plane"].dropna()
        conds[str(cond)] = ConditionSummary(
            condition=str(cond),
            n_trials=int(len(g)),
            n_recognized=int(len(rec)),
            recognition_rate=float(len(rec) / len(g)),
            time_to_recognition_median_s=_num(ttr.median()) if len(rec) else None,
            time_to_recognition_mean_s=_num(ttr.mean()) if len(rec) else None,
            planes_visited_mean=float(g["planes_visited"].mean()),
            planes_visited_median=float(g["planes_visited"].median()),
            depth_keys_mean=float(g["depth_keys"].mean()),
            zoom_use_rate=float(g["zoomed"].astype(bool).mean()),
            zooms_mean=float(g["zooms"].mean()),
            zoom_time_mean_s=float(g["zoom_time_s"].mean()),
            at_target_plane_rate=float(np.mean(known.astype(bool))) if len(known) else None,
        )
    searchers = tuple(sorted({str(s) for s in trials["searcher"]}))
    return ActiveSearchResult(
        conds, int(len(trials)), any(s.startswith("sim:") for s in searchers), searchers, sources
    )


def analyze_active(paths: Iterable[str | Path]) -> tuple[ActiveSearchResult, pd.DataFrame] | None:
    """Read the trial logs and return the result and the per-trial table (None without events)."""
    act = [Path(p) for p in paths if has_active_events(p)]
    if not act:
        return None
    trials = active_trials(read_active_events(act))
    return summarize_active(trials, tuple(p.name for p in act)), trials


def _f(v: float | None, digits: int = 1) -> str:
    return "n/a" if v is None else f"{v:.{digits}f}"


def render_active_markdown(result: ActiveSearchResult) -> str:
    """Return the report's "Active search" section (Markdown)."""
    label = " (SIMULATED searcher)" if result.simulated else ""
    lines = [
        f"## Active search{label}",
        "",
        f"{result.n_trials} answered trials; searchers: {', '.join(result.searchers) or 'n/a'}.",
        "Time to recognition is from the cue's onset to the recognised answer; planes visited "
        "counts the distinct depths shown.",
        "",
        "| condition | trials | recognised | time to recognition, median (mean) s | planes "
        "visited, mean (median) | depth keys | zoom use | zooms/trial | answered at target plane |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for c in result.conditions.values():
        lines.append(
            f"| {c.condition} | {c.n_trials} | {c.n_recognized} ({100 * c.recognition_rate:.0f}%)"
            f" | {_f(c.time_to_recognition_median_s)} ({_f(c.time_to_recognition_mean_s)})"
            f" | {c.planes_visited_mean:.1f} ({c.planes_visited_median:g}) | "
            f"{c.depth_keys_mean:.1f} | {100 * c.zoom_use_rate:.0f}% | {c.zooms_mean:.1f} | "
            + ("n/a" if c.at_target_plane_rate is None else f"{100 * c.at_target_plane_rate:.0f}%")
            + " |"
        )
    return "\n".join(lines) + "\n"


def summary_lines(result: ActiveSearchResult) -> list[str]:
    """Return one printable line per condition (time to recognition, planes, zoom use)."""
    sim = " (SIMULATED searcher)" if result.simulated else ""
    out = [f"active search: {result.n_trials} trials{sim}"]
    for c in result.conditions.values():
        out.append(
            f"{c.condition:>11}: {c.n_recognized}/{c.n_trials} recognised, time to recognition "
            f"median {_f(c.time_to_recognition_median_s)} s, planes visited "
            f"{c.planes_visited_mean:.1f}, zoom use {100 * c.zoom_use_rate:.0f}%"
        )
    return out


def _write_atomic(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def add_active_results(
    paths: Iterable[str | Path], folder: str | Path
) -> ActiveSearchResult | None:
    """Add active-search results to a report folder, if the trial logs have any.

    Writes (each atomically) ``active_trials.csv``, the ``active_search`` key of
    ``results.json`` (created when absent) and an "Active search" section at the end of
    ``report.md`` (created when absent).

    Returns
    -------
    ActiveSearchResult or None
        None when no file has active-search events (nothing is written).
    """
    out = analyze_active(paths)
    if out is None:
        return None
    result, trials = out
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    _write_atomic(folder / "active_trials.csv", frame_csv_text(trials))
    rj = folder / "results.json"
    data = json.loads(rj.read_text(encoding="utf-8")) if rj.is_file() else {}
    data["active_search"] = result.to_dict()
    _write_atomic(rj, json.dumps(data, indent=2, allow_nan=False) + "\n")
    md = folder / "report.md"
    head = md.read_text(encoding="utf-8") if md.is_file() else "# Report\n"
    _write_atomic(md, head.rstrip("\n") + "\n\n" + render_active_markdown(result))
    return result


def write_active_report(paths: Iterable[str | Path], out_dir: str | Path) -> ActiveSearchResult:
    """Write a report folder with only active-search results into a new or empty ``out_dir``.

    The folder is filled beside ``out_dir`` and renamed at the end
    (:func:`analysis.report.atomic_folder`); a non-empty ``out_dir`` is refused, never replaced.

    Raises
    ------
    DataError
        No file has active-search events, or ``out_dir`` is a file or a non-empty folder.
    """
    from analysis.report import atomic_folder

    paths = [Path(p) for p in paths]
    with atomic_folder(out_dir) as tmp:
        result = add_active_results(paths, tmp)
        if result is None:
            raise DataError(f"{paths[0] if paths else 'no files'}: no active-search events")
    return result
