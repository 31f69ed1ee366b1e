"""The views' agreement test at edge pixels after a lower bound, on strips of rows in threads:
the verdict of the full-image test and of its numpy twin, to the bit."""

from __future__ import annotations

import numpy as np
import pytest

from stimuli.declutter import FOCUS_AGREEMENT_RATIO, FOCUS_NOISE, _agreement_numpy


def _pair(rng):
    """A centre view and a neighbour: noise, or stripes seen at a random whole-pixel shift,
    along either axis (views in [0, 1], as light fields hold them)."""
    shape = (int(rng.integers(3, 40)), int(rng.integers(3, 40)))
    if rng.random() < 0.3:
        return rng.random(shape).astype(np.float32), rng.random(shape).astype(np.float32)
    wide = (shape[0], shape[1] + 24)
    base = np.cumsum(rng.random(wide) < 0.15, axis=1) % 2 * 0.8 + 0.1
    base = (base + rng.normal(0, 0.01, wide)).clip(0, 1).astype(np.float32)
    s = int(rng.integers(0, 8))
    c, n = base[:, 12 : 12 + shape[1]], base[:, 12 - s // 2 + s : 12 - s // 2 + s + shape[1]]
    if rng.random() < 0.5:
        c, n = c.T, n.T
    return np.ascontiguousarray(c), np.ascontiguousarray(n)


@pytest.mark.parametrize("seed", range(3))
def test_bounded_test_is_the_full_test_and_the_numpy_chain(seed):
    """At random listed pixels (some already in focus), random planes and 1, 2 or 9
    disparities: the kernel's verdict and threshold image equal the one-disparity-at-
    a-time twin's; its verdict at the listed pixels equals the full-image numpy chain's."""
    from stimuli.edgefocus import focus_agreement_at
    from stimuli.edgekernels import focus_agreement_with_limit

    rng = np.random.default_rng(seed)
    r, noise = FOCUS_AGREEMENT_RATIO, FOCUS_NOISE
    for _ in range(60):
        c, nb = _pair(rng)
        axis, side = int(rng.integers(0, 2)), int(rng.choice([-1, 1]))
        d0, nd = rng.uniform(-6, 6), int(rng.choice([1, 2, 9]))
        ds = np.linspace(d0 - 1, d0 + 1, nd) if nd > 1 else np.array([d0])
        ds = ds[np.argsort(np.abs(ds - d0), kind="stable")]
        where = rng.random(c.shape) < rng.uniform(0.05, 1.0)
        start = rng.random(c.shape) < 0.1
        want, got = start.copy(), start.copy()
        lim_want = np.full(c.shape, np.nan, np.float32)
        lim_got = lim_want.copy()
        w8 = where.view(np.uint8)
        focus_agreement_with_limit(c, nb, axis, side, ds, r, noise, lim_want, w8, want)
        focus_agreement_at(c, nb, axis, side, ds, r, noise, lim_got, w8, got, 0, c.shape[0])
        assert np.array_equal(got, want)
        assert np.array_equal(lim_got, lim_want, equal_nan=True)
        chain = _agreement_numpy(c, nb, axis, side, ds)
        assert np.array_equal(got[where & ~start], chain[where & ~start])


def test_where_the_bound_does_not_pay_the_twins_order_gives_the_verdict():
    """On noise (the neighbour's samples span about all of [0, 1], so the bound rules out few
    pixels) the kernel stops making the bound after its trial and tries the disparities in
    the twin's order; on stripes seen far off the plane it rules out most; the verdicts and
    threshold images are the twin's either way."""
    from stimuli.edgefocus import _PAYS, _TRIAL_PX, focus_agreement_at
    from stimuli.edgekernels import focus_agreement_with_limit

    rng = np.random.default_rng(4)
    noise = [rng.random((60, 80)).astype(np.float32) for _ in range(2)]
    x = np.arange(120)
    stripes = np.tile(((x // 6) % 2 * 0.8 + 0.1).astype(np.float32), (60, 1))
    far = [np.ascontiguousarray(stripes[:, 20:100]), np.ascontiguousarray(stripes[:, 23:103])]
    ds = np.linspace(-0.5, 1.5, 9)
    ds = ds[np.argsort(np.abs(ds - 0.5), kind="stable")]
    for (c, nb), pays in ((noise, False), (far, True)):
        where = np.ones(c.shape, np.uint8)
        want, got = np.zeros(c.shape, bool), np.zeros(c.shape, bool)
        lw, lg = (np.full(c.shape, np.nan, np.float32) for _ in range(2))
        focus_agreement_with_limit(
            c, nb, 1, 1, ds, FOCUS_AGREEMENT_RATIO, FOCUS_NOISE, lw, where, want
        )
        bounded, skipped = focus_agreement_at(
            c, nb, 1, 1, ds, FOCUS_AGREEMENT_RATIO, FOCUS_NOISE, lg, where, got, 0, c.shape[0]
        )
        assert np.array_equal(got, want) and np.array_equal(lg, lw, equal_nan=True)
        assert bounded >= _TRIAL_PX
        assert (_PAYS * skipped >= bounded) == pays
        if not pays:
            assert bounded < c.size // 2  # the rest went the twin's way


def test_threaded_strips_give_the_one_pass_verdict(monkeypatch):
    """With the threads' threshold at 1 test, the agreement at listed pixels of a 3x3 and a
    1x7 light field runs on strips of rows taken in turn by two threads (the second started
    on the pool) and gives the single pass's mask and threshold images."""
    import stimuli.declutter as dc
    import stimuli.rowthreads as rt
    from stimuli.lfsynth import render_camera_array, three_plane_scene
    from stimuli.sharedstrips import SharedStrips

    strips, started = [], []

    class Spy(SharedStrips):
        def __init__(self, work, parts):
            strips.append(list(parts))
            super().__init__(work, parts)

    def spy_start(work, start=rt.start_on_thread):
        started.append(work)
        return start(work)

    shape = (48, 64)
    for grid in ((3, 3), (1, 7)):
        lf = render_camera_array(three_plane_scene(shape), grid=grid, shape_px=shape)
        d = lf.geometry.disparity_px(4.0) + 0.37
        where = np.random.default_rng(1).random(shape) < 0.3
        one = dc.agreement_mask(lf, d, where=where, cache=False)
        monkeypatch.setattr(dc, "AGREE_THREAD_MIN_TESTS", 1)
        monkeypatch.setattr(rt, "default_workers", lambda: 2)
        monkeypatch.setattr(rt, "cores_free", lambda: 1.0)
        monkeypatch.setattr(rt, "start_on_thread", spy_start)
        monkeypatch.setattr("stimuli.sharedstrips.SharedStrips", Spy)
        n = len(started)
        two = dc.agreement_mask(lf, d, where=where, cache=False)
        monkeypatch.undo()
        assert len(started) == n + 1 and len(strips[-1]) > 2
        assert strips[-1][0][0] == 0 and strips[-1][-1][1] == shape[0]
        assert all(a[1] == b[0] for a, b in zip(strips[-1], strips[-1][1:], strict=False))
        assert np.array_equal(one, two) and one.any() and not one[where].all()
        assert np.array_equal(one, dc.agreement_mask(lf, d) & where)
