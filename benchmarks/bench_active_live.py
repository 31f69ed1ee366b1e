"""Benchmark: how long a person's key takes to change what the subject sees.

A person's active search (``confocal active run --searcher person``) applies each input in the
console process: the state changes, the CPU pipeline refocuses, de-clutters and compresses the
view, the event rows are committed to SQLite, and the new implant view is sent to the
presenter process, which draws and flips it. This measures that path per input kind on the
shipped protocol's scene (three-plane light field, 7x7 views of 308x385 px, 28x35 grid):

- ``depth key``: a depth the session has not refocused yet (the expensive case);
- ``revisit``: a depth refocused before (cached);
- ``plane jump``: PageDown to the next detected plane;
- ``zoom``: a dragged box (crop, Sobel, compression; the refocused image is cached).

Baseline, in the same process: one ``stimuli.refocus.refocus`` of the same light field (the
pipeline's largest step). Ratios to it compare across machines. ``--presenter offscreen`` adds
the real presenter process (EGL, offscreen), so the figure includes the JSON-lines transport and
the GL draw; ``none`` measures the console side alone.

Run: ``python benchmarks/bench_active_live.py [--repeat 20] [--presenter offscreen|none]``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path

__all__ = ["main"]


def _median_ms(samples: list[float]) -> float:
    return 1e3 * statistics.median(samples)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--presenter", choices=("offscreen", "none"), default="offscreen")
    args = ap.parse_args(argv)

    from experiment.active.live import LiveSearch
    from experiment.active.session import ActiveSession
    from experiment.log import TrialLog
    from experiment.presentation.displays import NullDisplay
    from experiment.protocol import load_protocol
    from stimuli.refocus import refocus

    spec = load_protocol("active_search")
    tmp = Path(tempfile.mkdtemp())
    log = TrialLog(tmp / "bench.sqlite")  # a file: commits are part of the cost
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        session = ActiveSession.open(log, spec, "B01", seed=0, responder="person")
    if args.presenter == "offscreen":
        from experiment.presentation.presenter import ScreenGeometry
        from experiment.presentation.process import RemoteDisplay

        display = RemoteDisplay(
            ScreenGeometry.from_display_spec(spec.display), mode="offscreen", inputs=True
        )
    else:
        display = NullDisplay(session.clock)
    live = LiveSearch(session, display)
    lf = session.scene.lightfield
    ctx = session.model
    try:
        base = []
        for k in range(args.repeat):
            d = ctx.far_px + (k + 0.5) * (ctx.near_px - ctx.far_px) / args.repeat
            t0 = time.perf_counter()
            refocus(lf, d, workers=1)
            base.append(time.perf_counter() - t0)

        def timed(event: dict) -> float:
            t0 = time.perf_counter()
            rows = live.handle(event)
            dt = time.perf_counter() - t0
            assert any(r["kind"] == "state" for r in rows), event
            return dt

        cases: dict[str, list[float]] = {k: [] for k in ("depth key", "revisit", "plane jump")}
        cases["zoom"] = []
        live.cue()
        live.begin()
        for _ in range(args.repeat):
            if live.session.state.disparity_px - ctx.step_px < ctx.far_px:
                live.handle({"key": "PageUp"})  # back near (the planes are refocused already)
            cases["depth key"].append(timed({"key": "Down"}))
            cases["revisit"].append(timed({"key": "Up"}))
            live.handle({"key": "Down"})
            cases["zoom"].append(timed({"key": "drag", "box": [0.2, 0.2, 0.7, 0.8]}))
            live.handle({"key": "Escape"})
        live.score("", "pass")
        live.cue()
        live.begin()
        for _ in range(args.repeat):
            ev = {"key": "PageDown"} if live.session.state.plane != len(ctx.planes_px) - 1 else None
            if ev is None:
                live.handle({"key": "PageUp"})
                ev = {"key": "PageDown"}
            cases["plane jump"].append(timed(ev))
        b = _median_ms(base)
        print(f"active search, a person's input -> new implant view ({args.presenter} presenter)")
        nu, nv = lf.views.shape[:2]
        print(f"scene {lf.shape_px[1]}x{lf.shape_px[0]} px, {nu}x{nv} views")
        print(f"baseline: one refocus, median {b:.1f} ms (n={len(base)})")
        print(f"{'input':<12} {'median ms':>10} {'x baseline':>11} {'max ms':>8}")
        for name, xs in cases.items():
            m = _median_ms(xs)
            print(f"{name:<12} {m:>10.1f} {m / b:>11.2f} {1e3 * max(xs):>8.1f}")
    finally:
        display.close()
        session.close()
        log.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
