"""The presenter's command: ``confocal present``.

``confocal present --protocol P --stimulus IMG --screenshot OUT.png`` renders one offscreen frame
at the protocol's full screen resolution, exactly as the subject's screen would show it (EGL, no
window needed). Without ``--screenshot`` it opens the subject's window and shows the stimulus
until the window is closed or ``--seconds`` pass.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from experiment.errors import ConfocalError
from stimuli.cli import seed_option
from stimuli.resources import check_memory, finite_option, parse_pair

if TYPE_CHECKING:
    import numpy as np

__all__ = ["register", "load_stimulus", "geometry_from_options"]


def load_stimulus(path: Path) -> np.ndarray:
    """Read a stimulus image: bool if it has only black and white pixels, else float32 [0, 1]."""
    import numpy as np

    from stimuli.io import load_gray

    img = load_gray(path)
    return img >= 0.5 if np.isin(img, (0.0, 1.0)).all() else img


def _pair(text: str, name: str, cast: type = float) -> tuple:
    return parse_pair(text, f"--{name} must look like WIDTHxHEIGHT", cast=cast, error=ConfocalError)


def geometry_from_options(
    protocol: Path | None,
    *,
    screen_px: str | None = None,
    screen_width_cm: float | None = None,
    distance_cm: float | None = None,
    image_cm: str | None = None,
    border_rgb: str | None = None,
    border_width_px: int | None = None,
    gamma: float | None = None,
    monitor: str | None = None,
):
    """Return the ScreenGeometry of a protocol file (or the paper's), with explicit overrides.

    A monitor profile (``monitor``: a name in ``protocols/monitors`` or a file) replaces the
    protocol's width, distance, resolution and gamma; the single-value options override both.
    """
    from experiment.presentation.presenter import ScreenGeometry

    if monitor is not None:
        from experiment.data.monitors import apply_monitor, load_monitor
        from experiment.protocol import DisplaySpec, load_protocol

        display = load_protocol(protocol).display if protocol is not None else DisplaySpec()
        kw = ScreenGeometry.from_display_spec(
            apply_monitor(display, load_monitor(monitor)[0])
        ).to_dict()
    elif protocol is not None:
        from experiment.protocol import load_protocol

        kw = ScreenGeometry.from_display_spec(load_protocol(protocol).display).to_dict()
    else:
        kw = ScreenGeometry.jung2015().to_dict()
    if screen_px:
        w, h = _pair(screen_px, "screen-px", int)
        kw["screen_shape_px"] = (h, w)
    if screen_width_cm is not None:
        kw["screen_width_cm"] = screen_width_cm
    if distance_cm is not None:
        kw["viewing_distance_cm"] = distance_cm
    if image_cm:
        w, h = _pair(image_cm, "image-cm")
        kw["image_size_cm"] = (h, w)
    if border_rgb:
        try:
            kw["border_rgb"] = tuple(int(v) for v in border_rgb.split(","))
        except ValueError:
            raise ConfocalError(
                f"--border-rgb must look like 0,0,255, got {border_rgb!r}"
            ) from None
    if border_width_px is not None:
        kw["border_width_px"] = None if border_width_px < 0 else border_width_px
    if gamma is not None:
        kw["gamma"] = gamma
    try:
        return ScreenGeometry.from_dict(kw)
    except ValueError as exc:
        raise ConfocalError(f"display geometry: {exc}") from None


_positive = finite_option(0.0, lo_open=True)


def register(app: typer.Typer) -> None:
    """Add ``present`` to the root ``confocal`` app."""

    @app.command("present")
    def present(
        stimulus: Annotated[Path, typer.Option("--stimulus", help="Stimulus image (PNG).")],
        protocol: Annotated[
            Path | None,
            typer.Option(
                help="Protocol TOML whose \\[display] sets the geometry (default: paper's)."
            ),
        ] = None,
        screenshot: Annotated[
            Path | None, typer.Option(help="Render one offscreen frame to this PNG and exit.")
        ] = None,
        monitor: Annotated[
            str | None,
            typer.Option(help="Monitor profile (name in protocols/monitors, or a .toml file)."),
        ] = None,
        screen_px: Annotated[str | None, typer.Option(help="Override: 1280x1024.")] = None,
        screen_width_cm: Annotated[
            float | None, typer.Option(callback=_positive, help="Override, cm.")
        ] = None,
        distance_cm: Annotated[
            float | None, typer.Option(callback=_positive, help="Override, cm.")
        ] = None,
        image_cm: Annotated[str | None, typer.Option(help="Override: 14.6x9.7 (cm).")] = None,
        border_rgb: Annotated[str | None, typer.Option(help="Override: 0,0,255.")] = None,
        border_width_px: Annotated[
            int | None, typer.Option(help="Frame width; -1 fills the whole surround.")
        ] = None,
        gamma: Annotated[
            float | None, typer.Option(callback=_positive, help="Display gamma (default 1).")
        ] = None,
        integer_scale: Annotated[
            bool, typer.Option(help="Equal-size cells (size off by < half a cell).")
        ] = False,
        phosphenes: Annotated[str | None, typer.Option(help="gaussian or disc.")] = None,
        phosphene_size: Annotated[
            float, typer.Option(callback=_positive, help="Fraction of the spacing.")
        ] = 0.8,
        dropout: Annotated[
            float,
            typer.Option(
                callback=finite_option(0.0, 1.0, hi_open=True),
                help="Fraction of dead phosphenes, in [0, 1).",
            ),
        ] = 0.0,
        phosphene_spacing_deg: Annotated[
            float | None, typer.Option(callback=_positive, help="Degrees.")
        ] = None,
        seed: Annotated[int, seed_option("Seed of the dropout pattern.")] = 0,
        implant: Annotated[
            str | None,
            typer.Option(
                help="Show as this implant's phosphenes: argus2, alpha_ims, ... or .toml "
                "(default: the protocol's [display] implant, if any)."
            ),
        ] = None,
        screen: Annotated[int | None, typer.Option(help="Screen index of the window.")] = None,
        fullscreen: Annotated[bool, typer.Option("--fullscreen/--window")] = False,
        seconds: Annotated[
            float | None,
            typer.Option(callback=finite_option(0.0), help="Close after this long."),
        ] = None,
        skip_timing_check: Annotated[bool, typer.Option("--skip-timing-check")] = False,
    ) -> None:
        """Show one stimulus as the subject would see it, or render it offscreen (--screenshot)."""
        if not phosphenes and (dropout != 0.0 or phosphene_spacing_deg is not None):
            raise ConfocalError("--dropout and --phosphene-spacing-deg need --phosphenes")
        if screenshot is not None and screenshot.is_dir():
            raise ConfocalError(f"--screenshot {screenshot} is a folder; expected a PNG file path")
        geometry = geometry_from_options(
            protocol,
            screen_px=screen_px,
            screen_width_cm=screen_width_cm,
            distance_cm=distance_cm,
            image_cm=image_cm,
            border_rgb=border_rgb,
            border_width_px=border_width_px,
            gamma=gamma,
            monitor=monitor,
        )
        rows, cols = geometry.screen_shape_px
        # the framebuffer, its read-back and the PNG: a few RGBA copies of the screen
        check_memory(rows * cols * 4 * 4, f"screen {cols}x{rows} px")
        image = load_stimulus(stimulus)
        from experiment.presentation.presenter import PhospheneSpec, Presenter, stimulus_rect_px

        implant_phos = None
        layout = None
        if implant is not None:
            from stimuli.implants import load_implant

            layout = load_implant(implant)
        elif protocol is not None:  # the protocol's [display] implant, as its sessions show it
            from experiment.protocol import load_protocol

            layout = load_protocol(protocol).display.implant_layout
        if layout is not None:
            # The stimulus resampled to the implant's grid (binary: the paper's compression;
            # grey: window means at the implant's brightness levels) and drawn as its
            # phosphenes at its field of view.
            from experiment.presentation.implant import phosphene_spec
            from stimuli.implants import to_implant_grid

            image = to_implant_grid(image, layout)
            implant_phos = phosphene_spec(layout)

        try:
            if implant_phos is not None:
                phos = implant_phos
            elif phosphenes:
                phos = PhospheneSpec(
                    phosphenes, phosphene_size, dropout, phosphene_spacing_deg, seed
                )
            else:
                phos = None
            rect = stimulus_rect_px(
                geometry, image.shape, integer_scale=integer_scale, phosphenes=phos
            )
        except ValueError as exc:
            raise ConfocalError(str(exc)) from None
        kw = dict(integer_scale=integer_scale, phosphenes=phos)
        if screenshot is not None:
            with Presenter.offscreen(geometry, **kw) as p:
                p.show_stimulus(image)
                p.screenshot(screenshot)
        else:
            import time

            with Presenter.windowed(geometry, screen=screen, fullscreen=fullscreen, **kw) as p:
                hz = p.measure_refresh(check=not skip_timing_check)
                p.show_stimulus(image)
                t0 = time.perf_counter()
                while not p.window.is_closing:
                    p.pump()
                    if seconds is not None and time.perf_counter() - t0 >= seconds:
                        break
                    if skip_timing_check:
                        time.sleep(1 / 60)
                off = p.clear()
            typer.echo(
                f"refresh {hz:.2f} Hz; {len(off.frame_intervals_ms)} frames, "
                f"{off.dropped_frames} dropped",
                err=True,
            )
        top, left, rows, cols = rect
        typer.echo(
            f"{geometry.screen_shape_px[1]}x{geometry.screen_shape_px[0]} px screen, "
            f"{geometry.px_per_cm:.2f} px/cm, {geometry.px_per_deg:.2f} px/deg; stimulus "
            f"{image.shape[1]}x{image.shape[0]} drawn at {cols}x{rows} px from ({left}, {top})"
            + (f" -> {screenshot}" if screenshot is not None else "")
        )
