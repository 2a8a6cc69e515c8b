"""Parameter declarations and validation of the simulator and monitoring nodes.

Every parameter is declared from one table (:data:`SIMULATOR_PARAMETERS`, :data:`MONITOR_PARAMETERS`)
with a :class:`rcl_interfaces.msg.ParameterDescriptor`: type (static typing), description, range
and whether it may change at runtime (parameters that shape the model, the streams or the
recording are read-only: changing them needs a restart). rclpy enforces types and ranges when a
parameter is declared or set; the checks here add what a descriptor cannot express (choices,
array elements, cross-field constraints) and are used both at start-up and in the nodes'
on-set-parameters callbacks.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.node import Node
from rclpy.parameter import Parameter

from gear_rotor_sim.setpoints import check_setpoint  # shared with gear-rotor-sim serve

STREAM_NAMES: tuple[str, ...] = (
    "dte",
    "bearing_forces",
    "displacements",
    "accelerations",
    "housing_accelerations",
)
DOF_CHOICES: tuple[str, ...] = ("x", "y", "z", "theta_x", "theta_y", "theta_z")
BEARING_TYPE_CHOICES: tuple[str, ...] = ("", "A#", "B#", "C#")
RELIABILITY_CHOICES: tuple[str, ...] = ("best_effort", "reliable")
DURABILITY_CHOICES: tuple[str, ...] = ("volatile", "transient_local")
NOISE_FIELDS: tuple[str, ...] = ("mean", "stddev", "bias_mean", "bias_stddev")


class ParamError(ValueError):
    """A parameter value that the node cannot run with; the message names the parameter."""


@dataclass(frozen=True)
class ParamSpec:
    """One declared parameter.

    Attributes
    ----------
    name : str
        Full parameter name (dots for nesting, as in a params file).
    default : Any
        Default value, or a :class:`Parameter.Type` for arrays whose default is empty.
    description : str
        Shown by ``ros2 param describe``.
    value_range : tuple of float or None
        ``(from, to)`` for scalars (and, checked here, for every element of a numeric array).
    runtime : bool
        False: read-only after start-up (``ros2 param set`` is refused).
    choices : tuple of str
        Allowed values of a string (or of each element of a string array).
    """

    name: str
    default: Any
    description: str
    value_range: tuple[float, float] | None = None
    runtime: bool = False
    choices: tuple[str, ...] = ()

    @property
    def type(self) -> Parameter.Type:
        if isinstance(self.default, Parameter.Type):
            return self.default
        return Parameter.Type.from_parameter_value(self.default)

    def descriptor(self) -> ParameterDescriptor:
        """The ROS descriptor: type, description, constraints, range, read-only flag."""
        constraints = []
        if self.choices:
            constraints.append("one of " + ", ".join(repr(c) for c in self.choices))
        if self.value_range is not None and self.type in (
            Parameter.Type.DOUBLE_ARRAY,
            Parameter.Type.INTEGER_ARRAY,
        ):
            constraints.append(f"every element in [{self.value_range[0]}, {self.value_range[1]}]")
        if not self.runtime:
            constraints.append("start-up only (restart the node to change it)")
        d = ParameterDescriptor(
            name=self.name,
            type=self.type.value,
            description=self.description,
            additional_constraints="; ".join(constraints),
            read_only=not self.runtime,
            dynamic_typing=False,
        )
        if self.value_range is not None:
            lo, hi = self.value_range
            if self.type == Parameter.Type.DOUBLE:
                d.floating_point_range = [
                    FloatingPointRange(from_value=float(lo), to_value=float(hi), step=0.0)
                ]
            elif self.type == Parameter.Type.INTEGER:
                d.integer_range = [IntegerRange(from_value=int(lo), to_value=int(hi), step=1)]
        return d

    def check(self, value: Any) -> None:
        """Checks the descriptor cannot express (choices, array elements, finiteness).

        Raises
        ------
        ParamError
            Naming the parameter, the value and what is allowed.
        """
        if self.choices:
            values = [value] if isinstance(value, str) else list(value or [])
            for v in values:
                if v not in self.choices:
                    raise ParamError(f"{self.name}: {v!r} is not one of {list(self.choices)}")
        if isinstance(value, float) and not math.isfinite(value):
            raise ParamError(f"{self.name}: {value} is not finite")
        if self.type in (Parameter.Type.DOUBLE_ARRAY, Parameter.Type.INTEGER_ARRAY) and value is not None:
            for v in value:
                if not math.isfinite(float(v)):
                    raise ParamError(f"{self.name}: element {v} is not finite")
                if self.value_range is not None and not self.value_range[0] <= v <= self.value_range[1]:
                    raise ParamError(
                        f"{self.name}: element {v} is outside [{self.value_range[0]}, {self.value_range[1]}]"
                    )


def _noise_specs() -> list[ParamSpec]:
    specs = [
        ParamSpec(
            "noise.seed",
            0,
            "Seed of the sensor-noise random generator (stream k uses seed + k): runs are reproducible.",
            (0, 2**31 - 1),
            runtime=True,
        )
    ]
    what = {
        "mean": "mean of the white Gaussian noise added to every sample",
        "stddev": "standard deviation of the white Gaussian noise added to every sample",
        "bias_mean": "mean of the constant bias drawn once per channel (Gazebo-style)",
        "bias_stddev": "standard deviation of the constant bias drawn once per channel",
    }
    for stream in STREAM_NAMES:
        for field_name in NOISE_FIELDS:
            lo = 0.0 if "stddev" in field_name else -1.0e12
            specs.append(
                ParamSpec(
                    f"noise.{stream}.{field_name}",
                    Parameter.Type.DOUBLE_ARRAY,
                    f"Sensor noise of stream {stream!r}: {what[field_name]}, in the channel's SI unit. "
                    "Empty: none; one value: every channel; else one value per channel in stream order.",
                    (lo, 1.0e12),
                    runtime=True,
                )
            )
    return specs


SIMULATOR_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("model", "paper_sun2021", "Model config: a name in config/ (paper_sun2021) or a YAML path."),
    ParamSpec(
        "bearing_type",
        "",
        "Bearing set of Table 5 used for every bearing; empty keeps the model's bearings.",
        choices=BEARING_TYPE_CHOICES,
    ),
    ParamSpec(
        "speed_rpm",
        3000.0,
        "Initial input-shaft speed, rpm. At runtime publish std_msgs/Float64 on "
        "/gear_rotor/setpoint/speed_rpm instead.",
        (0.0, 100000.0),
    ),
    ParamSpec(
        "temperature_c",
        25.0,
        "Initial steady-state temperature, C. At runtime publish std_msgs/Float64 on "
        "/gear_rotor/setpoint/temperature_c instead.",
        (-273.0, 2000.0),
    ),
    ParamSpec(
        "limits.speed_rpm_max",
        30000.0,
        "Largest accepted speed (initial value and setpoints), rpm.",
        (0.0, 100000.0),
        runtime=True,
    ),
    ParamSpec(
        "limits.temperature_c_min",
        25.0,
        "Smallest accepted temperature, C (default: lower end of the material table).",
        (-273.0, 2000.0),
        runtime=True,
    ),
    ParamSpec(
        "limits.temperature_c_max",
        325.0,
        "Largest accepted temperature, C (default: upper end of the material table).",
        (-273.0, 2000.0),
        runtime=True,
    ),
    ParamSpec(
        "speed_ramp_rpm_per_s",
        2000.0,
        "Rate at which the speed follows its setpoint, rpm per simulated second.",
        (1.0e-3, 1.0e7),
    ),
    ParamSpec(
        "temperature_ramp_c_per_s",
        20.0,
        "Rate at which the temperature follows its setpoint, C per simulated second.",
        (1.0e-3, 1.0e6),
    ),
    ParamSpec(
        "real_time_factor",
        1.0,
        "Requested simulated seconds per wall-clock second. When the model cannot keep up, simulated "
        "time runs slower (never skipping samples) and /diagnostics reports the achieved factor.",
        (1.0e-3, 1.0e4),
        runtime=True,
    ),
    ParamSpec(
        "chunk_period_s",
        0.1,
        "Simulated time per published chunk, s; chunk_period_s * output_sample_rate_hz must be a whole "
        "number of samples.",
        (1.0e-3, 2.0),
        runtime=True,
    ),
    ParamSpec("output_sample_rate_hz", 20000.0, "Output sample rate of every stream, Hz.", (1.0, 1.0e6)),
    ParamSpec(
        "steps_per_mesh",
        32,
        "Integration steps per mesh period while the teeth stay in contact (>= 48 also locates mesh "
        "events inside steps).",
        (8, 4096),
    ),
    ParamSpec(
        "contact_loss_rate_hz",
        320000.0,
        "Default dt rule: while the teeth separate, at least this many integration steps per second "
        "with the mesh events located (RMS DTE within 0.5 %, docs/solver.md); 0 keeps steps_per_mesh.",
        (0.0, 2.0e7),
    ),
    ParamSpec(
        "event_average",
        True,
        "On an integration step holding a located mesh event, stream the end value shifted by what the "
        "events change in the step's mean (Simulator(event_average=True)): removes the fold of the "
        "mesh force's harmonics into the band at high speed (docs/solver.md, Session 10).",
    ),
    ParamSpec(
        "periodic_replay",
        True,
        "At a constant set point without faults, once the state repeats after a whole number of forcing "
        "periods (to 1e-10), stream the stored period instead of integrating until a set point or the "
        "faults change (Simulator(periodic_replay=True), docs/solver.md, Periodic replay at steady state).",
    ),
    ParamSpec(
        "periodic_replay_faults",
        False,
        "With periodic_replay: also replay faults locked to a shaft's angle at a constant severity (tooth "
        "damage, eccentricity, unbalance, shaft misalignment; Simulator(periodic_replay='faults')). The "
        "faulted stream then differs from the integrator's, which calibrate simulates, by the "
        "integration's sensitivity to round-off: up to 0.15 of the peak at 3000 rpm (docs/solver.md).",
    ),
    ParamSpec("publish.dte", True, "Publish the DTE stream /gear_rotor/dte (dte, mesh_force)."),
    ParamSpec(
        "publish.bearings",
        [1, 2, 3, 4],
        "Bearings (1-based) whose housing forces x, y, z go to /gear_rotor/bearing_forces.",
        (1, 1000),
    ),
    ParamSpec(
        "publish.housing_bearings",
        Parameter.Type.INTEGER_ARRAY,
        "Bearings (1-based) whose housing accelerometers x, y go to /gear_rotor/housing_accelerations "
        "(single-DOF housing model and sensor noise of docs/faults.md, driven by the bearing forces).",
        (1, 1000),
    ),
    ParamSpec(
        "publish.displacement_nodes",
        [5, 14],
        "Nodes (1-based, Fig 5) whose displacements go to /gear_rotor/displacements.",
        (1, 10000),
    ),
    ParamSpec(
        "publish.displacement_dofs",
        ["x", "y", "z"],
        "DOFs of the displacement stream.",
        choices=DOF_CHOICES,
    ),
    ParamSpec(
        "publish.acceleration_nodes",
        Parameter.Type.INTEGER_ARRAY,
        "Nodes (1-based) whose x, y, z accelerations go to /gear_rotor/accelerations (empty: none).",
        (1, 10000),
    ),
    ParamSpec("frame_ids.dte", "gear_mesh", "frame_id of /gear_rotor/dte."),
    ParamSpec("frame_ids.bearing_forces", "gearbox_housing", "frame_id of /gear_rotor/bearing_forces."),
    ParamSpec("frame_ids.displacements", "gearbox_housing", "frame_id of /gear_rotor/displacements."),
    ParamSpec("frame_ids.accelerations", "gearbox_housing", "frame_id of /gear_rotor/accelerations."),
    ParamSpec(
        "frame_ids.housing_accelerations", "gearbox_housing", "frame_id of /gear_rotor/housing_accelerations."
    ),
    *_noise_specs(),
    ParamSpec(
        "publish_clock",
        False,
        "Publish rosgraph_msgs/Clock on /clock (simulated time at the end of the last published chunk) "
        "for use_sim_time consumers.",
        runtime=True,
    ),
    ParamSpec(
        "faults_file",
        "",
        "YAML fault list injected from the start (docs/faults.md); at run time use the ~/set_faults service.",
    ),
    ParamSpec("recording.enabled", False, "Record the published streams to an MCAP file (rosbag2 layout)."),
    ParamSpec("recording.path", "gear_rotor_sim.mcap", "Path of the MCAP file written when recording."),
    ParamSpec(
        "recording.flush_period_s",
        1.0,
        "Wall-clock period of chunk flushes (bounds crash loss).",
        (0.05, 60.0),
    ),
    ParamSpec(
        "stream_qos.reliability",
        "best_effort",
        "QoS reliability of the sample streams: best_effort (sensor data) or reliable.",
        choices=RELIABILITY_CHOICES,
    ),
    ParamSpec("stream_qos.depth", 10, "QoS history depth (keep last) of the sample streams.", (1, 10000)),
    ParamSpec(
        "stream_qos.durability",
        "volatile",
        "QoS durability of the sample streams: volatile (sensor data), or transient_local (the last "
        "stream_qos.depth chunks go to a subscriber that asks for them when it joins late).",
        choices=DURABILITY_CHOICES,
    ),
    ParamSpec("diagnostics_period_s", 1.0, "Wall-clock period of /diagnostics messages, s.", (0.05, 60.0)),
    ParamSpec(
        "foxglove_port",
        0,
        "Also serve the streams, indicators and setpoints on a Foxglove WebSocket on this port "
        "(8765 is the Foxglove app's default; docs/live.md); 0: off.",
        (0, 65535),
    ),
)

MONITOR_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("topic", "/gear_rotor/dte", "gear_rotor_msgs/msg/VibrationChunk stream to monitor."),
    ParamSpec(
        "indicators_topic",
        "/gear_rotor/indicators",
        "Topic of the published gear_rotor_msgs/msg/ConditionIndicators.",
    ),
    ParamSpec("window_s", 0.5, "Length of the analysis window, simulated seconds.", (1.0e-3, 600.0)),
    ParamSpec(
        "fault_thresholds_file",
        "",
        "JSON of fault-alarm thresholds learnt from healthy runs (benchmarks/detection.py "
        "--save-thresholds; config/fault_thresholds.json); on a housing_accelerations topic the fault "
        "indicators are checked per window and alarms go to /diagnostics. '' disables.",
    ),
    ParamSpec(
        "pinion_teeth",
        29,
        "Tooth count of the pinion on the input shaft: the mesh order of the order lines.",
        (1, 10000),
    ),
    ParamSpec(
        "order_halfwidth",
        0.4,
        "Half-width, in shaft orders, of the band searched around each order line.",
        (0.01, 0.49),
        runtime=True,
    ),
    ParamSpec(
        "alarm_rms_threshold",
        Parameter.Type.DOUBLE_ARRAY,
        "RMS alarm thresholds in the channel's unit; empty: no alarm; one value: every channel; "
        "else one per channel.",
        (0.0, 1.0e300),
        runtime=True,
    ),
    ParamSpec(
        "publish_every_n_chunks",
        1,
        "Publish indicators after every n-th received chunk (once the window is full).",
        (1, 100000),
        runtime=True,
    ),
    ParamSpec(
        "stream_qos.reliability",
        "best_effort",
        "QoS reliability of the subscription: best_effort matches both kinds of publisher.",
        choices=RELIABILITY_CHOICES,
    ),
    ParamSpec("stream_qos.depth", 10, "QoS history depth of the subscription.", (1, 10000)),
)


def declare(node: Node, specs: Sequence[ParamSpec]) -> dict[str, Any]:
    """Declare ``specs`` on ``node`` and return their values (overrides applied, checked).

    Raises
    ------
    ParamError
        When a value violates a check of :meth:`ParamSpec.check`. rclpy itself raises
        ``InvalidParameterValueException`` / ``InvalidParameterTypeException`` for range and
        type errors.
    """
    values: dict[str, Any] = {}
    for spec in specs:
        param = node.declare_parameter(spec.name, spec.default, spec.descriptor())
        value = parameter_value(param.value)
        spec.check(value)
        values[spec.name] = value
    return values


def parameter_value(value: Any) -> Any:
    """An rclpy parameter value as the nodes keep it: a scalar or string as is, an array as a list
    (``[]`` for an unset one)."""
    if value is None:
        return []
    if isinstance(value, str | bool | int | float):
        return value
    return list(value)


def updated_values(
    values: dict[str, Any], specs: dict[str, ParamSpec], params: Sequence[Any]
) -> dict[str, Any]:
    """A copy of ``values`` with the runtime changes ``params`` (``rclpy.parameter.Parameter``), each
    checked by its spec; parameters without a spec (rclpy's own, e.g. ``use_sim_time``) are ignored.

    Raises
    ------
    ParamError
        When a new value violates its spec (the message names the parameter).
    """
    new = dict(values)
    for p in params:
        spec = specs.get(p.name)
        if spec is None:
            continue
        value = parameter_value(p.value)
        spec.check(value)
        new[p.name] = value
    return new


def check_unknown_overrides(node: Node, node_name: str, specs: Sequence[ParamSpec]) -> None:
    """Raise :class:`ParamError` listing the start-up overrides of ``node`` that ``specs`` does not
    declare, each with the closest declared name as a hint (rclpy's own parameters are allowed)."""
    known = {s.name for s in specs} | {"use_sim_time", "start_type_description_service"}
    overrides = getattr(node, "_parameter_overrides", {}) or {}
    unknown = sorted(set(overrides) - known)
    if unknown:
        hints = {u: difflib.get_close_matches(u, known, n=1) for u in unknown}
        raise ParamError(
            f"unknown parameter(s) for node {node_name}: "
            + ", ".join(f"{u!r}" + (f" (did you mean {h[0]!r}?)" if h else "") for u, h in hints.items())
            + "; see docs/ros.md or config/simulator_node.yaml for the declared parameters"
        )


def spec_by_name(specs: Sequence[ParamSpec]) -> dict[str, ParamSpec]:
    return {s.name: s for s in specs}


def broadcast(values: Sequence[float], n: int, name: str, fill: float = 0.0) -> list[float]:
    """Expand an empty, one-element or n-element parameter array to n values.

    Raises
    ------
    ParamError
        When the length is neither 0, 1 nor ``n``.
    """
    vals = [float(v) for v in values]
    if not vals:
        return [fill] * n
    if len(vals) == 1:
        return vals * n
    if len(vals) != n:
        raise ParamError(f"{name}: {len(vals)} values given; expected none, one, or one per channel ({n})")
    return vals


def check_simulator_values(values: dict[str, Any]) -> None:
    """Cross-field checks of the simulator node's parameters.

    Raises
    ------
    ParamError
        Naming the offending parameter(s).
    """
    if values["limits.temperature_c_min"] > values["limits.temperature_c_max"]:
        raise ParamError(
            f"limits.temperature_c_min ({values['limits.temperature_c_min']}) is above "
            f"limits.temperature_c_max ({values['limits.temperature_c_max']})"
        )
    for kind in ("speed_rpm", "temperature_c"):
        reason = check_setpoint(kind, float(values[kind]), values)
        if reason is not None:
            raise ParamError(f"{kind}: initial value refused: {reason}")
    samples = values["chunk_period_s"] * values["output_sample_rate_hz"]
    if abs(samples - round(samples)) > 1e-6 * max(1.0, samples) or round(samples) < 1:
        raise ParamError(
            f"chunk_period_s: {values['chunk_period_s']} s at output_sample_rate_hz = "
            f"{values['output_sample_rate_hz']} is {samples:g} samples; it must be a whole number >= 1"
        )
    if not str(values["model"]).strip():
        raise ParamError("model: empty; give a config name (e.g. paper_sun2021) or a YAML path")
    if values["recording.enabled"] and not str(values["recording.path"]).strip():
        raise ParamError("recording.path: empty while recording.enabled is true")
    selected = (
        "publish.dte",
        "publish.bearings",
        "publish.displacement_nodes",
        "publish.acceleration_nodes",
        "publish.housing_bearings",
    )
    if not any(values[k] for k in selected):
        raise ParamError("publish.*: no stream selected (dte, bearings, displacement or acceleration nodes)")
    if values["publish.displacement_nodes"] and not values["publish.displacement_dofs"]:
        raise ParamError("publish.displacement_dofs: empty while publish.displacement_nodes is not")
    for key in (
        "publish.bearings",
        "publish.displacement_nodes",
        "publish.acceleration_nodes",
        "publish.housing_bearings",
    ):
        if len(set(values[key])) != len(values[key]):
            raise ParamError(f"{key}: duplicate entries in {values[key]}")
