"""Config loading and validation: every bad input names its field and the allowed values."""

from __future__ import annotations

import copy
import math
from typing import Any

import pytest

from gear_rotor_sim.config import ConfigError, load_config


def _paper_dict() -> dict[str, Any]:
    """The paper rig (Tables 1, 3, 4, 5) as a dict, written out independently of config/*.yaml."""
    el = [20, 20, 20, 10, 10, 20, 20, 20]
    bt = {"k_radial_n_per_m": 1.15e8, "k_axial_n_per_m": 2.28e7, "k_tilt_nm_per_rad": 2.08e4}
    bt |= {"c_radial_ns_per_m": 1e3, "c_axial_ns_per_m": 1e3, "c_tilt_nms_per_rad": 1e3}
    return {
        "name": "paper",
        "reference_temperature_c": 25.0,
        "materials": {
            "carbon_steel": {
                "density_kg_m3": 7860.0,
                "expansion_coefficient_per_c": 1.17e-5,
                "temperature_c": [25.0, 125.0, 225.0, 325.0],
                "youngs_modulus_gpa": [207.0, 200.0, 189.0, 174.0],
                "poisson_ratio": [0.290, 0.294, 0.298, 0.302],
                "out_of_range": "error",
            }
        },
        "shafts": [
            {
                "name": s,
                "material": "carbon_steel",
                "elements": [{"length_mm": x, "outer_diameter_mm": 30} for x in el],
            }
            for s in ("input", "output")
        ],
        "shear_coefficient": "solid_circular",
        "rayleigh_damping": {"mass_per_s": 0.0, "stiffness_s": 1e-7},
        "bearing_types": {"A#": bt},
        "bearings": [{"node": n, "type": "A#"} for n in (1, 9, 10, 18)],
        "gears": [
            {"name": "pinion", "node": 5, "teeth": 29, "material": "carbon_steel"},
            {"name": "gear", "node": 14, "teeth": 49, "material": "carbon_steel"},
        ],
        "meshes": [
            {
                "pinion": "pinion",
                "gear": "gear",
                "module_mm": 3.0,
                "pressure_angle_deg": 20.0,
                "face_width_mm": 20.0,
                "addendum_coefficient": 1.0,
                "clearance_coefficient": 0.25,
                "half_backlash_um": 35.0,
                "transmission_error_amplitude_um": 20.0,
                "transmission_error_phase_rad": 0.0,
                "friction_coefficient": 0.05,
                "damping_ratio": 0.07,
                "thermal_backlash": True,
            }
        ],
        "drive": {"node": 1},
        "load": {"node": 18, "torque_nm": 200.0},
    }


def test_paper_dict_loads_in_si() -> None:
    cfg = load_config(_paper_dict())
    assert cfg.n_nodes == 18
    assert [b.node0 for b in cfg.bearings] == [0, 8, 9, 17]
    assert [(g.node0, g.teeth) for g in cfg.gears] == [(4, 29), (13, 49)]
    m = cfg.meshes[0]
    assert m.module_m == pytest.approx(3e-3)
    assert m.pressure_angle_rad == pytest.approx(math.radians(20.0))
    assert m.half_backlash_m == pytest.approx(35e-6)
    assert (m.pinion_teeth, m.gear_teeth) == (29, 49)
    g = cfg.gears[0]
    assert (g.pitch_diameter_m, g.bore_diameter_m, g.face_width_m) == pytest.approx((0.087, 0.030, 0.020))
    assert cfg.shafts[0].elements[3].length_m == pytest.approx(0.010)
    assert cfg.bearings[0].properties.k_axial == pytest.approx(2.28e7)
    assert cfg.load.torque_nm == 200.0 and cfg.drive.node0 == 0


def test_paper_yaml_by_name_matches_the_tables() -> None:
    cfg = load_config("paper_sun2021")
    ref = load_config(_paper_dict())
    assert cfg.shafts == ref.shafts
    assert cfg.gears == ref.gears
    assert cfg.meshes == ref.meshes
    assert cfg.bearings == ref.bearings
    assert cfg.rayleigh_damping == ref.rayleigh_damping
    assert cfg.with_bearing_type("C#").bearings[0].properties.k_radial == pytest.approx(2.35e8)


def _set(d: dict[str, Any], path: list[Any], value: Any) -> dict[str, Any]:
    d = copy.deepcopy(d)
    target = d
    for p in path[:-1]:
        target = target[p]
    if value is _DELETE:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return d


_DELETE = object()

BAD = [
    (["shafts"], _DELETE, r"^shafts: missing required key"),
    (["drive"], _DELETE, r"^drive: missing required key"),
    (["shafts", 0, "elements", 2, "length_mm"], _DELETE, r"shafts\[0\]\.elements\[2\]\.length_mm: missing"),
    (["colour"], "red", r"^colour: unknown key; allowed keys are"),
    (["shafts", 1, "elements", 0, "lenght_mm"], 20, r"shafts\[1\]\.elements\[0\]\.lenght_mm: unknown key"),
    (
        ["shafts", 0, "elements", 3, "length_mm"],
        0,
        r"shafts\[0\]\.elements\[3\]\.length_mm: 0 .*allowed: > 0",
    ),
    (["shafts", 0, "elements", 3, "length_mm"], -5, r"shafts\[0\]\.elements\[3\]\.length_mm: -5 .*> 0"),
    (
        ["shafts", 1, "elements", 0, "outer_diameter_mm"],
        0.0,
        r"shafts\[1\]\.elements\[0\]\.outer_diameter_mm.*> 0",
    ),
    (
        ["shafts", 1, "elements", 0, "inner_diameter_mm"],
        30,
        r"shafts\[1\]\.elements\[0\]\.inner_diameter_mm.*< outer",
    ),
    (["bearing_types", "A#", "k_radial_n_per_m"], -1.0, r"bearing_types\.A#\.k_radial_n_per_m.*> 0"),
    (["bearing_types", "A#", "k_axial_n_per_m"], 0.0, r"bearing_types\.A#\.k_axial_n_per_m.*> 0"),
    (["bearings", 1, "node"], 19, r"bearings\[1\]\.node: node 19 does not exist; allowed 1\.\.18"),
    (["bearings", 1, "node"], 0, r"bearings\[1\]\.node: node 0 does not exist"),
    (
        ["bearings", 2, "type"],
        "D#",
        r"bearings\[2\]\.type: unknown bearing type 'D#'; allowed \['A#', 'B#', 'C#'\]",
    ),
    (["gears", 1, "node"], 42, r"gears\[1\]\.node: node 42 does not exist; allowed 1\.\.18"),
    (["drive", "node"], 19, r"drive\.node: node 19 does not exist"),
    (["load", "node"], 100, r"load\.node: node 100 does not exist"),
    (
        ["shafts", 0, "material"],
        "brass",
        r"shafts\[0\]\.material: unknown material 'brass'; allowed \['carbon_steel'\]",
    ),
    (["gears", 0, "material"], "brass", r"gears\[0\]\.material: unknown material 'brass'"),
    (["gears", 0, "teeth"], 4, r"gears\[0\]\.teeth: 4 must be an integer >= 5"),
    (["gears", 1, "teeth"], 29.5, r"gears\[1\]\.teeth: 29\.5 must be an integer >= 5"),
    (["meshes", 0, "module_mm"], 0.0, r"meshes\[0\]\.module_mm.*> 0"),
    (["meshes", 0, "module_mm"], -3.0, r"meshes\[0\]\.module_mm.*> 0"),
    (["meshes", 0, "pressure_angle_deg"], 10.0, r"meshes\[0\]\.pressure_angle_deg.*> 10 and < 35"),
    (["meshes", 0, "pressure_angle_deg"], 40.0, r"meshes\[0\]\.pressure_angle_deg.*> 10 and < 35"),
    (["meshes", 0, "addendum_coefficient"], 2.0, r"meshes\[0\]\.addendum_coefficient.*>= 0\.5 and <= 1\.5"),
    (["meshes", 0, "clearance_coefficient"], 0.6, r"meshes\[0\]\.clearance_coefficient.*<= 0\.5"),
    (["meshes", 0, "gear"], "wheel", r"meshes\[0\]\.gear: unknown gear 'wheel'"),
    (["gears", 1, "node"], 7, r"meshes\[0\]\.gear: pinion 'pinion' and gear 'gear' are both on shaft 1"),
    (["gears", 1, "name"], "pinion", r"gears\[1\]\.name: gear name 'pinion' is used twice"),
    (["materials", "carbon_steel", "out_of_range"], "clamp", r"out_of_range: 'clamp' is not one of"),
    (["materials", "carbon_steel", "poisson_ratio"], [0.29, 0.3], r"must have the same length"),
]


@pytest.mark.parametrize(("path", "value", "pattern"), BAD, ids=[".".join(map(str, b[0])) for b in BAD])
def test_bad_input_names_field(path: list[Any], value: Any, pattern: str) -> None:
    with pytest.raises(ConfigError, match=pattern):
        load_config(_set(_paper_dict(), path, value))


def test_involute_validity_from_gears_module() -> None:
    # 12 teeth at 20 deg undercut a standard gear (z_min = 2 / sin^2 20 deg = 17.1)
    with pytest.raises(ConfigError, match=r"meshes\[0\]\.pinion_teeth: 12"):
        load_config(_set(_paper_dict(), ["gears", 0, "teeth"], 12))


def test_single_rotor_without_gears_and_bad_names() -> None:
    d = _paper_dict()
    d["shafts"] = d["shafts"][:1]
    d["bearings"] = d["bearings"][:2]
    for key in ("gears", "meshes", "load"):
        del d[key]
    cfg = load_config(d)
    assert cfg.n_nodes == 9 and cfg.meshes == () and cfg.load is None
    with pytest.raises(ConfigError, match=r"bearings\[\]\.type: 'Z#' is not one of"):
        cfg.with_bearing_type("Z#")
    with pytest.raises(ConfigError, match=r"source: 'no_such_rig' is neither a file nor a config name"):
        load_config("no_such_rig")


def test_gear_without_mesh_needs_face_width_and_module() -> None:
    d = _paper_dict()
    del d["meshes"]
    with pytest.raises(ConfigError, match=r"gears\[0\]\.module_mm: gear 'pinion' is in no mesh"):
        load_config(d)
    d["gears"][0] |= {"module_mm": 3.0}
    d["gears"][1] |= {"module_mm": 3.0, "face_width_mm": 20.0}
    with pytest.raises(ConfigError, match=r"gears\[0\]\.face_width_mm: gear 'pinion' is in no mesh"):
        load_config(d)
    d["gears"][0] |= {"face_width_mm": 20.0, "bore_diameter_mm": 20.0}
    cfg = load_config(d)
    assert cfg.gears[0].bore_diameter_m == pytest.approx(0.020)
    assert cfg.gears[1].bore_diameter_m == pytest.approx(0.030)


def test_replace_revalidates_references() -> None:
    cfg = load_config(_paper_dict())
    with pytest.raises(ConfigError, match=r"bearings\[0\]\.node: node 19 does not exist"):
        cfg.replace(bearings=(cfg.bearings[0].__class__(18, "A#", cfg.bearings[0].properties),))
    assert cfg.replace(name="other").name == "other"
