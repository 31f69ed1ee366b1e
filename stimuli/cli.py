"""``confocal stimuli ...``: build stimulus sets, tune their thresholds, write synthetic pairs."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from stimuli.resources import MAX_SEED

__all__ = ["force_option", "register", "seed_option", "stimuli_app"]

#: Peak memory of ``synth`` per photo pixel, bytes (ours: measured 147 B/px at 2000x1500).
_SYNTH_BYTES_PER_PX = 160
#: Working memory of one ``build`` worker per working-size pixel, bytes (ours: a dozen float32
#: and float64 images of the working size; the estimate only has to catch absurd sizes).
_BUILD_BYTES_PER_PX = 64


def seed_option(text: str, name: str = "--seed"):
    """Return a seed option: every command's seeds (the experiment's too) take [0, MAX_SEED].

    Parameters
    ----------
    text : str
        The option's help.
    name : str
        The option's name.

    Returns
    -------
    typer.models.OptionInfo
        For ``Annotated[int, seed_option(...)]``.
    """
    return typer.Option(name, min=0, max=MAX_SEED, help=text)


def force_option(what: str):
    """Return the ``--force`` option of a command that writes a folder.

    Parameters
    ----------
    what : str
        What it replaces, e.g. ``"a PAIRS folder this command wrote before"``; the help adds
        that a folder holding anything else is never replaced.

    Returns
    -------
    typer.models.OptionInfo
        For ``Annotated[bool, force_option(...)]``.
    """
    return typer.Option("--force", help=f"Replace {what} (never a folder holding anything else).")


#: The PAIRS input of ``build`` and ``tune``.
_PairsArgument = Annotated[
    Path,
    typer.Argument(
        help="Folder with one sub-folder per object holding wide.* and narrow.* (optional "
        "objects.csv), or a CSV object,wide,narrow[,crop] with paths relative to it.",
        show_default=False,
    ),
]
#: The working size of ``build`` and ``tune``.
_WorkingSizeOption = Annotated[
    str,
    typer.Option("--working-size", help="Working size WIDTHxHEIGHT, pixels (paper: 492x327)."),
]

stimuli_app = typer.Typer(
    name="stimuli",
    help="Build stimulus sets (Jung et al. 2015, Sec. 3.1) from photo pairs or light fields.",
    no_args_is_help=True,
)


@stimuli_app.command("build")
def build_command(
    pairs: _PairsArgument,
    out: Annotated[Path, typer.Option("--out", "-o", help="Stimulus-set folder to write.")],
    working_size: _WorkingSizeOption = "492x327",
    threshold: Annotated[
        str,
        typer.Option(
            "--threshold",
            help="Sobel threshold: 'auto' (per object, --threshold-method) or a number; "
            "objects.csv values win (see 'confocal stimuli tune').",
        ),
    ] = "auto",
    threshold_method: Annotated[
        str,
        typer.Option(
            "--threshold-method",
            help="Automatic threshold method: retention (both photos of a pair; as 'stimuli "
            "tune'), otsu or triangle (narrow photo only).",
        ),
    ] = "retention",
    edge_ratio: Annotated[
        str,
        typer.Option(
            "--edge-ratio",
            help="Compression edge ratio: 'auto' (mean wide-DOF edge fraction; paper 0.077) or a "
            "number in [0, 1).",
        ),
    ] = "auto",
    mode: Annotated[str, typer.Option("--mode", help="edges (binary) or grey (Fig. 2).")] = "edges",
    grey_levels: Annotated[
        int, typer.Option("--grey-levels", min=2, max=256, help="Grey levels in grey mode.")
    ] = 8,
    declutter: Annotated[
        str,
        typer.Option(
            "--declutter",
            help="De-cluttering of light-field objects: auto (depth for 1-D light fields, whose "
            "refocusing blurs only along the baseline; else sobel), sobel (the paper's Sobel + "
            "threshold) or depth (keep only edges where the views agree at the plane; refused "
            "for photo pairs). Photo pairs: sobel.",
        ),
    ] = "auto",
    conditions: Annotated[
        str,
        typer.Option(
            "--conditions",
            help="The set's conditions, comma-separated: cluttered and de-clutter methods (see "
            "'confocal stimuli methods'; decluttered = sobel, the paper's). Every condition "
            "goes through the same crop, levels and compression.",
        ),
    ] = "cluttered,decluttered",
    plane: Annotated[
        str,
        typer.Option(
            "--plane",
            help="Plane of light-field objects without a plane or roi in objects.csv: auto "
            "(nearest detected plane with a twentieth of the strongest plane's support and "
            "evidence, not a border band), strongest, nearest, or a disparity in px per view "
            "step.",
        ),
    ] = "auto",
    bokeh_guard: Annotated[
        bool,
        typer.Option(
            "--bokeh-guard",
            help="Photo pairs: drop narrow-DOF edges absent from the wide photo at the same place "
            "(sharp bokeh rims; beyond the paper).",
        ),
    ] = False,
    allow_resize: Annotated[
        bool, typer.Option("--allow-resize", help="Accept pairs whose photos differ in pixel size.")
    ] = False,
    fast_decode: Annotated[
        bool,
        typer.Option(
            "--fast-decode",
            help="Decode JPEGs at reduced size (Pillow draft: 1/2, 1/4 or 1/8) just large enough "
            "for the working size; 3-5x faster, slightly different pixels.",
        ),
    ] = False,
    force: Annotated[
        bool,
        typer.Option(
            "--force",
            help="Replace a set this command wrote in --out before even if it is a different "
            "stimulus set (a folder holding anything else is never replaced).",
        ),
    ] = False,
    replaces: Annotated[
        Path | None,
        typer.Option(
            "--replaces",
            hidden=True,
            help="Set by confocal: the earlier set in --out, moved aside to be replaced.",
        ),
    ] = None,
    implant: Annotated[
        list[str] | None,
        typer.Option(
            "--implant",
            help="Also write each object's cluttered and de-cluttered image as this implant "
            "shows it: resampled to its electrode grid (implants/NAME/OBJECT/*_grid.png) and "
            "drawn as its phosphenes (*_phosphenes.png), listed with sha256 and the layout in "
            "stimulus_set.json. A shipped layout (argus2, alpha_ims, brainport) or your own "
            ".toml file; repeat for several.",
            show_default=False,
        ),
    ] = None,
    implant_px: Annotated[
        int,
        typer.Option(
            "--implant-px",
            min=1,
            max=256,
            help="Side of each electrode's cell in the phosphene PNGs, pixels.",
        ),
    ] = 16,
    processes: Annotated[
        int | None,
        typer.Option(
            "--processes",
            help="Local worker processes for the per-object work (reading, plane choice, "
            "refocus, de-cluttering, compression); default 1: in this process, on threads. The "
            "set is the same, byte for byte, apart from its build time.",
            show_default=False,
        ),
    ] = None,
    cluster: Annotated[
        str | None,
        typer.Option(
            "--cluster",
            help="Dask scheduler address that runs the per-object work instead (the 'dask' "
            "extra; its workers must see PAIRS at the same path).",
            show_default=False,
        ),
    ] = None,
) -> None:
    """Build cluttered and de-cluttered stimuli at the paper's eight resolutions.

    With --implant, also the stimuli as each implant shows them (grid and phosphenes). With
    --processes or --cluster, each object (a photo pair or a light-field capture) is prepared
    in a worker; the manifest, the set record and the overview sheet are assembled here.
    """
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

    from stimuli.implants import load_implant
    from stimuli.lfbatch import check_pool_options
    from stimuli.methods import parse_conditions
    from stimuli.resources import check_memory
    from stimuli.stimset import (
        BuildParams,
        build_stimulus_set,
        parse_edge_ratio,
        parse_threshold,
        parse_working_size,
    )

    check_pool_options(processes, cluster)  # one-line error before any work
    shape = parse_working_size(working_size)
    layouts = [load_implant(name) for name in implant or ()]  # one-line error before any work
    # each worker holds a few float32/float64 images of the working size at once
    check_memory(shape[0] * shape[1] * _BUILD_BYTES_PER_PX * 8, f"--working-size {working_size}")
    params = BuildParams(
        working_shape_px=shape,
        threshold=parse_threshold(threshold),
        threshold_method=threshold_method,
        edge_ratio=parse_edge_ratio(edge_ratio),
        mode=mode,
        grey_levels=grey_levels,
        declutter=declutter,
        plane=plane,
        bokeh_guard=bokeh_guard,
        allow_resize=allow_resize,
        fast_decode=fast_decode,
        conditions=parse_conditions(conditions),
    )
    console = Console(stderr=True)
    # The bar starts at the first progress report, so bad input prints its one line alone.
    bar: Progress | None = None
    tasks: dict[str, int] = {}

    def progress(stage: str, done: int, total: int) -> None:
        nonlocal bar
        if bar is None:
            bar = Progress(
                TextColumn("{task.description}"),
                BarColumn(),
                MofNCompleteColumn(),
                console=console,
                transient=True,
            )
            bar.start()
        if stage not in tasks:
            label = {"read": "reading and de-cluttering", "implants": "drawing implant views"}.get(
                stage, "writing stimuli"
            )
            tasks[stage] = bar.add_task(label, total=total)
        bar.update(tasks[stage], completed=done)

    from stimuli.flagnames import cli_flags

    try:
        with cli_flags():  # the library names parameters; the command line its flags
            result = build_stimulus_set(
                pairs,
                out,
                params=params,
                force=force,
                replaces=replaces,
                progress=progress,
                implants=layouts,
                implant_px_per_electrode=implant_px,
                processes=processes if processes is not None or cluster is not None else 1,
                cluster=cluster,
            )
    finally:
        if bar is not None:
            bar.stop()
    for note in result.notes:
        console.print(f"note: {note}", highlight=False)
    n = len(result.objects)
    per_object_ms = 1000.0 * result.seconds["total"] / max(n, 1)
    ratio = (
        ""
        if result.edge_ratio is None
        else f"; edge ratio {result.edge_ratio:.4f}"
        + (" (mean wide-DOF edge fraction)" if params.edge_ratio is None else " (given)")
    )
    views = (
        f" and {result.n_implant_views} implant views ({', '.join(result.implants)})"
        if result.implants
        else ""
    )
    typer.echo(
        f"wrote {result.n_stimuli} stimuli{views} for {n} objects to {result.out_dir}{ratio}; "
        f"{result.seconds['total']:.1f} s ({per_object_ms:.0f} ms per object)"
    )


@stimuli_app.command("synth")
def synth_command(
    out: Annotated[Path, typer.Option("--out", "-o", help="PAIRS folder to write.")],
    objects: Annotated[int, typer.Option("--objects", min=1, help="Number of main objects.")] = 20,
    training: Annotated[
        int, typer.Option("--training", min=0, help="Number of training objects.")
    ] = 3,
    seed: Annotated[int, seed_option("Random seed (the set is deterministic by seed).")] = 0,
    size: Annotated[
        str, typer.Option("--size", help="Photo size WIDTHxHEIGHT, pixels (e.g. 1536x1024).")
    ] = "492x327",
    force: Annotated[bool, force_option("a PAIRS folder this command wrote before")] = False,
) -> None:
    """Write synthetic wide/narrow-DOF photo pairs of named objects in front of clutter."""
    from stimuli.errors import InputError
    from stimuli.resources import check_memory
    from stimuli.stimset import parse_working_size
    from stimuli.synth import write_pairs

    try:
        shape = parse_working_size(size)
    except InputError:
        raise InputError(
            f"--size must be WIDTHxHEIGHT in pixels (e.g. 492x327), got {size!r}"
        ) from None
    check_memory(shape[0] * shape[1] * _SYNTH_BYTES_PER_PX, f"--size {size}")
    path = write_pairs(
        out,
        n_objects=objects,
        n_training=training,
        seed=seed,
        shape_px=shape,
    )
    typer.echo(f"wrote {objects} + {training} synthetic photo pairs to {path}")


@stimuli_app.command("tune")
def tune_command(
    pairs: _PairsArgument,
    sheet: Annotated[
        Path | None,
        typer.Option(
            "--sheet",
            help="Contact sheet of the candidates to write (PNG; default: tune_sheet.png in "
            "the PAIRS folder).",
            show_default=False,
        ),
    ] = None,
    working_size: _WorkingSizeOption = "492x327",
    dry_run: Annotated[
        bool,
        typer.Option("--dry-run", help="Show the proposals and the sheet; keep objects.csv."),
    ] = False,
) -> None:
    """Propose each object's Sobel threshold, draw the candidates, write them to objects.csv."""
    from stimuli.contact import save_contact_sheet
    from stimuli.errors import InputError
    from stimuli.stimset import parse_working_size, read_pairs
    from stimuli.tune import tune_pairs, tuning_sheet, write_thresholds

    shape = parse_working_size(working_size)
    inp = read_pairs(pairs)
    if pairs.is_dir():
        objects_csv = pairs / "objects.csv"
    else:
        objects_csv = pairs.parent / "objects.csv"
        if objects_csv.resolve() == pairs.resolve():
            raise InputError(
                f"{pairs}: the PAIRS CSV is named objects.csv; rename it (e.g. pairs.csv) so the "
                "thresholds can go into objects.csv beside it"
            )
    sheet = sheet if sheet is not None else inp.root / "tune_sheet.png"
    if sheet.suffix.lower() != ".png":
        raise InputError(f"--sheet must be a .png file, got {str(sheet)!r}")
    results = tune_pairs(pairs, working_shape_px=shape)
    save_contact_sheet(tuning_sheet(results), sheet)
    n = max(6, *(len(r.object) for r in results))
    typer.echo(
        f"{'object':<{n}} {'was':>8} {'proposed':>9} {'wide %':>7} {'narrow %':>9} {'Otsu':>7}"
    )
    for r in results:
        was = "" if r.previous_threshold is None else f"{r.previous_threshold:.4g}"
        typer.echo(
            f"{r.object:<{n}} {was:>8} {r.threshold:>9.4f} {100 * r.wide_edge_fraction:>7.1f} "
            f"{100 * r.narrow_edge_fraction:>9.1f} {r.otsu_threshold:>7.4f}"
        )
    main = [r for r in results if r.role == "main"] or results
    mean_wide = sum(r.wide_edge_fraction for r in main) / len(main)
    typer.echo(
        f"mean wide-DOF edge fraction {mean_wide:.3f} (the set's edge ratio; paper 0.077); "
        f"contact sheet: {sheet}"
    )
    if dry_run:
        typer.echo("dry run: objects.csv not changed")
        return
    write_thresholds(objects_csv, {r.object: r.threshold for r in results})
    typer.echo(f"wrote {len(results)} thresholds to {objects_csv}")


@stimuli_app.command("methods")
def methods_command() -> None:
    """List the de-clutter methods a build's --conditions may name (plug-ins included)."""
    from stimuli.methods import ALIASES, available_methods

    methods, failed = available_methods()
    aliases = {m: a for a, m in ALIASES.items()}
    width = max(len(n) for n in methods)
    base = "the wide-DOF photo's Sobel edges (no method; the baseline)"
    typer.echo(f"{'cluttered':<{width}}  {base}")
    for name, m in methods.items():
        alias = f" [alias: {aliases[name]}]" if name in aliases else ""
        typer.echo(f"{name:<{width}}  {m.description}{alias}")
        typer.echo(f"{'':<{width}}  reference: {m.reference}; {m.source} {m.version}".rstrip())
    for name, why in failed.items():
        typer.echo(f"{name:<{width}}  NOT AVAILABLE: {why}")


def register(app: typer.Typer) -> None:
    """Add the ``stimuli`` command group to the root app.

    The group holds ``build``, ``synth``, ``tune`` and ``methods``.
    """
    app.add_typer(stimuli_app, name="stimuli")
