"""Example rigs: the paper's gearbox (Fig 5) and a single rotor on two bearings.

Both return validated :class:`~gear_rotor_sim.config.RigConfig` objects; tests and the calibration
reuse them.
"""

from __future__ import annotations

from typing import Any

from gear_rotor_sim.config import RigConfig, load_config

#: Named configurations of the paper's gearbox: the physically consistent model (default) and the
#: literal reading of Sec 3.5 (gear mass and inertia in both Eq 20 and Eq 32), which puts the Fig 6a
#: band where the paper has it (docs/REPRODUCTION.md).
PAPER_CONFIGS = ("paper_sun2021", "paper_sun2021_as_published")


def paper_gearbox(
    bearing_type: str = "A#", thermal_backlash: bool = True, config: str = "paper_sun2021"
) -> RigConfig:
    """The gear-rotor-bearing system of Sun et al. (2021), ``config/paper_sun2021.yaml``.

    Parameters
    ----------
    bearing_type : str
        Table 5 type for all four bearings (``"A#"``, ``"B#"``, ``"C#"``).
    thermal_backlash : bool
        Eq 27 on (True) or off (False, Fig 6c).
    config : str
        One of :data:`PAPER_CONFIGS`: ``"paper_sun2021"`` (default, each gear's mass counted once)
        or ``"paper_sun2021_as_published"`` (Eq 32's gear-pair mass added on top of Eq 20).

    Raises
    ------
    ValueError
        If ``config`` is not one of :data:`PAPER_CONFIGS`.

    References
    ----------
    Sun et al. (2021), Fig 5, Tables 1, 3, 4, 5, Sec 4.2 (b = 35 um, e0 = 20 um).
    """
    import dataclasses

    if config not in PAPER_CONFIGS:
        raise ValueError(f"config: {config!r} is not one of {list(PAPER_CONFIGS)}")
    cfg = load_config(config).with_bearing_type(bearing_type)
    if not thermal_backlash:
        cfg = cfg.replace(meshes=tuple(dataclasses.replace(m, thermal_backlash=False) for m in cfg.meshes))
    return cfg


def single_rotor(
    length_m: float = 0.5,
    diameter_m: float = 0.02,
    n_elements: int = 10,
    *,
    bearing_type: str | None = None,
    k_radial_n_per_m: float = 1.0e8,
    k_axial_n_per_m: float = 1.0e8,
    k_tilt_nm_per_rad: float = 0.0,
    c_radial_ns_per_m: float = 1.0e3,
    c_axial_ns_per_m: float = 1.0e3,
    c_tilt_nms_per_rad: float = 0.0,
    bearing_nodes: tuple[int, int] | None = None,
    disc_node: int | None = None,
    disc_outer_diameter_m: float = 0.1,
    disc_width_m: float = 0.02,
    out_of_range: str = "error",
    rayleigh_stiffness_s: float = 0.0,
    reference_temperature_c: float = 25.0,
) -> RigConfig:
    """A uniform solid carbon-steel shaft on two bearings, optionally with one rigid disc, no gears.

    Parameters
    ----------
    length_m, diameter_m : float
        Shaft length and diameter, m.
    n_elements : int
        Number of equal Timoshenko elements (nodes 1..n_elements+1).
    bearing_type : str or None
        A Table 5 type for both bearings; None uses the ``k_*``/``c_*`` values given here.
    bearing_nodes : (int, int) or None
        1-based bearing nodes; default the two shaft ends.
    disc_node : int or None
        1-based node of a rigid disc (``disc_outer_diameter_m``, ``disc_width_m``, bore = shaft).
    out_of_range : str
        Material temperature policy (``"error"`` or ``"extrapolate"``).

    Returns
    -------
    RigConfig
        Drive at node 1 (theta_z held by the motor), no load torque.

    References
    ----------
    Sun et al. (2021), Sec 3.3 (shaft), Sec 3.4 (bearings), Table 1 (material).
    """
    n_nodes = n_elements + 1
    nodes = bearing_nodes if bearing_nodes is not None else (1, n_nodes)
    seg = {"length_mm": length_m * 1e3 / n_elements, "outer_diameter_mm": diameter_m * 1e3}
    d: dict[str, Any] = {
        "name": "single_rotor",
        "reference_temperature_c": reference_temperature_c,
        "materials": {
            "carbon_steel": {
                "density_kg_m3": 7860.0,
                "expansion_coefficient_per_c": 1.17e-5,
                "temperature_c": [25.0, 125.0, 225.0, 325.0],
                "youngs_modulus_gpa": [207.0, 200.0, 189.0, 174.0],
                "poisson_ratio": [0.290, 0.294, 0.298, 0.302],
                "out_of_range": out_of_range,
            }
        },
        "shafts": [
            {"name": "rotor", "material": "carbon_steel", "elements": [dict(seg) for _ in range(n_elements)]}
        ],
        "rayleigh_damping": {"mass_per_s": 0.0, "stiffness_s": rayleigh_stiffness_s},
        "bearings": [],
        "drive": {"node": 1},
    }
    if bearing_type is None:
        d["bearing_types"] = {
            "custom": {
                "k_radial_n_per_m": k_radial_n_per_m,
                "k_axial_n_per_m": k_axial_n_per_m,
                "k_tilt_nm_per_rad": k_tilt_nm_per_rad,
                "c_radial_ns_per_m": c_radial_ns_per_m,
                "c_axial_ns_per_m": c_axial_ns_per_m,
                "c_tilt_nms_per_rad": c_tilt_nms_per_rad,
            }
        }
        bearing_type = "custom"
    d["bearings"] = [{"node": n, "type": bearing_type} for n in nodes]
    if disc_node is not None:
        d["discs"] = [
            {
                "node": disc_node,
                "outer_diameter_mm": disc_outer_diameter_m * 1e3,
                "width_mm": disc_width_m * 1e3,
                "material": "carbon_steel",
            }
        ]
    return load_config(d)
