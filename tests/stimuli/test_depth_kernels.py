"""The depth de-clutter's compiled passes against their numpy twins, to the bit."""

from __future__ import annotations

import numpy as np
import pytest

from stimuli.declutter import declutter_depth


@pytest.mark.parametrize("seed", range(6))
def test_compiled_vote_is_the_numpy_twin(seed):
    """Random images, edge densities and evidence (bool, and uint8 with dropped pixels): the
    kept edges are the two box filters' to the bit, ties of the local majority included."""
    rng = np.random.default_rng(seed)
    shape = (int(rng.integers(1, 160)), int(rng.integers(1, 160)))
    img = rng.random(shape).astype(np.float32)
    img[:, : shape[1] // 2] *= 0.2  # a flat half and a busy half
    evidence = rng.integers(0, 3, shape).astype(np.uint8)
    for focus in (evidence, evidence == 1):
        for t in (0.05, 0.2):
            fast = declutter_depth(img, focus, threshold=t)
            slow = declutter_depth(img, focus, threshold=t, compiled=False)
            assert np.array_equal(fast, slow)
    # blocks of ties: half the edges of each box in focus
    img = np.tile(np.array([[0.0, 1.0]], np.float32), (40, 30))
    focus = np.zeros(img.shape, bool)
    focus[:, ::4] = True
    focus[:, 1::4] = True
    fast = declutter_depth(img, focus, threshold=0.1)
    assert np.array_equal(fast, declutter_depth(img, focus, threshold=0.1, compiled=False))
    assert 0 < fast.sum() < img.size


@pytest.mark.parametrize("grid", [(1, 7), (3, 3), (7, 1)])
def test_evidence_at_the_edges_is_the_full_evidence_there(grid):
    """The in-focus test run only where it is read (the edge pixels, and on 1-D light fields
    the edges the unmeasured ones take their depth from) gives the depth edges of the full
    test, to the bit, and its evidence equals the full evidence at those edges."""
    from stimuli.declutter import agreement_mask, auto_threshold, declutter, in_focus_evidence
    from stimuli.refocus import refocus
    from tests.stimuli.test_edge_depth import D_BOX, _box_scene

    lf, _ = _box_scene(grid)
    for d in (D_BOX, 1.3):
        img = refocus(lf, d)
        t = auto_threshold(img)
        edges = declutter(img, threshold=t)
        full, stats = in_focus_evidence(lf, d, confocal=img)
        part, stats_part = in_focus_evidence(lf, d, confocal=img, where=edges)
        assert stats == stats_part
        assert np.array_equal(full[edges], part[edges])
        assert np.array_equal(
            declutter_depth(img, full, threshold=t), declutter_depth(img, part, threshold=t)
        )
        at = agreement_mask(lf, d, where=edges)
        assert np.array_equal(at, agreement_mask(lf, d) & edges)
        assert at.any() and not at.all()


def test_label_extents_are_find_objects():
    from scipy import ndimage

    from stimuli.edgedepth import _extents

    rng = np.random.default_rng(0)
    lab, n = ndimage.label(rng.random((120, 170)) < 0.3, np.ones((3, 3), bool))
    boxes = ndimage.find_objects(lab)
    top, bottom, left, right = _extents(lab, n)
    assert n > 10
    assert top.tolist() == [b[0].start for b in boxes]
    assert bottom.tolist() == [b[0].stop - 1 for b in boxes]
    assert left.tolist() == [b[1].start for b in boxes]
    assert right.tolist() == [b[1].stop - 1 for b in boxes]


@pytest.mark.parametrize("shape", [(1, 1), (7, 3), (3, 50), (90, 130)])
def test_box_max_is_scipys_dilation(shape):
    from scipy import ndimage

    from stimuli.edgedepth import _box_max, _grow

    rng = np.random.default_rng(1)
    mask = rng.random(shape) < 0.1
    labels, _ = ndimage.label(mask, np.ones((3, 3), bool))
    for size in (5, 7):
        assert np.array_equal(_box_max(labels, size), ndimage.grey_dilation(labels, size=size))
        ref = ndimage.maximum_filter(mask.view(np.uint8), size=size, mode="constant") > 0
        assert np.array_equal(_grow(mask, size), ref)


@pytest.mark.parametrize("grid", [(1, 7), (3, 3)])
def test_scan_and_refocus_depth_edges_are_those_of_the_full_test(grid):
    """``depth_evidence`` (what ``lightfield scan`` and ``refocus`` run) gives the edges and
    cells of the evidence tested at every pixel, with and without a zoom box, for the Otsu and
    the retention threshold."""
    from stimuli.declutter import in_focus_evidence
    from stimuli.edgegrid import declutter_and_compress, depth_evidence
    from stimuli.refocus import refocus
    from tests.stimuli.test_edge_depth import D_BOX, _box_scene

    lf, _ = _box_scene(grid)
    img = refocus(lf, D_BOX)
    centre = lf.centre_view()
    full, _ = in_focus_evidence(lf, D_BOX, confocal=img)
    rows, cols = img.shape
    for box in (None, (slice(3, rows - 5), slice(7, cols - 2))):
        rs, cs = box or (slice(None), slice(None))
        for c in (None, centre):
            ev, _, t = depth_evidence(lf, D_BOX, img, centre_view=c, box=box)
            cc = None if c is None else np.ascontiguousarray(c[rs, cs])
            z = np.ascontiguousarray(img[rs, cs])
            a = declutter_and_compress(
                z, (8, 8), edge_ratio=1 / 13, focus_mask=full[rs, cs], centre_view=cc
            )
            b = declutter_and_compress(
                z,
                (8, 8),
                threshold=t,
                edge_ratio=1 / 13,
                focus_mask=np.ascontiguousarray(ev[rs, cs]),
                centre_view=cc,
            )
            assert a[2] == b[2]
            assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
            assert a[0].any()


@pytest.mark.parametrize("shape", [(1, 1), (2, 9), (6, 7), (40, 57)])
def test_edge_depth_filters_are_scipys(shape):
    """The compiled Sobel pair and 5x5 box mean of the edge confidence are scipy's, to the
    bit (small images take scipy itself)."""
    from scipy import ndimage

    from stimuli.edgedepth import _box_mean, _sobel_pair

    rng = np.random.default_rng(2)
    img = rng.random(shape).astype(np.float32)
    gy, gx = _sobel_pair(img)
    assert np.array_equal(gy, ndimage.sobel(img, axis=0))
    assert np.array_equal(gx, ndimage.sobel(img, axis=1))
    for g in (gy, gx):
        assert np.array_equal(_box_mean(g**2, 5), ndimage.uniform_filter(g**2, 5))
