"""``confocal active run``: run (or resume) an active-search session headless.

The searcher is simulated (``sim:planes`` or ``sim:ordered``, :mod:`experiment.active.searcher`)
and its times run on a simulated clock; they are labelled simulated in the log (``searcher``
of each ``trial_start``) and in ``confocal analyze``'s report. A person searches through the
live viewer (``confocal view``), which drives the same :class:`ActiveSession` methods.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from experiment.errors import ConfocalError

__all__ = ["register", "active_app", "SEARCHERS"]

#: Searchers ``confocal active run`` can use headless.
SEARCHERS: tuple[str, ...] = ("sim:planes", "sim:ordered")

active_app = typer.Typer(
    name="active",
    no_args_is_help=True,
    add_completion=False,
    help="Active search (Jung et al. 2015, Sec. 5): a subject drives the confocal viewer to "
    "find and name objects; every key and displayed state is logged.",
)


@active_app.command("run")
def run_command(
    protocol: Annotated[
        Path, typer.Argument(help='Protocol with \\[task] type = "active_search" (or its name).')
    ],
    data: Annotated[Path, typer.Option("--data", help="The study's SQLite trial log.")],
    subject: Annotated[str, typer.Option("--subject", help="Subject code, e.g. S01.")],
    searcher: Annotated[
        str, typer.Option("--searcher", help="sim:planes or sim:ordered (simulated).")
    ] = "sim:planes",
    seed: Annotated[int | None, typer.Option("--seed", min=0, help="Root seed.")] = None,
) -> None:
    """Run or resume SUBJECT's active-search session with a simulated searcher."""
    from experiment.active.searcher import EdgeRecogniser, SimulatedSearcher
    from experiment.active.session import ActiveSession
    from experiment.clock import FakeClock
    from experiment.protocol import load_protocol
    from experiment.triallog import TrialLog

    if searcher not in SEARCHERS:
        raise ConfocalError(
            f"--searcher must be one of {', '.join(SEARCHERS)}, got {searcher!r} "
            "(a person searches through 'confocal view')"
        )
    spec = load_protocol(protocol)
    if spec.task is None:
        raise ConfocalError(
            f'{protocol}: not an active-search protocol (needs [task] type = "active_search")'
        )
    if not spec.task.scene.startswith("synthetic:"):
        raise ConfocalError(
            f"{protocol}: task.scene {spec.task.scene!r} is a recorded light field; the simulated "
            "searcher needs a synthetic scene (its model observer knows the objects' looks)"
        )
    with TrialLog(data) as log:
        session = ActiveSession.open(
            log, spec, subject, seed=seed, clock=FakeClock(), responder=searcher
        )
        try:
            rec = EdgeRecogniser(session.scene, spec.task.grid_px, rng=session.seed)
            sim = SimulatedSearcher(rec, searcher.split(":", 1)[1], rng=session.seed)
            for ev in session.iter_run(sim):
                if ev["kind"] == "answer":
                    p = ev["payload"]
                    typer.echo(
                        f"trial {ev['trial']}: answered {p['response'] or '(pass)'!r} after "
                        f"{p['rt_s']:.1f} s (simulated)"
                    )
            done, total = session.progress()
        finally:
            session.close()
    typer.echo(f"session of {subject}: {done} of {total} trials answered; log: {data}")


def register(app: typer.Typer) -> None:
    """Add the ``active`` group to the root app."""
    app.add_typer(active_app, name="active")
