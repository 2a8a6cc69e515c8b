"""Faults of the lumped gearbox, with the effect names and main parameters of the effect library.

Each fault is a small dataclass; :func:`parse_fault` reads the CLI form
``name:key=value,key=value``. The physics of each fault is implemented in ``model.py``:

==========================  =====================================================================
name (fields)               physics in this model
==========================  =====================================================================
``tooth_damage``            every pair formed by that tooth has its stiffness multiplied by
(wheel, tooth, depth)       ``1 - depth`` over its whole path (root crack / chipped tooth)
``pinion_eccentricity``,    the geometric centre of the wheel runs ``e`` off its rotation centre:
``gear_eccentricity``       the profile moves ``e`` (cos, sin) of the wheel angle, projected on the
(eccentricity_m, phase_rad) line of action, and the wheel's mass centre whirls (force ``m e w^2``)
``mass_unbalance``          rotating force ``U w^2`` at the pinion (node 5) or the gear (node 14)
(node, unbalance_kg_m,
phase_rad)
``gear_misalignment``       the wheel's tooth lines wobble by ``angle_rad`` (cos of the wheel angle)
(member, angle_rad,         in the plane of action: the face is split in 9 slices whose
phase_rad)                  approach differs by ``angle * xi`` across the face (edge loading,
                            partial contact, softer mesh twice per revolution) and the mesh
                            force gets an axial component ``F_m * angle``
``tooth_wear``              uniform wear ``h`` on the loaded flanks: half backlash + ``h``; plus a
(wear_depth_m)              sliding-wear profile error per pair, ``h`` times the distance from
                            the pitch point relative to its largest value along the path (zero at
                            the pitch point where there is no sliding), stiffness-weighted
``temperature_offset``      the machine runs at declared + ``offset_c``: E(T), thermal axial
(offset_c)                  load, thermal backlash
``outer_race_defect``,      a ball entering and leaving a spall (0.4 mm) in that race of bearing 2
``inner_race_defect``,      (6206: 9 balls, d 9.525 mm, pitch 46 mm) gives a half-sine force pulse
``ball_defect``             of the spall's transit time and peak ``force_n`` times the Hertz load
(force_n, bearing=2,        factor ``max(cos psi, 0)^1.5`` at its position, between race and
defect_angle_rad)           housing; 1 % random slip of the ball passes (Antoni & Randall 2002)
``bearing_stiffness``       all four bearings' radial and axial stiffness times ``scale``
(scale)
``shaft_crack``             NOT in the FE library: a breathing transverse crack on that shaft
(shaft, stiffness_loss,     (Gasch's switching crack): while the crack's mouth is on the tension
phase_rad)                  side the shaft's lateral stiffness normal to the crack drops by
                            ``stiffness_loss`` (fraction); 1x, 2x, 3x of that shaft
``cardan_misalignment``     NOT in the FE library: the motor drives the input shaft through a
(angle_rad, phase_rad)      Cardan (Hooke's) joint bent by ``angle_rad``: the driven end turns
                            ``~ angle^2 / 4 sin(2 psi)`` off uniform; even input orders, torsional
``loose_housing``           NOT in the FE library: bearing 2's housing lifts off its loose foot
(stiffness_loss,            once its push along ``direction_rad`` exceeds ``preload_n``, floats
clearance_m, preload_n,     through the bolt clearance, then the bolts hold it with
direction_rad,              ``(1 - stiffness_loss)`` of the bearing's stiffness (bilinear support,
unbalance_kg_m, phase_rad)  changed load path); driven by the pinion's residual unbalance
==========================  =====================================================================

The physics and derivations of the out-of-library faults: ``shaft_faults.py`` (crack, Cardan joint) and
``loose_housing.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any


@dataclass(frozen=True)
class ToothDamage:
    wheel: str = "pinion"
    tooth: int = 1
    depth: float = 0.0
    name = "tooth_damage"
    main = "depth"

    def __post_init__(self) -> None:
        if self.wheel not in ("pinion", "gear"):
            raise ValueError(f"tooth_damage.wheel: {self.wheel!r} is not one of ['pinion', 'gear']")
        z = 29 if self.wheel == "pinion" else 49
        if not 1 <= int(self.tooth) <= z:
            raise ValueError(f"tooth_damage.tooth: {self.tooth!r} outside 1..{z} for the {self.wheel}")
        check_range("tooth_damage.depth", self.depth, 0.0, 1.0)


@dataclass(frozen=True)
class Eccentricity:
    member: str = "pinion"
    eccentricity_m: float = 0.0
    phase_rad: float = 0.0
    main = "eccentricity_m"

    @property
    def name(self) -> str:
        return f"{self.member}_eccentricity"

    def __post_init__(self) -> None:
        if self.member not in ("pinion", "gear"):
            raise ValueError(f"eccentricity.member: {self.member!r} is not one of ['pinion', 'gear']")
        check_range(f"{self.name}.eccentricity_m", self.eccentricity_m, 0.0, 500e-6)


@dataclass(frozen=True)
class MassUnbalance:
    node: int = 5
    unbalance_kg_m: float = 0.0
    phase_rad: float = 0.0
    name = "mass_unbalance"
    main = "unbalance_kg_m"

    def __post_init__(self) -> None:
        if int(self.node) not in (5, 14):
            raise ValueError(f"mass_unbalance.node: {self.node!r}; allowed 5 (pinion) or 14 (gear)")
        check_range("mass_unbalance.unbalance_kg_m", self.unbalance_kg_m, 0.0, 1e-2)


@dataclass(frozen=True)
class GearMisalignment:
    member: str = "gear"
    angle_rad: float = 0.0
    phase_rad: float = 0.0
    name = "gear_misalignment"
    main = "angle_rad"

    def __post_init__(self) -> None:
        if self.member not in ("pinion", "gear"):
            raise ValueError(f"gear_misalignment.member: {self.member!r} is not one of ['pinion', 'gear']")
        check_range("gear_misalignment.angle_rad", self.angle_rad, 0.0, 0.02)


@dataclass(frozen=True)
class ToothWear:
    wear_depth_m: float = 0.0
    name = "tooth_wear"
    main = "wear_depth_m"

    def __post_init__(self) -> None:
        check_range("tooth_wear.wear_depth_m", self.wear_depth_m, 0.0, 200e-6)


@dataclass(frozen=True)
class TemperatureOffset:
    offset_c: float = 0.0
    name = "temperature_offset"
    main = "offset_c"

    def __post_init__(self) -> None:
        check_range("temperature_offset.offset_c", self.offset_c, -300.0, 300.0)


@dataclass(frozen=True)
class BearingDefect:
    kind: str = "outer"
    force_n: float = 0.0
    bearing: int = 2
    defect_angle_rad: float = -0.5 * math.pi
    main = "force_n"

    @property
    def name(self) -> str:
        return "ball_defect" if self.kind == "ball" else f"{self.kind}_race_defect"

    def __post_init__(self) -> None:
        if self.kind not in ("outer", "inner", "ball"):
            raise ValueError(f"bearing defect kind: {self.kind!r} is not one of ['outer', 'inner', 'ball']")
        if int(self.bearing) != 2:
            raise ValueError(f"{self.name}.bearing: {self.bearing!r}; only bearing 2 (node 9) is modelled")
        check_range(f"{self.name}.force_n", self.force_n, 0.0, 1e5)


@dataclass(frozen=True)
class BearingStiffness:
    scale: float = 1.0
    name = "bearing_stiffness"
    main = "scale"

    def __post_init__(self) -> None:
        check_range("bearing_stiffness.scale", self.scale, 0.1, 10.0)


@dataclass(frozen=True)
class ShaftCrack:
    shaft: str = "pinion"
    stiffness_loss: float = 0.0
    phase_rad: float = 0.0
    name = "shaft_crack"
    main = "stiffness_loss"

    def __post_init__(self) -> None:
        if self.shaft not in ("pinion", "gear"):
            raise ValueError(f"shaft_crack.shaft: {self.shaft!r} is not one of ['pinion', 'gear']")
        check_range("shaft_crack.stiffness_loss", self.stiffness_loss, 0.0, 0.5)


@dataclass(frozen=True)
class CardanMisalignment:
    angle_rad: float = 0.0
    phase_rad: float = 0.0
    name = "cardan_misalignment"
    main = "angle_rad"

    def __post_init__(self) -> None:
        check_range("cardan_misalignment.angle_rad", self.angle_rad, 0.0, 0.35)


@dataclass(frozen=True)
class LooseHousing:
    """Bearing 2's housing on a loose foot (``loose_housing.py``); ``direction_rad`` turns the lift direction
    from the normal of the line of action (0: across the static mesh load) towards the line of action."""

    stiffness_loss: float = 0.0
    clearance_m: float = 0.0
    preload_n: float = 0.0
    direction_rad: float = 0.0
    unbalance_kg_m: float = 0.0
    phase_rad: float = 0.0
    name = "loose_housing"
    main = "stiffness_loss"

    def __post_init__(self) -> None:
        check_range("loose_housing.stiffness_loss", self.stiffness_loss, 0.0, 1.0)
        check_range("loose_housing.clearance_m", self.clearance_m, 0.0, 200e-6)
        check_range("loose_housing.preload_n", self.preload_n, 0.0, 1e5)
        check_range("loose_housing.direction_rad", self.direction_rad, -math.pi, math.pi)
        check_range("loose_housing.unbalance_kg_m", self.unbalance_kg_m, 0.0, 1e-2)


#: faults of this generator that the FE effect library does not model
#: (benchmarks/calibration_out_of_library.py)
OUT_OF_LIBRARY = ("shaft_crack", "cardan_misalignment", "loose_housing")

Fault = (
    ToothDamage
    | Eccentricity
    | MassUnbalance
    | GearMisalignment
    | ToothWear
    | TemperatureOffset
    | BearingStiffness
    | ShaftCrack
    | CardanMisalignment
    | LooseHousing
)

FAULT_NAMES = (
    "tooth_damage",
    "pinion_eccentricity",
    "gear_eccentricity",
    "mass_unbalance",
    "gear_misalignment",
    "tooth_wear",
    "temperature_offset",
    "outer_race_defect",
    "inner_race_defect",
    "ball_defect",
    "bearing_stiffness",
    "shaft_crack",
    "cardan_misalignment",
    "loose_housing",
)


def check_range(path: str, value: Any, lo: float, hi: float) -> float:
    """``value`` as a float if it is a finite number in ``[lo, hi]``; else a ValueError naming ``path``
    and the range (the generator's faults and its speed and load profiles)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if isinstance(value, bool) or not (math.isfinite(v) and lo <= v <= hi):
        raise ValueError(f"{path}: {value!r} outside the allowed range [{lo:g}, {hi:g}]")
    return v


def make_fault(name: str, **params: Any) -> Fault:
    """A fault by library name and field values (strings are converted)."""
    if name in ("pinion_eccentricity", "gear_eccentricity"):
        cls: Any = Eccentricity
        params = {"member": name.split("_")[0], **params}
    elif name in ("outer_race_defect", "inner_race_defect", "ball_defect"):
        cls = BearingDefect
        params = {"kind": name.split("_")[0], **params}
    else:
        table = {
            "tooth_damage": ToothDamage,
            "mass_unbalance": MassUnbalance,
            "gear_misalignment": GearMisalignment,
            "tooth_wear": ToothWear,
            "temperature_offset": TemperatureOffset,
            "bearing_stiffness": BearingStiffness,
            "shaft_crack": ShaftCrack,
            "cardan_misalignment": CardanMisalignment,
            "loose_housing": LooseHousing,
        }
        if name not in table:
            raise ValueError(f"fault: unknown name {name!r}; allowed: {list(FAULT_NAMES)}")
        cls = table[name]
    kinds = {f.name: f.type for f in fields(cls)}
    out: dict[str, Any] = {}
    for k, v in params.items():
        if k not in kinds:
            raise ValueError(f"{name}.{k}: unknown field; allowed: {sorted(kinds)}")
        if kinds[k] in ("str", str):
            out[k] = str(v)
        elif kinds[k] in ("int", int):
            try:
                out[k] = int(v)
            except ValueError:
                raise ValueError(f"{name}.{k}: expected an integer, got {v!r}") from None
        else:
            try:
                out[k] = float(v)
            except ValueError:
                raise ValueError(f"{name}.{k}: expected a number, got {v!r}") from None
    return cls(**out)


def parse_fault(text: str) -> Fault:
    """``"tooth_damage:wheel=gear,tooth=5,depth=0.3"`` -> :class:`ToothDamage`."""
    name, _, rest = text.partition(":")
    params: dict[str, str] = {}
    for item in filter(None, rest.split(",")):
        key, eq, value = item.partition("=")
        if not eq:
            raise ValueError(f"fault {text!r}: {item!r} is not key=value")
        params[key.strip()] = value.strip()
    return make_fault(name.strip(), **params)


def fault_truth(fault: Fault) -> dict[str, Any]:
    """Ground-truth entry: ``{name, parameters, main}``."""
    params = {f.name: getattr(fault, f.name) for f in fields(fault)}
    if isinstance(fault, Eccentricity):
        params.pop("member")
    if isinstance(fault, BearingDefect):
        params.pop("kind")
    return {"name": fault.name, "parameters": params, "main": fault.main}
