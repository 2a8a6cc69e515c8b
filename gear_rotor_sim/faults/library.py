"""The library as a whole: names, and every effect applicable to a rig at its neutral value."""

from __future__ import annotations

import functools
from typing import Any

from gear_rotor_sim.config import RigConfig
from gear_rotor_sim.faults.base import Effect
from gear_rotor_sim.faults.baseline import BearingStiffnessDamping, MeshStiffnessDamping
from gear_rotor_sim.faults.bearing import BEARING_6206, BearingDefect, BearingGeometry
from gear_rotor_sim.faults.crack import ShaftCrack
from gear_rotor_sim.faults.gear import GearEccentricity, GearMisalignment, ToothDamage, ToothWear
from gear_rotor_sim.faults.operating import TemperatureOffset
from gear_rotor_sim.faults.shaft import MassUnbalance, ShaftMisalignment


def effect_name(effect: Effect) -> str:
    """Library name of an effect instance (``pinion_eccentricity``, ``inner_race_defect``, ...)."""
    if isinstance(effect, GearEccentricity):
        return f"{effect.member}_eccentricity"
    if isinstance(effect, BearingDefect):
        return effect.effect_name
    return effect.name


LIBRARY_NAMES: tuple[str, ...] = (
    "pinion_eccentricity",
    "gear_eccentricity",
    "mass_unbalance",
    "shaft_misalignment",
    "tooth_damage",
    "tooth_wear",
    "gear_misalignment",
    "temperature_offset",
    "outer_race_defect",
    "inner_race_defect",
    "ball_defect",
    "shaft_crack",
)


def candidate_effects(
    cfg: RigConfig,
    bearing_geometry: BearingGeometry = BEARING_6206,
    bearings: tuple[int, ...] | None = None,
    unbalance_nodes: tuple[int, ...] | None = None,
    misalignment_nodes: tuple[int, ...] | None = None,
    names: tuple[str, ...] | None = None,
    bearing_pulse_s: float | None = None,
    crack_nodes: tuple[int, ...] | None = None,
) -> list[Effect]:
    """All library effects applicable to a rig, each at its neutral value with its location fixed.

    Parameters
    ----------
    cfg : RigConfig
        The rig; gear effects are offered only when it has a mesh, on every mesh and both of its
        wheels (labels ``...@mesh<k>`` from the second mesh on).
    bearing_geometry : BearingGeometry
        Geometry used for the bearing-defect frequencies.
    bearings : tuple of int, optional
        1-based bearings considered for defects (default all).
    unbalance_nodes, misalignment_nodes : tuple of int, optional
        1-based nodes; default the gear/disc nodes (unbalance) and the drive node (misalignment).
    names : tuple of str, optional
        Restrict to these library names.
    bearing_pulse_s : float, optional
        Fixed impact duration of the bearing defects (default: the transit time over the nominal
        spall, ``BearingDefect``).
    crack_nodes : tuple of int, optional
        1-based nodes offered a breathing shaft crack (``faults/crack.py``); None (the default): the
        pinion seat of every mesh; ``()`` offers none.
    """
    out: list[Effect] = []
    has_mesh = bool(cfg.meshes)
    if unbalance_nodes is None:
        nodes = [g.node0 + 1 for g in cfg.gears] + [d.node0 + 1 for d in cfg.discs]
        if not nodes:
            nodes = [cfg.n_nodes // 2 + 1]
        unbalance_nodes = tuple(dict.fromkeys(nodes))
    if misalignment_nodes is None:
        misalignment_nodes = (cfg.drive.node0 + 1,)
    if bearings is None:
        bearings = tuple(range(1, len(cfg.bearings) + 1))
    meshes = range(1, len(cfg.meshes) + 1)  # every mesh of a multi-stage rig, both wheels of each
    wheels = ("pinion", "gear")
    if has_mesh:
        out += [GearEccentricity(member=w, mesh=k) for k in meshes for w in wheels]
    out += [MassUnbalance(node=n) for n in unbalance_nodes]
    out += [ShaftMisalignment(node=n) for n in misalignment_nodes]
    if has_mesh:
        out += [ToothDamage(wheel=w, mesh=k) for k in meshes for w in wheels]
        out += [ToothWear(mesh=k) for k in meshes]
        out += [GearMisalignment(member=w, mesh=k) for k in meshes for w in wheels]
    out.append(TemperatureOffset())
    if crack_nodes is None:
        crack_nodes = tuple(dict.fromkeys(cfg.gear(m.pinion).node0 + 1 for m in cfg.meshes))
    out += [ShaftCrack(node=n) for n in crack_nodes]
    for kind in ("outer", "inner", "ball"):
        out += [
            BearingDefect(kind=kind, bearing=b, geometry=bearing_geometry, pulse_s=bearing_pulse_s)
            for b in bearings
        ]
    if names is not None:
        out = [e for e in out if effect_name(e) in names]
    return out


#: Names of the baseline parameter sets (uncertain nominal values; ``baseline_updates``, never effects).
BASELINE_NAMES: tuple[str, ...] = ("mesh_stiffness_damping", "bearing_stiffness_damping")


def baseline_candidates(cfg: RigConfig) -> list[Effect]:
    """Baseline parameter sets applicable to a rig, at their nominal values (scale 1)."""
    out: list[Effect] = []
    if cfg.meshes:
        out.append(MeshStiffnessDamping())
    if cfg.bearings:
        out.append(BearingStiffnessDamping())
    return out


#: Constructors of the injectable effects by library name: ``EFFECT_TYPES[name](**fields)``, where the
#: fields are the effect's location keys (``mesh``, ``wheel``, ``tooth``, ``node``, ``bearing``) and
#: parameters (``depth``, ``eccentricity_m``, ...). A new library effect registers here.
EFFECT_TYPES: dict[str, Any] = {
    "pinion_eccentricity": functools.partial(GearEccentricity, member="pinion"),
    "gear_eccentricity": functools.partial(GearEccentricity, member="gear"),
    "mass_unbalance": MassUnbalance,
    "shaft_misalignment": ShaftMisalignment,
    "tooth_damage": ToothDamage,
    "tooth_wear": ToothWear,
    "gear_misalignment": GearMisalignment,
    "temperature_offset": TemperatureOffset,
    "outer_race_defect": functools.partial(BearingDefect, kind="outer"),
    "inner_race_defect": functools.partial(BearingDefect, kind="inner"),
    "ball_defect": functools.partial(BearingDefect, kind="ball"),
    "shaft_crack": ShaftCrack,
    "mesh_stiffness_damping": MeshStiffnessDamping,
    "bearing_stiffness_damping": BearingStiffnessDamping,
}
