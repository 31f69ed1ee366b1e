"""The ``confocal analyze`` command group: analyse trial files, and plan studies by power.

``confocal analyze TRIALS... --out REPORT_DIR`` runs the default ``run`` command (the group
inserts ``run`` when the first word is not a sub-command), and ``confocal analyze power ...``
estimates how many subjects a study needs.
"""

from __future__ import annotations

import logging
import warnings
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer
from typer.core import TyperGroup

__all__ = ["register", "analyze_app"]

logger = logging.getLogger(__name__)


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
        "  confocal analyze power --odds-ratio 5.6 | --threshold-ratio 2.5 [--subjects 1,2,4,6]: "
        "subjects needed for a given power, by simulation."
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
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder (replaced atomically).")],
    pc: Annotated[float, typer.Option("--pc", help="Proportion correct of the threshold.")] = 0.5,
    by: Annotated[
        By, typer.Option("--by", help="Also fit each subject ('none': pooled only).")
    ] = By.subject,
    guess: Annotated[float, typer.Option("--guess", help="Guess rate (0.5 for 2AFC).")] = 0.0,
    seed: Annotated[int | None, typer.Option("--seed", help="Seed of the MCMC runs.")] = None,
    mixed: Annotated[
        bool, typer.Option("--mixed", help="Also fit the mixed logistic model.")
    ] = False,
    subject_factor: Annotated[
        bool, typer.Option("--subject-factor", help="Add subject dummies to the logistic model.")
    ] = False,
    figures: Annotated[
        bool, typer.Option("--figures/--no-figures", help="Draw Figs. 8, 9, S2, S3.")
    ] = True,
    lapse_prior: Annotated[
        str, typer.Option("--lapse-prior", help="Beta(a,b) prior of the lapse rate, as 'a,b'.")
    ] = "1,10",
    overdispersion: Annotated[
        bool,
        typer.Option(
            "--overdispersion/--no-overdispersion",
            help="Beta-binomial pooled fits (free scale, as psignifit 4).",
        ),
    ] = True,
) -> None:
    """Analyse TRIALS and write REPORT_DIR (results.json, report.md, figures)."""
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from analysis.data import read_trials
    from analysis.pipeline import AnalysisOptions, analyze
    from analysis.report import write_report

    try:
        lp = tuple(float(v) for v in lapse_prior.split(","))
    except ValueError as exc:
        raise typer.BadParameter(f"--lapse-prior must be 'a,b', got {lapse_prior!r}") from exc
    try:
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
    except ValueError as exc:
        raise typer.BadParameter(str(exc)) from exc
    table = read_trials(trials)
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
        for step in analyze(table, options):
            bar.update(task, total=step.total, completed=step.done, description=step.label)
            result = step.result or result
    assert result is not None
    if figures:
        err.print("drawing figures and writing the report...")
    folder = write_report(result, out, figures=figures)
    _print_summary(result, folder)


def _print_summary(result, folder: Path) -> None:
    from analysis.report import threshold_text

    r = result.results_json()
    typer.echo(f"{r['n_trials']} trials, {r['n_recognized']} recognised")
    if r["n_training_excluded"]:
        typer.echo(f"({r['n_training_excluded']} training trials excluded)")
    for c, t in r["thresholds"].items():
        conv = "" if t["converged"] else "  NOT CONVERGED"
        typer.echo(f"50% threshold {c:>11}: {threshold_text(t['threshold_50'])}{conv}")
        if "threshold_pc" in t:
            typer.echo(f"{100 * r['pc']:g}% threshold {c:>11}: {threshold_text(t['threshold_pc'])}")
    lo = r["logistic"]
    if lo["method"] == "none":
        typer.echo("logistic model: not estimable (" + "; ".join(lo["warnings"]) + ")")
    for term in ("background", "log10_pixels"):
        o = lo["odds_ratios"].get(term)
        if o is None:
            continue
        sep = " (separated; Firth)" if term in lo["separated"] else ""
        typer.echo(
            f"odds ratio {term:>12}: {o['or']:.3g} (95% CI {o['ci95'][0]:.3g}-{o['ci95'][1]:.3g}, "
            f"p = {o['p']:.2g}){sep}"
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
    out: Annotated[Path, typer.Option("--out", "-o", help="Report folder (replaced atomically).")],
    y: Annotated[
        str | None, typer.Option("--y", help="Per-trial outcome column (1 correct, 0 not).")
    ] = None,
    k: Annotated[str | None, typer.Option("--k", help="Number-correct column.")] = None,
    n: Annotated[str | None, typer.Option("--n", help="Number-of-trials column.")] = None,
    p: Annotated[
        str | None, typer.Option("--p", help="Proportion-correct column (0-1 or percent).")
    ] = None,
    group: Annotated[
        str, typer.Option("--group", help="Comma-separated columns to fit separately.")
    ] = "",
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
    guess: Annotated[float, typer.Option("--guess", help="Guess rate (0.5 for 2AFC).")] = 0.0,
    pc: Annotated[
        str, typer.Option("--pc", help="Comma-separated proportions correct of the thresholds.")
    ] = "0.5",
    overdispersion: Annotated[
        bool,
        typer.Option("--overdispersion/--no-overdispersion", help="Beta-binomial posteriors."),
    ] = True,
    plots: Annotated[bool, typer.Option("--plots/--no-plots", help="One plot per group.")] = True,
    seed: Annotated[int | None, typer.Option("--seed", help="Seed of the sampler.")] = None,
) -> None:
    """Fit psychometric functions to any table: thresholds, intervals, goodness of fit, plots."""
    from rich.console import Console
    from rich.progress import Progress

    from analysis.errors import OptionError
    from analysis.psychometric import FitSpec, iter_fit_table, read_table, write_fit_report

    try:
        pcs = tuple(float(v) for v in pc.split(",") if v.strip())
    except ValueError as exc:
        raise OptionError(f"--pc must be numbers like 0.5,0.75, got {pc!r}") from exc
    try:
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
    except ValueError as exc:
        raise OptionError(str(exc)) from exc
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
    for g in r["groups"]:
        for t in g["thresholds"]:
            typer.echo(f"{g['label']}: {100 * t['pc']:g}% threshold {_threshold_line(t)}")
    for w in r["warnings"]:
        typer.echo(f"warning: {w}", err=True)
    typer.echo(f"report: {folder / 'report.md'}  (results: {folder / 'results.json'})")


def _threshold_line(t: dict) -> str:
    from analysis.psychometric import _threshold_md

    return _threshold_md(t)


class Effect(StrEnum):
    """Effect kinds for the power analysis."""

    odds_ratio = "odds_ratio"
    threshold_ratio = "threshold_ratio"


@analyze_app.command("power")
def power(
    odds_ratio: Annotated[
        float | None,
        typer.Option("--odds-ratio", help="Background odds ratio to detect (paper: 5.6)."),
    ] = None,
    threshold_ratio: Annotated[
        float | None,
        typer.Option(
            "--threshold-ratio", help="Cluttered / de-cluttered 50% threshold ratio to detect."
        ),
    ] = None,
    subjects: Annotated[
        str, typer.Option("--subjects", help="Comma-separated numbers of subjects to simulate.")
    ] = "1,2,3,4,6,8",
    target: Annotated[float, typer.Option("--power", help="Power wanted.")] = 0.8,
    sims: Annotated[int, typer.Option("--sims", help="Simulations per number of subjects.")] = 200,
    alpha: Annotated[float, typer.Option("--alpha", help="Test level.")] = 0.05,
    seed: Annotated[int | None, typer.Option("--seed", help="Seed of the simulations.")] = None,
) -> None:
    """Estimate how many subjects detect a given odds ratio or threshold ratio (simulation)."""
    from rich.console import Console
    from rich.progress import Progress

    from analysis.power import PowerResult, iter_power

    if (odds_ratio is None) == (threshold_ratio is None):
        raise typer.BadParameter("give exactly one of --odds-ratio and --threshold-ratio")
    try:
        ns = sorted({int(s) for s in subjects.split(",") if s.strip()})
    except ValueError as exc:
        raise typer.BadParameter(
            f"--subjects must be integers like 1,2,4, got {subjects!r}"
        ) from exc
    effect = "odds_ratio" if odds_ratio is not None else "threshold_ratio"
    size = odds_ratio if odds_ratio is not None else threshold_ratio
    points = []
    try:
        gen = iter_power(effect, size, ns, n_sims=sims, alpha=alpha, rng=seed)
        with Progress(console=Console(stderr=True), transient=True) as bar:
            task = bar.add_task(f"simulating {effect} = {size:g}", total=len(ns) * sims)
            for p in gen:
                if p is None:
                    bar.advance(task)
                else:
                    points.append(p)
    except ValueError as exc:
        raise typer.BadParameter(str(exc)) from exc
    n_req = next((p.n_subjects for p in points if p.power >= target), None)
    res = PowerResult(effect, float(size), alpha, target, tuple(points), n_req)
    typer.echo(f"{effect} = {size:g}, alpha = {alpha:g}, {sims} simulations per row")
    typer.echo("subjects  power  (95% CI)")
    for p in res.points:
        typer.echo(f"{p.n_subjects:>8}  {p.power:.2f}   ({p.ci95[0]:.2f}-{p.ci95[1]:.2f})")
    if n_req is None:
        typer.echo(f"no simulated number of subjects reached power {target:g}")
    else:
        typer.echo(f"subjects needed for power {target:g}: {n_req}")


def register(app: typer.Typer) -> None:
    """Add the ``analyze`` group (``run`` by default, ``fit`` and ``power``) to the root app."""
    app.add_typer(analyze_app, name="analyze")
