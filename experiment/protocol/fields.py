"""Field readers of the protocol specs: one-line checks that name the field (house style H10, H11).

Every spec class of :mod:`experiment.protocol` (and the ``[task]`` table of
:mod:`experiment.protocol.task`) is a frozen dataclass built on :class:`_Spec`: its ``_checks``
table names the reader of each plain field, and a ``_check_<field>()`` method adds what a table
cannot say (checks across fields, loading an implant layout). A bad value raises
:class:`ProtocolError` with one line ``<table>.<field> must be <expected>, got <value>``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import MISSING, fields
from typing import Any, ClassVar

from experiment.errors import ConfocalError

__all__ = ["ProtocolError"]

#: A field reader: ``check(value, name)`` raises :class:`ProtocolError` naming ``name``.
Check = Callable[[Any, str], None]


class ProtocolError(ConfocalError):
    """A protocol file or spec is invalid (one line naming the field)."""


def _type_name(value: Any) -> str:
    return type(value).__name__


def _names(types: type | tuple[type, ...]) -> str:
    t = types if isinstance(types, tuple) else (types,)
    return " or ".join(x.__name__ for x in t)


def _need(value: Any, types: type | tuple[type, ...], name: str) -> None:
    """Refuse a value that is not of ``types`` (a bool is not an int unless ``bool`` is named)."""
    allowed = types if isinstance(types, tuple) else (types,)
    if not isinstance(value, types) or (isinstance(value, bool) and bool not in allowed):
        raise ProtocolError(f"{name} must be {_names(types)}, got {_type_name(value)} {value!r}")


def _need_str(value: Any, name: str) -> None:
    """Refuse a value that is not a string."""
    _need(value, str, name)


def _need_bool(value: Any, name: str) -> None:
    """Refuse a value that is not true or false."""
    _need(value, bool, name)


def _choice(value: Any, name: str, choices: tuple[str, ...]) -> None:
    """Refuse a value that is not one of ``choices``."""
    if value not in choices:
        raise ProtocolError(f"{name} must be one of {', '.join(choices)}, got {value!r}")


def _need_int(value: Any, name: str, *, minimum: int) -> None:
    """Refuse a value that is not an integer ``>= minimum``."""
    _need(value, int, name)
    if value < minimum:
        raise ProtocolError(f"{name} must be >= {minimum}, got {value!r}")


def _need_number(
    value: Any, name: str, *, inclusive: bool = False, expected: str | None = None
) -> None:
    """Refuse a value that is not a finite number ``> 0`` (``>= 0`` when ``inclusive``)."""
    _need(value, (int, float), name)
    if not (math.isfinite(value) and (value >= 0 if inclusive else value > 0)):
        expected = expected or (">= 0" if inclusive else "> 0")
        raise ProtocolError(f"{name} must be {expected}, got {value!r}")


def _need_text(value: Any, name: str, *, empty: str = "must not be empty") -> None:
    """Refuse a value that is not a string with something in it."""
    _need(value, str, name)
    if not value.strip():
        raise ProtocolError(f"{name} {empty}")


def _need_ints(value: Any, name: str, *, count: int, minimum: int, maximum: int | None = None):
    """Refuse a value that is not a tuple of ``count`` integers in ``[minimum, maximum]``."""
    ok = (
        isinstance(value, tuple)
        and len(value) == count
        and all(
            isinstance(v, int)
            and not isinstance(v, bool)
            and minimum <= v
            and (maximum is None or v <= maximum)
            for v in value
        )
    )
    if not ok:
        bounds = f">= {minimum}" if maximum is None else f"in [{minimum}, {maximum}]"
        raise ProtocolError(f"{name} must be {count} integers {bounds}, got {value!r}")


def _need_distinct(
    values: Any, name: str, *, noun: str, item: Check, expected: str = "a non-empty list"
) -> None:
    """Refuse a value that is not a non-empty tuple of distinct items, each read by ``item``."""
    if not isinstance(values, tuple) or not values:
        raise ProtocolError(f"{name} must be {expected}, got {values!r}")
    for v in values:
        item(v, f"{name}[]")
    if len(set(values)) != len(values):
        raise ProtocolError(f"{name} lists {noun} twice: {list(values)}")


def _optional(check: Check) -> Check:
    """Return a reader that lets ``None`` through and reads anything else with ``check``."""

    def read(value: Any, name: str) -> None:
        if value is not None:
            check(value, name)

    return read


def _instance_of(cls: type) -> Check:
    """Return a reader that refuses anything but a ``cls`` (a spec built by ``from_dict``).

    The message names the field without its table: such values come from code, not a file.
    """
    article = "an" if cls.__name__[0] in "AEIOU" else "a"

    def read(value: Any, name: str) -> None:
        if not isinstance(value, cls):
            field_name = name.rpartition(".")[2]
            raise ProtocolError(
                f"{field_name} must be {article} {cls.__name__}, got {_type_name(value)}"
            )

    return read


def _need_table(table: Any, where: str) -> None:
    """Refuse a TOML value that is not a table."""
    if not isinstance(table, dict):
        raise ProtocolError(f"[{where}] must be a table, got {_type_name(table)}")


def _refuse_unknown(table: dict, known: Any, where: str) -> None:
    """Refuse a key of ``table`` that is not in ``known`` (``where``: "in [x]", "at top level")."""
    known = list(known)
    unknown = sorted(set(table) - set(known))
    if unknown:
        raise ProtocolError(
            f"unknown key {unknown[0]!r} {where} (expected one of {', '.join(known)})"
        )


def _from_table(cls: type, table: Any, where: str, **extra: Any) -> Any:
    """Build a spec dataclass from a TOML table, refusing unknown keys and missing fields.

    ``extra`` are keyword arguments that do not come from the file (resolved values).
    """
    _need_table(table, where)
    known = {f.name: f for f in fields(cls) if f.init and f.metadata.get("toml", True)}
    _refuse_unknown(table, known, f"in [{where}]")
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

    #: The reader of each plain field, ``check(value, name)``, run in field order.
    _checks: ClassVar[dict[str, Check]] = {}
    #: Put before a field's name in messages (``"display."`` -> ``display.gamma``).
    _prefix: ClassVar[str] = ""

    def __post_init__(self) -> None:
        for f in fields(self):  # type: ignore[arg-type]
            check = self._checks.get(f.name)
            if check is not None:
                check(getattr(self, f.name), self._prefix + f.name)
            method = getattr(self, f"_check_{f.name}", None)
            if method is not None:
                method()

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
