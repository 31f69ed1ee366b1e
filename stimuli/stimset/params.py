"""Parameters of a stimulus-set build: the command line's texts and the frozen ``BuildParams``."""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np

from stimuli import jung2015
from stimuli.declutter import AUTO_THRESHOLD_METHODS, DECLUTTER_MODES
from stimuli.errors import InputError
from stimuli.flagnames import param

__all__ = [
    "BuildParams",
    "MODES",
    "THRESHOLD_METHODS",
    "BUILD_DECLUTTER_MODES",
    "parse_working_size",
    "parse_threshold",
    "parse_edge_ratio",
    "min_photo_shape_px",
]

#: Automatic threshold methods of the build (ours, not the paper's: the paper set the threshold
#: by hand). ``'retention'`` (the default) uses both photos of a pair; the others only the narrow
#: photo. On the six real photo pairs in ``dof_pairs/`` Otsu leaves a mean wide-DOF edge fraction
#: of 0.28, retention 0.068 (paper 0.077); see ``stimuli/retention.py``.
THRESHOLD_METHODS: tuple[str, ...] = ("retention", *AUTO_THRESHOLD_METHODS)

#: De-cluttering modes of the build: ``'auto'`` (the default, ours) is ``'depth'`` for a light
#: field whose views lie along one axis (1-D) or mostly along one
#: (:func:`stimuli.lfviews.is_one_dimensional`), ``'sobel'`` otherwise and for photo
#: pairs; see :mod:`stimuli.stimset.lightfield`.
BUILD_DECLUTTER_MODES: tuple[str, ...] = ("auto", *DECLUTTER_MODES)

#: Kinds of stimuli: binary edge images, or grey-level compression of the photos (Fig. 2).
MODES: tuple[str, ...] = ("edges", "grey")

_SIZE_RE = re.compile(r"^\s*(\d+)\s*[xX×]\s*(\d+)\s*$")


def parse_working_size(text: str) -> tuple[int, int]:
    """Parse ``"WIDTHxHEIGHT"`` (the paper's order, e.g. ``"492x327"``) into ``(rows, cols)``.

    Raises
    ------
    InputError
        If the text is not two positive integers separated by ``x``.

    Examples
    --------
    >>> parse_working_size("492x327")
    (327, 492)
    """
    m = _SIZE_RE.match(str(text))
    if not m or int(m.group(1)) < 1 or int(m.group(2)) < 1:
        raise InputError(
            f"--working-size must be WIDTHxHEIGHT in pixels (e.g. 492x327), got {text!r}"
        )
    return (int(m.group(2)), int(m.group(1)))


#: Largest Sobel magnitude of an image in [0, 1]: scikit-image's kernels have weights summing
#: to 1 per side, so |Gx|, |Gy| <= 1 and sqrt((Gx**2 + Gy**2) / 2) <= 1.
_MAX_SOBEL = 1.0


def _parse_auto_or_number(
    text: str | float | None, option: str, expected: str, accept: Callable[[float], bool]
) -> float | None:
    """``None`` for ``"auto"`` (or ``None``), else the number, refused unless ``accept`` holds."""
    if text is None or (isinstance(text, str) and text.strip().lower() == "auto"):
        return None
    message = f"{option} must be 'auto' or {expected}, got {text!r}"
    try:
        v = float(text)
    except (TypeError, ValueError):
        raise InputError(message) from None
    if not accept(v):
        raise InputError(message)
    return v


def parse_threshold(text: str | float | None) -> float | None:
    """Parse a Sobel threshold: ``"auto"`` (or ``None``) gives ``None``, else a number in [0, 1].

    Raises
    ------
    InputError
        If the text is neither ``auto`` nor a number in [0, 1] (no Sobel magnitude exceeds 1).
    """
    return _parse_auto_or_number(
        text,
        "--threshold",
        f"a number in [0, {_MAX_SOBEL:g}] (the Sobel magnitude of an image in [0, 1] is at most "
        f"{_MAX_SOBEL:g}, so above it no pixel would be an edge)",
        lambda v: bool(np.isfinite(v)) and 0 <= v <= _MAX_SOBEL,
    )


def parse_edge_ratio(text: str | float | None) -> float | None:
    """Parse an edge ratio: ``"auto"`` (or ``None``) gives ``None``, else a number in [0, 1).

    Raises
    ------
    InputError
        If the text is neither ``auto`` nor a number in [0, 1).
    """
    return _parse_auto_or_number(text, "--edge-ratio", "a number in [0, 1)", lambda v: 0 <= v < 1)


def _check_choice(
    value: object, choices: tuple[str, ...], name: str, shown: str | None = None
) -> None:
    """Refuse a value outside ``choices``, naming the field and the choices.

    The choices are named by ``shown``, else by the tuple as Python writes it.
    """
    if value not in choices:
        raise InputError(
            f"{name} must be one of {choices if shown is None else shown}, got {value!r}"
        )


@dataclass(frozen=True)
class BuildParams:
    """Parameters of a stimulus-set build (every field is recorded in ``stimulus_set.json``).

    Parameters
    ----------
    working_shape_px : (rows, cols)
        Working size of the edge images (paper: 327 x 492).
    threshold : float >= 0 or None
        Global Sobel threshold; ``None`` = automatic per object (objects.csv values win).
    threshold_method : {'retention', 'otsu', 'triangle'}
        Automatic threshold method: ``'retention'`` uses both photos of the pair
        (:func:`stimuli.retention.retention_threshold`); the others the narrow photo alone
        (:func:`stimuli.declutter.auto_threshold`).
    edge_ratio : float in [0, 1) or None
        Compression edge ratio; ``None`` = mean wide-DOF edge fraction of the set.
    mode : {'edges', 'grey'}
        Binary edge stimuli, or grey-level compression of the photos (Fig. 2).
    grey_levels : int >= 2
        Grey levels in grey mode (the paper shows 8, 4 and 2).
    allow_resize : bool
        Accept pairs whose two photos differ in pixel size (each is resized on its own).
    windows_px : tuple of int
        Compression windows (paper: 1, 2, 3, 5, 7, 13, 18, 40).
    declutter : {'auto', 'sobel', 'depth'}
        De-cluttering of light-field objects: the paper's Sobel + threshold, or Sobel edges kept
        where the light field's views agree at the plane (:func:`stimuli.declutter.in_focus_mask`;
        ours, beyond the paper); ``'auto'``: ``'depth'`` for 1-D (or strongly anisotropic)
        light fields, whose refocusing blurs only along the baseline, else ``'sobel'``. Photo
        pairs use Sobel (``'depth'`` is refused for them by the build's plan).
    plane : str
        Light-field objects without their own plane or region in ``objects.csv``: ``'auto'``
        (nearest plane passing the evidence cuts of :mod:`stimuli.planechoice`),
        ``'strongest'``, ``'nearest'``, or a disparity (px per view step) as text.
    bokeh_guard : bool
        Photo pairs: drop narrow-DOF edges with no wide-DOF edge nearby
        (:func:`stimuli.declutter.bokeh_guard`; ours, beyond the paper).
    conditions : tuple of str
        The set's conditions, in order: ``cluttered`` and de-clutter methods of
        :mod:`stimuli.methods` (``decluttered`` is ``sobel``); default the paper's pair.
    fast_decode : bool
        Decode JPEG photos at reduced size (1/2, 1/4 or 1/8 in the DCT domain, Pillow's
        ``draft``), just large enough for the working size, before the anti-aliased resize.
        About 3-5x faster per photo; the images differ slightly from a full decode (on the real
        VABD/EBB! pairs 96-99 % of edge pixels agree). Off by default; recorded in the set.
    """

    working_shape_px: tuple[int, int] = jung2015.WORKING_SHAPE_PX
    threshold: float | None = None
    threshold_method: str = "retention"
    edge_ratio: float | None = None
    mode: str = "edges"
    grey_levels: int = 8
    allow_resize: bool = False
    windows_px: tuple[int, ...] = jung2015.WINDOWS_PX
    fast_decode: bool = False
    declutter: str = "auto"
    bokeh_guard: bool = False
    plane: str = "auto"
    conditions: tuple[str, ...] = ("cluttered", "decluttered")

    def __post_init__(self) -> None:
        for name in (
            "working_shape_px",
            "threshold",
            "threshold_method",
            "edge_ratio",
            "mode",
            "grey_levels",
            "windows_px",
            "declutter",
            "plane",
            "conditions",
        ):
            getattr(self, f"_check_{name}")()

    def _check_working_shape_px(self) -> None:
        s = self.working_shape_px
        if len(s) != 2 or any(int(v) < 1 for v in s):
            raise InputError(f"working_shape_px must be (rows, cols) > 0, got {s!r}")

    def _check_threshold(self) -> None:
        if self.threshold is not None and not (np.isfinite(self.threshold) and self.threshold >= 0):
            raise InputError(f"threshold must be None or a number >= 0, got {self.threshold!r}")

    def _check_threshold_method(self) -> None:
        _check_choice(self.threshold_method, THRESHOLD_METHODS, "threshold_method")

    def _check_edge_ratio(self) -> None:
        if self.edge_ratio is not None and not (0.0 <= self.edge_ratio < 1.0):
            raise InputError(f"edge_ratio must be None or in [0, 1), got {self.edge_ratio!r}")

    def _check_declutter(self) -> None:
        _check_choice(
            self.declutter,
            BUILD_DECLUTTER_MODES,
            param("declutter"),
            ", ".join(BUILD_DECLUTTER_MODES),
        )

    def _check_plane(self) -> None:
        from stimuli.planechoice import parse_plane_option

        object.__setattr__(self, "plane", parse_plane_option(self.plane))

    def _check_conditions(self) -> None:
        from stimuli.methods.registry import parse_conditions

        c = self.conditions
        if isinstance(c, str) or not all(isinstance(n, str) for n in c):
            raise InputError(f"conditions must be a sequence of names, got {c!r}")
        object.__setattr__(self, "conditions", parse_conditions(",".join(c)))

    def _check_mode(self) -> None:
        _check_choice(self.mode, MODES, "mode")

    def _check_grey_levels(self) -> None:
        g = self.grey_levels
        if isinstance(g, bool) or not isinstance(g, int) or not 2 <= g <= 256:
            raise InputError(f"grey_levels must be an integer in [2, 256], got {g!r}")

    def _check_windows_px(self) -> None:
        w = self.windows_px
        if not w or any(isinstance(v, bool) or int(v) != v or v < 1 for v in w):
            raise InputError(f"windows_px must be positive integers, got {w!r}")
        if len(set(w)) != len(w):
            raise InputError(f"windows_px must not repeat a window, got {w!r}")

    def to_dict(self) -> dict:
        """Return the parameters as JSON-ready values."""
        d = asdict(self)
        d["working_shape_px"] = list(self.working_shape_px)
        d["windows_px"] = list(self.windows_px)
        if self.plane == "auto":  # a set built with the default keeps the id it had before
            del d["plane"]
        if self.conditions == ("cluttered", "decluttered"):  # likewise the paper's conditions
            del d["conditions"]
        else:
            d["conditions"] = list(self.conditions)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> BuildParams:
        """Inverse of :meth:`to_dict`."""
        d = dict(d)
        d["working_shape_px"] = tuple(d["working_shape_px"])
        d["windows_px"] = tuple(d["windows_px"])
        if "conditions" in d:
            d["conditions"] = tuple(d["conditions"])
        return cls(**d)


def min_photo_shape_px(params: BuildParams) -> tuple[int, int]:
    """Return the smallest photo ``(rows, cols)`` the builder accepts for ``params``.

    A photo must give at least one pixel per cell of the coarsest level (working size divided
    by the largest window, rounded up) and at least 3x3 for the Sobel filter; anything smaller
    would be upsampled into a stimulus set with no information in it (a 1x1 photo, say).
    """
    w = max(params.windows_px)
    rows, cols = params.working_shape_px
    return max(3, -(-rows // w)), max(3, -(-cols // w))
