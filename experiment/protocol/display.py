"""The ``[display]`` table of a protocol: screen, stimulus geometry and an optional implant."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

from experiment.protocol.fields import (
    ProtocolError,
    _from_table,
    _need,
    _need_int,
    _need_ints,
    _need_number,
    _Spec,
    _type_name,
)
from stimuli.implants import ImplantError, ImplantLayout, load_implant
from stimuli.jung2015 import BORDER_RGB, IMAGE_SIZE_CM, SCREEN_SHAPE_PX, VIEWING_DISTANCE_CM

__all__ = ["DisplaySpec"]

_positive_int = partial(_need_int, minimum=1)
_positive_number = partial(_need_number, expected="a positive number")
_rgb = partial(_need_ints, count=3, minimum=0, maximum=255)


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
        Show every stimulus as this implant shows it (beyond the paper): resampled to its
        electrode grid (:func:`stimuli.implants.to_implant_grid`) and drawn as its phosphenes at
        its field of view, as ``confocal present --implant`` does. A shipped layout's name
        (``argus2``) or a ``.toml`` file, relative to the protocol file. Checked when the
        protocol loads. Colour training photos are still shown as photos.
    implant_layout : stimuli.implants.ImplantLayout or None
        The layout ``implant`` names, loaded when the spec is built (not a TOML key; a caller
        that resolved the file itself may pass it).
    """

    screen_width_px: int = SCREEN_SHAPE_PX[1]
    screen_height_px: int = SCREEN_SHAPE_PX[0]
    #: Inferred, not stated in the paper: 14.6 cm for the 492 px image means 0.2967 mm per
    #: pixel if it was shown pixel for pixel, so 1280 px span 37.98 cm, the visible width of a
    #: 21-inch CRT. Measure your own monitor.
    screen_width_cm: float = 37.98
    viewing_distance_cm: float = VIEWING_DISTANCE_CM
    image_width_cm: float = IMAGE_SIZE_CM[1]
    image_height_cm: float = IMAGE_SIZE_CM[0]
    border_rgb: tuple[int, int, int] = BORDER_RGB
    border_width_px: int = 6
    background_rgb: tuple[int, int, int] = (0, 0, 0)
    gamma: float = 1.0
    implant: str | None = None
    implant_layout: ImplantLayout | None = field(
        default=None, compare=False, repr=False, metadata={"toml": False}
    )

    _prefix = "display."
    _checks = {
        "screen_width_px": _positive_int,
        "screen_height_px": _positive_int,
        "screen_width_cm": _positive_number,
        "viewing_distance_cm": _positive_number,
        "image_width_cm": _positive_number,
        "image_height_cm": _positive_number,
        "border_rgb": _rgb,
        "border_width_px": partial(_need_int, minimum=0),
        "background_rgb": _rgb,
        "gamma": _positive_number,
    }

    def _check_image_width_cm(self) -> None:
        if self.image_width_cm > self.screen_width_cm:
            raise ProtocolError(
                f"display.image_width_cm must be <= screen_width_cm ({self.screen_width_cm}), "
                f"got {self.image_width_cm!r}"
            )

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
