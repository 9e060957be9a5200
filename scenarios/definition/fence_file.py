"""The ``fence: {file: ...}`` block of a scenario: the fence file found, read by its format's adapter, and
the block's inline keys applied over it.

A relative path is resolved against ``base_dir`` (the scenario file's folder, see
:func:`scenarios.definition.schema.parse_scenario`); against the working directory only when no ``base_dir`` is
known. Inline ``ceiling_m``, ``floor_m`` and ``altitude_reference`` win over the file's values (GeoJSON
properties); ``floor_gaps`` are added (no format carries them); an inline ``recovery_point`` replaces the
file's return point as the recovery point; ``inclusion_polygon`` picks one of several inclusion areas. A
ceiling is required: inline, or in the file (a scenario never flies under the importer's silent
default). The importer's warnings (dropped keep-outs, ignored zones, ...) are kept in
:attr:`geofence.unit.config.GeofenceConfig.fence_warnings`.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from analysis.formats.fence_files import ImportOptions, load_fence_file
from geofence.geometry.fence import AltitudeReference, Fence, FenceError
from geofence.unit.config import GeofenceConfigError
from geofence.validation import enum_value, integer, number

FENCE_FILE_KEYS = (
    "file",
    "ceiling_m",
    "floor_m",
    "floor_gaps",
    "recovery_point",
    "altitude_reference",
    "inclusion_polygon",
)
"""The keys of a ``fence:`` block that references a fence file."""


def fence_file_path(file: Any, where: str, base_dir: str | Path | None) -> Path:
    """The path a ``fence.file`` value names: relative ones against ``base_dir`` (the scenario's folder)."""
    if not isinstance(file, str) or not file.strip():
        raise GeofenceConfigError(f"{where}.file: must be a path to a fence file, got {file!r}")
    path = Path(file).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    return path


def fence_from_file(block: Mapping, where: str, base_dir: str | Path | None = None) -> tuple[Fence, str, list[str]]:
    """A ``fence: {file: ..., <overrides>}`` block: the file read by the importer, the inline keys applied."""
    unknown = [k for k in block if k not in FENCE_FILE_KEYS]
    if unknown:
        extra = " (keep_in comes from the file)" if "keep_in" in unknown else ""
        raise GeofenceConfigError(
            f"{where}: unknown key(s) {', '.join(repr(k) for k in unknown)} with a fence file "
            f"(allowed: {', '.join(FENCE_FILE_KEYS)}){extra}"
        )
    path = fence_file_path(block["file"], where, base_dir)
    if not path.is_file():
        place = f" (relative to {base_dir})" if base_dir is not None and not Path(block["file"]).is_absolute() else ""
        if path.exists():
            raise GeofenceConfigError(f"{where}.file: {block['file']!r} is not a file{place}")
        raise GeofenceConfigError(f"{where}.file: no such file {block['file']!r}{place}")
    for key in ("ceiling_m", "floor_m"):
        if block.get(key) is not None:
            number(block[key], f"{where}.{key}")
    ref = block.get("altitude_reference")
    if ref is not None:
        ref = enum_value(ref.lower() if isinstance(ref, str) else ref, f"{where}.altitude_reference", AltitudeReference)
    choice = block.get("inclusion_polygon")
    if choice is not None:
        choice = integer(choice, f"{where}.inclusion_polygon", minimum=0)
    gaps = block.get("floor_gaps")
    if gaps is not None and (isinstance(gaps, (str, Mapping)) or not isinstance(gaps, (list, tuple))):
        raise GeofenceConfigError(f"{where}.floor_gaps: must be a list of polygons, got {type(gaps).__name__}")
    try:
        imported = load_fence_file(
            path,
            ImportOptions(
                ceiling_m=block.get("ceiling_m"),
                floor_m=block.get("floor_m"),
                altitude_reference=ref,
                floor_gaps=tuple(gaps or ()),
                recovery_point=block.get("recovery_point"),
                inclusion_polygon=choice,
            ),
        )
    except FenceError as exc:
        msg = str(exc)
        rest = msg[len(str(path)) + 2 :] if msg.startswith(f"{path}: ") else msg
        field = re.match(r"[a-z_]*", rest).group(0)  # type: ignore[union-attr]  # [a-z_]* matches every string
        if rest.startswith(("inclusion polygon", "inclusion_polygon")) and "inclusion_polygon" in block:
            raise GeofenceConfigError(f"{where}.inclusion_polygon: {msg}") from None
        if field in block and field != "file":  # the inline value is the problem (e.g. a floor gap outside the keep-in)
            raise GeofenceConfigError(f"{where}.{rest}") from None
        raise GeofenceConfigError(f"{where}.file: {msg}") from None
    if imported.ceiling_source == "default":
        raise GeofenceConfigError(f"{where}.ceiling_m: required: the fence file {block['file']!r} gives no ceiling")
    return imported.fence, str(path), list(imported.warnings)
