"""The simulator node: the digital twin's streams as ROS 2 topics (``ros2 run gear_rotor_sim simulator``).

Threading (why setpoints are never starved): a dedicated *stepping thread* advances the simulator
chunk by chunk and paces the chunks against the wall clock (``real_time_factor``); an *output
thread* runs the chunk's anti-aliasing decimation (``Simulator.advance_deferred``), adds sensor
noise, publishes the chunks and feeds the recorder, in order, while the next
chunk is integrated (a queue of two blocks between them: nothing is dropped; if publishing falls
behind, the stepping thread waits). The main thread spins a single-threaded executor that serves
everything else: setpoint subscriptions, parameter services and the diagnostics timer. Setpoint callbacks only
validate and store the latest target under a lock; the stepping thread hands it to the simulator
between two chunks. A callback waits at most for the Python interpreter lock, i.e. the length of
one compiled kernel call when the kernels hold it; with ``nogil`` kernels it runs concurrently.

Pacing: chunk ``k`` covers simulated ``[t_k, t_k + chunk_period_s)`` and is published when the wall
clock reaches ``anchor + (t_k + chunk_period_s - t_anchor) / real_time_factor``. When the model is
late by more than one chunk (it cannot keep the requested factor), the anchor moves to "now": sim
time slows down, no sample is dropped or repeated, and ``/diagnostics`` reports the achieved factor.

The ROS layer adds no physics: the simulator computes every sample; this node selects channels,
adds the configured sensor noise (a sensor model, off by default) and stamps messages with
simulated time.
"""

from __future__ import annotations

import collections
import difflib
import math
import queue
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from gear_rotor_msgs.msg import FaultState, VibrationChunk
from gear_rotor_msgs.srv import SetFaults
from rcl_interfaces.msg import SetParametersResult
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64

from gear_rotor_sim.blocks import SampleBlock
from gear_rotor_sim.recording.cdr import serialize_vibration_chunk
from gear_rotor_sim.ros.node_faults import FAULTS_QOS, FAULTS_TOPIC, NodeFaults, fault_state_msg
from gear_rotor_sim.ros.params import (
    NOISE_FIELDS,
    SIMULATOR_PARAMETERS,
    STREAM_NAMES,
    ParamError,
    broadcast,
    check_setpoint,
    check_simulator_values,
    declare,
    spec_by_name,
)
from gear_rotor_sim.streams import StreamSpec, chunk_fields, default_streams, time_to_stamp

if TYPE_CHECKING:
    from gear_rotor_sim.simulator import PendingBlock

NODE_NAME = "gear_rotor_simulator"
SPEED_SETPOINT_TOPIC = "/gear_rotor/setpoint/speed_rpm"
TEMPERATURE_SETPOINT_TOPIC = "/gear_rotor/setpoint/temperature_c"
#: Reliable, keep last 10, volatile: setpoints here, condition indicators in the monitor node.
RELIABLE_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
SETPOINT_QOS = RELIABLE_QOS
CLOCK_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE)
DIAGNOSTICS_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE
)
#: Exit status for invalid parameters or an unusable model at start-up.
EXIT_INVALID = 2


def stream_qos(reliability: str, depth: int) -> QoSProfile:
    """QoS of the sample streams: sensor data (best effort) by default, or reliable."""
    if reliability == "reliable":
        return QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=depth,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.VOLATILE,
        )
    qos = QoSProfile(
        history=qos_profile_sensor_data.history,
        depth=depth,
        reliability=qos_profile_sensor_data.reliability,
        durability=qos_profile_sensor_data.durability,
    )
    return qos


class NoiseModel:
    """Gazebo-style Gaussian sensor noise of one stream: ``x + bias + N(mean, stddev)``.

    The bias of each channel is drawn once, from ``N(bias_mean, bias_stddev)``, when the model is
    built; the white part is drawn per sample. The generator is seeded, so a run is reproducible.
    """

    def __init__(self, n_channels: int, params: dict[str, list[float]], seed: int, stream: str) -> None:
        self.mean = np.asarray(broadcast(params["mean"], n_channels, f"noise.{stream}.mean"))
        self.stddev = np.asarray(broadcast(params["stddev"], n_channels, f"noise.{stream}.stddev"))
        bias_mean = np.asarray(broadcast(params["bias_mean"], n_channels, f"noise.{stream}.bias_mean"))
        bias_std = np.asarray(broadcast(params["bias_stddev"], n_channels, f"noise.{stream}.bias_stddev"))
        self._rng = np.random.default_rng(seed)
        self.bias = bias_mean + bias_std * self._rng.standard_normal(n_channels)
        self.active = bool(np.any(self.stddev) or np.any(self.mean) or np.any(self.bias))

    def apply(self, data: np.ndarray) -> np.ndarray:
        """Noisy copy of ``data`` (shape ``(n_samples, n_channels)``); ``data`` itself when inactive."""
        if not self.active:
            return data
        noise = self._rng.standard_normal(data.shape) * self.stddev
        return data + (self.mean + self.bias) + noise


@dataclass
class _SharedState:
    """What the stepping thread and the executor callbacks share; guarded by ``lock``."""

    lock: threading.Lock = field(default_factory=threading.Lock)
    pending_speed: float | None = None
    pending_temperature: float | None = None
    target_speed: float = 0.0
    target_temperature: float = 0.0
    accepted: int = 0
    refused: int = 0
    refused_since_diag: int = 0
    last_refusal: str = ""
    last_warn_wall: float = -math.inf
    warn_suppressed: int = 0
    sim_time: float = 0.0
    speed: float = 0.0
    temperature: float = 0.0
    chunks: int = 0
    samples: int = 0
    late_chunks: int = 0
    contact_loss: float = 0.0
    back_side_contact: float = 0.0
    solver_steps: int = 0
    chunk_wall_s: float = 0.0
    mesh_solve_failures: int = 0
    health_level: bytes = DiagnosticStatus.OK
    health_message: str = "ok"
    achieved_rtf_window: collections.deque = field(default_factory=lambda: collections.deque(maxlen=512))
    start_wall: float = 0.0


def _stat(stats: Any, *names: str, default: float = 0.0) -> float:
    """Field of the simulator's chunk statistics, which may be a dataclass or a mapping."""
    if stats is None:
        return default
    for name in names:
        if isinstance(stats, dict) and name in stats:
            return float(stats[name])
        if hasattr(stats, name):
            return float(getattr(stats, name))
    return default


#: Blocks the stepping thread may run ahead of the output thread (publishing and recording).
_OUTPUT_QUEUE = 2


def process_age_s() -> float | None:
    """Seconds since this process started (Linux ``/proc/self/stat``); None where unavailable."""
    try:
        with open("/proc/self/stat", encoding="ascii") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        start_ticks = int(fields[19])  # field 22, starttime, in clock ticks since boot
        import os

        return time.clock_gettime(time.CLOCK_BOOTTIME) - start_ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def name_os_thread(name: str) -> None:
    """Name the calling thread in the operating system (Linux ``prctl(PR_SET_NAME)``, at most 15
    bytes: ``top -H``, ``/proc/<pid>/task/<tid>/comm``, ``benchmarks/bench_node.py``); a no-op where
    that is not available."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(15, ctypes.c_char_p(name.encode("ascii")[:15]), 0, 0, 0)  # 15: PR_SET_NAME
    except (OSError, AttributeError, ValueError):
        pass


#: Interpreter-lock switch interval of the node process (Python's default is 5 ms).
GIL_SWITCH_INTERVAL_S = 2e-4


class SimulatorNode(Node):
    """Publishes the simulator's streams, takes setpoints, reports diagnostics, optionally records.

    The constructor only declares parameters and wires publishers, subscriptions, the parameter
    callback and the diagnostics timer; :meth:`start` builds the model and starts the stepping
    thread, :meth:`stop` stops it and finalises the recording.
    """

    def __init__(self) -> None:
        self._t_constructed = time.monotonic()
        #: Seconds from the constructor to the first published message (None until then); logged.
        self.startup_s: float | None = None
        super().__init__(NODE_NAME)
        self._check_unknown_overrides()
        self._specs = spec_by_name(SIMULATOR_PARAMETERS)
        self._values: dict[str, Any] = declare(self, SIMULATOR_PARAMETERS)
        check_simulator_values(self._values)
        self._state = _SharedState()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._sim: Any = None
        self._recorder: Any = None
        self._recording_status = "off"
        self._streams: list[StreamSpec] = self._select_streams()
        self._noise: dict[str, NoiseModel] = {}
        self._rebuild_noise = True
        self._reanchor = True
        self._live: Any = None  # LiveServer when foxglove_port is set (docs/live.md)

        qos = stream_qos(self._values["stream_qos.reliability"], int(self._values["stream_qos.depth"]))
        self._stream_pubs = {
            s.name: self.create_publisher(VibrationChunk, s.topic, qos) for s in self._streams
        }
        self._clock_pub = self.create_publisher(Clock, "/clock", CLOCK_QOS)
        self._faults: NodeFaults | None = None  # built in start() (needs the rig)
        self._housing: Any = None  # housing accelerometers, built in start()
        self._fault_pub = self.create_publisher(FaultState, FAULTS_TOPIC, FAULTS_QOS)
        self.create_service(SetFaults, "~/set_faults", self._on_set_faults)
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", DIAGNOSTICS_QOS)
        self.create_subscription(Float64, SPEED_SETPOINT_TOPIC, self._on_speed, SETPOINT_QOS)
        self.create_subscription(Float64, TEMPERATURE_SETPOINT_TOPIC, self._on_temperature, SETPOINT_QOS)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.create_timer(float(self._values["diagnostics_period_s"]), self._publish_diagnostics)

    # ------------------------------------------------------------------------------------------
    # set-up
    # ------------------------------------------------------------------------------------------
    def _check_unknown_overrides(self) -> None:
        known = {s.name for s in SIMULATOR_PARAMETERS} | {"use_sim_time", "start_type_description_service"}
        overrides = getattr(self, "_parameter_overrides", {}) or {}
        unknown = sorted(set(overrides) - known)
        if unknown:
            hints = {u: difflib.get_close_matches(u, known, n=1) for u in unknown}
            raise ParamError(
                f"unknown parameter(s) for node {NODE_NAME}: "
                + ", ".join(f"{u!r}" + (f" (did you mean {h[0]!r}?)" if h else "") for u, h in hints.items())
                + "; see docs/ros.md or config/simulator_node.yaml for the declared parameters"
            )

    def _select_streams(self) -> list[StreamSpec]:
        v = self._values
        bearings = [int(b) for b in v["publish.bearings"]]
        specs = default_streams(
            n_bearings=max(bearings) if bearings else 0,
            displacement_nodes=tuple(int(n) for n in v["publish.displacement_nodes"]),
            displacement_dofs=tuple(v["publish.displacement_dofs"]),
            acceleration_nodes=tuple(int(n) for n in v["publish.acceleration_nodes"]),
            has_mesh=bool(v["publish.dte"]),
        )
        out = []
        for spec in specs:
            channels = spec.channels
            if spec.name == "bearing_forces":
                if not bearings:
                    continue
                channels = tuple(f"bearing{k}_f{d}" for k in bearings for d in "xyz")
            out.append(StreamSpec(spec.name, channels, str(v[f"frame_ids.{spec.name}"])))
        housing = [int(b) for b in v["publish.housing_bearings"]]
        if housing:
            from gear_rotor_sim.sensors.housing import housing_channels

            name = "housing_accelerations"
            out.append(StreamSpec(name, housing_channels(housing), str(v[f"frame_ids.{name}"])))
        return out

    def _housing_model(self) -> Any:
        """Streaming housing accelerometers of the housing stream (docs/faults.md), or None."""
        spec = next((s for s in self._streams if s.name == "housing_accelerations"), None)
        if spec is None:
            return None
        from gear_rotor_sim.sensors.housing import HousingAccelerometers
        from gear_rotor_sim.sensors.noise import SensorNoise

        seed = int(self._values["noise.seed"]) + STREAM_NAMES.index(spec.name) + 1000
        fs = float(self._values["output_sample_rate_hz"])
        return HousingAccelerometers(spec.channels, fs, noise=SensorNoise(seed=seed))

    def start(self) -> None:
        """Load the model, build the simulator (and recorder), start the stepping thread.

        Raises
        ------
        ParamError
            When the model, a bearing type, or a requested channel does not exist, or the simulator
            refuses the initial operating point; the message names the parameter.
        """
        from gear_rotor_sim.config import load_config
        from gear_rotor_sim.simulator import Simulator

        v = self._values
        try:
            cfg = load_config(str(v["model"]))
            if v["bearing_type"]:
                cfg = cfg.with_bearing_type(str(v["bearing_type"]))
        except ValueError as exc:
            raise ParamError(f"model/bearing_type: {exc}") from exc
        from gear_rotor_sim.faults.spec import FaultError, load_faults

        faults_file = str(v["faults_file"]).strip()
        try:
            initial = load_faults(faults_file, cfg) if faults_file else ()
        except FaultError as exc:
            raise ParamError(f"faults_file: {faults_file}: {exc}") from exc
        self._faults = NodeFaults(cfg, initial)
        self._cfg = cfg
        if len(cfg.meshes) > 1:  # a multi-stage rig: the DTE stream carries every mesh's DTE and force
            per_mesh = default_streams(0, n_meshes=len(cfg.meshes))[0].channels
            self._streams = [
                StreamSpec(sp.name, per_mesh, sp.frame_id) if sp.name == "dte" else sp for sp in self._streams
            ]
        available = {name for name, _unit in Simulator.available_channels(cfg)}
        self._housing = self._housing_model()
        channels = [c for s in self._streams if s.name != "housing_accelerations" for c in s.channels]
        channels += list(self._housing.sources) if self._housing is not None else []
        missing = [c for c in channels if c not in available]
        if missing:
            raise ParamError(
                f"publish.*: channels {missing} do not exist in model {v['model']!r} "
                f"({len(cfg.bearings)} bearings, {cfg.n_nodes} nodes)"
            )
        try:
            self._sim = Simulator(
                cfg,
                speed_rpm=float(v["speed_rpm"]),
                temperature_c=float(v["temperature_c"]),
                output_rate_hz=float(v["output_sample_rate_hz"]),
                channels=list(dict.fromkeys(channels)),
                steps_per_mesh=int(v["steps_per_mesh"]),
                contact_loss_rate_hz=float(v["contact_loss_rate_hz"]) or None,
                speed_ramp_rpm_per_s=float(v["speed_ramp_rpm_per_s"]),
                temperature_ramp_c_per_s=float(v["temperature_ramp_c_per_s"]),
                effects=self._faults.effects(),
            )
        except ValueError as exc:
            raise ParamError(f"simulator refused the parameters: {exc}") from exc
        self._check_noise_lengths(v)
        with self._state.lock:
            self._state.target_speed = float(v["speed_rpm"])
            self._state.target_temperature = float(v["temperature_c"])
            self._state.speed = float(v["speed_rpm"])
            self._state.temperature = float(v["temperature_c"])
            self._state.start_wall = time.monotonic()
        if v["recording.enabled"]:
            self._recorder = self._open_recorder(
                str(v["recording.path"]), float(v["recording.flush_period_s"])
            )
            self._recording_status = f"recording to {v['recording.path']}"
        if v["foxglove_port"]:
            self._live = self._open_live(cfg, int(v["foxglove_port"]))
        self._thread = threading.Thread(target=self._run, name="gear_rotor_stepping", daemon=True)
        self._thread.start()
        self.get_logger().info(
            f"simulating {v['model']} at {v['speed_rpm']} rpm, {v['temperature_c']} C, "
            f"{v['output_sample_rate_hz']} Hz, chunks of {v['chunk_period_s']} s, requested RTF "
            f"{v['real_time_factor']}; streams {[s.topic for s in self._streams]}"
            + (f"; recording to {v['recording.path']}" if self._recorder is not None else "")
        )

    def _open_recorder(self, path: str, flush_period_s: float) -> Any:
        from gear_rotor_sim.recording.writer import McapRecorder, RecordingError, qos_profile
        from gear_rotor_sim.system import drivetrain_metadata

        reliable = self._values["stream_qos.reliability"] == "reliable"
        offered = dict(qos_profile("reliable" if reliable else "sensor_data"))
        offered["depth"] = int(self._values["stream_qos.depth"])
        from gear_rotor_sim.recording import schemas
        from gear_rotor_sim.recording.record_cli import latched_qos

        try:
            rec = McapRecorder(
                path,
                self._streams,
                qos=offered,
                flush_period_s=flush_period_s,
                # the rig (calibrate reads it when no sidecar names the gearbox), per-shaft speed
                # ratios and mesh orders
                custom_data={
                    "config": str(self._values["model"]),
                    "bearing_type": str(self._values["bearing_type"] or "null"),
                    **drivetrain_metadata(self._cfg),
                },
            )
            rec.add_topic(FAULTS_TOPIC, schemas.FAULT_STATE, qos=latched_qos())
            return rec
        except (OSError, ValueError, RecordingError) as exc:
            raise ParamError(f"recording.path: cannot record to {path!r}: {exc}") from exc

    def _open_live(self, cfg: Any, port: int) -> Any:
        """The Foxglove WebSocket server of ``foxglove_port``; its setpoints take the topics' path."""
        from gear_rotor_sim.live.server import LiveServer

        def on_setpoint(kind: str, value: float) -> str | None:
            reason = check_setpoint(kind, value, self._values)
            self._setpoint(kind, value)  # stores it, or counts and logs the refusal
            return reason

        teeth = cfg.gears[0].teeth if cfg.gears else 1
        try:
            return LiveServer(self._streams, on_setpoint, port=port, pinion_teeth=teeth)
        except (OSError, RuntimeError, ValueError) as exc:
            raise ParamError(f"foxglove_port: cannot serve on port {port}: {exc}") from exc

    def _write_recording(self, spec: StreamSpec, fields: dict, data: bytes) -> None:
        """Record one published chunk; a failing recording (disk full, ...) is stopped, streaming goes on."""
        try:
            self._recorder.write_chunk(spec, fields, data)
        except Exception as exc:  # RecordingError, OSError: reported, streaming continues
            recorder, self._recorder = self._recorder, None
            self._recording_status = f"failed: {exc}"
            self.get_logger().error(f"recording stopped, streaming continues: {exc}")
            try:
                recorder.close()
            except Exception as close_exc:  # the original error was already reported
                self.get_logger().error(f"recording not finalised: {close_exc}")

    def stop(self) -> None:
        """Stop the stepping thread and finalise the recording (idempotent)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        if self._live is not None:
            live, self._live = self._live, None
            live.stop()
        if self._recorder is not None:
            recorder, self._recorder = self._recorder, None
            try:
                recorder.close()
            except Exception as exc:  # RecordingError / OSError: nothing more to do than report it
                self.get_logger().error(f"recording not finalised: {exc}")
                return
            self._recording_status = "finalised"
            self.get_logger().info(
                f"recording finalised: {self._values['recording.path']} "
                f"({recorder.message_count} messages, {recorder.bytes_written / 1e6:.1f} MB)"
            )

    @property
    def failed(self) -> bool:
        """True once the stepping thread has stopped on an error."""
        return self._state.health_level == DiagnosticStatus.ERROR

    # ------------------------------------------------------------------------------------------
    # setpoints and parameters (executor thread)
    # ------------------------------------------------------------------------------------------
    def _on_speed(self, msg: Float64) -> None:
        self._setpoint("speed_rpm", msg.data)

    def _on_temperature(self, msg: Float64) -> None:
        self._setpoint("temperature_c", msg.data)

    def _setpoint(self, kind: str, value: float) -> None:
        reason = check_setpoint(kind, float(value), self._values)
        if reason is not None:
            self._refuse(reason)
            return
        with self._state.lock:
            if kind == "speed_rpm":
                self._state.pending_speed = float(value)
            else:
                self._state.pending_temperature = float(value)
            self._state.accepted += 1

    def _on_set_faults(self, request: SetFaults.Request, response: SetFaults.Response) -> SetFaults.Response:
        """``~/set_faults``: validate now, apply between two chunks; a refusal changes nothing."""
        if self._faults is None:
            response.success, response.message = False, "refused: the simulator is not running yet"
            return response
        try:
            ok, message = self._faults.request(request.faults_yaml)
        except Exception as exc:  # never let a request take the node down
            ok, message = False, f"refused, faults unchanged: {type(exc).__name__}: {exc}"
        response.success, response.message = ok, message
        if ok:
            self.get_logger().info(f"set_faults accepted: {message}")
        else:
            self.get_logger().warning(f"set_faults {message}")
        return response

    def _refuse(self, reason: str) -> None:
        """Count a refused setpoint and log it at WARN (at most once per second, with a count)."""
        now = time.monotonic()
        st = self._state
        with st.lock:
            st.refused += 1
            st.refused_since_diag += 1
            st.last_refusal = reason
            if now - st.last_warn_wall < 1.0:
                st.warn_suppressed += 1
                return
            suppressed, st.warn_suppressed, st.last_warn_wall = st.warn_suppressed, 0, now
        more = f" ({suppressed} more refused in the last second)" if suppressed else ""
        self.get_logger().warning(f"setpoint refused, running state unchanged: {reason}{more}")

    def _check_noise_lengths(self, values: dict[str, Any]) -> None:
        for spec in self._streams:
            for f in NOISE_FIELDS:
                broadcast(values[f"noise.{spec.name}.{f}"], len(spec.channels), f"noise.{spec.name}.{f}")

    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        new = dict(self._values)
        try:
            for p in params:
                spec = self._specs.get(p.name)
                if spec is None:
                    continue  # e.g. use_sim_time: rclpy's own
                value = p.value
                if value is None:
                    value = []
                elif not isinstance(value, str | bool | int | float):
                    value = list(value)
                spec.check(value)
                new[p.name] = value
            check_simulator_values(new)
            self._check_noise_lengths(new)
        except ParamError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        changed = {k for k in new if new[k] != self._values[k]}
        self._values = new
        if any(k.startswith("noise.") for k in changed):
            self._rebuild_noise = True
        if changed & {"real_time_factor", "chunk_period_s"}:
            self._reanchor = True
        if changed:
            self.get_logger().info(f"parameters changed: {sorted(changed)}")
        return SetParametersResult(successful=True, reason="")

    # ------------------------------------------------------------------------------------------
    # stepping thread
    # ------------------------------------------------------------------------------------------
    def _apply_pending(self) -> None:
        st = self._state
        with st.lock:
            speed, st.pending_speed = st.pending_speed, None
            temp, st.pending_temperature = st.pending_temperature, None
        for kind, value in (("speed_rpm", speed), ("temperature_c", temp)):
            if value is None:
                continue
            try:
                self._sim.set_targets(**{kind: value})
            except ValueError as exc:  # the simulator's own range checks (e.g. material table)
                self._refuse(f"{kind} setpoint {value} refused by the simulator: {exc}")
                continue
            with st.lock:
                if kind == "speed_rpm":
                    st.target_speed = value
                else:
                    st.target_temperature = value

    def _build_noise(self) -> None:
        v = self._values
        self._noise = {
            spec.name: NoiseModel(
                len(spec.channels),
                {f: v[f"noise.{spec.name}.{f}"] for f in NOISE_FIELDS},
                int(v["noise.seed"]) + STREAM_NAMES.index(spec.name),
                spec.name,
            )
            for spec in self._streams
        }

    def _run(self) -> None:
        name_os_thread("gear_rotor_step")
        try:
            self._loop()
        except Exception as exc:  # reported on /diagnostics and in the log; the node stays up
            with self._state.lock:
                self._state.health_level = DiagnosticStatus.ERROR
                self._state.health_message = f"{type(exc).__name__}: {exc}"
            self.get_logger().error(f"simulation stopped: {type(exc).__name__}: {exc}")

    def _loop(self) -> None:
        """Simulate chunk after chunk at the requested pace; hand each block to the output thread.

        The output thread (decimation FIR, noise, messages, publishing, recording) works on chunk i
        while this thread integrates chunk i + 1 (the compiled kernel and the FIR release the GIL,
        so the two use both cores), through a
        queue of ``_OUTPUT_QUEUE`` blocks: when publishing cannot keep up the queue fills and this
        thread waits, so nothing is dropped and the achieved real-time factor shows it.
        """
        out_q: queue.Queue = queue.Queue(maxsize=_OUTPUT_QUEUE)
        writer = threading.Thread(
            target=self._output_loop, args=(out_q,), name="gear_rotor_output", daemon=True
        )
        writer.start()
        try:
            self._simulate(out_q)
        finally:
            out_q.put(None)  # after every block: the output thread drains the queue, then ends
            writer.join()

    def _output_loop(self, out_q: queue.Queue) -> None:
        name_os_thread("gear_rotor_out")
        sequence = {s.name: 0 for s in self._streams}
        clock = Clock()
        while True:
            item = out_q.get()
            if item is None:
                return
            pending, t_end, faults = item
            try:
                # the decimation FIR runs here, on this thread, while the stepping thread integrates
                # the next chunk (Simulator.advance_deferred)
                self._publish_block(pending.result(), t_end, sequence, clock, faults)
            except Exception as exc:  # reported; the stream goes on with the next block
                self.get_logger().error(f"publishing failed: {type(exc).__name__}: {exc}")

    def _publish_faults(self, t: float, faults: tuple | None) -> None:
        """Ground truth on /gear_rotor/faults (and in the recording) when it changed; ``faults``:
        (list, generation) the block starting at ``t`` was integrated with (see ``_simulate``)."""
        if self._faults is None or faults is None:
            return
        fields = self._faults.state_if_changed(t, *faults)
        if fields is None:
            return
        self._fault_pub.publish(fault_state_msg(fields))
        if self._recorder is not None:
            from gear_rotor_sim.recording.cdr import serialize_fault_state
            from gear_rotor_sim.recording.schemas import FAULT_STATE

            stamp = fields["stamp_sec"] * 1_000_000_000 + fields["stamp_nanosec"]
            try:
                self._recorder.write_serialized(
                    FAULTS_TOPIC, FAULT_STATE, serialize_fault_state(fields), stamp
                )
            except Exception as exc:  # the recording's own failure handling reports on the next chunk
                self.get_logger().error(f"fault state not recorded: {exc}")

    def _publish_block(
        self, block: SampleBlock, t_end: float, sequence: dict, clock: Clock, faults: tuple | None
    ) -> None:
        self._publish_faults(block.t0, faults)
        if self._housing is not None:
            from gear_rotor_sim.sensors.housing import append_housing

            block = append_housing(block, self._housing)
        if self._rebuild_noise:
            self._rebuild_noise = False
            self._build_noise()
        parts: list[SampleBlock] = []
        for spec in self._streams:
            sub = block.select(spec.channels)
            noisy = self._noise[spec.name].apply(sub.data)
            if noisy is not sub.data:
                sub = SampleBlock(
                    sub.t0,
                    sub.sample_rate_hz,
                    sub.channels,
                    sub.units,
                    noisy,
                    sub.first_index,
                    sub.speed_rpm,
                    sub.temperature_c,
                )
            seq = sequence[spec.name]
            # serialised once (the CDR bytes rclpy would produce, test/test_recording.py): the same
            # bytes are published and recorded
            fields = chunk_fields(sub, spec, seq)
            data = serialize_vibration_chunk(fields)
            self._stream_pubs[spec.name].publish(data)
            if self.startup_s is None:
                self._log_startup()
            if self._recorder is not None:
                self._write_recording(spec, fields, data)
            sequence[spec.name] = seq + 1
            parts.append(sub)
        if self._live is not None:
            self._publish_live(parts, t_end)
        if self._values["publish_clock"]:
            clock.clock.sec, clock.clock.nanosec = time_to_stamp(t_end)
            self._clock_pub.publish(clock)

    def _publish_live(self, parts: list[SampleBlock], t_end: float) -> None:
        """The published (noisy) chunk of every stream, as one block, to the Foxglove server."""
        first = parts[0]
        block = SampleBlock(
            first.t0,
            first.sample_rate_hz,
            tuple(c for p in parts for c in p.channels),
            tuple(u for p in parts for u in p.units),
            np.hstack([p.data for p in parts]),
            first.first_index,
            first.speed_rpm,
            first.temperature_c,
        )
        self._live.publish(block)
        with self._state.lock:
            fields = {
                "sim_time_s": t_end,
                "speed_rpm": self._state.speed,
                "target_speed_rpm": self._state.target_speed,
                "temperature_c": self._state.temperature,
                "target_temperature_c": self._state.target_temperature,
                "requested_real_time_factor": float(self._values["real_time_factor"]),
            }
        fields["achieved_real_time_factor"] = self.achieved_rtf()
        self._live.publish_status(fields, t_end)

    def _log_startup(self) -> None:
        from gear_rotor_sim.warmup import kernel_compile_counts

        self.startup_s = time.monotonic() - self._t_constructed
        age = process_age_s()
        loaded, compiled = kernel_compile_counts()
        self.get_logger().info(
            f"start-up: first message {self.startup_s:.2f} s after the node constructor"
            + (f", {age:.2f} s after the process started" if age is not None else "")
            + f"; numba kernels: {loaded} loaded from the cache, {compiled} compiled"
        )

    def _simulate(self, out_q: queue.Queue) -> None:
        expected_index: int | None = None
        anchor_wall = anchor_sim = 0.0
        while not self._stop.is_set():
            self._apply_pending()
            if self._faults is not None:
                try:
                    self._faults.apply_pending(self._sim)
                except ValueError as exc:  # validated on request; a rig-level refusal is reported
                    self.get_logger().error(f"faults not applied, previous faults kept: {exc}")
            # the fault list this block is integrated with: the output thread, up to two blocks
            # behind, publishes its truth (not the newest list's) at the block's start
            faults = None if self._faults is None else (self._faults.faults, self._faults.generation)
            rtf = float(self._values["real_time_factor"])
            chunk = float(self._values["chunk_period_s"])
            t_start = float(self._sim.time_s)
            if self._reanchor:
                self._reanchor = False
                anchor_wall, anchor_sim = time.monotonic(), t_start
            block = self._sim.advance_deferred(chunk)  # filtered by the output thread
            if expected_index is not None and block.first_index != expected_index:
                raise RuntimeError(
                    f"simulator continuity broken: block starts at sample {block.first_index}, "
                    f"expected {expected_index}"
                )
            expected_index = block.first_index + block.n_samples
            t_end = float(self._sim.time_s)
            due = anchor_wall + (t_end - anchor_sim) / rtf
            now = time.monotonic()
            late = now - due > chunk / rtf
            if due > now:
                self._stop.wait(due - now)
            elif late:
                anchor_wall, anchor_sim = now, t_end  # cannot keep up: sim time slows down
            out_q.put((block, t_end, faults))  # waits while the output thread is _OUTPUT_QUEUE blocks behind
            self._record_progress(block, t_end, late)

    def _record_progress(self, block: PendingBlock, t_end: float, late: bool) -> None:
        stats = getattr(self._sim, "last_chunk_stats", None)
        st = self._state
        with st.lock:
            st.sim_time = t_end
            st.speed = float(self._sim.speed_rpm)
            st.temperature = float(self._sim.temperature_c)
            st.chunks += 1
            st.samples += block.n_samples
            st.late_chunks += int(late)
            st.contact_loss = _stat(stats, "contact_loss_fraction")
            st.back_side_contact = _stat(stats, "back_contact_fraction", "back_side_contact_fraction")
            st.solver_steps = int(_stat(stats, "steps"))
            st.chunk_wall_s = _stat(stats, "wall_s", "wall_time_s")
            st.mesh_solve_failures = int(_stat(stats, "mesh_solve_failures"))
            st.achieved_rtf_window.append((time.monotonic(), t_end))

    # ------------------------------------------------------------------------------------------
    # diagnostics (executor thread)
    # ------------------------------------------------------------------------------------------
    def achieved_rtf(self) -> float:
        """Simulated seconds per wall second over the last few seconds (0 before two chunks)."""
        with self._state.lock:
            window = list(self._state.achieved_rtf_window)
        if len(window) < 2:
            return 0.0
        now = window[-1][0]
        recent = [w for w in window if now - w[0] <= 3.0]
        if len(recent) < 2:
            recent = window[-2:]
        (w0, s0), (w1, s1) = recent[0], recent[-1]
        return (s1 - s0) / (w1 - w0) if w1 > w0 else 0.0

    def _publish_diagnostics(self) -> None:
        rtf = self.achieved_rtf()
        st = self._state
        with st.lock:
            sim_kv = {
                "achieved_real_time_factor": f"{rtf:.4g}",
                "requested_real_time_factor": f"{self._values['real_time_factor']:.4g}",
                "sim_time_s": f"{st.sim_time:.6f}",
                "speed_rpm": f"{st.speed:.3f}",
                "target_speed_rpm": f"{st.target_speed:.3f}",
                "temperature_c": f"{st.temperature:.3f}",
                "target_temperature_c": f"{st.target_temperature:.3f}",
                "contact_loss_fraction": f"{st.contact_loss:.6f}",
                "back_side_contact_fraction": f"{st.back_side_contact:.6f}",
                "solver_steps_last_chunk": str(st.solver_steps),
                "chunk_wall_time_s": f"{st.chunk_wall_s:.6f}",
                "mesh_solve_failures": str(st.mesh_solve_failures),
                "chunks_published": str(st.chunks),
                "samples_published": str(st.samples),
                "late_chunks": str(st.late_chunks),
                "solver_health": st.health_message,
                "recording": self._recording_status,
            }
            level, message = st.health_level, st.health_message
            sp_level = DiagnosticStatus.WARN if st.refused_since_diag else DiagnosticStatus.OK
            sp_message = (
                f"{st.refused_since_diag} setpoint(s) refused since last report; last: {st.last_refusal}"
                if st.refused_since_diag
                else "ok"
            )
            sp_kv = {
                "accepted_total": str(st.accepted),
                "refused_total": str(st.refused),
                "refused_since_last_report": str(st.refused_since_diag),
                "last_refusal": st.last_refusal,
            }
            st.refused_since_diag = 0
        requested = float(self._values["real_time_factor"])
        if level == DiagnosticStatus.OK and st.chunks > 1 and rtf < 0.9 * requested:
            level = DiagnosticStatus.WARN
            message = f"cannot keep real_time_factor {requested:g}: achieved {rtf:.3g}"
        elif level == DiagnosticStatus.OK:
            message = f"running, achieved real-time factor {rtf:.3g}"
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        arr.status = [
            DiagnosticStatus(
                level=level,
                name=f"{NODE_NAME}: simulation",
                message=message,
                hardware_id="gear_rotor_sim",
                values=[KeyValue(key=k, value=val) for k, val in sim_kv.items()],
            ),
            DiagnosticStatus(
                level=sp_level,
                name=f"{NODE_NAME}: setpoints",
                message=sp_message,
                hardware_id="gear_rotor_sim",
                values=[KeyValue(key=k, value=val) for k, val in sp_kv.items()],
            ),
        ]
        self._diag_pub.publish(arr)


def main(args: list[str] | None = None) -> int:
    """Console script ``simulator``: run the node until SIGINT/SIGTERM; 2 on invalid parameters."""
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    # The stepping thread takes the interpreter lock back after every compiled (nogil) call; with the
    # default 5 ms switch interval it can wait that long behind the output thread's Python work.
    sys.setswitchinterval(GIL_SWITCH_INTERVAL_S)
    stop = threading.Event()

    def _on_signal(signum: int, _frame: Any) -> None:
        stop.set()

    signal.signal(signal.SIGINT, _on_signal)
    signal.signal(signal.SIGTERM, _on_signal)
    node: SimulatorNode | None = None
    try:
        try:
            node = SimulatorNode()
            node.start()
        except (ParamError, InvalidParameterValueException, InvalidParameterTypeException) as exc:
            print(f"[{NODE_NAME}] invalid parameters: {exc}", file=sys.stderr)
            return EXIT_INVALID
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.1)
        node.get_logger().info("shutting down")
    finally:
        if node is not None:
            node.stop()
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
