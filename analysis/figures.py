"""Figures after Jung et al. 2015 (Figs. 8, 9, S2, S3): with its files, matplotlib's only user.

Only this module and :mod:`analysis.figure_files` (which saves the figures) import matplotlib.

Functions take result objects and an optional ``ax`` and return the Axes (or Figure). They use
:class:`matplotlib.figure.Figure` directly, so no backend is chosen and nothing is shown
(house style H13).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from analysis.data import CONDITIONS
from analysis.figure_files import PNG_DPI, load_backends, save_figures
from analysis.figure_formats import DEFAULT_FIGURE_FORMATS
from analysis.logistic import LogisticFit
from analysis.weibull import WeibullFit

__all__ = [
    "plot_recognition",
    "plot_subject_thresholds",
    "plot_subject_curves",
    "plot_object_difficulty",
    "save_all",
    "save_figures",
    "STUDY_FIGURES",
    "binomial_ci95",
    "plot_time_to_recognition",
    "save_time_to_recognition",
    "ACTIVE_FIGURE",
    "mark_simulated",
    "SIMULATED_MARK",
    "PNG_DPI",
]

#: Colours per condition (ours): grey for cluttered, blue for de-cluttered.
COLORS: dict[str, str] = {"cluttered": "0.35", "decluttered": "tab:blue"}
#: Prosthesis resolution line of Fig. 9, pixels. Source: Jung et al. 2015, Fig. 9 caption.
PROSTHESIS_PX: float = 1500.0
#: Text stamped on every figure drawn from simulated sessions (:func:`mark_simulated`).
SIMULATED_MARK: str = "SIMULATED"


def mark_simulated(fig: Figure) -> Figure:
    """Stamp :data:`SIMULATED_MARK` across a figure drawn from simulated data; return it.

    A large, light diagonal label over the whole figure (drawn above the axes), so that a
    cropped panel still says it is not data from people.

    Parameters
    ----------
    fig : matplotlib Figure

    Returns
    -------
    matplotlib.figure.Figure
        The same figure.
    """
    fig.text(
        0.5,
        0.5,
        SIMULATED_MARK,
        ha="center",
        va="center",
        rotation=25,
        fontsize=40,
        color="tab:red",
        alpha=0.25,
        zorder=10,
        gid="simulated-mark",
    )
    return fig


def _plain_numbers(v: float, _pos: Any = None) -> str:
    """Tick label of a log axis as a plain number (``1,000``): read at a glance, and no TeX."""
    return f"{v:,.0f}" if v >= 1 else f"{v:g}"


def _log_axis(ax: Axes, which: str) -> None:
    """Make the ``which`` ('x' or 'y') axis of ``ax`` logarithmic with plain-number labels.

    Matplotlib's default labels (``10^3``) go through its TeX parser on every draw, the largest
    single cost of drawing the figures; plain numbers cost nothing to lay out. Minor ticks sit
    at 2 and 5 times each power of ten (each tick is drawn object by object), labelled only
    when fewer than two powers of ten are in view, so that at least two labels show.
    """
    from matplotlib.ticker import FuncFormatter, LogLocator

    (ax.set_xscale if which == "x" else ax.set_yscale)("log")
    axis = ax.xaxis if which == "x" else ax.yaxis

    def minor(v: float, pos: Any = None) -> str:
        lo, hi = sorted(axis.get_view_interval())
        if lo <= 0 or np.floor(np.log10(hi)) - np.ceil(np.log10(lo)) >= 1:  # 2+ powers of ten
            return ""
        lead = round(v / 10 ** np.floor(np.log10(v) + 1e-9))
        return _plain_numbers(v) if lead in (2, 5) else ""

    axis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))  # a third of the default's ticks
    axis.set_major_formatter(FuncFormatter(_plain_numbers))
    axis.set_minor_formatter(FuncFormatter(minor))


def _new_ax(ax: Axes | None, size: tuple[float, float] = (5.0, 3.8)) -> Axes:
    if ax is not None:
        return ax
    fig = Figure(figsize=size, layout="constrained")
    return fig.add_subplot()


def binomial_ci95(k: Any, n: Any) -> tuple[np.ndarray, np.ndarray]:
    """Return Clopper-Pearson 95 % intervals of proportions ``k / n``.

    Parameters
    ----------
    k, n : array_like
        Successes and trials (n > 0).

    Returns
    -------
    low, high : ndarray

    Examples
    --------
    >>> [round(float(v), 4) for v in np.ravel(binomial_ci95([0], [10]))]
    [0.0, 0.3085]
    """
    from scipy import stats

    k = np.asarray(k, float)
    n = np.asarray(n, float)
    with np.errstate(invalid="ignore"):
        lo = np.where(k > 0, stats.beta.ppf(0.025, k, n - k + 1), 0.0)
        hi = np.where(k < n, stats.beta.ppf(0.975, k + 1, n - k), 1.0)
    return lo, hi


def plot_recognition(
    fits: dict[str, WeibullFit],
    *,
    pc: float = 0.5,
    ax: Axes | None = None,
    legend: bool = True,
    midpoint: bool = False,
) -> Axes:
    """Plot recognition rate vs pixels per condition: data, fitted curve, 95 % band, thresholds.

    The paper's Fig. 8 (Jung et al. 2015).

    Parameters
    ----------
    fits : dict of str to WeibullFit
        Condition -> fit (pixels on a log axis).
    pc : float
        Proportion correct of the marked thresholds.
    ax : matplotlib Axes, optional
        Drawn into when given; a new Figure otherwise.
    legend : bool
        Draw a legend.
    midpoint : bool
        Mark the midpoint thresholds (between the guess rate and 1 - lapse) instead of ``pc``.

    A curve whose posterior-predictive p is below :data:`analysis.weibull.summary.POOR_FIT_PPP`
    says so in its legend entry.

    Returns
    -------
    matplotlib.axes.Axes
    """
    from analysis.weibull import is_log_axis
    from analysis.weibull.summary import POOR_FIT_PPP

    ax = _new_ax(ax)
    log = True
    for i, (cond, fit) in enumerate(fits.items()):
        color = COLORS.get(cond, f"C{i % 10}")
        log = is_log_axis(fit.sigmoid)
        x = np.asarray(fit.pixels)
        k, n = np.asarray(fit.k), np.asarray(fit.n)
        rate = k / n
        if log:
            grid = np.logspace(np.log10(x.min()) - 0.2, np.log10(x.max()) + 0.2, 200)
        else:
            pad = 0.1 * (x.max() - x.min() or 1.0)
            grid = np.linspace(x.min() - pad, x.max() + pad, 200)
        med, lo, hi = fit.curve_band(grid)
        ax.fill_between(grid, lo, hi, color=color, alpha=0.2, lw=0)
        gof = fit.goodness_of_fit()
        poor = gof["deviance_df"] > 0 and gof["ppp"] < POOR_FIT_PPP
        fit_label = f"{cond}: fit, 95 % band" + (
            f" - POOR FIT (posterior-predictive p {gof['ppp']:.2f})" if poor else ""
        )
        ax.plot(grid, med, color=color, label=fit_label)
        clo, chi = binomial_ci95(k, n)
        ax.errorbar(
            x,
            rate,
            yerr=[rate - clo, chi - rate],
            fmt="o",
            color=color,
            ms=4,
            elinewidth=0.8,
            capsize=0,
            label=f"{cond}: data, 95 % binomial CI",
        )
        t = fit.threshold(pc, midpoint=midpoint)
        if t.measured:
            ax.axvline(t.median, color=color, ls="--", lw=0.8)
            ax.axvspan(*t.ci95, color=color, alpha=0.08, lw=0, label=f"{cond}: threshold, 95 % CrI")
    if not midpoint:
        ax.axhline(pc, color="0.6", lw=0.5)
    if log:
        _log_axis(ax, "x")
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("resolution (pixels)")
    ax.set_ylabel("recognition rate")
    if legend:
        ax.legend(fontsize="small", frameon=False)
    return ax


def _threshold_bar(ax: Axes, x: float, t: Any, **style: Any) -> None:
    """Draw threshold ``t``'s median at ``x`` with its 95 % interval as an error bar."""
    lo, hi = t.ci95
    ax.errorbar(x, t.median, yerr=[[t.median - lo], [hi - t.median]], **style)


def plot_subject_thresholds(
    subject_fits: dict[str, dict[str, WeibullFit]],
    pooled: dict[str, WeibullFit] | None = None,
    *,
    pc: float = 0.5,
    population_ci: dict[str, dict[str, Any]] | None = None,
    ax: Axes | None = None,
) -> Axes:
    """Plot each subject's threshold per condition and the pooled one with its intervals (log axis).

    The paper's Fig. 9 (Jung et al. 2015). A measured threshold is a point with its 95 % credible
    interval; a censored one an open triangle at the tested limit; an unidentified one a bar
    spanning the tested levels that bracket it (no point). The pooled threshold is a black diamond
    with its 95 % credible interval (these subjects and objects) and, when given, a wider grey bar
    for its population interval. The legend lists only what is drawn.

    Parameters
    ----------
    subject_fits : dict
        Subject -> condition -> fit.
    pooled : dict of str to WeibullFit, optional
        Pooled fits.
    pc : float
        Proportion correct of the thresholds.
    population_ci : dict, optional
        ``AnalysisResult.population_ci``: condition -> ``{"0.5": [low, high]}``.
    ax : matplotlib Axes, optional
        Drawn into when given; a new 6.8 x 3.8 inch figure otherwise.

    Returns
    -------
    matplotlib.axes.Axes
    """
    from matplotlib.lines import Line2D

    ax = _new_ax(ax, (6.8, 3.8))
    subjects = list(subject_fits)
    drawn: dict[str, Any] = {}
    width = max(0.06, min(0.5 / max(len(subjects), 1), 0.12))
    for j, cond in enumerate(CONDITIONS):
        for i, s in enumerate(subjects):
            fit = subject_fits[s].get(cond)
            if fit is None:
                continue
            t = fit.threshold(pc)
            off = (i - (len(subjects) - 1) / 2) * width - 0.15
            color = f"C{i % 10}"
            if t.status in ("censored_below", "censored_above"):
                y, m = (t.lowest, "v") if t.status == "censored_below" else (t.highest, "^")
                ax.plot(j + off, y, m, mfc="none", ms=5, color=color)
                key = "< lowest level tested" if m == "v" else "> highest level tested"
                drawn.setdefault(key, Line2D([], [], marker=m, ls="", mfc="none", color="0.3"))
                drawn.setdefault(f"subject {s}", Line2D([], [], marker="o", ls="", color=color))
            elif t.measured:
                _threshold_bar(ax, j + off, t, fmt="o", ms=4, color=color)
                drawn.setdefault(f"subject {s}", Line2D([], [], marker="o", ls="", color=color))
            else:
                blo, bhi = t.bracket
                blo = blo if np.isfinite(blo) else t.lowest
                bhi = bhi if np.isfinite(bhi) else t.highest
                if np.isfinite(blo) and np.isfinite(bhi):
                    ax.plot([j + off] * 2, [blo, bhi], color=color, lw=3, alpha=0.5)
                    drawn.setdefault(
                        "not identified: between tested levels",
                        Line2D([], [], color="0.3", lw=3, alpha=0.5),
                    )
                    drawn.setdefault(f"subject {s}", Line2D([], [], marker="o", ls="", color=color))
        if pooled and cond in pooled:
            t = pooled[cond].threshold(pc)
            x = j + 0.3
            pop = (population_ci or {}).get(cond, {}).get(f"{pc:g}")
            if t.measured:
                if pop:
                    ax.plot([x, x], pop, color="0.6", lw=6, solid_capstyle="butt", zorder=1)
                    drawn["pooled: population 95 % interval"] = Line2D([], [], color="0.6", lw=6)
                _threshold_bar(ax, x, t, fmt="D", ms=6, color="k", capsize=3, zorder=3)
                drawn["pooled: median, 95 % CrI"] = Line2D([], [], marker="D", ls="", color="k")
            elif t.status in ("censored_below", "censored_above"):
                y, m = (t.lowest, "v") if t.status == "censored_below" else (t.highest, "^")
                ax.plot(x, y, m, ms=7, color="k")
                drawn["pooled: censored"] = Line2D([], [], marker=m, ls="", color="k")
            elif np.isfinite(t.bracket[0]) and np.isfinite(t.bracket[1]):
                ax.plot([x, x], t.bracket, color="k", lw=3, alpha=0.5)
                drawn["pooled: not identified, between tested levels"] = Line2D(
                    [], [], color="k", lw=3, alpha=0.5
                )
    ax.axhline(PROSTHESIS_PX, color="k", ls="--", lw=0.8)
    ax.annotate(
        f"prostheses, {PROSTHESIS_PX:,.0f} px",
        (0.5, PROSTHESIS_PX),
        xycoords=("axes fraction", "data"),
        xytext=(0, 3),
        textcoords="offset points",
        ha="center",
        va="bottom",
        fontsize="x-small",
    )
    _log_axis(ax, "y")
    ax.set_xticks(range(len(CONDITIONS)), CONDITIONS)
    ax.set_xlim(-0.6, len(CONDITIONS) - 0.4)
    ax.set_ylabel(f"pixels for {100 * pc:g} % recognition")
    if drawn:
        ax.legend(
            list(drawn.values()),
            list(drawn),
            fontsize="x-small",
            frameon=False,
            loc="upper left",
            bbox_to_anchor=(1.01, 1.0),
            title="subjects: median, 95 % CrI",
            title_fontsize="x-small",
        )
    return ax


def plot_subject_curves(
    subject_fits: dict[str, dict[str, WeibullFit]], *, pc: float = 0.5, fig: Figure | None = None
) -> Figure:
    """Plot every subject's fitted curves and data in a grid of panels.

    The paper's Fig. S2 (Jung et al. 2015).

    Parameters
    ----------
    subject_fits : dict
        Subject -> condition -> fit.
    pc : float
        Proportion correct of the marked thresholds.
    fig : matplotlib Figure, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    n = max(1, len(subject_fits))
    cols = min(3, n)
    rows = int(np.ceil(n / cols))
    fig = fig or Figure(figsize=(3.3 * cols, 2.8 * rows + 0.5))
    # A fixed layout, in inches (a layout engine would draw the figure twice more to find it):
    # room for the y labels at the left, titles at the top, x labels and the legend below.
    w, h = fig.get_size_inches()
    left, right, top, bottom, gap_w, gap_h = 0.6, 0.1, 0.25, 1.0, 0.15, 0.45
    ax_w = (w - left - right - gap_w * (cols - 1)) / cols
    ax_h = (h - top - bottom - gap_h * (rows - 1)) / rows
    grid = {
        "left": left / w,
        "right": 1 - right / w,
        "top": 1 - top / h,
        "bottom": bottom / h,
        "wspace": gap_w / ax_w,
        "hspace": gap_h / ax_h,
    }
    axes = fig.subplots(rows, cols, squeeze=False, sharex=True, sharey=True, gridspec_kw=grid)
    for ax, (s, fits) in zip(axes.ravel(), subject_fits.items(), strict=False):
        plot_recognition(fits, pc=pc, ax=ax, legend=False)
        ax.set_title(f"subject {s}", fontsize="small", pad=3)
        ax.label_outer()  # axis labels on the outer panels only
    for ax in axes.ravel()[len(subject_fits) :]:
        ax.set_visible(False)
    for ax in axes[-1, len(subject_fits) - (rows - 1) * cols :] if rows > 1 else ():
        ax.xaxis.label.set_visible(True)  # above an empty slot of the last row
        ax.tick_params(labelbottom=True)
    handles, labels = axes.ravel()[0].get_legend_handles_labels()
    if handles:
        fig.legend(
            handles,
            labels,
            loc="lower center",
            bbox_to_anchor=(0.5, 0.0),
            ncols=2,
            fontsize="x-small",
            frameon=False,
        )
    return fig


def plot_object_difficulty(logistic: LogisticFit, *, ax: Axes | None = None) -> Axes:
    """Plot object difficulty: log odds ratio of *not* recognising each object vs object 1.

    The paper's Fig. S3 (Jung et al. 2015; difficulty as the log odds ratio of failure).
    Positive = harder than the reference object. Error bars are 95 % profile-likelihood intervals
    (Wald intervals when the fit has none, said in the title); objects separated in the data
    (no finite ML estimate) are circled and named in the legend.

    Parameters
    ----------
    logistic : LogisticFit
    ax : matplotlib Axes, optional
        Drawn into when given; otherwise a new figure, taller for long object names.

    Returns
    -------
    matplotlib.axes.Axes
    """
    rows = [r for r in logistic.odds_ratios.rows if r[0].startswith("object:")]
    names = [logistic.reference_object] + [r[0].split(":", 1)[1] for r in rows]
    # Rotated object names take height from the axes; grow the figure with the longest, so the
    # y-label (centred on the axes) keeps inside it.
    ax = _new_ax(ax, (7.0, max(4.2, 3.4 + 0.075 * max(len(n) for n in names))))
    prof = logistic.profile_ci95
    use_profile = bool(rows) and all(r[0] in prof for r in rows)
    ci = [prof[r[0]] if use_profile else (r[2], r[3]) for r in rows]
    # Failure odds ratio = 1 / recognition odds ratio, so its log10 is the negated log10.
    with np.errstate(divide="ignore"):
        val = [0.0] + [-np.log10(r[1]) for r in rows]
        lo = [0.0] + [-np.log10(c[1]) for c in ci]
        hi = [0.0] + [-np.log10(c[0]) for c in ci]
    x = np.arange(len(names))
    ax.errorbar(
        x,
        val,
        yerr=[np.subtract(val, lo), np.subtract(hi, val)],
        fmt="s",
        ms=4,
        color="k",
    )
    for xi, r in zip(x[1:], rows, strict=False):
        mark = "**" if r[4] < 0.01 else "*" if r[4] < 0.05 else ""
        if mark:
            ax.annotate(mark, (xi, hi[xi]), ha="center", va="bottom", fontsize="small")
    sep = [i + 1 for i, r in enumerate(rows) if r[0] in logistic.separated]
    if sep:  # no finite ML estimate: the point is Firth's, and is marked as such
        ax.plot(
            x[sep],
            np.asarray(val)[sep],
            "o",
            mfc="none",
            mec="C3",
            ms=10,
            label="separated in these data (ML infinite): Firth's estimate",
        )
        ax.legend(fontsize="x-small", frameon=False)
    ax.axhline(0, color="0.6", lw=0.5)
    ax.set_xticks(x, names, fontsize="small", rotation=55, ha="right", rotation_mode="anchor")
    ax.set_xlabel(f"object (reference: object {logistic.reference_object})")
    ax.set_ylabel("difficulty (log10 odds\nratio of not recognising)")
    ax.set_title(
        "above 0: harder than the reference object; below 0: easier "
        f"(95 % {'profile-likelihood' if use_profile else 'Wald'} CI; "
        "* p < 0.05, ** p < 0.01)",
        fontsize="x-small",
    )
    return ax


def _draw(result: Any, name: str) -> Figure:
    fig = _draw_figure(result, name)
    if getattr(result, "simulated_sessions", ()):
        mark_simulated(fig)
    return fig


def _draw_figure(result: Any, name: str) -> Figure:
    pc = result.options.pc
    if name == "fig8_recognition_vs_pixels":
        return plot_recognition(result.thresholds, pc=pc).figure
    if name == "fig9_subject_thresholds":
        return plot_subject_thresholds(
            result.subject_thresholds,
            result.thresholds,
            pc=pc,
            population_ci=getattr(result, "population_ci", None),
        ).figure
    if name == "figS2_subject_curves":
        return plot_subject_curves(result.subject_thresholds, pc=pc)
    ax = plot_object_difficulty(result.logistic)
    if not any(r[0].startswith("object:") for r in result.logistic.odds_ratios.rows):
        ax.text(
            0.5,
            0.5,
            "object effects not estimated (see report)",
            ha="center",
            transform=ax.transAxes,
            fontsize="small",
        )
    return ax.figure


def _draw_and_save(
    result: Any, names: list[str], folder: Path, formats: tuple[str, ...]
) -> list[Path]:
    return save_figures({n: _draw(result, n) for n in names}, folder, formats)


#: Figures of :func:`save_all`, after the paper's figure numbers.
STUDY_FIGURES: tuple[str, ...] = (
    "figS2_subject_curves",
    "fig8_recognition_vs_pixels",
    "fig9_subject_thresholds",
    "figS3_object_difficulty",
)


def save_all(
    result: Any,
    folder: str | Path,
    *,
    processes: int = 2,
    formats: tuple[str, ...] = DEFAULT_FIGURE_FORMATS,
) -> list[Path]:
    """Draw Figs. 8, 9, S2 and S3 for an analysis result; save each in ``formats``.

    Parameters
    ----------
    result : analysis.pipeline.AnalysisResult
    folder : str or Path
        Existing folder.
    processes : int
        1: draw in this process. 2 or more: the figure with per-subject panels (as long to draw
        as the other three together) is drawn in a forked worker process while this one draws
        the others, which halves the time on two cores; a second worker would cost more CPU
        time (a forked process pays again for what this one has loaded) and save none.
    formats : tuple of str
        File formats (:func:`save_figures`): PNG and PDF unless asked otherwise.

    Returns
    -------
    list of Path
        Files written.
    """
    folder = Path(folder)
    names = list(STUDY_FIGURES)
    if processes > 1:
        import multiprocessing as mp
        import os
        from concurrent.futures import ProcessPoolExecutor

        from analysis.workers import stop_pool, worker_init

        load_backends(formats)  # before the fork: loaded once, for both processes
        try:
            pool = ProcessPoolExecutor(
                max_workers=1,
                mp_context=mp.get_context("fork"),
                initializer=worker_init,
                initargs=(os.getpid(),),
            )
        except ValueError:  # no fork here
            pool = None
        if pool is not None:
            with pool:
                try:
                    job = pool.submit(_draw_and_save, result, names[:1], folder, formats)
                except (OSError, RuntimeError):  # no process could be started: draw here
                    job = None
                if job is not None:
                    try:
                        mine = _draw_and_save(result, names[1:], folder, formats)
                        return [*job.result(), *mine]
                    except BaseException:  # stopped or failed: no figure is kept; wait for none
                        stop_pool(pool)
                        raise
    return _draw_and_save(result, names, folder, formats)


#: File stem of the active-search figure (:func:`save_time_to_recognition`).
ACTIVE_FIGURE: str = "active_time_to_recognition"


def _condition_color(condition: str, i: int) -> str:
    return COLORS.get(condition, f"C{(i + 2) % 10}")


def plot_time_to_recognition(survival: Any, *, simulated: bool = False) -> Figure:
    """Draw censored time to recognition: Kaplan-Meier curves and a per-subject panel.

    Left: per condition, the share of trials not yet recognised against time, with its
    pointwise 95 % band, censor marks (passes and time-outs, at the time the trial ended) and
    the median; the hazard ratio in the title. Right: per subject and condition, each trial's
    end time (filled: recognised; open: censored) and the subject's Kaplan-Meier median (bar).

    Parameters
    ----------
    survival : analysis.survival.SurvivalAnalysis
    simulated : bool
        Write "SIMULATED" across the figure (the searcher was simulated, not a person).

    Returns
    -------
    Figure
    """
    fig = Figure(figsize=(7.2, 3.6), layout="constrained")
    ax, axs = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.25, 1.0]})
    t_max = 0.0
    for i, (cond, km) in enumerate(survival.conditions.items()):
        col = _condition_color(cond, i)
        t = np.concatenate([[0.0], km.time_s, [km.longest_s]])
        s = np.concatenate([[1.0], km.survival, [km.survival[-1] if km.survival else 1.0]])
        lo = np.concatenate([[1.0], km.survival_ci95_low, [s[-1]]])
        hi = np.concatenate([[1.0], km.survival_ci95_high, [s[-1]]])
        if km.survival:
            lo[-1], hi[-1] = km.survival_ci95_low[-1], km.survival_ci95_high[-1]
        med = "not reached" if km.median_s is None else f"{km.median_s:.1f} s"
        ax.step(
            t, s, where="post", color=col, lw=1.6, label=f"{cond} (n={km.n_trials}, median {med})"
        )
        ax.fill_between(t, lo, hi, step="post", color=col, alpha=0.18, lw=0)
        if km.censored_s:
            cs = np.asarray(km.censored_s)
            ax.plot(cs, km.survival_at(cs), "|", color=col, ms=9, mew=1.4)
        t_max = max(t_max, km.longest_s)
    ax.axhline(0.5, color="0.6", lw=0.8, ls=":")
    ax.plot([], [], "|", color="0.3", ms=9, mew=1.4, label="censored (pass / time-out)")
    ax.set_xlim(0, t_max * 1.03 if t_max > 0 else 1.0)
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("time since cue onset (s)")
    ax.set_ylabel("not yet recognised (Kaplan-Meier)")
    ax.legend(fontsize="x-small", frameon=False, loc="upper right")
    comp = survival.comparison
    if comp is not None:
        if comp.hazard_ratio is not None:
            p = "p < 0.001" if comp.p < 0.001 else f"p = {comp.p:.3f}"
            txt = (
                f"HR {comp.condition} / {comp.reference} = {comp.hazard_ratio:.2f} "
                f"[{comp.ci95[0]:.2f}, {comp.ci95[1]:.2f}], {p}"
            )
        else:
            txt = "hazard ratio not estimable"
        ax.set_title(txt, fontsize="small")
    subjects = list(survival.subjects)
    conds = list(survival.conditions)
    step = 0.6 / max(len(conds), 1)
    for i, cond in enumerate(conds):
        col = _condition_color(cond, i)
        for j, subj in enumerate(subjects):
            km = survival.subjects[subj].get(cond)
            if km is None:
                continue
            y = j + (i - (len(conds) - 1) / 2) * step
            ax_kw = {"color": col, "ms": 5, "ls": "none"}
            axs.plot(km.time_s, [y] * len(km.time_s), "o", **ax_kw)
            axs.plot(km.censored_s, [y] * len(km.censored_s), "o", mfc="white", **ax_kw)
            if km.median_s is not None:
                axs.plot([km.median_s] * 2, [y - step / 2, y + step / 2], color=col, lw=2)
    axs.plot([], [], "o", color="0.3", ms=5, ls="none", label="recognised")
    axs.plot([], [], "o", color="0.3", mfc="white", ms=5, ls="none", label="censored")
    axs.plot([], [], "-", color="0.3", lw=2, label="subject's KM median")
    axs.set_yticks(range(len(subjects)), subjects)
    axs.set_ylim(-0.6, len(subjects) - 0.4)
    axs.invert_yaxis()
    axs.set_xlim(0, t_max * 1.03 if t_max > 0 else 1.0)
    axs.set_xlabel("time the trial ended (s)")
    axs.set_title("per subject", fontsize="small")
    axs.legend(fontsize="x-small", frameon=False, loc="lower right")
    if simulated:
        mark_simulated(fig)
        fig.suptitle("SIMULATED searcher, not a person", color="tab:red", fontsize="small")
    return fig


def save_time_to_recognition(
    survival: Any,
    folder: str | Path,
    *,
    simulated: bool = False,
    formats: tuple[str, ...] = DEFAULT_FIGURE_FORMATS,
) -> list[Path]:
    """Draw :func:`plot_time_to_recognition` and save it in ``formats`` (:func:`save_figures`).

    Parameters
    ----------
    survival : analysis.survival.SurvivalAnalysis
    folder : str or Path
        Existing folder; the files are ``active_time_to_recognition.{png,pdf}`` (and ``.svg``).
    simulated : bool
        Mark the figure "SIMULATED".
    formats : tuple of str
        File formats: PNG and PDF unless asked otherwise.

    Returns
    -------
    list of Path
        Files written.
    """
    fig = plot_time_to_recognition(survival, simulated=simulated)
    return save_figures({ACTIVE_FIGURE: fig}, folder, formats)
