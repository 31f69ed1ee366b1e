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
``scene``                   the scene searched: ``trial_start``'s ``scene`` when logged, else the
                            session's scene (``sessions.stimset_path``)
``searcher``                who searched (``sim:...`` = simulated)
``rt_s``                    answer time - onset time (session clock), seconds: the time the
                            trial ended (the answer, pass or time-out)
``recognized, score``       the trial's latest primary ``score`` row
``time_to_recognition_s``   ``rt_s`` when recognised, else empty (the trial is right-censored at
                            ``rt_s``; see :mod:`analysis.survival`)
``planes_visited``          distinct depths (``depth_px``) shown, the first view included
``detected_planes_visited`` distinct detected planes (``plane`` not null) shown
``depth_keys``              depth and plane-jump inputs
``zooms``                   zoom inputs; ``zoomed``: at least one
``zoom_time_s``             time a zoomed view was on screen, seconds
``at_target_plane``         the answer was given within one depth step of the target's true
                            plane (where ``trial_start`` or the plan records it: synthetic
                            scenes, described recorded ones), else empty
``ended``                   how the trial ended: ``recognised``, ``pass`` (the subject gave
                            up), ``wrong`` (an answer not scored recognised) or ``timeout``
==========================  =====================================================================
"""

from __future__ import annotations

import json
import math
import os
import sqlite3
import tempfile
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from analysis.competing import competing_by_condition
from analysis.data import connect_readonly
from analysis.errors import DataError
from analysis.figure_formats import DEFAULT_FIGURE_FORMATS
from analysis.survival import CENSORING, SurvivalAnalysis, analyze_survival
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
    "hazard_ratio_text",
    "ph_text",
    "competing_lines",
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
    "scene",
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
    "ended",
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
        decoded to a dict) and ``stimset_path`` (the session's scene), ordered by source,
        session and seq.

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
                "e.payload AS payload, s.stimset_path AS stimset_path FROM active_events e "
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
    scene = start["payload"].get("scene") or (plan or {}).get("scene") or ans.get("stimset_path")
    at_plane = None
    # the trial's own scene facts (logged with trial_start) win over the plan's single scene
    facts = start["payload"] if "objects_px" in start["payload"] else (plan or {})
    if target in facts.get("objects_px", {}):
        d_ans = ans["payload"].get("state", {}).get("depth_px")
        if d_ans is not None:
            tol = float(facts.get("depth_step_px", 0.0)) + 1e-9
            at_plane = bool(abs(float(d_ans) - float(facts["objects_px"][target])) <= tol)
    rt = t1 - t0
    recognized = bool(sc["recognized"])
    last_key = keys["payload"].iloc[-1] if len(keys) else {}
    if recognized:
        ended = "recognised"
    elif last_key.get("key") == "timeout":
        ended = "timeout"
    elif not str(ans["payload"].get("response", "")).strip():
        ended = "pass"
    else:
        ended = "wrong"
    return {
        "subject": ans["subject"],
        "session": int(ans["session"]),
        "trial": int(ans["trial"]),
        "attempt": int(ans["attempt"]),
        "target": target,
        "scene": scene,
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
        "ended": ended,
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
    median_rt_recognised_only_s, mean_rt_recognised_only_s : float or None
        Over the recognised trials only, seconds. Biased: a condition whose subjects often
        pass looks fast; the censored Kaplan-Meier median
        (``time_to_recognition_km_median_s``, :mod:`analysis.survival`) is the headline.
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
    median_rt_recognised_only_s: float | None
    mean_rt_recognised_only_s: float | None
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
    survival : SurvivalAnalysis or None
        Censored time to recognition, hazard ratio, mixed model, per-subject results
        (:mod:`analysis.survival`); None without answered trials.
    proportional_hazards : dict
        Per compared condition, the check of the hazard ratio's proportional-hazards assumption
        (:func:`analysis.ph_check.proportional_hazards_check`).
    competing : dict
        Per condition, the cumulative incidence of recognition and of giving up, giving up a
        competing outcome (:func:`analysis.competing.cumulative_incidence`).
    """

    conditions: dict[str, ConditionSummary]
    n_trials: int
    simulated: bool
    searchers: tuple[str, ...] = ()
    sources: tuple[str, ...] = field(default=())
    survival: SurvivalAnalysis | None = None
    proportional_hazards: dict[str, Any] = field(default_factory=dict)
    competing: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """Return the ``results.json`` ``active_search`` entry.

        With a survival analysis, each ``conditions.<c>`` gains its Kaplan-Meier median
        (``time_to_recognition_km_median_s``, ``..._ci95_s``) and intervals, and the entry gains
        ``comparison`` (hazard ratio), ``recognition_model``, ``subjects`` and ``censoring``.
        """
        conds = {k: v.to_dict() for k, v in self.conditions.items()}
        extra: dict[str, Any] = {}
        if self.survival is not None:
            extra = self.survival.to_dict()
            for k, v in extra.pop("conditions").items():
                conds.setdefault(k, {}).update(v)
        return {
            "n_trials": self.n_trials,
            "simulated": self.simulated,
            "searchers": list(self.searchers),
            "sources": list(self.sources),
            "conditions": conds,
            **extra,
            "proportional_hazards": self.proportional_hazards,
            "competing_outcomes": self.competing,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ActiveSearchResult:
        """Inverse of :meth:`to_dict`."""
        own = {f.name for f in fields(ConditionSummary)}
        return cls(
            conditions={
                k: ConditionSummary.from_dict({n: x for n, x in v.items() if n in own})
                for k, v in d["conditions"].items()
            },
            n_trials=int(d["n_trials"]),
            simulated=bool(d["simulated"]),
            searchers=tuple(d.get("searchers", ())),
            sources=tuple(d.get("sources", ())),
            survival=SurvivalAnalysis.from_dict(d) if d.get("censoring") else None,
            proportional_hazards=dict(d.get("proportional_hazards", {})),
            competing=dict(d.get("competing_outcomes", {})),
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
            median_rt_recognised_only_s=_num(ttr.median()) if len(rec) else None,
            mean_rt_recognised_only_s=_num(ttr.mean()) if len(rec) else None,
            planes_visited_mean=float(g["planes_visited"].mean()),
            planes_visited_median=float(g["planes_visited"].median()),
            depth_keys_mean=float(g["depth_keys"].mean()),
            zoom_use_rate=float(g["zoomed"].astype(bool).mean()),
            zooms_mean=float(g["zooms"].mean()),
            zoom_time_mean_s=float(g["zoom_time_s"].mean()),
            at_target_plane_rate=float(np.mean(known.astype(bool))) if len(known) else None,
        )
    searchers = tuple(sorted({str(s) for s in trials["searcher"]}))
    survival = analyze_survival(trials) if len(trials) else None
    ph: dict[str, Any] = {}
    if survival is not None:
        from analysis.ph_check import proportional_hazards_check

        for h in survival.comparisons:
            if h.hazard_ratio is not None:
                ph[h.condition] = proportional_hazards_check(
                    trials["rt_s"].astype(float),
                    trials["recognized"].astype(bool),
                    trials["condition"].astype(str),
                    trials["subject"].astype(str),
                    treated=h.condition,
                    reference=h.reference,
                )
    return ActiveSearchResult(
        conds,
        int(len(trials)),
        any(s.startswith("sim:") for s in searchers),
        searchers,
        sources,
        survival,
        ph,
        competing_by_condition(trials) if len(trials) else {},
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


def _ci(ci, digits: int = 1, scale: float = 1.0, unit: str = "") -> str:
    lo, hi = ci
    if lo is None and hi is None:
        return "n/a"
    lo_s = "n/a" if lo is None else f"{scale * lo:.{digits}f}"
    hi_s = "not reached" if hi is None else f"{scale * hi:.{digits}f}"
    return f"{lo_s}-{hi_s}{unit}"


def _median_text(km, unit: str = "") -> str:
    if km.median_s is None:
        return "not reached"
    return f"{km.median_s:.1f}{unit} ({_ci(km.median_ci95_s)})"


def hazard_ratio_text(h) -> str:
    """Return a hazard ratio as text: value, 95 % interval and p, or why it is not estimable."""
    if h.hazard_ratio is None:
        return f"not estimable ({h.note})"
    p = "p < 0.001" if h.p < 0.001 else f"p = {h.p:.3f}"
    return f"{h.hazard_ratio:.2f} (95 % CI {_ci(h.ci95, 2)}), {p}"


def _survival_markdown(result: ActiveSearchResult) -> list[str]:
    sv = result.survival
    lines = [
        "| condition | trials | recognised (95 % CI) | censored | time to recognition, "
        "Kaplan-Meier median s (95 % CI) | planes visited, mean (95 % CI) | depth keys, mean "
        "(95 % CI) | zoom use (95 % CI) | answered at target plane |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for c in result.conditions.values():
        km, sec = sv.conditions[c.condition], sv.secondary.get(c.condition, {})
        rate = f"{c.n_recognized} ({100 * c.recognition_rate:.0f}%, "
        lines.append(
            f"| {c.condition} | {c.n_trials} | {rate}{_ci(km.recognition_rate_ci95, 0, 100, '%')})"
            f" | {km.n_censored} | {_median_text(km)} | {c.planes_visited_mean:.1f} "
            f"({_ci(sec.get('planes_visited_mean', (None, None)))}) | {c.depth_keys_mean:.1f} "
            f"({_ci(sec.get('depth_keys_mean', (None, None)))}) | {100 * c.zoom_use_rate:.0f}% "
            f"({_ci(sec.get('zoom_use_rate', (None, None)), 0, 100, '%')}) | "
            + ("n/a" if c.at_target_plane_rate is None else f"{100 * c.at_target_plane_rate:.0f}%")
            + " |"
        )
    lines += [
        "",
        f'**Censoring**: {CENSORING}. A median is "not reached" while the Kaplan-Meier curve '
        "stays at or above one half (fewer than half recognised by the time trials ended). "
        "Recognition rates have Wilson intervals; the secondary measures are the "
        f"{sv.secondary_interval}.",
        "",
    ]
    lines += competing_lines(result.competing)
    for h in sv.comparisons:
        lines.append(
            f"**Hazard ratio of recognition**, {h.condition} vs {h.reference} (above 1: "
            f"{h.condition} recognised sooner): {hazard_ratio_text(h)}; {h.method}; "
            f"{h.n_trials} trials, {h.n_recognized} recognised, {h.n_subjects} subject(s)."
        )
        ph = result.proportional_hazards.get(h.condition)
        if ph:
            lines.append(ph_text(ph))
    m = sv.recognition_model
    if m is not None:
        what = (
            f"odds ratio {m.condition} vs {m.reference} {m.odds_ratio:.2f} "
            f"(95 % interval {_ci(m.ci95, 2)}), subject SD {m.subject_sd:.2f} log-odds"
            if m.odds_ratio is not None
            else m.note
        )
        lines.append(f"\n**Recognition (mixed-effects logistic model)**: {what}; {m.method}.")
    lines += [
        "",
        "Per subject (Kaplan-Meier median, or how many were censored):",
        "",
        "| subject | condition | trials | recognised | censored | time to recognition, KM "
        "median s | planes visited, mean | zoom use |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for subj, by_c in sv.subjects.items():
        for cond, km in by_c.items():
            mm = sv.subject_means.get(subj, {}).get(cond, {})
            med = f"{km.median_s:.1f}" if km.median_s is not None else "not reached"
            lines.append(
                f"| {subj} | {cond} | {km.n_trials} | {km.n_recognized} | {km.n_censored} | "
                f"{med} | {mm.get('planes_visited_mean', float('nan')):.1f} | "
                f"{100 * mm.get('zoom_use_rate', float('nan')):.0f}% |"
            )
    naive = ", ".join(
        f"{c.condition} {_f(c.median_rt_recognised_only_s)} s" for c in result.conditions.values()
    )
    lines += [
        "",
        f"For comparison only, the median time over the recognised trials alone (biased toward "
        f"conditions in which subjects give up: it drops the censored trials): {naive}.",
    ]
    return lines


def competing_lines(comp: dict[str, Any]) -> list[str]:
    """Report lines: cumulative incidence of recognition and of giving up per condition."""
    if not comp:
        return []
    parts = []
    for c, r in comp.items():
        rec, gave = r["recognised"], r["gave_up"]
        parts.append(
            f"{c}: recognised {100 * rec['cif']:.0f} % ({_ci(rec['ci95'], 0, 100, '%')}), gave "
            f"up {100 * gave['cif']:.0f} % ({_ci(gave['ci95'], 0, 100, '%')}) "
            f"by {r['at_s']:.1f} s "
            f"({r['n_gave_up']} passes or wrong answers, {r['n_timeout']} time-outs censored)"
        )
    return [
        "**Giving up as a competing outcome** (Aalen-Johansen cumulative incidence; a pass or a "
        "wrong answer ends the search, only time-outs are censored; 95 % intervals on the "
        "log(-log) scale): " + "; ".join(parts) + ".",
        "",
    ]


def ph_text(ph: dict[str, Any]) -> str:
    """Say whether the hazard ratio's proportional-hazards assumption held, and what replaces it.

    When it did not hold, it is replaced by the hazard ratio before and after the median event
    time.
    """
    t = ph["test"]
    if t.get("p") is None:
        return "**Proportional hazards**: not tested (too few recognitions or no fit)."
    head = (
        f"**Proportional hazards**: {ph['method']}: chi-squared {t['statistic']:.2f}, "
        f"p = {t['p']:.2g}"
    )
    if ph["holds"]:
        return head + "; no evidence against it, so one hazard ratio summarises the data."
    alt = ph["alternative"]
    parts = []
    for name, when in (("early", "before"), ("late", "after")):
        a = alt[name]
        hr = "n/a" if a["hazard_ratio"] is None else f"{a['hazard_ratio']:.2f}"
        ci = "" if a["hazard_ratio"] is None else f" (95 % CI {_ci(a['ci95'], 2)})"
        parts.append(f"{when} {alt['split_s']:.1f} s {hr}{ci}")
    return (
        head + "; the assumption FAILS, so the single hazard ratio above averages a ratio that "
        "changes with time. Time-varying alternative (one hazard ratio per period, split at the "
        "median recognition time, same stratification): " + "; ".join(parts) + "."
    )


def render_active_markdown(result: ActiveSearchResult, *, figure: str | None = None) -> str:
    """Return the report's "Active search" section (Markdown).

    Parameters
    ----------
    result : ActiveSearchResult
    figure : str or None
        File name of the time-to-recognition figure to show (PNG), if drawn.
    """
    label = " (SIMULATED searcher)" if result.simulated else ""
    lines = [
        f"## Active search{label}",
        "",
        f"{result.n_trials} answered trials; searchers: {', '.join(result.searchers) or 'n/a'}.",
        "Time to recognition is from the cue's onset to the recognised answer; planes visited "
        "counts the distinct depths shown.",
        "",
    ]
    if result.survival is not None:
        lines += _survival_markdown(result)
    if figure:
        lines += ["", f"![Time to recognition, Kaplan-Meier, per condition and subject]({figure})"]
    return "\n".join(lines) + "\n"


def summary_lines(result: ActiveSearchResult) -> list[str]:
    """Return printable lines: per condition, then the hazard ratio between conditions."""
    sim = " (SIMULATED searcher)" if result.simulated else ""
    out = [f"active search: {result.n_trials} trials{sim}"]
    sv = result.survival
    for c in result.conditions.values():
        med = _median_text(sv.conditions[c.condition], " s") if sv is not None else "n/a"
        out.append(
            f"{c.condition:>11}: {c.n_recognized}/{c.n_trials} recognised, time to recognition "
            f"(Kaplan-Meier, censored) median {med}, planes visited "
            f"{c.planes_visited_mean:.1f}, zoom use {100 * c.zoom_use_rate:.0f}%"
        )
    for h in sv.comparisons if sv is not None else ():
        out.append(f"hazard ratio {h.condition} vs {h.reference}: {hazard_ratio_text(h)}")
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
    paths: Iterable[str | Path],
    folder: str | Path,
    *,
    figures: bool = True,
    figure_formats: tuple[str, ...] = DEFAULT_FIGURE_FORMATS,
) -> ActiveSearchResult | None:
    """Add active-search results to a report folder, if the trial logs have any.

    Writes (each atomically) ``active_trials.csv``, the ``active_search`` key of
    ``results.json`` (created when absent) and an "Active search" section at the end of
    ``report.md`` (created when absent); with ``figures``, the Kaplan-Meier figure
    ``active_time_to_recognition`` in ``figure_formats`` (PNG and PDF unless asked otherwise;
    :func:`analysis.figures.save_time_to_recognition`), shown in the report when a PNG.

    Returns
    -------
    ActiveSearchResult or None
        None when no file has active-search events (nothing is written).
    """
    from analysis.report import results_json_text

    out = analyze_active(paths)
    if out is None:
        return None
    result, trials = out
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    _write_atomic(folder / "active_trials.csv", frame_csv_text(trials))
    figure = None
    if figures and result.survival is not None:
        from analysis.figures import ACTIVE_FIGURE, save_time_to_recognition

        save_time_to_recognition(
            result.survival, folder, simulated=result.simulated, formats=figure_formats
        )
        figure = f"{ACTIVE_FIGURE}.png" if "png" in figure_formats else None
    rj = folder / "results.json"
    data = json.loads(rj.read_text(encoding="utf-8")) if rj.is_file() else {}
    data["active_search"] = result.to_dict()
    _write_atomic(rj, results_json_text(data))
    md = folder / "report.md"
    head = md.read_text(encoding="utf-8") if md.is_file() else "# Report\n"
    _write_atomic(md, head.rstrip("\n") + "\n\n" + render_active_markdown(result, figure=figure))
    return result


def write_active_report(
    paths: Iterable[str | Path],
    out_dir: str | Path,
    *,
    figures: bool = True,
    figure_formats: tuple[str, ...] = DEFAULT_FIGURE_FORMATS,
) -> ActiveSearchResult:
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
        result = add_active_results(paths, tmp, figures=figures, figure_formats=figure_formats)
        if result is None:
            raise DataError(f"{paths[0] if paths else 'no files'}: no active-search events")
    return result
