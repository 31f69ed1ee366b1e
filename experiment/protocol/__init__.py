"""Protocols: what a session shows and in which order, loaded from ``protocols/*.toml`` (H10).

A protocol file has four tables, and two optional ones::

    [protocol]      name, description, pass_allowed_after_s, feedback
    [display]       screen and image geometry (DisplaySpec)
    [scoring]       which scores count as recognised, who the primary rater is (ScoringSpec)
    [[blocks]]      one or more entries (BlockSpec), each expanding into one or more blocks
    [instructions]  the texts of the subject's instruction screens (InstructionsSpec)
    [task]          an active-search task instead of blocks (ActiveSearchSpec)

Every value is checked when the spec is built; an unknown key, a wrong type or a missing field
raises :class:`ProtocolError` with one line naming the file and the field.

The package is split by job: :mod:`~experiment.protocol.fields` (the field readers and the
error), :mod:`~experiment.protocol.display`, :mod:`~experiment.protocol.blocks`,
:mod:`~experiment.protocol.task` (the table specs), :mod:`~experiment.protocol.spec` (the whole
protocol, scoring and instructions) and :mod:`~experiment.protocol.load` (reading a file).

Examples
--------
>>> spec = load_protocol(PROTOCOLS_DIR / "jung2015.toml")
>>> spec.name, sum(b.part == "main" for b in spec.blocks)
('jung2015', 1)
"""

from experiment.protocol.blocks import BlockSpec, Condition
from experiment.protocol.display import DisplaySpec
from experiment.protocol.fields import ProtocolError
from experiment.protocol.load import PROTOCOLS_DIR, load_protocol
from experiment.protocol.spec import SCORES, InstructionsSpec, ProtocolSpec, ScoringSpec

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
