"""Write a report folder: ``results.json``, ``report.md`` and the figures, atomically.

The folder is built in a temporary sibling and renamed into place, so a reader never sees a
half-written report; an existing report at the same path is replaced.
"""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from analysis.data import CONDITIONS, object_order
from analysis.errors import DataError
from analysis.figure_formats import DEFAULT_FIGURE_FORMATS, figure_links
from analysis.jung2015 import (
    OR_BACKGROUND,
    OR_BACKGROUND_CI95,
    OR_LOG10_PIXELS,
    OR_LOG10_PIXELS_CI95,
    THRESHOLD_P50_PX,
)
from analysis.pipeline import AnalysisResult
from analysis.staging import STAGING_MARKER as _STAGING_MARKER
from analysis.staging import (
    is_link_loop,
    make_parents,
    new_staging,
    publish,
    remove_made,
    remove_own_tree,
    resolve,
)
from analysis.weibull.threshold import unmeasured_text

__all__ = [
    "render_markdown",
    "write_report",
    "threshold_text",
    "atomic_folder",
    "results_json_text",
    "FIGURE_NAMES",
    "p_text",
    "deviance_text",
    "QUESTION_SAMPLE",
    "QUESTION_POPULATION",
    "QUESTION_FITTED",
    "QUESTION_ODDS_RATIO",
    "THRESHOLD_INTERVALS_NOTE",
    "pooled_curve_text",
    "OR_INTERVALS_NOTE",
]

#: The target of the pooled-curve interval (:mod:`analysis.pooled_curve`): where the subjects and
#: objects tested, taken together, recognise half the time.
QUESTION_SAMPLE: str = "these subjects and objects"
#: The target of a population interval (cluster-robust, or a mixed model's).
QUESTION_POPULATION: str = "the population of subjects and objects"
#: The target of the pooled Weibull fit's credible interval: when subjects and objects differ,
#: the pooled curve is not a Weibull and the fitted Weibull's 50 % point lies a few percent above
#: the pooled curve's (benchmarks/validate_weibull_coverage.py).
QUESTION_FITTED: str = "the Weibull fitted to the pooled responses"
#: The target of the fixed-effects odds ratios: the logistic model fitted to the pooled responses
#: of the subjects and objects tested (averaged over subjects, lapses included).
QUESTION_ODDS_RATIO: str = "these subjects and objects, pooled"


def p_text(p: float) -> str:
    """Return a p-value as report text: ``p = 0.012``, or ``p < 1e-300`` below that.

    Below about 1e-300 a double underflows towards 0, and "p = 0" would claim certainty.

    Examples
    --------
    >>> p_text(0.0123), p_text(0.0), p_text(3e-302)
    ('p = 0.012', 'p < 1e-300', 'p < 1e-300')
    """
    return "p < 1e-300" if p < 1e-300 else f"p = {p:.2g}"


def deviance_text(gof: dict[str, Any]) -> str:
    """Return ``deviance 7.3 on 5 df``, or why there is no deviance test (df <= 0).

    Parameters
    ----------
    gof : dict
        ``WeibullFit.goodness_of_fit()``: ``deviance``, ``deviance_df`` (levels - 3).
    """
    df = int(gof["deviance_df"])
    if df > 0:
        return f"deviance {gof['deviance']:.1f} on {df} df"
    return f"no deviance test ({df + 3} levels with data for 3 parameters)"


#: Figure files written (a 300 dpi .png and a .pdf, and .svg when asked for), after the paper's
#: figure numbers.
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


def threshold_text(t: dict[str, Any], *, side: bool = False, question: str = "") -> str:
    """Return a threshold entry (``Threshold.to_dict()``) as report text, honest about censoring.

    Parameters
    ----------
    t : dict
        ``status``, ``median``, ``ci95``, ``mle``, ``lowest_tested``, ``highest_tested``,
        ``reason``.
    side : bool
        Add the image side (``about 114x76``) after a measured value in pixels.
    question : str
        The target the credible interval covers (e.g. :data:`QUESTION_FITTED`), named after it.

    Returns
    -------
    str
        ``"8,695 px (...; 95 % CrI ...; ML ...)"`` when measured; ``"< 96 px (...)"``,
        ``"> 160,884 px (...)"`` when censored; ``"between 3,290 and 17,876 px (unidentified:
        2 levels with data; ...)"`` (the tested levels that bracket it, or a bound) or
        ``"not identified (...)"`` when the data do not identify it.
    """
    if t["status"] == "measured":
        extra = f"{_side(t['median'])}; " if side else ""
        q = f" for {question}" if question else ""
        return f"{_px(t['median'])} px ({extra}95 % CrI {_ci(t['ci95'])}{q}; ML {_px(t['mle'])})"
    return unmeasured_text(
        t, "{:,.0f}", "px", with_reason=True, unidentified_note="; no interval is given"
    )


def pooled_curve_text(pcv: dict[str, Any] | None) -> str:
    """Return the pooled curve's 50 % point and interval (:mod:`analysis.pooled_curve`) as text.

    Parameters
    ----------
    pcv : dict or None
        ``threshold``, ``ci95`` (an end may be None: beyond one decade outside the tested
        levels), ``asymmetry``.

    Returns
    -------
    str
        ``"8,210 px (95 % CI 7,010-9,700 px for these subjects and objects; asymmetric curve,
        lambda 0.36, profile likelihood)"``; ``""`` when ``pcv`` is None.
    """
    if not pcv:
        return ""
    lo, hi = pcv["ci95"]
    ends = (
        f"{'0' if lo is None else _px(lo)}-{'beyond the tested range' if hi is None else _px(hi)}"
    )
    return (
        f"{_px(pcv['threshold'])} px (95 % CI {ends} px for {QUESTION_SAMPLE}; asymmetric "
        f"curve, lambda {pcv['asymmetry']:.2f}, profile likelihood)"
    )


#: What each threshold interval covers, from benchmarks/validate_weibull_coverage.py.
THRESHOLD_INTERVALS_NOTE: str = (
    "Each interval names the target it covers. The credible interval covers "
    f"'{QUESTION_FITTED}': the 50 % point of the Weibull that best fits the responses of the "
    "subjects and objects tested. When they differ, their pooled curve (the mean of their "
    "curves) is shallower than a Weibull, and the fitted Weibull's 50 % point lies a few "
    "percent above the pooled curve's. The pooled-curve interval covers "
    f"'{QUESTION_SAMPLE}': where the subjects and objects tested, taken together, recognise "
    "half the time, by a curve whose asymmetry is free (Aranda-Ordaz's family: lambda 0 is the "
    "Weibull, 1 the log-logistic), so that it can take the shape that differing subjects and "
    "objects give the pooled curve (profile likelihood). The population 95 % interval of the ML "
    "threshold (two-way cluster-robust over subjects and objects, t quantile with min(subjects, "
    f"objects) - 1 df) covers '{QUESTION_POPULATION}': where it would be for other subjects "
    "and objects drawn the same way. In simulated studies of this design "
    "(benchmarks/validate_weibull_coverage.py; binomial standard error about 0.01) with "
    "subjects and objects that differ and subjects that lapse (1,000 fits), each interval "
    "covered its own target in 0.947 (credible), 0.957 (pooled curve) and 0.954 "
    "(population) of fits, and with identical observers (500 fits) in 0.948, 0.942 and "
    "0.940; the credible interval covered the pooled curve's 50 % point in only 0.918 "
    "(the fitted Weibull's sat 1.046 times above it on average) and the population's in "
    "0.564. A threshold the data do not identify is given by the tested levels that "
    "bracket it, with no interval."
)


#: How the odds-ratio intervals were chosen, from benchmarks/validate_or_coverage.py.
OR_INTERVALS_NOTE: str = (
    f"Odds-ratio intervals cover the odds ratio of '{QUESTION_ODDS_RATIO}': that of the logistic "
    "model fitted to the responses of the subjects and objects tested (objects as dummies, "
    "subjects pooled), which averages over subjects and includes their lapses, so it is smaller "
    "than any one subject's. The first interval is the default: the profile penalised likelihood "
    "around Firth's estimate (Heinze & Schemper 2002). In 2,000 simulated studies of the "
    "paper's design (6 subjects x 20 objects x 8 levels x 2 conditions) from its model "
    "(benchmarks/validate_or_coverage.py) the ML log odds ratios "
    "are biased away from 0 (+2.6 % background, +2.8 % per log10 pixels, Firth's -0.2 % and "
    "-0.1 %), and 95 % intervals covered the true odds ratio in 0.949 and 0.937 (Wald), 0.947 "
    "and 0.925 (ML profile likelihood), and 0.958 and 0.949 (Firth profile, the default) of "
    "studies (background, log10 pixels; Monte-Carlo error +-0.01). In 300 simulated studies "
    "where subjects differ (random intercepts, SD 1 log-odds unit), objects are drawn afresh and "
    "each subject lapses (0-10 %), the default covered the odds ratio of these subjects and "
    "objects, pooled, in 0.960 and 0.943 of studies (ML Wald 0.960 and 0.937; binomial "
    "standard error about 0.013), the subject-specific odds ratio that generated the data in "
    "only 0.08 and 0.00, and the population's (subjects integrated out) in 0.94 and "
    "0.72: for the population, see the mixed model (confocal analyze --mixed)."
)


def _or_ends(ci: Any) -> str:
    lo = "0" if ci[0] is None else f"{ci[0]:.3g}"
    hi = "inf" if ci[1] is None else f"{ci[1]:.3g}"
    return f"{lo}-{hi}"


def _or_text(
    o: dict[str, Any],
    term: str,
    separated: tuple[str, ...],
    profile: Any = None,
    intervals: dict[str, Any] | None = None,
) -> str:
    if intervals:
        # The default first (one rule, said beside it), the paper's ML intervals after it.
        if intervals["interval"] == "none":
            ci = f"no 95 % CI: {intervals['note']}"
        else:
            ci = f"95 % CI {_or_ends(intervals['ci95'])} Firth profile penalised likelihood"
        if "ml_or" in intervals:
            ci += f"; ML {intervals['ml_or']:.3g}, 95 % CI {_or_ends(intervals['wald'])} Wald"
            if "profile" in intervals:
                ci += f", {_or_ends(intervals['profile'])} profile likelihood"
        wald = "ML Wald" if "ml_or" in intervals else "Wald"
        what = "Firth's estimate" if "firth_or" in intervals else "ML estimate"
        base = (
            f"{intervals['or']:.3g} ({what}; {ci}; {wald} {p_text(o['p'])}; "
            f"for {QUESTION_ODDS_RATIO})"
        )
        if term in separated:
            return f"{base}; separated in these data (the ML odds ratio is infinite)"
        return base
    ci = f"95 % CI {o['ci95'][0]:.3g}-{o['ci95'][1]:.3g} Wald"
    if profile:
        ci += f", {_or_ends(profile)} profile likelihood"
    base = f"{o['or']:.3g} ({ci}; {p_text(o['p'])}; for {QUESTION_ODDS_RATIO})"
    if term in separated:
        return (
            f"{base}; separated in these data (the ML odds ratio is infinite), Firth's penalised "
            "estimate"
        )
    return base


def render_markdown(
    result: AnalysisResult,
    *,
    figures: bool = True,
    results: dict[str, Any] | None = None,
    figure_formats: tuple[str, ...] = DEFAULT_FIGURE_FORMATS,
) -> str:
    """Return the report text: results in sentences, as in Jung et al. 2015, Sec. 3.2.2.

    Every threshold is printed with its status: a number (posterior median, 95 % CrI and the ML
    value) only when it lies inside the tested range, "< lowest" / "> highest" when censored,
    and "not identified" when the data do not locate it.

    Parameters
    ----------
    result : AnalysisResult
    figures : bool
        Whether figure links are included.
    results : dict, optional
        ``result.results_json()`` when already computed.
    figure_formats : tuple of str
        The figures' file formats, each linked (:mod:`analysis.figure_formats`).

    Returns
    -------
    str
        Markdown.
    """
    r = results if results is not None else result.results_json()
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
    guess = result.options.guess
    od = result.options.overdispersion
    lines.append(
        f"Weibull psychometric functions (guess rate {guess:g}, lapse rate free, so not forced to "
        "100 %) were fitted to the pooled responses of each background condition; intervals are "
        "95 % credible intervals of the posterior (ensemble MCMC, differential-evolution moves)"
        + (
            ", with beta-binomial overdispersion (free scale eta, as psignifit 4) because pooled "
            "subjects and objects differ"
            if od
            else ", binomial likelihood"
        )
        + ", and the maximum-likelihood (ML) value, which the paper reports, is given beside the "
        "posterior median."
    )
    lines.append(THRESHOLD_INTERVALS_NOTE)
    lines.append("")
    for c in CONDITIONS:
        if c not in th:
            lines.append(f"- {c}: no trials, not fitted.")
            continue
        f = th[c]
        t50 = threshold_text(f["threshold_50"], side=True, question=QUESTION_FITTED)
        line = f"- {c}: 50 % threshold {t50}"
        if f["threshold_50"]["status"] == "measured" and f.get("pooled_curve"):
            line += f"; pooled curve {pooled_curve_text(f['pooled_curve'])}"
        pop = f.get("population_ci95", {}).get("0.5")
        if pop:
            line += f"; 95 % population interval {_ci(pop)} px for {QUESTION_POPULATION}"
        if f["overdispersion"]:
            line += f"; overdispersion eta {f['eta']:.3f} ({f['eta_ci95'][0]:.3f}-" + (
                f"{f['eta_ci95'][1]:.3f})"
            )
        g = f["goodness_of_fit"]
        line += f"; {deviance_text(g)}, posterior-predictive p = {g['ppp']:.2f}."
        lines.append(line)
        if pc != 0.5:
            lines.append(f"  At {100 * pc:g} % recognition: {threshold_text(f['threshold_pc'])}.")
    lines.append("")
    lines.append(
        f"The paper reports {THRESHOLD_P50_PX['cluttered']:,.0f} (cluttered) and "
        f"{THRESHOLD_P50_PX['decluttered']:,.0f} (de-cluttered) pixels."
    )
    conv = [name for name, f in th.items() if not f["converged"]]
    lines.append("")
    lines.append(
        "All pooled chains converged (chain length >= 50 integrated autocorrelation times)."
        if not conv
        else f"Chains NOT converged: {', '.join(conv)}; treat their intervals with care."
    )
    lo = r["logistic"]
    sep = tuple(lo.get("separated", ()))
    ors = lo["odds_ratios"]
    prof = lo.get("profile_ci95", {})
    ivs = lo.get("intervals", {})
    n_obj = sum(1 for t in ors if t.startswith("object:"))
    lines.append("")
    if lo["method"] == "none":
        lines.append(
            "The binary logistic regression could not be estimated: "
            + "; ".join(lo["warnings"])
            + "."
        )
    else:
        preds = ["background, reference cluttered"] if "background" in ors else []
        if n_obj:
            preds.append(f"{n_obj} object dummies, reference object {lo['reference_object']}")
        if "log10_pixels" in ors:
            preds.append("log10 pixels")
        if lo["subject_factor"]:
            preds.append("subject dummies")
        how = (
            "maximum likelihood"
            if lo["method"] == "ml"
            else "Firth's penalised likelihood (the ML estimates do not exist in these data)"
        )
        text = f"In the binary logistic regression on all trials ({'; '.join(preds)}; {how})"
        if "background" in ors:
            bg = ors["background"]
            pr = r["predictions"]
            text += (
                ", the odds ratio for background was "
                f"{_or_text(bg, 'background', sep, prof.get('background'), ivs.get('background'))}"
                ": holding the other variables constant, a de-cluttered image is "
                f"{ivs.get('background', bg)['or']:.3g} times more "
                "likely (in odds) to be recognised than a background-cluttered one. By Eq. 1, if "
                "the cluttered recognition rate is 50 %, the de-cluttered rate is expected to be "
                f"{100 * pr['decluttered_if_cluttered_50pct']:.1f} %; if the de-cluttered rate is "
                f"50 %, the cluttered rate is only "
                f"{100 * pr['cluttered_if_decluttered_50pct']:.1f} %. (Paper: OR {OR_BACKGROUND} "
                f"with 95 % CI {OR_BACKGROUND_CI95[0]}-{OR_BACKGROUND_CI95[1]}.)"
            )
        else:
            text += ", no background odds ratio could be estimated (one condition only)."
        lines.append(text)
        if "log10_pixels" in ors:
            lp = ors["log10_pixels"]
            lp_text = _or_text(
                lp, "log10_pixels", sep, prof.get("log10_pixels"), ivs.get("log10_pixels")
            )
            lines += [
                "",
                f"The odds ratio per log10 pixels was {lp_text}: the odds of recognition are "
                f"multiplied by {ivs.get('log10_pixels', lp)['or']:.3g} for a "
                f"tenfold increase in resolution (paper: {OR_LOG10_PIXELS}, "
                f"{OR_LOG10_PIXELS_CI95[0]}-{OR_LOG10_PIXELS_CI95[1]}).",
            ]
        if ivs:
            lines += ["", OR_INTERVALS_NOTE]
        cl = lo["classification"]
        tail = (
            f"{lo['n_significant_objects']} of {n_obj} object dummies were significant (p < 0.05). "
            if n_obj
            else ""
        )
        lines += [
            "",
            tail + f"The model classified {cl['recognized_correct_pct']:.1f} % of recognised and "
            f"{cl['not_recognized_correct_pct']:.1f} % of not-recognised trials correctly "
            f"(cutoff {cl['cutoff']:g}).",
        ]
    if "mixed" in lo:
        m = lo["mixed"]
        parts = []
        for term in ("background", "log10_pixels"):
            o = m["odds_ratios"].get(term)
            if o is None:
                continue
            if m.get("intervals"):
                parts.append(
                    f"{term} {o['or']:.3g} (95 % CI {o['ci95'][0]:.3g}-{o['ci95'][1]:.3g} Wald, "
                    f"for {QUESTION_POPULATION}; {p_text(o['p'])})"
                )
            else:
                parts.append(f"{term} {o['or']:.3g}")
        lines += [
            "",
            f"A mixed model with random subject and object intercepts ({m['method']}) gives odds "
            f"ratios {', '.join(parts)}; random-intercept SDs {m['subject_sd']:.2f} (subjects) "
            f"and {m['object_sd']:.2f} (objects), log-odds units."
            + ("" if m.get("intervals") else " " + m.get("note", "")),
        ]
    st = r["subject_thresholds"]
    if st:
        lines += [
            "",
            "## 50 % thresholds per subject (Fig. 9)",
            "",
            "Posterior median (95 % CrI; ML). Censored thresholds are given as bounds.",
            "",
            "| subject | cluttered | de-cluttered | converged |",
            "|---|---|---|---|",
        ]
        for s, fits in st.items():
            cells = []
            for c in CONDITIONS:
                f = fits.get(c)
                cells.append(threshold_text(f["threshold_50"]) if f else "n/a")
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
        lines += [figure_links(name, figure_formats) for name in FIGURE_NAMES]
    return "\n".join(lines) + "\n"


def results_json_text(data: dict[str, Any]) -> str:
    """Return ``data`` as a report's ``results.json`` text: strict JSON (no NaN), indented."""
    return json.dumps(data, indent=2, allow_nan=False) + "\n"


def write_report(
    result: AnalysisResult,
    out_dir: str | Path,
    *,
    figures: bool = True,
    figure_formats: tuple[str, ...] = DEFAULT_FIGURE_FORMATS,
) -> Path:
    """Write ``results.json``, ``report.md`` and figures to ``out_dir``, atomically.

    Parameters
    ----------
    result : AnalysisResult
    out_dir : str or Path
        Report folder; replaced if it exists.
    figures : bool
        Draw the figures.
    figure_formats : tuple of str
        Their file formats (:mod:`analysis.figure_formats`): a 300 dpi PNG and a PDF by default.

    Returns
    -------
    Path
        The report folder.
    """
    if getattr(result, "kind", "") == "conditions":  # a comparison of k conditions
        from analysis.conditions_report import write_conditions_report

        return write_conditions_report(
            result, out_dir, staging=atomic_folder, figures=figures, figure_formats=figure_formats
        )
    with atomic_folder(out_dir) as tmp:
        r = result.results_json()
        (tmp / "results.json").write_text(results_json_text(r), encoding="utf-8")
        (tmp / "report.md").write_text(
            render_markdown(result, figures=figures, results=r, figure_formats=figure_formats),
            encoding="utf-8",
        )
        if figures:
            from analysis.figures import save_all

            save_all(result, tmp, formats=figure_formats)
    return resolve(out_dir)


#: Name of the marker file inside a staging folder (``.NAME.tmp-*``): ``{"pid": N}``, the process
#: that fills it (the same convention as ``stimuli.io.STAGING_MARKER``). It proves confocal made
#: the folder, so a later run may delete it once that process is gone; it is removed before the
#: rename.
STAGING_MARKER = _STAGING_MARKER


@contextlib.contextmanager
def atomic_folder(out_dir: str | Path) -> Iterator[Path]:
    """Yield a staging folder beside ``out_dir`` that becomes ``out_dir`` when the block succeeds.

    ``out_dir`` is resolved once (:func:`analysis.staging.resolve`: links, then ``..``); a link at
    ``out_dir`` itself is refused. It must be missing or an empty folder: a non-empty folder is
    never replaced (checked before the block; the final rename replaces nothing but an empty
    folder, and a target that appeared meanwhile is refused). On any exception only the staging
    folder this call made is removed (checked by device and inode), and ``out_dir`` is left as
    it was.

    Parameters
    ----------
    out_dir : str or Path
        Folder to create (missing or empty).

    Yields
    ------
    Path
        The staging folder to fill.

    Raises
    ------
    DataError
        ``out_dir`` is a link, a loop of links, an existing file or a non-empty folder.
    """
    given = Path(out_dir)
    real = resolve(given)
    if os.path.islink(given):
        raise DataError(
            f"--out {given} is a symbolic link; confocal never writes through a link: give the "
            "folder itself, or a new one"
        )
    if is_link_loop(real):
        raise DataError(f"--out {given} is a loop of symbolic links; expected a report folder")
    _check_missing_or_empty(real, given)
    made: list = []
    tmp, ident = None, None
    try:
        made = make_parents(real.parent)
        tmp, ident = new_staging(real)
        yield tmp
        try:
            publish(tmp, ident, real)
        except FileExistsError:
            _check_missing_or_empty(real, given)
            raise DataError(
                f"--out {given} appeared while the report was written; it was left as it was"
            ) from None
        tmp = None  # it is the report now
    except BaseException:
        if tmp is not None:
            remove_own_tree(tmp, ident)
            tmp = None
        remove_made(made)
        raise
    finally:
        if tmp is not None:
            remove_own_tree(tmp, ident)


def _check_missing_or_empty(out: Path, given: Path) -> None:
    if out.exists() and not out.is_dir():
        raise DataError(f"--out {given} exists and is not a folder; expected a report folder")
    if out.is_dir() and any(out.iterdir()):
        raise DataError(
            f"--out {given}: folder is not empty; a report is written only into a new or empty "
            "folder"
        )
