"""Output channels: names, units and how each is formed from the state (``ChannelSpec``)."""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

from gear_rotor_sim.system_data import DOF_NAMES, AssembledSystem


@dataclass(frozen=True)
class ChannelSpec:
    """How one output channel is formed: a state row, a mesh scalar, with its unit."""

    name: str
    unit: str
    kind: str  # "row" | "dte" | "force"
    mesh: int = -1
    dof: int = -1  # global DOF for node channels
    order: int = 0  # 0 displacement, 1 velocity, 2 acceleration
    bearing: int = -1  # index into system.bearings
    component: int = -1  # 0..2 for bearing forces


_NODE_RE = re.compile(r"^node(\d+)_(v|a)?(x|y|z|theta_x|theta_y|theta_z)$")
_BEARING_RE = re.compile(r"^bearing(\d+)_f(x|y|z)$")
_MESH_RE = re.compile(r"^(?:mesh(\d+)_)?(dte|mesh_force|force)$")


def available_channels(system: AssembledSystem) -> list[tuple[str, str]]:
    """All channel names of a system with their SI units."""
    out: list[tuple[str, str]] = []
    if system.meshes:  # the first mesh's, and every mesh's by its 1-based number in ``meshes:``
        out += [("dte", "m"), ("mesh_force", "N")]
    for i in range(len(system.meshes)):
        out += [(f"mesh{i + 1}_dte", "m"), (f"mesh{i + 1}_force", "N")]
    for b in system.bearings:
        out += [(f"bearing{b.number}_f{c}", "N") for c in "xyz"]
    for node in range(1, system.n_nodes + 1):
        for prefix, lin, ang in (("", "m", "rad"), ("v", "m/s", "rad/s"), ("a", "m/s^2", "rad/s^2")):
            for d in DOF_NAMES:
                out.append((f"node{node}_{prefix}{d}", ang if d.startswith("theta") else lin))
    return out


def parse_channels(system: AssembledSystem, names: Sequence[str]) -> list[ChannelSpec]:
    """Channel specifications; ValueError naming ``channels`` and the allowed forms otherwise."""
    specs: list[ChannelSpec] = []
    units = dict(available_channels(system))
    numbers = {b.number: i for i, b in enumerate(system.bearings)}
    for name in names:
        if name not in units:
            raise ValueError(
                f"channels: {name!r} is not available; allowed: dte, mesh_force (the first mesh), "
                f"mesh{{1..{len(system.meshes)}}}_dte, mesh{{1..{len(system.meshes)}}}_force, "
                f"bearing{{1..{len(system.bearings)}}}_f{{x,y,z}}, node{{1..{system.n_nodes}}}_[v|a]"
                "{x,y,z,theta_x,theta_y,theta_z}"
            )
        if mm := _MESH_RE.match(name):
            i = int(mm.group(1)) - 1 if mm.group(1) else 0
            specs.append(ChannelSpec(name, units[name], "dte" if mm.group(2) == "dte" else "force", mesh=i))
        elif mb := _BEARING_RE.match(name):
            specs.append(
                ChannelSpec(
                    name,
                    units[name],
                    "row",
                    bearing=numbers[int(mb.group(1))],
                    component="xyz".index(mb.group(2)),
                )
            )
        elif mn := _NODE_RE.match(name):
            order = {None: 0, "v": 1, "a": 2}[mn.group(2)]
            specs.append(
                ChannelSpec(
                    name, units[name], "row", dof=system.dof(int(mn.group(1)), mn.group(3)), order=order
                )
            )
    return specs
