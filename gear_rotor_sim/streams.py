"""Virtual vibration-sensor streams: which channels go to which topic, and the message fields.

Pure Python (no ROS): the ROS node fills ``gear_rotor_msgs/msg/VibrationChunk`` from
:func:`chunk_fields`, and the MCAP recorder serialises the very same fields, so a recording made
offline and one made by the node carry identical messages.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gear_rotor_sim.blocks import SampleBlock

TOPIC_PREFIX = "/gear_rotor"


@dataclass(frozen=True)
class StreamSpec:
    """One published stream: a topic carrying a fixed set of channels."""

    name: str
    channels: tuple[str, ...]
    frame_id: str

    @property
    def topic(self) -> str:
        return f"{TOPIC_PREFIX}/{self.name}"


def default_streams(
    n_bearings: int,
    displacement_nodes: tuple[int, ...] = (),
    displacement_dofs: tuple[str, ...] = ("x", "y", "z"),
    acceleration_nodes: tuple[int, ...] = (),
    has_mesh: bool = True,
    n_meshes: int = 1,
) -> list[StreamSpec]:
    """The standard streams: DTE and mesh force, bearing forces, node displacements, accelerations.

    Parameters
    ----------
    n_bearings : int
        Bearings are numbered 1..n_bearings as in the paper.
    displacement_nodes, acceleration_nodes : tuple of int
        1-based node numbers (Fig 5) to publish.
    n_meshes : int
        Meshes of the rig: with more than one the DTE stream carries ``mesh{k}_dte``, ``mesh{k}_force``
        of every mesh (1-based in the order of ``meshes:``) instead of ``dte``, ``mesh_force``.
    """
    streams: list[StreamSpec] = []
    if has_mesh:
        mesh_ch = ("dte", "mesh_force")
        if n_meshes > 1:
            mesh_ch = tuple(f"mesh{k}_{q}" for k in range(1, n_meshes + 1) for q in ("dte", "force"))
        streams.append(StreamSpec("dte", mesh_ch, "gear_mesh"))
    forces = tuple(f"bearing{k}_f{d}" for k in range(1, n_bearings + 1) for d in "xyz")
    if forces:
        streams.append(StreamSpec("bearing_forces", forces, "gearbox_housing"))
    if displacement_nodes:
        disp = tuple(f"node{n}_{d}" for n in displacement_nodes for d in displacement_dofs)
        streams.append(StreamSpec("displacements", disp, "gearbox_housing"))
    if acceleration_nodes:
        acc = tuple(f"node{n}_a{d}" for n in acceleration_nodes for d in ("x", "y", "z"))
        streams.append(StreamSpec("accelerations", acc, "gearbox_housing"))
    return streams


def time_to_stamp(t: float) -> tuple[int, int]:
    """Split a non-negative time in seconds into (sec, nanosec) as builtin_interfaces/Time."""
    ns = round(t * 1e9)
    return ns // 1_000_000_000, ns % 1_000_000_000


def chunk_fields(block: SampleBlock, spec: StreamSpec, sequence: int) -> dict:
    """Field values of one ``VibrationChunk`` message for ``spec``'s channels of ``block``.

    Returns a dict with keys ``stamp_sec``, ``stamp_nanosec``, ``frame_id``, ``sequence``,
    ``first_sample_index``, ``sample_rate_hz``, ``speed_rpm``, ``temperature_c``,
    ``channel_names``, ``units``, ``layout_dim`` (list of (label, size, stride)), ``data``
    (C-contiguous float64, row-major sample x channel, flattened).
    """
    sub = block if block.channels == tuple(spec.channels) else block.select(spec.channels)
    sec, nsec = time_to_stamp(block.t0)
    n, c = sub.data.shape
    return {
        "stamp_sec": sec,
        "stamp_nanosec": nsec,
        "frame_id": spec.frame_id,
        "sequence": int(sequence),
        "first_sample_index": int(block.first_index),
        "sample_rate_hz": float(block.sample_rate_hz),
        "speed_rpm": float(block.speed_rpm[0]) if block.speed_rpm.size else 0.0,
        "temperature_c": float(block.temperature_c[0]) if block.temperature_c.size else 0.0,
        "channel_names": list(sub.channels),
        "units": list(sub.units),
        "layout_dim": [("sample", n, n * c), ("channel", c, c)],
        "data": np.ascontiguousarray(sub.data, dtype=np.float64).ravel(),
    }
