"""The ``confocal analyze`` command group: analyse trial files, and plan studies by power.

``confocal analyze TRIALS... --out REPORT_DIR`` runs the default ``run`` command (the group
inserts ``run`` when the first word is not a sub-command), and ``confocal analyze power ...``
estimates how many subjects a study needs.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import math
import warnings
from collections.abc import Iterator
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer
from typer.core import TyperGroup

from analysis.errors import DataError
from analysis.figure_formats import FORMATS_HELP, parse_figure_formats
from analysis.power_report import needed_text as _needed

__all__ = ["register", "analyze_app"]

logger = logging.getLogger(__name__)

#: Memory per simulated trial in ``power``, bytes (ours, rounded up: the trial table and the
#: logistic model's design matrix); checked before simulating so a huge --subjects is refused.
_POWER_BYTES_PER_TRIAL = 2048
#: Largest seed a command accepts (ours; as ``stimuli.resources.MAX_SEED``, which analysis does
#: not import): SQLite's INTEGER and NumPy's int64 hold it.
_MAX_SEED = 2**63 - 1

#: Most local worker processes (ours): far above any machine's cores; each costs memory.
_MAX_PROCESSES = 1024

#: Trials per simulated subject in the paper's design (20 objects x 8 levels x 2 conditions).
_TRIALS_PER_SUBJECT = 320


def _finite(lo: float | None = None, hi: float | None = None, *, open_lo=False, open_hi=False):
    """Return a typer callback refusing NaN, infinities and values outside the range."""
    interval = (
        ("(" if open_lo or lo is None else "[")
        + ("-inf" if lo is None else f"{lo:g}")
        + ", "
        + ("inf" if hi is None else f"{hi:g}")
        + (")" if open_hi or hi is None else "]")
    )

    def callback(param: typer.CallbackParam, value):
        if value is None:
            return value
        v = float(value)
        bad = not math.isfinite(v)
        bad = bad or (lo is not None and (v <= lo if open_lo else v < lo))
        bad = bad or (hi is not None and (v >= hi if open_hi else v > hi))
        if bad:
            raise typer.BadParameter(
                f"{param.name} must be in {interval}, a finite number; got {value!r}"
            )
        return value

    return callback


#: Options that mean the same in every sub-command, declared once.
_Out = Annotated[Path, typer.Option("--out", "-o", help="Report folder (replaced atomically).")]
_Guess = Annotated[
    float,
    typer.Option(
        "--guess", callback=_finite(0.0, 1.0, open_hi=True), help="Guess rate (0.5 for 2AFC)."
    ),
]


def _seed_option(what: str):
    """Return the ``--seed`` option of a command whose random draws are ``what``."""
    return typer.Option("--seed", min=0, max=_MAX_SEED, help=f"Seed of the {what}.")


def _list_option(name: str, what: str):
    """Return an option holding comma-separated ``what``."""
    return typer.Option(name, help=f"Comma-separated {what}")


def _switch_option(name: str, text: str):
    """Return the on/off option ``--NAME/--no-NAME``, whose help is ``text``."""
    return typer.Option(f"--{name}/--no-{name}", help=text)


def _active_option(name: str, what: str):
    """Return an option of ``power`` that only active-search studies use, saying ``what`` it is."""
    return typer.Option(name, help=f"Active search: {what}")


@contextlib.contextmanager
def _refused_as(error: type[Exception], message: str | None = None) -> Iterator[None]:
    """Raise ``error(message)`` for a ``ValueError`` in the block: a bad option value.

    Without ``message`` the ``ValueError``'s own message is kept (a spec's checks name the option).
    """
    try:
        yield
    except ValueError as exc:
        raise error(str(exc) if message is None else message) from exc


def _disk_full(exc: OSError, out: Path) -> DataError:
    return DataError(
        f"--out {out}: the disk is full ({exc.strerror or exc}) while writing the report; the "
        "partial report was removed and any earlier report left as it was"
    )


class _DefaultRunGroup(TyperGroup):
    """A group whose first argument, when not a sub-command, is a trial file for ``run``."""

    default_command = "run"

    def parse_args(self, ctx, args: list[str]) -> list[str]:  # ctx: typer's click Context
        if args and args[0] not in self.commands and args[0] not in ctx.help_option_names:
            args = [self.default_command, *args]
        return super().parse_args(ctx, args)


analyze_app = typer.Typer(
    cls=_DefaultRunGroup,
    name="analyze",
    no_args_is_help=True,
    add_completion=False,
    help=(
        "Analyse trial logs (Jung et al. 2015, Sec. 3.2.2) or plan a study.\n\n"
        "  confocal analyze TRIALS... --out REPORT_DIR [--pc 0.5] [--by subject] [--guess 0] "
        "[--seed N] [--mixed]\n\n"
        "  (same as 'confocal analyze run TRIALS...'): Weibull posteriors and thresholds, "
        "logistic odds ratios, figures, results.json and report.md.\n\n"
        "  confocal analyze fit TABLE --x COL (--y COL | --k COL --n COL | --p COL --n COL) "
        "[--group COLS] [--sigmoid weibull|loglogistic|lognormal|logistic|normal|gumbel] "
        "[--axis log|linear] [--guess 0.5] [--pc 0.5,0.75] --out DIR: psychometric functions "
        "for any table.\n\n"
        "  confocal analyze power --odds-ratio 2,5.6 | --threshold-ratio 2.5 [--subjects 1,2,4,6] "
        "[--objects 10,20] [--levels 4,8] [--processes N | --cluster ADDRESS]: power by "
        "simulation, in parallel.\n\n"
        "  confocal analyze power --active --hazard-ratio 2,3 [--subjects 4,8] [--scenes 2,4] "
        "[--targets 3] [--time-limit 60] [--median-time 20] [--weibull-shape 1] [--frailty-sd "
        "0.5]: power of an active-search study (censored times, Cox model by subject)."
    ),
)


class By(StrEnum):
    """How to split the per-group psychometric fits."""

    subject = "subject"
    none = "none"


@analyze_app.command("run")
def run(
    trials: Annotated[
        list[Path],
        typer.Argument(
            help="Trial files: SQLite session databases, CSV or Parquet tables; pooled.",
            show_default=False,
        ),
    ],
    out: _Out,
    pc: Annotated[
        float,
        typer.Option(
            "--pc",
            callback=_finite(0.0, 1.0, open_lo=True, open_hi=True),
            help="Proportion correct of the threshold, in (0, 1).",
        ),
    ] = 0.5,
    by: Annotated[
        By, typer.Option("--by", help="Also fit each subject ('none': pooled only).")
    ] = By.subject,
    guess: _Guess = 0.0,
    seed: Annotated[int | None, _seed_option("MCMC runs")] = None,
    mixed: Annotated[
        bool, typer.Option("--mixed", help="Also fit the mixed logistic model.")
    ] = False,
    subject_factor: Annotated[
        bool, typer.Option("--subject-factor", help="Add subject dummies to the logistic model.")
    ] = False,
    figures: Annotated[bool, _switch_option("figures", "Draw Figs. 8, 9, S2, S3.")] = True,
    figure_formats: Annotated[str, typer.Option("--figure-formats", help=FORMATS_HELP)] = "png,pdf",
    lapse_prior: Annotated[
        str, typer.Option("--lapse-prior", help="Beta(a,b) prior of the lapse rate, as 'a,b'.")
    ] = "1,10",
    overdispersion: Annotated[
        bool,
        _switch_option(
            "overdispersion",
            "Beta-binomial pooled fits (free scale, as psignifit 4); off by default, as its "
            "credible interval over-covers in simulation "
            "(benchmarks/validate_weibull_coverage.py).",
        ),
    ] = False,
    include_simulated: Annotated[
        bool,
        typer.Option(
            "--include-simulated",
            help="Pool simulated observers' sessions with human ones (refused otherwise).",
        ),
    ] = False,
    reference: Annotated[
        str,
        typer.Option(
            "--reference",
            help="Data with conditions beyond cluttered/decluttered (a comparison of de-clutter "
            "methods): the logistic model's reference condition.",
        ),
    ] = "cluttered",
) -> None:
    """Analyse TRIALS and write REPORT_DIR (results.json, report.md, figures)."""
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from analysis.data import read_trials
    from analysis.pipeline import AnalysisOptions, analyze
    from analysis.report import write_report

    with _refused_as(typer.BadParameter, f"--lapse-prior must be 'a,b', got {lapse_prior!r}"):
        lp = tuple(float(v) for v in lapse_prior.split(","))
    with _refused_as(typer.BadParameter):
        formats = parse_figure_formats(figure_formats)
        options = AnalysisOptions(
            lapse_prior=lp,
            pc=pc,
            by_subject=by == By.subject,
            guess=guess,
            seed=seed,
            subject_factor=subject_factor,
            mixed=mixed,
            overdispersion=overdispersion,
        )
    from analysis.active import add_active_results, only_active, summary_lines, write_active_report

    if only_active(trials):  # active-search logs only: no static trials to fit
        res = write_active_report(trials, out, figures=figures, figure_formats=formats)
        typer.echo("\n".join([*summary_lines(res), f"report: {Path(out) / 'report.md'}"]))
        return
    if out.exists() and not out.is_dir():
        raise DataError(f"--out {out} exists and is a file; expected a report folder")
    table = read_trials(trials, include_simulated=include_simulated)
    err = Console(stderr=True)
    result = None
    with (
        Progress(
            TextColumn("[progress.description]{task.description}"),
            BarColumn(),
            TextColumn("{task.completed}/{task.total}"),
            TimeElapsedColumn(),
            console=err,
            transient=True,
        ) as bar,
        warnings.catch_warnings(),
    ):
        warnings.simplefilter("ignore")  # collected into the report instead
        task = bar.add_task("fitting", total=None)
        for step in analyze(table, options, reference=reference):
            bar.update(task, total=step.total, completed=step.done, description=step.label)
            result = step.result or result
    assert result is not None
    if figures:
        err.print("drawing figures and writing the report...")
    try:
        folder = write_report(result, out, figures=figures, figure_formats=formats)
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            raise _disk_full(exc, out) from None
        raise
    active = add_active_results(trials, folder, figures=figures, figure_formats=formats)
    _print_summary(result, folder)
    if active is not None:
        typer.echo("\n".join(summary_lines(active)))


def _ci_text(ci: list) -> str:
    """Format an odds-ratio interval as console text: ``95% CI 3.9-8.1``, open ends as 0 / inf."""
    if ci[0] is None and ci[1] is None:
        return "no interval: its profile could not be computed"
    lo = "0" if ci[0] is None else f"{ci[0]:.3g}"
    hi = "inf" if ci[1] is None else f"{ci[1]:.3g}"
    return f"95% CI {lo}-{hi}"


def _print_summary(result, folder: Path) -> None:
    from analysis.report import (
        QUESTION_FITTED,
        QUESTION_ODDS_RATIO,
        QUESTION_POPULATION,
        p_text,
        pooled_curve_text,
        threshold_text,
    )

    if getattr(result, "kind", "") == "conditions":  # a comparison of k conditions
        from analysis.conditions_report import print_conditions_summary

        print_conditions_summary(result, folder, typer.echo)
        return
    r = result.results_json()
    typer.echo(f"{r['n_trials']} trials, {r['n_recognized']} recognised")
    typer.echo(_model_line(r["overdispersion"]))
    if r.get("simulated_sessions"):
        typer.echo(f"SIMULATED (no person answered): {'; '.join(r['simulated_sessions'])}")
    if r["n_training_excluded"]:
        typer.echo(f"({r['n_training_excluded']} training trials excluded)")
    for c, t in r["thresholds"].items():
        conv = "" if t["converged"] else "  NOT CONVERGED"
        pop = t.get("population_ci95", {}).get("0.5")
        pop = (
            f"; 95% interval {pop[0]:,.0f}-{pop[1]:,.0f} px for {QUESTION_POPULATION}"
            if pop
            else ""
        )
        t50 = threshold_text(t["threshold_50"], question=QUESTION_FITTED)
        measured = t["threshold_50"]["status"] == "measured"
        pcv = f"; pooled curve {pooled_curve_text(t.get('pooled_curve'))}" if measured else ""
        typer.echo(f"50% threshold {c:>11}: {t50}{pcv if t.get('pooled_curve') else ''}{pop}{conv}")
        if "threshold_pc" in t:
            typer.echo(f"{100 * r['pc']:g}% threshold {c:>11}: {threshold_text(t['threshold_pc'])}")
    lo = r["logistic"]
    if lo["method"] == "none":
        typer.echo("logistic model: not estimable (" + "; ".join(lo["warnings"]) + ")")
    for term in ("background", "log10_pixels"):
        o, iv = lo["odds_ratios"].get(term), lo.get("intervals", {}).get(term)
        if o is None or iv is None:
            continue
        sep = "; separated in these data, ML infinite" if term in lo["separated"] else ""
        typer.echo(
            f"odds ratio {term:>12}: {iv['or']:.3g} ({_ci_text(iv['ci95'])}, "
            f"Wald {p_text(o['p'])}; {iv['estimator']}; for {QUESTION_ODDS_RATIO}{sep})"
        )
    cl = lo["classification"]
    if lo["method"] != "none":
        typer.echo(
            f"classified correctly: {cl['recognized_correct_pct']:.1f}% recognised, "
            f"{cl['not_recognized_correct_pct']:.1f}% not recognised"
        )
    for w in r["warnings"]:
        typer.echo(f"warning: {w}", err=True)
    typer.echo(f"report: {folder / 'report.md'}  (results: {folder / 'results.json'})")


@analyze_app.command("fit")
def fit(
    table: Annotated[
        Path, typer.Argument(help="CSV table, per trial or aggregated.", show_default=False)
    ],
    x: Annotated[str, typer.Option("--x", help="Stimulus-level column (name or 1-based number).")],
    out: _Out,
    y: Annotated[
        str | None, typer.Option("--y", help="Per-trial outcome column (1 correct, 0 not).")
    ] = None,
    k: Annotated[str | None, typer.Option("--k", help="Number-correct column.")] = None,
    n: Annotated[str | None, typer.Option("--n", help="Number-of-trials column.")] = None,
    p: Annotated[
        str | None, typer.Option("--p", help="Proportion-correct column (0-1 or percent).")
    ] = None,
    group: Annotated[str, _list_option("--group", "columns to fit separately.")] = "",
    sigmoid: Annotated[
        str,
        typer.Option(
            "--sigmoid",
            help="auto, weibull, loglogistic, lognormal, logistic, normal or gumbel.",
        ),
    ] = "auto",
    axis: Annotated[
        str, typer.Option("--axis", help="auto (the sigmoid's own), log or linear.")
    ] = "auto",
    guess: _Guess = 0.0,
    pc: Annotated[
        str,
        _list_option(
            "--pc",
            "proportions correct of the thresholds (default: the midpoint between the guess "
            "rate and 1 - lapse, as psignifit).",
        ),
    ] = "",
    overdispersion: Annotated[
        bool,
        _switch_option(
            "overdispersion", "Beta-binomial posteriors (default binomial, as 'analyze run')."
        ),
    ] = False,
    plots: Annotated[
        bool, _switch_option("plots", "One plot per group and one of all groups.")
    ] = True,
    seed: Annotated[int | None, _seed_option("sampler")] = None,
) -> None:
    """Fit psychometric functions to any table: thresholds, intervals, goodness of fit, plots."""
    from rich.console import Console
    from rich.progress import Progress

    from analysis.errors import OptionError
    from analysis.psychometric import (
        FitSpec,
        iter_fit_table,
        read_table,
        threshold_name,
        write_fit_report,
    )

    with _refused_as(OptionError, f"--pc must be numbers like 0.5,0.75, got {pc!r}"):
        pcs = tuple(float(v) for v in pc.split(",") if v.strip())
    with _refused_as(OptionError):
        spec = FitSpec(
            x=x,
            y=y,
            k=k,
            n=n,
            p=p,
            group=tuple(g.strip() for g in group.split(",") if g.strip()),
            sigmoid=sigmoid,
            axis=axis,
            guess=guess,
            pcs=pcs,
            overdispersion=overdispersion,
            seed=seed,
        )
    df = read_table(table)
    result = None
    with (
        Progress(console=Console(stderr=True), transient=True) as bar,
        warnings.catch_warnings(),
    ):
        warnings.simplefilter("ignore")
        task = bar.add_task("fitting", total=None)
        for done, total, r in iter_fit_table(df, spec, str(table)):
            bar.update(task, completed=done, total=total)
            result = r or result
    folder = write_fit_report(result, out, plots=plots)
    r = result.results_json()
    typer.echo(f"{len(r['groups'])} group(s), sigmoid {r['sigmoid']} ({r['axis']} axis)")
    typer.echo(_model_line(r["overdispersion"]))
    typer.echo(f"thresholds at the {r['threshold_rule']}")
    for g in r["groups"]:
        for t in g["thresholds"]:
            typer.echo(f"{g['label']}: {threshold_name(t)} {_threshold_line(t)}")
    for w in r["warnings"]:
        typer.echo(f"warning: {w}", err=True)
    typer.echo(f"report: {folder / 'report.md'}  (results: {folder / 'results.json'})")


def _model_line(overdispersion: bool) -> str:
    """Say the psychometric fits' likelihood and the switch that changes it."""
    if overdispersion:
        return "model: beta-binomial (--overdispersion; --no-overdispersion for binomial)"
    return "model: binomial (the default; --overdispersion for beta-binomial)"


def _threshold_line(t: dict) -> str:
    from analysis.psychometric import threshold_md

    return threshold_md(t)


class Effect(StrEnum):
    """Effect kinds for the power analysis."""

    odds_ratio = "odds_ratio"
    threshold_ratio = "threshold_ratio"


def _numbers(text: str, option: str, kind: type = float) -> list:
    from analysis.errors import OptionError

    what = "integers like 1,2,4" if kind is int else "numbers like 2,3.5"
    with _refused_as(OptionError, f"{option} must be {what}, got {text!r}"):
        vals = [kind(v) for v in text.split(",") if v.strip()]
    if not vals:
        raise OptionError(f"{option} needs at least one value, got {text!r}")
    return vals


def _check_power_and_alpha(target: float, alpha: float) -> None:
    """Refuse a ``--power`` or ``--alpha`` outside (0, 1)."""
    from analysis.errors import OptionError

    if not (0.0 < target < 1.0):
        raise OptionError(f"--power must be in (0, 1), got {target!r}")
    if not (0.0 < alpha < 1.0):
        raise OptionError(f"--alpha must be in (0, 1), got {alpha!r}")


def _run_with_progress(gen, label: str, total: int) -> list:
    """Drain a power grid under a progress bar; return its points. Closes it (and its pool) too."""
    import contextlib

    from rich.console import Console
    from rich.progress import Progress

    points = []
    with contextlib.closing(gen), Progress(console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(label, total=total)
        for item in gen:
            if isinstance(item, int):
                bar.update(task, completed=item)
            else:
                points.append(item)
    return points


def _echo_power_table(design_heads: str, points: list, design_cells) -> None:
    """Print one row per grid point.

    Its design (``design_cells(point)``, under ``design_heads``), then its power and the power's 95%
    interval.
    """
    typer.echo(f"{design_heads}  power  (95% CI)")
    for p in points:
        typer.echo(f"{design_cells(p)}  {p.power:.2f}   ({p.ci95[0]:.2f}-{p.ci95[1]:.2f})")


def _write_power_out(out, kind: str, points, target: float, settings: dict) -> None:
    """Write ``--out``: the power-curve figure and the table (CSV, JSON); print where."""
    from analysis.power_report import POWER_FIGURE, save_power_table

    folder = save_power_table(out, kind, points, target, settings)
    typer.echo(f"power curve: {folder / (POWER_FIGURE + '.png')}  (table: {folder / 'power.csv'})")


def _resolved_seed(seed: int | None) -> tuple[int, str]:
    """Return the seed to simulate with and how it is printed.

    A drawn seed is printed too, so that ``--seed`` reproduces the table.
    """
    import numpy as np

    if seed is not None:
        return seed, f"seed {seed}"
    drawn = int(np.random.SeedSequence().entropy % _MAX_SEED)
    return drawn, f"seed {drawn} (drawn; --seed {drawn} reproduces this table)"


@analyze_app.command("power")
def power(
    odds_ratio: Annotated[
        str | None,
        typer.Option("--odds-ratio", help="Background odds ratio(s) to detect (paper: 5.6)."),
    ] = None,
    threshold_ratio: Annotated[
        str | None,
        typer.Option(
            "--threshold-ratio", help="Cluttered / de-cluttered 50% threshold ratio(s) to detect."
        ),
    ] = None,
    subjects: Annotated[
        str, _list_option("--subjects", "numbers of subjects to simulate.")
    ] = "1,2,3,4,6,8",
    objects: Annotated[str, _list_option("--objects", "numbers of objects (paper: 20).")] = "20",
    levels: Annotated[str, _list_option("--levels", "numbers of resolution levels (8).")] = "8",
    target: Annotated[float, typer.Option("--power", help="Power wanted, in (0, 1).")] = 0.8,
    sims: Annotated[int, typer.Option("--sims", help="Simulated studies per grid point.")] = 200,
    alpha: Annotated[float, typer.Option("--alpha", help="Test level.")] = 0.05,
    seed: Annotated[int | None, _seed_option("simulations")] = None,
    processes: Annotated[
        int | None,
        typer.Option(
            "--processes",
            min=1,
            max=_MAX_PROCESSES,
            help="Local worker processes (default: CPUs).",
        ),
    ] = None,
    cluster: Annotated[
        str | None,
        typer.Option("--cluster", help="Dask scheduler address (needs the 'dask' extra)."),
    ] = None,
    active: Annotated[
        bool, typer.Option("--active", help="Plan an active-search study (needs --hazard-ratio).")
    ] = False,
    hazard_ratio: Annotated[
        str | None, _active_option("--hazard-ratio", "hazard ratio(s) of recognition.")
    ] = None,
    scenes: Annotated[str | None, _active_option("--scenes", "numbers of scenes (2).")] = None,
    targets: Annotated[int | None, _active_option("--targets", "targets per scene (3).")] = None,
    time_limit: Annotated[
        float | None, _active_option("--time-limit", "trial limit, s (60).")
    ] = None,
    median_time: Annotated[
        float | None, _active_option("--median-time", "cluttered median time, s (20).")
    ] = None,
    weibull_shape: Annotated[
        float | None, _active_option("--weibull-shape", "Weibull shape (1: exponential).")
    ] = None,
    frailty_sd: Annotated[
        float | None, _active_option("--frailty-sd", "subject log-hazard SD (0.5).")
    ] = None,
    conditions: Annotated[
        int,
        typer.Option(
            "--conditions",
            min=2,
            max=12,
            help="Conditions of a method comparison: above 2, power to tell the reference from "
            "one method among this many, Holm-corrected over every pair (first --objects).",
        ),
    ] = 2,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            "-o",
            help="Folder for the power-curve figure (PNG, SVG) and the table (CSV, JSON).",
        ),
    ] = None,
) -> None:
    """Estimate power over effect sizes, subjects, objects and levels (simulated studies).

    With --hazard-ratio (and --active), simulate active-search studies instead: censored times
    to recognition, tested by a Cox model stratified by subject.
    """
    active_opts = {
        "--scenes": scenes,
        "--targets": targets,
        "--time-limit": time_limit,
        "--median-time": median_time,
        "--weibull-shape": weibull_shape,
        "--frailty-sd": frailty_sd,
    }
    from analysis.errors import OptionError as _OptionError

    if active or hazard_ratio is not None:
        if odds_ratio is not None or threshold_ratio is not None:
            raise _OptionError(
                "--hazard-ratio (active search) excludes --odds-ratio and --threshold-ratio"
            )
        _active_power(
            hazard_ratio, subjects, active_opts, sims, alpha, target, seed, processes, cluster, out
        )
        return
    given = [k for k, v in active_opts.items() if v is not None]
    if given:
        raise _OptionError(f"{given[0]} is for active-search power; add --hazard-ratio")
    import math

    import psutil

    from analysis.errors import OptionError
    from analysis.power import MAX_SIMS, GridPoint, power_grid

    if (odds_ratio is None) == (threshold_ratio is None):
        raise OptionError("give exactly one of --odds-ratio and --threshold-ratio")
    effect = "odds_ratio" if odds_ratio is not None else "threshold_ratio"
    option = "--odds-ratio" if odds_ratio is not None else "--threshold-ratio"
    sizes = _numbers(odds_ratio if odds_ratio is not None else threshold_ratio, option)
    if not all(math.isfinite(v) and v > 0 for v in sizes):
        raise OptionError(f"{option} must be in (0, inf), a finite number; got {sizes!r}")
    _check_power_and_alpha(target, alpha)
    if not 1 <= sims <= MAX_SIMS:
        raise OptionError(f"--sims must be an integer in [1, {MAX_SIMS}], got {sims!r}")
    if conditions > 2:  # a comparison of methods
        from analysis.conditions_power import echo_method_power

        ns = sorted(set(_numbers(subjects, "--subjects", int)))
        n_obj = _numbers(objects, "--objects", int)[0]
        if min(ns) < 1 or n_obj < 2:
            raise OptionError(f"--subjects must be >= 1 and --objects >= 2, got {ns}, {n_obj}")
        seed, seed_text = _resolved_seed(seed)
        args = (effect, sizes, ns, conditions, n_obj, sims, alpha, seed, target)
        pts = echo_method_power(*args, run=_run_with_progress, echo=typer.echo, seed_text=seed_text)
        if out is not None:
            settings = {"effect": effect, "sizes": sizes, "n_conditions": conditions}
            settings |= {"n_objects": n_obj, "alpha": alpha, "n_sims": sims, "seed": seed}
            _write_power_out(out, "methods", pts, target, settings)
        return
    ns = sorted(set(_numbers(subjects, "--subjects", int)))
    nos = sorted(set(_numbers(objects, "--objects", int)))
    nls = sorted(set(_numbers(levels, "--levels", int)))
    for opt, vals, low in (("--subjects", ns, 1), ("--objects", nos, 1), ("--levels", nls, 2)):
        if min(vals) < low:
            raise OptionError(f"{opt} must be integers >= {low}, got {vals!r}")
    need = ns[-1] * nos[-1] * nls[-1] * 2 * _POWER_BYTES_PER_TRIAL
    avail = psutil.virtual_memory().available
    if need > avail:
        raise OptionError(
            f"--subjects {ns[-1]} (with {nos[-1]} objects, {nls[-1]} levels) needs about "
            f"{need / 2**30:.1f} GiB of memory per simulation but only {avail / 2**30:.1f} GiB is "
            "available; simulate fewer subjects"
        )
    total = len(sizes) * len(ns) * len(nos) * len(nls) * sims
    seed, seed_text = _resolved_seed(seed)
    gen = power_grid(
        effect,
        sizes,
        ns,
        n_objects=nos,
        n_levels=nls,
        n_sims=sims,
        alpha=alpha,
        seed=seed,
        processes=processes,
        cluster=cluster,
    )
    points: list[GridPoint] = _run_with_progress(gen, f"simulating {effect}", total)
    typer.echo(f"{effect}, alpha = {alpha:g}, {sims} SIMULATED studies per row, {seed_text}")
    _echo_power_table(
        f"{'size':>6} {'levels':>6} {'objects':>7} {'subjects':>8}",
        points,
        lambda p: f"{p.size:>6g} {p.n_levels:>6} {p.n_objects:>7} {p.n_subjects:>8}",
    )
    for z in sizes:
        for nl in nls:
            for no in nos:
                row = [p for p in points if (p.size, p.n_levels, p.n_objects) == (z, nl, no)]
                typer.echo(f"size {z:g}, {nl} levels, {no} objects: {_needed(row, target)}")
    if out is not None:
        settings = {"effect": effect, "alpha": alpha, "n_sims": sims, "seed": seed}
        _write_power_out(out, "grid", points, target, settings)


#: The active-search design's fields that ``power --active`` options set, and each one's option.
_ACTIVE_DESIGN_OPTIONS = {
    "n_targets": "--targets",
    "time_limit_s": "--time-limit",
    "median_time_s": "--median-time",
    "weibull_shape": "--weibull-shape",
    "frailty_sd": "--frailty-sd",
}


def _active_power(
    hazard_ratio, subjects, opts, sims, alpha, target, seed, processes, cluster, out=None
):
    """Run and print ``analyze power --hazard-ratio``: power of active-search studies."""
    from analysis.active_power import ActiveDesign, ActivePowerPoint, active_power_grid
    from analysis.errors import OptionError

    if hazard_ratio is None:
        raise OptionError("--active needs --hazard-ratio (the effect to detect), e.g. 2")
    hrs = _numbers(hazard_ratio, "--hazard-ratio")
    if not all(math.isfinite(v) and v > 0 for v in hrs):
        raise OptionError(f"--hazard-ratio must be in (0, inf), a finite number; got {hrs!r}")
    _check_power_and_alpha(target, alpha)
    if sims < 1:
        raise OptionError(f"--sims must be >= 1, got {sims!r}")
    ns = sorted(set(_numbers(subjects, "--subjects", int)))
    nsc = sorted(set(_numbers(opts["--scenes"] or "2", "--scenes", int)))
    for opt, vals in (("--subjects", ns), ("--scenes", nsc)):
        if min(vals) < 1:
            raise OptionError(f"{opt} must be integers >= 1, got {vals!r}")
    given = {f: opts[o] for f, o in _ACTIVE_DESIGN_OPTIONS.items() if opts[o] is not None}
    try:
        design = ActiveDesign(1, 1, **given)  # checks the options; the defaults are its own
    except ValueError as exc:
        field = str(exc).split()[0]
        raise OptionError(f"{_ACTIVE_DESIGN_OPTIONS.get(field, field)}: {exc}") from None
    fixed = {f: getattr(design, f) for f in _ACTIVE_DESIGN_OPTIONS}
    seed, seed_text = _resolved_seed(seed)
    gen = active_power_grid(
        hrs,
        ns,
        n_scenes=nsc,
        n_sims=sims,
        alpha=alpha,
        seed=seed,
        processes=processes,
        cluster=cluster,
        **fixed,
    )
    total = len(hrs) * len(ns) * len(nsc) * sims
    points: list[ActivePowerPoint] = _run_with_progress(gen, "simulating active search", total)
    typer.echo(
        f"active search, hazard ratio (Cox, stratified by subject, Wald), alpha = {alpha:g}, "
        f"{sims} SIMULATED studies per row, {seed_text}"
    )
    typer.echo(
        f"targets/scene {fixed['n_targets']}, time limit {fixed['time_limit_s']:g} s, cluttered "
        f"median {fixed['median_time_s']:g} s, Weibull shape {fixed['weibull_shape']:g}, "
        f"subject frailty SD {fixed['frailty_sd']:g}"
    )
    _echo_power_table(
        f"{'HR':>6} {'scenes':>6} {'subjects':>8}",
        points,
        lambda p: f"{p.hazard_ratio:>6g} {p.n_scenes:>6} {p.n_subjects:>8}",
    )
    for hr in hrs:
        for sc in nsc:
            row = [p for p in points if (p.hazard_ratio, p.n_scenes) == (hr, sc)]
            typer.echo(f"hazard ratio {hr:g}, {sc} scenes: {_needed(row, target)}")
    if out is not None:
        settings = {"effect": "hazard_ratio", "alpha": alpha, "n_sims": sims, "seed": seed}
        _write_power_out(out, "active", points, target, {**settings, **fixed})


def register(app: typer.Typer) -> None:
    """Add the ``analyze`` group (``run`` by default, ``fit`` and ``power``) to the root app."""
    app.add_typer(analyze_app, name="analyze")
