"""Schedules: the protocol's trials in the order one subject sees them (house style H5).

:func:`build_schedule` expands each ``[[blocks]]`` entry of a :class:`ProtocolSpec` against a
stimulus set, with one random generator, into a :class:`Schedule` of :class:`Trial` objects.
The session writes the whole schedule into the trial log before the first trial and, on resume,
reads it back from there; it is never drawn twice.
"""

from __future__ import annotations

import numpy as np

from experiment.protocol import BlockSpec, ProtocolError, ProtocolSpec
from experiment.session.stimset import StimulusSet
from experiment.trials import Schedule, Trial

#: ``Trial`` and ``Schedule`` live in :mod:`experiment.trials` (below the trial log) and are
#: re-exported here, where schedules are drawn.
__all__ = [
    "Trial",
    "Schedule",
    "build_schedule",
    "planned_trials",
    "latin_square_order",
    "counterbalance_record",
    "subject_position",
]


def _objects_for(entry: BlockSpec, stimset: StimulusSet, where: str) -> tuple[str, ...]:
    if isinstance(entry.objects, str):
        ids = stimset.object_ids(entry.objects)
        if not ids:
            raise ProtocolError(
                f"{where}.objects: no objects with role {entry.objects!r} in stimulus set "
                f"{stimset.root}"
            )
        return ids
    for o in entry.objects:
        if o not in stimset.objects:
            raise ProtocolError(
                f"{where}.objects: object {o!r} is not in stimulus set {stimset.root}"
            )
    return entry.objects


def _check_available(
    entry: BlockSpec, objs: tuple[str, ...], stimset: StimulusSet, where: str
) -> None:
    have = stimset.levels()
    for lv in entry.levels:
        if lv not in have:
            raise ProtocolError(
                f"{where}.levels: level {lv} is not in stimulus set {stimset.root} "
                f"(it has levels {', '.join(map(str, have))})"
            )
    index = {(r.object, r.condition, r.level) for r in stimset.records}
    for o in objs:
        for c in entry.conditions:
            for lv in entry.levels:
                if (o, c, lv) not in index:
                    raise ProtocolError(
                        f"{where}: stimulus set {stimset.root} has no image for object {o!r}, "
                        f"condition {c!r}, level {lv}"
                    )


def _ordered_levels(entry: BlockSpec, rng: np.random.Generator) -> list[int]:
    if entry.level_order == "ascending":
        return sorted(entry.levels)
    if entry.level_order == "descending":
        return sorted(entry.levels, reverse=True)
    if entry.level_order == "random":
        return [entry.levels[i] for i in rng.permutation(len(entry.levels))]
    return list(entry.levels)


def _ordered_conditions(
    entry: BlockSpec, rng: np.random.Generator, subject_index: int = 0
) -> list[str]:
    if entry.condition_order == "latin_square":
        return list(latin_square_order(entry.conditions, subject_index))
    if entry.condition_order == "random":
        return [entry.conditions[i] for i in rng.permutation(len(entry.conditions))]
    return list(entry.conditions)


def latin_square_order(conditions: tuple[str, ...], subject_index: int) -> tuple[str, ...]:
    """Return a subject's order of condition blocks: a row of a balanced Latin square.

    Row ``subject_index mod rows`` of the Williams square of ``len(conditions)`` conditions
    (:func:`experiment.trials.balanced_latin_square`, the one active search uses), so
    every condition comes at every position equally often over a full cycle of subjects.

    Parameters
    ----------
    conditions : tuple of str
    subject_index : int >= 0
        The subject's position in the study (first subject 0).

    Returns
    -------
    tuple of str

    Examples
    --------
    >>> latin_square_order(("a", "b", "c", "d"), 1)
    ('b', 'c', 'a', 'd')
    """
    from experiment.trials import balanced_latin_square

    if isinstance(subject_index, bool) or not isinstance(subject_index, int) or subject_index < 0:
        raise ValueError(f"subject_index must be an integer >= 0, got {subject_index!r}")
    rows = balanced_latin_square(len(conditions))
    return tuple(conditions[k] for k in rows[subject_index % len(rows)])


def subject_position(log, subject: str) -> int:
    """Return the subject's position among the subjects of a trial log, 0-based.

    The order in which subjects first appear in ``log.sessions()``; a new subject comes
    after all of them (the rule active search uses for its Latin square).

    Parameters
    ----------
    log : TrialLog
    subject : str
    """
    order: list[str] = []
    for row in log.sessions():
        if row["subject"] not in order:
            order.append(row["subject"])
    return order.index(subject) if subject in order else len(order)


def counterbalance_record(protocol: ProtocolSpec, subject_index: int) -> dict | None:
    """Return what a session records of its counterbalancing (``None`` without a Latin square).

    ``{"scheme": "latin_square", "subject_index": i, "condition_orders": {entry: [...]}}``, one
    order per ``[[blocks]]`` entry (by its index) whose ``condition_order`` is ``latin_square``.
    """
    orders = {
        str(e): list(latin_square_order(b.conditions, subject_index))
        for e, b in enumerate(protocol.blocks)
        if b.condition_order == "latin_square"
    }
    if not orders:
        return None
    return {"scheme": "latin_square", "subject_index": subject_index, "condition_orders": orders}


def _entry_blocks(
    entry: BlockSpec, objs: tuple[str, ...], rng: np.random.Generator, subject_index: int = 0
) -> list[list[tuple[str, str, int]]]:
    """Blocks of one repetition: lists of (object, condition, level), before trial shuffling."""
    levels = _ordered_levels(entry, rng)
    blocks: list[list[tuple[str, str, int]]] = []
    if entry.group_by == "level_condition":
        for lv in levels:
            for c in _ordered_conditions(entry, rng, subject_index):
                blocks.append([(o, c, lv) for o in objs])
    elif entry.group_by == "level":
        for lv in levels:
            blocks.append([(o, c, lv) for c in entry.conditions for o in objs])
    elif entry.group_by == "condition":
        for c in _ordered_conditions(entry, rng, subject_index):
            blocks.append([(o, c, lv) for lv in levels for o in objs])
    else:
        blocks.append([(o, c, lv) for lv in levels for c in entry.conditions for o in objs])
    if entry.trial_order == "random":
        blocks = [[b[i] for i in rng.permutation(len(b))] for b in blocks]
    if entry.block_order == "random":
        blocks = [blocks[i] for i in rng.permutation(len(blocks))]
    return blocks


def planned_trials(protocol: ProtocolSpec, stimset: StimulusSet) -> int:
    """Return how many trials :func:`build_schedule` would plan, without building them.

    Checks every block's objects, levels and conditions against the stimulus set first, so a
    caller can refuse a protocol (or one too large for memory) before writing anything.

    Raises
    ------
    ProtocolError
        A block entry names an object, role or level the stimulus set lacks.
    """
    n = 0
    for e, entry in enumerate(protocol.blocks):
        where = f"blocks[{e}]"
        objs = _objects_for(entry, stimset, where)
        _check_available(entry, objs, stimset, where)
        n += entry.repetitions * len(objs) * len(entry.levels) * len(entry.conditions)
    return n


def build_schedule(
    protocol: ProtocolSpec,
    stimset: StimulusSet,
    rng: np.random.Generator | int | None = None,
    *,
    subject_index: int = 0,
) -> Schedule:
    """Expand a protocol into one subject's ordered trials.

    Parameters
    ----------
    protocol : ProtocolSpec
    stimset : StimulusSet
        Supplies the objects of each role and the image of every (object, condition, level).
    rng : numpy.random.Generator, int or None
        The only source of randomness (trial order inside blocks, random level, condition and
        block orders). The session passes a child of its stored seed.
    subject_index : int >= 0
        The subject's position in the study: picks the row of the Latin square for entries
        with ``condition_order = "latin_square"`` (:func:`latin_square_order`).

    Returns
    -------
    Schedule

    Raises
    ------
    ProtocolError
        A block entry names an object or level the stimulus set lacks (one line naming both).

    References
    ----------
    Jung et al. 2015, Sec. 3.2: levels lowest to highest; at each level the cluttered block
    then the de-cluttered block; random object order inside a block.
    """
    if protocol.task is not None:  # an active-search [task] has no static schedule
        raise ProtocolError(
            f"{protocol.source_path or protocol.name}: an active-search protocol runs with "
            "'confocal active run', not as a static session"
        )
    rng = np.random.default_rng(rng)
    trials: list[Trial] = []
    block_no = 0
    for e, entry in enumerate(protocol.blocks):
        where = f"blocks[{e}]"
        objs = _objects_for(entry, stimset, where)
        _check_available(entry, objs, stimset, where)
        n_in_entry = 0
        for rep in range(entry.repetitions):
            for block in _entry_blocks(entry, objs, rng, subject_index):
                block_no += 1
                brk = (
                    entry.break_every_blocks > 0
                    and n_in_entry > 0
                    and n_in_entry % entry.break_every_blocks == 0
                )
                n_in_entry += 1
                for k, (o, c, lv) in enumerate(block):
                    rec = stimset.get(o, c, lv)
                    trials.append(
                        Trial(
                            index=len(trials),
                            part=entry.part,
                            block=block_no,
                            object=o,
                            object_name=stimset.objects[o].name,
                            condition=c,
                            level=lv,
                            window=rec.window,
                            pixels=rec.pixels,
                            path=rec.path,
                            sha256=rec.sha256,
                            pass_allowed_after_s=float(protocol.pass_allowed_after_s),
                            repetition=rep,
                            break_before=brk and k == 0,
                        )
                    )
    return Schedule(trials)
