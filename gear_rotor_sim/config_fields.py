"""Reading the fields of a rig file: each section parsed into the SI dataclasses, every error a
:class:`~gear_rotor_sim.config_types.ConfigError` naming the field path and the allowed values.

:func:`parse_rig` is the whole file; :func:`gear_rotor_sim.config.load_config` reads the source
(file, config name or dict) and calls it.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from gear_rotor_sim.config_types import (
    BearingConfig,
    ConfigError,
    DiscConfig,
    DriveConfig,
    GearConfig,
    LoadConfig,
    MeshConfig,
    RayleighDamping,
    RigConfig,
    ShaftConfig,
    ShaftElementConfig,
)
from gear_rotor_sim.elements.bearing import BEARING_TYPES, Bearing
from gear_rotor_sim.materials import OUT_OF_RANGE_POLICIES, Material


# ---------------------------------------------------------------------------------------------------
# Validation helpers
# ---------------------------------------------------------------------------------------------------
def _mapping(value: Any, path: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise ConfigError(f"{path}: expected a mapping, got {type(value).__name__}")
    return value


def _list(value: Any, path: str) -> list[Any]:
    if not isinstance(value, list | tuple):
        raise ConfigError(f"{path}: expected a list, got {type(value).__name__}")
    return list(value)


def _keys(d: Mapping[str, Any], path: str, required: set[str], optional: set[str]) -> None:
    allowed = required | optional
    unknown = sorted(str(k) for k in d if k not in allowed)
    if unknown:
        where = f"{path}.{unknown[0]}" if path else unknown[0]
        raise ConfigError(f"{where}: unknown key; allowed keys are {sorted(allowed)}")
    missing = sorted(required - set(d))
    if missing:
        where = f"{path}.{missing[0]}" if path else missing[0]
        raise ConfigError(f"{where}: missing required key; required keys are {sorted(required)}")


def _number(
    value: Any,
    path: str,
    *,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
) -> float:
    if isinstance(value, str):
        # YAML 1.1 (PyYAML) reads exponent literals without a sign or dot ("1.15e8") as strings.
        try:
            value = float(value)
        except ValueError:
            raise ConfigError(f"{path}: {value!r} is not a number") from None
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ConfigError(f"{path}: {value!r} is not a number")
    x = float(value)
    conds = []
    if gt is not None:
        conds.append(f"> {gt:g}")
    if ge is not None:
        conds.append(f">= {ge:g}")
    if lt is not None:
        conds.append(f"< {lt:g}")
    if le is not None:
        conds.append(f"<= {le:g}")
    allowed = " and ".join(conds) if conds else "finite"
    ok = math.isfinite(x)
    ok = ok and (gt is None or x > gt) and (ge is None or x >= ge)
    ok = ok and (lt is None or x < lt) and (le is None or x <= le)
    if not ok:
        raise ConfigError(f"{path}: {value!r} is out of range; allowed: {allowed}")
    return x


def _string(value: Any, path: str) -> str:
    if not isinstance(value, str) or not value:
        raise ConfigError(f"{path}: {value!r} must be a non-empty string")
    return value


def _node(value: Any, path: str, n_nodes: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ConfigError(f"{path}: {value!r} must be an integer node number in 1..{n_nodes}")
    if not 1 <= int(value) <= n_nodes:
        raise ConfigError(f"{path}: node {value} does not exist; allowed 1..{n_nodes}")
    return int(value) - 1


def _material_name(value: Any, path: str, materials: Mapping[str, Material]) -> str:
    name = _string(value, path)
    if name not in materials:
        raise ConfigError(f"{path}: unknown material {name!r}; allowed {sorted(materials)}")
    return name


# ---------------------------------------------------------------------------------------------------
# Section parsers
# ---------------------------------------------------------------------------------------------------
_TOP_REQUIRED = {"reference_temperature_c", "materials", "shafts", "bearings", "drive"}
_TOP_OPTIONAL = {
    "name",
    "shear_coefficient",
    "rayleigh_damping",
    "bearing_types",
    "gears",
    "discs",
    "meshes",
    "load",
}
_MATERIAL_KEYS = {
    "density_kg_m3",
    "expansion_coefficient_per_c",
    "temperature_c",
    "youngs_modulus_gpa",
    "poisson_ratio",
}
_BEARING_TYPE_KEYS = {
    "k_radial_n_per_m",
    "k_axial_n_per_m",
    "k_tilt_nm_per_rad",
    "c_radial_ns_per_m",
    "c_axial_ns_per_m",
    "c_tilt_nms_per_rad",
}
_MESH_REQUIRED = {
    "pinion",
    "gear",
    "module_mm",
    "pressure_angle_deg",
    "face_width_mm",
    "half_backlash_um",
    "transmission_error_amplitude_um",
    "friction_coefficient",
    "damping_ratio",
}
_MESH_OPTIONAL = {
    "addendum_coefficient",
    "clearance_coefficient",
    "transmission_error_phase_rad",
    "thermal_backlash",
    "gear_mass_in_mesh_matrix",
}
PRESSURE_ANGLE_RANGE_DEG = (10.0, 35.0)  # exclusive
ADDENDUM_RANGE = (0.5, 1.5)  # inclusive
CLEARANCE_RANGE = (0.0, 0.5)  # (0, 0.5]
MIN_TEETH = 5


def _parse_material(name: str, d: Any, ref_t: float) -> Material:
    path = f"materials.{name}"
    d = _mapping(d, path)
    _keys(d, path, _MATERIAL_KEYS, {"out_of_range"})
    temps = [_number(t, f"{path}.temperature_c[{i}]") for i, t in enumerate(_list(d["temperature_c"], path))]
    emod = [
        _number(e, f"{path}.youngs_modulus_gpa[{i}]", gt=0.0) * 1e9
        for i, e in enumerate(_list(d["youngs_modulus_gpa"], f"{path}.youngs_modulus_gpa"))
    ]
    nus = [
        _number(v, f"{path}.poisson_ratio[{i}]", gt=0.0, lt=0.5)
        for i, v in enumerate(_list(d["poisson_ratio"], f"{path}.poisson_ratio"))
    ]
    if not temps:
        raise ConfigError(f"{path}.temperature_c: must list at least one temperature")
    if not len(temps) == len(emod) == len(nus):
        raise ConfigError(
            f"{path}.youngs_modulus_gpa: temperature_c, youngs_modulus_gpa and poisson_ratio must have the "
            f"same length ({len(temps)}, {len(emod)}, {len(nus)})"
        )
    if any(b <= a for a, b in itertools.pairwise(temps)):
        raise ConfigError(f"{path}.temperature_c: {temps} must be strictly increasing")
    policy = d.get("out_of_range", "error")
    if policy not in OUT_OF_RANGE_POLICIES:
        raise ConfigError(f"{path}.out_of_range: {policy!r} is not one of {list(OUT_OF_RANGE_POLICIES)}")
    return Material(
        name=name,
        density=_number(d["density_kg_m3"], f"{path}.density_kg_m3", gt=0.0),
        expansion_coefficient=_number(
            d["expansion_coefficient_per_c"], f"{path}.expansion_coefficient_per_c", ge=0.0
        ),
        temperatures_c=tuple(temps),
        youngs_moduli=tuple(emod),
        poisson_ratios=tuple(nus),
        out_of_range=policy,
        reference_temperature_c=ref_t,
    )


def _parse_shaft(k: int, d: Any, materials: Mapping[str, Material]) -> ShaftConfig:
    path = f"shafts[{k}]"
    d = _mapping(d, path)
    _keys(d, path, {"elements", "material"}, {"name"})
    name = _string(d.get("name", f"shaft{k + 1}"), f"{path}.name")
    mat = _material_name(d["material"], f"{path}.material", materials)
    raw = _list(d["elements"], f"{path}.elements")
    if not raw:
        raise ConfigError(f"{path}.elements: a shaft needs at least one element")
    elements = []
    for j, e in enumerate(raw):
        p = f"{path}.elements[{j}]"
        e = _mapping(e, p)
        _keys(e, p, {"length_mm", "outer_diameter_mm"}, {"inner_diameter_mm", "material"})
        length = _number(e["length_mm"], f"{p}.length_mm", gt=0.0) * 1e-3
        outer = _number(e["outer_diameter_mm"], f"{p}.outer_diameter_mm", gt=0.0) * 1e-3
        inner = _number(e.get("inner_diameter_mm", 0.0), f"{p}.inner_diameter_mm", ge=0.0) * 1e-3
        if inner >= outer:
            raise ConfigError(
                f"{p}.inner_diameter_mm: {inner * 1e3:g} must be < outer_diameter_mm ({outer * 1e3:g}); "
                "allowed 0 <= inner < outer"
            )
        emat = _material_name(e["material"], f"{p}.material", materials) if "material" in e else mat
        elements.append(ShaftElementConfig(length, outer, inner, emat))
    return ShaftConfig(name=name, material=mat, elements=tuple(elements))


def _parse_bearing_type(name: str, d: Any) -> Bearing:
    path = f"bearing_types.{name}"
    d = _mapping(d, path)
    _keys(d, path, _BEARING_TYPE_KEYS, set())
    return Bearing(
        k_radial=_number(d["k_radial_n_per_m"], f"{path}.k_radial_n_per_m", gt=0.0),
        k_axial=_number(d["k_axial_n_per_m"], f"{path}.k_axial_n_per_m", gt=0.0),
        k_tilt=_number(d["k_tilt_nm_per_rad"], f"{path}.k_tilt_nm_per_rad", ge=0.0),
        c_radial=_number(d["c_radial_ns_per_m"], f"{path}.c_radial_ns_per_m", ge=0.0),
        c_axial=_number(d["c_axial_ns_per_m"], f"{path}.c_axial_ns_per_m", ge=0.0),
        c_tilt=_number(d["c_tilt_nms_per_rad"], f"{path}.c_tilt_nms_per_rad", ge=0.0),
        name=str(name),
    )


def _shaft_diameter_at(shafts: tuple[ShaftConfig, ...], node0: int) -> float:
    """Largest outer diameter of the elements adjacent to a node (the seat of a disc)."""
    off = 0
    for s in shafts:
        if off <= node0 < off + s.n_nodes:
            local = node0 - off
            adjacent = [s.elements[j] for j in (local - 1, local) if 0 <= j < len(s.elements)]
            return max(e.outer_diameter_m for e in adjacent)
        off += s.n_nodes
    raise ValueError(node0)


def _parse_mesh(k: int, d: Any, gear_raw: Mapping[str, tuple[int, Mapping[str, Any]]]) -> MeshConfig:
    path = f"meshes[{k}]"
    d = _mapping(d, path)
    _keys(d, path, _MESH_REQUIRED, _MESH_OPTIONAL)
    names = {}
    for role in ("pinion", "gear"):
        nm = _string(d[role], f"{path}.{role}")
        if nm not in gear_raw:
            raise ConfigError(f"{path}.{role}: unknown gear {nm!r}; allowed {sorted(gear_raw)}")
        names[role] = nm
    if names["pinion"] == names["gear"]:
        raise ConfigError(
            f"{path}.gear: {names['gear']!r} is also the pinion; a mesh needs two different gears"
        )
    tb = d.get("thermal_backlash", True)
    if not isinstance(tb, bool):
        raise ConfigError(f"{path}.thermal_backlash: {tb!r} must be true or false")
    gm = d.get("gear_mass_in_mesh_matrix", False)
    if not isinstance(gm, bool):
        raise ConfigError(f"{path}.gear_mass_in_mesh_matrix: {gm!r} must be true or false")
    lo, hi = PRESSURE_ANGLE_RANGE_DEG
    return MeshConfig(
        pinion=names["pinion"],
        gear=names["gear"],
        pinion_teeth=int(gear_raw[names["pinion"]][1]["teeth"]),
        gear_teeth=int(gear_raw[names["gear"]][1]["teeth"]),
        module_m=_number(d["module_mm"], f"{path}.module_mm", gt=0.0) * 1e-3,
        pressure_angle_rad=math.radians(
            _number(d["pressure_angle_deg"], f"{path}.pressure_angle_deg", gt=lo, lt=hi)
        ),
        face_width_m=_number(d["face_width_mm"], f"{path}.face_width_mm", gt=0.0) * 1e-3,
        addendum_coefficient=_number(
            d.get("addendum_coefficient", 1.0),
            f"{path}.addendum_coefficient",
            ge=ADDENDUM_RANGE[0],
            le=ADDENDUM_RANGE[1],
        ),
        clearance_coefficient=_number(
            d.get("clearance_coefficient", 0.25),
            f"{path}.clearance_coefficient",
            gt=CLEARANCE_RANGE[0],
            le=CLEARANCE_RANGE[1],
        ),
        half_backlash_m=_number(d["half_backlash_um"], f"{path}.half_backlash_um", ge=0.0) * 1e-6,
        transmission_error_amplitude_m=_number(
            d["transmission_error_amplitude_um"], f"{path}.transmission_error_amplitude_um", ge=0.0
        )
        * 1e-6,
        transmission_error_phase_rad=_number(
            d.get("transmission_error_phase_rad", 0.0), f"{path}.transmission_error_phase_rad"
        ),
        friction_coefficient=_number(
            d["friction_coefficient"], f"{path}.friction_coefficient", ge=0.0, lt=1.0
        ),
        damping_ratio=_number(d["damping_ratio"], f"{path}.damping_ratio", ge=0.0),
        thermal_backlash=tb,
        gear_mass_in_mesh_matrix=gm,
    )


def _parse_gears(
    raw: list[Any],
    raw_meshes: list[Any],
    shafts: tuple[ShaftConfig, ...],
    materials: Mapping[str, Material],
    n_nodes: int,
) -> tuple[tuple[GearConfig, ...], tuple[MeshConfig, ...]]:
    gear_raw: dict[str, tuple[int, Mapping[str, Any]]] = {}
    for k, g in enumerate(raw):
        path = f"gears[{k}]"
        g = _mapping(g, path)
        _keys(
            g, path, {"name", "node", "teeth", "material"}, {"bore_diameter_mm", "face_width_mm", "module_mm"}
        )
        nm = _string(g["name"], f"{path}.name")
        if nm in gear_raw:
            raise ConfigError(f"{path}.name: gear name {nm!r} is used twice; gear names must be unique")
        teeth = g["teeth"]
        if isinstance(teeth, bool) or not isinstance(teeth, int | np.integer) or teeth < MIN_TEETH:
            raise ConfigError(f"{path}.teeth: {teeth!r} must be an integer >= {MIN_TEETH}")
        gear_raw[nm] = (k, g)
    meshes = tuple(_parse_mesh(k, m, gear_raw) for k, m in enumerate(raw_meshes))
    gears = []
    for nm, (k, g) in gear_raw.items():
        path = f"gears[{k}]"
        node0 = _node(g["node"], f"{path}.node", n_nodes)
        mat = _material_name(g["material"], f"{path}.material", materials)
        own = [m for m in meshes if nm in (m.pinion, m.gear)]
        if "module_mm" in g:
            module = _number(g["module_mm"], f"{path}.module_mm", gt=0.0) * 1e-3
            for m in own:
                if not math.isclose(m.module_m, module, rel_tol=1e-12):
                    raise ConfigError(
                        f"{path}.module_mm: {module * 1e3:g} differs from its mesh's "
                        f"module_mm {m.module_m * 1e3:g}"
                    )
        elif own:
            module = own[0].module_m
        else:
            raise ConfigError(f"{path}.module_mm: gear {nm!r} is in no mesh, so module_mm is required (> 0)")
        if "face_width_mm" in g:
            width = _number(g["face_width_mm"], f"{path}.face_width_mm", gt=0.0) * 1e-3
        elif own:
            width = max(m.face_width_m for m in own)
        else:
            raise ConfigError(
                f"{path}.face_width_mm: gear {nm!r} is in no mesh, so face_width_mm is required (> 0)"
            )
        if "bore_diameter_mm" in g:
            bore = _number(g["bore_diameter_mm"], f"{path}.bore_diameter_mm", ge=0.0) * 1e-3
        else:
            bore = _shaft_diameter_at(shafts, node0)
        pitch = module * int(g["teeth"])
        if bore >= pitch:
            raise ConfigError(
                f"{path}.bore_diameter_mm: bore {bore * 1e3:g} mm must be < pitch diameter "
                f"module*teeth = {pitch * 1e3:g} mm"
            )
        gears.append(GearConfig(nm, node0, int(g["teeth"]), mat, bore, width, module))
    bores = {g.name: g.bore_diameter_m for g in gears}
    meshes = tuple(
        dataclasses.replace(m, pinion_bore_diameter_m=bores[m.pinion], gear_bore_diameter_m=bores[m.gear])
        for m in meshes
    )
    return tuple(gears), meshes


def _parse_disc(
    k: int, d: Any, shafts: tuple[ShaftConfig, ...], materials: Mapping[str, Material], n: int
) -> DiscConfig:
    path = f"discs[{k}]"
    d = _mapping(d, path)
    _keys(d, path, {"node", "outer_diameter_mm", "width_mm", "material"}, {"bore_diameter_mm"})
    node0 = _node(d["node"], f"{path}.node", n)
    outer = _number(d["outer_diameter_mm"], f"{path}.outer_diameter_mm", gt=0.0) * 1e-3
    width = _number(d["width_mm"], f"{path}.width_mm", gt=0.0) * 1e-3
    if "bore_diameter_mm" in d:
        bore = _number(d["bore_diameter_mm"], f"{path}.bore_diameter_mm", ge=0.0) * 1e-3
    else:
        bore = _shaft_diameter_at(shafts, node0)
    if bore >= outer:
        raise ConfigError(
            f"{path}.bore_diameter_mm: bore {bore * 1e3:g} mm must be < outer_diameter_mm {outer * 1e3:g}"
        )
    return DiscConfig(node0, outer, bore, width, _material_name(d["material"], f"{path}.material", materials))


def _shear_coefficient(value: Any) -> float | None:
    if value in ("solid_circular", "cowper"):
        return None
    if isinstance(value, str):
        raise ConfigError(
            f"shear_coefficient: {value!r} is not 'solid_circular', 'cowper' or a number in (0, 2]"
        )
    return _number(value, "shear_coefficient", gt=0.0, le=2.0)


def _validate_involute(cfg: RigConfig) -> None:
    """Involute validity of each pair (undercut, contact ratio) by ``gears.validate_pair`` if present."""
    try:
        from gear_rotor_sim import gears as gears_module
    except ImportError:
        return
    validate_pair = getattr(gears_module, "validate_pair", None)
    if validate_pair is None:
        return
    for k, m in enumerate(cfg.meshes):
        try:
            validate_pair(
                m.pinion_teeth,
                m.gear_teeth,
                m.module_m,
                m.pressure_angle_rad,
                m.face_width_m,
                m.addendum_coefficient,
                m.clearance_coefficient,
            )
        except ValueError as exc:
            raise ConfigError(f"meshes[{k}].{exc}") from exc


def parse_rig(d: Mapping[str, Any]) -> RigConfig:
    """Validate the mapping of a rig file (the schema of :mod:`gear_rotor_sim.config`) into a
    :class:`RigConfig` in SI.

    Raises
    ------
    ConfigError
        Naming the field path and the allowed values.
    """
    _keys(d, "", _TOP_REQUIRED, _TOP_OPTIONAL)
    ref_t = _number(d["reference_temperature_c"], "reference_temperature_c")
    name = _string(d.get("name", "rig"), "name")

    raw_materials = _mapping(d["materials"], "materials")
    if not raw_materials:
        raise ConfigError("materials: at least one material is required")
    materials = {str(k): _parse_material(str(k), v, ref_t) for k, v in raw_materials.items()}

    raw_shafts = _list(d["shafts"], "shafts")
    if not raw_shafts:
        raise ConfigError("shafts: at least one shaft is required")
    shafts = tuple(_parse_shaft(k, s, materials) for k, s in enumerate(raw_shafts))
    n_nodes = sum(s.n_nodes for s in shafts)

    bearing_types = dict(BEARING_TYPES)
    for k, v in _mapping(d.get("bearing_types", {}), "bearing_types").items():
        bearing_types[str(k)] = _parse_bearing_type(str(k), v)

    bearings = []
    for k, b in enumerate(_list(d["bearings"], "bearings")):
        path = f"bearings[{k}]"
        b = _mapping(b, path)
        _keys(b, path, {"node", "type"}, set())
        node0 = _node(b["node"], f"{path}.node", n_nodes)
        t = b["type"]
        if t not in bearing_types:
            raise ConfigError(f"{path}.type: unknown bearing type {t!r}; allowed {sorted(bearing_types)}")
        bearings.append(BearingConfig(node0, str(t), bearing_types[t]))

    gears, meshes = _parse_gears(
        _list(d.get("gears", []), "gears"), _list(d.get("meshes", []), "meshes"), shafts, materials, n_nodes
    )
    discs = tuple(
        _parse_disc(k, x, shafts, materials, n_nodes)
        for k, x in enumerate(_list(d.get("discs", []), "discs"))
    )

    drive = _mapping(d["drive"], "drive")
    _keys(drive, "drive", {"node"}, set())
    drive_cfg = DriveConfig(_node(drive["node"], "drive.node", n_nodes))

    load_cfg = None
    if d.get("load") is not None:
        load = _mapping(d["load"], "load")
        _keys(load, "load", {"node", "torque_nm"}, set())
        load_cfg = LoadConfig(
            _node(load["node"], "load.node", n_nodes), _number(load["torque_nm"], "load.torque_nm")
        )

    ray = _mapping(d.get("rayleigh_damping", {}), "rayleigh_damping")
    _keys(ray, "rayleigh_damping", set(), {"mass_per_s", "stiffness_s"})
    rayleigh = RayleighDamping(
        _number(ray.get("mass_per_s", 0.0), "rayleigh_damping.mass_per_s", ge=0.0),
        _number(ray.get("stiffness_s", 0.0), "rayleigh_damping.stiffness_s", ge=0.0),
    )

    cfg = RigConfig(
        name=name,
        reference_temperature_c=ref_t,
        materials=materials,
        shafts=shafts,
        bearings=tuple(bearings),
        gears=gears,
        meshes=meshes,
        drive=drive_cfg,
        load=load_cfg,
        rayleigh_damping=rayleigh,
        shear_coefficient=_shear_coefficient(d.get("shear_coefficient", "cowper")),
        bearing_types=bearing_types,
        discs=discs,
    )
    _validate_involute(cfg)
    return cfg
