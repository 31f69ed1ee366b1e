"""``confocal view LIGHTFIELD``: the live active-confocal viewer.

Without ``--screenshot`` it opens a window (moderngl-window); with ``--screenshot OUT.png`` it
renders one state offscreen (EGL, or ``--cpu`` with numpy only) and exits, so the viewer runs in
scripts and tests with no display. Options set the first state (``--disparity``, ``--plane``,
``--zoom``, ``--implant``, ``--grey-levels``, ``--threshold``, ``--obstacle``, ``--marker``); a
``--script`` file of JSON-lines events is then applied through the same handler as keys and
mouse; ``--log`` appends every event and displayed state to an SQLite file. ``--help`` groups
the options (Input, View, Implant, Modes, Output) and lists the window's keys.

The checks of the start options are the library's
(:meth:`experiment.viewer.app.Viewer.from_options`); this module parses the options and maps
the library's parameter names to the flags (:data:`FLAGS`). ``--levels`` is the old spelling of
``--grey-levels``, still read and hidden from ``--help``.
"""

from __future__ import annotations

from functools import partial
from pathlib import Path
from typing import Annotated

import typer

from experiment.errors import ConfocalError
from stimuli.resources import MAX_PLANES, finite_option, parse_pair

__all__ = ["FLAGS", "register", "view_command"]

#: The flag of each parameter of :meth:`experiment.viewer.app.Viewer.from_options`.
FLAGS: dict[str, str] = {
    "implants": "--implant",
    "grey_levels": "--grey-levels",
    "threshold": "--threshold",
    "disparity_px": "--disparity",
    "plane": "--plane",
    "zoom": "--zoom",
    "obstacle_px": "--obstacle",
    "marker": "--marker",
    "extension_px": "--extension",
    "compute": "--compute",
}


def _as_flag(exc: Exception, parameter: str) -> ConfocalError:
    # the library's one line, its parameter name replaced by the flag
    msg = str(exc)
    flag = FLAGS.get(parameter)
    if flag is not None and msg.startswith(parameter):
        msg = flag + msg[len(parameter) :]
    return ConfocalError(msg)


def _ints(text: str, n: int, option: str) -> tuple[int, ...]:
    try:
        vals = tuple(int(v) for v in text.split(","))
    except ValueError:
        vals = ()
    if len(vals) != n:
        raise ConfocalError(f"{option} must be {n} comma-separated integers, got {text!r}")
    return vals


def _size(text: str) -> tuple[int, int]:
    w, h = parse_pair(text, "--size must be WIDTHxHEIGHT like 1080x720", error=ConfocalError)
    if w < 160 or h < 120:
        raise ConfocalError(f"--size must be at least 160x120, got {text!r}")
    return h, w


# the option groups of ``confocal view --help``
_input_option = partial(typer.Option, rich_help_panel="Input")
_view_option = partial(typer.Option, rich_help_panel="View")
_implant_option = partial(typer.Option, rich_help_panel="Implant")
_modes_option = partial(typer.Option, rich_help_panel="Modes")
_output_option = partial(typer.Option, rich_help_panel="Output")


def view_command(
    lightfield: Annotated[
        Path,
        typer.Argument(help="Folder of views, .npy/.npz, elemental image, or folder of frames."),
    ],
    implant: Annotated[
        list[str] | None,
        _implant_option(
            "--implant", help="Implant name or .toml (repeat: the i key cycles). Default: all."
        ),
    ] = None,
    screenshot: Annotated[
        Path | None, _output_option(help="Render one state offscreen to this PNG and exit.")
    ] = None,
    cpu: Annotated[bool, _view_option("--cpu", help="Render with numpy (no OpenGL).")] = False,
    compute: Annotated[
        str,
        _view_option(
            "--compute",
            help="Where refocus, Sobel and compression run: auto (numpy on a software "
            "rasteriser such as llvmpipe, where it is faster; else shaders), gpu or cpu.",
        ),
    ] = "auto",
    size: Annotated[str, _view_option(help="Frame size WIDTHxHEIGHT.")] = "1080x720",
    disparity: Annotated[
        float | None,
        _view_option(
            callback=finite_option(), help="Start depth, px per view step (default: nearest plane)."
        ),
    ] = None,
    plane: Annotated[
        int | None, _view_option(min=1, help="Start at detected plane N (1 = nearest).")
    ] = None,
    zoom: Annotated[str | None, _view_option(help="Zoom box x,y,w,h (view pixels).")] = None,
    grey_levels: Annotated[
        int, _view_option("--grey-levels", help="2: binary edges; 4 or 8: grey levels.")
    ] = 2,
    old_levels: Annotated[
        int | None, typer.Option("--levels", hidden=True, help="Old name of --grey-levels.")
    ] = None,
    threshold: Annotated[str, _view_option(help="Sobel threshold: auto or a number.")] = "auto",
    obstacle: Annotated[
        str | None, _modes_option(help="Obstacle mode: FAR:NEAR disparity range, px per view.")
    ] = None,
    marker: Annotated[
        str | None, _modes_option(help="Confocal extension: marked point x,y (view pixels).")
    ] = None,
    extension: Annotated[
        float,
        _modes_option(
            callback=finite_option(),
            help="Extension: focus this many px/view nearer than the marker.",
        ),
    ] = 0.0,
    track_bright: Annotated[
        bool, _modes_option(help="Extension: follow the brightest spot as the marker.")
    ] = False,
    average: Annotated[bool, _modes_option(help="Temporal averaging of the implant view.")] = False,
    px_per_deg: Annotated[
        float | None,
        _implant_option(
            callback=finite_option(0.0, lo_open=True),
            help="Draw the implant's field of view at this px/deg.",
        ),
    ] = None,
    planes: Annotated[
        int,
        _view_option(
            min=3,
            max=MAX_PLANES,
            help="Planes of the startup depth scan (at the default, the scan 'stimuli build' "
            "and 'lightfield scan' use).",
        ),
    ] = 200,
    script: Annotated[
        Path | None, _modes_option(help="JSON-lines events to apply (one per frame in a window).")
    ] = None,
    log: Annotated[
        Path | None, _output_option(help="Append events and states to this SQLite.")
    ] = None,
    shots: Annotated[
        Path | None, _output_option(help="Window: save a PNG after each scripted event here.")
    ] = None,
    seconds: Annotated[
        float | None,
        _view_option(callback=finite_option(0.0), help="Window: close after this long."),
    ] = None,
    video_fps: Annotated[
        float,
        _modes_option(callback=finite_option(0.0), help="Video: frames per second (0: keys)."),
    ] = 0.0,
    p2p: Annotated[
        str | None,
        _output_option(
            help="With --screenshot: also write NAME_p2p.png, the implant view through "
            "pulse2percept's scoreboard or axonmap model (the p2p extra)."
        ),
    ] = None,
    pattern: Annotated[str | None, _input_option(help="View file-name pattern.")] = None,
    grid_cols: Annotated[int | None, _input_option(help="Grid columns for {index}.")] = None,
    pitch: Annotated[int | None, _input_option(help="Elemental image: lenslet pitch, px.")] = None,
    border: Annotated[int | None, _input_option(help="Elemental image: border, px.")] = None,
    offset: Annotated[
        str | None, _input_option(help="Elemental image: ROW,COL pixels before the first lens.")
    ] = None,
    view_crop: Annotated[
        str,
        _input_option(
            help="Crop every view first: auto (leave out the capture's dark vignette rim and "
            "clipped strip, found in the data as lightfield scan and stimuli build find it), "
            "none, or x,y,w,h."
        ),
    ] = "auto",
) -> None:
    """Scan depth, jump to object planes, zoom and see the implant's view, live."""
    from experiment.viewer.app import Viewer
    from experiment.viewer.events import ViewerEventLog
    from experiment.viewer.options import ViewerOptionError, check_options
    from experiment.viewer.source import open_source, read_script
    from stimuli.stimset import parse_threshold

    if old_levels is not None:
        if grey_levels not in (2, old_levels):
            raise ConfocalError("--levels is the old name of --grey-levels: give one of them")
        grey_levels = old_levels
    shape = _size(size)
    t = parse_threshold(threshold)
    try:  # one-line errors before anything is opened
        names = check_options(
            implant, grey_levels=grey_levels, threshold=t, compute=compute, extension_px=extension
        )
    except ViewerOptionError as exc:
        raise _as_flag(exc, exc.parameter) from None
    events = read_script(script) if script is not None else []
    if log is not None and not log.parent.is_dir():
        raise ConfocalError(f"--log {log}: folder {log.parent} does not exist")
    if screenshot is not None and screenshot.suffix.lower() != ".png":
        raise ConfocalError(f"--screenshot must name a .png file, got {screenshot}")
    if p2p is not None:
        from experiment.viewer.p2p import P2P_MODELS

        if screenshot is None:
            raise ConfocalError("--p2p needs --screenshot (it renders a still)")
        if p2p not in P2P_MODELS:
            raise ConfocalError(f"--p2p must be one of {P2P_MODELS}, got {p2p!r}")
    zoom_box = _ints(zoom, 4, "--zoom") if zoom is not None else None
    marker_xy = _ints(marker, 2, "--marker") if marker is not None else None
    obstacle_px = None
    if obstacle is not None:
        try:
            far, near = (float(x) for x in obstacle.split(":"))
        except ValueError:
            raise ConfocalError(f"--obstacle must be FAR:NEAR, got {obstacle!r}") from None
        obstacle_px = (far, near)
    crop: tuple[int, ...] | str | None
    if view_crop in ("auto", "none"):
        crop = None if view_crop == "none" else "auto"
    else:
        crop = _ints(view_crop, 4, "--view-crop")
    off = _ints(offset, 2, "--offset") if offset is not None else None
    source = open_source(
        lightfield,
        view_crop=crop,
        pattern=pattern,
        grid_cols=grid_cols,
        pitch_px=pitch,
        border_px=border,
        offset_px=off,
    )

    def make(ctx):
        try:
            return Viewer.from_options(
                source,
                names,
                grey_levels=grey_levels,
                threshold=t,
                disparity_px=disparity,
                plane=plane,
                zoom=zoom_box,  # type: ignore[arg-type]
                obstacle_px=obstacle_px,
                marker=marker_xy,  # type: ignore[arg-type]
                extension_px=extension,
                averaging=average,
                compute=compute,
                screen_shape_px=shape,
                ctx=ctx,
                event_log=ViewerEventLog(log) if log is not None else None,
                px_per_deg=px_per_deg,
                n_planes=planes,
                track_bright=track_bright,
            )
        except ViewerOptionError as exc:
            raise _as_flag(exc, exc.parameter) from None

    if screenshot is None:
        from experiment.viewer.window import run_window

        n = run_window(
            make,
            size_px=shape,
            seconds=seconds,
            script=events,
            shots_dir=shots,
            video_fps=video_fps,
            confirm_quit=log is not None,
        )
        typer.echo(f"{n} frames shown", err=True)
        return
    ctx = None
    if not cpu:
        from experiment.viewer.gpu import GpuError, create_headless_context

        try:
            ctx = create_headless_context()
        except GpuError as exc:  # the product never requires a GPU, nor even GL
            typer.echo(f"confocal view: {exc}; drawing with the CPU pipeline", err=True)
    v = make(ctx)
    try:
        for ev in events:
            v.handle(ev["kind"], ev["payload"])
        v.screenshot(screenshot)
        line = f"{v.status_text()} -> {screenshot}"
        if p2p is not None:
            from experiment.viewer.p2p import p2p_percept
            from stimuli.io import save_png

            depth = v.depth() if v.state.mode == "obstacle" else None
            cells = v.renderer.render(v.state, layout=v.layout, depth=depth).cells
            percept = p2p_percept(cells * v.layout.alive_mask(), v.layout, model=p2p)
            out = save_png(percept, screenshot.with_name(screenshot.stem + "_p2p.png"))
            line += f"; pulse2percept {p2p} -> {out}"
    finally:
        v.close()
        if ctx is not None:
            ctx.release()
    typer.echo(line)


def _key_epilog() -> str:
    from experiment.viewer.state import KEY_HELP

    # typer's rich help keeps line breaks only between paragraphs
    return "Keys in the window:\n\n" + "\n\n".join(f"{k}: {v}" for k, v in KEY_HELP)


def register(app: typer.Typer) -> None:
    """Add ``view`` to the root ``confocal`` app (options grouped, keys in the epilog)."""
    app.command("view", epilog=_key_epilog())(view_command)
