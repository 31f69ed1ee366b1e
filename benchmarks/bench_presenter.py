"""Benchmark: presenter draw time per frame at 1280x1024.

Measures, in one process and one OpenGL context (EGL offscreen unless ``--window``), the time to
draw one frame and wait for it (``glFinish``):

- *baseline*: a plain ``clear`` of the 1280x1024 framebuffer;
- *stimulus*: the presenter's full-screen shader at the paper's geometry, for the lowest (12x8),
  a middle (70x47) and the full (492x327) level;
- *phosphenes*: the Gaussian phosphene shader (3x3 neighbourhood per pixel) at 38x25.

Each is reported in ms per frame and as a ratio to the baseline, so numbers compare across
machines (llvmpipe on 2 CPU cores is far slower than any GPU; the ratio is what to compare). A
frame budget at 60 Hz is 16.7 ms; on a real GPU every case is well under 1 ms.

Run: ``python benchmarks/bench_presenter.py [--frames 60] [--repeat 3]``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from experiment.presentation.presenter import PhospheneSpec, Presenter, ScreenGeometry  # noqa: E402

__all__ = ["time_frames", "main"]


def time_frames(draw, finish, n_frames: int, repeat: int) -> float:
    """Return the median over ``repeat`` runs of the mean s/frame of ``draw(); finish()``."""
    draw()
    finish()  # warm-up: shader compile, texture upload
    runs = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(n_frames):
            draw()
            finish()
        runs.append((time.perf_counter() - t0) / n_frames)
    return statistics.median(runs)


def main(argv: list[str] | None = None) -> int:
    """Print draw time per frame for each case and its ratio to the clear baseline."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)

    g = ScreenGeometry.jung2015()
    p = Presenter.offscreen(g)
    ctx, fbo = p.ctx, p._fbo
    rng = np.random.default_rng(0)
    print(
        f"renderer: {ctx.info['GL_RENDERER']}; screen {g.screen_shape_px[1]}x{g.screen_shape_px[0]}"
    )

    def clear() -> None:
        fbo.use()
        fbo.clear(0.0, 0.0, 1.0, 1.0)

    base = time_frames(clear, ctx.finish, args.frames, args.repeat)
    rows = [("baseline: clear", base)]
    for shape in ((8, 12), (47, 70), (327, 492)):
        p.show_stimulus(rng.random(shape) < 0.3)
        rows.append(
            (
                f"stimulus {shape[1]}x{shape[0]}",
                time_frames(p._draw, ctx.finish, args.frames, args.repeat),
            )
        )
    p.close()
    q = Presenter.offscreen(g, phosphenes=PhospheneSpec(kind="gaussian", size=0.8, dropout=0.1))
    q.show_stimulus(rng.random((25, 38)) < 0.3)
    rows.append(
        ("gaussian phosphenes 38x25", time_frames(q._draw, q.ctx.finish, args.frames, args.repeat))
    )
    q.close()
    print(f"{'case':32s} {'ms/frame':>9s} {'x baseline':>11s}")
    for name, t in rows:
        print(f"{name:32s} {t * 1e3:9.3f} {t / base:11.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
