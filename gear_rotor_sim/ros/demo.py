"""The README's main command (``bash scripts/demo.sh``): bring up the node, steer it, record, summarise.

What it does, with real ROS 2 processes:

1. starts the installed ``simulator`` executable the way ``ros2 run gear_rotor_sim simulator``
   resolves it (ament index prefix + ``lib/gear_rotor_sim/simulator``) with
   ``config/simulator_node.yaml``, recording to an MCAP file, and the ``monitor`` executable;
2. from this (separate) process, a node subscribes to every stream and publishes setpoints on
   ``/gear_rotor/setpoint/speed_rpm`` and ``/gear_rotor/setpoint/temperature_c``: a speed step, a few
   invalid setpoints (refused), then a temperature step, then a fault through the node's
   ``~/set_faults`` service (``DEMO_FAULT``: tooth damage on gear tooth 5 at about 5 s);
3. stops the simulator with SIGINT (the recording is finalised) and prints a summary: topics,
   message counts and rates, sequence continuity, the DTE's dominant frequency against the mesh
   frequency ``29 * rpm / 60``, the axial bearing force before and after the temperature step
   against the thermal-expansion estimate, the monitor's indicators of the DTE before and after
   the fault, and what the MCAP file holds.

The helpers (executable resolution, environment, :class:`Probe`) are reused by the node tests and
the node benchmark.
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import math
import os
import random
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

PACKAGE = "gear_rotor_sim"
REPO_ROOT = Path(__file__).resolve().parents[2]
#: The fault the demo injects through ~/set_faults (docs/faults.md).
DEMO_FAULT = "[{type: tooth_damage, wheel: gear, tooth: 5, depth: 0.3}]"
STREAM_TOPICS = ("/gear_rotor/dte", "/gear_rotor/bearing_forces", "/gear_rotor/displacements")


# ------------------------------------------------------------------------------------------------
# process helpers (no rclpy import needed)
# ------------------------------------------------------------------------------------------------
def _env_from_script(script: Path) -> dict[str, str]:
    out = subprocess.run(
        ["bash", "-c", f'. "{script}" >/dev/null && env -0'],
        check=True,
        capture_output=True,
        cwd=script.parent.parent,
    ).stdout
    return dict(item.split("=", 1) for item in out.decode().split("\0") if "=" in item)


def ros_environment(domain_id: int | None = None) -> dict[str, str]:
    """Environment in which ``ros2 run gear_rotor_sim ...`` works, isolated on one DDS domain.

    Uses the current environment when it already resolves the package (a sourced workspace or
    ``. scripts/env.sh``), else the environment that ``scripts/env.sh`` of this checkout sets up.
    Discovery is restricted to this host; ``domain_id`` defaults to a random id in 1..200 so that
    concurrent runs on one machine do not see each other.
    """
    env = dict(os.environ)
    try:
        from ament_index_python.packages import get_package_prefix

        get_package_prefix(PACKAGE)
    except Exception:  # package not in the current ament index: use the checkout's env.sh
        script = REPO_ROOT / "scripts" / "env.sh"
        if script.is_file():
            env = _env_from_script(script)
    env["ROS_DOMAIN_ID"] = str(domain_id if domain_id is not None else random.randint(1, 200))
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env.pop("ROS_LOCALHOST_ONLY", None)  # deprecated in Jazzy; conflicts with the range setting
    env["PYTHONUNBUFFERED"] = "1"
    return env


def executable(name: str, env: dict[str, str] | None = None) -> Path:
    """``<prefix>/lib/gear_rotor_sim/<name>``, the file ``ros2 run gear_rotor_sim <name>`` executes."""
    env = env or dict(os.environ)
    paths = [p for p in env.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    for prefix in paths:  # what ament_index_python.get_package_prefix does, for a given environment
        marker = Path(prefix) / "share" / "ament_index" / "resource_index" / "packages" / PACKAGE
        if marker.is_file():
            exe = Path(prefix) / "lib" / PACKAGE / name
            if not exe.is_file():
                raise FileNotFoundError(f"{exe} does not exist: rebuild with scripts/setup_env.sh")
            return exe
    raise FileNotFoundError(f"package {PACKAGE} not found on AMENT_PREFIX_PATH={paths}")


def share_file(relative: str, env: dict[str, str] | None = None) -> Path:
    """A file installed under ``share/gear_rotor_sim`` (falls back to the source tree)."""
    exe = executable("simulator", env)
    candidate = exe.parents[2] / "share" / PACKAGE / relative
    return candidate if candidate.is_file() else REPO_ROOT / relative


def start_process(
    name: str, args: Sequence[str], env: dict[str, str], log_path: Path | None = None
) -> subprocess.Popen:
    """Start an installed executable of the package; output to ``log_path`` (or inherited)."""
    out = open(log_path, "wb") if log_path is not None else None  # closed by the child's exit
    return subprocess.Popen(
        [str(executable(name, env)), *args],
        env=env,
        stdout=out,
        stderr=subprocess.STDOUT if out is not None else None,
        cwd=str(REPO_ROOT),
    )


def stop_process(proc: subprocess.Popen, sig: int = signal.SIGINT, timeout_s: float = 30.0) -> int:
    """Send ``sig`` and wait; SIGKILL after ``timeout_s``. Returns the exit status."""
    if proc.poll() is None:
        proc.send_signal(sig)
        try:
            return proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
            return -signal.SIGKILL
    return int(proc.returncode)


def rss_bytes(pid: int) -> int:
    """Resident set size of a process (Linux ``/proc``), bytes."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) * 1024
    raise RuntimeError(f"no VmRSS for pid {pid}")


def wait_for(predicate: Callable[[], bool], timeout_s: float, what: str, poll_s: float = 0.02) -> None:
    """Wait until ``predicate()``; TimeoutError naming ``what`` otherwise."""
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise TimeoutError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(poll_s)


# ------------------------------------------------------------------------------------------------
# the probe: an rclpy node in this process that records what the simulator publishes
# ------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class ChunkRecord:
    """One received ``VibrationChunk``."""

    wall: float
    sequence: int
    first_index: int
    stamp: float
    sample_rate_hz: float
    speed_rpm: float
    temperature_c: float
    channels: tuple[str, ...]
    data: np.ndarray  # (n_samples, n_channels)

    @property
    def n_samples(self) -> int:
        return int(self.data.shape[0])


def continuity(records: Sequence[ChunkRecord]) -> dict[str, int]:
    """Sequence-number jumps and sample-index gaps/overlaps between consecutive records."""
    seq_gaps = sum(1 for a, b in itertools.pairwise(records) if b.sequence != a.sequence + 1)
    idx_gaps = sum(1 for a, b in itertools.pairwise(records) if b.first_index != a.first_index + a.n_samples)
    return {"messages": len(records), "sequence_jumps": seq_gaps, "sample_gaps_or_overlaps": idx_gaps}


def stitch(records: Sequence[ChunkRecord], t_from: float, t_to: float) -> tuple[np.ndarray, np.ndarray]:
    """Samples with simulated time in ``[t_from, t_to)`` from contiguous records: (time, data)."""
    times, blocks = [], []
    for r in records:
        t = r.stamp + np.arange(r.n_samples) / r.sample_rate_hz
        keep = (t >= t_from) & (t < t_to)
        if keep.any():
            times.append(t[keep])
            blocks.append(r.data[keep])
    if not blocks:
        raise ValueError(f"no samples in [{t_from}, {t_to})")
    return np.concatenate(times), np.concatenate(blocks, axis=0)


class Probe:
    """rclpy node spun in a background thread: subscribes to streams, /diagnostics, indicators, /clock.

    Parameters
    ----------
    topics : sequence of str
        ``VibrationChunk`` topics to record.
    reliable : bool
        Subscribe reliably (matches only reliable publishers) or best effort.
    keep_data : bool
        Keep the sample arrays (else only the metadata of each chunk).
    transient_local : bool
        Ask for the history a ``stream_qos.durability: transient_local`` publisher keeps (a probe
        that joins after the node started still gets the stream from its first chunk).
    """

    def __init__(
        self,
        topics: Sequence[str] = STREAM_TOPICS,
        reliable: bool = True,
        keep_data: bool = True,
        transient_local: bool = False,
    ):
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from gear_rotor_msgs.msg import ConditionIndicators, VibrationChunk
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import (
            DurabilityPolicy,
            HistoryPolicy,
            QoSProfile,
            ReliabilityPolicy,
            qos_profile_sensor_data,
        )
        from rosgraph_msgs.msg import Clock
        from std_msgs.msg import Float64

        self._rclpy = rclpy
        self._context = rclpy.Context()
        rclpy.init(context=self._context)
        self.node = rclpy.create_node(f"gear_rotor_probe_{os.getpid()}", context=self._context)
        self.lock = threading.Lock()
        self.chunks: dict[str, list[ChunkRecord]] = {t: [] for t in topics}
        self.diagnostics: list = []
        self.indicators: list = []
        self.clock: list[float] = []
        self.keep_data = keep_data
        if reliable:
            # keep all: the middleware's receive thread stores every chunk until this (Python) executor
            # takes it; a keep-last reader drops the oldest unread ones when the executor lags
            qos = QoSProfile(
                depth=200, history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE
            )
        else:
            qos = QoSProfile(depth=qos_profile_sensor_data.depth, reliability=ReliabilityPolicy.BEST_EFFORT)
        if transient_local:
            qos.durability = DurabilityPolicy.TRANSIENT_LOCAL
        for topic in topics:
            self.node.create_subscription(VibrationChunk, topic, self._chunk_cb(topic), qos)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._store("diagnostics"), 50)
        self.node.create_subscription(
            ConditionIndicators, "/gear_rotor/indicators", self._store("indicators"), 50
        )
        self.node.create_subscription(
            Clock, "/clock", lambda m: self.clock.append(m.clock.sec + m.clock.nanosec * 1e-9), 10
        )
        setpoint_qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.speed_pub = self.node.create_publisher(Float64, "/gear_rotor/setpoint/speed_rpm", setpoint_qos)
        self.temperature_pub = self.node.create_publisher(
            Float64, "/gear_rotor/setpoint/temperature_c", setpoint_qos
        )
        self._float64 = Float64
        self._executor = SingleThreadedExecutor(context=self._context)
        self._executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, name="probe_spin", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set():
            self._executor.spin_once(timeout_sec=0.05)

    def _chunk_cb(self, topic: str) -> Callable:
        def cb(msg) -> None:
            n_ch = max(1, len(msg.channel_names))
            data = (
                np.array(msg.data, dtype=np.float64).reshape(-1, n_ch)
                if self.keep_data
                else np.empty((0, n_ch))
            )
            n = len(msg.data) // n_ch
            if not self.keep_data:
                data = np.empty((n, 0))
            rec = ChunkRecord(
                time.monotonic(),
                int(msg.sequence),
                int(msg.first_sample_index),
                msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9,
                float(msg.sample_rate_hz),
                float(msg.speed_rpm),
                float(msg.temperature_c),
                tuple(msg.channel_names),
                data,
            )
            with self.lock:
                self.chunks[topic].append(rec)

        return cb

    def _store(self, attr: str) -> Callable:
        def cb(msg) -> None:
            with self.lock:
                getattr(self, attr).append((time.monotonic(), msg))

        return cb

    def records(self, topic: str) -> list[ChunkRecord]:
        with self.lock:
            return list(self.chunks[topic])

    def sim_time(self, topic: str = "/gear_rotor/dte") -> float:
        """Simulated time at the end of the newest received chunk (-1 before any)."""
        with self.lock:
            recs = self.chunks[topic]
            if not recs:
                return -1.0
            r = recs[-1]
        return r.stamp + r.n_samples / r.sample_rate_hz

    def wait_sim_time(self, t: float, timeout_s: float, topic: str = "/gear_rotor/dte") -> None:
        wait_for(lambda: self.sim_time(topic) >= t, timeout_s, f"simulated time {t:.3f} s on {topic}")

    def latest_status(self, name_suffix: str) -> dict[str, str] | None:
        """Key/values (plus ``level`` and ``message``) of the newest diagnostics status named ``*suffix``."""
        with self.lock:
            diags = list(self.diagnostics)
        for _wall, arr in reversed(diags):
            for st in arr.status:
                if st.name.endswith(name_suffix):
                    kv = {k.key: k.value for k in st.values}
                    kv["level"] = str(st.level[0] if isinstance(st.level, bytes) else st.level)
                    kv["message"] = st.message
                    return kv
        return None

    def wait_subscribers(self, timeout_s: float = 20.0) -> None:
        """Wait until the simulator's setpoint subscriptions are matched."""
        wait_for(
            lambda: (
                self.speed_pub.get_subscription_count() > 0
                and self.temperature_pub.get_subscription_count() > 0
            ),
            timeout_s,
            "the simulator's setpoint subscriptions",
        )

    def set_speed(self, rpm: float) -> None:
        self.speed_pub.publish(self._float64(data=float(rpm)))

    def set_temperature(self, celsius: float) -> None:
        self.temperature_pub.publish(self._float64(data=float(celsius)))

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self._executor.shutdown()
        self.node.destroy_node()
        self._context.try_shutdown()


# ------------------------------------------------------------------------------------------------
# physics references used in the summary (the same the acceptance tests use)
# ------------------------------------------------------------------------------------------------
def mesh_frequency_hz(speed_rpm: float, pinion_teeth: int = 29) -> float:
    """Mesh frequency of the input pinion, Hz."""
    return pinion_teeth * speed_rpm / 60.0


def thermal_axial_force(
    delta_t_c: float,
    youngs_modulus_pa: float = 2.0e11,
    length_m: float = 0.14,
    diameter_m: float = 0.030,
    bearing_k_axial: float = 2.28e7,
    expansion_per_c: float = 1.17e-5,
) -> float:
    """Axial force on the bearings of a shaft held at both ends: ``k_s a dT L / (1 + 2 k_s / k_b)``.

    ``k_s = E A / L`` is the shaft's axial stiffness; the two bearings (``k_b`` each, A# by default)
    act in series with it. Defaults: the paper's shafts (140 mm, 30 mm) and A# bearings.
    """
    k_s = youngs_modulus_pa * math.pi * diameter_m**2 / 4.0 / length_m
    return k_s * expansion_per_c * delta_t_c * length_m / (1.0 + 2.0 * k_s / bearing_k_axial)


# ------------------------------------------------------------------------------------------------
# the demo
# ------------------------------------------------------------------------------------------------
def _read_mcap(path: Path) -> dict[str, list[tuple[int, int, int]]]:
    """Per topic: (sequence, first_sample_index, n_samples) of every recorded VibrationChunk; other
    message types (the fault ground truth) as (index, 0, 0)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out: dict[str, list[tuple[int, int, int]]] = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, _message, msg in reader.iter_decoded_messages():
            if schema is None or not schema.name.endswith("VibrationChunk"):
                recs = out.setdefault(channel.topic, [])
                recs.append((len(recs), 0, 0))
                continue
            n_ch = max(1, len(msg.channel_names))
            out.setdefault(channel.topic, []).append(
                (msg.sequence, msg.first_sample_index, len(msg.data) // n_ch)
            )
    for recs in out.values():
        recs.sort()
    return out


def _mcap_continuity(recs: list[tuple[int, int, int]]) -> tuple[int, int]:
    seq = sum(1 for a, b in itertools.pairwise(recs) if b[0] != a[0] + 1)
    idx = sum(1 for a, b in itertools.pairwise(recs) if b[1] != a[1] + a[2])
    return seq, idx


def startup_line(log: Path) -> str:
    """The simulator node's ``start-up:`` log line (first message after the constructor / process start)."""
    try:
        for line in log.read_text(encoding="utf-8", errors="replace").splitlines():
            if "start-up:" in line:
                return line.split("start-up:", 1)[1].strip()
    except OSError:
        pass
    return "(no start-up line yet)"


def set_faults(probe: Probe, faults_yaml: str, timeout_s: float = 30.0) -> tuple[bool, str]:
    """Call the simulator's ``~/set_faults`` service from the probe's node."""
    from gear_rotor_msgs.srv import SetFaults

    client = probe.node.create_client(SetFaults, "/gear_rotor_simulator/set_faults")
    if not client.wait_for_service(timeout_sec=timeout_s):
        return False, "service /gear_rotor_simulator/set_faults not available"
    future = client.call_async(SetFaults.Request(faults_yaml=faults_yaml))
    wait_for(future.done, timeout_s, "the set_faults response")
    res = future.result()
    return bool(res.success), str(res.message)


def print_fault_effect(indicators: Sequence, t_from: float, t_fault: float, t_after: float) -> None:
    """Median indicators of the monitor's windows wholly before the fault and wholly after it
    (``indicators``: the probe's ``(wall time, ConditionIndicators)`` pairs)."""
    msgs = [m for _, m in indicators]

    def stamp(m) -> float:
        return m.header.stamp.sec + m.header.stamp.nanosec * 1e-9

    before = [m for m in msgs if t_from <= stamp(m) and stamp(m) + m.window_s <= t_fault]
    after = [m for m in msgs if stamp(m) >= t_after]
    if not before or not after:
        print(f"not enough monitor windows (before {len(before)}, after {len(after)})")
        return
    print(f"{len(before)} windows before, {len(after)} after (medians)")
    for k, name in enumerate(before[0].channel_names):
        for field in ("kurtosis", "crest_factor", "sideband_amplitude", "rms"):
            b = float(np.median([getattr(m, field)[k] for m in before]))
            a = float(np.median([getattr(m, field)[k] for m in after]))
            ratio = a / b if b else float("nan")
            print(f"{name:10s} {field:18s} {b:12.4g} -> {a:12.4g}  (x {ratio:.2f})")


def run_demo(
    out_dir: Path,
    real_time_factor: float,
    speed_to: float,
    temperature_to: float,
    speed_ramp: float = 1.0e7,
    temperature_ramp: float = 1.0e6,
) -> int:
    """Run the scenario and print the summary; returns a process exit status."""
    from gear_rotor_sim.indicators import dominant_frequency

    out_dir.mkdir(parents=True, exist_ok=True)
    mcap_path = (out_dir / "demo.mcap").resolve()
    for stale in (mcap_path, mcap_path.with_name(mcap_path.name + ".part")):
        stale.unlink(missing_ok=True)
    env = ros_environment()
    params = share_file("config/simulator_node.yaml", env)
    sim_args = [
        "--ros-args",
        "--params-file",
        str(params),
        "-p",
        "recording.enabled:=true",
        "-p",
        f"recording.path:={mcap_path}",
        "-p",
        f"real_time_factor:={float(real_time_factor)}",
        "-p",
        "stream_qos.reliability:=reliable",
        "-p",
        "stream_qos.depth:=100",
        "-p",
        f"speed_ramp_rpm_per_s:={float(speed_ramp)}",
        "-p",
        f"temperature_ramp_c_per_s:={float(temperature_ramp)}",
    ]
    print(f"[demo] ROS_DOMAIN_ID={env['ROS_DOMAIN_ID']}; starting {executable('simulator', env)}")
    print(f"[demo]   --params-file {params}, recording to {mcap_path}; logs in {out_dir}")
    launched = time.monotonic()
    sim = start_process("simulator", sim_args, env, out_dir / "simulator.log")
    mon = start_process(
        "monitor",
        ["--ros-args", "--params-file", str(share_file("config/monitor_node.yaml", env))],
        env,
        out_dir / "monitor.log",
    )
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
    probe = Probe()
    status = 0
    wall0 = time.monotonic()
    try:
        probe.wait_subscribers(timeout_s=120.0)
        probe.wait_sim_time(0.0, timeout_s=120.0)
        t_start = probe.sim_time()
        print(
            f"[demo] node up after {time.monotonic() - wall0:.1f} s; streaming from sim time {t_start:.2f} s"
        )
        first_message_s = time.monotonic() - launched
        print(
            f"[demo] start-up: first message received {first_message_s:.1f} s after launching the simulator"
        )
        # phase 1: 3000 rpm, 25 C
        t_speed = t_start + 2.0
        probe.wait_sim_time(t_speed, timeout_s=120.0)
        t_speed = probe.sim_time()
        print(f"[demo] t={t_speed:.2f} s: speed setpoint {speed_to} rpm")
        probe.set_speed(speed_to)
        for bad in (float("nan"), float("inf"), -100.0, 1.0e9):
            probe.set_speed(bad)
        probe.set_temperature(float("nan"))
        print("[demo]   also sent invalid setpoints: speed nan, inf, -100, 1e9; temperature nan (refused)")
        ramp_s = abs(speed_to - 3000.0) / speed_ramp
        t_temp = t_speed + ramp_s + 1.5
        probe.wait_sim_time(t_temp, timeout_s=120.0)
        t_temp = probe.sim_time()
        print(f"[demo] t={t_temp:.2f} s: temperature setpoint {temperature_to} C")
        probe.set_temperature(temperature_to)
        t_end = t_temp + abs(temperature_to - 25.0) / temperature_ramp + 1.5
        probe.wait_sim_time(t_end, timeout_s=300.0)
        # phase 3: a fault through the node's service
        t_fault = probe.sim_time()
        ok, message = set_faults(probe, DEMO_FAULT)
        verdict = "accepted" if ok else "REFUSED"
        print(f"[demo] t={t_fault:.2f} s: ~/set_faults {DEMO_FAULT}: {verdict}: {message}")
        probe.wait_sim_time(t_fault + 2.0, timeout_s=300.0)
        time.sleep(1.2)  # one more /diagnostics period
    except TimeoutError as exc:
        print(f"[demo] ERROR: {exc}; see {out_dir}/simulator.log", file=sys.stderr)
        status = 1
    finally:
        wall = time.monotonic() - wall0
        diag = probe.latest_status(": simulation")
        setpoint_diag = probe.latest_status(": setpoints")
        rc_sim = stop_process(sim, signal.SIGINT)
        rc_mon = stop_process(mon, signal.SIGINT)
        probe.close()
    print(f"[demo] simulator exited with {rc_sim} (SIGINT), monitor with {rc_mon}; {wall:.1f} s wall")
    print(f"[demo] start-up (simulator log): {startup_line(out_dir / 'simulator.log')}")
    if status:
        return status

    print("\n=== published (received by the demo's subscriber) ===")
    for topic in STREAM_TOPICS:
        recs = probe.records(topic)
        if not recs:
            print(f"{topic:28s} no messages")
            continue
        c = continuity(recs)
        span_wall = recs[-1].wall - recs[0].wall
        rate = (len(recs) - 1) / span_wall if span_wall > 0 else float("nan")
        print(
            f"{topic:28s} {c['messages']:5d} msgs {rate:7.1f} msg/s, {recs[0].sample_rate_hz:.0f} Hz x "
            f"{len(recs[0].channels)} ch, seq {recs[0].sequence}..{recs[-1].sequence}, "
            f"jumps {c['sequence_jumps']}, sample gaps/overlaps {c['sample_gaps_or_overlaps']}"
        )
    n_ind = len(probe.indicators)
    print(f"{'/gear_rotor/indicators':28s} {n_ind:5d} msgs (monitor node)")
    print(f"{'/diagnostics':28s} {len(probe.diagnostics):5d} msgs")
    if diag:
        print(
            f"achieved real-time factor {diag['achieved_real_time_factor']} (requested "
            f"{diag['requested_real_time_factor']}), sim time {float(diag['sim_time_s']):.2f} s, solver "
            f"{diag['solver_health']}, contact-loss fraction {diag['contact_loss_fraction']}"
        )
    if setpoint_diag:
        print(
            f"setpoints: {setpoint_diag['accepted_total']} accepted, "
            f"{setpoint_diag['refused_total']} refused "
            f"(last: {setpoint_diag['last_refusal']})"
        )

    dte = probe.records("/gear_rotor/dte")
    fs = dte[0].sample_rate_hz
    print("\n=== DTE dominant line vs mesh frequency (29 teeth) ===")
    for label, t0, rpm in (("before", t_speed - 1.0, 3000.0), ("after", t_temp - 1.0, speed_to)):
        _t, x = stitch(dte, t0, t0 + 1.0)
        f_dom = dominant_frequency(x[:, 0], fs, min_hz=20.0)
        f_mesh = mesh_frequency_hz(rpm)
        print(f"{label:6s} speed step: {rpm:7.1f} rpm  dominant {f_dom:8.1f} Hz  mesh {f_mesh:8.1f} Hz")
    forces = probe.records("/gear_rotor/bearing_forces")
    print("\n=== axial bearing force before/after the temperature step ===")
    _t, before = stitch(forces, t_temp - 1.0, t_temp)
    _t, after = stitch(forces, t_end - 1.0, t_end)
    expected = thermal_axial_force(temperature_to - 25.0)
    for k, name in enumerate(forces[0].channels):
        if name.endswith("_fz"):
            fb, fa = float(before[:, k].mean()), float(after[:, k].mean())
            print(f"{name:12s} {fb:10.1f} N -> {fa:10.1f} N  (|change| {abs(fa - fb):8.1f} N)")
    print(
        "thermal-expansion estimate k_s a dT L / (1 + 2 k_s / k_b), "
        f"dT = {temperature_to - 25.0:g} C: {expected:.1f} N"
    )

    print(f"\n=== monitor indicators of /gear_rotor/dte before/after the fault (t = {t_fault:.2f} s) ===")
    print_fault_effect(probe.indicators, t_temp + 0.2, t_fault, t_fault + 0.3)

    print(f"\n=== recording {mcap_path} ===")
    if mcap_path.is_file():
        rec = _read_mcap(mcap_path)
        print(f"size {mcap_path.stat().st_size / 1e6:.1f} MB")
        for topic, items in sorted(rec.items()):
            seq_j, idx_j = _mcap_continuity(items)
            print(f"{topic:28s} {len(items):5d} msgs, sequence jumps {seq_j}, sample gaps/overlaps {idx_j}")
    else:
        print("missing!")
        status = 1
    return status


def main(argv: list[str] | None = None) -> int:
    """Command line of the demo (``python -m gear_rotor_sim.ros.demo``)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=REPO_ROOT / "out" / "demo", help="output folder")
    parser.add_argument("--real-time-factor", type=float, default=2.0, help="requested RTF of the node")
    parser.add_argument("--speed-rpm", type=float, default=5000.0, help="speed after the step, rpm")
    parser.add_argument("--temperature-c", type=float, default=125.0, help="temperature after the step, C")
    parser.add_argument("--speed-ramp", type=float, default=1.0e7, help="speed ramp, rpm/s (default: a step)")
    parser.add_argument(
        "--temperature-ramp", type=float, default=1.0e6, help="temperature ramp, C/s (default: a step)"
    )
    args = parser.parse_args(argv)
    return run_demo(
        args.out,
        args.real_time_factor,
        args.speed_rpm,
        args.temperature_c,
        args.speed_ramp,
        args.temperature_ramp,
    )


if __name__ == "__main__":
    raise SystemExit(main())
