"""Write a report folder: ``results.json``, ``report.md`` and the figures, atomically.

The folder is built in a temporary sibling and renamed into place, so a reader never sees a
half-written report; an existing report at the same path is replaced.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

from analysis.data import CONDITIONS, object_order
from analysis.jung2015 import (
    OR_BACKGROUND,
    OR_BACKGROUND_CI95,
    OR_LOG10_PIXELS,
    OR_LOG10_PIXELS_CI95,
    THRESHOLD_P50_PX,
)
from analysis.pipeline import AnalysisResult

__all__ = ["render_markdown", "write_report", "FIGURE_NAMES"]

#: Figure files written (each as .png and .svg), after the paper's figure numbers.
FIGURE_NAMES: tuple[str, ...] = (
    "fig8_recognition_vs_pixels",
    "fig9_subject_thresholds",
    "figS2_subject_curves",
    "figS3_object_difficulty",
)


def _px(v: float | None) -> str:
    if v is None:
        return "n/a"
    return f"{v:,.0f}"


def _ci(ci: Any) -> str:
    return f"{_px(ci[0])}-{_px(ci[1])}"


def _side(v: float | None) -> str:
    if v is None:
        return "n/a"
    import math

    side = round(math.sqrt(v * 1.5))
    return f"about {side}x{round(v / side)}"


def render_markdown(result: AnalysisResult, *, figures: bool = True) -> str:
    """Return the report text: results in sentences, as in Jung et al. 2015, Sec. 3.2.2.

    Parameters
    ----------
    result : AnalysisResult
    figures : bool
        Whether figure links are included.

    Returns
    -------
    str
        Markdown.
    """
    r = result.results_json()
    pc = result.options.pc
    lines = ["# Recognition analysis", ""]
    lines.append(
        f"Data: {len(result.sources)} file(s) ({', '.join(Path(s).name for s in result.sources)})."
    )
    if result.simulated_sessions:
        lines.append(
            "**Simulated data**: these sessions were answered by a simulated observer, not a "
            f"person: {'; '.join(result.simulated_sessions)}."
        )
    if result.n_training_excluded:
        lines.append(
            f"Only main-part trials are analysed: {result.n_training_excluded} training trials "
            "(`part` != `main`) were excluded."
        )
    n, k = r["n_trials"], r["n_recognized"]
    subjects = sorted({s for s in result.first_recognized})
    lines += [
        "",
        "## Results",
        "",
        f"There were {n:,} trials from {len(subjects)} subject(s); {k:,} were recognised "
        f"({100 * k / n:.1f} %) and {n - k:,} were not.",
        "",
    ]
    th = r["thresholds"]
    if all(c in th for c in CONDITIONS):
        c, d = th["cluttered"], th["decluttered"]
        guess = result.options.guess
        lines.append(
            "Weibull psychometric functions (guess rate "
            f"{guess:g}, lapse rate free, so not forced to 100 %) were fitted to the pooled "
            "responses of each background condition; intervals are 95 % credible intervals of "
            "the posterior (emcee), and the maximum-likelihood value is given as well. "
            f"The 50 % recognition threshold for the background-cluttered images required a "
            f"resolution of {_px(c['p50_pixels'])} pixels ({_side(c['p50_pixels'])}; 95 % CrI "
            f"{_ci(c['ci95'])}; MLE {_px(c['mle_p50_pixels'])}), while for the de-cluttered images "
            f"the same 50 % performance was reached at {_px(d['p50_pixels'])} pixels "
            f"({_side(d['p50_pixels'])}; 95 % CrI {_ci(d['ci95'])}; MLE "
            f"{_px(d['mle_p50_pixels'])}). The paper reports "
            f"{THRESHOLD_P50_PX['cluttered']:,.0f} and {THRESHOLD_P50_PX['decluttered']:,.0f} "
            "pixels."
        )
        if pc != 0.5:
            lines.append("")
            lines.append(
                f"At {100 * pc:g} % recognition the thresholds are {_px(c.get('threshold'))} "
                f"(95 % CrI {_ci(c['threshold_ci95'])}) pixels cluttered and "
                f"{_px(d.get('threshold'))} (95 % CrI {_ci(d['threshold_ci95'])}) pixels "
                "de-cluttered."
            )
        conv = [name for name, f in th.items() if not f["converged"]]
        lines.append("")
        lines.append(
            "All pooled chains converged (chain length >= 50 integrated autocorrelation times)."
            if not conv
            else f"Chains NOT converged: {', '.join(conv)}; treat their intervals with care."
        )
    lo = r["logistic"]
    bg = lo["odds_ratios"]["background"]
    lp = lo["odds_ratios"]["log10_pixels"]
    pr = r["predictions"]
    cl = lo["classification"]
    n_obj = sum(1 for t in lo["odds_ratios"] if t.startswith("object:"))
    lines += [
        "",
        "In the binary logistic regression on all trials (predictors: background, reference "
        f"cluttered; {n_obj} object dummies, reference object {lo['reference_object']}; "
        "log10 pixels"
        + ("; subject dummies" if lo["subject_factor"] else "")
        + f"), the odds ratio for background was {bg['or']:.1f} (95 % CI "
        f"{bg['ci95'][0]:.1f}-{bg['ci95'][1]:.1f}, p = {bg['p']:.2g}): holding the other "
        f"variables constant, a de-cluttered image is {bg['or']:.1f} times more likely (in odds) "
        "to be recognised than a background-cluttered one. By Eq. 1, if the cluttered "
        f"recognition rate is 50 %, the de-cluttered rate is expected to be "
        f"{100 * pr['decluttered_if_cluttered_50pct']:.1f} %; if the de-cluttered rate is 50 %, "
        f"the cluttered rate is only {100 * pr['cluttered_if_decluttered_50pct']:.1f} %. "
        f"(Paper: OR {OR_BACKGROUND} with 95 % CI {OR_BACKGROUND_CI95[0]}-"
        f"{OR_BACKGROUND_CI95[1]}.)",
        "",
        f"The odds ratio per log10 pixels was {lp['or']:.1f} (95 % CI {lp['ci95'][0]:.1f}-"
        f"{lp['ci95'][1]:.1f}, p = {lp['p']:.2g}): the odds of recognition are multiplied by "
        f"{lp['or']:.1f} for a tenfold increase in resolution (paper: {OR_LOG10_PIXELS}, "
        f"{OR_LOG10_PIXELS_CI95[0]}-{OR_LOG10_PIXELS_CI95[1]}). "
        f"{lo['n_significant_objects']} of {n_obj} object dummies were significant "
        "(p < 0.05). "
        f"The model classified {cl['recognized_correct_pct']:.1f} % of recognised and "
        f"{cl['not_recognized_correct_pct']:.1f} % of not-recognised trials correctly "
        f"(cutoff {cl['cutoff']:g}).",
    ]
    if "mixed" in lo:
        mb = lo["mixed"]["odds_ratios"]["background"]
        ml = lo["mixed"]["odds_ratios"]["log10_pixels"]
        lines += [
            "",
            "A mixed model with random subject and object intercepts (statsmodels "
            "BinomialBayesMixedGLM, variational Bayes) gives a background odds ratio of "
            f"{mb['or']:.1f} ({mb['ci95'][0]:.1f}-{mb['ci95'][1]:.1f}) and {ml['or']:.1f} "
            f"({ml['ci95'][0]:.1f}-{ml['ci95'][1]:.1f}) per log10 pixels; random-intercept SDs "
            f"{lo['mixed']['subject_sd']:.2f} (subjects) and {lo['mixed']['object_sd']:.2f} "
            "(objects), log-odds units. Variational-Bayes intervals understate the uncertainty; "
            "read the point estimates.",
        ]
    st = r["subject_thresholds"]
    if st:
        lines += [
            "",
            "## 50 % thresholds per subject (Fig. 9)",
            "",
            "| subject | cluttered px (95 % CrI) | de-cluttered px (95 % CrI) | converged |",
            "|---|---|---|---|",
        ]
        for s, fits in st.items():
            cells = []
            for c in CONDITIONS:
                f = fits.get(c)
                cells.append(f"{_px(f['p50_pixels'])} ({_ci(f['ci95'])})" if f else "n/a")
            conv = all(f["converged"] for f in fits.values())
            lines.append(f"| {s} | {cells[0]} | {cells[1]} | {'yes' if conv else 'no'} |")
    fr = result.first_recognized
    if fr:
        subs = list(fr)
        objects = object_order({o for s in fr for o in fr[s]})
        lines += [
            "",
            "## First recognised level per subject (pixels; cluttered / de-cluttered)",
            "",
            "Lowest resolution at which each subject recognised each object; `-` = never.",
            "",
            "| object | " + " | ".join(subs) + " |",
            "|---|" + "---|" * len(subs),
        ]
        for o in objects:
            cells = []
            for s in subs:
                v = fr[s].get(o, {})
                cells.append(
                    " / ".join("-" if v.get(c) is None else f"{v[c]:,.0f}" for c in CONDITIONS)
                )
            lines.append(f"| {o} | " + " | ".join(cells) + " |")
    if result.warnings:
        lines += ["", "## Warnings", ""] + [f"- {w}" for w in result.warnings]
    if figures:
        lines += ["", "## Figures", ""]
        lines += [f"- [{name}]({name}.png) ([SVG]({name}.svg))" for name in FIGURE_NAMES]
    return "\n".join(lines) + "\n"


def _folder_mode() -> int:
    """Return the mode ``mkdir`` would give a new folder under the user's umask."""
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o777 & ~mask


def write_report(result: AnalysisResult, out_dir: str | Path, *, figures: bool = True) -> Path:
    """Write ``results.json``, ``report.md`` and figures to ``out_dir``, atomically.

    Parameters
    ----------
    result : AnalysisResult
    out_dir : str or Path
        Report folder; replaced if it exists.
    figures : bool
        Draw the figures (PNG and SVG).

    Returns
    -------
    Path
        The report folder.
    """
    out = Path(out_dir).resolve()
    if out.exists() and not out.is_dir():
        raise FileExistsError(f"out_dir must be a folder, got an existing file {out}")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=out.parent))
    try:
        with open(tmp / "results.json", "w", encoding="utf-8") as fh:
            json.dump(result.results_json(), fh, indent=2, allow_nan=False)
            fh.write("\n")
        (tmp / "report.md").write_text(render_markdown(result, figures=figures), encoding="utf-8")
        if figures:
            from analysis.figures import save_all

            save_all(result, tmp)
        os.chmod(tmp, _folder_mode())  # mkdtemp makes it private (0700)
        old = None
        if out.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
            os.replace(out, old / out.name)
        os.replace(tmp, out)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out
