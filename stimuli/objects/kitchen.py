"""Tableware: a cup, a mug, a bottle, a teapot, a wine glass, a fork and a spoon.

Drawn in object units; see :mod:`stimuli.objects.registry`.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from stimuli.objects import drawing as dr
from stimuli.objects.drawing import OUTLINE_UNITS as OL

__all__ = [
    "draw_cup",
    "draw_mug",
    "draw_bottle",
    "draw_teapot",
    "draw_wine_glass",
    "draw_fork",
    "draw_spoon",
]


def draw_cup(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a cup."""
    base = rng.uniform(0.75, 0.92)
    cv.paint(dr.ellipse(0, 0.05, 0.5, 0.055), dr.gradient(0, 0.1, 0, 0.0, 0.9, 0.55), outline=OL)
    cv.paint(dr.ellipse(0, 0.07, 0.3, 0.03), 0.5)
    cv.paint(dr.ring(0.37, 0.38, 0.12, 0.05), dr.metal(base * 0.9, 45), outline=OL)
    body = dr.polygon([(-0.25, 0.08), (0.25, 0.08), (0.33, 0.64), (-0.33, 0.64)]) | dr.ellipse(
        0, 0.09, 0.25, 0.035
    )
    cv.paint(body, dr.cylinder(0, 0.33, base), outline=OL)
    band = body & dr.box(0, 0.47, 1.0, 0.07)
    cv.paint(band, dr.cylinder(0, 0.33, base * 0.45, spec=0.15))
    for k in range(-2, 3):
        cv.paint(dr.circle(k * 0.1, 0.3, 0.025), dr.cylinder(0, 0.33, base * 0.5, spec=0.1))
    cv.paint(dr.ellipse(0, 0.64, 0.33, 0.06), dr.gradient(0, 0.7, 0, 0.58, 0.55, 0.85), outline=OL)
    cv.paint(dr.ellipse(0, 0.63, 0.29, 0.042), 0.18)


def draw_mug(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a mug."""
    base = rng.uniform(0.35, 0.6)
    handle = dr.stroke(dr.box(0.35, 0.38, 0.3, 0.4, r=0.12), 0.075)
    cv.paint(handle - dr.box(0.1, 0.38, 0.3, 0.6), dr.metal(base, 80), outline=OL)
    body = dr.box(0, 0.37, 0.66, 0.74, r=0.03)
    cv.paint(body, dr.cylinder(0, 0.33, base, spec=0.4), outline=OL)
    cv.paint(dr.circle(-0.02, 0.4, 0.14), 0.92, outline=OL)
    cv.paint(dr.polygon([(-0.1, 0.42), (-0.02, 0.3), (0.06, 0.42), (-0.02, 0.5)]), 0.15)
    for i, w in enumerate((0.34, 0.22)):
        cv.paint(dr.box(-0.02, 0.17 - 0.05 * i, w, 0.022, r=0.01), 0.95)
    cv.paint(dr.ellipse(0, 0.74, 0.33, 0.05), dr.gradient(0, 0.79, 0, 0.69, base * 0.6, base * 1.2))
    cv.paint(dr.ellipse(0, 0.735, 0.3, 0.038), 0.12, outline=OL)


def draw_bottle(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a bottle."""
    base = rng.uniform(0.2, 0.4)
    glass = dr.cylinder(0, 0.22, base, spec=0.55)
    body = dr.box(0, 0.4, 0.44, 0.78, r=0.05)
    shoulder = dr.polygon([(-0.22, 0.74), (0.22, 0.74), (0.08, 1.0), (-0.08, 1.0)])
    neck = dr.box(0, 1.12, 0.15, 0.3, r=0.02)
    cv.paint(body | shoulder | neck, glass, outline=OL)
    cv.paint(dr.box(0, 1.28, 0.17, 0.1, r=0.015), dr.stripes(0.02, 0.75, 0.45), outline=OL)
    label = dr.box(0, 0.38, 0.445, 0.34)
    cv.paint(label, dr.cylinder(0, 0.22, 0.95, spec=0.1), outline=OL)
    cv.paint(dr.ellipse(0, 0.43, 0.13, 0.08), dr.cylinder(0, 0.22, 0.35, spec=0.0), outline=OL / 2)
    for i, w in enumerate((0.28, 0.2, 0.24)):
        cv.paint(dr.box(0, 0.3 - 0.045 * i, w, 0.018), 0.25)
    cv.paint(dr.box(0, 1.0, 0.18, 0.05), dr.cylinder(0, 0.09, 0.9, spec=0.1), outline=OL / 2)


def draw_teapot(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a teapot."""
    base = rng.uniform(0.7, 0.9)
    cv.paint(dr.ring(0.38, 0.42, 0.15, 0.055), dr.metal(base * 0.8, 45), outline=OL)
    spout = dr.polygon(
        [
            (-0.25, 0.25),
            (-0.45, 0.45),
            (-0.58, 0.66),
            (-0.64, 0.68),
            (-0.6, 0.6),
            (-0.47, 0.34),
            (-0.28, 0.45),
        ]
    )
    cv.paint(spout, dr.gradient(-0.6, 0.7, -0.3, 0.3, base, base * 0.6), outline=OL)
    cv.paint(dr.box(0, 0.05, 0.38, 0.08, r=0.02), base * 0.6, outline=OL)
    body = dr.ellipse(0, 0.37, 0.38, 0.3)
    cv.paint(body, dr.sphere(0, 0.37, 0.42, base), outline=OL)
    for k in range(-2, 3):
        cx, cyy = k * 0.13, 0.36 + 0.02 * (abs(k) == 1)
        cv.paint(dr.circle(cx, cyy, 0.035), 0.3)
        for j in range(5):
            a = j * 2 * math.pi / 5
            cv.paint(dr.circle(cx + 0.05 * math.cos(a), cyy + 0.05 * math.sin(a), 0.025), 0.5)
    cv.paint(dr.ellipse(0, 0.66, 0.22, 0.045), base * 0.7, outline=OL)
    cv.paint(
        dr.ellipse(0, 0.68, 0.18, 0.08) & dr.above(0.67), dr.sphere(0, 0.67, 0.2, base), outline=OL
    )
    cv.paint(dr.circle(0, 0.79, 0.04), dr.sphere(0, 0.79, 0.04, base * 0.8), outline=OL)


def draw_wine_glass(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a wine glass."""
    wine = rng.uniform(0.1, 0.3)
    glass = dr.cylinder(0, 0.25, 0.75, spec=0.5)
    bowl = dr.ellipse(0, 0.98, 0.26, 0.34) & dr.below(1.3)
    cv.paint(dr.ellipse(0, 0.06, 0.28, 0.05), glass, opacity=0.85, outline=OL)
    cv.paint(dr.box(0, 0.38, 0.04, 0.64, r=0.02), glass, opacity=0.85, outline=OL)
    cv.paint(bowl, glass, opacity=0.6, outline=OL)
    cv.paint(bowl & dr.below(0.96), dr.cylinder(0, 0.25, wine * 2, spec=0.25), opacity=0.95)
    cv.paint(dr.ellipse(0, 0.96, 0.255, 0.035), wine * 2.5, outline=OL / 2)
    cv.paint(dr.stroke(dr.ellipse(0, 1.3, 0.2, 0.03), 0.012), 0.15)
    cv.paint(dr.capsule(-0.16, 0.9, -0.13, 1.2, 0.018), 1.0, opacity=0.85)


def _utensil(
    cv: dr.Canvas, ang: float, head: Callable[[], tuple[dr.Shape, dr.Field]], base: float
) -> None:
    """Paint a piece of cutlery tilted by ``ang``: a metal handle and the head ``head()`` gives."""
    cx, cy = 0.0, 0.65
    turn = dr.rotator(ang, cx, cy)
    handle = dr.polygon([(-0.06, 0.1), (0.06, 0.1), (0.035, 0.85), (-0.035, 0.85)]) | dr.ellipse(
        0, 0.12, 0.065, 0.07
    )
    cv.paint(turn(handle), dr.metal(base, ang), outline=OL)
    shape, shade = head()
    cv.paint(turn(shape), shade, outline=OL)
    cv.paint(turn(dr.capsule(-0.01, 0.15, -0.01, 0.7, 0.008)), 0.97, opacity=0.8)


def draw_fork(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a fork."""
    ang = dr.random_tilt_deg(rng, 20.0, 32.0)

    def head():
        s = dr.polygon(
            [(-0.035, 0.84), (0.035, 0.84), (0.12, 1.0), (0.12, 1.06), (-0.12, 1.06), (-0.12, 1.0)]
        )
        for k in range(4):
            x = -0.1 + k * 0.0667
            s = s | dr.box(x, 1.2, 0.038, 0.3, r=0.018)
        return s, dr.metal(0.7, 90)

    _utensil(cv, ang, head, 0.7)


def draw_spoon(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a spoon."""
    ang = dr.random_tilt_deg(rng, 20.0, 32.0)

    def head():
        s = dr.ellipse(0, 1.08, 0.14, 0.23) | dr.polygon(
            [(-0.035, 0.84), (0.035, 0.84), (0.05, 0.9), (-0.05, 0.9)]
        )

        def concave(x, y):
            u, v = x / 0.14, (y - 1.08) / 0.23
            return np.clip(
                0.45
                + 0.35 * u
                - 0.25 * v
                + 0.45 * np.exp(-((u - 0.3) ** 2 + (v + 0.3) ** 2) / 0.08),
                0,
                1,
            )

        return s, concave

    _utensil(cv, ang, head, 0.72)
