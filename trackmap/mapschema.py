"""The JSON Schema of the trackmap map file (format ``trackmap``, version 1).

:data:`SCHEMA` states every type, range and required member of a map file; :func:`validate`
checks a parsed document against it and raises :class:`~trackmap.errors.MapFileError` naming
the feature (its index and id) and the member that is wrong. What a schema cannot say —
references between features, lengths that fit the coordinates, a CRS that fits them — is
checked by :mod:`trackmap.mapfile` after this.

The schema is JSON Schema draft-07, compiled to Python once per process by
``fastjsonschema`` (0.1 s for the 1.5 MB Kraków map). Other tools can validate map files
with it too::

    python -c "import json, trackmap.mapschema as s; print(json.dumps(s.SCHEMA, indent=1))"

Numbers are finite by construction: :func:`trackmap.mapfile.read` refuses ``NaN``,
``Infinity`` and numbers beyond the range of a double before the schema is applied.

>>> validate({"type": "FeatureCollection"})
Traceback (most recent call last):
...
trackmap.errors.MapFileError: not a trackmap map file: the document must contain 'trackmap'
"""

from __future__ import annotations

import functools
import re
from collections.abc import Callable
from typing import Any, Final

from trackmap.errors import MapFileError
from trackmap.kinds import ConflictKind, NodeClass

__all__ = [
    "DIRECTION_SOURCES",
    "FEATURE_SCHEMAS",
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "INT64_MAX",
    "INT64_MIN",
    "MAX_ENDS_PER_NODE",
    "MAX_SPEED_MPS",
    "SCHEMA",
    "validate",
]

FORMAT_NAME: Final = "trackmap"
FORMAT_VERSION: Final = 1
#: OSM ids (and the coordinate ids of GeoJSON sources) are signed 64-bit integers.
INT64_MIN: Final = -(2**63)
INT64_MAX: Final = 2**63 - 1
#: Edge ends that may meet at one node (the builder classifies at most 4; ``unknown`` more).
MAX_ENDS_PER_NODE: Final = 64
#: Speed limits above this are not track speeds, m/s (540 km/h).
MAX_SPEED_MPS: Final = 150.0
#: Where an edge's running direction came from.
DIRECTION_SOURCES: Final = (
    "preferred_direction", "oneway", "tracks", "driving_side", "propagated", "none",
)  # fmt: skip

_INT64: Final = {"type": "integer", "minimum": INT64_MIN, "maximum": INT64_MAX}
_COUNT: Final = {"type": "integer", "minimum": 0, "maximum": INT64_MAX}
_NUMBER: Final = {"type": "number"}
_TEXT: Final = {"type": "string", "maxLength": 10_000}
_OPT_TEXT: Final = {"type": ["string", "null"], "maxLength": 10_000}
_LON: Final = {"type": "number", "minimum": -180.0, "maximum": 180.0}
_LAT: Final = {"type": "number", "minimum": -90.0, "maximum": 90.0}
_POSITION: Final = {"type": "array", "minItems": 2, "maxItems": 2, "items": [_LON, _LAT]}
_POINT: Final = {
    "type": "object",
    "required": ["type", "coordinates"],
    "properties": {"type": {"const": "Point"}, "coordinates": _POSITION},
}
_LINE: Final = {
    "type": "object",
    "required": ["type", "coordinates"],
    "properties": {
        "type": {"const": "LineString"},
        "coordinates": {"type": "array", "minItems": 2, "items": _POSITION},
    },
}
_PAIR: Final = {"type": "array", "minItems": 2, "maxItems": 2, "items": _COUNT}


def _feature(geometry: dict[str, Any], props: dict[str, Any]) -> dict[str, Any]:
    """The schema of one feature type (members marked ``optional`` are not required)."""
    required = [k for k, v in props.items() if not v.pop("optional", False)]
    return {
        "type": "object",
        "properties": {
            "geometry": geometry,
            "properties": {"type": "object", "required": required, "properties": props},
        },
    }


_EDGE: Final = _feature(
    _LINE,
    {
        "edge_id": {"type": "integer", "minimum": 0, "maximum": 2**31 - 1},
        "start_node": dict(_INT64),
        "end_node": dict(_INT64),
        "node_ids": {"type": "array", "minItems": 2, "items": _INT64},
        "way_ids": {"type": "array", "items": _INT64},
        "kind": {"type": "string", "minLength": 1, "maxLength": 100},
        "service": {"type": ["string", "null"], "maxLength": 100, "optional": True},
        "layer": {"type": "integer", "minimum": -100, "maximum": 100},
        "bridge": {"type": "boolean"},
        "tunnel": {"type": "boolean"},
        "maxspeed_mps": {
            "type": ["number", "null"],
            "exclusiveMinimum": 0,
            "maximum": MAX_SPEED_MPS,
            "optional": True,
        },
        "direction": {"type": "integer", "enum": [-1, 0, 1]},
        "direction_source": {"type": "string", "enum": list(DIRECTION_SOURCES)},
        "name": dict(_OPT_TEXT, optional=True),
        "length_m": {"type": "number", "minimum": 0},
    },
)
_NODE: Final = _feature(
    _POINT,
    {
        "node_id": dict(_INT64),
        "class": {"type": "string", "enum": [c.value for c in NodeClass]},
        "ends": {
            "type": "array",
            "minItems": 1,
            "maxItems": MAX_ENDS_PER_NODE,
            "items": {
                "type": "array",
                "minItems": 2,
                "maxItems": 2,
                "items": [_COUNT, {"type": "integer", "enum": [0, 1]}],
            },
        },
        "allowed": {"type": "array", "maxItems": MAX_ENDS_PER_NODE**2, "items": _PAIR},
    },
)
_CONFLICT: Final = _feature(
    _POINT,
    {
        "conflict_id": {"type": "integer", "minimum": 0, "maximum": 2**31 - 1},
        "kind": {"type": "string", "enum": [k.value for k in ConflictKind]},
        "x": dict(_NUMBER),
        "y": dict(_NUMBER),
        "node_id": {"type": ["integer", "null"], "minimum": INT64_MIN, "maximum": INT64_MAX},
        "edges": {"type": "array", "minItems": 2, "maxItems": 4, "items": _COUNT},
        "offsets_m": {"type": "array", "items": {"type": "number", "minimum": 0}},
        "extents_m": {"type": "array", "items": {"type": "number", "minimum": 0}},
        "angle_deg": {
            "type": ["number", "null"],
            "minimum": 0,
            "maximum": 180,
            "optional": True,
        },
    },
)
_STOP: Final = _feature(
    _POINT,
    {
        "stop_id": dict(_INT64),
        "name": dict(_OPT_TEXT, optional=True),
        "edge_id": {"type": ["integer", "null"], "minimum": 0, "optional": True},
        "offset_m": {"type": ["number", "null"], "minimum": 0, "optional": True},
    },
)
_GRADE_SEPARATED: Final = _feature(
    _POINT,
    {"edges": _PAIR, "x": dict(_NUMBER), "y": dict(_NUMBER)},
)
#: The schema of each feature type, by the value of ``properties.feature``.
FEATURE_SCHEMAS: Final[dict[str, dict[str, Any]]] = {
    "edge": _EDGE,
    "node": _NODE,
    "conflict": _CONFLICT,
    "stop": _STOP,
    "grade_separated": _GRADE_SEPARATED,
}

_SOURCE: Final = {
    "type": "object",
    "properties": {
        "file": _TEXT,
        "format": _TEXT,
        "ways": _COUNT,
        "dropped": {"type": "object", "additionalProperties": _COUNT},
        "duplicate_ways": {"type": "array", "items": {"type": "array", "items": _INT64}},
        "multi_track_ways": {
            "type": "array",
            "items": {"type": "array", "minItems": 2, "maxItems": 2, "items": [_INT64, _COUNT]},
        },
        "direction_tag_doubts": {
            "type": "array",
            "items": {"type": "array", "minItems": 2, "maxItems": 2, "items": [_INT64, _TEXT]},
        },
        "overlapping_edges": {
            "type": "array",
            "items": {
                "type": "array",
                "minItems": 4,
                "maxItems": 4,
                "items": [_COUNT, _COUNT, _NUMBER, _NUMBER],
            },
        },
        "bounds": {
            "type": "array",
            "minItems": 4,
            "maxItems": 4,
            "items": [_LON, _LAT, _LON, _LAT],
        },
        "clipped": {"type": "object", "additionalProperties": _COUNT},
        "boundary_nodes": {
            "type": "array",
            "items": {"type": "array", "minItems": 2, "maxItems": 2, "items": [_INT64, _INT64]},
        },
        "driving_side_evidence": {
            "type": "object",
            "properties": {
                "right_m": {"type": "number", "minimum": 0},
                "left_m": {"type": "number", "minimum": 0},
            },
        },
    },
}
_BUILD: Final = {
    "type": "object",
    "properties": {
        "kinds": {"type": "array", "items": _TEXT},
        "max_deflection_deg": {"type": "number", "exclusiveMinimum": 0, "exclusiveMaximum": 90},
        "tangent_probe_m": {"type": "number", "exclusiveMinimum": 0, "maximum": 1000},
        "parallel_spacing_m": {
            "type": "array",
            "minItems": 2,
            "maxItems": 2,
            "items": {"type": "number", "minimum": 0, "maximum": 1000},
        },
        "fouling_clearance_m": {"type": "number", "minimum": 0, "maximum": 1000},
        "stop_snap_m": {"type": "number", "minimum": 0, "maximum": 100_000},
        "driving_side": {"type": "string", "enum": ["auto", "right", "left"]},
    },
}

_ANY_FEATURE: Final = {
    "type": "object",
    "required": ["type", "geometry", "properties"],
    "properties": {
        "type": {"const": "Feature"},
        "geometry": {"type": "object"},
        "properties": {
            "type": "object",
            "required": ["feature"],
            "properties": {"feature": {"type": "string", "enum": list(FEATURE_SCHEMAS)}},
        },
    },
}
_DOCUMENT: Final[dict[str, Any]] = {
    "$schema": "http://json-schema.org/draft-07/schema#",
    "title": "trackmap map file, version 1",
    "type": "object",
    "required": ["type", "trackmap", "features"],
    "properties": {
        "type": {"const": "FeatureCollection"},
        "trackmap": {
            "type": "object",
            "required": ["format", "version", "crs_wkt"],
            "properties": {
                "format": {"const": FORMAT_NAME},
                "version": {"type": "integer", "const": FORMAT_VERSION},
                "crs_wkt": {"type": "string", "minLength": 1, "maxLength": 100_000},
                "driving_side": {"type": "string", "enum": ["right", "left"]},
                "source": _SOURCE,
                "build": _BUILD,
                "attribution": _TEXT,
                "created": _TEXT,
                "stats": {"type": "object"},
            },
        },
        "features": {"type": "array", "items": _ANY_FEATURE},
    },
}

#: The map file's JSON Schema (draft-07): the document, and each feature by its type.
SCHEMA: Final[dict[str, Any]] = {
    **_DOCUMENT,
    "properties": {
        **_DOCUMENT["properties"],
        "features": {
            "type": "array",
            "items": {
                **_ANY_FEATURE,
                "allOf": [
                    {
                        "if": {
                            "properties": {
                                "properties": {"properties": {"feature": {"const": kind}}}
                            }
                        },
                        "then": schema,
                    }
                    for kind, schema in FEATURE_SCHEMAS.items()
                ],
            },
        },
    },
}

_ID_KEYS: Final = {
    "edge": "edge_id",
    "node": "node_id",
    "conflict": "conflict_id",
    "stop": "stop_id",
}
_INDEX: Final = re.compile(r"^\d+$")


@functools.cache
def _compiled(kind: str | None) -> Callable[[Any], Any]:
    """The compiled schema of the document (None) or of one feature type."""
    import fastjsonschema

    schema = _DOCUMENT if kind is None else FEATURE_SCHEMAS[kind]
    validator: Callable[[Any], Any] = fastjsonschema.compile(schema)
    return validator


def validate(doc: Any) -> None:
    """Check a parsed map file against :data:`SCHEMA`.

    Parameters
    ----------
    doc : object
        The parsed JSON document.

    Raises
    ------
    trackmap.errors.MapFileError
        The first member that does not fit the schema, named by its place in the file
        (``feature 12 (edge 5): properties.node_ids[0] must be integer``). A file of another
        format version gets a message that says so.
    """
    from fastjsonschema import JsonSchemaValueException

    if not isinstance(doc, dict) or doc.get("type") != "FeatureCollection":
        raise MapFileError("not a GeoJSON FeatureCollection")
    header = doc.get("trackmap")
    if not isinstance(header, dict) or header.get("format") != FORMAT_NAME:
        raise MapFileError(
            "not a trackmap map file: the document must contain 'trackmap'"
            if header is None
            else "not a trackmap map file (no 'trackmap' header with format 'trackmap')"
        )
    version = header.get("version")
    if type(version) is not int or version != FORMAT_VERSION:
        raise MapFileError(
            f"map file format version {_short(version)} is not supported "
            f"(this trackmap reads version {FORMAT_VERSION}); rebuild the map with 'trackmap build'"
        )
    # the document first, then each feature against its type's schema: the same checks
    # as SCHEMA's if/then, at a third of the cost
    try:
        _compiled(None)(doc)
    except JsonSchemaValueException as exc:
        raise MapFileError(_message(doc, [str(p) for p in exc.path or []][1:], exc)) from None
    for i, feat in enumerate(doc["features"]):
        try:
            _compiled(feat["properties"]["feature"])(feat)
        except JsonSchemaValueException as exc:
            path = ["features", str(i), *[str(p) for p in exc.path or []][1:]]
            raise MapFileError(_message(doc, path, exc)) from None


def _message(doc: dict[str, Any], path: list[str], exc: Any) -> str:
    """Where in the file the schema failed (``path`` from the document's root), and how."""
    text = str(exc.message)
    # fastjsonschema names the place as ``data.features[3].properties...``; say it plainly
    if text.startswith("data"):
        text = text.split(" ", 1)[1] if " " in text else ""
    if exc.rule == "required" and isinstance(exc.value, dict):
        required = (exc.definition or {}).get("required", [])
        missing = [k for k in required if k not in exc.value]
        text = "missing " + ", ".join(repr(k) for k in missing)
    text = _short_text(text)
    if len(path) >= 2 and path[0] == "features" and _INDEX.match(path[1]):
        index = int(path[1])
        where = f"feature {index}{_feature_label(doc, index)}"
        member = _dotted(path[2:])
    elif path and path[0] == "trackmap":
        where = "header"
        member = _dotted(path[1:])
    else:
        where = "document"
        member = _dotted(path)
    return f"{where}: {member + ' ' if member else ''}{text}"


def _feature_label(doc: dict[str, Any], index: int) -> str:
    try:
        props = doc["features"][index]["properties"]
        kind = props["feature"]
        key = _ID_KEYS.get(kind)
        if key is None:
            return f" ({kind})" if isinstance(kind, str) and len(kind) < 30 else ""
        return f" ({kind} {_short(props.get(key))})"
    except (KeyError, IndexError, TypeError):
        return ""


def _dotted(parts: list[str]) -> str:
    out = ""
    for p in parts:
        out += f"[{p}]" if _INDEX.match(p) else (f".{p}" if out else p)
    return out


def _short(value: object, limit: int = 40) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _short_text(text: str, limit: int = 200) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."
