"""What a de-clutter method is: its input (one object's images), its result, its record.

A method is one function: the images of one object at the working size in
(:class:`MethodInput`), an edge image and what it measured out (:class:`MethodResult`). A
:class:`Method` wraps the function with the name a condition uses, a one-line description, a
reference and a version, which ``stimulus_set.json`` records for every condition it built.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from stimuli.errors import InputError

__all__ = ["MethodInput", "MethodResult", "Method", "NEEDS", "as_edges"]

#: What a method may need beyond the two photos: ``'mask'`` (the object's own mask,
#: ``OBJECT/mask.png``) and ``'focus'`` (a light field's in-focus mask at the plane).
NEEDS: tuple[str, ...] = ("mask", "focus")


@dataclass(frozen=True)
class MethodInput:
    """One object's images at the working size, as every method receives them.

    Parameters
    ----------
    object : str
        Object id (for messages).
    wide, narrow : ndarray of shape (rows, cols), float32 in [0, 1]
        The wide-DOF photo (or a light field's centre view) and the narrow-DOF photo (or its
        confocal image), after the build's zoom, aspect crop and resize.
    threshold : float >= 0
        The object's Sobel threshold by the set's rules (``objects.csv``, ``--threshold`` or
        the automatic rule), the one the cluttered condition is built with.
    kind : {'photos', 'lightfield'}
    focus : ndarray of bool or None
        A light field's in-focus mask at its confocal plane (``None`` for photo pairs, or a
        light field de-cluttered by Sobel).
    mask : ndarray of bool or None
        The object's own mask (``OBJECT/mask.png`` through the same crop and resize, at 0.5),
        given only to methods that need it.
    """

    object: str
    wide: np.ndarray
    narrow: np.ndarray
    threshold: float
    kind: str = "photos"
    focus: np.ndarray | None = None
    mask: np.ndarray | None = None


@dataclass(frozen=True)
class MethodResult:
    """What a method returns.

    Parameters
    ----------
    edges : ndarray of shape (rows, cols), bool, or float in [0, 1]
        The de-cluttered edge image; a grey one is an edge where it is at least 0.5
        (:func:`as_edges`).
    measured : mapping of str to number or str
        What the method measured on this object (its threshold, the share of the image its
        region covers, ...), recorded per object in ``stimulus_set.json``.
    """

    edges: np.ndarray
    measured: Mapping[str, float | int | str] = field(default_factory=dict)


@dataclass(frozen=True)
class Method:
    """A registered de-clutter method.

    Parameters
    ----------
    name : str
        The condition name that selects it (letters, digits and ``_``, starting with a letter).
    function : callable(MethodInput) -> MethodResult
    description : str
        One line.
    reference : str
        Where the method comes from (a publication, or "ours").
    version : str
        The method's version (the package's for built-in methods, the distribution's for a
        plug-in), recorded with each condition it built.
    needs : tuple of str
        What it needs beyond the photos, from :data:`NEEDS`.
    parameters : mapping of str to value
        Its fixed parameters, recorded with each condition it built.
    source : str
        ``'built-in'`` or the entry point that registered it.
    """

    name: str
    function: Callable[[MethodInput], MethodResult]
    description: str
    reference: str
    version: str = ""
    needs: tuple[str, ...] = ()
    parameters: Mapping[str, object] = field(default_factory=dict)
    source: str = "built-in"

    def __post_init__(self) -> None:
        import re

        if not isinstance(self.name, str) or not re.fullmatch(r"[a-z][a-z0-9_]{0,31}", self.name):
            raise InputError(
                f"method name must be lower-case letters, digits and '_' (starting with a "
                f"letter, at most 32), got {self.name!r}"
            )
        if not callable(self.function):
            raise InputError(f"method {self.name!r}: function is not callable")
        bad = [n for n in self.needs if n not in NEEDS]
        if bad:
            raise InputError(f"method {self.name!r}: needs must be among {NEEDS}, got {bad}")
        object.__setattr__(self, "needs", tuple(self.needs))
        object.__setattr__(self, "parameters", MappingProxyType(dict(self.parameters)))

    def run(self, images: MethodInput) -> MethodResult:
        """Run the method on one object; check and return its result.

        Parameters
        ----------
        images : MethodInput

        Returns
        -------
        MethodResult
            With ``edges`` a bool image of the working size.

        Raises
        ------
        InputError
            If the method returns anything but a :class:`MethodResult` whose edge image has
            the working size, or a grey image outside [0, 1].
        """
        out = self.function(images)
        if not isinstance(out, MethodResult):
            raise InputError(
                f"method {self.name!r} ({self.source}) returned {type(out).__name__}; "
                "expected a MethodResult"
            )
        edges = as_edges(out.edges, images.narrow.shape, where=f"method {self.name!r}")
        return MethodResult(edges, dict(out.measured))


def as_edges(image: np.ndarray, shape_px: tuple[int, int], *, where: str) -> np.ndarray:
    """Return a method's edge image as bool: a grey one is an edge where it is >= 0.5.

    Parameters
    ----------
    image : ndarray, bool or float in [0, 1]
    shape_px : (rows, cols)
        The working size it must have.
    where : str
        Names the method in error messages.

    Returns
    -------
    ndarray of shape ``shape_px``, bool

    Examples
    --------
    >>> as_edges(np.array([[0.2, 0.7]]), (1, 2), where="x").tolist()
    [[False, True]]
    """
    a = np.asarray(image)
    if a.shape != tuple(shape_px):
        raise InputError(f"{where}: edge image is {a.shape}, expected the working size {shape_px}")
    if a.dtype == bool:
        return a.copy()
    if not np.issubdtype(a.dtype, np.number):
        raise InputError(f"{where}: edge image must be bool or numbers, got {a.dtype}")
    if a.size and not (np.isfinite(a).all() and a.min() >= 0 and a.max() <= 1):
        raise InputError(f"{where}: a grey edge image must hold values in [0, 1]")
    return a >= 0.5
