"""Fast ROS 2 CDR serialisation (XCDR1, little endian) of the messages the recorder writes.

The byte layout equals ``rclpy.serialization.serialize_message`` (Fast CDR) of the same message:
a 4-byte encapsulation header ``00 01 00 00``, then the fields in definition order, each primitive
aligned to its own size counted from the end of the header, strings as ``uint32`` length including
the terminating NUL followed by the bytes and the NUL, sequences as a ``uint32`` count followed by
the elements (an empty ``float64`` sequence adds no alignment padding after its count, as in
Fast CDR). Padding bytes are written as zeros. Fast CDR leaves padding uninitialised, and rclpy's
buffer can carry a few unused trailing bytes when a ``float64`` sequence is empty (its size
estimate reserves alignment that is never written), so rclpy's bytes equal ours except in padding
and except for such a trailing tail.

The ``float64[] data`` payload is copied straight from the NumPy array, so a message of 20,000
samples costs a few tens of microseconds.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Mapping, Sequence
from functools import lru_cache

import numpy as np

ENCAPSULATION_HEADER = b"\x00\x01\x00\x00"

_U32 = struct.Struct("<I")
_I32 = struct.Struct("<i")
_U64 = struct.Struct("<Q")
_F64 = struct.Struct("<d")
_ZEROS = bytes(8)
_LE_F64 = np.dtype("<f8")


class CdrWriter:
    """Appends CDR-encoded values to a growing buffer (offsets count from after the header)."""

    __slots__ = ("_buf",)

    def __init__(self) -> None:
        self._buf = bytearray(ENCAPSULATION_HEADER)

    def _align(self, size: int) -> None:
        pad = -(len(self._buf) - 4) % size
        if pad:
            self._buf += _ZEROS[:pad]

    def uint8(self, value: int) -> None:
        self._buf.append(int(value) & 0xFF)

    def bool(self, value: bool) -> None:
        self._buf.append(1 if value else 0)

    def int32(self, value: int) -> None:
        self._align(4)
        self._buf += _I32.pack(int(value))

    def uint32(self, value: int) -> None:
        self._align(4)
        self._buf += _U32.pack(int(value))

    def uint64(self, value: int) -> None:
        self._align(8)
        self._buf += _U64.pack(int(value))

    def float64(self, value: float) -> None:
        self._align(8)
        self._buf += _F64.pack(float(value))

    def string(self, value: str) -> None:
        raw = value.encode("utf-8")
        if b"\x00" in raw:
            raise ValueError(f"string {value!r}: NUL characters cannot be serialised")
        self.uint32(len(raw) + 1)
        self._buf += raw
        self._buf.append(0)

    def string_sequence(self, values: Sequence[str]) -> None:
        self.uint32(len(values))
        for v in values:
            self.string(v)

    def float64_sequence(self, values: np.ndarray | Sequence[float]) -> None:
        arr = np.ascontiguousarray(values, dtype=_LE_F64).reshape(-1)
        self.uint32(arr.size)
        if arr.size:
            self._align(8)
            self._buf += memoryview(arr).cast("B")

    def extend(self, raw: bytes) -> None:
        """Append bytes serialised by another writer from an offset of the same alignment."""
        self._buf += raw

    def bool_sequence(self, values: Sequence[bool] | np.ndarray) -> None:
        arr = np.asarray(values, dtype=bool).reshape(-1)
        self.uint32(arr.size)
        self._buf += arr.astype(np.uint8).tobytes()

    def header(self, stamp_sec: int, stamp_nanosec: int, frame_id: str) -> None:
        """A ``std_msgs/Header`` (``builtin_interfaces/Time stamp``, ``string frame_id``)."""
        self.int32(stamp_sec)
        self.uint32(stamp_nanosec)
        self.string(frame_id)

    def getvalue(self) -> bytes:
        return bytes(self._buf)


def serialize_vibration_chunk(fields: Mapping) -> bytes:
    """CDR bytes of a ``gear_rotor_msgs/msg/VibrationChunk``.

    Parameters
    ----------
    fields : mapping
        As returned by :func:`gear_rotor_sim.streams.chunk_fields` (``stamp_sec``,
        ``stamp_nanosec``, ``frame_id``, ``sequence``, ``first_sample_index``,
        ``sample_rate_hz``, ``speed_rpm``, ``temperature_c``, ``channel_names``, ``units``,
        ``layout_dim`` as ``(label, size, stride)`` triples, ``data``), optionally
        ``layout_data_offset`` (default 0).

    Returns
    -------
    bytes
        The serialised message including the encapsulation header.
    """
    w = CdrWriter()
    w.header(fields["stamp_sec"], fields["stamp_nanosec"], fields["frame_id"])
    w.uint64(fields["sequence"])
    w.uint64(fields["first_sample_index"])
    w.float64(fields["sample_rate_hz"])
    w.float64(fields["speed_rpm"])
    w.float64(fields["temperature_c"])
    # the last float64 leaves the offset on a multiple of 8: the names, units and layout that follow
    # serialise to the same bytes in every message of a stream (cached)
    w.extend(
        _chunk_description(
            tuple(fields["channel_names"]),
            tuple(fields["units"]),
            tuple((str(lab), int(size), int(stride)) for lab, size, stride in fields["layout_dim"]),
            int(fields.get("layout_data_offset", 0)),
        )
    )
    w.float64_sequence(fields["data"])
    return w.getvalue()


@lru_cache(maxsize=256)
def _chunk_description(
    names: tuple[str, ...], units: tuple[str, ...], dims: tuple[tuple[str, int, int], ...], data_offset: int
) -> bytes:
    """CDR bytes of ``channel_names``, ``units`` and ``layout`` of a ``VibrationChunk``, serialised
    from an offset that is a multiple of 8 (where :func:`serialize_vibration_chunk` writes them)."""
    w = CdrWriter()
    w.string_sequence(names)
    w.string_sequence(units)
    w.uint32(len(dims))
    for label, size, stride in dims:
        w.string(label)
        w.uint32(size)
        w.uint32(stride)
    w.uint32(data_offset)
    return w.getvalue()[len(ENCAPSULATION_HEADER) :]


_CONDITION_ARRAYS = (
    "rms",
    "peak",
    "crest_factor",
    "kurtosis",
    "mesh_order_amplitude",
    "sideband_amplitude",
    "alarm_threshold",
)


def serialize_condition_indicators(fields: Mapping) -> bytes:
    """CDR bytes of a ``gear_rotor_msgs/msg/ConditionIndicators``.

    Parameters
    ----------
    fields : mapping
        Keys ``stamp_sec``, ``stamp_nanosec``, ``frame_id``, ``source_topic``, ``window_s``,
        ``speed_rpm``, ``mesh_frequency_hz``, ``channel_names`` and the per-channel arrays
        ``rms``, ``peak``, ``crest_factor``, ``kurtosis``, ``mesh_order_amplitude``,
        ``sideband_amplitude``, ``alarm_threshold`` (float) and ``alarm`` (bool).
    """
    w = CdrWriter()
    w.header(fields["stamp_sec"], fields["stamp_nanosec"], fields["frame_id"])
    w.string(fields["source_topic"])
    w.float64(fields["window_s"])
    w.float64(fields["speed_rpm"])
    w.float64(fields["mesh_frequency_hz"])
    w.string_sequence(fields["channel_names"])
    for key in _CONDITION_ARRAYS:
        w.float64_sequence(fields[key])
    w.bool_sequence(fields["alarm"])
    return w.getvalue()


def serialize_diagnostic_array(fields: Mapping) -> bytes:
    """CDR bytes of a ``diagnostic_msgs/msg/DiagnosticArray``.

    Parameters
    ----------
    fields : mapping
        Keys ``stamp_sec``, ``stamp_nanosec``, ``frame_id`` and ``status``: a sequence of
        mappings with ``level`` (0 OK, 1 WARN, 2 ERROR, 3 STALE), ``name``, ``message``,
        ``hardware_id`` and ``values`` (a mapping or ``(key, value)`` pairs of strings).
    """
    w = CdrWriter()
    w.header(fields["stamp_sec"], fields["stamp_nanosec"], fields["frame_id"])
    statuses = fields["status"]
    w.uint32(len(statuses))
    for st in statuses:
        w.uint8(st["level"])
        w.string(st.get("name", ""))
        w.string(st.get("message", ""))
        w.string(st.get("hardware_id", ""))
        values = st.get("values", ())
        pairs: Iterable[tuple[str, str]] = values.items() if isinstance(values, Mapping) else values
        pairs = list(pairs)
        w.uint32(len(pairs))
        for key, value in pairs:
            w.string(str(key))
            w.string(str(value))
    return w.getvalue()


def serialize_fault_state(fields: Mapping) -> bytes:
    """CDR bytes of a ``gear_rotor_msgs/msg/FaultState``.

    Parameters
    ----------
    fields : mapping
        Keys ``stamp_sec``, ``stamp_nanosec``, ``frame_id`` and ``faults``: a sequence of mappings
        with the ``gear_rotor_msgs/msg/Fault`` fields (``type``, ``label``, ``wheel``, ``tooth``,
        ``mesh``, ``bearing``, ``node``, ``onset_s``, ``severity_name``, ``severity``,
        ``final_severity``, ``active``, ``spec_json``), as :func:`gear_rotor_sim.faults.truth.fault_fields`
        builds them.
    """
    w = CdrWriter()
    w.header(fields["stamp_sec"], fields["stamp_nanosec"], fields["frame_id"])
    faults = fields["faults"]
    w.uint32(len(faults))
    for f in faults:
        w.string(f["type"])
        w.string(f["label"])
        w.string(f["wheel"])
        for key in ("tooth", "mesh", "bearing", "node"):
            w.int32(f[key])
        w.float64(f["onset_s"])
        w.string(f["severity_name"])
        w.float64(f["severity"])
        w.float64(f["final_severity"])
        w.bool(f["active"])
        w.string(f["spec_json"])
    return w.getvalue()
