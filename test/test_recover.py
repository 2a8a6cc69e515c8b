"""Crash recovery: a recorder killed with SIGKILL loses at most ~1 s; recovered files read cleanly."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader

from gear_rotor_sim.recording.recover import recover
from gear_rotor_sim.recording.recover_cli import default_output

REPO = Path(__file__).resolve().parents[1]
RATE = 20000.0
BLOCK = 2000  # samples per message: 0.1 s

# A recorder process: synthetic blocks paced at ~4x real time; prints each written time.
WRITER = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    from gear_rotor_sim.blocks import SampleBlock
    from gear_rotor_sim.recording.writer import McapRecorder
    from gear_rotor_sim.streams import default_streams

    specs = default_streams(2)
    chans = tuple(c for s in specs for c in s.channels)
    rec = McapRecorder(sys.argv[1], specs, flush_period_s=1.0, custom_data={"run": "kill-test"})
    k = 0
    while True:
        rng = np.random.default_rng(k)
        data = rng.normal(size=(2000, len(chans)))
        b = SampleBlock(k * 0.1, 20000.0, chans, tuple("N" for _ in chans), data, k * 2000,
                        np.full(2000, 3000.0), np.full(2000, 25.0))
        for s in specs:
            rec.write_block(b, s, k)
        k += 1
        print(f"t={k * 0.1:.6f}", flush=True)
        time.sleep(0.025)
    """
)


def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(REPO) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _run_and_kill(cmd: list[str], until_s: float, timeout_s: float = 60.0) -> float:
    """Start ``cmd``, SIGKILL it once it reports simulated time >= until_s; returns the last time."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())
    last = 0.0
    deadline = time.monotonic() + timeout_s
    try:
        assert proc.stdout is not None
        for line in proc.stdout:
            if line.startswith("t="):
                last = float(line[2:])
                if last >= until_s:
                    break
            if time.monotonic() > deadline:
                break
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == -signal.SIGKILL, proc.stderr.read() if proc.stderr else ""
    return last


def _read_everything(path: Path) -> tuple[list, list]:
    """Decode every message with both independent readers (seeking, summary-based)."""
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        a = [(ch.topic, m.log_time, d) for _s, ch, m, d in reader.iter_decoded_messages(log_time_order=True)]
        assert summary.statistics.message_count == len(a)
    with AnyReader([path]) as reader:
        b = [(c.topic, t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages()]
    return a, b


def test_sigkill_loses_at_most_one_second(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    last = _run_and_kill([sys.executable, "-c", WRITER, str(path)], until_s=3.0)
    assert last >= 3.0

    # the unfinished file has no summary: a seeking reader cannot use it
    with open(path, "rb") as f, pytest.raises(Exception):  # noqa: B017 - any reader error will do
        list(make_reader(f).iter_messages())

    out = tmp_path / "recovered.mcap"
    report = recover(path, out)
    assert not report.source_complete
    assert report.flush_period_s == 1.0
    kept_until = report.last_time_ns / 1e9 + 0.1  # end of the last recovered block
    assert last - kept_until <= 1.0 + 1e-6, report.summary()
    assert report.lost_span_bound_s is not None and report.lost_span_bound_s >= last - kept_until - 1e-6

    a, b = _read_everything(out)
    assert len(a) == len(b) == report.messages_recovered
    # every recovered message is intact: same values as the generator produced
    for _topic, _t, msg in b:
        k = msg.sequence
        rng = np.random.default_rng(k)
        full = rng.normal(size=(BLOCK, 2 + 6))
        cols = [0, 1] if len(msg.channel_names) == 2 else list(range(2, 8))
        assert np.array_equal(msg.data.reshape(BLOCK, -1), full[:, cols])
    seqs = sorted({m.sequence for _t, _x, m in b})
    assert seqs == list(range(len(seqs)))  # no gap: only the tail is lost

    with open(out, "rb") as f:
        bag = [m for m in make_reader(f).iter_metadata() if m.name == "rosbag2"]
    assert "kill-test" in bag[0].metadata["serialized_metadata"]


def test_sigkill_of_record_command(tmp_path: Path) -> None:
    """The real ``gear-rotor-sim record`` (streaming simulator), killed mid-run and recovered."""
    path = tmp_path / "run.mcap"
    cmd = [
        sys.executable, "-m", "gear_rotor_sim.cli", "record", "--speed-rpm", "3000", "--temperature-c", "25",
        "--duration-s", "60", "--out", str(path), "--progress",
    ]  # fmt: skip
    last = _run_and_kill(cmd, until_s=2.0, timeout_s=120.0)
    report = recover(path, default_output(path))
    assert report.messages_recovered > 0
    assert last - (report.last_time_ns / 1e9 + 0.1) <= 1.0 + 1e-6, report.summary()
    a, b = _read_everything(default_output(path))
    assert len(a) == len(b) == report.messages_recovered
    # the ground truth (an empty fault list for a healthy run) is recorded too
    assert {t for t, _x, _m in a} == {"/gear_rotor/dte", "/gear_rotor/bearing_forces", "/gear_rotor/faults"}


def test_recover_any_truncation_point(tmp_path: Path) -> None:
    """Cut a finished recording anywhere: recovery never fails and keeps every complete chunk."""
    from test_recording import write_blocks

    from gear_rotor_sim.streams import default_streams

    src = tmp_path / "full.mcap"
    write_blocks(src, default_streams(1), [4000] * 12, flush_period_s=0.5)
    data = src.read_bytes()
    counts = []
    for frac in (0.0005, 0.1, 0.33, 0.5, 0.77, 0.9, 0.97, 1.0):
        cut = tmp_path / f"cut{frac}.mcap"
        cut.write_bytes(data[: max(8, int(len(data) * frac))])
        report = recover(cut, tmp_path / f"rec{frac}.mcap")
        a, b = _read_everything(tmp_path / f"rec{frac}.mcap")
        assert len(a) == len(b) == report.messages_recovered
        counts.append(report.messages_recovered)
    assert counts == sorted(counts)
    assert counts[0] == 0 and counts[-1] == 24 and 0 < counts[3] < 24
    assert report.source_complete and report.lost_span_bound_s == 0.0


def test_recover_cli_and_errors(tmp_path: Path) -> None:
    from gear_rotor_sim.cli import main

    bad = tmp_path / "not.mcap"
    bad.write_bytes(b"hello world, not an mcap file")
    assert main(["recover", str(bad)]) == 1
    assert main(["recover", str(tmp_path / "missing.mcap")]) == 1
    assert not list(tmp_path.glob("*.recovered.mcap*"))
    with pytest.raises(ValueError, match="differ"):
        recover(bad, bad)
