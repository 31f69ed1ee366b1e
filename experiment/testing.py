"""Tiny synthetic stimulus sets for tests and dry runs (no photos needed).

:func:`make_stimulus_set` writes a folder in the stimulus-set format (``manifest.csv``,
``objects.csv``, ``stimulus_set.json``, PNGs) in well under a second for small sizes. Each object
is a few random outlines (rectangles, ellipses, lines) in the bottom centre; the de-cluttered
image is its edges alone, the cluttered image adds random background edges, and both are
compressed with :func:`stimuli.compress.compress` at the paper's windows. With
``working_shape_px=(327, 492)`` the levels have the paper's sizes and pixel counts.
"""

from __future__ import annotations

import csv
import hashlib
import json
from pathlib import Path

import numpy as np

from experiment.session.stimset import MANIFEST_COLUMNS

__all__ = ["make_stimulus_set", "DEFAULT_WINDOWS_PX", "OBJECT_WORDS"]

#: Windows of levels 1..8 (level 1 = fewest pixels). Source: Jung et al. 2015, Sec. 3.1.
DEFAULT_WINDOWS_PX: tuple[int, ...] = (40, 18, 13, 7, 5, 3, 2, 1)

#: Names, synonyms and uses of the synthetic objects (ours; household objects as in the paper).
OBJECT_WORDS: tuple[tuple[str, str, str], ...] = (
    ("mug", "cup;coffee mug", "drinking coffee;drinking"),
    ("scissors", "shears", "cutting paper;cutting"),
    ("stapler", "", "stapling paper;stapling"),
    ("telephone", "phone", "calling;making calls"),
    ("lamp", "desk lamp", "lighting;light"),
    ("kettle", "", "boiling water"),
    ("hammer", "", "hitting nails"),
    ("bottle", "water bottle", "holding water"),
    ("clock", "alarm clock", "telling time"),
    ("shoe", "sneaker", "walking"),
    ("keyboard", "", "typing"),
    ("headphones", "headset", "listening to music"),
    ("umbrella", "", "keeping dry"),
    ("toothbrush", "", "brushing teeth"),
    ("glasses", "spectacles", "seeing;reading"),
    ("camera", "", "taking pictures"),
    ("book", "", "reading"),
    ("spoon", "", "eating soup"),
    ("calculator", "", "calculating"),
    ("guitar", "", "playing music"),
    ("teapot", "", "making tea"),
    ("wrench", "spanner", "turning bolts"),
    ("candle", "", "lighting a room"),
)


def _outline(
    rng: np.random.Generator,
    shape_px: tuple[int, int],
    n_shapes: int,
    region: tuple[float, float, float, float],
) -> np.ndarray:
    """Random 1-px outlines inside ``region`` = (r0, r1, c0, c1) as fractions of the image."""
    rows, cols = shape_px
    out = np.zeros(shape_px, dtype=bool)
    rr, cc = np.mgrid[0:rows, 0:cols]
    r0, r1, c0, c1 = region
    for _ in range(n_shapes):
        kind = rng.integers(3)
        cr = rng.uniform(r0, r1) * rows
        cx = rng.uniform(c0, c1) * cols
        hr = rng.uniform(0.04, 0.16) * rows
        hc = rng.uniform(0.03, 0.12) * cols
        if kind == 0:  # ellipse outline
            d = ((rr - cr) / hr) ** 2 + ((cc - cx) / hc) ** 2
            out |= np.abs(d - 1.0) < 2.5 / max(min(hr, hc), 1.0)
        elif kind == 1:  # rectangle outline
            inside = (np.abs(rr - cr) <= hr) & (np.abs(cc - cx) <= hc)
            inner = (np.abs(rr - cr) <= hr - 1.5) & (np.abs(cc - cx) <= hc - 1.5)
            out |= inside & ~inner
        else:  # thick line segment
            ang = rng.uniform(0, np.pi)
            t = (rr - cr) * np.sin(ang) + (cc - cx) * np.cos(ang)
            n = -(rr - cr) * np.cos(ang) + (cc - cx) * np.sin(ang)
            out |= (np.abs(n) < 1.2) & (np.abs(t) < max(hr, hc))
    return out


def make_stimulus_set(
    root: str | Path,
    *,
    n_main: int = 4,
    n_training: int = 1,
    levels: tuple[int, ...] = (1, 2, 3, 4, 5, 6, 7, 8),
    working_shape_px: tuple[int, int] = (33, 49),
    clutter_shapes: int = 12,
    rng: np.random.Generator | int | None = 0,
    photos: bool = True,
) -> Path:
    """Write a small synthetic stimulus set and return its folder.

    Parameters
    ----------
    root : str or Path
        Folder to create (must not hold a set already).
    n_main, n_training : int
        Number of main and training objects (at most ``len(OBJECT_WORDS)`` together).
    levels : tuple of int in 1..8
        Levels to write; level k uses window ``DEFAULT_WINDOWS_PX[k - 1]``.
    working_shape_px : (rows, cols)
        Size of the edge images before compression (the paper: (327, 492)).
    clutter_shapes : int
        Random background outlines in the cluttered images.
    rng : numpy.random.Generator, int or None
    photos : bool
        Also write one ``photo`` row per object (grey, level 8).

    Returns
    -------
    Path
    """
    from stimuli.compress import compress, grid_shape
    from stimuli.io import save_png
    from stimuli.tables import write_table

    rng = np.random.default_rng(rng)
    if n_main + n_training > len(OBJECT_WORDS):
        raise ValueError(
            f"n_main + n_training must be <= {len(OBJECT_WORDS)}, got {n_main + n_training}"
        )
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    (root / "images").mkdir(exist_ok=True)
    edge_ratio = 1.0 / 13.0
    rows_out = []
    objects = []
    for k in range(n_main + n_training):
        oid = f"obj{k + 1:02d}"
        role = "main" if k < n_main else "training"
        name, syn, uses = OBJECT_WORDS[k]
        objects.append({"object": oid, "name": name, "synonyms": syn, "uses": uses, "role": role})
        obj_edges = _outline(rng, working_shape_px, 3, (0.55, 0.8, 0.35, 0.65))
        clutter = _outline(rng, working_shape_px, clutter_shapes, (0.1, 0.9, 0.05, 0.95))
        images = {"decluttered": obj_edges, "cluttered": obj_edges | clutter}
        for cond, edges in images.items():
            for lv in levels:
                w = DEFAULT_WINDOWS_PX[lv - 1]
                shape = grid_shape(working_shape_px, w)
                img = edges if w == 1 else compress(edges, shape, edge_ratio=edge_ratio)
                rel = f"images/{oid}_{cond}_L{lv}.png"
                save_png(img, root / rel)
                rows_out.append((oid, role, cond, lv, w, img.shape[1], img.shape[0], rel))
        if photos:
            grey = np.clip(
                0.5 + 0.3 * obj_edges + 0.15 * clutter + rng.normal(0, 0.05, working_shape_px), 0, 1
            ).astype(np.float32)
            rel = f"images/{oid}_photo.png"
            save_png(grey, root / rel)
            rows_out.append((oid, role, "photo", 8, 1, grey.shape[1], grey.shape[0], rel))
            if role == "training":  # the colour photos of the paper's training (Sec. 3.1)
                tint = np.array([1.0, 0.8, 0.6], np.float32)
                for cond, img in (
                    ("colour_wide", grey),
                    ("colour_confocal", 0.5 + 0.4 * obj_edges),
                ):
                    rel = f"images/{oid}_{cond}.png"
                    save_png(np.clip(img[..., None] * tint, 0, 1).astype(np.float32), root / rel)
                    rows_out.append((oid, role, cond, 8, 1, img.shape[1], img.shape[0], rel))
    with open(root / "manifest.csv", "w", newline="", encoding="utf-8") as f:
        wr = csv.writer(f)
        wr.writerow(MANIFEST_COLUMNS)
        for oid, role, cond, lv, w, wd, ht, rel in rows_out:
            sha = hashlib.sha256((root / rel).read_bytes()).hexdigest()
            wr.writerow([oid, role, cond, lv, w, wd, ht, wd * ht, rel, sha])
    write_table(root / "objects.csv", objects, ["object", "name", "synonyms", "uses", "role"])
    (root / "stimulus_set.json").write_text(
        json.dumps(
            {
                "generator": "experiment.testing.make_stimulus_set",
                "working_shape_px": list(working_shape_px),
            },
            indent=2,
        ),
        encoding="utf-8",
    )
    return root
