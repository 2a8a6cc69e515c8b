"""Acceptance tests of the ROS 2 nodes with real rclpy (issue 4).

The installed executables are started the way ``ros2 run gear_rotor_sim <exe>`` resolves them
(ament index prefix + ``lib/gear_rotor_sim/<exe>``), in the environment of ``scripts/env.sh``, on a
random DDS domain restricted to this host. One module-scoped *experiment* drives a single simulator
process through a scenario (steady run, speed step, invalid setpoints, a setpoint burst,
temperature step, runtime parameter changes, SIGTERM) while this process records everything it
publishes; the tests then check the records.
"""

from __future__ import annotations

import math
import os
import random
import re
import signal
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

try:
    import rclpy  # noqa: F401
    from gear_rotor_msgs.msg import VibrationChunk  # noqa: F401
except ImportError as exc:  # pragma: no cover - CI has both
    pytest.skip(
        f"rclpy or gear_rotor_msgs not importable ({exc}); run `bash scripts/setup_env.sh` "
        "and `. scripts/env.sh`",
        allow_module_level=True,
    )

from gear_rotor_sim.indicators import compute_indicators, dominant_frequency
from gear_rotor_sim.ros.demo import (
    ChunkRecord,
    Probe,
    continuity,
    executable,
    ros_environment,
    rss_bytes,
    share_file,
    stitch,
    stop_process,
    wait_for,
)

pytestmark = pytest.mark.ros

DOMAIN_ID = random.randint(1, 200)
CHUNK_S = 0.1
FS = 20000.0
REQUESTED_RTF = 10.0
SPEED_0, SPEED_1 = 3000.0, 5000.0
TEMP_0, TEMP_1 = 25.0, 125.0
PINION_TEETH = 29
STARTUP_TIMEOUT_S = 180.0
SIM_TIMEOUT_S = 120.0
BURST_S = 2.0


@dataclass
class Experiment:
    env: dict[str, str]
    mcap: Path
    probe: Probe
    sim: subprocess.Popen
    mon: subprocess.Popen
    marks: dict[str, float] = field(default_factory=dict)
    diag: dict[str, dict] = field(default_factory=dict)
    bad_setpoints: int = 0
    rss: dict[str, int] = field(default_factory=dict)
    burst_wall: tuple[float, float] = (0.0, 0.0)
    burst_sent: int = 0
    param_results: dict[str, tuple[bool, str]] = field(default_factory=dict)
    sim_rc: int | None = None
    sim_log: str = ""

    def records(self, topic: str = "/gear_rotor/dte") -> list[ChunkRecord]:
        return self.probe.records(topic)


def _checkable_indicators(probe: Probe) -> list[tuple[object, np.ndarray]]:
    """The monitor's indicator messages whose whole window this process received on the DTE stream,
    with that window (a best-effort subscriber under load may miss a chunk or the first ones)."""
    recs = probe.records("/gear_rotor/dte")
    out = []
    for _wall, msg in list(probe.indicators):
        t_first = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        n = round(msg.window_s * FS)
        try:
            _t, window = stitch(recs, t_first - 0.5 / FS, t_first + (n - 0.5) / FS)
        except ValueError:  # no sample of the window received
            continue
        if window.shape[0] == n:
            out.append((msg, window))
    return out


def _first_time(records: list[ChunkRecord], predicate) -> float:
    for r in records:
        if predicate(r):
            return r.stamp
    raise AssertionError("condition never reached in the stream")


def _set_parameters(probe: Probe, values: dict[str, object]) -> dict[str, tuple[bool, str]]:
    """Set parameters one by one through the node's parameter service (real rclpy client)."""
    from rclpy.parameter import Parameter
    from rclpy.parameter_client import AsyncParameterClient

    client = AsyncParameterClient(probe.node, "gear_rotor_simulator")
    assert client.wait_for_services(timeout_sec=20.0), "parameter services of the simulator not found"
    out = {}
    for name, value in values.items():
        future = client.set_parameters([Parameter(name, value=value)])
        wait_for(future.done, 20.0, f"set_parameters({name})")
        res = future.result().results[0]
        out[name] = (bool(res.successful), str(res.reason))
    return out


def _burst(probe: Probe, duration_s: float, rate_hz: float) -> int:
    """Publish speed and temperature setpoints at ``rate_hz``, valid (current targets) and invalid mixed."""
    bad = [math.nan, math.inf, -math.inf, -5.0, 1.0e9]
    period = 1.0 / rate_hz
    t0 = time.monotonic()
    sent = 0
    while time.monotonic() - t0 < duration_s:
        k = sent % 4
        if k == 0:
            probe.set_speed(SPEED_1)
        elif k == 1:
            probe.set_speed(bad[sent % len(bad)])
        elif k == 2:
            probe.set_temperature(TEMP_0)
        else:
            probe.set_temperature(bad[sent % len(bad)])
        sent += 1
        delay = t0 + sent * period - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    return sent


@pytest.fixture(scope="module")
def experiment(tmp_path_factory: pytest.TempPathFactory) -> Experiment:
    env = ros_environment(DOMAIN_ID)
    os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
    os.environ.pop("ROS_LOCALHOST_ONLY", None)
    tmp = tmp_path_factory.mktemp("ros_node")
    mcap = tmp / "run.mcap"
    sim_args = [
        "--ros-args",
        "--params-file",
        str(share_file("config/simulator_node.yaml", env)),
        "-p",
        f"real_time_factor:={REQUESTED_RTF}",
        "-p",
        "stream_qos.reliability:=reliable",
        "-p",
        "stream_qos.depth:=200",
        "-p",
        "speed_ramp_rpm_per_s:=1.0e7",
        "-p",
        "temperature_ramp_c_per_s:=1.0e6",
        "-p",
        "recording.enabled:=true",
        "-p",
        f"recording.path:={mcap}",
        "-p",
        "publish_clock:=true",
        "-p",
        "diagnostics_period_s:=0.25",
    ]
    mon_args = [
        "--ros-args",
        "--params-file",
        str(share_file("config/monitor_node.yaml", env)),
        "-p",
        "window_s:=0.2",
        "-p",
        "stream_qos.reliability:=reliable",
        "-p",
        "stream_qos.depth:=200",
    ]
    sim_log = tmp / "simulator.log"
    with open(sim_log, "wb") as log:
        sim = subprocess.Popen(
            [str(executable("simulator", env)), *sim_args], env=env, stdout=log, stderr=log
        )
    with open(tmp / "monitor.log", "wb") as log:
        mon = subprocess.Popen([str(executable("monitor", env)), *mon_args], env=env, stdout=log, stderr=log)
    probe = Probe()
    ex = Experiment(env, mcap, probe, sim, mon)
    try:
        probe.wait_subscribers(STARTUP_TIMEOUT_S)
        probe.wait_sim_time(0.0, STARTUP_TIMEOUT_S)
        t0 = probe.sim_time()
        ex.marks["start"] = t0
        # steady 3000 rpm
        probe.wait_sim_time(t0 + 0.7, SIM_TIMEOUT_S)
        ex.marks["speed_step_sent"] = probe.sim_time()
        probe.set_speed(SPEED_1)
        wait_for(
            lambda: any(r.speed_rpm >= SPEED_1 - 1e-6 for r in probe.records("/gear_rotor/dte")),
            SIM_TIMEOUT_S,
            "the speed to reach the setpoint",
        )
        t_speed = _first_time(probe.records("/gear_rotor/dte"), lambda r: r.speed_rpm >= SPEED_1 - 1e-6)
        ex.marks["speed_reached"] = t_speed
        probe.wait_sim_time(t_speed + 0.8, SIM_TIMEOUT_S)
        # invalid setpoints: refused, state unchanged
        bad = [math.nan, math.inf, -1.0, 1.0e9]
        for v in bad:
            probe.set_speed(v)
        for v in (math.nan, -300.0, 5000.0):
            probe.set_temperature(v)
        ex.bad_setpoints = len(bad) + 3
        # the next /diagnostics after the refusals (period 1 s wall; a fixed sleep raced the first
        # reports, which a loaded machine can delay or a late discovery lose)
        wait_for(
            lambda: (
                int((probe.latest_status(": setpoints") or {}).get("refused_total", 0)) >= ex.bad_setpoints
            ),
            SIM_TIMEOUT_S,
            "diagnostics counting the refused setpoints",
        )
        ex.diag["after_bad"] = probe.latest_status(": setpoints") or {}
        ex.diag["sim_after_bad"] = probe.latest_status(": simulation") or {}
        # burst of mixed setpoints at 1 kHz
        ex.rss["before_burst"] = rss_bytes(sim.pid)
        w0 = time.monotonic()
        ex.burst_sent = _burst(probe, BURST_S, 1000.0)
        ex.burst_wall = (w0, time.monotonic())
        time.sleep(1.0)
        ex.rss["after_burst"] = rss_bytes(sim.pid)
        ex.diag["after_burst"] = probe.latest_status(": setpoints") or {}
        ex.diag["sim_after_burst"] = probe.latest_status(": simulation") or {}
        # temperature step
        ex.marks["temperature_step_sent"] = probe.sim_time()
        probe.set_temperature(TEMP_1)
        wait_for(
            lambda: any(
                r.temperature_c >= TEMP_1 - 1e-6 for r in probe.records("/gear_rotor/bearing_forces")
            ),
            SIM_TIMEOUT_S,
            "the temperature to reach the setpoint",
        )
        t_temp = _first_time(
            probe.records("/gear_rotor/bearing_forces"), lambda r: r.temperature_c >= TEMP_1 - 1e-6
        )
        ex.marks["temperature_reached"] = t_temp
        probe.wait_sim_time(t_temp + 0.6, SIM_TIMEOUT_S)
        # runtime parameter changes through the parameter service
        ex.param_results = _set_parameters(
            probe,
            {
                "real_time_factor": -1.0,
                "bearing_type": "B#",
                "noise.dte.stddev": [1.0, 2.0, 3.0],
                "chunk_period_s": 0.0010001,
                "limits.speed_rpm_max": 20000.0,
            },
        )
        assert mon.poll() is None, f"monitor exited with {mon.returncode}: see {tmp / 'monitor.log'}"
        wait_for(
            lambda: len(_checkable_indicators(probe)) >= 3,
            SIM_TIMEOUT_S,
            "condition indicators from the monitor over windows this process received",
        )
        time.sleep(0.6)
        ex.diag["final"] = probe.latest_status(": simulation") or {}
        ex.marks["end_wall"] = time.monotonic()
    finally:
        ex.sim_rc = stop_process(sim, signal.SIGTERM, timeout_s=60.0)
        stop_process(mon, signal.SIGINT, timeout_s=30.0)
        time.sleep(0.2)
        probe.close()
        ex.sim_log = sim_log.read_text(errors="replace")
    return ex


def test_message_rate_and_stamps(experiment: Experiment) -> None:
    recs = experiment.records()
    assert len(recs) >= 20
    for r in recs:
        assert r.sample_rate_hz == FS
        assert r.n_samples == round(CHUNK_S * FS)
        assert r.channels == ("dte", "mesh_force")
        # stamps follow simulated time: the stamp is the time of the first sample
        assert r.stamp == pytest.approx(r.first_index / FS, abs=1e-9)
    stamps = np.array([r.stamp for r in recs])
    np.testing.assert_allclose(np.diff(stamps), CHUNK_S, atol=1e-9)
    # wall-clock rate agrees with the achieved real-time factor the node reports, never above the request
    diag = experiment.diag["final"]
    achieved = float(diag["achieved_real_time_factor"])
    assert 0.0 < achieved <= 1.15 * REQUESTED_RTF, diag
    recent = [r for r in recs if r.wall >= recs[-1].wall - 3.0]
    wall_rate = (len(recent) - 1) / (recent[-1].wall - recent[0].wall)
    assert wall_rate * CHUNK_S == pytest.approx(achieved, rel=0.5), (wall_rate, achieved)


def test_streams_are_continuous(experiment: Experiment) -> None:
    for topic in ("/gear_rotor/dte", "/gear_rotor/bearing_forces", "/gear_rotor/displacements"):
        recs = experiment.records(topic)
        c = continuity(recs)
        assert c["messages"] >= 20, topic
        assert c["sequence_jumps"] == 0 and c["sample_gaps_or_overlaps"] == 0, (topic, c)


def test_speed_setpoint_moves_dte_line_to_mesh_frequency(experiment: Experiment) -> None:
    recs = experiment.records()
    t0, t_sent = experiment.marks["start"], experiment.marks["speed_step_sent"]
    _t, before = stitch(recs, t0 + 0.1, t_sent)
    f_before = dominant_frequency(before[:, 0], FS, min_hz=100.0)
    t_speed = experiment.marks["speed_reached"]
    _t, after = stitch(recs, t_speed + 0.3, t_speed + 0.8)
    f_after = dominant_frequency(after[:, 0], FS, min_hz=100.0)
    f_mesh_0 = PINION_TEETH * SPEED_0 / 60.0  # 1450 Hz
    f_mesh_1 = PINION_TEETH * SPEED_1 / 60.0  # 2416.7 Hz
    assert f_before == pytest.approx(f_mesh_0, abs=4.0)
    assert f_after == pytest.approx(f_mesh_1, abs=4.0)


def test_temperature_step_raises_axial_bearing_force(experiment: Experiment) -> None:
    recs = experiment.records("/gear_rotor/bearing_forces")
    t_sent, t_temp = experiment.marks["temperature_step_sent"], experiment.marks["temperature_reached"]
    _t, before = stitch(recs, t_sent - 0.3, t_sent)
    _t, after = stitch(recs, t_temp + 0.2, t_temp + 0.6)
    channels = recs[0].channels
    # axial force of a shaft (L = 0.14 m, d = 30 mm) held by two A# bearings (k_b = 2.28e7 N/m):
    # F = k_s a dT L / (1 + 2 k_s / k_b), k_s = E A / L, E at the new temperature (Table 1: 200 GPa)
    length, area, alpha, k_b = 0.14, math.pi * 0.030**2 / 4.0, 1.17e-5, 2.28e7
    k_s = 200.0e9 * area / length
    expected = k_s * alpha * (TEMP_1 - TEMP_0) * length / (1.0 + 2.0 * k_s / k_b)  # about 1.85 kN
    deltas = {}
    for k in range(1, 5):
        i = channels.index(f"bearing{k}_fz")
        f_before, f_after = before[:, i].mean(), after[:, i].mean()
        assert abs(f_after) > abs(f_before), (k, f_before, f_after)
        deltas[k] = f_after - f_before
        assert abs(deltas[k]) == pytest.approx(expected, rel=0.05), (k, deltas[k], expected)
    # the two bearings of a shaft push in opposite directions
    assert deltas[1] * deltas[2] < 0 and deltas[3] * deltas[4] < 0


def test_bad_setpoints_refused_and_node_keeps_publishing(experiment: Experiment) -> None:
    sp = experiment.diag["after_bad"]
    assert int(sp["refused_total"]) >= experiment.bad_setpoints, sp
    assert "refused" in sp["message"] or int(sp["refused_since_last_report"]) >= 0
    sim = experiment.diag["sim_after_bad"]
    assert float(sim["target_speed_rpm"]) == SPEED_1 and float(sim["target_temperature_c"]) == TEMP_0, sim
    assert "setpoint refused" in experiment.sim_log and "WARN" in experiment.sim_log
    # the stream went on after the invalid setpoints, and the temperature step still worked
    recs = experiment.records()
    assert recs[-1].stamp > experiment.marks["temperature_reached"]


def test_setpoint_burst_neither_stalls_stream_nor_grows_memory(experiment: Experiment) -> None:
    w0, w1 = experiment.burst_wall
    assert experiment.burst_sent >= 0.8 * 1000 * BURST_S
    recs = [r for r in experiment.records() if w0 - 0.5 <= r.wall <= w1 + 0.5]
    assert len(recs) >= 5, "the stream stalled during the setpoint burst"
    gaps = np.diff([r.wall for r in recs])
    expected_gap = CHUNK_S / float(experiment.diag["final"]["achieved_real_time_factor"])
    assert gaps.max() < max(1.0, 5.0 * expected_gap), gaps.max()
    assert continuity(recs)["sequence_jumps"] == 0
    growth = experiment.rss["after_burst"] - experiment.rss["before_burst"]
    assert growth < 20e6, f"node RSS grew by {growth / 1e6:.1f} MB during the burst"
    sp = experiment.diag["after_burst"]
    # The setpoint subscriptions keep the last 10 messages (only the latest target matters), so under
    # a flood superseded messages may never be read and the refusal count depends on machine load.
    # What must hold: invalid setpoints of the burst were refused, and none became a target (the
    # valid ones of the burst repeat the current targets).
    assert int(sp["refused_total"]) > experiment.bad_setpoints, sp
    sim = experiment.diag["sim_after_burst"]
    assert float(sim["target_speed_rpm"]) == SPEED_1 and float(sim["target_temperature_c"]) == TEMP_0, sim


def test_runtime_parameter_changes_are_validated(experiment: Experiment) -> None:
    res = experiment.param_results
    assert res["real_time_factor"][0] is False and "real_time_factor" in res["real_time_factor"][1]
    assert res["bearing_type"][0] is False and "read-only" in res["bearing_type"][1]
    assert res["noise.dte.stddev"][0] is False and "one per channel" in res["noise.dte.stddev"][1]
    assert res["chunk_period_s"][0] is False and "whole number" in res["chunk_period_s"][1]
    assert res["limits.speed_rpm_max"] == (True, "")


def test_clock_follows_simulated_time(experiment: Experiment) -> None:
    clock = np.array(experiment.probe.clock)
    assert clock.size >= 10
    assert np.all(np.diff(clock) > 0)
    last = experiment.records()[-1]
    assert clock[-1] <= last.stamp + CHUNK_S + 1e-9


def test_monitor_indicators_match_offline_computation(experiment: Experiment) -> None:
    checked = 0
    for msg, window in _checkable_indicators(experiment.probe):
        ind = compute_indicators(window, FS, msg.speed_rpm, PINION_TEETH)
        assert list(msg.channel_names) == ["dte", "mesh_force"]
        assert msg.mesh_frequency_hz == pytest.approx(PINION_TEETH * msg.speed_rpm / 60.0)
        for name in ("rms", "peak", "crest_factor", "kurtosis", "mesh_order_amplitude", "sideband_amplitude"):
            np.testing.assert_allclose(
                np.asarray(getattr(msg, name)), getattr(ind, name), rtol=1e-9, err_msg=name
            )
        np.testing.assert_array_equal(np.asarray(msg.alarm), ind.rms > np.asarray(msg.alarm_threshold))
        checked += 1
    assert checked >= 3


def test_sigterm_finalises_recording(experiment: Experiment) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    assert experiment.sim_rc == 0, experiment.sim_log[-2000:]
    assert "recording finalised" in experiment.sim_log
    live = {r.sequence: r for r in experiment.records()}
    recorded: dict[str, list] = {}
    with open(experiment.mcap, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        from gear_rotor_sim.calibration.measurement import _recorded_rig

        assert _recorded_rig(reader) == ("paper_sun2021", None)  # calibrate finds the rig (issue 15)
        for _schema, channel, _message, msg in reader.iter_decoded_messages(log_time_order=True):
            recorded.setdefault(channel.topic, []).append(msg)
    assert set(recorded) == {
        "/gear_rotor/dte", "/gear_rotor/bearing_forces", "/gear_rotor/displacements", "/gear_rotor/faults"
    }  # fmt: skip
    assert all(len(m.faults) == 0 for m in recorded["/gear_rotor/faults"])  # healthy ground truth
    dte = recorded["/gear_rotor/dte"]
    assert [m.sequence for m in dte] == list(range(len(dte)))
    assert len(dte) >= max(live) + 1  # everything published is recorded
    seq = max(live) // 2
    np.testing.assert_array_equal(np.asarray(dte[seq].data).reshape(-1, 2), live[seq].data)


@pytest.mark.parametrize(
    ("override", "expected"),
    [
        ("real_time_factor:=-1.0", "real_time_factor"),
        ("bearing_type:=D#", "bearing_type"),
        ("speed_rpm:=3000", "speed_rpm"),
        ("chunk_period_s:=0.0010001", "whole number"),
        ("speed_rmp:=3000.0", "did you mean 'speed_rpm'"),
        ("model:=no_such_model", "no_such_model"),
    ],
)
def test_invalid_parameters_exit_nonzero(override: str, expected: str) -> None:
    env = ros_environment(DOMAIN_ID)
    proc = subprocess.run(
        [str(executable("simulator", env)), "--ros-args", "-p", override],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2, (proc.returncode, proc.stderr[-2000:])
    assert "invalid parameters" in proc.stderr and expected in proc.stderr, proc.stderr[-2000:]


def test_node_logs_its_start_up_time(experiment: Experiment) -> None:
    m = re.search(
        r"start-up: first message ([0-9.]+) s after the node constructor, "
        r"([0-9.]+) s after the process started",
        experiment.sim_log,
    )
    assert m, "no start-up line in the simulator log"
    after_constructor, after_process = float(m.group(1)), float(m.group(2))
    # the process starts before the node is constructed, and the first message came within the timeout
    assert 0.0 < after_constructor <= after_process < STARTUP_TIMEOUT_S
