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

*keys*: what a user sees. A driver sends arrow keys (depth steps, alternating runs up and
down) through :meth:`Viewer.handle`, the path the window's key callback takes, and each key's
frame is drawn into a GL framebuffer with the window's default pipeline: frames per second,
median of ``--repeats`` runs, idle and with both cores kept busy by two spinning processes
(``--busy``). ``--window`` instead runs ``confocal view`` in a real window (under its own Xvfb
when there is no ``DISPLAY``) and types the keys through the X server
(:class:`experiment.viewer.xdriver.XDriver`), counting the frames the window showed.

Run: ``python benchmarks/bench_viewer.py [--frames 20] [--size 1920x1080] [--keys-only]
[--busy] [--window]``.
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

from experiment.viewer.app import Viewer  # noqa: E402
from experiment.viewer.gpu import create_headless_context  # noqa: E402
from experiment.viewer.source import LightFieldSource  # noqa: E402

__all__ = ["fps", "key_fps", "busy_cores", "window_fps", "main"]


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


def key_fps(viewer: Viewer, keys: int, *, fbo=None, ctx=None, back_and_forth: bool = True) -> float:
    """Frames per second when every frame follows one arrow key (a depth step).

    ``back_and_forth``: runs of 10 ``up`` then 10 ``down`` keys, as a user scanning back and
    forth (the steps back revisit depths already refocused, which the numpy pipeline keeps, as
    in the window); else only ``up``: every key a new depth (the worst case).
    """
    viewer.render(fbo)
    if ctx is not None:
        ctx.finish()
    t0 = time.perf_counter()
    for k in range(keys):
        up = (k // 10) % 2 == 0 or not back_and_forth
        viewer.handle("key", {"key": "up" if up else "down"})
        viewer.render(fbo)
        if ctx is not None:
            ctx.finish()
    return keys / (time.perf_counter() - t0)


class busy_cores:  # noqa: N801 - a context manager used like a function
    """Context: keep ``n`` CPU cores busy with spinning subprocesses (the load of a shared box)."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.procs: list = []

    def __enter__(self) -> busy_cores:
        import subprocess

        self.procs = [
            subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(self.n)
        ]
        time.sleep(0.5)
        return self

    def __exit__(self, *exc) -> None:
        for p in self.procs:
            p.kill()
            p.wait()


def window_fps(lightfield: Path, size: str, seconds: float, display: str) -> float:
    """Frames per second of ``confocal view`` in a window while a driver types arrow keys."""
    import subprocess

    from experiment.viewer.xdriver import XDriver

    code = "import sys; from experiment.cli import main; main(sys.argv[1:])"
    proc = subprocess.Popen(
        [sys.executable, "-c", code, "view", str(lightfield), "--implant", "argus2",
         "--size", size, "--planes", "30"],
        env={**os.environ, "DISPLAY": display, "PYTHONPATH": str(REPO)},
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    drv = XDriver(display)
    try:
        win = drv.find("confocal view", timeout_s=120)
        drv.focus(win)
        time.sleep(1.0)  # let the first frame draw
        drv.press("v")  # a key that redraws: mark the start in the frame count below
        n0 = time.perf_counter()
        k = 0
        while time.perf_counter() - n0 < seconds:
            drv.press("Up" if (k // 10) % 2 == 0 else "Down", hold_s=0.0)
            k += 1
            time.sleep(0.004)
        elapsed = time.perf_counter() - n0
        drv.press("q")
        err = proc.communicate(timeout=60)[1]
    finally:
        if proc.poll() is None:
            proc.kill()
        drv.close()
    shown = [int(line.split()[0]) for line in err.splitlines() if line.endswith("frames shown")]
    # the frames shown include the first one and those of the start key
    return (shown[-1] - 2) / elapsed if shown else float("nan")


def main(argv: list[str] | None = None) -> int:
    """Print fps for each light field and renderer."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--keys-only", action="store_true", help="only the key-driven default path")
    ap.add_argument("--busy", action="store_true", help="also with both cores kept busy")
    ap.add_argument("--window", action="store_true", help="a real window, keys through X")
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
    import statistics

    for name, lf in cases:
        src = LightFieldSource(lf)
        loads = [("idle", 0)] + ([("both cores busy", os.cpu_count() or 2)] if args.busy else [])
        for label, n_busy in loads:
            for pattern, bf in (("back and forth", True), ("every key a new depth", False)):
                runs = []
                with busy_cores(n_busy):
                    for _ in range(args.repeats):
                        v = Viewer(src, ["argus2"], screen_shape_px=(h, w), ctx=ctx, n_planes=30)
                        runs.append(key_fps(v, args.frames, fbo=fbo, ctx=ctx, back_and_forth=bf))
                        v.close()
                    load = os.getloadavg()[0]
                print(
                    f"{name:24s} keys {pattern}, window default ({v.compute}), {label}: median "
                    f"{statistics.median(runs):5.1f} fps "
                    f"(runs {', '.join(f'{r:.1f}' for r in runs)}; load average {load:.1f})"
                )
    if args.window:
        import shutil
        import subprocess
        import tempfile

        display, xvfb = os.environ.get("DISPLAY"), None
        if not display:
            if shutil.which("Xvfb") is None:
                print("(no DISPLAY and no Xvfb: window case skipped)")
                return 0
            display = ":97"
            xvfb = subprocess.Popen(["Xvfb", display, "-screen", "0", f"{w + 64}x{h + 64}x24"])
            time.sleep(1.0)
        try:
            with tempfile.TemporaryDirectory() as tmp:
                path = Path(tmp) / "lf.npz"
                import numpy as np

                lf = cases[0][1]
                np.savez(path, views=lf.views)
                for label, n_busy in [("idle", 0)] + (
                    [("both cores busy", 2)] if args.busy else []
                ):
                    with busy_cores(n_busy):
                        f = [window_fps(path, args.size, 8.0, display) for _ in range(3)]
                    print(
                        f"{cases[0][0]:24s} window, keys through X, {label}: median "
                        f"{statistics.median(f):5.1f} fps (runs {', '.join(f'{r:.1f}' for r in f)})"
                    )
        finally:
            if xvfb is not None:
                xvfb.kill()
                xvfb.wait()
    if args.keys_only:
        fbo.release()
        ctx.release()
        return 0
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
