"""The front-end benchmark's cached path gives the observer's own responses (second path)."""

from __future__ import annotations

from pathlib import Path

from benchmarks.observer_frontend import cached_path_difference
from experiment.testing import make_stimulus_set


def test_cached_front_end_path_equals_the_observers_responses(tmp_path: Path) -> None:
    """Retinas sampled once and cached, then blurred and HOG'd (mirror images sampled as the
    observer samples them), pooled and normalised: the same responses as
    ``stimulus_responses`` reading the images through the observer's own front end."""
    make_stimulus_set(tmp_path / "cal50" / "test", n_main=4, n_training=1, levels=(8,), rng=3)
    make_stimulus_set(tmp_path / "knowledge" / "knowledge51", n_main=4, n_training=1,
                      levels=(8,), rng=4)  # fmt: skip
    assert cached_path_difference(tmp_path, 50, 1, (0.03, 0.4, 9, 0.02)) < 1e-9
