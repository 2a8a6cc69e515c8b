"""Messages and schemas of the live (Foxglove WebSocket) channels.

The channels mirror the ROS node's topics. Sample streams and the indicators are ROS 2 CDR
(encoding ``cdr``, schemas ``ros2msg`` with their dependencies, as rosbag2 and foxglove_bridge
advertise them), which the Foxglove app decodes natively and which costs a copy of the sample
arrays (JSON text of 20 channels x 2000 samples took 0.17 s per 0.1 s chunk on the 2-core machine,
more than real time allows):

- ``/gear_rotor/<stream>``: the fields of ``gear_rotor_msgs/msg/VibrationChunk`` with the samples
  as one ``float64[]`` field per channel (schema ``gear_rotor_sim/msg/<Stream>Chunk``), so a
  Foxglove Plot panel addresses a channel by name: ``/gear_rotor/dte.dte``;
- ``/gear_rotor/indicators``: ``gear_rotor_msgs/msg/ConditionIndicators`` exactly as the monitor
  node publishes it (:func:`gear_rotor_sim.indicators.compute_indicators`, no alarm thresholds);
- ``/gear_rotor/dte_spectrum``: ``gear_rotor_sim/msg/AmplitudeSpectrum``, the Hann-windowed
  amplitude spectrum the indicators' order lines are read from.

Small messages are JSON (encoding ``json``, schema ``jsonschema``): ``/gear_rotor/status``
(operating point, targets, pace, setpoint counts) and the setpoints a client publishes on
``/gear_rotor/setpoint/speed_rpm`` and ``/gear_rotor/setpoint/temperature_c`` as
``{"data": <float>}`` (the JSON form of ``std_msgs/msg/Float64``).

SI units in every array; ``speed_rpm`` and ``temperature_c`` only in fields named so.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import numpy as np

from gear_rotor_sim.blocks import SampleBlock
from gear_rotor_sim.indicators import Indicators
from gear_rotor_sim.recording.cdr import CdrWriter, serialize_condition_indicators
from gear_rotor_sim.recording.schemas import CONDITION_INDICATORS, SEPARATOR, full_definition
from gear_rotor_sim.setpoints import SETPOINT_KINDS
from gear_rotor_sim.streams import TOPIC_PREFIX, StreamSpec, time_to_stamp

INDICATORS_TOPIC = f"{TOPIC_PREFIX}/indicators"
SPECTRUM_TOPIC = f"{TOPIC_PREFIX}/dte_spectrum"
STATUS_TOPIC = f"{TOPIC_PREFIX}/status"
SETPOINT_TOPICS: dict[str, str] = {kind: f"{TOPIC_PREFIX}/setpoint/{kind}" for kind in SETPOINT_KINDS}

_HEADER_DEPENDENCIES = (
    f"{SEPARATOR}\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
    f"{SEPARATOR}\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
)


@dataclass(frozen=True)
class CdrSchema:
    """A ``ros2msg`` schema as the Foxglove SDK advertises it (name, text)."""

    name: str
    text: str


def chunk_schema(spec: StreamSpec) -> CdrSchema:
    """Schema of one stream: ``VibrationChunk``'s fields, then one ``float64[]`` per channel."""
    fields = "".join(f"float64[] {name}\n" for name in spec.channels)
    text = (
        "# One chunk of a gear_rotor_sim stream; one float64[] of sample_count values per channel, SI.\n"
        "std_msgs/Header header\nuint64 sequence\nuint64 first_sample_index\nuint32 sample_count\n"
        "float64 sample_rate_hz\nfloat64 speed_rpm\nfloat64 temperature_c\n"
        "string[] channel_names\nstring[] units\n" + fields + _HEADER_DEPENDENCIES
    )
    camel = "".join(part.capitalize() for part in spec.name.split("_"))
    return CdrSchema(f"gear_rotor_sim/msg/{camel}Chunk", text)


def chunk_message(block: SampleBlock, spec: StreamSpec, sequence: int) -> bytes:
    """CDR bytes of one stream's message for ``block`` (which holds at least ``spec``'s channels)."""
    sub = block.select(spec.channels)
    sec, nsec = time_to_stamp(block.t0)
    w = CdrWriter()
    w.header(sec, nsec, spec.frame_id)
    w.uint64(sequence)
    w.uint64(block.first_index)
    w.uint32(sub.n_samples)
    w.float64(block.sample_rate_hz)
    w.float64(float(block.speed_rpm[0]) if block.speed_rpm.size else 0.0)
    w.float64(float(block.temperature_c[0]) if block.temperature_c.size else 0.0)
    w.string_sequence(sub.channels)
    w.string_sequence(sub.units)
    for i in range(len(sub.channels)):
        w.float64_sequence(np.ascontiguousarray(sub.data[:, i]))
    return w.getvalue()


INDICATORS_SCHEMA = CdrSchema(CONDITION_INDICATORS, full_definition(CONDITION_INDICATORS))


def indicators_message(
    ind: Indicators, t0: float, frame_id: str, source_topic: str, channel_names: list[str], speed_rpm: float
) -> bytes:
    """CDR bytes of the ``ConditionIndicators`` of one window, as the monitor node fills them."""
    sec, nsec = time_to_stamp(t0)
    n = len(channel_names)
    return serialize_condition_indicators(
        {
            "stamp_sec": sec,
            "stamp_nanosec": nsec,
            "frame_id": frame_id,
            "source_topic": source_topic,
            "window_s": float(ind.window_s),
            "speed_rpm": float(speed_rpm),
            "mesh_frequency_hz": float(ind.mesh_frequency_hz),
            "channel_names": list(channel_names),
            "rms": ind.rms,
            "peak": ind.peak,
            "crest_factor": ind.crest_factor,
            "kurtosis": ind.kurtosis,
            "mesh_order_amplitude": ind.mesh_order_amplitude,
            "sideband_amplitude": ind.sideband_amplitude,
            "alarm_threshold": np.full(n, np.inf),
            "alarm": [False] * n,
        }
    )


SPECTRUM_SCHEMA = CdrSchema(
    "gear_rotor_sim/msg/AmplitudeSpectrum",
    "# Hann-windowed, amplitude-corrected single-sided spectrum of one channel over a window.\n"
    "std_msgs/Header header\nstring source_topic\nstring channel\nstring unit\nfloat64 window_s\n"
    "float64 speed_rpm\nfloat64 mesh_frequency_hz\nfloat64[] frequency_hz\nfloat64[] amplitude\n"
    + _HEADER_DEPENDENCIES,
)


def spectrum_message(
    freqs: np.ndarray,
    amplitude: np.ndarray,
    t0: float,
    frame_id: str,
    source_topic: str,
    channel: str,
    unit: str,
    window_s: float,
    speed_rpm: float,
    mesh_frequency_hz: float,
) -> bytes:
    """CDR bytes of one amplitude spectrum (``freqs`` and ``amplitude`` of equal length)."""
    sec, nsec = time_to_stamp(t0)
    w = CdrWriter()
    w.header(sec, nsec, frame_id)
    w.string(source_topic)
    w.string(channel)
    w.string(unit)
    w.float64(window_s)
    w.float64(speed_rpm)
    w.float64(mesh_frequency_hz)
    w.float64_sequence(np.ascontiguousarray(freqs, dtype=float))
    w.float64_sequence(np.ascontiguousarray(amplitude, dtype=float))
    return w.getvalue()


_TIME = {
    "type": "object",
    "title": "time",
    "properties": {"sec": {"type": "integer", "minimum": 0}, "nsec": {"type": "integer", "minimum": 0}},
    "required": ["sec", "nsec"],
}

#: Schema of a setpoint message (the JSON form of ``std_msgs/msg/Float64``).
SETPOINT_SCHEMA: dict[str, Any] = {
    "type": "object",
    "title": "std_msgs/Float64",
    "properties": {"data": {"type": "number", "description": "target: rpm or C (see the topic name)"}},
    "required": ["data"],
}

STATUS_FIELDS: tuple[str, ...] = (
    "sim_time_s",
    "speed_rpm",
    "target_speed_rpm",
    "temperature_c",
    "target_temperature_c",
    "achieved_real_time_factor",
    "requested_real_time_factor",
)

STATUS_SCHEMA: dict[str, Any] = {
    "type": "object",
    "title": "gear_rotor_sim/LiveStatus",
    "properties": {
        "timestamp": _TIME,
        **{name: {"type": "number"} for name in STATUS_FIELDS},
        "setpoints_accepted": {"type": "integer", "minimum": 0},
        "setpoints_refused": {"type": "integer", "minimum": 0},
        "last_refusal": {"type": "string"},
        "wall_time_s": {"type": "number", "description": "server's Unix time when sent (latency)"},
    },
    "required": [
        "timestamp",
        *STATUS_FIELDS,
        "setpoints_accepted",
        "setpoints_refused",
        "last_refusal",
        "wall_time_s",
    ],
}


def status_message(
    fields: dict[str, float], t: float, accepted: int, refused: int, last: str, wall_time_s: float
) -> dict:
    """``/gear_rotor/status`` at simulated time ``t`` (``fields``: :data:`STATUS_FIELDS`), sent at
    Unix time ``wall_time_s``."""
    sec, nsec = time_to_stamp(max(0.0, float(t)))
    return {
        "timestamp": {"sec": sec, "nsec": nsec},
        **{name: float(fields[name]) for name in STATUS_FIELDS},
        "setpoints_accepted": int(accepted),
        "setpoints_refused": int(refused),
        "last_refusal": last,
        "wall_time_s": float(wall_time_s),
    }


class SetpointError(ValueError):
    """A setpoint message that cannot be read; the message names the topic and the expected form."""


def parse_setpoint(topic: str, payload: bytes) -> float:
    """The target carried by a setpoint message: ``{"data": <number>}``.

    Raises
    ------
    SetpointError
        When the payload is not UTF-8 JSON of that form (the message names the topic and the
        expected form). Range checks are :func:`gear_rotor_sim.setpoints.check_setpoint`'s.
    """
    form = 'expected JSON {"data": <number>}'
    try:
        obj = json.loads(payload.decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        shown = payload[:40].decode("utf-8", "replace")
        raise SetpointError(f"{topic}: not JSON ({shown!r}); {form}") from None
    if not isinstance(obj, dict) or "data" not in obj:
        raise SetpointError(f"{topic}: {str(obj)[:60]!r} has no field 'data'; {form}")
    unknown = sorted(set(obj) - {"data"})
    if unknown:
        raise SetpointError(f"{topic}: unknown field(s) {unknown}; {form}")
    value = obj["data"]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SetpointError(f"{topic}: data = {value!r} is not a number; {form}")
    return float(value)
