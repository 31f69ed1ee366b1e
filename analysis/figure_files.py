"""Saving figures to files: the layout once, one drawing per file, a fast PNG (matplotlib).

:func:`save_figures` writes each figure as a 300 dpi PNG, a PDF and, when asked for, an SVG
(:mod:`analysis.figure_formats`); :mod:`analysis.figures` draws them.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from analysis.figure_formats import DEFAULT_FIGURE_FORMATS, FIGURE_FORMATS

__all__ = ["PNG_DPI", "save_figures", "load_backends"]

#: Resolution of the PNG files, dots per inch: what journals ask of raster figures.
PNG_DPI: int = 300


def load_backends(formats: tuple[str, ...]) -> None:
    """Import the backends that ``formats`` use and load the default font.

    Called before forking a worker process, so that it is done once, for both processes.

    Parameters
    ----------
    formats : tuple of str
        File formats (:data:`analysis.figure_formats.FIGURE_FORMATS`).
    """
    import importlib

    from matplotlib import font_manager

    for ext in formats:
        importlib.import_module(f"matplotlib.backends.backend_{'agg' if ext == 'png' else ext}")
    importlib.import_module("analysis.pngfile")
    font_manager.get_font(font_manager.findfont(font_manager.FontProperties()))


def save_figures(
    figs: dict[str, Any],
    folder: str | Path,
    formats: tuple[str, ...] = DEFAULT_FIGURE_FORMATS,
) -> list[Path]:
    """Save each figure in ``formats``: a 300 dpi PNG, a PDF and (when asked for) an SVG.

    The layout is computed once per figure, not once per file, and the saved area is grown to
    every label (as ``bbox_inches='tight'``, so a long axis label is never clipped), measured
    once. The layout, that measure and the PNG use one 300 dpi renderer, so each text's size is
    measured once; the PNG is the figure drawn once, cut to that area and written as RGB (the
    figure is opaque) by :func:`analysis.pngfile.write_png`, a third of the encoding time.

    Parameters
    ----------
    figs : dict of str to Figure
        File stem -> figure.
    folder : str or Path
        Existing folder.
    formats : tuple of str
        Some of :data:`analysis.figure_formats.FIGURE_FORMATS`, written in that order.

    Returns
    -------
    list of Path
        Files written.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    folder = Path(folder)
    written = []
    for name, fig in figs.items():
        fig.set_dpi(PNG_DPI)
        canvas = FigureCanvasAgg(fig)
        renderer = canvas.get_renderer()
        engine = fig.get_layout_engine()
        if engine is not None:
            engine.execute(fig)  # the layout, once (a draw would run it and draw everything)
            # No engine at all: "none" leaves a placeholder, and savefig draws a figure that has
            # any engine once more, unseen, before drawing it into the file.
            fig.set_layout_engine("none")
            fig._layout_engine = None
        if "png" in formats:
            canvas.draw()  # the PNG's pixels; the measure below reuses its text sizes
        _fix_best_legends(fig, renderer)
        area = fig.get_tightbbox(renderer).padded(0.04)
        for ext in (f for f in FIGURE_FORMATS if f in formats):
            p = folder / f"{name}.{ext}"
            if ext != "png" or not _save_png(canvas, area, p):
                # zlib level 1: a fifth larger than the default 6, and its encoding half the time
                extra = {"pil_kwargs": {"compress_level": 1}} if ext == "png" else {}
                fig.savefig(p, dpi=PNG_DPI, bbox_inches=area, **extra)
            written.append(p)
    return written


def _fix_best_legends(fig: Any, renderer: Any) -> None:
    """Pin each legend placed "best" where it now stands, so later drawings do not search again.

    The search tries every corner against every data point of the axes, on every drawing; the
    place, kept as a fraction of the anchoring box, is the same at every resolution.
    """
    legends = [ax.get_legend() for ax in fig.axes] + list(fig.legends)
    for leg in legends:
        if leg is None or getattr(leg, "_loc", None) != 0:  # 0: "best"
            continue
        box, anchor = leg.get_window_extent(renderer), leg.get_bbox_to_anchor()
        leg.set_loc(
            (
                float((box.x0 - anchor.x0) / anchor.width),
                float((box.y0 - anchor.y0) / anchor.height),
            )
        )


def _save_png(canvas: Any, area: Any, path: Path) -> bool:
    """Write the figure ``canvas`` has drawn, cut to ``area`` (inches), as an RGB PNG.

    Returns False (nothing written) when ``area`` reaches outside the figure, where a label
    sticks out: matplotlib's ``savefig`` then draws the grown area.
    """
    from analysis.pngfile import write_png

    fig = canvas.figure
    width, height = canvas.get_width_height(physical=True)
    x0, y0, x1, y1 = (v * fig.dpi for v in area.extents)
    left, right = math.floor(x0), math.ceil(x1)
    top, bottom = math.floor(height - y1), math.ceil(height - y0)  # rows count from the top
    if left < 0 or top < 0 or right > width or bottom > height:
        return False
    rgba = np.asarray(canvas.buffer_rgba())
    software = f"Matplotlib version{_mpl_version()}, https://matplotlib.org/"
    write_png(path, rgba[top:bottom, left:right, :3], dpi=PNG_DPI, text={"Software": software})
    return True


def _mpl_version() -> str:
    import matplotlib

    return matplotlib.__version__
