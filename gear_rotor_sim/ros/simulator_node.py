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
simulated time. This module holds the node's QoS, wiring and threads; what it builds at start is in
:mod:`.node_setup`, the shared state in :mod:`.node_runtime`, the noise in :mod:`.stream_noise`,
the diagnostics in :mod:`.node_diagnostics`, the faults service in :mod:`.node_faults`.
"""

from __future__ import annotations

import dataclasses
import queue
import signal
import sys
import threading
import time
from typing import Any

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
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
from gear_rotor_sim.ros.node_diagnostics import diagnostic_statuses
from gear_rotor_sim.ros.node_faults import FAULTS_QOS, FAULTS_TOPIC, NodeFaults, fault_state_msg
from gear_rotor_sim.ros.node_runtime import (
    GIL_SWITCH_INTERVAL_S,
    OUTPUT_QUEUE,
    SharedState,
    achieved_rtf,
    name_os_thread,
    process_age_s,
)
from gear_rotor_sim.ros.node_setup import build_model, open_live, open_recorder, select_streams
from gear_rotor_sim.ros.params import (
    SIMULATOR_PARAMETERS,
    ParamError,
    check_setpoint,
    check_simulator_values,
    check_unknown_overrides,
    declare,
    spec_by_name,
    updated_values,
)
from gear_rotor_sim.ros.stream_noise import NoiseModel, build_noise, check_noise_lengths
from gear_rotor_sim.streams import StreamSpec, chunk_fields, time_to_stamp

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


def stream_qos(reliability: str, depth: int, durability: str = "volatile") -> QoSProfile:
    """QoS of the sample streams: sensor data (best effort) by default, or reliable; volatile by
    default, or transient_local (a late-joining subscriber asking for it gets the last ``depth``)."""
    keep = DurabilityPolicy.TRANSIENT_LOCAL if durability == "transient_local" else None
    if reliability == "reliable":
        return QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=depth,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=keep or DurabilityPolicy.VOLATILE,
        )
    return QoSProfile(
        history=qos_profile_sensor_data.history,
        depth=depth,
        reliability=qos_profile_sensor_data.reliability,
        durability=keep or qos_profile_sensor_data.durability,
    )


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
        check_unknown_overrides(self, NODE_NAME, SIMULATOR_PARAMETERS)
        self._specs = spec_by_name(SIMULATOR_PARAMETERS)
        self._values: dict[str, Any] = declare(self, SIMULATOR_PARAMETERS)
        check_simulator_values(self._values)
        self._state = SharedState()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._sim: Any = None
        self._recorder: Any = None
        self._recording_status = "off"
        self._streams: list[StreamSpec] = select_streams(self._values)
        self._noise: dict[str, NoiseModel] = {}
        self._rebuild_noise = True
        self._reanchor = True
        self._live: Any = None  # LiveServer when foxglove_port is set (docs/live.md)

        qos = stream_qos(
            self._values["stream_qos.reliability"],
            int(self._values["stream_qos.depth"]),
            self._values["stream_qos.durability"],
        )
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
    def start(self) -> None:
        """Load the model, build the simulator (and recorder), start the stepping thread.

        Raises
        ------
        ParamError
            When the model, a bearing type, or a requested channel does not exist, or the simulator
            refuses the initial operating point; the message names the parameter.
        """
        v = self._values
        model = build_model(v, self._streams)
        self._cfg, self._faults, self._streams = model.cfg, model.faults, model.streams
        self._housing, self._sim = model.housing, model.sim
        check_noise_lengths(self._streams, v)
        with self._state.lock:
            self._state.target_speed = float(v["speed_rpm"])
            self._state.target_temperature = float(v["temperature_c"])
            self._state.speed = float(v["speed_rpm"])
            self._state.temperature = float(v["temperature_c"])
            self._state.start_wall = time.monotonic()
        if v["recording.enabled"]:
            self._recorder = open_recorder(
                v, self._streams, self._cfg, str(v["recording.path"]), float(v["recording.flush_period_s"])
            )
            self._recording_status = f"recording to {v['recording.path']}"
        if v["foxglove_port"]:
            self._live = open_live(self._streams, self._cfg, int(v["foxglove_port"]), self._live_setpoint)
        self._thread = threading.Thread(target=self._run, name="gear_rotor_stepping", daemon=True)
        self._thread.start()
        self.get_logger().info(
            f"simulating {v['model']} at {v['speed_rpm']} rpm, {v['temperature_c']} C, "
            f"{v['output_sample_rate_hz']} Hz, chunks of {v['chunk_period_s']} s, requested RTF "
            f"{v['real_time_factor']}; streams {[s.topic for s in self._streams]}"
            + (f"; recording to {v['recording.path']}" if self._recorder is not None else "")
        )

    def _live_setpoint(self, kind: str, value: float) -> str | None:
        """A setpoint from the Foxglove view: takes the topics' path; returns the refusal reason."""
        reason = check_setpoint(kind, value, self._values)
        self._setpoint(kind, value)  # stores it, or counts and logs the refusal
        return reason

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

    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        try:
            new = updated_values(self._values, self._specs, params)
            check_simulator_values(new)
            check_noise_lengths(self._streams, new)
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
        queue of ``OUTPUT_QUEUE`` blocks: when publishing cannot keep up the queue fills and this
        thread waits, so nothing is dropped and the achieved real-time factor shows it.
        """
        out_q: queue.Queue = queue.Queue(maxsize=OUTPUT_QUEUE)
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
            self._noise = build_noise(self._streams, self._values)
        parts: list[SampleBlock] = []
        for spec in self._streams:
            sub = block.select(spec.channels)
            noisy = self._noise[spec.name].apply(sub.data)
            if noisy is not sub.data:
                sub = dataclasses.replace(sub, data=noisy)
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
            out_q.put((block, t_end, faults))  # waits while the output thread is OUTPUT_QUEUE blocks behind
            self._state.record_chunk(self._sim, block.n_samples, t_end, late)

    # ------------------------------------------------------------------------------------------
    # diagnostics (executor thread)
    # ------------------------------------------------------------------------------------------
    def achieved_rtf(self) -> float:
        """Simulated seconds per wall second over the last few seconds (0 before two chunks)."""
        with self._state.lock:
            window = list(self._state.achieved_rtf_window)
        return achieved_rtf(window)

    def _publish_diagnostics(self) -> None:
        requested = float(self._values["real_time_factor"])
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        arr.status = diagnostic_statuses(
            NODE_NAME, self._state, self.achieved_rtf(), requested, self._recording_status
        )
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
