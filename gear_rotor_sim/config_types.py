"""The rig configuration as a frozen SI dataclass tree (:class:`RigConfig` and its parts).

Build one with :func:`gear_rotor_sim.config.load_config`; the YAML schema and its units are described
there. :class:`RigConfig` checks its cross-references (nodes, gear names, materials, shafts of a mesh)
on construction and on :meth:`RigConfig.replace`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from gear_rotor_sim.elements.bearing import BEARING_TYPES, Bearing
from gear_rotor_sim.materials import Material


class ConfigError(ValueError):
    """Invalid rig configuration; the message names the field path and the allowed values."""


# ---------------------------------------------------------------------------------------------------
# Dataclasses (SI)
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ShaftElementConfig:
    """One shaft element (Table 4): length, outer/inner diameter (m), material name."""

    length_m: float
    outer_diameter_m: float
    inner_diameter_m: float
    material: str


@dataclass(frozen=True)
class ShaftConfig:
    """A shaft: consecutive elements; its nodes are numbered consecutively."""

    name: str
    material: str
    elements: tuple[ShaftElementConfig, ...]

    @property
    def n_nodes(self) -> int:
        return len(self.elements) + 1


@dataclass(frozen=True)
class BearingConfig:
    """A bearing at a node (Eq 37)."""

    node0: int
    type_name: str
    properties: Bearing


@dataclass(frozen=True)
class GearConfig:
    """A gear: rigid disc (Sec 3.1) of pitch diameter module*teeth; geometry resolved in SI."""

    name: str
    node0: int
    teeth: int
    material: str
    bore_diameter_m: float
    face_width_m: float
    module_m: float

    @property
    def pitch_diameter_m(self) -> float:
        return self.module_m * self.teeth


@dataclass(frozen=True)
class DiscConfig:
    """A plain rigid disc (no teeth) at a node."""

    node0: int
    outer_diameter_m: float
    bore_diameter_m: float
    width_m: float
    material: str


@dataclass(frozen=True)
class MeshConfig:
    """A spur mesh (Sec 3.2, Table 3; Eqs 22-27).

    ``pinion_teeth``/``gear_teeth`` and the bore diameters are copied from the two gears on loading.
    """

    pinion: str
    gear: str
    pinion_teeth: int
    gear_teeth: int
    module_m: float
    pressure_angle_rad: float
    face_width_m: float
    addendum_coefficient: float
    clearance_coefficient: float
    half_backlash_m: float
    transmission_error_amplitude_m: float
    transmission_error_phase_rad: float
    friction_coefficient: float
    damping_ratio: float
    thermal_backlash: bool
    pinion_bore_diameter_m: float | None = None  # copied from the gears (for the fillet foundation)
    gear_bore_diameter_m: float | None = None
    gear_mass_in_mesh_matrix: bool = False  # Eq 32's M^g added on top of Eq 20's M^d (as published)


@dataclass(frozen=True)
class DriveConfig:
    """Drive condition: theta_z of ``node0`` follows the commanded rotation (rigid motor)."""

    node0: int


@dataclass(frozen=True)
class LoadConfig:
    """Resisting output torque T2 (Table 3) on ``node0``, N m."""

    node0: int
    torque_nm: float


@dataclass(frozen=True)
class RayleighDamping:
    """Shaft structural damping C_shaft = mass_per_s * M_shaft + stiffness_s * K_shaft."""

    mass_per_s: float = 0.0
    stiffness_s: float = 0.0


@dataclass(frozen=True)
class RigConfig:
    """Validated rig description in SI. Build it with :func:`load_config`."""

    name: str
    reference_temperature_c: float
    materials: dict[str, Material]
    shafts: tuple[ShaftConfig, ...]
    bearings: tuple[BearingConfig, ...]
    gears: tuple[GearConfig, ...]
    meshes: tuple[MeshConfig, ...]
    drive: DriveConfig
    load: LoadConfig | None
    rayleigh_damping: RayleighDamping = field(default_factory=RayleighDamping)
    shear_coefficient: float | None = None  # None: Cowper's value per section
    bearing_types: dict[str, Bearing] = field(default_factory=lambda: dict(BEARING_TYPES))
    discs: tuple[DiscConfig, ...] = ()

    def __post_init__(self) -> None:
        _check_references(self)

    @property
    def n_nodes(self) -> int:
        """Total number of nodes over all shafts."""
        return sum(s.n_nodes for s in self.shafts)

    @property
    def node_offsets(self) -> tuple[int, ...]:
        """0-based global index of the first node of each shaft."""
        offsets, n = [], 0
        for s in self.shafts:
            offsets.append(n)
            n += s.n_nodes
        return tuple(offsets)

    def shaft_of_node(self, node0: int) -> int:
        """Shaft index of a 0-based node."""
        for k, (off, s) in enumerate(zip(self.node_offsets, self.shafts, strict=True)):
            if off <= node0 < off + s.n_nodes:
                return k
        raise ValueError(f"node: {node0 + 1} is outside 1..{self.n_nodes}")

    def gear(self, name: str) -> GearConfig:
        """The gear called ``name``."""
        for g in self.gears:
            if g.name == name:
                return g
        raise KeyError(name)

    def replace(self, **changes: Any) -> RigConfig:
        """Copy with fields replaced (``dataclasses.replace``); references are re-validated."""
        return dataclasses.replace(self, **changes)

    def with_bearing_type(self, type_name: str) -> RigConfig:
        """Copy with every bearing of type ``type_name`` (one of ``bearing_types``)."""
        if type_name not in self.bearing_types:
            raise ConfigError(f"bearings[].type: {type_name!r} is not one of {sorted(self.bearing_types)}")
        props = self.bearing_types[type_name]
        return self.replace(
            bearings=tuple(
                dataclasses.replace(b, type_name=type_name, properties=props) for b in self.bearings
            )
        )


def _check_references(cfg: RigConfig) -> None:
    """Cross-reference checks shared by loading and :meth:`RigConfig.replace`."""
    n = cfg.n_nodes
    for k, b in enumerate(cfg.bearings):
        if not 0 <= b.node0 < n:
            raise ConfigError(f"bearings[{k}].node: node {b.node0 + 1} does not exist; allowed 1..{n}")
    names = [g.name for g in cfg.gears]
    for k, g in enumerate(cfg.gears):
        if names.count(g.name) > 1:
            raise ConfigError(
                f"gears[{k}].name: gear name {g.name!r} is used twice; gear names must be unique"
            )
        if not 0 <= g.node0 < n:
            raise ConfigError(f"gears[{k}].node: node {g.node0 + 1} does not exist; allowed 1..{n}")
        if g.material not in cfg.materials:
            raise ConfigError(
                f"gears[{k}].material: unknown material {g.material!r}; allowed {sorted(cfg.materials)}"
            )
    for k, d in enumerate(cfg.discs):
        if not 0 <= d.node0 < n:
            raise ConfigError(f"discs[{k}].node: node {d.node0 + 1} does not exist; allowed 1..{n}")
    for k, m in enumerate(cfg.meshes):
        for role in ("pinion", "gear"):
            if getattr(m, role) not in names:
                raise ConfigError(
                    f"meshes[{k}].{role}: unknown gear {getattr(m, role)!r}; allowed {sorted(names)}"
                )
        sp = cfg.shaft_of_node(cfg.gear(m.pinion).node0)
        sg = cfg.shaft_of_node(cfg.gear(m.gear).node0)
        if sp == sg:
            raise ConfigError(
                f"meshes[{k}].gear: pinion {m.pinion!r} and gear {m.gear!r} are both on shaft {sp + 1} "
                f"({cfg.shafts[sp].name!r}); they must be on different shafts"
            )
    if not 0 <= cfg.drive.node0 < n:
        raise ConfigError(f"drive.node: node {cfg.drive.node0 + 1} does not exist; allowed 1..{n}")
    if cfg.load is not None and not 0 <= cfg.load.node0 < n:
        raise ConfigError(f"load.node: node {cfg.load.node0 + 1} does not exist; allowed 1..{n}")
