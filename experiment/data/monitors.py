"""Monitor profiles: the lab's own screen, kept apart from the protocol.

A protocol's ``[display]`` table describes the paper's set-up (a 1280x1024 monitor 37.98 cm wide
at 80 cm). A lab's monitor is described once in a *monitor file*, like PsychoPy's Monitor Center,
and chosen with ``--monitor NAME|PATH`` in ``confocal session run`` and ``confocal present``::

    # protocols/monitors/lab_lcd.toml
    [monitor]
    name = "lab_lcd"
    description = "Dell U2412M in room 3.14, measured 2026-05-02"
    screen_width_cm = 51.8
    viewing_distance_cm = 80.0
    screen_width_px = 1920
    screen_height_px = 1200
    gamma = 2.2

Its five values replace the protocol's; the stimulus size in cm (and so in degrees) stays the
protocol's. The profile used (name, file, sha256, values) is recorded in the session's row of
the trial log. Shipped profiles live in ``protocols/monitors/`` (listed in its ``SHA256SUMS``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from experiment.errors import ConfocalError
from experiment.protocol import PROTOCOLS_DIR, DisplaySpec, ProtocolError
from experiment.protocol.load import read_toml, shipped_or_path

__all__ = [
    "MONITORS_DIR",
    "MONITOR_FIELDS",
    "MonitorError",
    "MonitorProfile",
    "load_monitor",
    "apply_monitor",
    "shipped_monitors",
]

#: Folder of the shipped monitor profiles.
MONITORS_DIR: Path = PROTOCOLS_DIR / "monitors"

#: The display fields a monitor profile sets (names as in :class:`DisplaySpec`).
MONITOR_FIELDS: tuple[str, ...] = (
    "screen_width_cm",
    "viewing_distance_cm",
    "screen_width_px",
    "screen_height_px",
    "gamma",
)


class MonitorError(ConfocalError):
    """A monitor profile is missing or invalid (one line naming the file and the field)."""


def _number(value: Any, name: str, *, integer: bool = False) -> None:
    kinds = (int,) if integer else (int, float)
    if isinstance(value, bool) or not isinstance(value, kinds):
        want = "an integer" if integer else "a number"
        raise MonitorError(f"{name} must be {want}, got {type(value).__name__} {value!r}")
    if not (math.isfinite(value) and value > 0):
        raise MonitorError(f"{name} must be > 0, got {value!r}")


@dataclass(frozen=True)
class MonitorProfile:
    """One monitor: its size, the subject's distance from it, its resolution and gamma.

    Parameters
    ----------
    name : str
        Short name (the file's stem for shipped profiles).
    screen_width_cm : float
        Visible width of the picture, cm (measure it; not the diagonal).
    viewing_distance_cm : float
        Eye to screen, cm.
    screen_width_px, screen_height_px : int
        Resolution the subject's window runs at, pixels.
    gamma : float
        Display gamma from a photometer measurement (1 = linear, no correction).
    description : str
        Free text: model, room, date of the measurement.
    """

    name: str
    screen_width_cm: float
    viewing_distance_cm: float
    screen_width_px: int
    screen_height_px: int
    gamma: float = 1.0
    description: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise MonitorError(f"name must be a non-empty string, got {self.name!r}")
        for name in MONITOR_FIELDS:
            _number(getattr(self, name), name, integer=name.endswith("_px"))
        if not 0.2 <= self.gamma <= 5.0:
            raise MonitorError(f"gamma must be in [0.2, 5] (a display's gamma), got {self.gamma}")
        if not isinstance(self.description, str):
            raise MonitorError(f"description must be a string, got {self.description!r}")

    def to_dict(self) -> dict[str, Any]:
        """Return the profile as plain data (the ``[monitor]`` table)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> MonitorProfile:
        """Build a profile from a ``[monitor]`` table, refusing unknown keys and missing fields."""
        if not isinstance(data, dict):
            raise MonitorError(f"[monitor] must be a table, got {type(data).__name__}")
        known = [f.name for f in dataclasses.fields(cls)]
        unknown = sorted(set(data) - set(known))
        if unknown:
            raise MonitorError(
                f"unknown key {unknown[0]!r} in [monitor] (expected one of {', '.join(known)})"
            )
        required = [f.name for f in dataclasses.fields(cls) if f.default is dataclasses.MISSING]
        missing = [k for k in required if k not in data]
        if missing:
            raise MonitorError(f"[monitor] is missing field {missing[0]}")
        return cls(**data)


def shipped_monitors() -> list[str]:
    """Return the names of the shipped monitor profiles."""
    return sorted(p.stem for p in MONITORS_DIR.glob("*.toml"))


def load_monitor(name_or_path: str | Path) -> tuple[MonitorProfile, dict[str, Any]]:
    """Load a monitor profile by shipped name or file path.

    Parameters
    ----------
    name_or_path : str or Path
        A ``.toml`` file, or the name of a profile in :data:`MONITORS_DIR`.

    Returns
    -------
    profile : MonitorProfile
    record : dict
        What the trial log stores: ``name``, ``path``, ``sha256`` of the file and the values.

    Raises
    ------
    MonitorError
        One line ``<file>: <what is wrong>``: not found, bad TOML, unknown key, missing or bad
        field.
    """
    p = shipped_or_path(name_or_path, MONITORS_DIR)
    if not p.is_file():
        names = ", ".join(shipped_monitors()) or "none"
        raise MonitorError(
            f"{name_or_path}: monitor profile not found (a .toml file, or one of: {names})"
        )
    raw, data = read_toml(p, MonitorError)
    unknown = sorted(set(data) - {"monitor"})
    if unknown or "monitor" not in data:
        raise MonitorError(
            f"{p}: a monitor file has one table, [monitor]; got {', '.join(data) or 'nothing'}"
        )
    try:
        profile = MonitorProfile.from_dict(data["monitor"])
    except (MonitorError, TypeError) as exc:
        raise MonitorError(f"{p}: {exc}") from None
    record = {
        "name": profile.name,
        "path": str(p),
        "sha256": hashlib.sha256(raw).hexdigest(),
        **{k: getattr(profile, k) for k in MONITOR_FIELDS},
    }
    return profile, record


def apply_monitor(display: DisplaySpec, profile: MonitorProfile) -> DisplaySpec:
    """Return ``display`` with the monitor's size, distance, resolution and gamma.

    Raises
    ------
    MonitorError
        The protocol's stimulus does not fit on this monitor (e.g. the image is wider in cm
        than the screen).
    """
    values = {k: getattr(profile, k) for k in MONITOR_FIELDS}
    values["screen_width_cm"] = float(values["screen_width_cm"])
    values["viewing_distance_cm"] = float(values["viewing_distance_cm"])
    values["gamma"] = float(values["gamma"])
    try:
        return dataclasses.replace(display, **values)
    except ProtocolError as exc:
        raise MonitorError(f"monitor {profile.name!r} does not fit the protocol: {exc}") from None
