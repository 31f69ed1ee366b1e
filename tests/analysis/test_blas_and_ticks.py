"""The analysis runs BLAS on one thread (restored after); log axes get plain-number labels."""

from __future__ import annotations

import numpy as np
from threadpoolctl import threadpool_info

from analysis.blas import on_one_blas_thread


def _blas_threads() -> list[int]:
    np.ones((2, 2)) @ np.ones((2, 2))  # BLAS loaded
    return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]


def test_a_decorated_generator_runs_on_one_blas_thread_and_restores_the_limit():
    before = _blas_threads()

    @on_one_blas_thread
    def steps():
        yield _blas_threads()
        yield _blas_threads()

    inside = list(steps())
    assert inside and all(set(t) == {1} for t in inside)
    assert _blas_threads() == before


def test_the_analysis_is_limited():
    from analysis.pipeline import analyze

    assert analyze.__wrapped__.__name__ == "analyze"


def test_log_axes_have_plain_labels_and_two_of_them_on_a_narrow_range():
    from matplotlib.figure import Figure

    from analysis.figures import _log_axis

    for lo, hi, expect in ((1_400, 18_000, {"2,000", "5,000", "10,000"}), (60, 250_000, None)):
        ax = Figure().add_subplot()
        _log_axis(ax, "y")
        ax.set_ylim(lo, hi)
        ax.figure.draw_without_rendering()
        shown = {
            t.get_text()
            for t in ax.yaxis.get_ticklabels(which="both")
            if t.get_visible() and t.get_text() and lo <= t.get_position()[1] <= hi
        }
        assert len(shown) >= 2 and not any("$" in t for t in shown), shown
        assert expect is None or expect <= shown
        if expect is None:
            assert shown == {"100", "1,000", "10,000", "100,000"}
