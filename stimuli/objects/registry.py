"""The object kinds the synthetic set can draw: names, accepted answers and drawing functions.

:data:`KINDS` lists every kind in the order the PAIRS writer (:func:`stimuli.synth.write_pairs`)
uses them; :data:`DRAWERS` maps each kind's name to the function of its family module
(:mod:`~stimuli.objects.kitchen`, :mod:`~stimuli.objects.tools`, :mod:`~stimuli.objects.home`,
:mod:`~stimuli.objects.devices`, :mod:`~stimuli.objects.personal`) that draws it.

Each ``draw_<kind>(canvas, rng)`` paints its object in *object units*: 1 = the object's nominal
width, base at y = 0, y up, centred on x = 0. ``rng`` chooses the variant (shade, tilt, the time
on a dial); :func:`stimuli.synth.make_scene` scales the drawing to 10 deg and places it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from stimuli.errors import InputError
from stimuli.objects.devices import draw_clock, draw_headphones, draw_phone, draw_remote, draw_watch
from stimuli.objects.drawing import Canvas
from stimuli.objects.home import (
    draw_book,
    draw_chair,
    draw_desk_lamp,
    draw_light_bulb,
    draw_umbrella,
)
from stimuli.objects.kitchen import (
    draw_bottle,
    draw_cup,
    draw_fork,
    draw_mug,
    draw_spoon,
    draw_teapot,
    draw_wine_glass,
)
from stimuli.objects.personal import draw_glasses, draw_shoe, draw_toothbrush
from stimuli.objects.tools import (
    draw_hammer,
    draw_key,
    draw_padlock,
    draw_pen,
    draw_scissors,
    draw_screwdriver,
)

__all__ = ["ObjectKind", "KINDS", "DRAWERS", "object_kinds", "find_kind"]


@dataclass(frozen=True)
class ObjectKind:
    """A kind of object the synthetic set can draw, with the answers that score as correct.

    Parameters
    ----------
    name : str
        Identifier used in folder names (``"desk_lamp"``).
    display_name : str
        What the object is called (``"desk lamp"``).
    synonyms : tuple of str
        Other names accepted as correct.
    uses : tuple of str
        Descriptions of its use accepted as correct.
    """

    name: str
    display_name: str
    synonyms: tuple[str, ...]
    uses: tuple[str, ...]


#: Every kind, in the order the PAIRS writer uses them (see :func:`object_kinds`).
KINDS: tuple[ObjectKind, ...] = (
    ObjectKind(
        "cup",
        "cup",
        ("teacup", "coffee cup", "cup and saucer"),
        ("drinking", "drink tea", "drink coffee"),
    ),
    ObjectKind(
        "mug", "mug", ("coffee mug", "tea mug", "cup"), ("drinking", "drink coffee", "drink tea")
    ),
    ObjectKind(
        "desk_lamp",
        "desk lamp",
        ("lamp", "table lamp", "reading lamp", "light"),
        ("lighting", "reading light", "give light"),
    ),
    ObjectKind(
        "bottle",
        "bottle",
        ("wine bottle", "glass bottle", "beer bottle"),
        ("holding liquid", "drinking", "pouring"),
    ),
    ObjectKind("scissors", "scissors", ("shears", "pair of scissors"), ("cutting", "cut paper")),
    ObjectKind(
        "key", "key", ("house key", "door key"), ("opening a lock", "unlock a door", "locking")
    ),
    ObjectKind(
        "glasses",
        "glasses",
        ("eyeglasses", "spectacles", "sunglasses", "specs"),
        ("seeing", "reading", "correct vision"),
    ),
    ObjectKind(
        "hammer", "hammer", ("claw hammer", "mallet"), ("hammering", "drive nails", "pull nails")
    ),
    ObjectKind(
        "umbrella",
        "umbrella",
        ("parasol", "brolly"),
        ("rain protection", "keep dry", "shade from sun"),
    ),
    ObjectKind(
        "teapot",
        "teapot",
        ("tea pot", "kettle", "pot"),
        ("making tea", "pouring tea", "serving tea"),
    ),
    ObjectKind(
        "clock",
        "alarm clock",
        ("clock", "alarm", "timepiece"),
        ("telling time", "waking up", "alarm"),
    ),
    ObjectKind(
        "light_bulb",
        "light bulb",
        ("bulb", "lightbulb", "lamp bulb"),
        ("lighting", "give light", "lamp"),
    ),
    ObjectKind("fork", "fork", ("table fork", "dinner fork"), ("eating", "eat food", "cutlery")),
    ObjectKind(
        "spoon",
        "spoon",
        ("teaspoon", "tablespoon", "soup spoon"),
        ("eating", "stirring", "eat soup"),
    ),
    ObjectKind(
        "toothbrush",
        "toothbrush",
        ("tooth brush", "brush"),
        ("brushing teeth", "cleaning teeth", "dental hygiene"),
    ),
    ObjectKind(
        "phone",
        "mobile phone",
        ("phone", "cell phone", "smartphone", "cellphone", "mobile"),
        ("calling", "phone calls", "texting", "communication"),
    ),
    ObjectKind("book", "book", ("open book", "notebook"), ("reading", "learning", "study")),
    ObjectKind(
        "wine_glass", "wine glass", ("glass", "goblet", "wineglass"), ("drinking", "drink wine")
    ),
    ObjectKind(
        "padlock", "padlock", ("lock", "combination lock"), ("locking", "security", "lock a door")
    ),
    ObjectKind(
        "headphones",
        "headphones",
        ("headset", "earphones", "headphone", "cans"),
        ("listening to music", "listening", "hearing audio"),
    ),
    ObjectKind(
        "screwdriver",
        "screwdriver",
        ("screw driver", "driver"),
        ("turning screws", "tighten screws", "repair"),
    ),
    ObjectKind(
        "shoe",
        "shoe",
        ("sneaker", "trainer", "running shoe", "boot"),
        ("wearing", "walking", "running", "footwear"),
    ),
    ObjectKind("chair", "chair", ("seat", "stool"), ("sitting", "sit on")),
    ObjectKind("pen", "pen", ("ballpoint pen", "ballpoint", "biro"), ("writing", "write")),
    ObjectKind(
        "watch", "wristwatch", ("watch", "wrist watch"), ("telling time", "time", "wear on wrist")
    ),
    ObjectKind(
        "remote",
        "remote control",
        ("remote", "tv remote", "controller", "clicker"),
        ("changing channels", "control the tv", "switching the tv"),
    ),
)


def object_kinds() -> list[ObjectKind]:
    """Return the object kinds the synthetic set can draw, in the order the PAIRS writer uses.

    The first 20 are the main set (the paper's study had 20 objects), the next 3 are for
    training trials, and the rest are spares that :func:`stimuli.synth.write_pairs` uses when
    asked for more objects.

    Returns
    -------
    list of ObjectKind
        Distinct names; each with at least one synonym and one use.

    Examples
    --------
    >>> object_kinds()[4].name, object_kinds()[4].synonyms
    ('scissors', ('shears', 'pair of scissors'))
    """
    return list(KINDS)


#: The function that draws each kind, by ``ObjectKind.name``.
DRAWERS: dict[str, Callable[[Canvas, np.random.Generator], None]] = {
    "cup": draw_cup,
    "mug": draw_mug,
    "desk_lamp": draw_desk_lamp,
    "bottle": draw_bottle,
    "scissors": draw_scissors,
    "key": draw_key,
    "glasses": draw_glasses,
    "hammer": draw_hammer,
    "umbrella": draw_umbrella,
    "teapot": draw_teapot,
    "clock": draw_clock,
    "light_bulb": draw_light_bulb,
    "fork": draw_fork,
    "spoon": draw_spoon,
    "toothbrush": draw_toothbrush,
    "phone": draw_phone,
    "book": draw_book,
    "wine_glass": draw_wine_glass,
    "padlock": draw_padlock,
    "headphones": draw_headphones,
    "screwdriver": draw_screwdriver,
    "shoe": draw_shoe,
    "chair": draw_chair,
    "pen": draw_pen,
    "watch": draw_watch,
    "remote": draw_remote,
}


def find_kind(kind: str | ObjectKind) -> ObjectKind:
    """Return the registered kind named ``kind`` (or ``kind.name``); InputError if unknown."""
    name = kind.name if isinstance(kind, ObjectKind) else kind
    for k in KINDS:
        if k.name == name:
            return k
    raise InputError(f"kind must be one of {[k.name for k in KINDS]}, got {name!r}")
