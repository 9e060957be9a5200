"""The validation kit: the one error type a user sees for bad input, and the readers that raise it.

Every parser of user input (scenario YAML, wind, sensors, the fence and its
files, profiles, flight logs) reads its values through these functions and
raises :class:`ConfigError` (or a subclass naming its domain), so the CLI
catches one type, prints its one-line message and exits with code 2, without a
traceback. A message reads ``<file>: <field>: <problem>``: callers pass the
field's full path as ``where``.

A leaf module: the standard library only, so that both bottom packages
(``geofence`` and ``wind``) can use it.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import re
from collections.abc import Collection, Mapping
from enum import Enum
from typing import Any, TypeVar

E = TypeVar("E", bound=Enum)


TOP_LEVEL = "(top level)"
"""The ``where`` of a document's top level (``"scenario.yaml: (top level)"``)."""


class ConfigError(ValueError):
    """Bad user input (a scenario, fence, profile, sensor or log file, or a command-line value).

    The message is one line, ``<file>: <field>: <problem>``, fit to print as it is: the CLI catches this type
    (every parser's own error type subclasses it) and exits with code 2, without a traceback.
    """


def kind(value: Any) -> str:
    """What a value is, in words, for messages ("a mapping", "a list", "nothing" ...)."""
    if value is None:
        return "nothing"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, Mapping):
        return "a mapping"
    if isinstance(value, (list, tuple)):
        return "a list"
    return type(value).__name__


def require_mapping(value: Any, where: str) -> Mapping:
    if not isinstance(value, Mapping):
        raise ConfigError(f"{where}: expected a mapping (key: value), got {kind(value)}")
    return value


_PLAIN_KEY = re.compile(r"[A-Za-z0-9_\-\[\]]+")


def field_path(where: str, key: Any) -> str:
    """``<where>.<key>``; a ``where`` ending in :data:`TOP_LEVEL` names a document's top level, whose keys stand bare.

    A key that is not a plain name (spaces, newlines, quotes, not a string) is quoted with ``repr``, so the
    message stays one line whatever the file holds.
    """
    name = key if isinstance(key, str) and _PLAIN_KEY.fullmatch(key) else repr(key)
    if where.endswith(TOP_LEVEL):
        return f"{where[: -len(TOP_LEVEL)]}{name}"
    return f"{where}.{name}"


def reject_unknown_keys(mapping: Mapping, allowed: Collection[str], where: str) -> None:
    """Refuse the first key not in ``allowed``: ``<where>.<key>: unknown key (did you mean ...? allowed: ...)``."""
    names = sorted(str(k) for k in allowed)
    for key in mapping:
        if key not in allowed:
            close = difflib.get_close_matches(str(key), names, n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise ConfigError(f"{field_path(where, key)}: unknown key ({hint}allowed: {', '.join(names)})")


def number(
    value: Any,
    where: str,
    *,
    minimum: float | None = None,
    maximum: float | None = None,
    strictly_positive: bool = False,
    allow_inf: bool = False,
) -> float:
    """A finite real number within [minimum, maximum] (and > 0 when ``strictly_positive``); never a boolean.

    ``allow_inf``: +inf is accepted too (an unbounded limit).
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"{where}: expected a number, got {kind(value)} {value!r}")
    x = float(value)
    if math.isnan(x) or (math.isinf(x) and not (allow_inf and x > 0)):
        raise ConfigError(f"{where}: must be a finite number, got {value!r}")
    if strictly_positive and not x > 0.0:
        raise ConfigError(f"{where}: must be > 0, got {value!r}")
    if minimum is not None and x < minimum:
        raise ConfigError(f"{where}: must be >= {minimum:g}, got {value!r}")
    if maximum is not None and x > maximum:
        raise ConfigError(f"{where}: must be <= {maximum:g}, got {value!r}")
    return x


def integer(value: Any, where: str, *, minimum: int | None = None) -> int:
    """An integer (never a boolean), at least ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(f"{where}: expected an integer, got {kind(value)} {value!r}")
    if minimum is not None and value < minimum:
        raise ConfigError(f"{where}: must be >= {minimum}, got {value}")
    return value


def number_range(value: Any, where: str, *, minimum: float | None = None, strictly_positive: bool = False) -> tuple[float, float]:
    """A number (a fixed value, returned as ``(x, x)``) or a ``[low, high]`` pair with low <= high."""
    if isinstance(value, (list, tuple)):
        if len(value) != 2:
            raise ConfigError(f"{where}: expected a number or a [low, high] pair, got a list of {len(value)}")
        lo = number(value[0], f"{where}[0]", minimum=minimum, strictly_positive=strictly_positive)
        hi = number(value[1], f"{where}[1]", minimum=minimum, strictly_positive=strictly_positive)
        if hi < lo:
            raise ConfigError(f"{where}: low must be <= high, got [{value[0]!r}, {value[1]!r}]")
        return (lo, hi)
    x = number(value, where, minimum=minimum, strictly_positive=strictly_positive)
    return (x, x)


def direction_deg(value: Any, where: str) -> float:
    """A compass direction in degrees, [0, 360], returned modulo 360."""
    return number(value, where, minimum=0.0, maximum=360.0) % 360.0


def string(value: Any, where: str, *, choices: Collection[str] | None = None) -> str:
    """A non-empty string, one of ``choices`` if given."""
    if not isinstance(value, str) or not value:
        expected = f"one of {', '.join(choices)}" if choices is not None else "a non-empty string"
        raise ConfigError(f"{where}: expected {expected}, got {kind(value)} {value!r}")
    if choices is not None and value not in choices:
        raise ConfigError(f"{where}: {value!r} is not one of {', '.join(choices)}")
    return value


def enum_value(value: Any, where: str, enum_type: type[E]) -> E:
    """The member of ``enum_type`` whose value is ``value`` (a member passes through); else one line listing them."""
    if isinstance(value, enum_type):
        return value
    for member in enum_type:
        if member.value == value:
            return member
    allowed = ", ".join(str(m.value) for m in enum_type)
    raise ConfigError(f"{where}: {value!r} is not one of {allowed}")


def boolean(value: Any, where: str) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(f"{where}: expected true or false, got {value!r}")
    return value


def latitude(value: Any, where: str) -> float:
    return number(value, where, minimum=-90.0, maximum=90.0)


def longitude(value: Any, where: str) -> float:
    return number(value, where, minimum=-180.0, maximum=180.0)


def field_default(cls: type, name: str) -> Any:
    """The default of dataclass ``cls``'s field ``name`` (its factory called), so a parser writes no default twice."""
    f = cls.__dataclass_fields__[name]  # type: ignore[attr-defined]
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    raise KeyError(f"{cls.__name__}.{name} has no default")
