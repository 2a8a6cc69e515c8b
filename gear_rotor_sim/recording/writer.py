"""Crash-safe MCAP recorder of vibration streams, following rosbag2's MCAP conventions.

File layout (what ``ros2 bag``, Foxglove, ``mcap`` and ``rosbags`` expect):

- header profile ``ros2``; one schema per message type (``pkg/msg/Type``, encoding ``ros2msg``,
  full concatenated definition, see :mod:`.schemas`); one channel per topic, message encoding
  ``cdr``, metadata ``offered_qos_profiles`` (YAML list of QoS profiles) and ``topic_type_hash``;
- messages with log time = publish time = the simulated time of the message stamp, in ns;
- chunks (uncompressed by default, 768 KiB target like rosbag2) each followed by its message
  indexes; on close a ``rosbag2`` metadata record (key ``serialized_metadata``) and a summary
  with schemas, channels, statistics, chunk indexes, metadata index and summary offsets.

Crash safety: every byte goes straight to the operating system (no user-space buffer), and the
open chunk is closed and written whenever it spans ``flush_period_s`` of simulated time, whenever
``flush_period_s`` of wall time passed since the last flush (checked on every write and by a
background timer thread), and when it reaches ``chunk_size`` bytes. A killed process therefore
loses only the open chunk: at most ``flush_period_s`` of simulated time and at most
``flush_period_s`` of wall time of data. ``gear-rotor-sim recover`` rewrites the complete chunks
of such a file into a finished one.

fsync policy (``fsync=True``, the default): ``os.fsync`` after every timed flush (so at most once
per ``flush_period_s``) and at close. This bounds what an operating-system crash or power loss
can take to the same period; a killed process loses nothing that was flushed even without fsync.
Size-triggered chunk writes are not individually synced.
"""

from __future__ import annotations

import errno
import os
import threading
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

import yaml
from mcap.writer import CompressionType, Writer

from gear_rotor_sim.blocks import SampleBlock
from gear_rotor_sim.recording import schemas
from gear_rotor_sim.recording.cdr import serialize_vibration_chunk
from gear_rotor_sim.streams import StreamSpec, chunk_fields

ROS_DISTRO = "jazzy"
BAG_METADATA_VERSION = 9
DEFAULT_CHUNK_SIZE = 768 * 1024
LIBRARY = "gear_rotor_sim recording (mcap-python)"
RECORDING_METADATA = "gear_rotor_sim.recording"

_INFINITE = {"sec": 9223372036, "nsec": 854775807}


def qos_profile(name: str) -> dict:
    """The offered QoS profile of the simulator node's publishers, as rosbag2 serialises it.

    Parameters
    ----------
    name : {"sensor_data", "reliable"}
        ``sensor_data``: best effort, keep last 5 (rclpy ``qos_profile_sensor_data``);
        ``reliable``: reliable, keep last 10 (rclpy's default publisher profile).
        Durations are infinite, liveliness automatic, as a Fast DDS publisher reports them.
    """
    profiles = {
        "sensor_data": ("best_effort", 5),
        "reliable": ("reliable", 10),
    }
    if name not in profiles:
        raise ValueError(f"qos: {name!r} is not one of {sorted(profiles)}")
    reliability, depth = profiles[name]
    return {
        "history": "keep_last",
        "depth": depth,
        "reliability": reliability,
        "durability": "volatile",
        "deadline": dict(_INFINITE),
        "lifespan": dict(_INFINITE),
        "liveliness": "automatic",
        "liveliness_lease_duration": dict(_INFINITE),
        "avoid_ros_namespace_conventions": False,
    }


class _NoAliasDumper(yaml.SafeDumper):
    """Safe dumper that writes repeated objects in full (yaml-cpp never emits anchors)."""

    def ignore_aliases(self, data: object) -> bool:
        return True


def _duration(value: object) -> dict:
    ns = getattr(value, "nanoseconds", None)
    if ns is None:
        sec = int(getattr(value, "sec", 0))
        ns = sec * 1_000_000_000 + int(getattr(value, "nanosec", 0))
    ns = int(ns)
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def profile_from_qos(qos: object) -> dict:
    """rosbag2's QoS dict from an rclpy ``QoSProfile`` (duck-typed, rclpy is not imported)."""

    def policy(name: str) -> str:
        value = getattr(qos, name)
        return str(getattr(value, "name", value)).lower()

    return {
        "history": policy("history"),
        "depth": int(qos.depth),  # type: ignore[attr-defined]
        "reliability": policy("reliability"),
        "durability": policy("durability"),
        "deadline": _duration(qos.deadline),  # type: ignore[attr-defined]
        "lifespan": _duration(qos.lifespan),  # type: ignore[attr-defined]
        "liveliness": policy("liveliness"),
        "liveliness_lease_duration": _duration(qos.liveliness_lease_duration),  # type: ignore[attr-defined]
        "avoid_ros_namespace_conventions": bool(qos.avoid_ros_namespace_conventions),  # type: ignore[attr-defined]
    }


def _profiles(qos: object) -> list[dict]:
    if isinstance(qos, str):
        return [qos_profile(qos)]
    if isinstance(qos, Mapping):
        return [dict(qos)]
    if hasattr(qos, "reliability") and hasattr(qos, "depth"):
        return [profile_from_qos(qos)]
    return [p if isinstance(p, Mapping) else profile_from_qos(p) for p in qos]  # type: ignore[attr-defined]


def dump_yaml(data: object) -> str:
    """Block-style YAML in the key order given, without anchors (as yaml-cpp emits rosbag2 metadata)."""
    return yaml.dump(data, Dumper=_NoAliasDumper, sort_keys=False, default_flow_style=False, width=1 << 16)


def bag_metadata(
    file_name: str,
    topics: Sequence[Mapping],
    starting_time_ns: int,
    duration_ns: int,
    custom_data: Mapping[str, str] | None = None,
) -> dict:
    """The rosbag2 ``BagMetadata`` (version 9, Jazzy) of a single-file MCAP bag.

    Parameters
    ----------
    file_name : str
        The bag file's name (``relative_file_paths`` and ``files[0].path``).
    topics : sequence of mapping
        Per topic: ``name``, ``type``, ``serialization_format``, ``offered_qos_profiles`` (list
        of profile dicts), ``type_description_hash``, ``message_count``.
    starting_time_ns, duration_ns : int
        Earliest message log time and the span to the latest, ns.
    custom_data : mapping of str to str, optional
        User key/value pairs; written as null when empty.

    Notes
    -----
    MCAP chunk compression is a storage detail: rosbag2 leaves the bag-level
    ``compression_format`` and ``compression_mode`` empty for it, and so does this function.
    """
    count = int(sum(t["message_count"] for t in topics))
    return {
        "version": BAG_METADATA_VERSION,
        "storage_identifier": "mcap",
        "duration": {"nanoseconds": int(duration_ns)},
        "starting_time": {"nanoseconds_since_epoch": int(starting_time_ns)},
        "message_count": count,
        "topics_with_message_count": [
            {
                "topic_metadata": {
                    "name": t["name"],
                    "type": t["type"],
                    "serialization_format": t["serialization_format"],
                    "offered_qos_profiles": list(t["offered_qos_profiles"]),
                    "type_description_hash": t["type_description_hash"],
                },
                "message_count": int(t["message_count"]),
            }
            for t in topics
        ],
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": [file_name],
        "files": [
            {
                "path": file_name,
                "starting_time": {"nanoseconds_since_epoch": int(starting_time_ns)},
                "duration": {"nanoseconds": int(duration_ns)},
                "message_count": count,
            }
        ],
        "custom_data": dict(custom_data) if custom_data else None,
        "ros_distro": ROS_DISTRO,
    }


class RecordingError(RuntimeError):
    """Writing the recording failed; ``errno`` carries the operating-system error, if any."""

    def __init__(self, message: str, err: int | None = None) -> None:
        super().__init__(message)
        self.errno = err


class _FileSink:
    """Unbuffered write-through file: every ``write`` reaches the OS before it returns."""

    def __init__(self, path: Path) -> None:
        self._fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_CLOEXEC", 0), 0o644)
        self._pos = 0

    def write(self, data: bytes | bytearray | memoryview) -> int:
        view = memoryview(data).cast("B")
        total = len(view)
        done = 0
        while done < total:
            done += self._write(view[done:])
        self._pos += total
        return total

    def _write(self, view: memoryview) -> int:
        n = os.write(self._fd, view)
        if n == 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return n

    def tell(self) -> int:
        return self._pos

    def flush(self) -> None:
        """Nothing is buffered in user space."""

    def fsync(self) -> None:
        os.fsync(self._fd)

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


class McapRecorder:
    """Write ``VibrationChunk`` streams (and other serialised messages) to one MCAP file.

    Parameters
    ----------
    path : str or Path
        Output file. Its folder must exist.
    streams : sequence of StreamSpec
        Streams registered up front (topic ``spec.topic``, type ``VibrationChunk``).
    qos : {"sensor_data", "reliable"}, mapping or rclpy QoSProfile
        Offered QoS written in each channel's ``offered_qos_profiles``: a name, a full profile in
        rosbag2's YAML form, or the publisher's ``rclpy.qos.QoSProfile``.
    flush_period_s : float
        Close the open chunk at least this often, in simulated and in wall time (seconds > 0).
    chunk_size : int
        Close a chunk once it holds this many bytes.
    compression : {"none", "zstd", "lz4"}
        Chunk compression (rosbag2's default is none).
    fsync : bool
        ``os.fsync`` on timed flushes and at close (see the module docstring).
    flush_thread : bool
        Run a background thread enforcing the wall-time flush while no messages arrive.
    atomic : bool
        Write to ``<path>.part`` and rename to ``path`` only after a clean close, so ``path``
        never names an unfinished file (used by dataset generation).
    custom_data : mapping of str to str
        Stored in the rosbag2 metadata's ``custom_data``.

    Raises
    ------
    RecordingError
        The file cannot be created (message names the path and the OS error).
    """

    def __init__(
        self,
        path: str | os.PathLike,
        streams: Sequence[StreamSpec] = (),
        qos: object = "sensor_data",
        flush_period_s: float = 1.0,
        chunk_size: int = DEFAULT_CHUNK_SIZE,
        compression: str = "none",
        fsync: bool = True,
        flush_thread: bool = True,
        atomic: bool = False,
        custom_data: Mapping[str, str] | None = None,
    ) -> None:
        if not (flush_period_s > 0 and flush_period_s < float("inf")):
            raise ValueError(f"flush_period_s: {flush_period_s!r} must be a finite number > 0")
        if int(chunk_size) < 1024:
            raise ValueError(f"chunk_size: {chunk_size!r} must be >= 1024 bytes")
        compressions = {
            "none": CompressionType.NONE,
            "zstd": CompressionType.ZSTD,
            "lz4": CompressionType.LZ4,
        }
        if compression not in compressions:
            raise ValueError(f"compression: {compression!r} is not one of {sorted(compressions)}")
        self._default_qos = _profiles(qos)
        self.path = Path(path)
        self._work_path = self.path.with_name(self.path.name + ".part") if atomic else self.path
        self._atomic = atomic
        self._period_s = float(flush_period_s)
        self._period_ns = round(flush_period_s * 1e9)
        self._fsync = fsync
        self._custom_data = {str(k): str(v) for k, v in (custom_data or {}).items()}
        self._lock = threading.RLock()
        self._closed = False
        self._failed: BaseException | None = None
        try:
            self._sink = _FileSink(self._work_path)
        except OSError as exc:
            raise RecordingError(
                f"cannot create recording {self._work_path}: {exc.strerror or exc}", exc.errno
            ) from exc
        self._writer = Writer(
            self._sink,  # type: ignore[arg-type]
            chunk_size=int(chunk_size),
            compression=compressions[compression],
        )
        self._schema_ids: dict[str, int] = {}
        self._topics: dict[str, dict] = {}
        self._chunk_first_ns: int | None = None
        self._last_flush_wall = time.monotonic()
        self._first_ns: int | None = None
        self._last_ns: int | None = None
        self.message_count = 0
        self.sample_count = 0
        self.serialize_s = 0.0
        self.write_s = 0.0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        try:
            self._guard(lambda: self._writer.start(profile="ros2", library=LIBRARY))
            # Written first so that a recovered file still knows the flush period and the run's data.
            info = {"flush_period_s": repr(self._period_s), "chunk_size": str(int(chunk_size))}
            info.update({f"custom_data.{k}": v for k, v in self._custom_data.items()})
            self._guard(lambda: self._writer.add_metadata(RECORDING_METADATA, info))
            for spec in streams:
                self.add_topic(spec.topic, schemas.VIBRATION_CHUNK)
        except BaseException:
            self._closed = True
            self._discard()
            raise
        if flush_thread:
            self._thread = threading.Thread(target=self._flush_loop, name="mcap-flush", daemon=True)
            self._thread.start()

    # -- topics -------------------------------------------------------------------------------
    def add_topic(
        self,
        topic: str,
        type_name: str,
        qos: object = None,
        schema_text: str | None = None,
        type_hash: str | None = None,
    ) -> int:
        """Register ``topic`` of ``type_name`` (``pkg/msg/Type``); returns its channel id.

        ``schema_text`` and ``type_hash`` default to :mod:`.schemas`; give them for types it does
        not know. ``qos`` may be a name, one profile (dict or rclpy ``QoSProfile``) or a list.
        """
        with self._lock:
            self._check_open()
            if topic in self._topics:
                if self._topics[topic]["type"] != type_name:
                    raise ValueError(
                        f"topic {topic}: already registered as {self._topics[topic]['type']}, not {type_name}"
                    )
                return self._topics[topic]["channel_id"]
            if schema_text is None:
                schema_text = schemas.full_definition(type_name)
            if type_hash is None:
                try:
                    type_hash = schemas.type_hash(type_name)
                except schemas.SchemaError:
                    type_hash = ""
            profiles = self._default_qos if qos is None else _profiles(qos)
            if type_name not in self._schema_ids:
                self._schema_ids[type_name] = self._guard(
                    lambda: self._writer.register_schema(type_name, "ros2msg", schema_text.encode("utf-8"))
                )
            metadata = {"offered_qos_profiles": dump_yaml(profiles), "topic_type_hash": type_hash}
            channel_id = self._guard(
                lambda: self._writer.register_channel(topic, "cdr", self._schema_ids[type_name], metadata)
            )
            self._topics[topic] = {
                "name": topic,
                "type": type_name,
                "serialization_format": "cdr",
                "offered_qos_profiles": profiles,
                "type_description_hash": type_hash,
                "message_count": 0,
                "channel_id": channel_id,
            }
            return channel_id

    # -- writing ------------------------------------------------------------------------------
    def write_block(self, block: SampleBlock, spec: StreamSpec, sequence: int) -> int:
        """Write ``spec``'s channels of ``block`` as one ``VibrationChunk``; returns its size in bytes."""
        t0 = time.perf_counter()
        fields = chunk_fields(block, spec, sequence)
        data = serialize_vibration_chunk(fields)
        self.serialize_s += time.perf_counter() - t0
        return self.write_chunk(spec, fields, data)

    def write_chunk(self, spec: StreamSpec, fields: Mapping, data: bytes) -> int:
        """Write one ``VibrationChunk`` serialised already: ``data`` =
        :func:`~gear_rotor_sim.recording.cdr.serialize_vibration_chunk` of ``fields`` (the
        :func:`~gear_rotor_sim.streams.chunk_fields` of the chunk), e.g. the bytes a node published.
        Returns the size in bytes."""
        if spec.topic not in self._topics:
            self.add_topic(spec.topic, schemas.VIBRATION_CHUNK)
        stamp = fields["stamp_sec"] * 1_000_000_000 + fields["stamp_nanosec"]
        self.write_serialized(spec.topic, schemas.VIBRATION_CHUNK, data, stamp, sequence=fields["sequence"])
        self.sample_count += int(fields["data"].size)
        return len(data)

    def write_serialized(
        self,
        topic: str,
        type_name: str,
        data: bytes,
        log_time_ns: int,
        publish_time_ns: int | None = None,
        sequence: int = 0,
    ) -> None:
        """Write one CDR-serialised message (registering ``topic`` on first use).

        Parameters
        ----------
        log_time_ns, publish_time_ns : int
            Simulated time of the message, ns (``publish_time_ns`` defaults to ``log_time_ns``).
        sequence : int
            Stored modulo 2**32 in the MCAP message record.
        """
        t0 = time.perf_counter()
        if log_time_ns < 0:
            raise ValueError(f"log_time_ns: {log_time_ns} must be >= 0")
        with self._lock:
            self._check_open()
            info = self._topics.get(topic)
            if info is None:
                self.add_topic(topic, type_name)
                info = self._topics[topic]
            elif info["type"] != type_name:
                raise ValueError(f"topic {topic}: registered as {info['type']}, not {type_name}")
            pub = log_time_ns if publish_time_ns is None else publish_time_ns
            before = self._sink.tell()
            self._guard(
                lambda: self._writer.add_message(
                    info["channel_id"], int(log_time_ns), data, int(pub), int(sequence) & 0xFFFFFFFF
                )
            )
            info["message_count"] += 1
            self.message_count += 1
            self._first_ns = log_time_ns if self._first_ns is None else min(self._first_ns, log_time_ns)
            self._last_ns = log_time_ns if self._last_ns is None else max(self._last_ns, log_time_ns)
            if self._sink.tell() != before:
                self._chunk_first_ns = None  # a size-triggered chunk closed, this message included
            else:
                if self._chunk_first_ns is None:
                    self._chunk_first_ns = log_time_ns
                if (
                    log_time_ns - self._chunk_first_ns >= self._period_ns
                    or time.monotonic() - self._last_flush_wall >= self._period_s
                ):
                    self._timed_flush()
        self.write_s += time.perf_counter() - t0

    def add_metadata(self, name: str, data: Mapping[str, str]) -> None:
        """Write an MCAP metadata record (``rosbag2`` is reserved for the record written at close)."""
        if name == "rosbag2":
            raise ValueError("metadata name 'rosbag2' is reserved for the bag metadata written at close")
        with self._lock:
            self._check_open()
            items = {str(k): str(v) for k, v in data.items()}
            self._guard(lambda: self._writer.add_metadata(name, items))

    def set_custom_data(self, key: str, value: str) -> None:
        """Set one ``custom_data`` entry of the rosbag2 metadata written at close."""
        with self._lock:
            self._check_open()
            self._custom_data[str(key)] = str(value)

    def flush(self) -> None:
        """Close the open chunk now, and fsync if the policy says so."""
        with self._lock:
            self._check_open()
            self._timed_flush()

    # -- closing ------------------------------------------------------------------------------
    def close(self) -> None:
        """Finish the file: last chunk, rosbag2 metadata record, summary, footer; fsync; rename.

        After a write failure the file is left as it is (its complete chunks are recoverable; an
        atomic recording's ``.part`` file is removed instead) and the error is raised again.
        """
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        with self._lock:
            if self._closed:
                return
            self._closed = True
            if self._failed is not None:
                self._discard()
                raise RecordingError(f"recording {self._work_path} was not finished: {self._failed}")
            try:
                self._writer.flush()
                first = self._first_ns or 0
                duration = (self._last_ns or 0) - first
                meta = bag_metadata(
                    self.path.name, list(self._topics.values()), first, duration, self._custom_data
                )
                self._writer.add_metadata("rosbag2", {"serialized_metadata": dump_yaml(meta)})
                self._writer.finish()
                if self._fsync:
                    self._sink.fsync()
            except OSError as exc:
                self._failed = exc
                self._discard()
                raise self._error(exc) from exc
            self._sink.close()
            if self._atomic:
                os.replace(self._work_path, self.path)
                if self._fsync:
                    _fsync_dir(self.path.parent)

    def _discard(self) -> None:
        """Close the file after a failure; an atomic recording's partial file is removed."""
        self._sink.close()
        if self._atomic:
            self._work_path.unlink(missing_ok=True)

    def abort(self) -> None:
        """Stop without finishing (as a crash would); an atomic recording's partial file is removed."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        with self._lock:
            if not self._closed:
                self._closed = True
                self._sink.close()
                if self._atomic:
                    self._work_path.unlink(missing_ok=True)

    def __enter__(self) -> McapRecorder:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        elif self._atomic:
            self.abort()
        else:
            self._stop.set()
            with self._lock:
                if not self._closed:
                    self._closed = True
                    self._sink.close()

    # -- introspection --------------------------------------------------------------------------
    @property
    def bytes_written(self) -> int:
        return self._sink.tell()

    @property
    def topics(self) -> dict[str, int]:
        """Message count per topic."""
        return {t: info["message_count"] for t, info in self._topics.items()}

    @property
    def time_range_ns(self) -> tuple[int, int] | None:
        if self._first_ns is None or self._last_ns is None:
            return None
        return self._first_ns, self._last_ns

    # -- internals ------------------------------------------------------------------------------
    def _check_open(self) -> None:
        if self._failed is not None:
            raise RecordingError(f"recording {self._work_path} failed earlier: {self._failed}")
        if self._closed:
            raise RecordingError(f"recording {self._work_path} is closed")

    def _error(self, exc: OSError) -> RecordingError:
        detail = exc.strerror or str(exc)
        hint = ""
        if exc.errno == errno.ENOSPC:
            hint = "; the chunks written before are intact: run 'gear-rotor-sim recover' on the file"
        return RecordingError(f"writing {self._work_path} failed: {detail}{hint}", exc.errno)

    def _guard(self, fn):
        try:
            return fn()
        except OSError as exc:
            self._failed = exc
            raise self._error(exc) from exc

    def _timed_flush(self) -> None:
        self._guard(self._writer.flush)
        if self._fsync:
            self._guard(self._sink.fsync)
        self._chunk_first_ns = None
        self._last_flush_wall = time.monotonic()

    def _flush_loop(self) -> None:
        while not self._stop.wait(self._period_s / 4):
            with self._lock:
                if self._closed or self._failed is not None:
                    return
                if (
                    self._chunk_first_ns is not None
                    and time.monotonic() - self._last_flush_wall >= self._period_s
                ):
                    try:
                        self._timed_flush()
                    except RecordingError:
                        return


def _fsync_dir(folder: Path) -> None:
    """fsync a folder so a rename in it survives a power loss (no-op where unsupported)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
