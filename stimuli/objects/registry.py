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


#: Other names accepted as correct, by kind, in the order the PAIRS writer uses the kinds.
_SYNONYMS: dict[str, tuple[str, ...]] = {
    "cup": ("teacup", "coffee cup", "cup and saucer"),
    "mug": ("coffee mug", "tea mug", "cup"),
    "desk_lamp": ("lamp", "table lamp", "reading lamp", "light"),
    "bottle": ("wine bottle", "glass bottle", "beer bottle"),
    "scissors": ("shears", "pair of scissors"),
    "key": ("house key", "door key"),
    "glasses": ("eyeglasses", "spectacles", "sunglasses", "specs"),
    "hammer": ("claw hammer", "mallet"),
    "umbrella": ("parasol", "brolly"),
    "teapot": ("tea pot", "kettle", "pot"),
    "clock": ("clock", "alarm", "timepiece"),
    "light_bulb": ("bulb", "lightbulb", "lamp bulb"),
    "fork": ("table fork", "dinner fork"),
    "spoon": ("teaspoon", "tablespoon", "soup spoon"),
    "toothbrush": ("tooth brush", "brush"),
    "phone": ("phone", "cell phone", "smartphone", "cellphone", "mobile"),
    "book": ("open book", "notebook"),
    "wine_glass": ("glass", "goblet", "wineglass"),
    "padlock": ("lock", "combination lock"),
    "headphones": ("headset", "earphones", "headphone", "cans"),
    "screwdriver": ("screw driver", "driver"),
    "shoe": ("sneaker", "trainer", "running shoe", "boot"),
    "chair": ("seat", "stool"),
    "pen": ("ballpoint pen", "ballpoint", "biro"),
    "watch": ("watch", "wrist watch"),
    "remote": ("remote", "tv remote", "controller", "clicker"),
}

#: Descriptions of use accepted as correct, by kind.
_USES: dict[str, tuple[str, ...]] = {
    "cup": ("drinking", "drink tea", "drink coffee"),
    "mug": ("drinking", "drink coffee", "drink tea"),
    "desk_lamp": ("lighting", "reading light", "give light"),
    "bottle": ("holding liquid", "drinking", "pouring"),
    "scissors": ("cutting", "cut paper"),
    "key": ("opening a lock", "unlock a door", "locking"),
    "glasses": ("seeing", "reading", "correct vision"),
    "hammer": ("hammering", "drive nails", "pull nails"),
    "umbrella": ("rain protection", "keep dry", "shade from sun"),
    "teapot": ("making tea", "pouring tea", "serving tea"),
    "clock": ("telling time", "waking up", "alarm"),
    "light_bulb": ("lighting", "give light", "lamp"),
    "fork": ("eating", "eat food", "cutlery"),
    "spoon": ("eating", "stirring", "eat soup"),
    "toothbrush": ("brushing teeth", "cleaning teeth", "dental hygiene"),
    "phone": ("calling", "phone calls", "texting", "communication"),
    "book": ("reading", "learning", "study"),
    "wine_glass": ("drinking", "drink wine"),
    "padlock": ("locking", "security", "lock a door"),
    "headphones": ("listening to music", "listening", "hearing audio"),
    "screwdriver": ("turning screws", "tighten screws", "repair"),
    "shoe": ("wearing", "walking", "running", "footwear"),
    "chair": ("sitting", "sit on"),
    "pen": ("writing", "write"),
    "watch": ("telling time", "time", "wear on wrist"),
    "remote": ("changing channels", "control the tv", "switching the tv"),
}

#: What a kind is called, where that is not its name with spaces for underscores.
_DISPLAY_NAMES: dict[str, str] = {
    "clock": "alarm clock",
    "phone": "mobile phone",
    "watch": "wristwatch",
    "remote": "remote control",
}

#: Every kind, in the order the PAIRS writer uses them (see :func:`object_kinds`).
KINDS: tuple[ObjectKind, ...] = tuple(
    ObjectKind(name, _DISPLAY_NAMES.get(name, name.replace("_", " ")), synonyms, _USES[name])
    for name, synonyms in _SYNONYMS.items()
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
