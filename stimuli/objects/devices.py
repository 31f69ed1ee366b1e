"""Timepieces and electronics: an alarm clock, a wristwatch, a phone, headphones, a remote.

Drawn in object units; see :mod:`stimuli.objects.registry`.
"""

from __future__ import annotations

import math

import numpy as np

from stimuli.objects import drawing as dr
from stimuli.objects.drawing import OUTLINE_UNITS as OL

__all__ = ["draw_clock", "draw_watch", "draw_phone", "draw_headphones", "draw_remote"]


def _dial(
    cv: dr.Canvas,
    rng: np.random.Generator,
    centre: tuple[float, float],
    *,
    tick_radii: tuple[float, float, float],
    tick_widths: tuple[float, float],
    hands: tuple[tuple[float, float], tuple[float, float]],
) -> None:
    """Paint a clock face's 12 hour ticks and its hour and minute hands, at a random time.

    ``tick_radii`` = (inner radius of the minor ticks, of the four major ticks, outer radius);
    ``tick_widths`` = (minor, major) tick radius; ``hands`` = ((length, radius) of the hour
    hand, of the minute hand). Units of the drawing.
    """
    minor_r0, major_r0, r1 = tick_radii
    for k in range(12):
        a = k * math.pi / 6
        r0 = minor_r0 if k % 3 else major_r0
        p0 = (centre[0] + r0 * math.sin(a), centre[1] + r0 * math.cos(a))
        p1 = (centre[0] + r1 * math.sin(a), centre[1] + r1 * math.cos(a))
        cv.paint(dr.capsule(*p0, *p1, tick_widths[0] if k % 3 else tick_widths[1]), 0.1)
    h, m = rng.uniform(0, 2 * math.pi), rng.uniform(0, 2 * math.pi)
    for angle, (length, radius) in zip((h, m), hands, strict=True):
        tip = (centre[0] + length * math.sin(angle), centre[1] + length * math.cos(angle))
        cv.paint(dr.capsule(*centre, *tip, radius), 0.05)


def draw_clock(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw an alarm clock."""
    base = rng.uniform(0.3, 0.6)
    c = (0.0, 0.56)
    for sx in (-1.0, 1.0):
        cv.paint(dr.capsule(sx * 0.22, 0.2, sx * 0.3, 0.02, 0.03), 0.3, outline=OL)
        bell = dr.circle(sx * 0.26, 0.98, 0.14) & dr.above(0.94)
        cv.paint(
            dr.rotate(bell, -sx * 25, sx * 0.26, 0.9),
            dr.sphere(sx * 0.3, 1.0, 0.16, base * 1.3),
            outline=OL,
        )
    cv.paint(dr.capsule(0, 0.98, 0, 1.12, 0.02), 0.35, outline=OL)
    cv.paint(dr.box(0, 1.12, 0.2, 0.04, r=0.015), 0.35, outline=OL)
    cv.paint(dr.circle(*c, 0.42), dr.sphere(*c, 0.45, base), outline=OL)
    cv.paint(dr.circle(*c, 0.35), dr.gradient(-0.3, 0.85, 0.3, 0.3, 0.98, 0.82), outline=OL)
    ticks, widths = (0.27, 0.24, 0.31), (0.012, 0.02)
    _dial(cv, rng, c, tick_radii=ticks, tick_widths=widths, hands=((0.16, 0.022), (0.25, 0.015)))
    cv.paint(dr.circle(*c, 0.03), 0.4, outline=OL)


def draw_watch(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a wristwatch."""
    strap = rng.uniform(0.15, 0.35)
    c = (0.0, 0.62)
    for sy in (-1.0, 1.0):
        band = dr.box(0, c[1] + sy * 0.42, 0.3, 0.5, r=0.04)
        cv.paint(band, dr.gradient(-0.15, 0, 0.15, 0, strap * 1.4, strap * 0.8), outline=OL)
        for k in range(3):
            cv.paint(dr.box(0, c[1] + sy * (0.3 + 0.1 * k), 0.26, 0.008), strap * 0.5)
    for k in range(4):
        cv.paint(dr.ellipse(0, c[1] - 0.44 - 0.06 * k, 0.022, 0.016), 0.05)
    cv.paint(dr.box(0.3, c[1], 0.07, 0.08, r=0.015), dr.metal(0.7, 90), outline=OL)
    cv.paint(dr.circle(*c, 0.3), dr.sphere(*c, 0.34, 0.75), outline=OL)
    cv.paint(dr.circle(*c, 0.245), dr.gradient(-0.2, 0.85, 0.2, 0.4, 0.98, 0.8), outline=OL)
    ticks, widths = (0.19, 0.16, 0.22), (0.008, 0.014)
    _dial(cv, rng, c, tick_radii=ticks, tick_widths=widths, hands=((0.11, 0.016), (0.18, 0.011)))
    cv.paint(dr.circle(*c, 0.02), 0.3)


def draw_phone(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a mobile phone."""
    body = dr.box(0, 0.6, 0.62, 1.16, r=0.08)
    cv.paint(dr.box(0.315, 0.85, 0.02, 0.16, r=0.008), 0.4)
    cv.paint(body, dr.gradient(-0.3, 1.2, 0.3, 0.0, 0.3, 0.08), outline=OL)
    screen = dr.box(0, 0.6, 0.55, 1.06, r=0.05)
    wall_v = rng.uniform(0.3, 0.6)
    cv.paint(screen, dr.gradient(0, 1.13, 0, 0.07, wall_v + 0.3, wall_v - 0.2))
    for i in range(5):
        for j in range(4):
            v = rng.uniform(0.15, 1.0)
            cv.paint(
                dr.box(-0.195 + j * 0.13, 0.96 - i * 0.16, 0.09, 0.09, r=0.025), v, outline=OL / 2
            )
    for j in range(4):
        cv.paint(
            dr.box(-0.195 + j * 0.13, 0.16, 0.09, 0.09, r=0.025),
            rng.uniform(0.5, 1.0),
            outline=OL / 2,
        )
    cv.paint(dr.box(0, 0.245, 0.5, 0.003), 0.9)
    cv.paint(dr.capsule(-0.06, 1.1, 0.06, 1.1, 0.016), 0.02)
    cv.paint(dr.box(0, 0.1, 0.16, 0.012, r=0.006), 0.9)


def draw_headphones(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a pair of headphones."""
    base = rng.uniform(0.15, 0.35)
    cy = 0.56
    band = dr.ring(0, cy, 0.4, 0.08) & dr.above(cy)
    cv.paint(band, dr.sphere(0, cy + 0.2, 0.6, base + 0.2), outline=OL)
    pad = dr.ring(0, cy, 0.35, 0.035) & dr.above(cy + 0.2)
    cv.paint(pad, lambda x, y: base * 0.6 + 0.2 * (np.sin(np.arctan2(y - cy, x) * 40) > 0))
    for sx in (-1.0, 1.0):
        cv.paint(dr.box(sx * 0.4, cy - 0.05, 0.05, 0.18), dr.metal(0.75, 90), outline=OL)
        cv.paint(
            dr.box(sx * 0.33, 0.32, 0.1, 0.36, r=0.04),
            dr.gradient(0, 0.5, 0, 0.1, 0.55, 0.3),
            outline=OL,
        )
        cup = dr.box(sx * 0.43, 0.32, 0.17, 0.44, r=0.08)
        cv.paint(cup, dr.sphere(sx * 0.43, 0.32, 0.3, base + 0.15), outline=OL)
        cv.paint(dr.circle(sx * 0.43, 0.32, 0.04), 0.9, outline=OL / 2)


def draw_remote(cv: dr.Canvas, rng: np.random.Generator) -> None:
    """Draw a remote control."""
    ang = rng.uniform(-12.0, 12.0)
    base = rng.uniform(0.12, 0.3)
    turn = dr.rotator(ang, 0.0, 0.6)
    cv.paint(
        turn(dr.box(0, 0.62, 0.36, 1.2, r=0.08)), dr.cylinder(0, 0.18, base, spec=0.25), outline=OL
    )
    cv.paint(turn(dr.circle(-0.09, 1.1, 0.04)), 0.5, outline=OL / 2)
    cv.paint(turn(dr.ring(0, 0.84, 0.1, 0.06)), 0.7, outline=OL / 2)
    cv.paint(turn(dr.circle(0, 0.84, 0.04)), 0.85, outline=OL / 2)
    for i in range(4):
        for j in range(3):
            cv.paint(
                turn(dr.box(-0.1 + 0.1 * j, 0.58 - 0.09 * i, 0.07, 0.05, r=0.02)),
                0.8,
                outline=OL / 2,
            )
    for j in range(2):
        cv.paint(turn(dr.box(-0.07 + 0.14 * j, 0.17, 0.1, 0.08, r=0.03)), 0.55, outline=OL / 2)
