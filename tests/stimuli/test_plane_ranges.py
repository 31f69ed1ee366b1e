"""The planes found do not depend on the range of disparities asked for.

A rendered row of 7 views (:func:`stimuli.lfsynth.render_views`) holds three textured planes at
known disparities (0.5, 2.5 and 4 px per view step). Scans over the default range and over
nested, shifted and wide ranges that contain all three (two of them within 0.3 px of the
planes at the range's ends, one 61 px per view step wide) must each find the three planes
within 0.5 px per view step, and no other plane. The test is shown to fail on a finder whose
planes move with the range: the same scan with its support curve smoothed by a fixed number
of planes instead of a fixed disparity (so a wide range blurs neighbouring planes into one).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from stimuli import agreementscan
from stimuli.lfsynth import render_views
from stimuli.lightfield import LightField
from stimuli.planes import find_object_planes
from stimuli.scene import Layer

#: The planes, px per view step: a far wall and two squares in front of it.
TRUTH = (0.5, 2.5, 4.0)
#: Ranges that contain the planes: nested, shifted, tight at both ends, wide.
RANGES = ((0.2, 4.3), (0.0, 5.0), (-3.0, 4.5), (0.3, 12.0), (-10.0, 10.0), (-30.0, 31.0))


def _scene(grid=(1, 7), shape=(96, 128), seed=3) -> LightField:
    rng = np.random.default_rng(seed)
    m = 48
    big = (shape[0] + 2 * m, shape[1] + 2 * m)
    layers = []
    for k, d in enumerate(TRUTH):
        tex = ndimage.gaussian_filter(rng.random(big), 1.0)
        tex = ((tex - tex.min()) / np.ptp(tex)).astype(np.float32)
        alpha = np.ones(big, np.float32)
        if k:
            alpha[:] = 0.0
            y0, x0 = m + 8 + 22 * (k - 1), m + 10 + 50 * (k - 1)
            alpha[y0 : y0 + 50, x0 : x0 + 45] = 1.0
        layers.append(Layer(f"plane {d}", tex, alpha, 10.0 / (k + 1)))
    return LightField(render_views(layers, list(TRUTH), grid, shape))


def _range_dependence(lf: LightField) -> list[str]:
    """Every way the planes found depend on the range (empty when they do not)."""
    out = []
    scans = {"default": find_object_planes(lf)}
    for a, b in RANGES:
        scans[f"{a:g}..{b:g}"] = find_object_planes(lf, np.linspace(a, b, 200))
    for name, scan in scans.items():
        found = [p.disparity_px for p in scan.peaks]
        for d in TRUTH:
            if not found or min(abs(f - d) for f in found) > 0.5:
                out.append(f"{name}: no plane within 0.5 px of {d} (found {found})")
        extra = [f for f in found if min(abs(f - d) for d in TRUTH) > 0.5]
        if extra:
            out.append(f"{name}: planes with no support {extra}")
        if any(not p.support > 0 for p in scan.peaks):
            out.append(f"{name}: a plane without support")
    return out


@pytest.fixture(scope="module")
def scene() -> LightField:
    return _scene()


@pytest.mark.filterwarnings("ignore:.*agree best at the")
def test_planes_are_the_same_for_every_range_that_contains_them(scene):
    assert _range_dependence(scene) == []


@pytest.mark.filterwarnings("ignore:.*agree best at the")
def test_the_check_fails_on_a_finder_whose_planes_move_with_the_range(scene, monkeypatch):
    """Mutation: the support curve smoothed by 8 planes whatever their spacing (as if every
    range were scanned at 0.01 px per plane); on the wide ranges the near planes merge."""
    monkeypatch.setattr(agreementscan, "median_spacing", lambda ds: 0.01)
    problems = _range_dependence(scene)
    assert problems, "the range check passed a range-dependent finder"
    assert any(r.startswith("-30..31") for r in problems), problems
