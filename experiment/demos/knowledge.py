"""The demo's knowledge renderings: other renderings of its kinds, for the image observers.

Each rendering is a stimulus set of its own (synthetic photo pairs with another seed, built at
the full-resolution level only). The demo makes them in two worker processes beside the test
set, and there also reads them as the observer will (its exemplar features), so that its own
process need not compute them after the wait.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["make_knowledge_set", "make_knowledge_sets"]


def make_knowledge_set(pairs: Path, out: Path, seed: int) -> Path:
    """Synthesise 23 photo pairs with ``seed`` and build their full-resolution level only.

    This is the exemplar observer's knowledge: other renderings (pose, size, colour,
    background, lens draw) of the demo's kinds. Only the highest level is built, since that is
    all the observer remembers.

    Parameters
    ----------
    pairs : Path
        Folder for the photo pairs.
    out : Path
        Folder for the stimulus set.
    seed : int
        Seed of the rendering (not the test set's).

    Returns
    -------
    Path
        ``out``.
    """
    from stimuli.stimset import BuildParams, build_stimulus_set
    from stimuli.synth import write_pairs

    # read once, by the build below: zlib's fastest level (the same pixels and the same
    # observer features; about 8 % less CPU time a rendering, measured in one process)
    write_pairs(pairs, n_objects=20, n_training=3, seed=seed, compress_level=1)
    build_stimulus_set(pairs, out, params=BuildParams(windows_px=(1,)), workers=1)
    return Path(out)


def make_knowledge_sets(
    folders: list[tuple[Path, Path]], seeds: list[int], params: Any = None
) -> list[tuple[tuple, Any]]:
    """Run :func:`make_knowledge_set` for each (pairs, stimuli) folder pair and seed, in turn.

    Given the observer's parameters (``params``, its knowledge and geometry), each set is then
    read as the observer reads it (its exemplar features,
    :func:`~experiment.observers.exemplar.load_knowledge`), and the cache entries are returned
    for the demo's process, which would otherwise compute them alone after the sets are made.
    The features are computed by the same code with the same parameters, so the observer's
    answers do not change.

    Parameters
    ----------
    folders : list of (Path, Path)
        (photo pairs, stimulus set) folders to make.
    seeds : list of int
        One rendering seed per folder pair.
    params : ExemplarParams, optional
        The observer's parameters; None: make the sets only.

    Returns
    -------
    list of (tuple, Knowledge)
        :func:`~experiment.observers.exemplar.knowledge_cache_entries` of the sets (empty
        without ``params``).
    """
    from dataclasses import replace

    from experiment.observers.exemplar import knowledge_cache_entries, load_knowledge

    for (pairs, stimuli), s in zip(folders, seeds, strict=True):
        make_knowledge_set(pairs, stimuli, s)
        if params is not None:
            load_knowledge(replace(params, knowledge=str(stimuli)))
    return [] if params is None else knowledge_cache_entries([str(f[1]) for f in folders])
