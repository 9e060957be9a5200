"""The one error type a user sees for bad input, and small validators that raise it.

Every message is a single line ``<file>: <field>: <problem>`` so that the CLI can
print it as is and exit with code 2, without a traceback.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any


class ConfigError(ValueError):
    """Bad user input: the message names the file, the field and the problem on one line."""


def require_mapping(value: Any, where: str) -> Mapping:
    if not isinstance(value, Mapping):
        raise ConfigError(f"{where}: expected a mapping (key: value), got {_kind(value)}")
    return value


def reject_unknown_keys(mapping: Mapping, allowed: set[str] | frozenset[str], where: str) -> None:
    unknown = sorted(str(k) for k in mapping if k not in allowed)
    if unknown:
        raise ConfigError(f"{where}: unknown key {unknown[0]!r} (allowed: {', '.join(sorted(allowed))})")


def number(
    value: Any,
    where: str,
    *,
    minimum: float | None = None,
    maximum: float | None = None,
    strictly_positive: bool = False,
) -> float:
    """A finite real number within [minimum, maximum] (and > 0 when ``strictly_positive``)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"{where}: expected a number, got {_kind(value)} {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise ConfigError(f"{where}: must be a finite number, got {value!r}")
    if strictly_positive and x <= 0.0:
        raise ConfigError(f"{where}: must be > 0, got {value!r}")
    if minimum is not None and x < minimum:
        raise ConfigError(f"{where}: must be >= {minimum:g}, got {value!r}")
    if maximum is not None and x > maximum:
        raise ConfigError(f"{where}: must be <= {maximum:g}, got {value!r}")
    return x


def integer(value: Any, where: str, *, minimum: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(f"{where}: expected an integer, got {_kind(value)} {value!r}")
    if minimum is not None and value < minimum:
        raise ConfigError(f"{where}: must be >= {minimum}, got {value}")
    return value


def string(value: Any, where: str, *, choices: list[str] | None = None) -> str:
    if not isinstance(value, str) or not value:
        raise ConfigError(f"{where}: expected a non-empty string, got {_kind(value)} {value!r}")
    if choices is not None and value not in choices:
        raise ConfigError(f"{where}: {value!r} is not one of {', '.join(choices)}")
    return value


def boolean(value: Any, where: str) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(f"{where}: expected true or false, got {value!r}")
    return value


def latitude(value: Any, where: str) -> float:
    return number(value, where, minimum=-90.0, maximum=90.0)


def longitude(value: Any, where: str) -> float:
    return number(value, where, minimum=-180.0, maximum=180.0)


def _kind(value: Any) -> str:
    if value is None:
        return "nothing"
    return {dict: "a mapping", list: "a list", str: "a string"}.get(type(value), type(value).__name__)
