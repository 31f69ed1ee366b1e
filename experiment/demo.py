"""``confocal demo``: the whole study end to end on synthetic data, with no data of the user's own.

Stages (each with a progress bar):

1. **synth**: the 20 main + 3 training objects as narrow/wide depth-of-field photo pairs, rendered
   from the layered-scene model (:func:`stimuli.synth.write_pairs`);
2. **build**: the stimulus set at the paper's eight resolutions in both conditions
   (:func:`stimuli.build.build_stimulus_set`);
3. **sessions**: simulated subjects run the shipped ``jung2015`` protocol through the real session
   engine (saved schedule, SQLite trial log, one transaction per trial). By default the subjects
   are the image-based ``model`` observer, which *looks at the stimuli*: clutter and low
   resolution hurt it because of the pictures themselves;
4. **analyse**: Weibull posteriors, 50 % thresholds, logistic odds ratios, figures and report
   (:func:`analysis.pipeline.analyze`, :func:`analysis.report.write_report`).

Nothing here asserts a result: the printed numbers are whatever the computation gives. If the
de-cluttered threshold does not come out lower than the cluttered one, the demo says so.

``confocal demo --lightfield`` runs the light-field half of the paper instead: the three-plane
scene of Fig. 10 rendered as a lens-array light field, scanned for object planes (Fig. 15), and
each detected plane refocused, de-cluttered and compressed (Figs. 11-13, 16).
"""

from __future__ import annotations

import json
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from experiment.errors import ConfocalError

__all__ = ["DemoResult", "run_demo", "summary_lines", "register"]

#: Subjects of the paper's study (Sec. 3.1: six normally sighted subjects).
DEFAULT_SUBJECTS = 6


@dataclass
class DemoResult:
    """Where the demo wrote its outputs, and the headline numbers it computed.

    Parameters
    ----------
    out_dir : Path
        The demo folder.
    paths : dict of str to Path
        ``pairs``, ``stimuli``, ``data`` (the SQLite trial log), ``report``.
    results : dict
        The analysis' ``results.json``.
    seconds : dict of str to float
        Wall time of each stage, seconds.
    """

    out_dir: Path
    paths: dict[str, Path]
    results: dict[str, Any]
    seconds: dict[str, float] = field(default_factory=dict)


def _prepare_out(out_dir: Path, force: bool) -> None:
    if out_dir.exists() and not out_dir.is_dir():
        raise ConfocalError(f"--out {out_dir} exists and is not a folder")
    if out_dir.is_dir() and any(out_dir.iterdir()):
        if not force:
            raise ConfocalError(
                f"--out {out_dir} is not empty; use --force to replace it or choose another folder"
            )
        shutil.rmtree(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)


class _Bars:
    """Rich progress bars, one task per stage (silent when ``enabled`` is False)."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self.progress = None

    def __enter__(self) -> _Bars:
        if self.enabled:
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
            )

            self.progress = Progress(
                TextColumn("{task.description:<34}"),
                BarColumn(),
                MofNCompleteColumn(),
                TimeElapsedColumn(),
            )
            self.progress.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        if self.progress is not None:
            self.progress.__exit__(*exc)

    def task(self, description: str, total: int | None) -> Any:
        if self.progress is None:
            return None
        return self.progress.add_task(description, total=total)

    def update(self, task: Any, completed: int, total: int | None = None) -> None:
        if self.progress is not None and task is not None:
            self.progress.update(task, completed=completed, total=total)


def run_demo(
    out_dir: str | Path,
    *,
    n_subjects: int = DEFAULT_SUBJECTS,
    seed: int = 0,
    observer: str = "model",
    force: bool = False,
    show_progress: bool = True,
) -> DemoResult:
    """Run the whole study on synthetic data and write everything under ``out_dir``.

    Parameters
    ----------
    out_dir : str or Path
        Demo folder (created; an existing non-empty one needs ``force``).
    n_subjects : int >= 1
        Simulated subjects (the paper had 6).
    seed : int >= 0
        Root seed: scenes, schedules, observers and MCMC are all derived from it.
    observer : {'model', 'logistic'}
        The simulated subject: the image-based template matcher, or the paper's logistic model.
    force : bool
        Replace a non-empty ``out_dir``.
    show_progress : bool
        Draw progress bars on the terminal.

    Returns
    -------
    DemoResult

    Raises
    ------
    ConfocalError
        An unusable ``out_dir`` or bad counts.
    """
    from analysis.data import read_trials
    from analysis.pipeline import AnalysisOptions, analyze
    from analysis.report import write_report
    from experiment.displays import NullDisplay
    from experiment.observers import OBSERVERS, make_observer
    from experiment.protocol import load_protocol
    from experiment.session import Session
    from experiment.stimset import StimulusSet
    from experiment.triallog import TrialLog
    from stimuli.build import build_stimulus_set
    from stimuli.synth import write_pairs

    if isinstance(n_subjects, bool) or not isinstance(n_subjects, int) or n_subjects < 1:
        raise ConfocalError(f"--subjects must be an integer >= 1, got {n_subjects!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfocalError(f"--seed must be an integer >= 0, got {seed!r}")
    if observer not in OBSERVERS:
        raise ConfocalError(
            f"--observer must be one of {', '.join(sorted(OBSERVERS))}, got {observer!r}"
        )
    out = Path(out_dir)
    _prepare_out(out, force)
    paths = {
        "pairs": out / "pairs",
        "stimuli": out / "stimuli",
        "data": out / "study.sqlite",
        "report": out / "report",
    }
    seconds: dict[str, float] = {}
    subjects = [f"S{i + 1:02d}" for i in range(n_subjects)]

    with _Bars(show_progress) as bars:
        t0 = time.perf_counter()
        task = bars.task("1/4 synthesise 23 photo pairs", 1)
        write_pairs(paths["pairs"], n_objects=20, n_training=3, seed=seed)
        bars.update(task, 1, 1)
        seconds["synth"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        task = bars.task("2/4 build the stimulus set", None)

        def build_progress(stage: str, done: int, total: int) -> None:
            bars.update(task, done + (total if stage == "write" else 0), 2 * total)

        build_stimulus_set(paths["pairs"], paths["stimuli"], progress=build_progress)
        seconds["build"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        protocol = load_protocol("jung2015")
        stimset = StimulusSet.load(paths["stimuli"])
        log = TrialLog(paths["data"])
        try:
            seeds = np.random.SeedSequence(seed).generate_state(n_subjects)
            task = bars.task(f"3/4 run {n_subjects} simulated subjects", None)
            done_before = 0
            for subject, s in zip(subjects, seeds, strict=True):
                session = Session.open(
                    log, protocol, stimset, subject, seed=int(s), responder=f"sim:{observer}"
                )
                try:
                    total = session.progress()[1]

                    def session_progress(
                        answered: int, _total: int, base: int = done_before, n: int = total
                    ) -> None:
                        bars.update(task, base + answered, n * n_subjects)

                    responder = make_observer(observer, stimset, subject, rng=session.child_rng(1))
                    session.run(NullDisplay(), responder, progress=session_progress)
                    done_before += total
                finally:
                    session.close()
        finally:
            log.close()
        seconds["sessions"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        table = read_trials([paths["data"]])
        task = bars.task("4/4 analyse (MCMC, logistic, figures)", None)
        result = None
        for step in analyze(table, AnalysisOptions(seed=seed)):
            bars.update(task, step.done, step.total)
            if step.result is not None:
                result = step.result
        if result is None:  # analyze always ends with a result; guard against a silent change
            raise RuntimeError("analysis ended without a result")
        write_report(result, paths["report"])
        seconds["analysis"] = time.perf_counter() - t0

    results = json.loads((paths["report"] / "results.json").read_text(encoding="utf-8"))
    summary = {
        "seed": seed,
        "subjects": subjects,
        "observer": observer,
        "paths": {k: str(v) for k, v in paths.items()},
        "seconds": seconds,
    }
    (out / "demo.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    return DemoResult(out_dir=out, paths=paths, results=results, seconds=seconds)


def _fmt_px(v: Any) -> str:
    return "n/a" if v is None else f"{float(v):,.0f}"


def summary_lines(result: DemoResult) -> list[str]:
    """Return the demo's headline results as printable lines (computed, never asserted)."""
    r = result.results
    lines = [f"{r['n_trials']} trials, {r['n_recognized']} recognised"]
    th = r.get("thresholds", {})
    for cond in ("cluttered", "decluttered"):
        t = th.get(cond)
        if t:
            lo, hi = t["ci95"]
            lines.append(
                f"50% threshold, {cond:<11}: {_fmt_px(t['p50_pixels'])} px "
                f"(95% CrI {_fmt_px(lo)}-{_fmt_px(hi)}; ML {_fmt_px(t['mle_p50_pixels'])})"
                f"{'' if t.get('converged') else '  [chain NOT converged]'}"
            )
    c, d = th.get("cluttered"), th.get("decluttered")
    if c and d and c.get("p50_pixels") and d.get("p50_pixels"):
        ratio = c["p50_pixels"] / d["p50_pixels"]
        if ratio > 1:
            lines.append(f"de-cluttering lowers the 50% threshold {ratio:.2f}-fold")
        else:
            lines.append(
                f"finding: the de-cluttered threshold is NOT lower than the cluttered one "
                f"(ratio {ratio:.2f})"
            )
    ors = r.get("logistic", {}).get("odds_ratios", {})
    for key, label in (("background", "background (de-cluttered)"), ("log10_pixels", "log10 px")):
        o = ors.get(key)
        if o:
            lo, hi = o["ci95"]
            lines.append(f"odds ratio {label}: {o['or']:.2f} (95% CI {lo:.2f}-{hi:.2f})")
    lines.append(f"report:  {result.paths['report'] / 'report.md'}")
    lines.append(f"figures: {result.paths['report']}")
    lines.append(f"trial log: {result.paths['data']}")
    return lines


def register(app: typer.Typer) -> None:
    """Add ``confocal demo`` to the root app."""

    @app.command("demo")
    def demo_command(
        out: Annotated[
            Path, typer.Option("--out", "-o", help="Folder for everything the demo writes.")
        ] = Path("confocal-demo"),
        subjects: Annotated[
            int, typer.Option("--subjects", min=1, help="Simulated subjects (paper: 6).")
        ] = DEFAULT_SUBJECTS,
        seed: Annotated[int, typer.Option("--seed", min=0, help="Root seed.")] = 0,
        observer: Annotated[
            str,
            typer.Option(
                "--observer",
                help="Simulated subject: model (looks at the images) "
                "or logistic (the paper's fitted model).",
            ),
        ] = "model",
        lightfield: Annotated[
            bool,
            typer.Option("--lightfield", help="Run the light-field demo (paper Figs. 10-16)."),
        ] = False,
        force: Annotated[bool, typer.Option("--force", help="Replace a non-empty --out.")] = False,
        active: Annotated[
            bool, typer.Option("--active", help="Draw a simulated active search (issue 14).")
        ] = False,
    ) -> None:
        """Run the whole study on synthetic data: scenes, stimuli, sessions, analysis, report.

        With --lightfield: render the paper's three-plane light field, scan it for object
        planes, and write confocal, de-cluttered and compressed images of each plane.
        """
        if active:
            from experiment.active.demo import run_active_demo

            out_a = out if out != Path("confocal-demo") else Path("confocal-demo-active")
            for line in run_active_demo(out_a, seed=seed, force=force):
                typer.echo(line)
            return
        if lightfield:
            from experiment.demo_lightfield import run_lightfield_demo

            out_lf = out if out != Path("confocal-demo") else Path("confocal-demo-lightfield")
            for line in run_lightfield_demo(out_lf, seed=seed, force=force):
                typer.echo(line)
            return
        result = run_demo(out, n_subjects=subjects, seed=seed, observer=observer, force=force)
        for line in summary_lines(result):
            typer.echo(line)
