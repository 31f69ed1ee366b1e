"""The plane scan's own peak finder and its light imports."""

import subprocess
import sys

import numpy as np
import pytest
from scipy.signal import find_peaks as scipy_find_peaks
from scipy.signal import peak_prominences as scipy_peak_prominences

from stimuli.planescan import find_peaks, peak_prominences


def _curves():
    rng = np.random.default_rng(3)
    for n in (3, 4, 7, 50, 200, 513):
        yield rng.random(n)
        # plateaus and exact ties: quantised values, runs of equal samples, flat ends
        yield np.round(rng.random(n) * 4) / 4
        yield np.repeat(np.round(rng.random(max(1, n // 3)) * 3), 3)[:n]
        yield np.convolve(rng.random(n + 10), np.ones(7) / 7, mode="same")[:n]


@pytest.mark.parametrize("prominence", [0.0, 0.05, 0.3])
def test_find_peaks_matches_scipy(prominence):
    for x in _curves():
        idx, props = find_peaks(x, prominence=prominence)
        ref, ref_props = scipy_find_peaks(x, prominence=prominence)
        np.testing.assert_array_equal(idx, ref)
        np.testing.assert_array_equal(props["prominences"], ref_props["prominences"])


@pytest.mark.filterwarnings("ignore:some peaks have a prominence of 0")
def test_peak_prominences_matches_scipy_at_any_sample():
    for x in _curves():
        peaks = np.arange(x.size)
        np.testing.assert_array_equal(
            peak_prominences(x, peaks)[0], scipy_peak_prominences(x, peaks)[0]
        )


def test_plane_detection_does_not_import_scipy_signal():
    code = (
        "import sys, numpy as np\n"
        "from stimuli.planes import find_object_planes\n"
        "tex = np.random.default_rng(0).random((80, 120)).astype(np.float32)\n"
        "lf = np.stack([np.stack([np.roll(tex, (-2 * (u - 2), -2 * (v - 2)), (0, 1))"
        " for v in range(5)]) for u in range(5)])\n"
        "scan = find_object_planes(lf, n_planes=40)\n"
        "assert [round(p.disparity_px) for p in scan.peaks] == [2], scan.peaks\n"
        "print('scipy.signal' in sys.modules, 'matplotlib' in sys.modules)\n"
    )
    out = subprocess.run(
        [sys.executable, "-W", "ignore", "-c", code], capture_output=True, text=True, check=True
    )
    assert out.stdout.split() == ["False", "False"]


def _shifted_grid(tex, grid, d):
    """Views of one fronto-parallel plane at disparity ``d`` (whole-pixel shifts, wrapped)."""
    n_u, n_v = grid
    return np.stack(
        [
            np.stack(
                [
                    np.roll(tex, (-d * (u - n_u // 2), -d * (v - n_v // 2)), (0, 1))
                    for v in range(n_v)
                ]
            )
            for u in range(n_u)
        ]
    ).astype(np.float32)


@pytest.mark.parametrize("grid", [(3, 5), (5, 3), (1, 7), (7, 1)])
def test_sweep_finds_the_plane_along_rows_and_columns(grid):
    """The row-shifted and the column-shifted views are shifted by the plane's disparity: the
    best plane of the textured pixels is the true one on every layout (non-square views)."""
    from stimuli.agreementscan import _scan_inputs, _sweep
    from stimuli.lfload import as_lightfield

    tex = np.random.default_rng(11).random((70, 96)).astype(np.float32)
    lf = as_lightfield(_shifted_grid(tex, grid, 2))
    ds = np.linspace(-3.0, 5.0, 33)  # 2.0 is ds[20]
    _, views, offsets, centre, null_centre = _scan_inputs(lf, 1)
    best_i, agrees, _, _ = _sweep(views, offsets, centre, null_centre, ds, 2)
    assert agrees.mean() > 0.5
    assert np.mean(best_i[agrees] == 20) > 0.95


def test_sweep_of_the_transposed_light_field_is_transposed():
    from stimuli.agreementscan import _scan_inputs, _sweep
    from stimuli.lfload import as_lightfield

    rng = np.random.default_rng(12)
    views = rng.random((3, 5, 60, 84)).astype(np.float32)
    views[:, :, 20:40] = _shifted_grid(rng.random((20, 84)), (3, 5), 1)
    ds = np.linspace(-2.0, 2.0, 17)
    out = []
    for lf in (views, views.transpose(1, 0, 3, 2)):
        _, v, offsets, centre, null_centre = _scan_inputs(
            as_lightfield(np.ascontiguousarray(lf)), 1
        )
        out.append(_sweep(v, offsets, centre, null_centre, ds, 1))
    (b, a, _, _), (bt, at, _, _) = out
    assert np.mean(a == at.T) > 0.99
    assert np.mean(b[a & at.T] == bt.T[a & at.T]) > 0.99


def test_plane_choice_reuses_the_scans_sweep_and_never_a_stale_one(monkeypatch):
    import stimuli.agreementscan as ag
    from stimuli.planes import find_object_planes

    rng = np.random.default_rng(13)
    views = _shifted_grid(rng.random((64, 90)), (5, 5), 2)
    calls = []
    real = ag._sweep
    monkeypatch.setattr(ag, "_sweep", lambda *a: calls.append(1) or real(*a))
    ds = np.linspace(-1.0, 4.0, 41)
    scan = find_object_planes(views, ds, binning=1)
    n = len(calls)
    best_i, agrees = ag.best_plane_map(views, ds, binning=1)
    assert len(calls) == n  # the same views and planes: no second sweep
    best_i[:] = 0  # the caller's copy: the stored result is untouched
    again, _ = ag.best_plane_map(views, ds, binning=1)
    assert len(calls) == n and np.mean(again[agrees] == 24) > 0.95
    other = views.copy()
    other[2, 2, 10:20, 10:20] = 0.0  # changed views must be swept again
    ag.best_plane_map(other, ds, binning=1)
    assert len(calls) == n + 1
    assert [round(p.disparity_px) for p in scan.peaks] == [2]
