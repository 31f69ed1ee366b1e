"""The views' agreement at the edge pixels run on a second thread beside the edge classes of a
1-D light field: the evidence of the single-thread call, to the bit."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.mark.parametrize("grid", [(1, 7), (7, 1)])
def test_agreement_beside_the_edge_classes_gives_the_one_thread_evidence(grid, monkeypatch):
    """With the overlap's threshold at one test and a core free, the agreement at the edge
    pixels starts on the pool's thread (spied) in strips the caller joins after the edge
    classes, and the segment vote's extra pixels are tested after it: the evidence and counts
    equal those of the call without the overlap, and the full test's at the edges; with no
    core free it does not start."""
    import stimuli.declutter as dc
    import stimuli.rowthreads as rt
    from stimuli.refocus import refocus
    from tests.stimuli.test_edge_depth import D_BOX, _box_scene

    lf, _ = _box_scene(grid)
    started = []

    def spy(work, start=rt.start_on_thread):
        started.append(work)
        return start(work)

    for d in (D_BOX, 1.3):
        img = refocus(lf, d)
        edges = dc.declutter(img, threshold=dc.auto_threshold(img))
        monkeypatch.setattr(dc, "OVERLAP_MIN_TESTS", 10**12)
        one, stats_one = dc.in_focus_evidence(lf, d, confocal=img, where=edges)
        monkeypatch.setattr(dc, "OVERLAP_MIN_TESTS", 1)
        monkeypatch.setattr(rt, "default_workers", lambda: 2)
        monkeypatch.setattr(rt, "start_on_thread", spy)
        monkeypatch.setattr(rt, "cores_free", lambda: 0.0)  # a busy machine: no second thread
        n = len(started)
        busy, _ = dc.in_focus_evidence(lf, d, confocal=img, where=edges)
        assert len(started) == n and np.array_equal(busy, one)
        monkeypatch.setattr(rt, "cores_free", lambda: 1.0)
        two, stats_two = dc.in_focus_evidence(lf, d, confocal=img, where=edges)
        monkeypatch.undo()
        assert len(started) == n + 1
        assert stats_one == stats_two and np.array_equal(one, two)
        full, _ = dc.in_focus_evidence(lf, d, confocal=img)
        assert np.array_equal(full[edges], two[edges])
        assert stats_two.unmeasured > 0
