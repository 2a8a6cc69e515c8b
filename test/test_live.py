"""``gear-rotor-sim serve`` seen by a real Foxglove-protocol WebSocket client (test/foxglove_ws_client.py).

Truths independent of the server code: the protocol's framing (spec), the advertised JSON schemas,
sample-index arithmetic (chunk k+1 starts where chunk k ends, t0 = index / rate), and the mesh
frequency z1 * n / 60 of the pinion (29 teeth, the paper's Table 3) located in the DTE received by
the client with its own FFT.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from foxglove_ws_client import SUBPROTOCOL, FoxgloveClient, validate

from gear_rotor_sim.live.serve import ChunkPacer
from gear_rotor_sim.setpoints import DEFAULT_LIMITS, check_setpoint

PINION_TEETH = 29
RATE_HZ = 20000.0
STREAM_TOPICS = ("/gear_rotor/dte", "/gear_rotor/bearing_forces", "/gear_rotor/displacements")
EXTRA_TOPICS = ("/gear_rotor/indicators", "/gear_rotor/dte_spectrum", "/gear_rotor/status")
SETPOINT_TOPICS = ("/gear_rotor/setpoint/speed_rpm", "/gear_rotor/setpoint/temperature_c")
LAYOUT = Path(__file__).resolve().parent.parent / "config" / "foxglove_layout.json"


def _mesh_line_hz(dte: np.ndarray, rate_hz: float, min_hz: float = 200.0) -> float:
    """Frequency of the largest line above ``min_hz`` (Hann window, the bin's centre)."""
    x = (dte - dte.mean()) * np.hanning(dte.size)
    amp = np.abs(np.fft.rfft(x))
    f = np.fft.rfftfreq(dte.size, 1.0 / rate_hz)
    amp[f < min_hz] = 0.0
    return float(f[int(np.argmax(amp))])


@pytest.fixture(scope="module")
def server():
    """``gear-rotor-sim serve`` in a subprocess on a free port; yields (process, ws url)."""
    cmd = [
        sys.executable,
        "-m",
        "gear_rotor_sim.cli",
        "serve",
        "--speed-rpm",
        "3000",
        "--temperature-c",
        "25",
        "--port",
        "0",
        "--duration-s",
        "60",
        "--speed-ramp-rpm-per-s",
        "inf",
    ]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    line = proc.stdout.readline()
    if not line.startswith("serving ws://"):
        proc.kill()
        raise AssertionError(f"serve did not start: {line!r} {proc.stderr.read()[-2000:]}")
    url = line.split()[1]
    yield proc, url
    assert proc.poll() is None, "serve ended before the test did"
    proc.terminate()
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err[-2000:]  # SIGTERM ends the server cleanly
    assert "setpoints accepted 1, refused 5" in out, out


def _advertised_fields(channel: dict) -> set[str]:
    """Top-level field names of an advertised channel: ros2msg text or JSON schema properties."""
    if channel["schemaEncoding"] == "jsonschema":
        return set(json.loads(channel["schema"])["properties"])
    main = channel["schema"].split("=" * 80)[0]
    return {ln.split()[1] for ln in main.splitlines() if ln.strip() and not ln.startswith("#")}


def _check_layout(topics: dict[str, dict]) -> None:
    """config/foxglove_layout.json opens the streams by name: every message path's topic is
    advertised (or is a setpoint topic) and its first field exists in the advertised schema."""
    layout = json.loads(LAYOUT.read_text())
    paths = []
    for panel_id, cfg in layout["configById"].items():
        paths += [p["value"] for p in cfg.get("paths", [])]
        paths += [cfg[k]["value"] for k in ("xAxisPath",) if k in cfg]
        if "topicPath" in cfg:
            paths.append(cfg["topicPath"])
        if panel_id.startswith("Publish!"):
            assert cfg["topicName"] in SETPOINT_TOPICS, cfg["topicName"]
    assert len(paths) >= 8
    for path in paths:
        topic = next((t for t in sorted(topics, key=len, reverse=True) if path.startswith(t)), None)
        assert topic is not None, f"layout path {path!r}: topic not advertised"
        rest = path[len(topic) :]
        if rest:
            field = rest.lstrip(".").split(".")[0].split("[")[0]
            assert field in _advertised_fields(topics[topic]), f"layout path {path!r}: no field {field!r}"


def _collect(client: FoxgloveClient, seconds: float, state: dict, timeout_s: float = 90.0) -> np.ndarray:
    """Receive ``seconds`` of /gear_rotor/dte, checking fields and continuity; returns the DTE."""
    status_schema = json.loads(client.topics()["/gear_rotor/status"]["schema"])
    parts = []
    need = round(seconds * RATE_HZ)
    deadline = time.monotonic() + timeout_s
    while sum(p.size for p in parts) < need:
        assert time.monotonic() < deadline, "no DTE messages"
        got = client.poll(timeout_s)
        assert got is not None, "no message within the timeout"
        if got.topic == "/gear_rotor/status":
            validate(got.message, status_schema)
            state["status"] = got.message
            continue
        if got.topic == "/gear_rotor/indicators":
            state["indicators"] = got.message
            continue
        if got.topic != "/gear_rotor/dte":
            continue
        m = got.message
        n = m.sample_count
        assert len(m.dte) == n and len(m.mesh_force) == n and n == round(0.1 * RATE_HZ)
        assert list(m.channel_names) == ["dte", "mesh_force"] and list(m.units) == ["m", "N"]
        assert m.sample_rate_hz == RATE_HZ and m.header.frame_id == "gear_mesh"
        if state.get("next_index") is not None:
            assert m.first_sample_index == state["next_index"], "gap or overlap between chunks"
            assert m.sequence == state["sequence"] + 1
        t0 = m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec
        assert abs(t0 - m.first_sample_index / m.sample_rate_hz) <= 1e-9
        assert got.log_time_ns == m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
        state["next_index"] = m.first_sample_index + n
        state["sequence"] = m.sequence
        state["speed_rpm"] = m.speed_rpm
        want = state.get("want_speed", m.speed_rpm)
        if abs(m.speed_rpm - want) <= 1e-9 * want:
            parts.append(np.asarray(m.dte))
    return np.concatenate(parts)


def test_serve_streams_setpoints_and_refusals(server):
    _proc, url = server
    client = FoxgloveClient(url)
    try:
        assert client.subprotocol == SUBPROTOCOL
        client.wait_for(lambda c: set(STREAM_TOPICS + EXTRA_TOPICS) <= set(c.topics()), 30.0)
        assert "clientPublish" in client.server_info["capabilities"]
        assert "json" in client.server_info["supportedEncodings"]
        for topic in STREAM_TOPICS + EXTRA_TOPICS:
            ch = client.topics()[topic]
            json_topic = topic == "/gear_rotor/status"
            assert ch["encoding"] == ("json" if json_topic else "cdr")
            assert ch["schemaEncoding"] == ("jsonschema" if json_topic else "ros2msg")
        assert (
            client.topics()["/gear_rotor/indicators"]["schemaName"]
            == "gear_rotor_msgs/msg/ConditionIndicators"
        )
        _check_layout(client.topics())
        client.subscribe(["/gear_rotor/dte", "/gear_rotor/status", "/gear_rotor/indicators"])
        state: dict = {"want_speed": 3000.0}
        dte = _collect(client, 1.0, state)
        assert abs(_mesh_line_hz(dte, RATE_HZ) - PINION_TEETH * 3000 / 60) <= 1.0
        ind = state["indicators"]
        assert list(ind.channel_names) == ["dte", "mesh_force"] and ind.source_topic == "/gear_rotor/dte"
        assert ind.mesh_frequency_hz == pytest.approx(PINION_TEETH * 3000 / 60, rel=1e-12)

        speed = client.advertise("/gear_rotor/setpoint/speed_rpm", "std_msgs/Float64", {"type": "object"})
        client.publish(speed, json.dumps({"data": 4500.0}).encode())
        state["want_speed"] = 4500.0
        dte = _collect(client, 1.0, state)
        assert abs(_mesh_line_hz(dte, RATE_HZ) - PINION_TEETH * 4500 / 60) <= 1.0

        n_status = len(client.statuses)
        bad = [b'{"data": -100}', b'{"data": 1e9}', b"fast please", b'{"data": "fast"}']
        for payload in bad:
            client.publish(speed, payload)
        temperature = client.advertise("/gear_rotor/setpoint/temperature_c", "std_msgs/Float64", {})
        client.publish(temperature, b'{"data": 1000}')
        client.wait_for(lambda c: len(c.statuses) >= n_status + 5, 30.0)
        texts = [s["message"] for s in client.statuses[n_status:]]
        assert all(s["level"] == 1 for s in client.statuses[n_status:])  # warning
        assert any("speed_rpm setpoint -100.0 is negative" in t for t in texts), texts
        assert any("above limits.speed_rpm_max" in t for t in texts), texts
        assert any("not JSON" in t for t in texts), texts
        assert any("is not a number" in t for t in texts), texts
        assert any("temperature_c setpoint 1000.0 is outside" in t for t in texts), texts
        # the streams go on, contiguous, at the last accepted speed
        dte = _collect(client, 0.5, state)
        assert state["speed_rpm"] == pytest.approx(4500.0, rel=1e-9)
        deadline = time.monotonic() + 30
        while state.get("status", {}).get("setpoints_refused") != 5:
            assert time.monotonic() < deadline, state.get("status")
            _collect(client, 0.1, state)
        status = state["status"]
        assert status["target_speed_rpm"] == pytest.approx(4500.0, rel=1e-9)
        assert status["setpoints_accepted"] == 1
        assert "temperature_c setpoint 1000.0" in status["last_refusal"]
    finally:
        client.close()


def test_setpoint_validation_is_the_nodes():
    """The live server and the node share one validator (values of the node's default limits)."""
    assert check_setpoint("speed_rpm", 4500.0, DEFAULT_LIMITS) is None
    assert "negative" in check_setpoint("speed_rpm", -1.0, DEFAULT_LIMITS)
    assert "not finite" in check_setpoint("temperature_c", float("nan"), DEFAULT_LIMITS)
    assert "outside [25.0, 325.0]" in check_setpoint("temperature_c", 24.0, DEFAULT_LIMITS)


def test_chunk_pacer_holds_real_time_and_slows_down_when_late():
    """Fake clock: chunks are released at t_end / rtf; a late chunk re-anchors (no catch-up burst)."""
    now = [0.0]
    pacer = ChunkPacer(2.0, clock=lambda: now[0], sleep=lambda s: now.__setitem__(0, now[0] + s))
    for k in range(5):
        assert not pacer.wait(0.1 * k, 0.1 * (k + 1))
    assert now[0] == pytest.approx(0.25, rel=1e-12)
    now[0] += 1.0  # a slow chunk: 1 s of wall time for 0.05 s of simulated time
    assert pacer.wait(0.5, 0.6)
    t_late = now[0]
    assert not pacer.wait(0.6, 0.7)
    assert now[0] == pytest.approx(t_late + 0.05, rel=1e-12)
    with pytest.raises(ValueError, match="real_time_factor"):
        ChunkPacer(0.0)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.ros
def test_node_serves_foxglove_with_parameter(tmp_path):
    """The ROS node with ``foxglove_port`` serves the same channels; client setpoints reach it."""
    pytest.importorskip("rclpy", reason="the simulator node needs rclpy (scripts/setup_env.sh)")
    from gear_rotor_sim.ros.demo import ros_environment, share_file, start_process, stop_process

    env = ros_environment()
    port = _free_port()
    params = share_file("config/simulator_node.yaml", env)
    args = ["--ros-args", "--params-file", str(params), "-p", f"foxglove_port:={port}"]
    args += ["-p", "speed_ramp_rpm_per_s:=1.0e7"]  # a step: no slow ramp to wait through
    node = start_process("simulator", args, env, tmp_path / "simulator.log")
    client = None
    try:
        deadline = time.monotonic() + 120
        while client is None:
            try:
                client = FoxgloveClient(f"ws://127.0.0.1:{port}")
            except OSError:
                assert node.poll() is None, (tmp_path / "simulator.log").read_text()[-2000:]
                assert time.monotonic() < deadline, "the node's Foxglove server did not start"
                time.sleep(0.5)
        client.wait_for(lambda c: set(STREAM_TOPICS + EXTRA_TOPICS) <= set(c.topics()), 60.0)
        client.subscribe(["/gear_rotor/dte", "/gear_rotor/status"])
        state: dict = {}
        _collect(client, 0.3, state)
        speed = client.advertise("/gear_rotor/setpoint/speed_rpm", "std_msgs/Float64", {"type": "object"})
        client.publish(speed, b'{"data": 3300}')
        client.publish(speed, b'{"data": -5}')
        deadline = time.monotonic() + 60
        while state.get("status", {}).get("target_speed_rpm") != 3300.0:
            assert time.monotonic() < deadline, state.get("status")
            _collect(client, 0.1, state)
        assert state["status"]["setpoints_refused"] == 1
        assert "speed_rpm setpoint -5.0 is negative" in state["status"]["last_refusal"]
    finally:
        if client is not None:
            client.close()
        assert stop_process(node) == 0, (tmp_path / "simulator.log").read_text()[-2000:]
