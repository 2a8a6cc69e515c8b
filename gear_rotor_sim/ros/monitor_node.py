"""Monitoring node: condition indicators of one vibration stream (``ros2 run gear_rotor_sim monitor``).

Subscribes to a ``gear_rotor_msgs/msg/VibrationChunk`` topic, keeps the most recent ``window_s`` of
contiguous samples, and after every ``publish_every_n_chunks``-th chunk (once the window is full)
publishes ``gear_rotor_msgs/msg/ConditionIndicators`` computed by
:func:`gear_rotor_sim.indicators.compute_indicators`:

- ``header.stamp``: simulated time of the first sample of the window; ``header.frame_id``: the
  stream's frame; ``window_s = n / sample_rate_hz`` with ``n = round(window_s * sample_rate_hz)``;
- ``speed_rpm``: the operating point of the newest chunk in the window (orders refer to it);
- ``alarm[i]``: ``rms[i] > alarm_threshold[i]``.

With ``fault_thresholds_file`` (thresholds learnt from healthy runs, docs/detection.md) and housing
accelerometer channels on the topic, every window is also checked by
:class:`gear_rotor_sim.alarms.FaultAlarms` (FM0, FM4, NA4, SER, shaft orders, envelope lines, ...;
the detection benchmark's computation): ``/diagnostics`` status ``gear_rotor_monitor: fault alarms``,
WARN naming the fault types whose indicator groups exceed their thresholds, OK otherwise.

A gap in ``first_sample_index`` (a chunk lost on a best-effort link) or a change of channels or
sample rate restarts the window, so indicators are always computed over contiguous samples.
"""

from __future__ import annotations

import math
import sys
from typing import Any

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from gear_rotor_msgs.msg import ConditionIndicators, VibrationChunk
from rcl_interfaces.msg import SetParametersResult
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter

from gear_rotor_sim.indicators import compute_indicators
from gear_rotor_sim.ros.params import (
    MONITOR_PARAMETERS,
    ParamError,
    broadcast,
    declare,
    spec_by_name,
    updated_values,
)
from gear_rotor_sim.ros.simulator_node import DIAGNOSTICS_QOS, RELIABLE_QOS, stream_qos
from gear_rotor_sim.streams import time_to_stamp

NODE_NAME = "gear_rotor_monitor"
INDICATORS_QOS = RELIABLE_QOS


class SampleWindow:
    """The most recent ``capacity`` contiguous samples of one stream.

    Parameters
    ----------
    capacity : int
        Window length in samples.
    """

    def __init__(self, capacity: int) -> None:
        self.capacity = int(capacity)
        self._chunks: list[np.ndarray] = []
        self._starts: list[int] = []
        self._speeds: list[float] = []
        self._count = 0
        self.next_index: int | None = None
        self.key: tuple | None = None
        self.gaps = 0

    def add(self, key: tuple, first_index: int, data: np.ndarray, speed_rpm: float) -> None:
        """Append a chunk (shape ``(n, c)``); restart on a gap, overlap or layout change."""
        if key != self.key or first_index != self.next_index:
            if self.key is not None and key == self.key:
                self.gaps += 1
            self._chunks, self._starts, self._speeds, self._count = [], [], [], 0
            self.key = key
        self._chunks.append(data)
        self._starts.append(first_index)
        self._speeds.append(speed_rpm)
        self._count += data.shape[0]
        self.next_index = first_index + data.shape[0]
        while self._chunks and self._count - self._chunks[0].shape[0] >= self.capacity:
            self._count -= self._chunks[0].shape[0]
            del self._chunks[0], self._starts[0], self._speeds[0]

    @property
    def full(self) -> bool:
        return self._count >= self.capacity

    def latest(self) -> tuple[np.ndarray, int, float]:
        """The last ``capacity`` samples, the stream index of the first one, and the newest speed."""
        data = np.concatenate(self._chunks, axis=0)[-self.capacity :]
        return data, self.next_index - self.capacity, self._speeds[-1]


class MonitorNode(Node):
    """Subscribes to a vibration stream and publishes running condition indicators."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        self._specs = spec_by_name(MONITOR_PARAMETERS)
        self._values: dict[str, Any] = declare(self, MONITOR_PARAMETERS)
        self._window: SampleWindow | None = None
        self._received = 0
        qos = stream_qos(self._values["stream_qos.reliability"], int(self._values["stream_qos.depth"]))
        self._pub = self.create_publisher(
            ConditionIndicators, self._values["indicators_topic"], INDICATORS_QOS
        )
        self.create_subscription(VibrationChunk, self._values["topic"], self._on_chunk, qos)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._fault_alarms: Any = None
        path = str(self._values["fault_thresholds_file"]).strip()
        if path:
            from gear_rotor_sim.alarms import FaultAlarms

            try:
                self._fault_alarms = FaultAlarms(path)
            except ValueError as exc:
                raise ParamError(f"fault_thresholds_file: {exc}") from exc
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", DIAGNOSTICS_QOS)

    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        try:
            new = updated_values(self._values, self._specs, params)
        except ParamError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        self._values = new
        return SetParametersResult(successful=True, reason="")

    def _on_chunk(self, msg: VibrationChunk) -> None:
        n_ch = len(msg.channel_names)
        if n_ch == 0 or len(msg.data) % n_ch != 0 or not msg.sample_rate_hz > 0.0:
            self.get_logger().warning(
                f"malformed chunk {msg.sequence} on {self._values['topic']}: {len(msg.data)} values, "
                f"{n_ch} channels, {msg.sample_rate_hz} Hz; ignored",
                throttle_duration_sec=5.0,
            )
            return
        fs = float(msg.sample_rate_hz)
        capacity = max(2, round(float(self._values["window_s"]) * fs))
        if self._window is None or self._window.capacity != capacity:
            self._window = SampleWindow(capacity)
        data = np.frombuffer(msg.data, dtype=np.float64).reshape(-1, n_ch)
        key = (tuple(msg.channel_names), fs)
        self._window.add(key, int(msg.first_sample_index), data, float(msg.speed_rpm))
        self._received += 1
        if not self._window.full or self._received % int(self._values["publish_every_n_chunks"]) != 0:
            return
        window, first_index, speed = self._window.latest()
        try:
            thresholds = broadcast(self._values["alarm_rms_threshold"], n_ch, "alarm_rms_threshold", math.inf)
        except ParamError as exc:
            self.get_logger().warning(f"{exc}; alarms off", throttle_duration_sec=5.0)
            thresholds = [math.inf] * n_ch
        ind = compute_indicators(
            window, fs, speed, int(self._values["pinion_teeth"]), float(self._values["order_halfwidth"])
        )
        # time of the window's first sample, from the newest chunk's stamp and the sample indices
        t_last_chunk = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        t_first = t_last_chunk - (int(msg.first_sample_index) - first_index) / fs
        out = ConditionIndicators()
        out.header.stamp.sec, out.header.stamp.nanosec = time_to_stamp(max(t_first, 0.0))
        out.header.frame_id = msg.header.frame_id
        out.source_topic = self._values["topic"]
        out.window_s = ind.window_s
        out.speed_rpm = speed
        out.mesh_frequency_hz = ind.mesh_frequency_hz
        out.channel_names = list(msg.channel_names)
        out.rms = ind.rms.tolist()
        out.peak = ind.peak.tolist()
        out.crest_factor = ind.crest_factor.tolist()
        out.kurtosis = ind.kurtosis.tolist()
        out.mesh_order_amplitude = ind.mesh_order_amplitude.tolist()
        out.sideband_amplitude = ind.sideband_amplitude.tolist()
        out.alarm_threshold = [float(t) for t in thresholds]
        out.alarm = [bool(r > t) for r, t in zip(ind.rms, thresholds, strict=True)]
        self._pub.publish(out)
        if self._fault_alarms is not None and any("_housing_a" in c for c in msg.channel_names):
            self._check_faults(window, msg, fs, speed, out.header.stamp)
        if any(out.alarm):
            names = [c for c, a in zip(out.channel_names, out.alarm, strict=True) if a]
            self.get_logger().warning(f"RMS alarm on {names}", throttle_duration_sec=5.0)

    def _check_faults(
        self, window: np.ndarray, msg: VibrationChunk, fs: float, speed: float, stamp: Any
    ) -> None:
        """Fault alarms of the window on /diagnostics; an error is logged, the node goes on."""
        from types import SimpleNamespace

        w = SimpleNamespace(
            data=window,
            channels=tuple(msg.channel_names),
            sample_rate_hz=fs,
            speed_rpm=speed,
            temperature_c=float(msg.temperature_c),
        )
        try:
            alarms, cls = self._fault_alarms.check(w)
        except Exception as exc:  # a bad window must not stop the monitor
            self.get_logger().warning(f"fault alarms not computed: {exc}", throttle_duration_sec=5.0)
            return
        t = stamp.sec + stamp.nanosec * 1e-9
        status = DiagnosticStatus(
            level=DiagnosticStatus.WARN if alarms else DiagnosticStatus.OK,
            name=f"{NODE_NAME}: fault alarms",
            message=("alarm: " + ", ".join(sorted(alarms))) if alarms else "no fault alarm",
            hardware_id="gear_rotor_sim",
            values=[
                KeyValue(key="window_start_s", value=f"{t:.6f}"),
                KeyValue(key="operating_class", value=f"{cls[0]:g} rpm, {cls[1]:g} C"),
                *[KeyValue(key=k, value=", ".join(v)) for k, v in sorted(alarms.items())],
            ],
        )
        arr = DiagnosticArray()
        arr.header.stamp = stamp
        arr.status = [status]
        self._diag_pub.publish(arr)
        if alarms:
            self.get_logger().warning(
                f"fault alarm at {t:.3f} s: {sorted(alarms)}", throttle_duration_sec=2.0
            )


def main(args: list[str] | None = None) -> int:
    """Console script ``monitor``: run until SIGINT/SIGTERM; 2 on invalid parameters."""
    rclpy.init(args=args)
    node: MonitorNode | None = None
    try:
        try:
            node = MonitorNode()
        except (ParamError, InvalidParameterValueException, InvalidParameterTypeException) as exc:
            print(f"[{NODE_NAME}] invalid parameters: {exc}", file=sys.stderr)
            return 2
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
