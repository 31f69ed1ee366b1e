"""The whole protocol (:class:`ProtocolSpec`), its ``[scoring]`` and ``[instructions]`` tables."""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Any

from experiment.protocol.blocks import BlockSpec
from experiment.protocol.display import DisplaySpec
from experiment.protocol.fields import (
    ProtocolError,
    _instance_of,
    _need_bool,
    _need_number,
    _need_str,
    _need_table,
    _need_text,
    _optional,
    _refuse_unknown,
    _Spec,
    _type_name,
)
from experiment.protocol.task import ActiveSearchSpec, task_from_table

__all__ = [
    "SCORES",
    "INSTRUCTION_MAX_LINE_CHARS",
    "INSTRUCTION_MAX_LINES",
    "ScoringSpec",
    "InstructionsSpec",
    "ProtocolSpec",
]


#: The five scores an answer can get. Source: Jung et al. 2015, Sec. 3.2 (name, use, shape or
#: features; a pass after 1 min); "wrong" is ours for a named but wrong object.
SCORES: tuple[str, ...] = ("named", "use", "shape", "wrong", "pass")


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

    _prefix = "scoring."
    _checks = {"primary_rater": _need_text}

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


def _screen_text(text: Any, name: str) -> None:
    """Refuse an instruction text that is empty or does not fit the subject's screen."""
    _need_text(text, name)
    lines = text.strip("\n").split("\n")
    if len(lines) > INSTRUCTION_MAX_LINES:
        raise ProtocolError(
            f"{name} must have at most {INSTRUCTION_MAX_LINES} lines (so it fits the subject's "
            f"screen), got {len(lines)}"
        )
    for i, line in enumerate(lines, 1):
        if len(line) > INSTRUCTION_MAX_LINE_CHARS:
            raise ProtocolError(
                f"{name} line {i} must have at most {INSTRUCTION_MAX_LINE_CHARS} characters (so "
                f"it fits the subject's screen), got {len(line)}"
            )


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

    _prefix = "instructions."
    _checks = dict.fromkeys(("wait", "training", "main", "rest", "pause", "end"), _screen_text)

    def for_part(self, part: str) -> str:
        """Return the text shown before the first trial of ``part`` ('training' or 'main')."""
        return self.training if part == "training" else self.main


@dataclass(frozen=True)
class ProtocolSpec(_Spec):
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
    task : experiment.protocol.task.ActiveSearchSpec or None
        A ``[task]`` table (``type = "active_search"``); such a protocol needs no
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
    task: ActiveSearchSpec | None = None
    source_path: str | None = field(default=None, compare=False)
    source_sha256: str | None = field(default=None, compare=False)

    _prefix = "protocol."
    _checks = {
        "name": _need_text,
        "description": _need_str,
        "pass_allowed_after_s": partial(_need_number, inclusive=True),
        "feedback": _need_bool,
        "display": _instance_of(DisplaySpec),
        "scoring": _instance_of(ScoringSpec),
        "instructions": _instance_of(InstructionsSpec),
        "task": _optional(_instance_of(ActiveSearchSpec)),
    }

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
        _refuse_unknown(
            data,
            ("protocol", "display", "scoring", "blocks", "task", "instructions"),
            "at top level",
        )
        if "protocol" not in data:
            raise ProtocolError("missing table [protocol]")
        head = data["protocol"]
        _need_table(head, "protocol")
        _refuse_unknown(
            head, ("name", "description", "pass_allowed_after_s", "feedback"), "in [protocol]"
        )
        if "name" not in head:
            raise ProtocolError("[protocol] is missing field name")
        task = None
        if "task" in data:
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
