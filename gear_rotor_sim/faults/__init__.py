"""Faults and effects: physical changes of the machine, below the simulator.

One description of each change, applied by the simulator whoever asked for it: the node and
``record --faults`` inject it, datasets label with it, the calibration fits its parameters
(``../shared/ARCHITECTURE.md``, "Effects and faults"). Modules: ``base`` (Effect protocol
defaults, parameter specs), ``gear``, ``shaft``, ``bearing``, ``operating`` (temperature offset),
``crack`` (a breathing shaft crack), ``baseline`` (uncertain nominal parameters, never reported as
faults), ``library`` (names and the candidate set of a rig).
"""

from gear_rotor_sim.faults.base import Effect, ParameterSpec
from gear_rotor_sim.faults.baseline import BASELINE_TYPES, BearingStiffnessDamping, MeshStiffnessDamping
from gear_rotor_sim.faults.bearing import (
    BEARING_6205,
    BEARING_6206,
    BearingDefect,
    BearingGeometry,
    ball_defect,
    inner_race_defect,
    load_zone,
    outer_race_defect,
    static_bearing_force,
    static_load_angle,
)
from gear_rotor_sim.faults.crack import ShaftCrack
from gear_rotor_sim.faults.gear import (
    GearEccentricity,
    GearMisalignment,
    ToothDamage,
    ToothWear,
    mesh_wear_profile,
    tilted_contact_offset,
    tilted_contact_stiffness_factor,
    tooth_share,
    wear_profile,
)
from gear_rotor_sim.faults.library import (
    BASELINE_NAMES,
    LIBRARY_NAMES,
    baseline_candidates,
    candidate_effects,
    effect_name,
)
from gear_rotor_sim.faults.operating import TemperatureOffset
from gear_rotor_sim.faults.shaft import MassUnbalance, ShaftMisalignment

__all__ = [
    "BASELINE_NAMES",
    "BASELINE_TYPES",
    "BEARING_6205",
    "BEARING_6206",
    "LIBRARY_NAMES",
    "BearingDefect",
    "BearingGeometry",
    "BearingStiffnessDamping",
    "Effect",
    "GearEccentricity",
    "GearMisalignment",
    "MassUnbalance",
    "MeshStiffnessDamping",
    "ParameterSpec",
    "ShaftCrack",
    "ShaftMisalignment",
    "TemperatureOffset",
    "ToothDamage",
    "ToothWear",
    "ball_defect",
    "baseline_candidates",
    "candidate_effects",
    "effect_name",
    "inner_race_defect",
    "load_zone",
    "mesh_wear_profile",
    "outer_race_defect",
    "static_bearing_force",
    "static_load_angle",
    "tilted_contact_offset",
    "tilted_contact_stiffness_factor",
    "tooth_share",
    "wear_profile",
]
