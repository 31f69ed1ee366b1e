"""The depth scan as a figure: score versus depth or disparity, planes marked (Fig. 15)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_scores"]


def plot_scores(scan, path: Path, *, size_in: tuple[float, float] = (7.0, 3.6)) -> Path:
    """Draw the score versus depth (or disparity) as a PNG with matplotlib (Fig. 15).

    Detected planes are marked and labelled; the agreement scan's null is drawn dashed. Uses
    ``matplotlib.figure.Figure`` directly, so no backend is chosen and nothing is shown.
    Returns the written path.
    """
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    from stimuli.io import atomic_path

    use_depth = scan.depths_m is not None and bool(np.all(np.isfinite(scan.depths_m)))
    xs = np.asarray(scan.depths_m if use_depth else scan.disparities_px, dtype=float)
    order = np.argsort(xs)
    fig = Figure(figsize=size_in, dpi=100, layout="constrained")
    ax = fig.subplots()
    label = (
        "fraction of pixels whose views agree best here"
        if scan.method == "agreement"
        else "fraction of edge pixels coinciding with the centre view"
    )
    ax.plot(xs[order], np.asarray(scan.scores)[order], color="#00468c", lw=1.5, label=label)
    if scan.null_scores is not None:
        ax.plot(
            xs[order],
            np.asarray(scan.null_scores)[order],
            color="0.5",
            lw=1.0,
            ls="--",
            label="null (non-coincident reference)",
        )
    for p in scan.peaks:
        xv = p.depth_m if use_depth else p.disparity_px
        ax.plot([xv], [p.score], "o", color="#c80000", ms=5)
        ax.annotate(
            f"{xv:.3g}", (xv, p.score), textcoords="offset points", xytext=(4, 4), color="#c80000"
        )
    ax.set_xlabel("depth (m)" if use_depth else "disparity (px per view step)")
    ax.set_ylabel("score")
    ax.xaxis.set_major_locator(MaxNLocator(nbins=8))
    ax.yaxis.set_major_locator(MaxNLocator(nbins=5))
    top = max(float(np.max(scan.scores)), 1e-9)
    ax.set_ylim(0, 1.3 * top)  # room for the legend above the peaks
    ax.grid(True, color="0.9")
    ax.legend(loc="upper right", fontsize="small", frameon=False)
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    return path
