"""The files of ``confocal analyze power --out FOLDER``: a power-curve figure and the table.

A power table holds one curve per design (effect size, levels, objects, scenes, ...): power
against the number of subjects, each point the share of simulated studies that detected the
effect. :func:`needed` is the one rule that picks the recommended number of subjects, used by
the console and by these files alike; :func:`write_power_report` writes, atomically (a staging
folder renamed into place, :func:`analysis.report.atomic_folder`):

* ``power_curve.png`` and ``power_curve.svg`` (its text kept as text): power vs subjects, one
  line per curve with its 95 % intervals, the target power marked and each curve's
  recommended number annotated, labelled as simulated;
* ``power.csv``: one row per point (the design's columns, subjects, power, its interval, the
  number of simulated studies);
* ``power.json``: the settings, and per curve its design, points and recommendation.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = [
    "PowerCurve",
    "POWER_FIGURE",
    "needed",
    "needed_text",
    "DESIGNS",
    "save_power_table",
    "group_curves",
    "plot_power_curves",
    "write_power_report",
]

#: File stem of the power-curve figure.
POWER_FIGURE: str = "power_curve"


def needed(points: Iterable[Any], target: float) -> Any | None:
    """Return the point with the fewest subjects from which on power stays at ``target`` or above.

    Power must reach ``target`` at that number of subjects and at every larger number simulated,
    so that a noisy dip in a larger row (power is estimated from a finite number of studies)
    never sits beside the recommendation.

    Parameters
    ----------
    points : iterable
        One design's points, each with ``n_subjects`` and ``power``.
    target : float
        Power wanted.

    Returns
    -------
    point or None
        None when no number of subjects simulated reached ``target`` and kept it.

    Examples
    --------
    >>> from types import SimpleNamespace as P
    >>> row = [P(n_subjects=2, power=0.85), P(n_subjects=4, power=0.75), P(n_subjects=6, power=0.9)]
    >>> needed(row, 0.8).n_subjects
    6
    """
    row = sorted(points, key=lambda p: p.n_subjects)
    for i, p in enumerate(row):
        if all(q.power >= target for q in row[i:]):
            return p
    return None


def needed_text(row: Iterable[Any], target: float) -> str:
    """Say the recommended number of subjects of one design (:func:`needed`), as the console does.

    Parameters
    ----------
    row : iterable
        One design's points, each with ``n_subjects``, ``power`` and ``ci95``.
    target : float
        Power wanted.

    Returns
    -------
    str
    """
    need = needed(row, target)
    if need is None:
        return f"no simulated number of subjects reached power {target:g} (and kept it)"
    return (
        f"subjects needed for power {target:g}: {need.n_subjects} (power {need.power:.2f}, "
        f"95% CI {need.ci95[0]:.2f}-{need.ci95[1]:.2f}; every larger number simulated also "
        f"reached {target:g})"
    )


@dataclass(frozen=True)
class PowerCurve:
    """One design's power by number of subjects.

    Parameters
    ----------
    label : str
        The design in words, e.g. ``'size 2, 8 levels, 20 objects'``.
    design : dict
        The design's fields (the table's columns other than subjects), e.g. ``{'size': 2.0}``.
    points : tuple
        Points sorted by ``n_subjects``, each with ``n_subjects``, ``power``, ``ci95``
        and ``n_sims``.
    n_required : int or None
        The recommended number of subjects (:func:`needed`); None: none reached the target.
    """

    label: str
    design: dict[str, Any]
    points: tuple[Any, ...] = field(default=())
    n_required: int | None = None

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-ready dict."""
        return {
            "label": self.label,
            "design": dict(self.design),
            "n_required": self.n_required,
            "points": [
                {
                    "n_subjects": int(p.n_subjects),
                    "power": float(p.power),
                    "ci95": [float(p.ci95[0]), float(p.ci95[1])],
                    "n_sims": int(p.n_sims),
                }
                for p in self.points
            ],
        }


def group_curves(
    points: Sequence[Any],
    keys: Sequence[str],
    label: Callable[[dict[str, Any]], str],
    target: float,
) -> list[PowerCurve]:
    """Split a power table into one curve per design, in the table's order.

    Parameters
    ----------
    points : sequence
        The table's points (each with ``n_subjects``, ``power``, ``ci95``, ``n_sims`` and the
        attributes named in ``keys``).
    keys : sequence of str
        The attributes that name a design.
    label : callable(dict) -> str
        The design in words, from its ``{key: value}``.
    target : float
        Power wanted (for each curve's recommendation).

    Returns
    -------
    list of PowerCurve
    """
    designs: dict[tuple, list] = {}
    for p in points:
        designs.setdefault(tuple(getattr(p, k) for k in keys), []).append(p)
    curves = []
    for values, row in designs.items():
        design = dict(zip(keys, values, strict=True))
        need = needed(row, target)
        curves.append(
            PowerCurve(
                label(design),
                design,
                tuple(sorted(row, key=lambda p: p.n_subjects)),
                None if need is None else int(need.n_subjects),
            )
        )
    return curves


def plot_power_curves(curves: Sequence[PowerCurve], target: float, *, title: str = ""):
    """Draw power vs number of subjects, one line per curve; return the Figure.

    Each point has its 95 % interval (Monte Carlo error of the simulated share); the target
    power is a dashed line; each curve's recommended number of subjects is circled and
    annotated ``n = N`` (or the legend says none reached the target). The axes say the studies
    were simulated.

    Parameters
    ----------
    curves : sequence of PowerCurve
    target : float
        Power wanted.
    title : str
        The settings, shown above the axes.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 4.0))
    ax = fig.add_axes((0.1, 0.13, 0.58, 0.72))
    for i, c in enumerate(curves):
        color = f"C{i % 10}"
        xs = [p.n_subjects for p in c.points]
        ys = [p.power for p in c.points]
        lo = [p.power - p.ci95[0] for p in c.points]
        hi = [p.ci95[1] - p.power for p in c.points]
        need = "none reached it" if c.n_required is None else f"n = {c.n_required}"
        style = {"fmt": "o-", "ms": 4, "lw": 1.2, "capsize": 2, "color": color}
        ax.errorbar(xs, ys, yerr=[lo, hi], label=f"{c.label} ({need})", **style)
        if c.n_required is not None:
            p = next(q for q in c.points if q.n_subjects == c.n_required)
            ax.plot(p.n_subjects, p.power, "o", ms=11, mfc="none", mec=color, mew=1.5)
            ax.annotate(
                f"n = {c.n_required}",
                (p.n_subjects, p.power),
                xytext=(4, -12 - 9 * (i % 3)),
                textcoords="offset points",
                fontsize="small",
                color=color,
                gid=f"recommended-{i}",
            )
    ax.axhline(target, color="k", ls="--", lw=0.8)
    ax.annotate(
        f"target power {target:g}",
        (0.0, target),
        xycoords=("axes fraction", "data"),
        xytext=(3, 3),
        textcoords="offset points",
        fontsize="x-small",
    )
    ns = sorted({p.n_subjects for c in curves for p in c.points})
    ax.set_xticks(ns)
    ax.set_xlim(min(ns) - 0.5, max(ns) + 0.5)
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("number of subjects")
    ax.set_ylabel("power (share of SIMULATED studies\nthat detect the effect)")
    ax.set_title(title or "power by number of subjects (SIMULATED)", fontsize="small")
    ax.legend(
        fontsize="x-small",
        frameon=False,
        loc="upper left",
        bbox_to_anchor=(1.02, 1.0),
        title="design (recommended subjects)",
        title_fontsize="x-small",
    )
    return fig


def _csv_text(curves: Sequence[PowerCurve]) -> str:
    keys = list(curves[0].design) if curves else []
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([*keys, "n_subjects", "power", "ci95_low", "ci95_high", "n_sims", "recommended"])
    for c in curves:
        for p in c.points:
            w.writerow(
                [c.design[k] for k in keys]
                + [p.n_subjects, f"{p.power:.6g}", f"{p.ci95[0]:.6g}", f"{p.ci95[1]:.6g}"]
                + [p.n_sims, int(p.n_subjects == c.n_required)]
            )
    return buf.getvalue()


def write_power_report(
    out_dir: str | Path,
    curves: Sequence[PowerCurve],
    *,
    target: float,
    settings: dict[str, Any],
    title: str = "",
) -> Path:
    """Write the power-curve figure, ``power.csv`` and ``power.json`` to ``out_dir``, atomically.

    Parameters
    ----------
    out_dir : str or Path
        A missing or empty folder (a non-empty one is refused, never replaced).
    curves : sequence of PowerCurve
        From :func:`group_curves`.
    target : float
        Power wanted.
    settings : dict
        What was simulated (effect, test level, studies per point, seed, ...), for the JSON.
    title : str
        The figure's title.

    Returns
    -------
    Path
        The folder written.
    """
    from analysis.data import json_safe
    from analysis.report import atomic_folder
    from analysis.staging import resolve

    data = {
        "simulated": True,
        **settings,
        "target_power": target,
        "recommendation_rule": (
            "the fewest subjects simulated from which on every larger number simulated also "
            "reached the target power"
        ),
        "curves": [c.to_dict() for c in curves],
    }
    with atomic_folder(out_dir) as tmp:
        text = json.dumps(json_safe(data), indent=2, allow_nan=False) + "\n"
        (tmp / "power.json").write_text(text, encoding="utf-8")
        (tmp / "power.csv").write_text(_csv_text(curves), encoding="utf-8")
        import matplotlib

        fig = plot_power_curves(curves, target, title=title)
        # SVG text kept as text (not glyph outlines): searchable and editable
        with matplotlib.rc_context({"svg.fonttype": "none"}):
            for ext in ("png", "svg"):
                fig.savefig(tmp / f"{POWER_FIGURE}.{ext}", dpi=200, bbox_inches="tight")
    return resolve(out_dir)


#: Per kind of power table (``analyze power``; ``--active``; ``--conditions K``): what it is in
#: words, the point attributes that name a design, and the design in words.
DESIGNS: dict[str, tuple[str, tuple[str, ...], Callable[[dict[str, Any]], str]]] = {
    "grid": (
        "{effect}, alpha {alpha:g}",
        ("size", "n_levels", "n_objects"),
        lambda d: f"size {d['size']:g}, {d['n_levels']} levels, {d['n_objects']} objects",
    ),
    "active": (
        "active search, hazard ratio, alpha {alpha:g}",
        ("hazard_ratio", "n_scenes"),
        lambda d: f"hazard ratio {d['hazard_ratio']:g}, {d['n_scenes']} scenes",
    ),
    "methods": (
        "method comparison (reference vs one method, Holm), {n_objects} objects, alpha {alpha:g}",
        ("odds_ratio", "n_conditions"),
        lambda d: f"odds ratio {d['odds_ratio']:.3g}, {d['n_conditions']} conditions",
    ),
}


def save_power_table(
    out_dir: str | Path, kind: str, points: Sequence[Any], target: float, settings: dict[str, Any]
) -> Path:
    """Group a power table into curves (:data:`DESIGNS`) and write it (:func:`write_power_report`).

    Parameters
    ----------
    out_dir : str or Path
        A missing or empty folder.
    kind : {'grid', 'active', 'methods'}
        Which table.
    points : sequence
        The table's points.
    target : float
        Power wanted.
    settings : dict
        What was simulated; ``alpha``, ``n_sims`` and ``seed`` at least, and the fields the
        kind's title names (``effect``, ``n_objects``).

    Returns
    -------
    Path
        The folder written.
    """
    what, keys, label = DESIGNS[kind]
    curves = group_curves(points, keys, label, target)
    title = (
        f"{what.format(**settings).replace('_', ' ')}: power by subjects "
        f"({settings['n_sims']} SIMULATED studies per point, seed {settings['seed']})"
    )
    return write_power_report(out_dir, curves, target=target, settings=settings, title=title)
