"""MCAP recording: CDR bytes, schemas, rosbag2 metadata, crash-safety flushing, write errors.

Every file is read back with independent readers: the ``mcap`` reader with ``mcap_ros2``'s
decoder and the ``rosbags`` package; our own code never reads the files it checks.
"""

from __future__ import annotations

import array
import errno
import json
import os
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader

from gear_rotor_sim.blocks import SampleBlock
from gear_rotor_sim.recording import schemas
from gear_rotor_sim.recording.cdr import serialize_diagnostic_array, serialize_vibration_chunk
from gear_rotor_sim.recording.writer import McapRecorder, RecordingError, _FileSink
from gear_rotor_sim.streams import StreamSpec, chunk_fields, default_streams

REPO = Path(__file__).resolve().parents[1]
RATE = 20000.0


def make_block(k: int, n: int, channels: tuple[str, ...], first: int, seed: int = 0) -> SampleBlock:
    """A deterministic synthetic block (no simulator needed)."""
    rng = np.random.default_rng(seed * 100003 + k)
    return SampleBlock(
        first / RATE,
        RATE,
        channels,
        tuple("N" if "_f" in c else "m" for c in channels),
        rng.normal(size=(n, len(channels))),
        first,
        np.full(n, 3000.0 + k),
        np.full(n, 25.0 + 0.5 * k),
    )


def write_blocks(path: Path, specs: list[StreamSpec], sizes: list[int], **kw) -> list[SampleBlock]:
    channels = tuple(dict.fromkeys(c for s in specs for c in s.channels))
    blocks = []
    first = 0
    with McapRecorder(path, specs, **kw) as rec:
        for k, n in enumerate(sizes):
            b = make_block(k, n, channels, first)
            for s in specs:
                rec.write_block(b, s, k)
            blocks.append(b)
            first += n
    return blocks


def mcap_messages(path: Path) -> list[tuple]:
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [
            (ch.topic, msg, dec) for _sch, ch, msg, dec in reader.iter_decoded_messages(log_time_order=True)
        ]


# ---------------------------------------------------------------------------------------------
# schemas
# ---------------------------------------------------------------------------------------------
def test_schema_text_is_rosbag2_concatenation() -> None:
    text = schemas.full_definition(schemas.VIBRATION_CHUNK)
    parts = text.split("\n" + "=" * 80 + "\n")
    assert parts[0] == (REPO / "msg_defs/msg/VibrationChunk.msg").read_text()
    names = [p.splitlines()[0] for p in parts[1:]]
    assert names == [
        "MSG: std_msgs/Header",
        "MSG: builtin_interfaces/Time",
        "MSG: std_msgs/MultiArrayLayout",
        "MSG: std_msgs/MultiArrayDimension",
    ]
    assert "uint32 nanosec" in parts[2] and "uint32 data_offset" in parts[3]


def test_type_hashes_match_rosidl() -> None:
    # Published Jazzy constants (independent of any installation) ...
    assert schemas.type_hash("std_msgs/msg/Header") == (
        "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01"
    )
    assert schemas.type_hash("builtin_interfaces/msg/Time") == (
        "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197"
    )
    # ... and whatever rosidl generated for our package and diagnostic_msgs, when installed.
    candidates = [
        REPO / "install/gear_rotor_msgs/share/gear_rotor_msgs/msg/VibrationChunk.json",
        REPO / "install/gear_rotor_msgs/share/gear_rotor_msgs/msg/ConditionIndicators.json",
        REPO / ".venv/share/diagnostic_msgs/msg/DiagnosticArray.json",
    ]
    checked = 0
    for path in candidates:
        if path.is_file():
            for h in json.loads(path.read_text())["type_hashes"]:
                assert schemas.type_hash(h["type_name"]) == h["hash_string"], h["type_name"]
                checked += 1
    if not checked:
        pytest.skip("no rosidl-generated type descriptions installed to compare against")


# ---------------------------------------------------------------------------------------------
# CDR
# ---------------------------------------------------------------------------------------------
def _padding_positions(f: dict) -> set[int]:
    """Byte offsets (in the full message) of the alignment padding of a VibrationChunk."""
    pos = 0
    pad: set[int] = set()

    def align(n: int) -> None:
        nonlocal pos
        p = (-pos) % n
        pad.update(range(4 + pos, 4 + pos + p))
        pos += p

    def string(s: str) -> None:
        nonlocal pos
        align(4)
        pos += 4 + len(s.encode()) + 1

    align(4)
    pos += 8
    string(f["frame_id"])
    align(8)
    pos += 40
    for key in ("channel_names", "units"):
        align(4)
        pos += 4
        for s in f[key]:
            string(s)
    align(4)
    pos += 4
    for label, _size, _stride in f["layout_dim"]:
        string(label)
        align(4)
        pos += 8
    align(4)
    pos += 8  # data_offset, data count
    if len(f["data"]):
        align(8)
    return pad


def _rclpy_chunk(f: dict):
    """The ``VibrationChunk`` of these fields built field by field with rclpy's message class (the
    node publishes our CDR bytes of ``f``; this is what rclpy itself would serialise)."""
    from gear_rotor_msgs.msg import VibrationChunk
    from std_msgs.msg import MultiArrayDimension

    msg = VibrationChunk()
    msg.header.stamp.sec = int(f["stamp_sec"])
    msg.header.stamp.nanosec = int(f["stamp_nanosec"])
    msg.header.frame_id = f["frame_id"]
    msg.sequence = f["sequence"]
    msg.first_sample_index = f["first_sample_index"]
    msg.sample_rate_hz = f["sample_rate_hz"]
    msg.speed_rpm = f["speed_rpm"]
    msg.temperature_c = f["temperature_c"]
    msg.channel_names = f["channel_names"]
    msg.units = f["units"]
    msg.layout.dim = [MultiArrayDimension(label=a, size=b, stride=c) for a, b, c in f["layout_dim"]]
    msg.layout.data_offset = 0
    msg.data = array.array("d", f["data"].tobytes())
    return msg


@pytest.mark.ros
def test_cdr_bytes_equal_rclpy_serialisation() -> None:
    rclpy_serialization = pytest.importorskip("rclpy.serialization", reason="rclpy not importable")
    pytest.importorskip("gear_rotor_msgs.msg", reason="gear_rotor_msgs not built/sourced")
    from gear_rotor_msgs.msg import VibrationChunk

    cases = [
        (make_block(3, 20000, ("dte",), 60000), StreamSpec("dte", ("dte",), "gear_mesh")),
        (
            make_block(1, 7, ("dte", "mesh_force", "node5_ax"), 12345),
            StreamSpec("x", ("node5_ax", "dte"), "abc"),
        ),
        (make_block(2, 1, ("bearing1_fx",), 3), StreamSpec("b", ("bearing1_fx",), "gearbox_housing")),
    ]
    for k, (block, spec) in enumerate(cases):
        f = chunk_fields(block, spec, 10**12 + k)
        ours = serialize_vibration_chunk(f)
        theirs = rclpy_serialization.serialize_message(_rclpy_chunk(f))
        assert len(ours) == len(theirs)
        pad = _padding_positions(f)
        diff = [i for i in range(len(ours)) if ours[i] != theirs[i] and i not in pad]
        assert diff == []
        back = rclpy_serialization.deserialize_message(ours, VibrationChunk)
        assert np.array_equal(np.asarray(back.data), f["data"])
        assert back.header.frame_id == spec.frame_id and back.sequence == 10**12 + k
    # Empty data: rclpy's buffer carries unused alignment bytes at the end; the content is equal.
    empty = make_block(0, 0, ("dte",), 0)
    f = chunk_fields(empty, StreamSpec("dte", ("dte",), "m"), 0)
    ours = serialize_vibration_chunk(f)
    theirs = rclpy_serialization.serialize_message(_rclpy_chunk(f))
    pad = _padding_positions(f)
    assert len(theirs) - len(ours) in (0, 4)
    assert all(ours[i] == theirs[i] for i in range(len(ours)) if i not in pad)
    assert list(rclpy_serialization.deserialize_message(ours, VibrationChunk).data) == []


def test_cdr_serialisation_is_fast() -> None:
    block = make_block(0, 20000, ("dte",), 0)
    f = chunk_fields(block, StreamSpec("dte", ("dte",), "gear_mesh"), 0)
    serialize_vibration_chunk(f)
    times = []
    for _ in range(50):
        t0 = time.perf_counter()
        serialize_vibration_chunk(f)
        times.append(time.perf_counter() - t0)
    assert np.median(times) < 1e-3


def test_diagnostic_array_decodes_with_independent_decoder() -> None:
    from mcap.records import Schema

    data = serialize_diagnostic_array(
        {
            "stamp_sec": 5,
            "stamp_nanosec": 7,
            "frame_id": "",
            "status": [
                {
                    "level": 1,
                    "name": "sim",
                    "message": "rtf low",
                    "hardware_id": "hw",
                    "values": {"rtf": "0.8"},
                },
                {"level": 0, "name": "rec", "message": "ok", "values": [("bytes", "12"), ("topic", "/x")]},
            ],
        }
    )
    text = schemas.full_definition(schemas.DIAGNOSTIC_ARRAY).encode()
    decode = DecoderFactory().decoder_for(
        "cdr", Schema(id=1, name=schemas.DIAGNOSTIC_ARRAY, encoding="ros2msg", data=text)
    )
    msg = decode(data)
    assert msg.header.stamp.sec == 5 and msg.status[0].level == 1
    assert [(kv.key, kv.value) for kv in msg.status[1].values] == [("bytes", "12"), ("topic", "/x")]


# ---------------------------------------------------------------------------------------------
# files read by independent readers
# ---------------------------------------------------------------------------------------------
def test_recording_read_by_mcap_and_rosbags(tmp_path: Path) -> None:
    specs = default_streams(2, displacement_nodes=(5,), acceleration_nodes=(6,))
    sizes = [2000, 1999, 1, 2000, 4000, 2000, 37]
    path = tmp_path / "run.mcap"
    blocks = write_blocks(path, specs, sizes, custom_data={"speed_rpm": "3000"})

    # mcap reader + mcap_ros2 decoder: every message, values equal the blocks
    msgs = mcap_messages(path)
    assert len(msgs) == len(specs) * len(sizes)
    per_topic: dict[str, list] = {}
    for topic, msg, dec in msgs:
        per_topic.setdefault(topic, []).append((msg, dec))
    for spec in specs:
        got = per_topic[spec.topic]
        assert [d.sequence for _m, d in got] == list(range(len(sizes)))
        for (msg, dec), block in zip(got, blocks, strict=True):
            assert msg.log_time == msg.publish_time == round(block.t0 * 1e9)
            assert dec.header.stamp.sec * 10**9 + dec.header.stamp.nanosec == msg.log_time
            assert dec.header.frame_id == spec.frame_id
            assert list(dec.channel_names) == list(spec.channels)
            assert dec.first_sample_index == block.first_index
            assert dec.speed_rpm == block.speed_rpm[0] and dec.temperature_c == block.temperature_c[0]
            assert [(d.label, d.size, d.stride) for d in dec.layout.dim] == [
                ("sample", block.n_samples, block.n_samples * len(spec.channels)),
                ("channel", len(spec.channels), len(spec.channels)),
            ]
            data = np.asarray(dec.data).reshape(block.n_samples, len(spec.channels))
            assert np.array_equal(data, block.select(spec.channels).data)

    # header, schema, channels, summary
    with open(path, "rb") as f:
        reader = make_reader(f)
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary is not None
        (schema,) = summary.schemas.values()
        assert schema.name == schemas.VIBRATION_CHUNK and schema.encoding == "ros2msg"
        assert schema.data.decode() == schemas.full_definition(schemas.VIBRATION_CHUNK)
        assert sorted(c.topic for c in summary.channels.values()) == sorted(s.topic for s in specs)
        for ch in summary.channels.values():
            assert ch.message_encoding == "cdr"
            assert ch.metadata["topic_type_hash"] == schemas.type_hash(schemas.VIBRATION_CHUNK)
            (qos,) = yaml.safe_load(ch.metadata["offered_qos_profiles"])
            assert qos["reliability"] == "best_effort" and qos["history"] == "keep_last"
            assert set(qos) == {
                "history",
                "depth",
                "reliability",
                "durability",
                "deadline",
                "lifespan",
                "liveliness",
                "liveliness_lease_duration",
                "avoid_ros_namespace_conventions",
            }
        stats = summary.statistics
        assert stats.message_count == len(msgs)
        assert stats.message_start_time == 0
        assert stats.message_end_time == round(blocks[-1].t0 * 1e9)
        assert all(n == len(sizes) for n in stats.channel_message_counts.values())
        assert summary.chunk_indexes and all(ci.message_index_offsets for ci in summary.chunk_indexes)
        bag = [m for m in reader.iter_metadata() if m.name == "rosbag2"]
    assert len(bag) == 1
    meta = yaml.safe_load(bag[0].metadata["serialized_metadata"])
    assert meta["version"] == 9 and meta["storage_identifier"] == "mcap" and meta["ros_distro"] == "jazzy"
    assert meta["message_count"] == len(msgs)
    assert meta["starting_time"] == {"nanoseconds_since_epoch": 0}
    assert meta["duration"] == {"nanoseconds": stats.message_end_time}
    assert meta["relative_file_paths"] == ["run.mcap"] and meta["files"][0]["path"] == "run.mcap"
    assert meta["files"][0]["message_count"] == len(msgs)
    assert meta["compression_format"] == "" and meta["compression_mode"] == ""
    assert meta["custom_data"] == {"speed_rpm": "3000"}
    for t in meta["topics_with_message_count"]:
        tm = t["topic_metadata"]
        assert t["message_count"] == len(sizes)
        assert tm["type"] == schemas.VIBRATION_CHUNK and tm["serialization_format"] == "cdr"
        assert tm["offered_qos_profiles"][0]["depth"] == 5
        assert tm["type_description_hash"].startswith("RIHS01_")

    # rosbags: independent CDR decoder and MCAP reader
    with AnyReader([path]) as reader:
        assert {c.topic: c.msgcount for c in reader.connections} == {s.topic: len(sizes) for s in specs}
        seen = {s.topic: 0 for s in specs}
        for conn, timestamp, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            spec = next(s for s in specs if s.topic == conn.topic)
            block = blocks[msg.sequence]
            assert timestamp == round(block.t0 * 1e9)
            data = msg.data.reshape(block.n_samples, len(spec.channels))
            assert np.array_equal(data, block.select(spec.channels).data)
            seen[conn.topic] += 1
        assert all(n == len(sizes) for n in seen.values())


def test_reliable_qos_and_compression(tmp_path: Path) -> None:
    specs = default_streams(1)
    path = tmp_path / "z.mcap"
    blocks = write_blocks(path, specs, [500, 500], qos="reliable", compression="zstd")
    with AnyReader([path]) as reader:
        got = [reader.deserialize(raw, c.msgtype) for c, _t, raw in reader.messages()]
    assert len(got) == 4
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert all(ci.compression == "zstd" for ci in summary.chunk_indexes)
    (qos,) = yaml.safe_load(next(iter(summary.channels.values())).metadata["offered_qos_profiles"])
    assert qos["reliability"] == "reliable" and qos["depth"] == 10
    assert np.array_equal(got[0].data.reshape(500, -1), blocks[0].select(specs[0].channels).data)


# ---------------------------------------------------------------------------------------------
# crash safety: what is on disk before close
# ---------------------------------------------------------------------------------------------
def _messages_on_disk(path: Path) -> list:
    """Non-seeking read of an unfinished file: messages of the complete chunks."""
    out = []
    with open(path, "rb") as f:
        try:
            for rec in StreamReader(f, skip_magic=False).records:
                if type(rec).__name__ == "Message":
                    out.append(rec)
        except Exception:  # the file has no footer: reading stops at its end
            pass
    return out


def test_chunks_flushed_by_simulated_time(tmp_path: Path) -> None:
    spec = StreamSpec("dte", ("dte",), "gear_mesh")
    path = tmp_path / "open.mcap"
    rec = McapRecorder(path, [spec], flush_thread=False, flush_period_s=1.0)
    n = int(0.25 * RATE)
    for k in range(12):  # 3 s of simulated time, written faster than real time
        rec.write_block(make_block(k, n, ("dte",), k * n), spec, k)
        on_disk = _messages_on_disk(path)
        t_written = (k + 1) * 0.25
        t_on_disk = (max(m.log_time for m in on_disk) / 1e9 + 0.25) if on_disk else 0.0
        assert t_written - t_on_disk <= 1.0 + 1e-9
    rec.abort()


def test_chunks_flushed_by_wall_time(tmp_path: Path) -> None:
    spec = StreamSpec("dte", ("dte",), "gear_mesh")
    path = tmp_path / "slow.mcap"
    rec = McapRecorder(path, [spec], flush_period_s=0.3)
    rec.write_block(make_block(0, 10, ("dte",), 0), spec, 0)
    assert _messages_on_disk(path) == []
    deadline = time.monotonic() + 3.0
    while not _messages_on_disk(path) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert len(_messages_on_disk(path)) == 1  # written by the timer thread, no new message needed
    rec.close()
    assert len(mcap_messages(path)) == 1


# ---------------------------------------------------------------------------------------------
# bad input and write failures
# ---------------------------------------------------------------------------------------------
def test_unwritable_path_gives_clear_error(tmp_path: Path) -> None:
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    with pytest.raises(RecordingError, match=r"cannot create recording .*a_file/run\.mcap"):
        McapRecorder(blocker / "run.mcap", default_streams(1))
    with pytest.raises(RecordingError, match="No such file or directory"):
        McapRecorder(tmp_path / "missing" / "run.mcap", default_streams(1))
    with pytest.raises(ValueError, match="qos"):
        McapRecorder(tmp_path / "q.mcap", qos="fast")
    with pytest.raises(ValueError, match="flush_period_s"):
        McapRecorder(tmp_path / "f.mcap", flush_period_s=0)


def test_full_disk_keeps_written_data(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from gear_rotor_sim.recording.recover import recover

    specs = default_streams(1)
    earlier = tmp_path / "earlier.mcap"
    write_blocks(earlier, specs, [1000] * 3)
    earlier_bytes = earlier.read_bytes()

    budget = {"left": 1_500_000}
    real_write = _FileSink._write

    def limited(self, view):
        if len(view) > budget["left"]:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        budget["left"] -= len(view)
        return real_write(self, view)

    monkeypatch.setattr(_FileSink, "_write", limited)
    path = tmp_path / "full.mcap"
    rec = McapRecorder(path, specs, flush_thread=False, flush_period_s=0.2)
    channels = tuple(c for s in specs for c in s.channels)
    written = 0
    with pytest.raises(RecordingError, match=r"No space left on device.*recover"):
        for k in range(100):
            b = make_block(k, 2000, channels, k * 2000)
            for s in specs:
                rec.write_block(b, s, k)
            written = k
    with pytest.raises(RecordingError, match="failed earlier"):
        rec.write_block(make_block(0, 10, channels, 0), specs[0], 0)
    with pytest.raises(RecordingError, match="not finished"):
        rec.close()
    monkeypatch.undo()
    assert earlier.read_bytes() == earlier_bytes  # nothing already written was touched
    report = recover(path, tmp_path / "full.recovered.mcap")
    assert report.messages_recovered >= len(specs) * (written - 5)
    assert len(mcap_messages(tmp_path / "full.recovered.mcap")) == report.messages_recovered


# ---------------------------------------------------------------------------------------------
# the record command with the real streaming simulator
# ---------------------------------------------------------------------------------------------
def test_record_command_data_equal_simulator_blocks(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from gear_rotor_sim.cli import main
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.simulator import Simulator

    out = tmp_path / "run.mcap"
    schedule = "[{at_s: 0.15, speed_rpm: 3100}]"
    args = ["record", "--speed-rpm", "3000", "--temperature-c", "25", "--duration-s", "0.3",
            "--out", str(out), "--sample-rate-hz", "10000", "--schedule", schedule]  # fmt: skip
    assert main(args) == 0
    assert "wrote" in capsys.readouterr().out

    specs = default_streams(4)
    channels = [c for s in specs for c in s.channels]
    cfg = load_config("paper_sun2021")
    sim = Simulator(cfg, speed_rpm=3000.0, temperature_c=25.0, output_rate_hz=10000.0, channels=channels)
    first = sim.advance(0.1)
    second = sim.advance(0.05)
    sim.set_targets(speed_rpm=3100.0)
    expected = SampleBlock.concatenate([first, second, sim.advance(0.1), sim.advance(0.05)])
    with AnyReader([out]) as reader:
        got: dict[str, list] = {}
        for conn, _t, raw in reader.messages():
            got.setdefault(conn.topic, []).append(reader.deserialize(raw, conn.msgtype))
    for spec in specs:
        msgs = sorted(got[spec.topic], key=lambda m: m.sequence)
        data = np.concatenate([m.data.reshape(-1, len(spec.channels)) for m in msgs])
        assert np.array_equal(data, expected.select(spec.channels).data)
        assert [m.first_sample_index for m in msgs] == [0, 1000, 1500, 2500]


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--schedule", "[{at_s: 0.1, rpm: 5}]"], r"schedule\[0\]: unknown key\(s\) \['rpm'\]"),
        (["--temperature-c", "900"], r"temperature_c: 900.*allowed 25 <= value <= 325"),
        (["--streams", "dte,sound"], r"streams: \['sound'\] not known"),
        (["--bearing-type", "Q#"], r"'Q#' is not one of"),
    ],
)
def test_record_command_bad_input(
    tmp_path: Path, capsys: pytest.CaptureFixture, extra: list, message: str
) -> None:
    import re

    from gear_rotor_sim.cli import main

    out = tmp_path / "x.mcap"
    assert main(["record", "--duration-s", "0.1", "--out", str(out), *extra]) == 2
    assert re.search(message, capsys.readouterr().err)
    assert not out.exists()
