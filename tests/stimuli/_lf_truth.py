"""Ground-truth disparity of the shared light fields' centre views, for the stimulus tests.

* Middlebury Baby1 / Aloe: ``disp1.png`` is view 1's disparity (``disp1 / 8`` px per view step,
  0 = unknown). View 1 sees a point at ``x`` where the centre view 3 sees it at ``x - 2 d``
  (SOURCES.md: ``I_1(x) = I_k(x - (k - 1) d)``), so each known pixel is moved there; where two
  land on one pixel the nearer (larger disparity) wins, as it occludes the other.
* HCI antinous: ``gt_disp_lowres.pfm`` is the centre view's own disparity.

Unknown pixels are NaN.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from stimuli.io import load_gray
from stimuli.lightfield import read_pfm

__all__ = ["centre_truth", "TRUTH_CAPTURES"]

#: Shared light fields with a ground-truth disparity map (folders under ``lightfield/``).
TRUTH_CAPTURES: tuple[str, ...] = ("middlebury_Baby1", "middlebury_Aloe", "hci_antinous_3x3_gt")


def centre_truth(root: Path) -> np.ndarray:
    """Return the centre view's ground-truth disparity, px per view step (NaN = unknown)."""
    if root.name.startswith("middlebury"):
        disp = load_gray(root / "disp1.png").astype(np.float64) * 255.0 / 8.0
        out = np.full(disp.shape, -np.inf)
        ys, xs = np.nonzero(disp > 0)
        d = disp[ys, xs]
        xc = np.round(xs - 2.0 * d).astype(int)
        ok = (xc >= 0) & (xc < disp.shape[1])
        np.maximum.at(out, (ys[ok], xc[ok]), d[ok])
        out[~np.isfinite(out)] = np.nan
        return out
    return read_pfm(root / "gt_disp_lowres.pfm").astype(np.float64)
