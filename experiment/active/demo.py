"""``confocal demo --active``: a simulated search through the three-plane scene, as a picture.

The demo runs the active-search task (:mod:`experiment.active.session`) headless on the paper's
Fig. 10 scene (pedestrian 1 m, tree 4 m, building 9 m) with a simulated searcher that jumps
between the detected depth planes, nearest first, zooms when unsure, and answers when its model
observer recognises the cued object. Every key and every displayed state goes to an SQLite trial
log (``active.sqlite``), exactly as in a study. The pictures are then rendered *from the log*
(each logged state is re-rendered with the CPU pipeline and checked against the implant grid
the log recorded), so they show what the log holds:

* ``search.gif`` (and ``search.png``, an animated PNG): one frame per displayed state, four
  panes: centre view ("cluttered"), confocal image at the current depth, de-cluttered edges,
  and the implant's view drawn as phosphenes; a status line with depth, plane, zoom and the
  simulated time;
* ``contact_sheet.png``: all frames on one sheet;
* ``report/``: the active-search metrics (``results.json``, ``report.md``,
  ``active_trials.csv``) from :mod:`analysis.active`.

All times are simulated (the searcher's key and look times are drawn, not measured).
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from experiment.errors import ConfocalError
from experiment.outputs import require_missing_or_empty

__all__ = ["run_active_demo", "render_frame", "DEMO_PANE_PX"]

#: Size (rows, cols) of one pane of the demo's frames, pixels (ours: the paper's 308x385
#: confocal images at half size).
DEMO_PANE_PX: tuple[int, int] = (154, 192)

_HEAD_PX = 34
_GAP_PX = 6


def _u8(image: np.ndarray) -> Image.Image:
    a = np.asarray(image)
    u8 = a.astype(np.uint8) * 255 if a.dtype == bool else np.round(np.clip(a, 0, 1) * 255)
    return Image.fromarray(np.asarray(u8, dtype=np.uint8))


def _fit(image: np.ndarray, pane_px: tuple[int, int], *, nearest: bool) -> Image.Image:
    im = _u8(image)
    rows, cols = pane_px
    s = min(rows / im.height, cols / im.width)
    size = (max(1, round(im.width * s)), max(1, round(im.height * s)))
    im = im.resize(size, Image.NEAREST if nearest else Image.BILINEAR)
    pane = Image.new("L", (cols, rows), 0)
    pane.paste(im, ((cols - im.width) // 2, (rows - im.height) // 2))
    return pane


def _phosphenes(grid: np.ndarray, pane_px: tuple[int, int]) -> Image.Image:
    """Draw an implant grid as round phosphenes (lit cells bright, others faint)."""
    rows, cols = pane_px
    gr, gc = grid.shape
    cell = min(rows / gr, cols / gc)
    pane = Image.new("L", (cols, rows), 0)
    draw = ImageDraw.Draw(pane)
    y0, x0 = (rows - cell * gr) / 2, (cols - cell * gc) / 2
    r = 0.42 * cell
    for i in range(gr):
        for j in range(gc):
            cy, cx = y0 + (i + 0.5) * cell, x0 + (j + 0.5) * cell
            draw.ellipse((cx - r, cy - r, cx + r, cy + r), fill=245 if grid[i, j] else 28)
    return pane


def render_frame(
    centre: np.ndarray,
    confocal: np.ndarray,
    edges: np.ndarray,
    grid: np.ndarray,
    status: str,
    *,
    zoom: tuple[int, int, int, int] | None = None,
    pane_px: tuple[int, int] = DEMO_PANE_PX,
) -> Image.Image:
    """Return one frame: four labelled panes and a status line (8-bit RGB).

    Parameters
    ----------
    centre, confocal : ndarray (rows, cols), float32 in [0, 1]
    edges : ndarray (h, w), bool
        De-cluttered edges (of the zoom crop when zoomed).
    grid : ndarray (grid rows, grid cols), bool
        The implant's view.
    status : str
        Status line.
    zoom : (x, y, w, h), optional
        Drawn as a box on the centre and confocal panes.
    pane_px : (rows, cols)
    """
    rows, cols = pane_px
    panes = [
        ("centre view (cluttered)", _fit(centre, pane_px, nearest=False)),
        ("confocal at this depth", _fit(confocal, pane_px, nearest=False)),
        ("de-cluttered edges", _fit(edges, pane_px, nearest=True)),
        (f"implant {grid.shape[1]}x{grid.shape[0]}", _phosphenes(grid, pane_px)),
    ]
    width = 4 * cols + 5 * _GAP_PX
    frame = Image.new("RGB", (width, rows + _HEAD_PX + _GAP_PX), (40, 40, 48))
    draw = ImageDraw.Draw(frame)
    draw.text((_GAP_PX, 3), status, fill=(255, 255, 160))
    for k, (label, pane) in enumerate(panes):
        x = _GAP_PX + k * (cols + _GAP_PX)
        draw.text((x, 18), label, fill=(220, 220, 220))
        frame.paste(pane.convert("RGB"), (x, _HEAD_PX))
        if zoom is not None and k < 2:
            s = min(rows / centre.shape[0], cols / centre.shape[1])
            ox = x + (cols - round(centre.shape[1] * s)) // 2
            oy = _HEAD_PX + (rows - round(centre.shape[0] * s)) // 2
            zx, zy, zw, zh = zoom
            draw.rectangle(
                (ox + zx * s, oy + zy * s, ox + (zx + zw) * s - 1, oy + (zy + zh) * s - 1),
                outline=(255, 80, 80),
            )
    return frame


def _contact_sheet(frames: list[Image.Image], captions: list[str], columns: int = 3) -> Image.Image:
    w, h = frames[0].size
    scale = 0.5
    tw, th = round(w * scale), round(h * scale)
    n_rows = -(-len(frames) // columns)
    sheet = Image.new("RGB", (columns * (tw + 8) + 8, n_rows * (th + 22) + 8), (24, 24, 28))
    draw = ImageDraw.Draw(sheet)
    for i, (f, cap) in enumerate(zip(frames, captions, strict=True)):
        r, c = divmod(i, columns)
        x, y = 8 + c * (tw + 8), 8 + r * (th + 22)
        draw.text((x, y), cap, fill=(230, 230, 230))
        sheet.paste(f.resize((tw, th), Image.BILINEAR), (x, y + 14))
    return sheet


def run_active_demo(
    out_dir: str | Path,
    *,
    seed: int = 0,
    shape_px: tuple[int, int] | None = None,
    strategy: str = "planes",
) -> list[str]:
    """Run a simulated active search through the three-plane scene and draw it.

    Parameters
    ----------
    out_dir : str or Path
        Folder to write, as for :func:`experiment.demos.lightfield.run_lightfield_demo`.
    seed : int >= 0
        Seed of the searcher (its times and its model observer's noise).
    shape_px : (rows, cols), optional
        View size of the scene (default: the protocol's, the paper's 308x385).
    strategy : {'planes', 'ordered'}
        The simulated searcher's scan order.

    Returns
    -------
    list of str
        Printable summary lines.

    References
    ----------
    Jung et al. (2015), Sec. 4-5 (confocal scan, zoom, free search) and Fig. 10 (the scene).
    """
    from analysis.active import add_active_results
    from experiment.active.adapter import search_renderer
    from experiment.active.eventlog import ActiveEventLog
    from experiment.active.searcher import EdgeRecogniser, SimulatedSearcher
    from experiment.active.session import ActiveSession, _grid_hex
    from experiment.clock import FakeClock
    from experiment.log import TrialLog
    from experiment.protocol import load_protocol
    from experiment.viewer.state import ViewerState
    from stimuli.io import atomic_path

    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfocalError(f"seed must be an integer >= 0, got {seed!r}")
    out = Path(out_dir)
    require_missing_or_empty(out)
    out.mkdir(parents=True, exist_ok=True)

    base = load_protocol("active_search")
    task = replace(
        base.task,
        scene="synthetic:three_plane",
        counterbalance="none",
        conditions=("decluttered",),
        trial_order="listed",
        targets=("pedestrian", "tree", "building"),
        scene_shape_px=tuple(shape_px) if shape_px is not None else base.task.scene_shape_px,
    )
    protocol = replace(base, name="active_search_demo", task=task)
    db = out / "active.sqlite"
    log = TrialLog(db)
    try:
        session = ActiveSession.open(
            log, protocol, "demo", seed=seed, clock=FakeClock(), responder=f"sim:{strategy}"
        )
        try:
            rec = EdgeRecogniser(session.scene, task.grid_px, rng=seed)
            session.run(SimulatedSearcher(rec, strategy, rng=seed))
            rows = ActiveEventLog(log, session.session_id).rows()
            scene, planes = session.scene, session.planes_px
        finally:
            session.close()
    finally:
        log.close()

    renderer = search_renderer(scene, task.grid_px, "decluttered")
    centre = scene.centre_view()
    frames, captions, durations, lines = [], [], [], []
    n_trials = len(task.targets)
    states = [r for r in rows if r["kind"] == "state"]
    last_key: dict[int, str] = {}
    cue: dict[int, str] = {}
    for r in rows:
        if r["kind"] == "trial_start":
            cue[r["trial"]] = r["payload"]["cue"]
        if r["kind"] == "answer":
            p = r["payload"]
            lines.append(
                f"trial {r['trial'] + 1}: {cue[r['trial']]}: answered "
                f"{p['response'] or '(pass)'!r} after {p['rt_s']:.1f} s (simulated) at "
                f"{p['state']['depth_px']:.2f} px/view"
                + (
                    f" = {p['state']['depth_m']:.2f} m"
                    if p["state"].get("depth_m") is not None
                    else ""
                )
            )
    for i, r in enumerate(rows):
        if r["kind"] == "key":
            last_key[r["trial"]] = f"{r['payload']['key']} ({r['payload']['action']})"
        if r["kind"] != "state":
            continue
        p = r["payload"]
        zoom = tuple(p["zoom"]) if p["zoom"] is not None else None
        view = renderer.render(ViewerState(p["depth_px"], plane=p["plane"], zoom=zoom))
        if _grid_hex(view.grid) != p["implant"]:
            raise RuntimeError(
                f"event {r['seq']}: re-rendered implant view differs from the logged one"
            )
        confocal = renderer.confocal(p["depth_px"])
        depth = f"{p['depth_px']:.2f} px/view"
        if p.get("depth_m") is not None:
            depth += f" = {p['depth_m']:.2f} m"
        plane = f"plane {p['plane'] + 1}/{len(planes)}" if p["plane"] is not None else "no plane"
        status = (
            f"trial {r['trial'] + 1}/{n_trials}: {cue[r['trial']]} | {depth} | {plane} | "
            f"zoom {'x'.join(map(str, zoom[2:])) if zoom else 'off'} | "
            f"t = {r['t_s']:.1f} s (SIMULATED) | key: {last_key.get(r['trial'], '-')}"
        )
        frames.append(render_frame(centre, confocal, view.edges, view.grid, status, zoom=zoom))
        captions.append(f"t{r['trial'] + 1} {depth} {'zoom' if zoom else ''}")
        nxt = next((s for s in rows[i + 1 :] if s["kind"] in ("state", "answer")), None)
        dt = (nxt["t_s"] - r["t_s"]) if nxt is not None else 1.0
        durations.append(int(np.clip(dt * 500, 400, 1500)))  # half speed of simulated time
    if not states:
        raise RuntimeError("the simulated search logged no displayed states")
    with atomic_path(out / "search.gif") as tmp:
        pal = [f.convert("P", palette=Image.ADAPTIVE, colors=128) for f in frames]
        pal[0].save(
            tmp, format="GIF", save_all=True, append_images=pal[1:], duration=durations, loop=0
        )
    with atomic_path(out / "search.png") as tmp:
        frames[0].save(
            tmp,
            format="PNG",
            save_all=True,
            append_images=frames[1:],
            duration=durations,
            loop=0,
            compress_level=3,
        )
    with atomic_path(out / "contact_sheet.png") as tmp:
        _contact_sheet(frames, captions).save(tmp, format="PNG")
    result = add_active_results([db], out / "report")
    summary = {
        "seed": seed,
        "strategy": strategy,
        "simulated": True,
        "frames": len(frames),
        "planes_px": list(planes),
        "objects_px": dict(scene.objects),
        "answers": lines,
        "active_search": None if result is None else result.to_dict(),
    }
    with atomic_path(out / "active_demo.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=2) + "\n")
    truth = ", ".join(f"{k} {v:.2f} px/view" for k, v in scene.objects.items())
    det = ", ".join(f"{d:.2f}" for d in planes)
    return [
        f"scene (synthetic, Fig. 10): {truth}",
        f"detected planes (px/view, nearest first): {det}",
        *lines,
        f"{len(frames)} frames: {out / 'search.gif'}, {out / 'search.png'}",
        f"contact sheet: {out / 'contact_sheet.png'}",
        f"trial log: {db}; metrics: {out / 'report' / 'report.md'} (SIMULATED searcher)",
    ]
