"""Tools and hardware: scissors, a key, a hammer, a screwdriver, a padlock and a pen.

Drawn in object units; see :mod:`stimuli.objects.registry`.
"""

from __future__ import annotations

import math

import numpy as np

from stimuli.objects.drawing import OUTLINE_UNITS as OL
from stimuli.objects.drawing import (
    Canvas,
    above,
    box,
    capsule,
    circle,
    cylinder,
    ellipse,
    metal,
    polygon,
    random_tilt_deg,
    ring,
    rotator,
    smooth_noise,
    sphere,
)

__all__ = [
    "draw_scissors",
    "draw_key",
    "draw_hammer",
    "draw_screwdriver",
    "draw_padlock",
    "draw_pen",
]


def draw_scissors(cv: Canvas, rng: np.random.Generator) -> None:
    """Draw a pair of scissors."""
    handle = rng.uniform(0.1, 0.3)
    pivot = (0.0, 0.62)
    for sign in (-1.0, 1.0):
        tip = (sign * 0.33, 1.38)
        ring_c = (-sign * 0.26, 0.22)
        dx, dy = tip[0] - pivot[0], tip[1] - pivot[1]
        n = math.hypot(dx, dy)
        px, py = -dy / n, dx / n
        blade = polygon(
            [
                (ring_c[0] * 0.45 + px * 0.05, 0.38 + py * 0.05),
                (pivot[0] + px * 0.055, pivot[1] + py * 0.055),
                tip,
                (pivot[0] - px * 0.04, pivot[1] - py * 0.04),
                (ring_c[0] * 0.45 - px * 0.05, 0.38 - py * 0.05),
            ]
        )
        cv.paint(blade, metal(0.72, math.degrees(math.atan2(dy, dx)) + 90), outline=OL)
        cv.paint(
            ring(ring_c[0], ring_c[1], 0.15, 0.07), sphere(*ring_c, 0.2, handle + 0.2), outline=OL
        )
        cv.paint(
            capsule(ring_c[0] * 0.45, 0.38, ring_c[0] * 0.8, 0.3, 0.045), handle + 0.1, outline=OL
        )
    cv.paint(circle(*pivot, 0.035), sphere(*pivot, 0.035, 0.8), outline=OL)


def draw_key(cv: Canvas, rng: np.random.Generator) -> None:
    """Draw a key."""
    base = rng.uniform(0.55, 0.75)
    ang = rng.uniform(10.0, 22.0)
    cy = 0.38
    turn = rotator(ang, 0.0, cy)
    bow = circle(-0.3, cy, 0.22) - circle(-0.4, cy, 0.065)
    shaft = box(0.2, cy, 0.62, 0.1, r=0.01)
    teeth = polygon(
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
    cv.paint(turn(bow | shaft | teeth), metal(base, ang + 90), outline=OL)
    cv.paint(turn(box(0.24, cy + 0.01, 0.5, 0.018)), base * 0.45)
    cv.paint(turn(ring(-0.3, cy, 0.17, 0.015)), base * 0.5)
    cv.paint(turn(ring(-0.4, cy, 0.1, 0.04)), 0.35, outline=OL / 2)


def draw_hammer(cv: Canvas, rng: np.random.Generator) -> None:
    """Draw a hammer."""
    wood = rng.uniform(0.55, 0.75)
    grain = smooth_noise(rng, (8, 64), 2.0)

    def wood_f(x, y):
        gi = np.clip(((y + 0.0) * 40).astype(int), 0, 63)
        return np.clip(wood + 0.12 * np.sin(x * 160 + grain[0, gi] * 3) * 0.5 + 0.4 * (x * 2), 0, 1)

    cv.paint(box(0.0, 0.48, 0.11, 0.94, r=0.05), wood_f, outline=OL)
    grip = box(0.0, 0.2, 0.13, 0.38, r=0.06)
    cv.paint(grip, lambda x, y: 0.15 + 0.12 * (np.sin(y * 120) > 0.3), outline=OL)
    head = box(0.0, 1.0, 0.5, 0.17, r=0.02)
    face = box(0.3, 1.0, 0.12, 0.22, r=0.02)
    claw = polygon(
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
    cv.paint(head | face | claw, metal(0.55, 90), outline=OL)
    cv.paint(polygon([(-0.62, 0.84), (-0.5, 0.955), (-0.58, 0.98)]), 0.3)
    cv.paint(box(0.36, 1.0, 0.015, 0.2), 0.9)


def draw_screwdriver(cv: Canvas, rng: np.random.Generator) -> None:
    """Draw a screwdriver."""
    ang = random_tilt_deg(rng, 22.0, 32.0)
    base = rng.uniform(0.55, 0.8)
    turn = rotator(ang, 0.0, 0.7)
    tip = polygon([(-0.03, 1.3), (0.03, 1.3), (0.022, 1.4), (-0.022, 1.4)])
    cv.paint(turn(box(0, 0.98, 0.06, 0.66) | tip), cylinder(0, 0.03, 0.75, spec=0.5), outline=OL)
    cv.paint(turn(box(0, 0.62, 0.13, 0.08, r=0.02)), cylinder(0, 0.065, 0.6, spec=0.4), outline=OL)
    handle = box(0, 0.34, 0.24, 0.52, r=0.1) | polygon(
        [(-0.1, 0.52), (0.1, 0.52), (0.065, 0.6), (-0.065, 0.6)]
    )
    cv.paint(turn(handle), cylinder(0, 0.12, base, spec=0.45), outline=OL)
    for k in range(4):
        groove = box(-0.075 + k * 0.05, 0.3, 0.022, 0.36, r=0.011)
        cv.paint(turn(groove), cylinder(0, 0.12, base * 0.35, spec=0.1))
    cv.paint(turn(box(0, 0.1, 0.2, 0.035, r=0.015)), base * 0.4)


def draw_padlock(cv: Canvas, rng: np.random.Generator) -> None:
    """Draw a padlock."""
    base = rng.uniform(0.5, 0.7)
    shackle = (
        (ring(0, 0.68, 0.19, 0.075) & above(0.68))
        | box(-0.19, 0.6, 0.075, 0.18)
        | box(0.19, 0.6, 0.075, 0.18)
    )
    cv.paint(shackle, metal(0.75, 0), outline=OL)
    body = box(0, 0.3, 0.62, 0.52, r=0.07)
    cv.paint(body, cylinder(0, 0.31, base, spec=0.4), outline=OL)
    cv.paint(box(0, 0.5, 0.62, 0.03), base * 0.5)
    cv.paint(box(0, 0.1, 0.62, 0.03), base * 0.5)
    cv.paint(
        circle(0, 0.33, 0.06) | polygon([(-0.035, 0.33), (0.035, 0.33), (0.05, 0.2), (-0.05, 0.2)]),
        0.05,
    )
    for sx in (-1.0, 1.0):
        cv.paint(circle(sx * 0.24, 0.3, 0.02), sphere(sx * 0.24, 0.3, 0.02, 0.9), outline=OL / 2)


def draw_pen(cv: Canvas, rng: np.random.Generator) -> None:
    """Draw a pen."""
    ang = random_tilt_deg(rng, 22.0, 34.0)
    base = rng.uniform(0.15, 0.4)
    turn = rotator(ang, 0.0, 0.7)
    nib = polygon([(-0.035, 0.12), (0.035, 0.12), (0.006, 0.02), (-0.006, 0.02)])
    cv.paint(turn(nib), 0.75, outline=OL)
    cv.paint(turn(box(0, 0.3, 0.085, 0.36, r=0.02)), cylinder(0, 0.043, 0.25, spec=0.3), outline=OL)
    for k in range(6):
        cv.paint(turn(box(0, 0.2 + 0.04 * k, 0.085, 0.012)), 0.08)
    cv.paint(
        turn(box(0, 0.9, 0.1, 0.84, r=0.04)), cylinder(0, 0.05, base + 0.3, spec=0.5), outline=OL
    )
    cv.paint(turn(box(0, 1.34, 0.1, 0.04)), metal(0.8, 90 + ang), outline=OL)
    cv.paint(turn(box(0.065, 1.15, 0.035, 0.42, r=0.015)), metal(0.75, 90 + ang), outline=OL)
    cv.paint(turn(ellipse(0, 1.4, 0.045, 0.04)), base, outline=OL)
