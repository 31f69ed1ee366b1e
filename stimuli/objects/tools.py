"""Tools and hardware: scissors, a key, a hammer, a screwdriver, a padlock and a pen.

Drawn in object units; see :mod:`stimuli.objects.registry`.
"""

from __future__ import annotations

import math

import numpy as np

from stimuli.objects import drawing as dr
from stimuli.objects.drawing import OUTLINE_UNITS as OL

__all__ = [
    "draw_scissors",
    "draw_key",
    "draw_hammer",
    "draw_screwdriver",
    "draw_padlock",
    "draw_pen",
]


def draw_scissors(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a pair of scissors."""
    handle = rng.uniform(0.1, 0.3)
    pivot = (0.0, 0.62)
    for sign in (-1.0, 1.0):
        tip = (sign * 0.33, 1.38)
        ring_c = (-sign * 0.26, 0.22)
        dx, dy = tip[0] - pivot[0], tip[1] - pivot[1]
        n = math.hypot(dx, dy)
        px, py = -dy / n, dx / n
        blade = dr.polygon(
            [
                (ring_c[0] * 0.45 + px * 0.05, 0.38 + py * 0.05),
                (pivot[0] + px * 0.055, pivot[1] + py * 0.055),
                tip,
                (pivot[0] - px * 0.04, pivot[1] - py * 0.04),
                (ring_c[0] * 0.45 - px * 0.05, 0.38 - py * 0.05),
            ]
        )
        cv.paint(blade, dr.metal(0.72, math.degrees(math.atan2(dy, dx)) + 90), outline=OL)
        cv.paint(
            dr.ring(ring_c[0], ring_c[1], 0.15, 0.07),
            dr.sphere(*ring_c, 0.2, handle + 0.2),
            outline=OL,
        )
        cv.paint(
            dr.capsule(ring_c[0] * 0.45, 0.38, ring_c[0] * 0.8, 0.3, 0.045),
            handle + 0.1,
            outline=OL,
        )
    cv.paint(dr.circle(*pivot, 0.035), dr.sphere(*pivot, 0.035, 0.8), outline=OL)


def draw_key(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a key."""
    base = rng.uniform(0.55, 0.75)
    ang = rng.uniform(10.0, 22.0)
    cy = 0.38
    turn = dr.rotator(ang, 0.0, cy)
    bow = dr.circle(-0.3, cy, 0.22) - dr.circle(-0.4, cy, 0.065)
    shaft = dr.box(0.2, cy, 0.62, 0.1, r=0.01)
    teeth = dr.polygon(
        [
            (0.1, cy - 0.04),
            (0.1, cy - 0.13),
            (0.16, cy - 0.17),
            (0.22, cy - 0.11),
            (0.28, cy - 0.17),
            (0.34, cy - 0.12),
            (0.4, cy - 0.16),
            (0.46, cy - 0.1),
            (0.5, cy - 0.04),
        ]
    )
    cv.paint(turn(bow | shaft | teeth), dr.metal(base, ang + 90), outline=OL)
    cv.paint(turn(dr.box(0.24, cy + 0.01, 0.5, 0.018)), base * 0.45)
    cv.paint(turn(dr.ring(-0.3, cy, 0.17, 0.015)), base * 0.5)
    cv.paint(turn(dr.ring(-0.4, cy, 0.1, 0.04)), 0.35, outline=OL / 2)


def draw_hammer(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a hammer."""
    wood = rng.uniform(0.55, 0.75)
    grain = dr.smooth_noise(rng, (8, 64), 2.0)

    def wood_f(x, y):
        gi = np.clip(((y + 0.0) * 40).astype(int), 0, 63)
        return np.clip(wood + 0.12 * np.sin(x * 160 + grain[0, gi] * 3) * 0.5 + 0.4 * (x * 2), 0, 1)

    cv.paint(dr.box(0.0, 0.48, 0.11, 0.94, r=0.05), wood_f, outline=OL)
    grip = dr.box(0.0, 0.2, 0.13, 0.38, r=0.06)
    cv.paint(grip, lambda x, y: 0.15 + 0.12 * (np.sin(y * 120) > 0.3), outline=OL)
    head = dr.box(0.0, 1.0, 0.5, 0.17, r=0.02)
    face = dr.box(0.3, 1.0, 0.12, 0.22, r=0.02)
    claw = dr.polygon(
        [
            (-0.24, 1.08),
            (-0.45, 1.04),
            (-0.6, 0.92),
            (-0.62, 0.84),
            (-0.52, 0.9),
            (-0.38, 0.95),
            (-0.24, 0.93),
        ]
    )
    cv.paint(head | face | claw, dr.metal(0.55, 90), outline=OL)
    cv.paint(dr.polygon([(-0.62, 0.84), (-0.5, 0.955), (-0.58, 0.98)]), 0.3)
    cv.paint(dr.box(0.36, 1.0, 0.015, 0.2), 0.9)


def draw_screwdriver(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a screwdriver."""
    ang = dr.random_tilt_deg(rng, 22.0, 32.0)
    base = rng.uniform(0.55, 0.8)
    turn = dr.rotator(ang, 0.0, 0.7)
    tip = dr.polygon([(-0.03, 1.3), (0.03, 1.3), (0.022, 1.4), (-0.022, 1.4)])
    cv.paint(
        turn(dr.box(0, 0.98, 0.06, 0.66) | tip), dr.cylinder(0, 0.03, 0.75, spec=0.5), outline=OL
    )
    cv.paint(
        turn(dr.box(0, 0.62, 0.13, 0.08, r=0.02)), dr.cylinder(0, 0.065, 0.6, spec=0.4), outline=OL
    )
    handle = dr.box(0, 0.34, 0.24, 0.52, r=0.1) | dr.polygon(
        [(-0.1, 0.52), (0.1, 0.52), (0.065, 0.6), (-0.065, 0.6)]
    )
    cv.paint(turn(handle), dr.cylinder(0, 0.12, base, spec=0.45), outline=OL)
    for k in range(4):
        groove = dr.box(-0.075 + k * 0.05, 0.3, 0.022, 0.36, r=0.011)
        cv.paint(turn(groove), dr.cylinder(0, 0.12, base * 0.35, spec=0.1))
    cv.paint(turn(dr.box(0, 0.1, 0.2, 0.035, r=0.015)), base * 0.4)


def draw_padlock(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a padlock."""
    base = rng.uniform(0.5, 0.7)
    shackle = (
        (dr.ring(0, 0.68, 0.19, 0.075) & dr.above(0.68))
        | dr.box(-0.19, 0.6, 0.075, 0.18)
        | dr.box(0.19, 0.6, 0.075, 0.18)
    )
    cv.paint(shackle, dr.metal(0.75, 0), outline=OL)
    body = dr.box(0, 0.3, 0.62, 0.52, r=0.07)
    cv.paint(body, dr.cylinder(0, 0.31, base, spec=0.4), outline=OL)
    cv.paint(dr.box(0, 0.5, 0.62, 0.03), base * 0.5)
    cv.paint(dr.box(0, 0.1, 0.62, 0.03), base * 0.5)
    cv.paint(
        dr.circle(0, 0.33, 0.06)
        | dr.polygon([(-0.035, 0.33), (0.035, 0.33), (0.05, 0.2), (-0.05, 0.2)]),
        0.05,
    )
    for sx in (-1.0, 1.0):
        cv.paint(
            dr.circle(sx * 0.24, 0.3, 0.02), dr.sphere(sx * 0.24, 0.3, 0.02, 0.9), outline=OL / 2
        )


def draw_pen(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a pen."""
    ang = dr.random_tilt_deg(rng, 22.0, 34.0)
    base = rng.uniform(0.15, 0.4)
    turn = dr.rotator(ang, 0.0, 0.7)
    nib = dr.polygon([(-0.035, 0.12), (0.035, 0.12), (0.006, 0.02), (-0.006, 0.02)])
    cv.paint(turn(nib), 0.75, outline=OL)
    cv.paint(
        turn(dr.box(0, 0.3, 0.085, 0.36, r=0.02)), dr.cylinder(0, 0.043, 0.25, spec=0.3), outline=OL
    )
    for k in range(6):
        cv.paint(turn(dr.box(0, 0.2 + 0.04 * k, 0.085, 0.012)), 0.08)
    cv.paint(
        turn(dr.box(0, 0.9, 0.1, 0.84, r=0.04)),
        dr.cylinder(0, 0.05, base + 0.3, spec=0.5),
        outline=OL,
    )
    cv.paint(turn(dr.box(0, 1.34, 0.1, 0.04)), dr.metal(0.8, 90 + ang), outline=OL)
    cv.paint(turn(dr.box(0.065, 1.15, 0.035, 0.42, r=0.015)), dr.metal(0.75, 90 + ang), outline=OL)
    cv.paint(turn(dr.ellipse(0, 1.4, 0.045, 0.04)), base, outline=OL)
