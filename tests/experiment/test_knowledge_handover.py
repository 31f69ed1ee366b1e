"""Knowledge read in another process is handed over whole: the same features, not recomputed."""

from __future__ import annotations

import multiprocessing
from pathlib import Path

import numpy as np
import pytest

from experiment.observers import exemplar
from experiment.observers.exemplar import (
    ExemplarParams,
    add_knowledge_cache_entries,
    knowledge_cache_entries,
    load_knowledge,
)
from experiment.testing import make_stimulus_set


def _read_in_child(folder: str) -> list:
    load_knowledge(ExemplarParams(knowledge=folder))
    return knowledge_cache_entries([folder])


@pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(), reason="needs fork")
def test_knowledge_read_in_a_forked_process_is_what_this_one_would_read(
    tmp_path: Path, monkeypatch
) -> None:
    folder = str(make_stimulus_set(tmp_path / "k", n_main=3, n_training=1, levels=(8,), rng=4))
    monkeypatch.setattr(exemplar, "_KNOWLEDGE_CACHE", {})
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(1) as pool:
        entries = pool.apply(_read_in_child, (folder,))
    assert len(entries) == 1 and not exemplar._KNOWLEDGE_CACHE
    own = load_knowledge(ExemplarParams(knowledge=folder))  # computed here
    monkeypatch.setattr(exemplar, "_KNOWLEDGE_CACHE", {})
    add_knowledge_cache_entries(entries)

    def no_features(self, image):  # a cache miss would compute features: fail instead
        raise AssertionError("features recomputed")

    monkeypatch.setattr(ExemplarParams, "features", no_features)
    handed = load_knowledge(ExemplarParams(knowledge=folder))
    assert np.array_equal(handed.features, own.features)
    assert handed.categories == own.categories and handed.sources == own.sources
