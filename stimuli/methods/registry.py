"""The registry of de-clutter methods: the built-in ones and third-party plug-ins.

A plug-in registers a method through the entry point group :data:`ENTRY_POINT_GROUP`
(``confocal.declutter``) of its distribution, e.g. in its ``pyproject.toml``::

    [project.entry-points."confocal.declutter"]
    deepseg = "mylab.deepseg:METHOD"

The entry point names a :class:`~stimuli.methods.base.Method` (its ``name`` must be the entry
point's), or a plain function ``f(MethodInput) -> MethodResult``, which is wrapped with the entry
point's name, the first line of its docstring and the distribution's version. A plug-in is
loaded only when its method is listed or used; one that fails to load is named in one line.
"""

from __future__ import annotations

from dataclasses import replace
from importlib.metadata import entry_points

from stimuli.errors import InputError
from stimuli.methods import builtin
from stimuli.methods.base import Method

__all__ = [
    "ENTRY_POINT_GROUP",
    "ALIASES",
    "BASELINE_CONDITION",
    "PAPER_CONDITIONS",
    "builtin_methods",
    "available_methods",
    "get_method",
    "method_names",
    "parse_conditions",
]

#: The entry point group third-party methods register in.
ENTRY_POINT_GROUP: str = "confocal.declutter"

#: Condition names that select a method under another name: the paper's ``decluttered`` is
#: ``sobel``.
ALIASES: dict[str, str] = {"decluttered": "sobel"}

#: The condition every set can hold without a method: the wide-DOF photo's Sobel edges at the
#: same threshold (the paper's cluttered images).
BASELINE_CONDITION: str = "cluttered"

#: The paper's two conditions, the default of a build.
PAPER_CONDITIONS: tuple[str, ...] = ("cluttered", "decluttered")

_PAPER = "Jung, Aloni, Yitzhaky & Peli (2015), Vision Research 111, Sec. 2.2"


def _version() -> str:
    from stimuli import __version__

    return __version__


def builtin_methods() -> dict[str, Method]:
    """Return the built-in methods by name: sobel, depth, mask, segment, saliency.

    Returns
    -------
    dict of str to Method
    """
    v = _version()
    return {
        m.name: m
        for m in (
            Method(
                "sobel",
                builtin.sobel_method,
                "Sobel edges of the narrow-DOF photo above the threshold (the paper's; alias "
                "'decluttered')",
                _PAPER,
                v,
            ),
            Method(
                "depth",
                builtin.depth_method,
                "Sobel edges kept where a light field's views agree at the plane (light fields "
                "only)",
                "ours: view agreement at the confocal plane (stimuli.declutter.in_focus_mask)",
                v,
                needs=("focus",),
            ),
            Method(
                "mask",
                builtin.mask_method,
                "Edges of the narrow-DOF photo cut to the object's own mask (OBJECT/mask.png)",
                "ours: the user's segmentation, the 'perfect segmentation' bound",
                v,
                needs=("mask",),
            ),
            Method(
                "segment",
                builtin.segment_method,
                "Edges cut to a random-walker segmentation seeded by in-focus vs blurred-clutter "
                "edges",
                "Grady (2006), IEEE TPAMI 28(11) 1768-1783; seeds ours",
                v,
                parameters={"scale": builtin.SEGMENT_SCALE, "beta": builtin.RW_BETA},
            ),
            Method(
                "saliency",
                builtin.saliency_method,
                "Edges cut to the spectral-residual salient region (above 3x the map's mean)",
                "Hou & Zhang (2007), CVPR, 'Saliency detection: a spectral residual approach'",
                v,
                parameters={
                    "width_px": builtin.SALIENCY_WIDTH_PX,
                    "factor": builtin.SALIENCY_FACTOR,
                },
            ),
        )
    }


def _plugin(ep) -> Method:
    """Load one entry point as a Method, or raise a one-line InputError naming it."""
    where = f"de-clutter plug-in {ep.name!r} ({ep.value}, entry point group {ENTRY_POINT_GROUP})"
    try:
        obj = ep.load()
    except Exception as exc:  # a broken plug-in must not break the command
        raise InputError(f"{where} failed to load: {type(exc).__name__}: {exc}") from None
    dist = getattr(ep, "dist", None)
    version = getattr(dist, "version", "") or ""
    source = f"entry point {ep.value}" + (f" ({dist.name} {version})" if dist else "")
    if isinstance(obj, Method):
        if obj.name != ep.name:
            raise InputError(f"{where}: the Method is named {obj.name!r}, not {ep.name!r}")
        return replace(obj, version=obj.version or version, source=source)
    if callable(obj):
        doc = (getattr(obj, "__doc__", None) or "").strip().splitlines()
        return Method(
            ep.name,
            obj,
            doc[0] if doc else "(no description)",
            "third party",
            version,
            source=source,
        )
    raise InputError(f"{where}: expected a Method or a function, got {type(obj).__name__}")


def _plugin_entry_points() -> dict:
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def available_methods(*, strict: bool = False) -> tuple[dict[str, Method], dict[str, str]]:
    """Return every method, built-in first, and the plug-ins that failed to load.

    Parameters
    ----------
    strict : bool
        Raise on a plug-in that fails to load instead of returning it among the failures.

    Returns
    -------
    methods : dict of str to Method
        Built-in methods, then plug-ins in name order (a plug-in may not take a built-in's
        name or an alias).
    failed : dict of str to str
        Plug-in name to the one-line reason it failed.
    """
    methods = builtin_methods()
    failed: dict[str, str] = {}
    for name, ep in sorted(_plugin_entry_points().items()):
        try:
            if name in methods or name in ALIASES or name == BASELINE_CONDITION:
                raise InputError(
                    f"de-clutter plug-in {name!r} ({ep.value}) takes a built-in name; rename it"
                )
            methods[name] = _plugin(ep)
        except InputError as exc:
            if strict:
                raise
            failed[name] = str(exc)
    return methods, failed


def method_names() -> tuple[str, ...]:
    """Return every name a condition may use for a method, without loading any plug-in.

    Built-in methods, their aliases, then the plug-ins' entry point names, each once.
    """
    names = [*builtin_methods(), *ALIASES, *sorted(_plugin_entry_points())]
    return tuple(dict.fromkeys(names))


def get_method(name: str) -> Method:
    """Return the method a condition name selects (an alias gives its method).

    Raises
    ------
    InputError
        If no method has that name (the message lists them), or its plug-in fails to load.
    """
    key = ALIASES.get(name, name)
    builtins = builtin_methods()
    if key in builtins:
        return builtins[key]
    eps = _plugin_entry_points()
    if key in eps:
        return _plugin(eps[key])
    known = sorted([*builtins, *eps, *ALIASES, BASELINE_CONDITION])
    raise InputError(f"unknown condition {name!r}; expected one of {', '.join(known)}")


def parse_conditions(text: str | None) -> tuple[str, ...]:
    """Parse ``--conditions``: comma-separated condition names (default: the paper's pair).

    Parameters
    ----------
    text : str or None
        E.g. ``"cluttered,sobel,mask,segment"``; ``None`` or empty gives
        :data:`PAPER_CONDITIONS`.

    Returns
    -------
    tuple of str
        The names in the order given; each is ``cluttered`` or selects a method.

    Raises
    ------
    InputError
        An unknown name, a repeated one (an alias and its method count as one), or a list
        without a method.

    Examples
    --------
    >>> parse_conditions("cluttered, decluttered")
    ('cluttered', 'decluttered')
    """
    if text is None or not str(text).strip():
        return PAPER_CONDITIONS
    names = tuple(p.strip() for p in str(text).split(","))
    if any(not n for n in names):
        raise InputError(
            f"--conditions: empty name in {text!r}; expected names like cluttered,sobel"
        )
    seen: dict[str, str] = {}
    for n in names:
        key = n if n == BASELINE_CONDITION else ALIASES.get(n, n)
        if key in seen:
            raise InputError(f"--conditions: {n!r} repeats {seen[key]!r}")
        seen[key] = n
        if n != BASELINE_CONDITION:
            get_method(n)
    if all(n == BASELINE_CONDITION for n in names):
        raise InputError(f"--conditions {text!r}: expected at least one de-clutter method")
    return names
