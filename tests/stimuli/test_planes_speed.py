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
