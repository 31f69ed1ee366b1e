"""De-clutter methods as a registry: each one function from an object's images to edges.

:mod:`~stimuli.methods.base` (what a method is), :mod:`~stimuli.methods.builtin` (sobel,
depth, mask, segment, saliency), :mod:`~stimuli.methods.registry` (built-in methods and the
``confocal.declutter`` entry point group). ``confocal stimuli methods`` lists them; ``confocal
stimuli build --conditions cluttered,sobel,mask`` builds a set with one condition per name.
"""

from stimuli.methods.base import Method, MethodInput, MethodResult
from stimuli.methods.registry import (
    ALIASES,
    ENTRY_POINT_GROUP,
    PAPER_CONDITIONS,
    available_methods,
    get_method,
    parse_conditions,
)

__all__ = [
    "Method",
    "MethodInput",
    "MethodResult",
    "ALIASES",
    "ENTRY_POINT_GROUP",
    "PAPER_CONDITIONS",
    "available_methods",
    "get_method",
    "parse_conditions",
]
