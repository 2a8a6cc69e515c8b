"""Loader of recorded datasets for algorithm developers: windows of channels with their labels, no ROS.

::

    from gear_rotor_sim import datasets

    for w in datasets.load("DIR", window_s=0.25, skip_s=0.5):
        w.data            # (n_samples, n_channels) float64, SI units
        w.channels        # ("dte", "mesh_force", "bearing1_housing_ax", ...)
        w.labels          # ground truth of the faults in force at the window centre (list of dicts)
        w.fault_types     # e.g. ("tooth_damage",); () for a healthy window
        w.speed_rpm, w.temperature_c

``DIR`` is a dataset folder (``gear-rotor-sim dataset``: ``manifest.json`` and one MCAP per run) or
a single ``.mcap`` recording (``gear-rotor-sim record``, the node's recording). The vibration
topics (``gear_rotor_msgs/msg/VibrationChunk``) are joined on their sample index; the labels come
from the fault list recorded on ``/gear_rotor/faults`` (the requests: type, location, parameters,
onset, growth), evaluated at the window centre, so a growing fault carries its severity at that time.
Windows do not overlap unless ``hop_s`` is given; a window that reaches into a lost chunk is skipped.
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from gear_rotor_sim.faults.spec import FaultSpec, parse_faults
from gear_rotor_sim.faults.truth import truth

FAULTS_TOPIC = "/gear_rotor/faults"


@dataclass(frozen=True)
class Window:
    """One window of a run: samples, channel names and units, labels, operating point."""

    data: np.ndarray
    channels: tuple[str, ...]
    units: tuple[str, ...]
    sample_rate_hz: float
    t0: float
    speed_rpm: float
    temperature_c: float
    labels: list[dict[str, Any]]
    run: str

    @property
    def fault_types(self) -> tuple[str, ...]:
        """Types of the faults active in the window (``()``: healthy)."""
        return tuple(lab["type"] for lab in self.labels if lab["active"])

    def channel(self, name: str) -> np.ndarray:
        return self.data[:, self.channels.index(name)]


@dataclass
class Run:
    """A whole recording: joined channels, per-sample operating point and the fault list."""

    path: Path
    data: np.ndarray
    channels: tuple[str, ...]
    units: tuple[str, ...]
    sample_rate_hz: float
    first_index: int
    speed_rpm: np.ndarray
    temperature_c: np.ndarray
    valid: np.ndarray
    faults: tuple[FaultSpec, ...]

    def windows(self, window_s: float, skip_s: float = 0.0, hop_s: float | None = None) -> Iterator[Window]:
        """Consecutive windows of ``window_s`` from ``skip_s`` on (``hop_s`` default ``window_s``)."""
        fs = self.sample_rate_hz
        n = round(window_s * fs)
        hop = round((hop_s or window_s) * fs)
        if n < 2 or hop < 1:
            raise ValueError(f"window_s: {window_s!r} gives fewer than 2 samples at {fs:g} Hz")
        start = max(0, round(skip_s * fs) - self.first_index)
        for i in range(start, self.data.shape[0] - n + 1, hop):
            if not self.valid[i : i + n].all():
                continue
            t0 = (self.first_index + i) / fs
            tc = t0 + 0.5 * n / fs
            yield Window(
                self.data[i : i + n],
                self.channels,
                self.units,
                fs,
                t0,
                float(np.mean(self.speed_rpm[i : i + n])),
                float(np.mean(self.temperature_c[i : i + n])),
                truth(self.faults, tc),
                self.path.name,
            )


def read_run(path: str | Path, topics: Sequence[str] | None = None) -> Run:
    """Read one MCAP recording of the project's streams (no ROS needed)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    path = Path(path)
    chunks: dict[str, list] = {}
    fault_lists: list[list[dict]] = []
    with open(path, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for schema, channel, _m, msg in reader.iter_decoded_messages():
            if schema is None:
                continue
            if schema.name.endswith("FaultState") and channel.topic == FAULTS_TOPIC:
                fault_lists.append([json.loads(f.spec_json) for f in msg.faults])
            elif schema.name.endswith("VibrationChunk") and (topics is None or channel.topic in topics):
                names = tuple(msg.channel_names)
                data = np.asarray(msg.data, dtype=float).reshape(-1, len(names))
                chunks.setdefault(channel.topic, []).append(
                    (int(msg.first_sample_index), float(msg.sample_rate_hz), names, tuple(msg.units),
                     float(msg.speed_rpm), float(msg.temperature_c), data)
                )  # fmt: skip
    if not chunks:
        raise ValueError(f"{path}: no VibrationChunk messages" + (f" on {list(topics)}" if topics else ""))
    fs = next(iter(chunks.values()))[0][1]
    lo = max(min(c[0] for c in cs) for cs in chunks.values())
    hi = min(max(c[0] + c[6].shape[0] for c in cs) for cs in chunks.values())
    n = max(hi - lo, 0)
    cols: list[np.ndarray] = []
    names: list[str] = []
    units: list[str] = []
    valid = np.ones(n, dtype=bool)
    speed = np.zeros(n)
    temp = np.zeros(n)
    for k, topic in enumerate(sorted(chunks)):
        cs = sorted(chunks[topic], key=lambda c: c[0])
        if cs[0][1] != fs:
            raise ValueError(f"{path}: topic {topic} has {cs[0][1]} Hz, another {fs} Hz")
        arr = np.full((n, len(cs[0][2])), np.nan)
        have = np.zeros(n, dtype=bool)
        for first, _fs, _nm, _u, sp, tc, data in cs:
            a, b = max(first, lo), min(first + data.shape[0], hi)
            if b <= a:
                continue
            arr[a - lo : b - lo] = data[a - first : b - first]
            have[a - lo : b - lo] = True
            if k == 0:
                speed[a - lo : b - lo] = sp
                temp[a - lo : b - lo] = tc
        valid &= have
        for j, (nm, u) in enumerate(zip(cs[0][2], cs[0][3], strict=True)):
            if nm not in names:
                names.append(nm)
                units.append(u)
                cols.append(arr[:, j])
    faults = parse_faults(fault_lists[-1]) if fault_lists else ()
    return Run(path, np.column_stack(cols), tuple(names), tuple(units), fs, lo, speed, temp, valid, faults)


def load(
    source: str | Path,
    window_s: float = 0.25,
    skip_s: float = 0.5,
    hop_s: float | None = None,
    topics: Sequence[str] | None = None,
) -> Iterator[Window]:
    """Windows of every run of a dataset folder (manifest order) or of one ``.mcap`` file.

    Parameters
    ----------
    source : path
        Dataset folder with ``manifest.json``, or an MCAP file.
    window_s : float
        Window length, s.
    skip_s : float
        Start of the first window (the start-up transient from static equilibrium is skipped), s.
    hop_s : float, optional
        Window spacing (default ``window_s``: no overlap).
    topics : sequence of str, optional
        Vibration topics to join (default all).
    """
    for path in run_files(source):
        yield from read_run(path, topics).windows(window_s, skip_s, hop_s)


def run_files(source: str | Path) -> list[Path]:
    """The MCAP files of a dataset folder (from its manifest) or the file itself."""
    p = Path(source)
    if p.is_file():
        return [p]
    manifest = p / "manifest.json"
    if not manifest.is_file():
        raise FileNotFoundError(f"{p}: neither an MCAP file nor a dataset folder with manifest.json")
    entries = json.loads(manifest.read_text(encoding="utf-8"))["runs"]
    return [p / e["file"] for e in entries]
