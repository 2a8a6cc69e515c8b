"""Recover an MCAP recording cut short by a crash (``kill -9``, power loss, full disk).

A recording that did not close has no summary and no footer, and may end in a partly written
record. :func:`recover` reads the file front to back without seeking (record by record, parsed
with the ``mcap`` package's record readers, chunk CRCs validated), keeps every complete record
up to the first incomplete or corrupt one, and writes them into a new, finished file with the
recorder (schemas, channels with their QoS metadata and type hashes, messages with their
original times and sequence numbers, fresh statistics, indexes and ``rosbag2`` metadata).
The source file is never modified.
"""

from __future__ import annotations

import os
import struct
from collections import defaultdict
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path

import yaml
from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Message, Metadata, Schema
from mcap.stream_reader import breakup_chunk

from gear_rotor_sim.recording.writer import RECORDING_METADATA, McapRecorder


@dataclass
class RecoveryReport:
    """What :func:`recover` found and kept.

    Attributes
    ----------
    messages_recovered : int
        Messages written to the recovered file.
    messages_per_topic : dict
        Recovered messages per topic.
    chunks_recovered : int
        Complete chunks read from the source.
    source_complete : bool
        The source already ended with a footer (nothing was lost).
    first_time_ns, last_time_ns : int or None
        Log-time range of the recovered messages (simulated time, ns).
    source_bytes, bytes_used : int
        Size of the source and the length of its leading part that held complete records.
    lost_chunk_time_ns : tuple of int or None
        Log-time range of the messages of a partly written chunk found at the end, if its header
        survived (those messages are lost).
    flush_period_s : float or None
        The recorder's flush period, read from the file: data later than ``last_time_ns`` that
        was lost spans at most this much simulated time (unless a whole chunk was cut, see
        ``lost_chunk_time_ns``).
    stop_reason : str
        Why reading stopped (``"footer"``, ``"end of file"`` or the decoding error).
    """

    messages_recovered: int = 0
    messages_per_topic: dict[str, int] = field(default_factory=dict)
    chunks_recovered: int = 0
    source_complete: bool = False
    first_time_ns: int | None = None
    last_time_ns: int | None = None
    source_bytes: int = 0
    bytes_used: int = 0
    lost_chunk_time_ns: tuple[int, int] | None = None
    flush_period_s: float | None = None
    stop_reason: str = ""

    @property
    def lost_span_bound_s(self) -> float | None:
        """Upper bound of the simulated time lost after ``last_time_ns``, s (None when unknown)."""
        if self.source_complete:
            return 0.0
        bound = self.flush_period_s
        if self.lost_chunk_time_ns is not None:
            start = self.last_time_ns if self.last_time_ns is not None else self.lost_chunk_time_ns[0]
            cut = max(0.0, (self.lost_chunk_time_ns[1] - start) / 1e9)
            bound = None if bound is None else bound + cut
        return bound

    def summary(self) -> str:
        """Human-readable account of the recovery."""
        lines = [
            f"recovered {self.messages_recovered} messages in {self.chunks_recovered} chunks "
            f"({self.bytes_used} of {self.source_bytes} bytes used; stopped at: {self.stop_reason})"
        ]
        for topic, n in sorted(self.messages_per_topic.items()):
            lines.append(f"  {topic}: {n}")
        if self.first_time_ns is not None and self.last_time_ns is not None:
            lines.append(
                f"time range kept: {self.first_time_ns / 1e9:.6f} s .. {self.last_time_ns / 1e9:.6f} s"
            )
        if self.source_complete:
            lines.append("the source was complete: nothing lost")
        else:
            if self.lost_chunk_time_ns is not None:
                a, b = self.lost_chunk_time_ns
                lines.append(f"a cut chunk held messages from {a / 1e9:.6f} s to {b / 1e9:.6f} s (lost)")
            bound = self.lost_span_bound_s
            if bound is not None:
                lines.append(
                    f"data lost after the last kept message: at most {bound:.3f} s of simulated time"
                )
            else:
                lines.append(
                    "the span lost after the last kept message is unknown (no flush period recorded)"
                )
        return "\n".join(lines)


_RECORD_HEAD = struct.Struct("<BQ")
_MAGIC = b"\x89MCAP0\r\n"
_MAX_RECORD = 4 * 2**30


def _records(f):
    """Yield ``(offset, opcode, body)`` of each complete record; return the stop reason at the end.

    Reads strictly forward. Stops at the first record whose header or body is cut short and
    yields ``(offset, opcode, partial body)`` with ``opcode`` negated for it.
    """
    offset = len(_MAGIC)
    while True:
        head = f.read(_RECORD_HEAD.size)
        if not head:
            return "end of file"
        if len(head) < _RECORD_HEAD.size:
            return "incomplete record header"
        opcode, length = _RECORD_HEAD.unpack(head)
        if length > _MAX_RECORD:
            return f"implausible record length {length} at byte {offset} (corrupt data)"
        body = f.read(length)
        if len(body) < length:
            yield offset, -opcode, body
            return f"incomplete record (opcode 0x{opcode:02x}, {len(body)} of {length} bytes)"
        yield offset, opcode, body
        offset += _RECORD_HEAD.size + length


def _parse(opcode: int, body: bytes):
    stream = ReadDataStream(BytesIO(body))
    if opcode == Opcode.SCHEMA:
        return Schema.read(stream)
    if opcode == Opcode.CHANNEL:
        return Channel.read(stream)
    if opcode == Opcode.MESSAGE:
        return Message.read(stream, len(body))
    if opcode == Opcode.METADATA:
        return Metadata.read(stream)
    if opcode == Opcode.CHUNK:
        return Chunk.read(stream)
    return None


class _Rewriter:
    """Feeds recovered records into a recorder created lazily (once the custom data is known)."""

    def __init__(self, dst: Path, report: RecoveryReport) -> None:
        self.dst = dst
        self.report = report
        self.rec: McapRecorder | None = None
        self.custom_data: dict[str, str] = {}
        self.schemas: dict[int, Schema] = {}
        self.channels: dict[int, Channel] = {}
        self.registered: set[int] = set()
        self.per_topic: dict[str, int] = defaultdict(int)

    def recorder(self) -> McapRecorder:
        if self.rec is None:
            self.rec = McapRecorder(
                self.dst,
                flush_thread=False,
                atomic=True,
                custom_data=self.custom_data,
                flush_period_s=self.report.flush_period_s or 1.0,
            )
        return self.rec

    def handle(self, record) -> None:
        if isinstance(record, Schema):
            self.schemas[record.id] = record
        elif isinstance(record, Channel):
            self.channels[record.id] = record
        elif isinstance(record, Metadata):
            if record.name == RECORDING_METADATA:
                period = record.metadata.get("flush_period_s")
                self.report.flush_period_s = float(period) if period else None
                prefix = "custom_data."
                self.custom_data.update(
                    {k[len(prefix) :]: v for k, v in record.metadata.items() if k.startswith(prefix)}
                )
            elif record.name != "rosbag2":
                self.recorder().add_metadata(record.name, record.metadata)
        elif isinstance(record, Message):
            ch = self.channels[record.channel_id]
            if record.channel_id not in self.registered:
                _register(self.recorder(), ch, self.schemas.get(ch.schema_id))
                self.registered.add(record.channel_id)
            self.recorder().write_serialized(
                ch.topic,
                self.schemas[ch.schema_id].name,
                record.data,
                record.log_time,
                record.publish_time,
                record.sequence,
            )
            self.per_topic[ch.topic] += 1
            r = self.report
            r.messages_recovered += 1
            t = record.log_time
            r.first_time_ns = t if r.first_time_ns is None else min(r.first_time_ns, t)
            r.last_time_ns = t if r.last_time_ns is None else max(r.last_time_ns, t)

    def finish(self) -> None:
        rec = self.recorder()
        for ch_id, ch in self.channels.items():
            if ch_id not in self.registered and ch.schema_id in self.schemas:
                _register(rec, ch, self.schemas[ch.schema_id])
        rec.close()
        self.report.messages_per_topic = dict(self.per_topic)

    def abort(self) -> None:
        if self.rec is not None:
            self.rec.abort()


def recover(src: str | os.PathLike, dst: str | os.PathLike) -> RecoveryReport:
    """Rewrite the complete records of a (possibly truncated) MCAP file into a finished file.

    Parameters
    ----------
    src : path
        The recording to recover; it is only read.
    dst : path
        The finished file to write (written as ``dst.part`` and renamed when complete).

    Returns
    -------
    RecoveryReport

    Raises
    ------
    ValueError
        ``src`` and ``dst`` are the same file, ``src`` is not an MCAP file, or it holds channels
        that are not ROS 2 (cdr/ros2msg).
    FileNotFoundError
        ``src`` does not exist.
    """
    src_p, dst_p = Path(src), Path(dst)
    if not src_p.is_file():
        raise FileNotFoundError(f"recover: source {src_p} does not exist")
    if dst_p.exists() and dst_p.resolve() == src_p.resolve():
        raise ValueError("recover: the output must differ from the source")
    report = RecoveryReport(source_bytes=src_p.stat().st_size)
    out = _Rewriter(dst_p, report)
    try:
        with open(src_p, "rb") as f:
            if f.read(len(_MAGIC)) != _MAGIC:
                raise ValueError(f"recover: {src_p} is not an MCAP file (bad magic)")
            report.bytes_used = len(_MAGIC)
            records = _records(f)
            while True:
                try:
                    offset, opcode, body = next(records)
                except StopIteration as stop:
                    report.stop_reason = str(stop.value)
                    break
                if opcode < 0:
                    if -opcode == Opcode.CHUNK and len(body) >= 16:
                        start, end = struct.unpack_from("<QQ", body)
                        report.lost_chunk_time_ns = (int(start), int(end))
                    continue
                if opcode == Opcode.FOOTER:
                    report.source_complete = True
                    report.stop_reason = "footer"
                    report.bytes_used = report.source_bytes
                    break
                if opcode == Opcode.DATA_END:
                    # The data section ended cleanly; the summary that follows is rebuilt anyway.
                    report.source_complete = True
                try:
                    record = _parse(opcode, body)
                    inner = (
                        breakup_chunk(record, validate_crc=True) if isinstance(record, Chunk) else [record]
                    )
                except (McapError, struct.error, ValueError, UnicodeDecodeError) as exc:
                    report.stop_reason = f"corrupt record at byte {offset}: {exc}"
                    report.source_complete = False
                    break
                for r in inner:
                    if r is not None:
                        out.handle(r)
                if isinstance(record, Chunk):
                    report.chunks_recovered += 1
                report.bytes_used = offset + _RECORD_HEAD.size + len(body)
        out.finish()
    except BaseException:
        out.abort()
        raise
    return report


def _register(rec: McapRecorder, channel: Channel, schema: Schema | None) -> None:
    if schema is None:
        raise ValueError(f"recover: channel {channel.topic} has no schema in the file")
    if channel.message_encoding != "cdr" or schema.encoding != "ros2msg":
        raise ValueError(
            f"recover: channel {channel.topic} uses {channel.message_encoding}/{schema.encoding}; "
            "only ROS 2 (cdr/ros2msg) recordings are supported"
        )
    qos_text = channel.metadata.get("offered_qos_profiles", "")
    profiles = yaml.safe_load(qos_text) if qos_text else None
    rec.add_topic(
        channel.topic,
        schema.name,
        qos=profiles if profiles else None,
        schema_text=schema.data.decode("utf-8"),
        type_hash=channel.metadata.get("topic_type_hash", ""),
    )
