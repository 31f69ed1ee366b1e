"""Benchmark: ``confocal view`` frames per second, GPU shaders against the CPU pipeline (issue 14).

For each light field, the viewer draws all four panes (centre view, confocal image, edges,
implant phosphenes) and the status line into a 1080x720 frame, once per depth step (the worst
case: every frame refocuses, de-clutters with the automatic threshold and compresses):

- *gpu*: :class:`experiment.viewer.gpu.GpuPipeline` in a headless EGL context (llvmpipe when no
  GPU: the floor);
- *cpu*: the numpy / ``stimuli`` reference pipeline and numpy drawing, in the same process (the
  baseline);
- *gpu redraw*: the same frame drawn again with no change (the cost of a window refresh).

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
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from experiment.viewer.app import LightFieldSource, Viewer  # noqa: E402
from experiment.viewer.gpu import create_headless_context  # noqa: E402

__all__ = ["fps", "main"]


def fps(viewer: Viewer, frames: int, *, step: bool, fbo=None, ctx=None) -> float:
    """Return frames per second of ``frames`` renders (with a depth step before each if asked)."""
    viewer.render(fbo)  # warm-up: shader compile, first upload
    if ctx is not None:
        ctx.finish()
    t0 = time.perf_counter()
    for k in range(frames):
        if step:
            viewer.handle("wheel", {"dy": 1 if (k // 10) % 2 == 0 else -1})
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
    print(f"renderer: {ctx.info['GL_RENDERER']}; frame {w}x{h}, all four panes, Argus II")
    for name, lf in cases:
        src = LightFieldSource(lf)
        gv = Viewer(src, ["argus2"], screen_shape_px=(h, w), ctx=ctx, n_planes=30)
        cv = Viewer(src, ["argus2"], screen_shape_px=(h, w), ctx=None, n_planes=30)
        g = fps(gv, args.frames, step=True, fbo=fbo, ctx=ctx)
        redraw = fps(gv, args.frames, step=False, fbo=fbo, ctx=ctx)
        c = fps(cv, max(3, args.frames // 4), step=True)
        print(
            f"{name:24s} gpu {g:7.1f} fps   gpu redraw {redraw:7.1f} fps   "
            f"cpu {c:6.1f} fps   gpu/cpu {g / c:5.1f}x"
        )
        gv.close()
        cv.close()
    fbo.release()
    ctx.release()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
