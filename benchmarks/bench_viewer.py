"""Benchmark: ``confocal view`` frames per second, GPU shaders against the CPU pipeline.

For each light field, the viewer draws all four panes (centre view, confocal image, edges,
implant phosphenes) and the status line into a 1080x720 frame. *scan*: a new depth every frame
(the worst case: every frame refocuses, de-clutters with the automatic threshold, compresses
and draws); *revisit*: depths already shown (their confocal images and automatic thresholds
are cached; depths refocused ahead while the window is idle, ``Viewer.prefetch``, have the
image but not yet the threshold); *redraw*: no change.

- *gpu*: :class:`experiment.viewer.gpu.GpuPipeline` in a headless EGL context (llvmpipe when no
  GPU: the floor);
- *cpu*: the numpy / ``stimuli`` reference pipeline and numpy drawing, in the same process (the
  baseline);
- *window default*: what ``confocal view`` uses (``compute='auto'``: the numpy pipeline on a
  software rasteriser, its frame copied into the GL framebuffer; the shaders on a GPU);

Light fields: the Lytro Illum 7x7x383x552 views in ``$CONFOCAL_DATA/lightfield/
lytro_illum_2067_epinet`` (skipped when absent) and the simulated three-plane scene as a
9x9x512x512 camera array. Reported as fps and as the GPU/CPU speed ratio.

Run: ``python benchmarks/bench_viewer.py [--frames 20] [--size 1080x720]``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from experiment.viewer.app import LightFieldSource, Viewer  # noqa: E402
from experiment.viewer.gpu import create_headless_context  # noqa: E402

__all__ = ["fps", "main"]


def fps(viewer: Viewer, frames: int, *, mode: str, fbo=None, ctx=None) -> float:
    """Return frames per second of ``frames`` renders.

    ``mode``: ``scan`` (a new depth every frame: refocus, de-clutter, compress, draw),
    ``revisit`` (depths already shown: the GPU's cached confocal images) or ``redraw`` (no
    change: the cost of a window refresh).
    """
    viewer.render(fbo)  # warm-up: shader compile, first upload
    if ctx is not None:
        ctx.finish()
    lo, hi = viewer.model.disparity_range_px
    mid = 0.5 * (lo + hi)
    if mode == "revisit":  # visit the depths once first
        for k in range(frames):
            viewer.state = replace(viewer.state, disparity_px=mid + 1e-3 * k)
            viewer.render(fbo)
    t0 = time.perf_counter()
    for k in range(frames):
        if mode == "scan":
            viewer.state = replace(viewer.state, disparity_px=mid + 0.37 * (k + 1) / frames)
        elif mode == "revisit":
            viewer.state = replace(viewer.state, disparity_px=mid + 1e-3 * k)
        viewer.render(fbo)
        if ctx is not None:
            ctx.finish()
    return frames / (time.perf_counter() - t0)


def main(argv: list[str] | None = None) -> int:
    """Print fps for each light field and renderer."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--size", default="1080x720")
    args = ap.parse_args(argv)
    w, h = (int(v) for v in args.size.split("x"))
    from stimuli.lfsynth import render_camera_array, three_plane_scene
    from stimuli.lightfield import load_lightfield

    cases = []
    data = Path(os.environ.get("CONFOCAL_DATA", REPO.parent / "shared" / "data"))
    lytro = data / "lightfield" / "lytro_illum_2067_epinet"
    if lytro.is_dir():
        cases.append(("lytro 7x7x383x552", load_lightfield(lytro).gray()))
    else:
        print(f"(no {lytro}: Lytro case skipped)")
    shape = (512, 512)
    synth = render_camera_array(three_plane_scene(shape, rng=0), shape_px=shape, baseline_m=0.03)
    cases.append(("simulated 9x9x512x512", synth.gray()))

    ctx = create_headless_context()
    fbo = ctx.simple_framebuffer((w, h))
    print(
        f"renderer: {ctx.info['GL_RENDERER']}; frame {w}x{h}, all four panes, Argus II; "
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs"
    )
    for name, lf in cases:
        src = LightFieldSource(lf)
        gv = Viewer(src, ["argus2"], screen_shape_px=(h, w), ctx=ctx, n_planes=30, compute="gpu")
        av = Viewer(src, ["argus2"], screen_shape_px=(h, w), ctx=ctx, n_planes=30)
        cv = Viewer(src, ["argus2"], screen_shape_px=(h, w), ctx=None, n_planes=30)
        g = fps(gv, args.frames, mode="scan", fbo=fbo, ctx=ctx)
        rv = fps(gv, args.frames, mode="revisit", fbo=fbo, ctx=ctx)
        rd = fps(gv, args.frames, mode="redraw", fbo=fbo, ctx=ctx)
        c = fps(cv, max(3, args.frames // 4), mode="scan")
        a = fps(av, args.frames, mode="scan", fbo=fbo, ctx=ctx)
        print(
            f"{name:24s} gpu scan {g:6.1f} fps  revisit {rv:6.1f} fps  redraw {rd:6.1f} fps  "
            f"| cpu scan {c:5.1f} fps  | gpu/cpu scan {g / c:4.1f}x  "
            f"| window default ({av.compute}) scan {a:5.1f} fps"
        )
        av.close()
        gv.close()
        cv.close()
    fbo.release()
    ctx.release()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
