"""The report of a k-condition analysis (:mod:`analysis.conditions`): text and two figures.

``results.json`` (:meth:`~analysis.conditions.ConditionsResult.results_json`), ``report.md``
(which methods differ and by how much, in sentences) and two figures: every condition's
recognition curve (``conditions_curves``) and every pairwise threshold ratio with its 95 %
interval (``conditions_ratios``), each as PNG and PDF (and SVG when asked for), stamped
SIMULATED for simulated data.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from analysis.figure_formats import DEFAULT_FIGURE_FORMATS, figure_links

__all__ = [
    "CONDITION_FIGURES",
    "render_conditions_markdown",
    "plot_condition_ratios",
    "write_conditions_report",
    "print_conditions_summary",
]

#: The figures of a k-condition report, by file stem.
CONDITION_FIGURES: tuple[str, ...] = ("conditions_curves", "conditions_ratios")


def _px(v: Any) -> str:
    return "-" if v is None else f"{v:,.0f}"


def _num(v: Any, fmt: str = "{:.3g}") -> str:
    return "-" if v is None else fmt.format(v)


def _p(v: Any) -> str:
    if v is None:
        return "-"
    return "< 0.001" if v < 0.001 else f"{v:.3f}"


def render_conditions_markdown(
    result: Any, *, figures: bool = True, figure_formats: tuple[str, ...] = DEFAULT_FIGURE_FORMATS
) -> str:
    """Return the report text of a :class:`~analysis.conditions.ConditionsResult`.

    With ``figures``, the PNG figures are shown and each file in ``figure_formats`` is linked.

    Returns
    -------
    str
        Markdown: data, the thresholds table, the comparisons table, the odds ratios, which
        methods differ (Holm-adjusted p < 0.05) and the warnings.
    """
    r = result.results_json()
    lines = ["# Recognition analysis: comparison of conditions", ""]
    lines.append(f"Data: {len(result.sources)} file(s); conditions {', '.join(r['conditions'])}.")
    if r["simulated_sessions"]:
        lines.append(
            "**Simulated data**: these sessions were answered by a simulated observer, not a "
            f"person: {'; '.join(r['simulated_sessions'])}."
        )
    n, k = r["n_trials"], r["n_recognized"]
    lines += ["", f"There were {n:,} trials; {k:,} were recognised ({100 * k / n:.1f} %).", ""]
    lines += [
        "## Thresholds",
        "",
        "Weibull psychometric function per condition (pooled; guess rate "
        f"{r['guess']:g}, lapse free), 50 % threshold: posterior median and 95 % credible "
        "interval, and the ML value.",
        "",
        "| condition | status | 50 % threshold (px) | 95 % CrI | ML |",
        "|---|---|---:|---|---:|",
    ]
    for c in r["conditions"]:
        t = r["thresholds"].get(c)
        if t is None:
            lines.append(f"| {c} | not fitted | - | - | - |")
            continue
        ci = t["ci95"]
        lines.append(
            f"| {c} | {t['status']} | {_px(t['p50_pixels'])} | {_px(ci[0])}-{_px(ci[1])} | "
            f"{_px(t['mle_p50_pixels'])} |"
        )
    lines += [
        "",
        "## Comparisons",
        "",
        "Threshold ratio a / b (above 1: b needs fewer pixels) with its 95 % posterior "
        "interval; odds ratio of recognition in b over a from the logistic model, with its "
        "Wald p-value and Holm's adjustment over all pairs.",
        "",
        "| a | b | threshold ratio | 95 % interval | OR (b over a) | 95 % CI | p | p (Holm) |",
        "|---|---|---:|---|---:|---|---:|---:|",
    ]
    for c in r["comparisons"]:
        a, b = c["pair"]
        rc, oc = c["ratio_ci95"], c["odds_ratio_ci95"]
        lines.append(
            f"| {a} | {b} | {_num(c['ratio'])} | {_num(rc[0])}-{_num(rc[1])} | "
            f"{_num(c['odds_ratio'])} | {_num(oc[0])}-{_num(oc[1])} | {_p(c['p'])} | "
            f"{_p(c['p_adjusted'])} |"
        )
    lo = r["logistic"]
    lines += ["", "## Logistic model", ""]
    if lo["method"] == "none":
        lines.append("The logistic model could not be estimated: " + "; ".join(lo["warnings"]))
    else:
        lines.append(f"Model: `{lo['model']}`, reference condition {lo['reference']}.")
        for c, o in lo["odds_ratios"].items():
            ci = o["ci95"]
            sep = " (separated: not estimable)" if o["separated"] else ""
            lines.append(
                f"- {c}: OR {_num(o['or'])} ({_num(ci[0])}-{_num(ci[1])}), p {_p(o['p'])}{sep}"
            )
        px = lo["per_log10_pixels"]
        lines.append(
            f"- per log10 pixels: OR {_num(px['or'])} ({_num(px['ci95'][0])}-{_num(px['ci95'][1])})"
        )
    mx = r.get("logistic_mixed")
    if mx:
        ors = ", ".join(
            f"{c} {_num(o['or'])} ({_num(o['ci95'][0])}-{_num(o['ci95'][1])})"
            for c, o in mx["odds_ratios"].items()
        )
        hits = [
            c for c in mx["contrasts"] if c["p_adjusted"] is not None and c["p_adjusted"] < 0.05
        ]
        pairs = "; ".join(
            f"{c['pair'][1]} / {c['pair'][0]} OR {_num(c['or'])}, Holm p {_p(c['p_adjusted'])}"
            for c in hits
        )
        lines += [
            "",
            f"A mixed model with random subject and object intercepts ({mx['method']}) gives odds "
            f"ratios against {mx['reference']} (95 % CI Wald) {ors}; random-intercept SDs "
            f"{mx['subject_sd']:.2f} (subjects) and {mx['object_sd']:.2f} (objects), log-odds "
            "units. Pairs that differ at a familywise error of 0.05 (Holm): "
            + (pairs or "none")
            + ".",
        ]
    differ = [c for c in r["comparisons"] if c["p_adjusted"] is not None and c["p_adjusted"] < 0.05]
    lines += ["", "## Which methods differ", ""]
    if not differ:
        lines.append("No pair of conditions differs at a familywise error of 0.05 (Holm).")
    for c in differ:
        a, b = c["pair"]
        o = c["odds_ratio"]
        better, worse = (b, a) if o > 1 else (a, b)
        o_better = o if o > 1 else 1.0 / o
        ratio = c["ratio"]
        how = (
            f"; {b} needs {ratio:.2g} times fewer pixels than {a} at 50 %"
            if ratio is not None and ratio > 1
            else (
                f"; {a} needs {1 / ratio:.2g} times fewer pixels than {b} at 50 %" if ratio else ""
            )
        )
        lines.append(
            f"- {better} is recognised more often than {worse} (OR {_num(o_better)}, "
            f"Holm p {_p(c['p_adjusted'])}){how}."
        )
    if figures:
        lines += ["", "## Figures", ""]
        if "png" in figure_formats:
            lines += [
                "![recognition per condition](conditions_curves.png)",
                "",
                "![threshold ratios](conditions_ratios.png)",
                "",
            ]
        lines += [figure_links(name, figure_formats) for name in CONDITION_FIGURES]
    if r["warnings"]:
        lines += ["", "## Warnings", ""] + [f"- {w}" for w in r["warnings"]]
    return "\n".join(lines) + "\n"


def plot_condition_ratios(comparisons: list[dict[str, Any]], *, ax: Any = None) -> Any:
    """Plot every pairwise threshold ratio with its 95 % interval (log axis, 1 marked).

    Parameters
    ----------
    comparisons : list of dict
        ``results.json``'s ``comparisons``.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6.5, 0.4 * len(comparisons) + 1.2))
    labels = []
    for i, c in enumerate(comparisons):
        labels.append(f"{c['pair'][0]} / {c['pair'][1]}")
        if c["ratio"] is None:
            why = c.get("note", "not measured")
            ax.text(1.0, i, f"no ratio: {why}", va="center", ha="center", fontsize="x-small")
            continue
        lo, hi = c["ratio_ci95"]
        ax.errorbar(c["ratio"], i, xerr=[[c["ratio"] - lo], [hi - c["ratio"]]], fmt="o", color="C0")
    ax.axvline(1.0, color="0.6", lw=0.8)
    ax.set_xscale("log")
    ax.set_yticks(range(len(labels)), labels)
    ax.invert_yaxis()
    ax.set_xlabel("50 % threshold ratio (95 % posterior interval)")
    return ax


def write_conditions_report(
    result: Any,
    out_dir: str | Path,
    *,
    staging: Any,
    figures: bool = True,
    figure_formats: tuple[str, ...] = DEFAULT_FIGURE_FORMATS,
) -> Path:
    """Write ``results.json``, ``report.md`` and the two figures to ``out_dir``, atomically.

    Parameters
    ----------
    result : ConditionsResult
    out_dir : str or Path
    staging : callable(out_dir) -> context manager yielding a folder
        The report's staging folder (``analysis.report.atomic_folder``): renamed onto
        ``out_dir`` when everything is written, removed on any error.
    figures : bool
    figure_formats : tuple of str
        The figures' file formats (:mod:`analysis.figure_formats`).

    Returns
    -------
    Path
        The report folder.
    """
    import json

    with staging(out_dir) as tmp:
        text = json.dumps(result.results_json(), indent=2, allow_nan=False) + "\n"
        (tmp / "results.json").write_text(text, encoding="utf-8")
        (tmp / "report.md").write_text(
            render_conditions_markdown(result, figures=figures, figure_formats=figure_formats),
            encoding="utf-8",
        )
        if figures:
            _save_figures(result, tmp, figure_formats)
    return Path(out_dir).resolve()


def _save_figures(result: Any, folder: Path, formats: tuple[str, ...]) -> None:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from analysis.figures import mark_simulated, plot_recognition

    fig, ax = plt.subplots(figsize=(6.0, 4.2))
    plot_recognition(result.thresholds, ax=ax)
    ax.set_title("recognition per condition")
    ax2 = plot_condition_ratios(result.results_json()["comparisons"])
    for name, f in (("conditions_curves", fig), ("conditions_ratios", ax2.figure)):
        if result.simulated_sessions:
            mark_simulated(f)
        f.tight_layout()
        for ext in formats:
            f.savefig(folder / f"{name}.{ext}", dpi=120)
        plt.close(f)


def print_conditions_summary(result: Any, folder: Path, echo) -> None:
    """Print a k-condition result's thresholds and comparisons (``echo`` prints one line)."""
    r = result.results_json()
    echo(f"{r['n_trials']} trials, {r['n_recognized']} recognised")
    if r["simulated_sessions"]:
        echo(f"SIMULATED (no person answered): {'; '.join(r['simulated_sessions'])}")
    for c in r["conditions"]:
        t = r["thresholds"].get(c)
        if t is not None:
            echo(f"50% threshold {c:>11}: {_px(t['p50_pixels'])} px ({t['status']})")
    for c in r["comparisons"]:
        a, b = c["pair"]
        echo(
            f"{a} / {b}: threshold ratio {_num(c['ratio'])}, OR {_num(c['odds_ratio'])}, "
            f"Holm p {_p(c['p_adjusted'])}"
        )
    echo(f"report: {folder / 'report.md'}  (results: {folder / 'results.json'})")
