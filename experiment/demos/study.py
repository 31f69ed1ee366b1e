"""``confocal demo``: the whole study end to end on synthetic data, with no data of the user's own.

Stages (each with a progress bar):

1. **synth**: the 20 main + 3 training objects as narrow/wide depth-of-field photo pairs, rendered
   from the layered-scene model (:func:`stimuli.synth.write_pairs`);
2. **build**: the stimulus set at the paper's eight resolutions in both conditions
   (:func:`stimuli.stimset.build_stimulus_set`);
   With the default ``exemplar`` observer, a second rendering of the same kinds (another seed:
   other pose, size, colour, background and lens draw) is synthesised and built too: it is the
   observer's *knowledge* of the categories, and none of its images is a test stimulus;
3. **sessions**: simulated subjects run the shipped ``jung2015`` protocol through the real session
   engine (saved schedule, trial log, one transaction per trial). By default the subjects are the
   ``exemplar`` observer (:mod:`experiment.observers.exemplar`), which *looks at the stimuli*
   and recognises them from other exemplars of their category: clutter and low resolution hurt
   it because of the pictures themselves. Its training phase sets its criterion. Each session's
   observer (name, parameters, criterion, the data its knowledge came from) is logged as an
   ``observer`` event. The log is kept in memory (the trial log's test twin) and saved to
   ``study.sqlite`` when the sessions end: simulated subjects need no per-trial ``fsync``;
4. **analyse**: Weibull posteriors, 50 % thresholds, logistic odds ratios, figures and report
   (:func:`analysis.pipeline.analyze`, :func:`analysis.report.write_report`), then a
   "Simulated observers" section appended to ``report.md`` with the paper's numbers beside the
   simulated ones.

Nothing here asserts a result: the printed numbers are whatever the computation gives, and they
come from simulated observers, which the console output and the report both say. If the
de-cluttered threshold does not come out lower than the cluttered one, the demo says so.

``confocal demo --lightfield`` runs the light-field half of the paper instead: the three-plane
scene of Fig. 10 rendered as a lens-array light field, scanned for object planes (Fig. 15), and
each detected plane refocused, de-cluttered and compressed (Figs. 11-13, 16).
"""

from __future__ import annotations

import json
import multiprocessing
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Annotated, Any

import typer

from experiment.demos.knowledge import make_knowledge_set, make_knowledge_sets
from experiment.errors import ConfocalError
from experiment.outputs import require_missing_or_empty
from stimuli.cli import force_option, seed_option

__all__ = [
    "DemoResult",
    "run_demo",
    "summary_lines",
    "make_knowledge_set",
    "simulated_section",
    "append_simulated_section",
    "register",
    "PAPER_RESULTS",
]

#: Subjects of the paper's study (Sec. 3.1: six normally sighted subjects).
DEFAULT_SUBJECTS = 6

#: The demo's simulated subject. Ours: ``calibrated`` looks at the pictures, knows the objects
#: only from other renderings, and has its decision stage fitted to the paper's cluttered
#: condition only, so its de-cluttered numbers are a prediction; ``exemplar`` is the same
#: matcher uncalibrated; ``logistic`` only gives back the paper's model.
DEFAULT_OBSERVER = "calibrated"

#: Renderings of each kind the image observers know (seeds ``knowledge_seed`` onwards),
#: pooled. Ours: people know many mugs, not one; with one rendering per kind the exemplars
#: of a kind are far more alike than real objects, and which rendering it is moves the
#: cluttered threshold by up to 1.5x (benchmarks/observer_spread.py). Eight, not three:
#: benchmarks/observer_knowledge.py (design seeds 10-23).
KNOWLEDGE_RENDERINGS = 8

#: Observers that look at the pictures and need a knowledge set of other renderings.
_KNOWLEDGE_OBSERVERS = ("calibrated", "exemplar")

#: The paper's headline results, printed beside the simulated ones. Source: Jung et al. 2015,
#: Sec. 3.2.2: Weibull 50 % thresholds 8,695 px (cluttered) and 3,532 px (de-cluttered); logistic
#: regression OR background 5.6 (95 % CI 3.9-8.1), OR per log10 pixels 74.5 (48.9-113.5).
PAPER_RESULTS: dict[str, float] = {
    "x50_cluttered_px": 8695.0,
    "x50_decluttered_px": 3532.0,
    "threshold_ratio": 8695.0 / 3532.0,
    "or_background": 5.6,
    "or_per_log10_px": 74.5,
}


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
    observers : list of dict
        One per session: subject, session id and the observer's description (as logged).
    cpu_seconds : dict of str to float
        CPU time (user + system, this process and its finished children) of each stage,
        seconds: on a busy machine the wall time is inflated by other work, this is not.
    """

    out_dir: Path
    paths: dict[str, Path]
    results: dict[str, Any]
    seconds: dict[str, float] = field(default_factory=dict)
    observers: list[dict[str, Any]] = field(default_factory=list)
    cpu_seconds: dict[str, float] = field(default_factory=dict)


def _cpu_s() -> float:
    """CPU seconds (user + system) of this process and its finished children."""
    try:
        import resource
    except ImportError:  # not on Windows: this process only
        return time.process_time()
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def _clock() -> tuple[float, float]:
    return time.perf_counter(), _cpu_s()


def _lap(
    t0: tuple[float, float], stage: str, seconds: dict[str, float], cpu: dict[str, float]
) -> None:
    seconds[stage] = time.perf_counter() - t0[0]
    cpu[stage] = _cpu_s() - t0[1]


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


def _brief(desc: dict[str, Any]) -> dict[str, Any]:
    """Return an observer description with its per-image lists replaced by their lengths."""
    out = dict(desc)
    for part in ("knowledge", "calibration"):
        if isinstance(out.get(part), dict):
            out[part] = {
                k: (f"{len(v)} entries (full list in the trial log)" if isinstance(v, list) and
                    v and isinstance(v[0], dict) else v)
                for k, v in out[part].items()
            }  # fmt: skip
    return out


def _knowledge_reader(observer: str, folders: list[tuple[Path, Path]], protocol: Any) -> Any:
    """Return the observer's parameters for reading its knowledge where the sets are made.

    None for an observer other than ``calibrated`` and ``exemplar``.
    """
    from experiment.observers import CalibratedParams, ExemplarParams

    cls = {"calibrated": CalibratedParams, "exemplar": ExemplarParams}.get(observer)
    if cls is None or not folders:
        return None
    return cls(**_observer_params(observer, [f[1] for f in folders], protocol))


def _observer_params(observer: str, knowledge: list[Path], protocol: Any) -> dict[str, Any]:
    """Return an observer's parameters: knowledge and geometry, or ``logistic``'s x50.

    The ``logistic`` observer's average object is placed so that the pooled Weibull is at the
    paper's threshold (:func:`experiment.observers.pooled.paper_pooled_params`).
    """
    if observer == "logistic":
        from experiment.observers.pooled import paper_pooled_params

        return paper_pooled_params()
    if observer not in _KNOWLEDGE_OBSERVERS:
        return {}
    d = protocol.display
    return {
        "knowledge": str(knowledge[0]) if len(knowledge) == 1 else [str(k) for k in knowledge],
        "image_width_cm": float(d.image_width_cm),
        "image_height_cm": float(d.image_height_cm),
        "viewing_distance_cm": float(d.viewing_distance_cm),
    }


def run_demo(
    out_dir: str | Path,
    *,
    n_subjects: int = DEFAULT_SUBJECTS,
    seed: int = 0,
    observer: str = DEFAULT_OBSERVER,
    knowledge_seed: int | None = None,
    show_progress: bool = True,
    protocol: str = "jung2015",
) -> DemoResult:
    """Run the whole study on synthetic data and write everything under ``out_dir``.

    Parameters
    ----------
    out_dir : str or Path
        Demo folder: a new or empty one (a non-empty folder is refused, never replaced;
        ``confocal demo --force`` replaces a folder an earlier demo wrote, see
        :mod:`experiment.outputs`).
    n_subjects : int >= 1
        Simulated subjects (the paper had 6).
    seed : int >= 0
        Root seed: scenes, schedules, observers and MCMC are all derived from it.
    observer : {'calibrated', 'exemplar', 'logistic', 'model'}
        The simulated subject: ``calibrated`` is ``exemplar`` with a person's decision stage
        fitted to the paper's cluttered condition (:mod:`experiment.observers.calibration`);
        ``exemplar`` recognises the images from other exemplars of their
        category; ``logistic`` draws from the paper's fitted model; ``model`` matches the test
        set's own de-cluttered images (it knows the stimuli; kept for comparison).
    knowledge_seed : int >= 0, optional
        Seed of the exemplar observer's knowledge set; the ``calibrated`` observer knows
        :data:`KNOWLEDGE_RENDERINGS` renderings, seeds ``knowledge_seed`` onwards, pooled. None
        of them may be ``seed``. Default
        ``seed + 1``.
    show_progress : bool
        Draw progress bars on the terminal.
    protocol : str
        A shipped protocol or a file; its blocks' conditions are the set's
        (:func:`experiment.demos.methods.protocol_conditions`), e.g. ``methods_comparison``.

    Returns
    -------
    DemoResult

    Raises
    ------
    ConfocalError
        An unusable ``out_dir``, bad counts or seeds, or an unknown observer.
    """
    import numpy as np

    from analysis.data import read_trials
    from analysis.pipeline import AnalysisOptions, analyze
    from analysis.report import write_report
    from experiment.log import TrialLog
    from experiment.observers import OBSERVERS, describe_observer, make_observer
    from experiment.presentation.displays import NullDisplay
    from experiment.protocol import load_protocol
    from experiment.session.engine import Session
    from experiment.session.stimset import StimulusSet
    from stimuli.flagnames import param
    from stimuli.stimset import build_stimulus_set
    from stimuli.synth import write_pairs

    if isinstance(n_subjects, bool) or not isinstance(n_subjects, int) or n_subjects < 1:
        raise ConfocalError(f"{param('n_subjects')} must be an integer >= 1, got {n_subjects!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfocalError(f"{param('seed')} must be an integer >= 0, got {seed!r}")
    if observer not in OBSERVERS:
        raise ConfocalError(
            f"{param('observer')} must be one of {', '.join(sorted(OBSERVERS))}, got {observer!r}"
        )
    kseed = seed + 1 if knowledge_seed is None else knowledge_seed
    n_render = KNOWLEDGE_RENDERINGS if observer == "calibrated" else 1
    if (
        isinstance(kseed, bool)
        or not isinstance(kseed, int)
        or kseed < 0
        or 0 <= seed - kseed < n_render
    ):
        raise ConfocalError(
            f"{param('knowledge_seed')} must be an integer >= 0 whose {n_render} rendering(s) "
            f"(seeds {param('knowledge_seed')} onwards) are other than {param('seed')} ({seed}), "
            f"got {kseed!r}"
        )
    kseeds = [kseed + i for i in range(n_render)]
    from experiment.demos.methods import protocol_conditions
    from stimuli.stimset import BuildParams

    spec = load_protocol(protocol)  # one line before anything is written
    conditions = protocol_conditions(spec)
    build_params = None if conditions is None else BuildParams(conditions=conditions)
    out = Path(out_dir)
    require_missing_or_empty(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = {
        "pairs": out / "pairs",
        "stimuli": out / "stimuli",
        "data": out / "study.sqlite",
        "report": out / "report",
    }
    needs_knowledge = observer in _KNOWLEDGE_OBSERVERS
    knowledge_folders: list[tuple[Path, Path]] = []
    if needs_knowledge and n_render == 1:
        paths["knowledge_pairs"] = out / "knowledge" / "pairs"
        paths["knowledge"] = out / "knowledge" / "stimuli"
        knowledge_folders = [(paths["knowledge_pairs"], paths["knowledge"])]
    elif needs_knowledge:  # several renderings pooled: knowledge/seed<k>/{pairs,stimuli}
        paths["knowledge"] = out / "knowledge"
        knowledge_folders = [
            (out / "knowledge" / f"seed{k}" / "pairs", out / "knowledge" / f"seed{k}" / "stimuli")
            for k in kseeds
        ]
    seconds: dict[str, float] = {}
    cpu_seconds: dict[str, float] = {}
    subjects = [f"S{i + 1:02d}" for i in range(n_subjects)]
    observers: list[dict[str, Any]] = []

    # The knowledge sets are rendered and built in two more processes (half the renderings
    # each) while this one makes the test set. They are forked before the progress bars
    # start a thread; where fork is unavailable they are made afterwards, in turn.
    pool, knowledge_jobs = None, []
    if needs_knowledge and "fork" in multiprocessing.get_all_start_methods():
        from experiment.signals import worker_init

        halves = [slice(0, (len(kseeds) + 1) // 2), slice((len(kseeds) + 1) // 2, None)]
        halves = [h for h in halves if kseeds[h]]
        pool = ProcessPoolExecutor(
            len(halves),
            mp_context=multiprocessing.get_context("fork"),
            initializer=worker_init,
            initargs=(os.getpid(),),
        )
        reader = _knowledge_reader(observer, knowledge_folders, spec)
        knowledge_jobs = [
            pool.submit(make_knowledge_sets, knowledge_folders[h], kseeds[h], reader)
            for h in halves
        ]
    with _Bars(show_progress) as bars:
        try:
            t0 = _clock()
            task = bars.task("1/4 synthesise 23 photo pairs", 1)
            write_pairs(paths["pairs"], n_objects=20, n_training=3, seed=seed)
            bars.update(task, 1, 1)
            _lap(t0, "synth", seconds, cpu_seconds)

            t0 = _clock()
            task = bars.task("2/4 build the stimulus set", None)

            def build_progress(stage: str, done: int, total: int) -> None:
                bars.update(task, done + (total if stage == "write" else 0), 2 * total)

            build_stimulus_set(
                paths["pairs"], paths["stimuli"], params=build_params, progress=build_progress
            )
            _lap(t0, "build", seconds, cpu_seconds)
            if needs_knowledge:
                t0 = _clock()
                seeds_txt = ", ".join(str(k) for k in kseeds)
                task = bars.task(f"   exemplars (seed {seeds_txt}) for the observer", 1)
                if knowledge_jobs:
                    from experiment.observers.exemplar import add_knowledge_cache_entries

                    for job in knowledge_jobs:
                        add_knowledge_cache_entries(job.result())
                    pool.shutdown()  # reaps the processes, so their CPU time is counted here
                else:
                    make_knowledge_sets(knowledge_folders, kseeds)
                bars.update(task, 1, 1)
                _lap(t0, "knowledge_wait", seconds, cpu_seconds)
        except BaseException:
            if pool is not None:  # stopped or failed: do not wait for the exemplars
                from analysis.workers import stop_pool

                stop_pool(pool)
            raise
        finally:
            if pool is not None:
                pool.shutdown(cancel_futures=True)

        t0 = _clock()
        stimset = StimulusSet.load(paths["stimuli"])
        params = _observer_params(observer, [f[1] for f in knowledge_folders] or [out], spec)
        probe = make_observer(observer, stimset, "probe", rng=0, **params)
        effective_params = json.loads(json.dumps(asdict(probe.params), default=str))
        log = TrialLog(":memory:")
        try:
            seeds = np.random.SeedSequence(seed).generate_state(n_subjects)
            task = bars.task(f"3/4 run {n_subjects} simulated subjects ({observer})", None)
            done_before = 0
            for subject, s in zip(subjects, seeds, strict=True):
                session = Session.open(
                    log,
                    spec,
                    stimset,
                    subject,
                    seed=int(s),
                    responder=f"sim:{observer}",
                    observer=observer,
                    observer_params=effective_params,
                )
                try:
                    total = session.progress()[1]

                    def session_progress(
                        answered: int, _total: int, base: int = done_before, n: int = total
                    ) -> None:
                        bars.update(task, base + answered, n * n_subjects)

                    responder = make_observer(
                        observer, stimset, subject, rng=session.child_rng(1), **params
                    )
                    desc = describe_observer(responder)
                    session.log_event("observer", json.dumps(desc, sort_keys=True))
                    observers.append({"subject": subject, "session": session.session_id, **desc})
                    session.run(NullDisplay(), responder, progress=session_progress)
                    done_before += total
                finally:
                    session.close()
            log.save_copy(paths["data"])
        finally:
            log.close()
        _lap(t0, "sessions", seconds, cpu_seconds)

        t0 = _clock()
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
        _lap(t0, "analysis", seconds, cpu_seconds)

    results = json.loads((paths["report"] / "results.json").read_text(encoding="utf-8"))
    demo = DemoResult(
        out_dir=out,
        paths=paths,
        results=results,
        seconds=seconds,
        observers=observers,
        cpu_seconds=cpu_seconds,
    )
    append_simulated_section(paths["report"] / "report.md", demo)
    summary = {
        "seed": seed,
        "knowledge_seed": kseed if needs_knowledge else None,
        "knowledge_seeds": kseeds if needs_knowledge else None,
        "subjects": subjects,
        "observer": observer,
        "simulated": True,
        "observers": [_brief(o) for o in observers],
        "paper": PAPER_RESULTS,
        "paths": {k: _relative_to(v, out) for k, v in paths.items()},
        "seconds": seconds,
        "cpu_seconds": cpu_seconds,
    }
    (out / "demo.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    return demo


def _relative_to(path: Path, root: Path) -> str:
    """``path`` relative to ``root`` (its name when outside): no host path in ``demo.json``."""
    try:
        return Path(path).resolve().relative_to(Path(root).resolve()).as_posix()
    except ValueError:
        return Path(path).name


def _fmt_px(v: Any) -> str:
    return "n/a" if v is None else f"{float(v):,.0f}"


def _simulated_numbers(results: dict[str, Any]) -> dict[str, float | None]:
    th = results.get("thresholds", {})
    ors = results.get("logistic", {}).get("odds_ratios", {})

    def x50(cond: str) -> float | None:
        t = th.get(cond) or {}
        return None if t.get("p50_pixels") is None else float(t["p50_pixels"])

    c, d = x50("cluttered"), x50("decluttered")
    return {
        "x50_cluttered_px": c,
        "x50_decluttered_px": d,
        "threshold_ratio": c / d if c and d else None,
        "or_background": (ors.get("background") or {}).get("or"),
        "or_per_log10_px": (ors.get("log10_pixels") or {}).get("or"),
    }


_ROWS = (
    ("x50_cluttered_px", "50% threshold, cluttered", "{:,.0f} px"),
    ("x50_decluttered_px", "50% threshold, de-cluttered", "{:,.0f} px"),
    ("threshold_ratio", "threshold ratio (cluttered / de-cluttered)", "{:.2f}"),
    ("or_background", "odds ratio, background (de-cluttered)", "{:.2f}"),
    ("or_per_log10_px", "odds ratio per log10 px", "{:.1f}"),
)


def _fmt(v: Any, fmt: str) -> str:
    return "n/a" if v is None else fmt.format(float(v))


def _distance(sim: float | None, paper: float) -> str:
    """How far a simulated number is from the paper's: ``+23 %`` or ``2.1x the paper's``."""
    if sim is None:
        return "not estimated"
    r = sim / paper
    return f"{(r - 1) * 100:+.0f} %" if 0.25 <= r <= 2 else f"{r:.2g}x the paper's"


def _knowledge_source(knowledge: dict[str, Any], rendering: str) -> str:
    """Describe where an observer's knowledge came from.

    ``rendering`` formatted with the seed of the synthesis that made it, the seeds of several pooled
    renderings, or a held-out stimulus set.
    """
    seed = (knowledge.get("synth") or {}).get("seed")
    if isinstance(seed, list):  # knowledge pooled from several renderings
        return f"{len(seed)} other renderings (seeds {', '.join(str(s) for s in seed)})"
    return "a held-out stimulus set" if seed is None else rendering.format(seed=seed)


def _calibrated_line(demo: DemoResult, first: dict[str, Any]) -> str:
    """One sentence: the calibrated observer, its calibration and its distance to the paper."""
    p = first.get("params", {})
    k = first.get("knowledge", {})
    source = _knowledge_source(k, "another rendering (seed {seed})")
    sim = _simulated_numbers(demo.results)

    def px(key: str) -> str:
        return f"{_fmt_px(sim[key])} px ({_distance(sim[key], PAPER_RESULTS[key])})"

    ratio = sim["threshold_ratio"]
    passed = (first.get("calibration") or {}).get("unknown_kinds_passed")
    open_set = (
        ""
        if passed is None
        else f' and says "don\'t know" to {float(passed):.0%} of images of kinds it does not know'
    )
    priming = float(p.get("priming") or 0.0)
    primed = f" ({priming:g} lower for kinds already named)" if priming > 0 else ""
    spd = p.get("samples_per_deg")
    sampling = "" if spd is None else f"retinal sampling {float(spd):g}/deg, "
    return (
        "simulated observer: calibrated (HOG exemplar matcher knowing "
        f"{len(k.get('categories', []))} kinds from {source}, with a person's limits: "
        f"{sampling}blur {p.get('blur_deg')} deg, internal noise SD {p.get('noise_sd')}, "
        "open-set criterion "
        f"{float(p.get('criterion') or 0):.2f}{primed}, lapse {p.get('lapse')}; fitted to the "
        f"paper's cluttered condition only) gives cluttered {px('x50_cluttered_px')} and, as a "
        f"prediction, de-cluttered {px('x50_decluttered_px')} against the paper's 8,695 and "
        f"3,532 px, ratio {'n/a' if ratio is None else f'{ratio:.2f}'} against 2.46{open_set}"
    )


def _observer_line(demo: DemoResult) -> str:
    """One sentence: who the simulated observers were and where their knowledge came from."""
    if not demo.observers:
        return "simulated observer: (none logged)"
    first = demo.observers[0]
    name = first.get("observer", "?")
    if name == "calibrated":
        return _calibrated_line(demo, first)
    if name == "exemplar":
        k = first.get("knowledge", {})
        crit = [o["criterion"] for o in demo.observers if o.get("criterion") is not None]
        p = first.get("params", {})
        source = _knowledge_source(k, "another rendering synthesised with seed {seed}")
        return (
            f"simulated observer: exemplar ({first.get('model')}); knowledge: "
            f"{len(k.get('categories', []))} categories from {len(k.get('exemplars', []))} "
            f"exemplar images of {source} ({k.get('root')}), none of them a test "
            f"stimulus; blur {p.get('blur_deg')} deg, HOG cells {p.get('cell_deg')} deg, "
            f"internal noise SD {p.get('noise_sd')}; criterion set in each subject's training "
            f"phase: {min(crit):.4f}-{max(crit):.4f}"
        )
    if name == "logistic":
        return (
            "simulated observer: logistic (draws from the paper's own fitted logistic model, "
            "its average object's cluttered 50 % point at "
            f"{(first.get('params') or {}).get('x50_cluttered_px', float('nan')):,.0f} px so "
            "that the Weibull through all subjects' and objects' trials, as the paper fitted, "
            "sits at the paper's 8,695 px; it does not look at the images)"
        )
    return f"simulated observer: {name} (parameters in the trial log's 'observer' events)"


def simulated_section(demo: DemoResult) -> str:
    """Return the report's "Simulated observers" section (Markdown): who, and the paper beside."""
    sim = _simulated_numbers(demo.results)
    lines = [
        "",
        "## Simulated observers",
        "",
        "**Every number in this report comes from simulated observers, not from people.** "
        f"{len(demo.observers)} simulated subject{'' if len(demo.observers) == 1 else 's'} "
        "answered the synthetic stimuli through the "
        "session engine; each session's observer (name, parameters, criterion and the data its "
        "knowledge came from) is logged as an `observer` event in the trial log.",
        "",
        _observer_line(demo) + ".",
        "",
        "| | simulated (this run) | paper (Jung et al. 2015, Sec. 3.2.2) |",
        "|---|---|---|",
    ]
    for key, label, fmt in _ROWS:
        lines.append(f"| {label} | {_fmt(sim[key], fmt)} | {_fmt(PAPER_RESULTS[key], fmt)} |")
    lines.append("")
    return "\n".join(lines)


def append_simulated_section(report_md: str | Path, demo: DemoResult) -> None:
    """Append :func:`simulated_section` to ``report_md`` (rewritten through a temporary file)."""
    p = Path(report_md)
    text = p.read_text(encoding="utf-8").rstrip("\n") + "\n" + simulated_section(demo)
    tmp = p.with_name(f".{p.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(p)


def summary_lines(result: DemoResult) -> list[str]:
    """Return the demo's headline results as printable lines (computed, never asserted)."""
    r = result.results
    lines = [
        "SIMULATED DATA: every number below comes from simulated observers, not people.",
        _observer_line(result),
        f"{r['n_trials']} trials, {r['n_recognized']} recognised",
    ]
    th = r.get("thresholds", {})
    for cond in ("cluttered", "decluttered"):
        t = th.get(cond)
        if t:
            lo, hi = t["ci95"]
            lines.append(
                f"50% threshold, {cond:<11}: {_fmt_px(t['p50_pixels'])} px "
                f"(95% CrI {_fmt_px(lo)}-{_fmt_px(hi)}; ML {_fmt_px(t['mle_p50_pixels'])})"
                f"{'' if t.get('converged') else '  [chain NOT converged]'}"
                f"   paper: {_fmt_px(PAPER_RESULTS[f'x50_{cond}_px'])} px"
            )
    sim = _simulated_numbers(r)
    ratio = sim["threshold_ratio"]
    paper_ratio = f"paper: {PAPER_RESULTS['threshold_ratio']:.2f}"
    if ratio is not None and ratio > 1:
        lines.append(f"de-cluttering lowers the 50% threshold {ratio:.2f}-fold   {paper_ratio}")
    elif ratio is not None:
        lines.append(
            f"finding: the de-cluttered threshold is NOT lower than the cluttered one "
            f"(ratio {ratio:.2f})   {paper_ratio}"
        )
    ors = r.get("logistic", {}).get("odds_ratios", {})
    for key, label, paper in (
        ("background", "background (de-cluttered)", PAPER_RESULTS["or_background"]),
        ("log10_pixels", "log10 px", PAPER_RESULTS["or_per_log10_px"]),
    ):
        o = ors.get(key)
        if o:
            lo, hi = o["ci95"]
            lines.append(
                f"odds ratio {label}: {o['or']:.2f} (95% CI {lo:.2f}-{hi:.2f})   paper: {paper}"
            )
    from experiment.demos.methods import methods_summary_lines

    lines += methods_summary_lines(r)  # a method comparison's conditions and ratios
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
        seed: Annotated[int, seed_option("Root seed.")] = 0,
        observer: Annotated[
            str,
            typer.Option(
                "--observer",
                help="Simulated subject: calibrated (exemplar with a person's decision stage "
                "fitted to the paper's cluttered condition), exemplar (recognises the images "
                "from other renderings of each kind), logistic (draws from the paper's fitted "
                "model) or model (matches the test set's own images).",
            ),
        ] = DEFAULT_OBSERVER,
        knowledge_seed: Annotated[
            int | None,
            seed_option(
                "Seed of the observer's knowledge set (default: --seed + 1; the calibrated "
                f"observer knows {KNOWLEDGE_RENDERINGS} renderings, seeds --knowledge-seed "
                "onwards).",
                "--knowledge-seed",
            ),
        ] = None,
        lightfield: Annotated[
            bool,
            typer.Option("--lightfield", help="Run the light-field demo (paper Figs. 10-16)."),
        ] = False,
        force: Annotated[
            bool, force_option("a folder an earlier demo of the same kind wrote")
        ] = False,
        active: Annotated[
            bool, typer.Option("--active", help="Draw a simulated active search.")
        ] = False,
        protocol: Annotated[
            str,
            typer.Option(
                "--protocol",
                help="Protocol the simulated subjects run: jung2015 (the paper's), "
                "methods_comparison (every de-clutter method at the same levels) or a file.",
            ),
        ] = "jung2015",
    ) -> None:
        """Run the whole study on synthetic data: scenes, stimuli, sessions, analysis, report.

        With --lightfield: render the paper's three-plane light field, scan it for object
        planes, and write confocal, de-cluttered and compressed images of each plane.
        """
        if active:
            from experiment.active.demo import run_active_demo

            out_a = out if out != Path("confocal-demo") else Path("confocal-demo-active")
            for line in run_active_demo(out_a, seed=seed):
                typer.echo(line)
            return
        if lightfield:
            from experiment.demos.lightfield import run_lightfield_demo

            out_lf = out if out != Path("confocal-demo") else Path("confocal-demo-lightfield")
            for line in run_lightfield_demo(out_lf, seed=seed):
                typer.echo(line)
            return
        result = run_demo(
            out,
            n_subjects=subjects,
            seed=seed,
            observer=observer,
            knowledge_seed=knowledge_seed,
            protocol=protocol,
        )
        for line in summary_lines(result):
            typer.echo(line)
