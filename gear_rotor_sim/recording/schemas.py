"""ROS 2 message definitions for MCAP schemas: ``ros2msg`` texts and RIHS01 type hashes.

The recorder writes one MCAP schema per message type, encoded ``ros2msg`` as rosbag2 does: the
type's ``.msg`` text, then for every nested type (depth first, dependencies in sorted order, each
once) a newline, a line of 80 ``=``, a line ``MSG: pkg/Type`` and that type's text.

``gear_rotor_msgs`` texts are read at runtime from the source tree (``msg_defs/msg``) or from an
installed ``share/gear_rotor_msgs/msg`` found on ``AMENT_PREFIX_PATH``. The standard Jazzy
definitions the project nests (``std_msgs``, ``builtin_interfaces``, ``diagnostic_msgs``) are
embedded below, with their comments stripped, so that recording needs no ROS installation.

The type hash (``RIHS01_<sha256>``) is computed as ``rosidl_generator_type_description`` does:
the type description (the type and every referenced type, sorted by name; per field its name,
type id, capacity, string capacity and nested type name, default values removed) dumped as
compact JSON with ``", "`` and ``": "`` separators, then SHA-256.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from functools import cache
from pathlib import Path

VIBRATION_CHUNK = "gear_rotor_msgs/msg/VibrationChunk"
CONDITION_INDICATORS = "gear_rotor_msgs/msg/ConditionIndicators"
FAULT_STATE = "gear_rotor_msgs/msg/FaultState"
DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"

SEPARATOR = "=" * 80

# Standard ROS 2 Jazzy interface definitions (public), comments stripped.
_EMBEDDED: dict[str, str] = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "std_msgs/msg/MultiArrayDimension": "string label\nuint32 size\nuint32 stride\n",
    "std_msgs/msg/MultiArrayLayout": "MultiArrayDimension[] dim\nuint32 data_offset\n",
    "diagnostic_msgs/msg/DiagnosticArray": "std_msgs/Header header\nDiagnosticStatus[] status\n",
    "diagnostic_msgs/msg/DiagnosticStatus": (
        "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\n"
        "byte level\nstring name\nstring message\nstring hardware_id\nKeyValue[] values\n"
    ),
    "diagnostic_msgs/msg/KeyValue": "string key\nstring value\n",
}

_OWN_PACKAGE = "gear_rotor_msgs"

PRIMITIVE_TYPES = frozenset(
    {
        "bool",
        "byte",
        "char",
        "float32",
        "float64",
        "int8",
        "uint8",
        "int16",
        "uint16",
        "int32",
        "uint32",
        "int64",
        "uint64",
        "string",
        "wstring",
    }
)

# rosidl type_description_interfaces/FieldType ids of the value types.
_TYPE_IDS = {
    "int8": 2,
    "uint8": 3,
    "char": 3,
    "int16": 4,
    "uint16": 5,
    "int32": 6,
    "uint32": 7,
    "int64": 8,
    "uint64": 9,
    "float32": 10,
    "float64": 11,
    "bool": 15,
    "byte": 16,
    "string": 17,
    "wstring": 18,
}
_NESTED_TYPE_ID = 1
_BOUNDED_STRING_ID = 21
_BOUNDED_WSTRING_ID = 22
_ARRAY_OFFSET, _BOUNDED_SEQUENCE_OFFSET, _UNBOUNDED_SEQUENCE_OFFSET = 48, 96, 144

_FIELD_RE = re.compile(
    r"^(?P<type>[A-Za-z][A-Za-z0-9_/]*)(?P<strbound><=\d+)?(?P<array>\[(?P<bound><=)?(?P<size>\d*)\])?"
    r"\s+(?P<name>[A-Za-z][A-Za-z0-9_]*)\s*(?P<rest>.*)$"
)


class SchemaError(ValueError):
    """A message definition could not be found or parsed."""


def _msg_dirs() -> list[Path]:
    """Folders that may hold ``gear_rotor_msgs`` ``.msg`` files, most specific first."""
    dirs = [Path(__file__).resolve().parents[2] / "msg_defs" / "msg"]
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if prefix:
            dirs.append(Path(prefix) / "share" / _OWN_PACKAGE / "msg")
    return dirs


def _normalise(type_name: str, package_context: str = "") -> str:
    """``pkg/Type``, ``pkg/msg/Type`` or ``Type`` (within ``package_context``) -> ``pkg/msg/Type``."""
    parts = type_name.split("/")
    if len(parts) == 1:
        if not package_context:
            raise SchemaError(f"type {type_name!r}: a package name is required")
        return f"{package_context}/msg/{parts[0]}"
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    if len(parts) == 3 and parts[1] == "msg":
        return type_name
    raise SchemaError(f"type {type_name!r}: expected 'pkg/Type' or 'pkg/msg/Type'")


@cache
def message_text(type_name: str) -> str:
    """The ``.msg`` text of one type (``pkg/msg/Type``), without nested definitions.

    Raises
    ------
    SchemaError
        When the definition is neither embedded nor found in the searched folders.
    """
    full = _normalise(type_name)
    if full in _EMBEDDED:
        return _EMBEDDED[full]
    package, _, short = full.split("/")
    if package == _OWN_PACKAGE:
        searched = []
        for folder in _msg_dirs():
            path = folder / f"{short}.msg"
            searched.append(str(path))
            if path.is_file():
                return path.read_text(encoding="utf-8")
        raise SchemaError(f"definition of {full} not found; searched: {searched}")
    raise SchemaError(f"definition of {full} is not available (supported: {sorted(supported_types())})")


def supported_types() -> set[str]:
    """Type names this module can describe without a ROS installation."""
    return set(_EMBEDDED) | {VIBRATION_CHUNK, CONDITION_INDICATORS}


def parse_fields(text: str, package_context: str) -> list[tuple[str, str, str]]:
    """Fields of a ``.msg`` text as ``(field name, raw type token, normalised base type)``.

    Constants (``TYPE NAME=value``) and comments are skipped. The base type of a nested field is
    its full ``pkg/msg/Type`` name; of a primitive field the primitive name.
    """
    fields: list[tuple[str, str, str]] = []
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        m = _FIELD_RE.match(line)
        if m is None:
            raise SchemaError(f"cannot parse line {raw!r} of a {package_context} message")
        if m.group("rest").startswith("="):
            continue
        base = m.group("type")
        if base not in PRIMITIVE_TYPES:
            base = _normalise(base, package_context)
        token = line.split()[0]
        fields.append((m.group("name"), token, base))
    return fields


def _dependencies(type_name: str) -> list[str]:
    """Nested types of one type as rosbag2 orders them (sorted by the name written in the .msg)."""
    package = type_name.split("/")[0]
    written: dict[str, str] = {}
    for _name, token, base in parse_fields(message_text(type_name), package):
        if base not in PRIMITIVE_TYPES:
            key = token.split("[")[0]
            written[key if "/" in key else f"{package}/{key}"] = base
    return [written[k] for k in sorted(written)]


def _short(full: str) -> str:
    package, _, name = full.split("/")
    return f"{package}/{name}"


@cache
def full_definition(type_name: str) -> str:
    """The concatenated ``ros2msg`` schema text of ``type_name`` (rosbag2 convention)."""
    root = _normalise(type_name)
    seen: set[str] = set()

    def append(name: str) -> str:
        out = message_text(name)
        for dep in _dependencies(name):
            if dep not in seen:
                seen.add(dep)
                out += f"\n{SEPARATOR}\nMSG: {_short(dep)}\n" + append(dep)
        return out

    return append(root)


def _field_type(token: str, base: str) -> dict:
    """The ``FieldType`` of one field as a dict (type_id, capacity, string_capacity, nested name)."""
    m = _FIELD_RE.match(f"{token} x")
    if m is None:
        raise SchemaError(f"cannot parse field type {token!r}")
    string_capacity = 0
    nested = ""
    if base in PRIMITIVE_TYPES:
        type_id = _TYPE_IDS[base]
        if m.group("strbound"):
            string_capacity = int(m.group("strbound")[2:])
            type_id = _BOUNDED_STRING_ID if base == "string" else _BOUNDED_WSTRING_ID
    else:
        type_id = _NESTED_TYPE_ID
        nested = base
    capacity = 0
    if m.group("array"):
        size = m.group("size")
        if m.group("bound"):
            type_id += _BOUNDED_SEQUENCE_OFFSET
            capacity = int(size)
        elif size:
            type_id += _ARRAY_OFFSET
            capacity = int(size)
        else:
            type_id += _UNBOUNDED_SEQUENCE_OFFSET
    return {
        "type_id": type_id,
        "capacity": capacity,
        "string_capacity": string_capacity,
        "nested_type_name": nested,
    }


def _individual_description(type_name: str) -> dict:
    package = type_name.split("/")[0]
    fields = [
        {"name": name, "type": _field_type(token, base)}
        for name, token, base in parse_fields(message_text(type_name), package)
    ]
    if not fields:
        raise SchemaError(f"{type_name}: messages without fields are not supported")
    return {"type_name": type_name, "fields": fields}


def type_description(type_name: str) -> dict:
    """The hashable type description (no default values) of ``type_name`` and its references."""
    root = _normalise(type_name)
    refs: set[str] = set()
    queue = list(_dependencies(root))
    while queue:
        name = queue.pop()
        if name not in refs:
            refs.add(name)
            queue.extend(_dependencies(name))
    return {
        "type_description": _individual_description(root),
        "referenced_type_descriptions": [_individual_description(n) for n in sorted(refs)],
    }


@cache
def type_hash(type_name: str) -> str:
    """The RIHS01 type hash of ``type_name``, as in ``ros2 topic info -v`` and rosbag2 metadata."""
    text = json.dumps(
        type_description(type_name),
        skipkeys=False,
        ensure_ascii=True,
        check_circular=True,
        allow_nan=False,
        indent=None,
        separators=(", ", ": "),
        sort_keys=False,
    )
    return "RIHS01_" + hashlib.sha256(text.encode("utf-8")).hexdigest()
