"""The ``[[blocks]]`` entries of a protocol: which trials, cut into blocks, in which order."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from functools import partial
from typing import Any

from experiment.protocol.fields import (
    ProtocolError,
    _choice,
    _need,
    _need_distinct,
    _need_int,
    _need_str,
    _Spec,
)

__all__ = ["Condition", "BlockSpec"]

PARTS = ("training", "main")
GROUP_BY = ("level_condition", "level", "condition", "none")
LEVEL_ORDERS = ("ascending", "descending", "listed", "random")
CONDITION_ORDERS = ("listed", "random", "latin_square")
TRIAL_ORDERS = ("random", "listed")
BLOCK_ORDERS = ("planned", "random")


class Condition(StrEnum):
    """Image condition of a stimulus (``manifest.csv`` column ``condition``)."""

    CLUTTERED = "cluttered"
    DECLUTTERED = "decluttered"
    PHOTO = "photo"
    #: Full-resolution colour photos shown in training (Jung 2015, Sec. 3.1: "conventional and
    #: confocal images were shown followed by the edge-filtered and compressed images").
    COLOUR_WIDE = "colour_wide"
    COLOUR_CONFOCAL = "colour_confocal"


def _condition(value: Any, name: str) -> None:
    """Check that ``value`` is a paper condition or a de-clutter method's name.

    A method is named as in ``stimuli build --conditions``; the stimulus set must hold it.
    """
    from stimuli.methods.registry import method_names

    methods = method_names()
    if value in {c.value for c in Condition} or value in methods:
        return
    known = ", ".join([*(c.value for c in Condition), *methods])
    raise ProtocolError(f"{name} must be one of {known}, got {value!r}")


def _level(value: Any, name: str) -> None:
    _need(value, int, name)
    if value < 1:
        raise ProtocolError(f"levels must be >= 1, got {value!r}")


def _objects(value: Any, name: str) -> None:
    if isinstance(value, str):
        if not value:
            raise ProtocolError(f"{name} must be a role name or a list of object ids")
        return
    _need_distinct(
        value,
        name,
        noun="an object",
        item=_need_str,
        expected="a role name or a list of ids",
    )


@dataclass(frozen=True)
class BlockSpec(_Spec):
    """One ``[[blocks]]`` entry.

    A set of trials and how it is cut into blocks and ordered. The trials are every object of
    ``objects`` x every level in ``levels`` x every condition in ``conditions``, ``repetitions``
    times.

    Parameters
    ----------
    part : {'training', 'main'}
        Which part of the session the trials belong to (training trials are not analysed).
    objects : str or tuple of str
        A role of the stimulus set (``"main"``, ``"training"``) or explicit object ids.
    levels : tuple of int
        Resolution levels (1 = fewest pixels ... 8 = full 492x327).
    conditions : tuple of str
        ``'cluttered'``, ``'decluttered'``, ``'photo'`` (and the colour photos), or the name of
        any other condition the stimulus set holds (a de-clutter method: ``'mask'``, ...).
    group_by : {'level_condition', 'level', 'condition', 'none'}
        One block per (level, condition) pair (Jung 2015), per level (conditions mixed inside),
        per condition (levels mixed inside) or one block for everything.
    level_order : {'ascending', 'descending', 'listed', 'random'}
        Order of the level blocks. Jung 2015 Sec. 3.2: lowest to highest.
    condition_order : {'listed', 'random', 'latin_square'}
        Order of the condition blocks at each level (listed: as in ``conditions``; random: drawn
        per level and subject; latin_square: the subject's row of a balanced (Williams) Latin
        square of the conditions, the subject's position in the log choosing the row, the same
        at every level and recorded in the session's ``counterbalance`` event). Jung 2015:
        cluttered first.
    trial_order : {'random', 'listed'}
        Order of the trials inside a block (random: seeded per subject, Jung 2015).
    block_order : {'planned', 'random'}
        ``random`` shuffles the finished list of blocks (a randomised-blocks design).
    repetitions : int >= 1
        How many times the whole entry is repeated (each repetition drawn afresh).
    break_every_blocks : int >= 0
        A break screen before every n-th block of this entry (0 = no breaks).
    """

    part: str
    objects: str | tuple[str, ...]
    levels: tuple[int, ...]
    conditions: tuple[str, ...]
    group_by: str = "level_condition"
    level_order: str = "ascending"
    condition_order: str = "listed"
    trial_order: str = "random"
    block_order: str = "planned"
    repetitions: int = 1
    break_every_blocks: int = 0

    _checks = {
        "part": partial(_choice, choices=PARTS),
        "objects": _objects,
        "levels": partial(
            _need_distinct, noun="a level", item=_level, expected="a non-empty list of integers"
        ),
        "conditions": partial(_need_distinct, noun="a condition", item=_condition),
        "group_by": partial(_choice, choices=GROUP_BY),
        "level_order": partial(_choice, choices=LEVEL_ORDERS),
        "condition_order": partial(_choice, choices=CONDITION_ORDERS),
        "trial_order": partial(_choice, choices=TRIAL_ORDERS),
        "block_order": partial(_choice, choices=BLOCK_ORDERS),
        "repetitions": partial(_need_int, minimum=1),
        "break_every_blocks": partial(_need_int, minimum=0),
    }
