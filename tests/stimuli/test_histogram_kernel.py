"""The compiled equal-bin histogram of Otsu's threshold against ``numpy.histogram``, count for
count, values on the bins' edges and outside the range included."""

from __future__ import annotations

import numpy as np
import pytest

from stimuli.edgekernels import histogram_uniform


@pytest.mark.parametrize("seed", range(3))
def test_counts_are_numpys(seed):
    rng = np.random.default_rng(seed)
    for n_bins in (1, 7, 256):
        for _ in range(6):
            size = int(rng.integers(1, 5000))  # across blocks of values
            a = rng.random(size).astype(np.float32) ** float(rng.choice([1, 8]))
            lo, hi = (np.float32(v) for v in np.sort(rng.random(2)))
            if rng.random() < 0.5:
                lo, hi = a.min(), a.max()
            edges = np.linspace(lo, hi, n_bins + 1, endpoint=True, dtype=np.float32)
            # values on every edge, on both range ends, outside it, and 8-bit grey levels
            a = np.concatenate([a, edges, edges, [lo - 1, hi + 1, lo, hi]]).astype(np.float32)
            a = np.concatenate([a, (rng.integers(0, 256, 300) / 255).astype(np.float32)])
            rng.shuffle(a)
            if lo == hi:
                continue
            counts = np.zeros(n_bins, np.int64)
            histogram_uniform(a, lo, hi, edges, counts)
            want = np.histogram(a, bins=n_bins, range=(lo, hi))[0]
            assert np.array_equal(counts, want)
