"""Things worn or used on the body: glasses, a toothbrush and a shoe.

Drawn in object units; see :mod:`stimuli.objects.registry`.
"""

from __future__ import annotations

import numpy as np

from stimuli.objects import drawing as dr
from stimuli.objects.drawing import OUTLINE_UNITS as OL

__all__ = ["draw_glasses", "draw_toothbrush", "draw_shoe"]


def draw_glasses(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a pair of glasses."""
    frame = rng.uniform(0.05, 0.25)
    cy = 0.3
    for sx in (-1.0, 1.0):
        cv.paint(dr.capsule(sx * 0.47, cy + 0.1, sx * 0.5, 0.03, 0.02), frame + 0.15, outline=OL)
    for sx in (-1.0, 1.0):
        lens = dr.box(sx * 0.24, cy, 0.4, 0.3, r=0.11)
        cv.paint(
            lens,
            dr.gradient(sx * 0.24 - 0.2, cy + 0.15, sx * 0.24 + 0.2, cy - 0.15, 0.75, 0.5),
            opacity=0.55,
        )
        cv.paint(
            dr.capsule(sx * 0.24 - 0.1, cy - 0.02, sx * 0.24 - 0.02, cy + 0.1, 0.018),
            0.97,
            opacity=0.8,
        )
        cv.paint(dr.stroke(lens, 0.05), dr.metal(frame + 0.1, 30), outline=OL)
    bridge = dr.ring(0, cy + 0.02, 0.09, 0.04) & dr.above(cy + 0.04)
    cv.paint(bridge, frame + 0.1, outline=OL)
    for sx in (-1.0, 1.0):
        cv.paint(dr.circle(sx * 0.44, cy + 0.1, 0.02), 0.8)


def draw_toothbrush(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a toothbrush."""
    ang = dr.random_tilt_deg(rng, 28.0, 38.0)
    base = rng.uniform(0.6, 0.85)
    cx, cy = 0.0, 0.7
    turn = dr.rotator(ang, cx, cy)
    handle = dr.box(0, 0.45, 0.13, 0.8, r=0.06) | dr.polygon(
        [(-0.05, 0.84), (0.05, 0.84), (0.035, 1.1), (-0.035, 1.1)]
    )
    head = dr.box(0, 1.2, 0.1, 0.24, r=0.04)
    cv.paint(turn(handle | head), dr.cylinder(0, 0.065, base, spec=0.45), outline=OL)
    cv.paint(
        turn(dr.box(0, 0.38, 0.08, 0.46, r=0.04)),
        lambda x, y: 0.15 + 0.15 * (np.sin(y * 160) > 0),
        outline=OL,
    )
    for i in range(6):
        for j in range(2):
            tuft = dr.box(-0.08 - j * 0.045, 1.1 + i * 0.04, 0.045, 0.032, r=0.008)
            cv.paint(turn(tuft), 0.95 - 0.25 * ((i + j) % 2), outline=OL / 2, outline_value=0.4)


def draw_shoe(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a shoe."""
    upper_v = rng.uniform(0.2, 0.45)
    outline_pts = np.concatenate(
        [
            dr.bezier([(0.52, 0.1), (0.55, 0.3), (0.54, 0.5), (0.46, 0.58)], 10),
            dr.bezier([(0.46, 0.58), (0.38, 0.5), (0.3, 0.47), (0.2, 0.52)], 8),
            dr.bezier([(0.2, 0.52), (0.16, 0.66), (0.08, 0.66), (0.04, 0.58)], 8),
            dr.bezier([(0.04, 0.58), (-0.1, 0.42), (-0.3, 0.32), (-0.5, 0.27)], 10),
            dr.bezier([(-0.5, 0.27), (-0.62, 0.24), (-0.66, 0.16), (-0.6, 0.1)], 8),
        ]
    )
    upper = dr.polygon([tuple(p) for p in outline_pts])
    cv.paint(upper, dr.gradient(0, 0.6, 0, 0.1, upper_v * 1.5, upper_v * 0.8), outline=OL)
    toe = dr.polygon([tuple(p) for p in outline_pts[-14:]] + [(-0.3, 0.12), (-0.3, 0.3)])
    cv.paint(toe & upper, 0.88, outline=OL)
    for k in range(6):
        cv.paint(dr.circle(-0.52 + k * 0.035, 0.2 + 0.012 * k, 0.007), 0.45)
    heel = dr.polygon([(0.53, 0.1), (0.38, 0.1), (0.42, 0.46), (0.5, 0.56)]) & upper
    cv.paint(heel, 0.82, outline=OL)
    stripe = dr.polygon(
        [tuple(p) for p in dr.bezier([(-0.2, 0.16), (0.0, 0.2), (0.15, 0.3), (0.3, 0.4)], 10)]
        + [tuple(p) for p in dr.bezier([(0.28, 0.3), (0.15, 0.22), (0.0, 0.16), (-0.2, 0.16)], 10)]
    )
    cv.paint(stripe, 0.97, outline=OL)
    sole = dr.box(-0.06, 0.055, 1.2, 0.11, r=0.05)
    cv.paint(sole, dr.stripes(0.035, 0.93, 0.72, 90), outline=OL)
    eyes_a = [(0.1 - 0.055 * k, 0.56 - 0.045 * k) for k in range(5)]
    eyes_b = [(x - 0.07, y - 0.07) for x, y in eyes_a]
    for k in range(4):
        cv.paint(dr.capsule(*eyes_a[k], *eyes_b[k + 1], 0.011), 0.96, outline=OL / 2)
        cv.paint(dr.capsule(*eyes_b[k], *eyes_a[k + 1], 0.011), 0.96, outline=OL / 2)
    for e in eyes_a + eyes_b:
        cv.paint(dr.circle(*e, 0.013), 0.05)
