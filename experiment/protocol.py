"""Protocols: what a session shows and in which order, loaded from ``protocols/*.toml`` (H10).

A protocol file has four tables, and an optional fifth::

    [protocol]      name, description, pass_allowed_after_s, feedback
    [display]       screen and image geometry (DisplaySpec)
    [scoring]       which scores count as recognised, who the primary rater is (ScoringSpec)
    [[blocks]]      one or more entries (BlockSpec), each expanding into one or more blocks
    [instructions]  the texts of the subject's instruction screens (InstructionsSpec)

Every value is checked when the spec is built; an unknown key, a wrong type or a missing field
raises :class:`ProtocolError` with one line naming the file and the field.

Examples
--------
>>> spec = load_protocol(PROTOCOLS_DIR / "jung2015.toml")
>>> spec.name, sum(b.part == "main" for b in spec.blocks)
('jung2015', 1)
"""

from __future__ import annotations

import hashlib
import json
import math
import tomllib
from dataclasses import MISSING, dataclass, field, fields, replace
from enum import StrEnum
from pathlib import Path
from typing import Any

from experiment.errors import ConfocalError
from stimuli.datadirs import PROTOCOLS_DIR
from stimuli.implants import ImplantError, ImplantLayout, load_implant

__all__ = [
    "PROTOCOLS_DIR",
    "SCORES",
    "Condition",
    "ProtocolError",
    "DisplaySpec",
    "ScoringSpec",
    "InstructionsSpec",
    "BlockSpec",
    "ProtocolSpec",
    "load_protocol",
]


#: The five scores an answer can get. Source: Jung et al. 2015, Sec. 3.2 (name, use, shape or
#: features; a pass after 1 min); "wrong" is ours for a named but wrong object.
SCORES: tuple[str, ...] = ("named", "use", "shape", "wrong", "pass")

PARTS = ("training", "main")
GROUP_BY = ("level_condition", "level", "condition", "none")
LEVEL_ORDERS = ("ascending", "descending", "listed", "random")
CONDITION_ORDERS = ("listed", "random")
TRIAL_ORDERS = ("random", "listed")
BLOCK_ORDERS = ("planned", "random")


class ProtocolError(ConfocalError):
    """A protocol file or spec is invalid (one line naming the field)."""


class Condition(StrEnum):
    """Image condition of a stimulus (``manifest.csv`` column ``condition``)."""

    CLUTTERED = "cluttered"
    DECLUTTERED = "decluttered"
    PHOTO = "photo"
    #: Full-resolution colour photos shown in training (Jung 2015, Sec. 3.1: "conventional and
    #: confocal images were shown followed by the edge-filtered and compressed images").
    COLOUR_WIDE = "colour_wide"
    COLOUR_CONFOCAL = "colour_confocal"


def _type_name(value: Any) -> str:
    return type(value).__name__


def _need(value: Any, types: type | tuple[type, ...], name: str) -> None:
    if isinstance(value, bool) and bool not in (types if isinstance(types, tuple) else (types,)):
        raise ProtocolError(f"{name} must be {_names(types)}, got {_type_name(value)} {value!r}")
    if not isinstance(value, types):
        raise ProtocolError(f"{name} must be {_names(types)}, got {_type_name(value)} {value!r}")


def _names(types: type | tuple[type, ...]) -> str:
    t = types if isinstance(types, tuple) else (types,)
    return " or ".join(x.__name__ for x in t)


def _choice(value: Any, choices: tuple[str, ...], name: str) -> None:
    if value not in choices:
        raise ProtocolError(f"{name} must be one of {', '.join(choices)}, got {value!r}")


def _from_table(cls: type, table: Any, where: str, **extra: Any) -> Any:
    """Build a spec dataclass from a TOML table, refusing unknown keys and missing fields.

    ``extra`` are keyword arguments that do not come from the file (resolved values).
    """
    if not isinstance(table, dict):
        raise ProtocolError(f"[{where}] must be a table, got {_type_name(table)}")
    known = {f.name: f for f in fields(cls) if f.init and f.metadata.get("toml", True)}
    unknown = sorted(set(table) - set(known))
    if unknown:
        raise ProtocolError(
            f"unknown key {unknown[0]!r} in [{where}] (expected one of {', '.join(known)})"
        )
    kwargs = {}
    for name, value in table.items():
        if isinstance(value, list):
            value = tuple(tuple(v) if isinstance(v, list) else v for v in value)
        kwargs[name] = value
    try:
        return cls(**kwargs, **extra)
    except TypeError as exc:  # a field without default is missing
        missing = [
            f.name
            for f in fields(cls)
            if f.init
            and f.name not in kwargs
            and f.default is MISSING
            and f.default_factory is MISSING
        ]
        raise ProtocolError(
            f"[{where}] is missing field {missing[0] if missing else '?'} ({exc})"
        ) from None
    except ProtocolError as exc:
        raise ProtocolError(f"[{where}] {exc}") from None


def _plain(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    return value


class _Spec:
    """Shared checking and dict conversion of the frozen spec classes."""

    def __post_init__(self) -> None:
        for f in fields(self):  # type: ignore[arg-type]
            check = getattr(self, f"_check_{f.name}", None)
            if check is not None:
                check()

    def to_dict(self) -> dict[str, Any]:
        """Return the spec as plain TOML/JSON-compatible data."""
        return {
            f.name: _plain(getattr(self, f.name))
            for f in fields(self)  # type: ignore[arg-type]
            if f.metadata.get("toml", True)
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any], *, where: str | None = None) -> Any:
        """Build the spec from plain data (a TOML table), checking every field."""
        return _from_table(cls, data, where or cls.__name__)


def _load_layout(name_or_path: str) -> ImplantLayout:
    try:
        return load_implant(name_or_path)
    except ImplantError as exc:
        raise ProtocolError(f"display.implant: {exc}") from None


@dataclass(frozen=True)
class DisplaySpec(_Spec):
    """Screen and stimulus geometry.

    Parameters
    ----------
    screen_width_px, screen_height_px : int
        Monitor resolution, pixels. Jung 2015 Sec. 3.1: 1280x1024.
    screen_width_cm : float
        Visible width of the monitor, cm.
    viewing_distance_cm : float
        Eye to screen, cm. Jung 2015 Sec. 3.1: 80 cm.
    image_width_cm, image_height_cm : float
        Size of the shown stimulus, cm. Jung 2015 Sec. 3.1: 14.6 x 9.7 cm (10.4 x 6.9 deg).
    border_rgb : (r, g, b) ints in [0, 255]
        Colour of the frame drawn around the stimulus. Jung 2015 Sec. 3.1: blue.
    border_width_px : int
        Frame width, screen pixels (0 = no frame).
    background_rgb : (r, g, b) ints in [0, 255]
        Screen colour around the stimulus.
    gamma : float > 0
        Display gamma (measure it with a photometer); the presenter sends stimulus luminance
        ``v`` to the screen as ``v ** (1 / gamma)``. 1 = no correction.
    implant : str or None
        Show every stimulus as this implant shows it (issue 14; beyond the paper): resampled to
        its electrode grid (:func:`stimuli.implants.to_implant_grid`) and drawn as its
        phosphenes at its field of view, as ``confocal present --implant`` does. A shipped
        layout's name (``argus2``) or a ``.toml`` file, relative to the protocol file. Checked
        when the protocol loads. Colour training photos are still shown as photos.
    implant_layout : stimuli.implants.ImplantLayout or None
        The layout ``implant`` names, loaded when the spec is built (not a TOML key; a caller
        that resolved the file itself may pass it).
    """

    screen_width_px: int = 1280
    screen_height_px: int = 1024
    #: Inferred, not stated in the paper: 14.6 cm for the 492 px image means 0.2967 mm per
    #: pixel if it was shown pixel for pixel, so 1280 px span 37.98 cm, the visible width of a
    #: 21-inch CRT. Measure your own monitor.
    screen_width_cm: float = 37.98
    viewing_distance_cm: float = 80.0
    image_width_cm: float = 14.6
    image_height_cm: float = 9.7
    border_rgb: tuple[int, int, int] = (0, 0, 255)
    border_width_px: int = 6
    background_rgb: tuple[int, int, int] = (0, 0, 0)
    gamma: float = 1.0
    implant: str | None = None
    implant_layout: ImplantLayout | None = field(
        default=None, compare=False, repr=False, metadata={"toml": False}
    )

    def _check_positive_int(self, name: str) -> None:
        v = getattr(self, name)
        _need(v, int, f"display.{name}")
        if v < 1:
            raise ProtocolError(f"display.{name} must be >= 1, got {v!r}")

    def _check_positive_float(self, name: str) -> None:
        v = getattr(self, name)
        _need(v, (int, float), f"display.{name}")
        if not (math.isfinite(v) and v > 0):
            raise ProtocolError(f"display.{name} must be a positive number, got {v!r}")

    def _check_screen_width_px(self) -> None:
        self._check_positive_int("screen_width_px")

    def _check_screen_height_px(self) -> None:
        self._check_positive_int("screen_height_px")

    def _check_screen_width_cm(self) -> None:
        self._check_positive_float("screen_width_cm")

    def _check_viewing_distance_cm(self) -> None:
        self._check_positive_float("viewing_distance_cm")

    def _check_image_width_cm(self) -> None:
        self._check_positive_float("image_width_cm")
        if self.image_width_cm > self.screen_width_cm:
            raise ProtocolError(
                f"display.image_width_cm must be <= screen_width_cm ({self.screen_width_cm}), "
                f"got {self.image_width_cm!r}"
            )

    def _check_image_height_cm(self) -> None:
        self._check_positive_float("image_height_cm")

    def _check_rgb(self, name: str) -> None:
        v = getattr(self, name)
        ok = (
            isinstance(v, tuple)
            and len(v) == 3
            and all(isinstance(c, int) and not isinstance(c, bool) and 0 <= c <= 255 for c in v)
        )
        if not ok:
            raise ProtocolError(f"display.{name} must be 3 integers in [0, 255], got {v!r}")

    def _check_border_rgb(self) -> None:
        self._check_rgb("border_rgb")

    def _check_background_rgb(self) -> None:
        self._check_rgb("background_rgb")

    def _check_gamma(self) -> None:
        self._check_positive_float("gamma")

    def _check_border_width_px(self) -> None:
        _need(self.border_width_px, int, "display.border_width_px")
        if self.border_width_px < 0:
            raise ProtocolError(f"display.border_width_px must be >= 0, got {self.border_width_px}")

    def _check_implant(self) -> None:
        if self.implant is None:
            if self.implant_layout is not None:
                raise ProtocolError("display.implant_layout needs display.implant (its name)")
            return
        _need(self.implant, str, "display.implant")
        if self.implant_layout is None:
            object.__setattr__(self, "implant_layout", _load_layout(self.implant))
        elif not isinstance(self.implant_layout, ImplantLayout):
            raise ProtocolError(
                f"display.implant_layout must be an ImplantLayout, got "
                f"{_type_name(self.implant_layout)}"
            )

    def to_dict(self) -> dict[str, Any]:
        """Return the spec as plain TOML/JSON-compatible data (``implant`` only when set).

        Leaving an unset ``implant`` out keeps the content hash and the logged display JSON of
        every protocol without one as they were before the field existed.
        """
        out = super().to_dict()
        if self.implant is None:
            del out["implant"]
        return out

    @classmethod
    def from_dict(
        cls, data: dict[str, Any], *, where: str | None = None, base_dir: str | Path | None = None
    ) -> DisplaySpec:
        """Build the spec from a ``[display]`` table; ``implant`` files resolve from ``base_dir``.

        Parameters
        ----------
        data : dict
            The table.
        where : str, optional
            Names the table in error messages.
        base_dir : str or Path, optional
            Folder of the protocol file: a relative ``implant = "mine.toml"`` is read from there
            (else from the current folder).
        """
        where = where or cls.__name__
        extra: dict[str, Any] = {}
        implant = data.get("implant") if isinstance(data, dict) else None
        if (
            base_dir is not None
            and isinstance(implant, str)
            and implant.lower().endswith(".toml")
            and not Path(implant).is_absolute()
        ):
            try:
                extra["implant_layout"] = _load_layout(str(Path(base_dir) / implant))
            except ProtocolError as exc:
                raise ProtocolError(f"[{where}] {exc}") from None
        return _from_table(cls, data, where, **extra)

    @property
    def px_per_cm(self) -> float:
        """Screen pixels per cm (horizontal)."""
        return self.screen_width_px / self.screen_width_cm

    @property
    def image_size_deg(self) -> tuple[float, float]:
        """Visual angle (width, height) of the stimulus, degrees."""

        def deg(size_cm: float) -> float:
            return math.degrees(2 * math.atan(size_cm / (2 * self.viewing_distance_cm)))

        return deg(self.image_width_cm), deg(self.image_height_cm)


@dataclass(frozen=True)
class ScoringSpec(_Spec):
    """How scores map to "recognised".

    Parameters
    ----------
    recognized : dict score -> bool
        Must give every score in :data:`SCORES`. Jung 2015 Sec. 3.2: naming the object or
        describing its use counts as recognised; describing only its shape does not.
    primary_rater : str
        The rater whose latest score defines ``recognized`` in ``tidy_trials``.
    """

    recognized: dict[str, bool] = field(
        default_factory=lambda: {
            "named": True,
            "use": True,
            "shape": False,
            "wrong": False,
            "pass": False,
        }
    )
    primary_rater: str = "operator"

    def _check_recognized(self) -> None:
        if not isinstance(self.recognized, dict):
            raise ProtocolError(
                f"scoring.recognized must be a table of score = true/false, got "
                f"{_type_name(self.recognized)}"
            )
        for k, v in self.recognized.items():
            if k not in SCORES:
                raise ProtocolError(
                    f"scoring.recognized has unknown score {k!r} (expected {', '.join(SCORES)})"
                )
            if not isinstance(v, bool):
                raise ProtocolError(f"scoring.recognized.{k} must be true or false, got {v!r}")
        missing = [s for s in SCORES if s not in self.recognized]
        if missing:
            raise ProtocolError(f"scoring.recognized is missing score {missing[0]!r}")

    def _check_primary_rater(self) -> None:
        _need(self.primary_rater, str, "scoring.primary_rater")
        if not self.primary_rater.strip():
            raise ProtocolError("scoring.primary_rater must not be empty")

    def __hash__(self) -> int:
        return hash((tuple(sorted(self.recognized.items())), self.primary_rater))

    def is_recognized(self, score: str) -> bool:
        """Return whether ``score`` counts as recognised under this protocol."""
        if score not in self.recognized:
            raise ValueError(f"score must be one of {', '.join(SCORES)}, got {score!r}")
        return self.recognized[score]


#: Longest line of an instruction screen, characters (ours: at the presenter's text size, about
#: 0.6 deg per line, 70 characters span about 25 deg, the width of the paper's 21-inch screen
#: at 80 cm), and the most lines (ours: 16 lines fill about half its height).
INSTRUCTION_MAX_LINE_CHARS = 70
INSTRUCTION_MAX_LINES = 16


@dataclass(frozen=True)
class InstructionsSpec(_Spec):
    """Texts of the subject's screens (``[instructions]``); the defaults are short titles.

    Parameters
    ----------
    wait : str
        Shown while the operator prepares (console start, after a presenter restart).
    training, main : str
        Shown before the first trial of the training and the main part; the operator explains
        it and presses Enter to go on.
    rest : str
        Shown at a planned break between blocks.
    pause : str
        Shown while the operator pauses the session (F8).
    end : str
        Shown when the session is complete.
    """

    wait: str = "Please wait for the experimenter."
    training: str = "Training part"
    main: str = "Main part"
    rest: str = "Break"
    pause: str = "Pause"
    end: str = "The session is complete. Thank you."

    def __post_init__(self) -> None:
        for f in fields(self):
            self._check_text(f.name)

    def _check_text(self, name: str) -> None:
        text = getattr(self, name)
        _need(text, str, f"instructions.{name}")
        if not text.strip():
            raise ProtocolError(f"instructions.{name} must not be empty")
        lines = text.strip("\n").split("\n")
        if len(lines) > INSTRUCTION_MAX_LINES:
            raise ProtocolError(
                f"instructions.{name} must have at most {INSTRUCTION_MAX_LINES} lines (so it "
                f"fits the subject's screen), got {len(lines)}"
            )
        for i, line in enumerate(lines, 1):
            if len(line) > INSTRUCTION_MAX_LINE_CHARS:
                raise ProtocolError(
                    f"instructions.{name} line {i} must have at most "
                    f"{INSTRUCTION_MAX_LINE_CHARS} characters (so it fits the subject's screen), "
                    f"got {len(line)}"
                )

    def for_part(self, part: str) -> str:
        """Return the text shown before the first trial of ``part`` ('training' or 'main')."""
        return self.training if part == "training" else self.main


@dataclass(frozen=True)
class BlockSpec(_Spec):
    """One ``[[blocks]]`` entry: a set of trials and how it is cut into blocks and ordered.

    The trials are every object of ``objects`` x every level in ``levels`` x every condition in
    ``conditions``, ``repetitions`` times.

    Parameters
    ----------
    part : {'training', 'main'}
        Which part of the session the trials belong to (training trials are not analysed).
    objects : str or tuple of str
        A role of the stimulus set (``"main"``, ``"training"``) or explicit object ids.
    levels : tuple of int
        Resolution levels (1 = fewest pixels ... 8 = full 492x327).
    conditions : tuple of {'cluttered', 'decluttered', 'photo'}
    group_by : {'level_condition', 'level', 'condition', 'none'}
        One block per (level, condition) pair (Jung 2015), per level (conditions mixed inside),
        per condition (levels mixed inside) or one block for everything.
    level_order : {'ascending', 'descending', 'listed', 'random'}
        Order of the level blocks. Jung 2015 Sec. 3.2: lowest to highest.
    condition_order : {'listed', 'random'}
        Order of the condition blocks at each level (listed: as in ``conditions``; random: drawn
        per level and subject). Jung 2015: cluttered first.
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

    def _check_part(self) -> None:
        _choice(self.part, PARTS, "part")

    def _check_objects(self) -> None:
        if isinstance(self.objects, str):
            if not self.objects:
                raise ProtocolError("objects must be a role name or a list of object ids")
            return
        if not isinstance(self.objects, tuple) or not self.objects:
            raise ProtocolError(
                f"objects must be a role name or a list of ids, got {self.objects!r}"
            )
        for o in self.objects:
            _need(o, str, "objects[]")
        if len(set(self.objects)) != len(self.objects):
            raise ProtocolError(f"objects lists an object twice: {self.objects!r}")

    def _check_levels(self) -> None:
        if not isinstance(self.levels, tuple) or not self.levels:
            raise ProtocolError(f"levels must be a non-empty list of integers, got {self.levels!r}")
        for lv in self.levels:
            _need(lv, int, "levels[]")
            if lv < 1:
                raise ProtocolError(f"levels must be >= 1, got {lv!r}")
        if len(set(self.levels)) != len(self.levels):
            raise ProtocolError(f"levels lists a level twice: {list(self.levels)}")

    def _check_conditions(self) -> None:
        if not isinstance(self.conditions, tuple) or not self.conditions:
            raise ProtocolError(f"conditions must be a non-empty list, got {self.conditions!r}")
        allowed = tuple(c.value for c in Condition)
        for c in self.conditions:
            _choice(c, allowed, "conditions[]")
        if len(set(self.conditions)) != len(self.conditions):
            raise ProtocolError(f"conditions lists a condition twice: {list(self.conditions)}")

    def _check_group_by(self) -> None:
        _choice(self.group_by, GROUP_BY, "group_by")

    def _check_level_order(self) -> None:
        _choice(self.level_order, LEVEL_ORDERS, "level_order")

    def _check_condition_order(self) -> None:
        _choice(self.condition_order, CONDITION_ORDERS, "condition_order")

    def _check_trial_order(self) -> None:
        _choice(self.trial_order, TRIAL_ORDERS, "trial_order")

    def _check_block_order(self) -> None:
        _choice(self.block_order, BLOCK_ORDERS, "block_order")

    def _check_repetitions(self) -> None:
        _need(self.repetitions, int, "repetitions")
        if self.repetitions < 1:
            raise ProtocolError(f"repetitions must be >= 1, got {self.repetitions!r}")

    def _check_break_every_blocks(self) -> None:
        _need(self.break_every_blocks, int, "break_every_blocks")
        if self.break_every_blocks < 0:
            raise ProtocolError(f"break_every_blocks must be >= 0, got {self.break_every_blocks!r}")


@dataclass(frozen=True)
class ProtocolSpec:
    """A whole protocol: general settings, display, scoring and the block entries in order.

    Parameters
    ----------
    name : str
    blocks : tuple of BlockSpec
        Run in the order given (training entries first, by convention).
    description : str
    pass_allowed_after_s : float >= 0
        Time after onset from which the subject may pass, seconds. Jung 2015 Sec. 3.2: 60 s.
    feedback : bool
        Whether the subject is told if an answer was right. Jung 2015: no feedback.
    display : DisplaySpec
    scoring : ScoringSpec
    instructions : InstructionsSpec
        Texts of the subject's instruction screens (``[instructions]``; optional).
    source_path : str or None
        The file it was loaded from (provenance only; not compared, not in ``to_dict``).
    source_sha256 : str or None
        SHA-256 of that file's bytes (H15).
    task : experiment.active.task.ActiveSearchSpec or None
        A ``[task]`` table (``type = "active_search"``, issue 14); such a protocol needs no
        ``[[blocks]]``.
    """

    name: str
    blocks: tuple[BlockSpec, ...]
    description: str = ""
    pass_allowed_after_s: float = 60.0
    feedback: bool = False
    display: DisplaySpec = field(default_factory=DisplaySpec)
    scoring: ScoringSpec = field(default_factory=ScoringSpec)
    instructions: InstructionsSpec = field(default_factory=InstructionsSpec)
    task: Any = None
    source_path: str | None = field(default=None, compare=False)
    source_sha256: str | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        for f in fields(self):
            check = getattr(self, f"_check_{f.name}", None)
            if check is not None:
                check()

    def _check_name(self) -> None:
        _need(self.name, str, "protocol.name")
        if not self.name.strip():
            raise ProtocolError("protocol.name must not be empty")

    def _check_description(self) -> None:
        _need(self.description, str, "protocol.description")

    def _check_pass_allowed_after_s(self) -> None:
        v = self.pass_allowed_after_s
        _need(v, (int, float), "protocol.pass_allowed_after_s")
        if not (math.isfinite(v) and v >= 0):
            raise ProtocolError(f"protocol.pass_allowed_after_s must be >= 0, got {v!r}")

    def _check_feedback(self) -> None:
        _need(self.feedback, bool, "protocol.feedback")

    def _check_blocks(self) -> None:
        if self.task is not None and self.blocks == ():
            return
        if not isinstance(self.blocks, tuple) or not self.blocks:
            raise ProtocolError("blocks must have at least one [[blocks]] entry")
        for b in self.blocks:
            if not isinstance(b, BlockSpec):
                raise ProtocolError(f"blocks must hold BlockSpec, got {_type_name(b)}")
        if not any(b.part == "main" for b in self.blocks):
            raise ProtocolError("blocks must have at least one entry with part = 'main'")

    def _check_task(self) -> None:
        if self.task is not None:
            from experiment.active.task import ActiveSearchSpec

            if not isinstance(self.task, ActiveSearchSpec):
                raise ProtocolError(
                    f"task must be an ActiveSearchSpec, got {_type_name(self.task)}"
                )

    def _check_display(self) -> None:
        if not isinstance(self.display, DisplaySpec):
            raise ProtocolError(f"display must be a DisplaySpec, got {_type_name(self.display)}")

    def _check_scoring(self) -> None:
        if not isinstance(self.scoring, ScoringSpec):
            raise ProtocolError(f"scoring must be a ScoringSpec, got {_type_name(self.scoring)}")

    def _check_instructions(self) -> None:
        if not isinstance(self.instructions, InstructionsSpec):
            raise ProtocolError(
                f"instructions must be an InstructionsSpec, got {_type_name(self.instructions)}"
            )

    def to_dict(self) -> dict[str, Any]:
        """Return the protocol in the TOML file's structure (plain data).

        ``instructions`` appears only when it differs from the defaults, so protocols without an
        ``[instructions]`` table keep their content hash.
        """
        out = {
            "protocol": {
                "name": self.name,
                "description": self.description,
                "pass_allowed_after_s": self.pass_allowed_after_s,
                "feedback": self.feedback,
            },
            "display": self.display.to_dict(),
            "scoring": self.scoring.to_dict(),
            "blocks": [b.to_dict() for b in self.blocks],
        }
        if self.task is not None:
            out["task"] = self.task.to_dict()
        if self.instructions != InstructionsSpec():
            out["instructions"] = self.instructions.to_dict()
        return out

    @classmethod
    def from_dict(
        cls,
        data: dict[str, Any],
        *,
        source_path: str | None = None,
        source_sha256: str | None = None,
    ) -> ProtocolSpec:
        """Build a protocol from the TOML file's structure, checking every key and value."""
        if not isinstance(data, dict):
            raise ProtocolError(f"a protocol must be a table, got {_type_name(data)}")
        allowed = ("protocol", "display", "scoring", "blocks", "task", "instructions")
        unknown = sorted(set(data) - set(allowed))
        if unknown:
            raise ProtocolError(
                f"unknown key {unknown[0]!r} at top level (expected one of {', '.join(allowed)})"
            )
        if "protocol" not in data:
            raise ProtocolError("missing table [protocol]")
        head = data["protocol"]
        if not isinstance(head, dict):
            raise ProtocolError(f"[protocol] must be a table, got {_type_name(head)}")
        head_keys = ("name", "description", "pass_allowed_after_s", "feedback")
        unknown = sorted(set(head) - set(head_keys))
        if unknown:
            raise ProtocolError(
                f"unknown key {unknown[0]!r} in [protocol] (expected one of {', '.join(head_keys)})"
            )
        if "name" not in head:
            raise ProtocolError("[protocol] is missing field name")
        task = None
        if "task" in data:
            from experiment.active.task import task_from_table

            task = task_from_table(data["task"])
        raw_blocks = data.get("blocks", [] if task is not None else None)
        if task is not None and raw_blocks == []:
            pass
        elif not isinstance(raw_blocks, list) or not raw_blocks:
            raise ProtocolError("missing [[blocks]]: a protocol needs at least one block entry")
        blocks = tuple(
            BlockSpec.from_dict(b, where=f"blocks[{i}]") for i, b in enumerate(raw_blocks)
        )
        display = DisplaySpec.from_dict(
            data.get("display", {}),
            where="display",
            base_dir=None if source_path is None else Path(source_path).parent,
        )
        if task is not None and display.implant_layout is not None:
            # Active search with an implant: the task's grid is the implant's electrode grid.
            lay = display.implant_layout
            if "grid_px" in data["task"] and tuple(task.grid_px) != lay.shape:
                raise ProtocolError(
                    f"task.grid_px {list(task.grid_px)} differs from display.implant "
                    f"{display.implant!r} ({lay.rows}x{lay.cols} electrodes); leave task.grid_px "
                    "out to use the implant's grid"
                )
            task = replace(task, grid_px=lay.shape)
        scoring_raw = (
            dict(data.get("scoring", {}))
            if isinstance(data.get("scoring", {}), dict)
            else data["scoring"]
        )
        if isinstance(scoring_raw, dict) and isinstance(scoring_raw.get("recognized"), dict):
            scoring_raw["recognized"] = dict(scoring_raw["recognized"])
        scoring = ScoringSpec.from_dict(scoring_raw, where="scoring")
        instructions = InstructionsSpec.from_dict(
            data.get("instructions", {}), where="instructions"
        )
        return cls(
            name=head["name"],
            description=head.get("description", ""),
            pass_allowed_after_s=head.get("pass_allowed_after_s", 60.0),
            feedback=head.get("feedback", False),
            display=display,
            scoring=scoring,
            instructions=instructions,
            blocks=blocks,
            task=task,
            source_path=source_path,
            source_sha256=source_sha256,
        )

    def content_sha256(self) -> str:
        """SHA-256 of the canonical JSON of :meth:`to_dict` (independent of file formatting)."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    @property
    def main_blocks(self) -> tuple[BlockSpec, ...]:
        """The entries of the main part."""
        return tuple(b for b in self.blocks if b.part == "main")


def load_protocol(path: str | Path) -> ProtocolSpec:
    """Load and check a protocol TOML file.

    Parameters
    ----------
    path : str or Path
        A file, or the bare name of a shipped protocol (``"jung2015"``).

    Returns
    -------
    ProtocolSpec

    Raises
    ------
    ProtocolError
        One line ``<file>: <what is wrong>`` for a missing file, bad TOML, an unknown key, a
        missing field or a bad value.
    """
    p = Path(path)
    if not p.exists() and not p.suffix and (PROTOCOLS_DIR / f"{p.name}.toml").is_file():
        p = PROTOCOLS_DIR / f"{p.name}.toml"
    if not p.is_file():
        raise ProtocolError(f"{p}: protocol file not found")
    raw = p.read_bytes()
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ProtocolError(f"{p}: not valid TOML ({exc})") from None
    except RecursionError:  # tomllib parses nested tables and arrays recursively
        raise ProtocolError(f"{p}: not valid TOML (tables or arrays nested too deeply)") from None
    try:
        return ProtocolSpec.from_dict(
            data, source_path=str(p), source_sha256=hashlib.sha256(raw).hexdigest()
        )
    except ProtocolError as exc:
        raise ProtocolError(f"{p}: {exc}") from None
