"""The data-driven disparity range brackets the scene on small grids, and the peak rule keeps a
real plane whose hill sits just under the shoulder fraction.

Measured (px per view step), range before -> after this rule:

* synthetic 3x3 three-plane scene, 30 mm baseline, no geometry (truth 1.33, 3, 12):
  -34.0..14.0 -> -6.5..13.5;
* HCI antinous 3x3 (ground truth -3.13..2.69): -8.0..4.0 -> -4.5..4.0.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from stimuli import agreementscan
from stimuli.lfsynth import render_camera_array, three_plane_scene
from stimuli.lightfield import LightField, load_lightfield, read_pfm
from stimuli.planes import estimate_disparity_range, find_object_planes
from tests.conftest import require_data


@pytest.fixture(scope="module")
def synthetic_3x3():
    """The three-plane scene on a 3x3 grid, its geometry dropped (the range is the data's)."""
    lf = render_camera_array(
        three_plane_scene((327, 492)), grid=(3, 3), shape_px=(327, 492), baseline_m=0.03
    )
    truth = [lf.geometry.disparity_px(z) for z in (1.0, 4.0, 9.0)]  # 12, 3, 1.33
    return LightField(lf.views), truth


def test_range_brackets_the_synthetic_3x3_scene_tightly(synthetic_3x3):
    lf, truth = synthetic_3x3
    lo, hi = estimate_disparity_range(lf)
    assert lo < min(truth) and hi > max(truth)
    # Tight: the range is at most twice the scene's span (it was 3.8 times: -34..14).
    assert hi - lo <= 2.0 * (max(truth) - min(truth)), (lo, hi)
    assert hi <= max(truth) + 2.0, (lo, hi)


def test_synthetic_3x3_scan_finds_the_near_and_far_planes(synthetic_3x3):
    lf, truth = synthetic_3x3
    found = [p.disparity_px for p in find_object_planes(lf).peaks]
    # The pedestrian (12 px) and the far hill (tree 3 px and building 1.33 px, which a 3x3
    # grid binned 2x does not separate) are both reported; nothing else.
    assert min(abs(f - truth[0]) for f in found) <= 0.5, found
    assert min(abs(f - truth[2]) for f in found) <= 0.5, found
    assert len(found) == 2, found


def test_range_brackets_the_hci_3x3_light_field(data_dir):
    root = require_data(data_dir, "lightfield", "hci_antinous_3x3_gt")
    gt = read_pfm(require_data(root, "gt_disp_lowres.pfm"))
    gt = gt[np.isfinite(gt)]
    lf = load_lightfield(root, gray=True)
    lo, hi = estimate_disparity_range(lf)
    a, b = np.quantile(gt, [0.01, 0.99])
    assert lo < a and hi > b, (lo, hi, a, b)
    # Tight: within 1.5 px per view step of the scene on either side (it was -8..4).
    assert lo >= a - 1.5 and hi <= b + 1.6, (lo, hi, a, b)


@pytest.mark.parametrize(
    ("height", "prominence", "null", "kept"),
    [
        (1.0, 0.49, 0.01, True),  # the knife edge: 49 % of its height, 49x the null
        (1.0, 0.50, 0.01, True),
        (1.0, 0.49, 0.2, False),  # the same hill, with only 2.45x the null: a shoulder
        (1.0, 0.20, 0.01, False),  # too shallow even with strong evidence
        (1.0, 0.9, 0.5, False),  # under the evidence floor
    ],
)
def test_peak_rule_has_hysteresis(height, prominence, null, kept):
    assert agreementscan._is_plane_peak(height, prominence, null) is kept


def test_a_coarse_scan_keeps_a_plane_beside_the_geometrys_far_limit_off_its_censored_end():
    """A few planes far apart (3x3 views of 96x120 px, 20 planes: 0.7 px per view step apart):
    the building, 1.33 px per view step, stands a third of a pixel inside the renderer's far
    limit (1 px). With the end plane at that limit, its pixels voted for the censored end
    (30.5 % of the image, a "widen it" warning) and the building was not found; the end plane
    now lies a spacing beyond it."""
    from stimuli.planes import default_disparities

    lf = render_camera_array(
        three_plane_scene((96, 120)), grid=(3, 3), shape_px=(96, 120), baseline_m=0.03
    )
    building = lf.geometry.disparity_px(9.0)
    far_limit = lf.geometry.disparity_px(lf.geometry.far_m)
    ds = default_disparities(lf, 20)
    spacing = ds[1] - ds[0]
    assert ds[0] <= far_limit - spacing * (1 - 1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no pile-up at either end
        scan = find_object_planes(lf, ds)
    assert min(abs(p.disparity_px - building) for p in scan.peaks) < 0.5 * spacing


def test_a_fine_scan_of_a_scene_with_no_limits_scans_the_estimated_range(synthetic_3x3):
    """With the default 200 planes the range's margin is wider than a spacing: the planes are
    the range's, to the bit (the same scan as before the end planes were placed)."""
    from stimuli.planes import default_disparities

    lf, _ = synthetic_3x3
    lo, hi = estimate_disparity_range(lf)
    ds = default_disparities(lf)
    assert np.array_equal(ds, np.linspace(lo, hi, 200))
