"""Rig configuration: loading, validation and the frozen SI dataclass tree.

The dataclasses are in :mod:`gear_rotor_sim.config_types`, the field-by-field validation in
:mod:`gear_rotor_sim.config_fields`; this module reads the source and re-exports both.

``load_config(source)`` accepts a path to a YAML file, the name of a file in the package's
``config/`` directory (``"paper_sun2021"``), or a dict of the same schema. Only ``yaml.safe_load`` is
used. Units are in the key names (``*_mm``, ``*_um``, ``*_deg``, ``*_gpa``, ...) and are converted to
SI on loading; nodes are 1-based in the file and 0-based (``node0``) inside.

Schema (``config/paper_sun2021.yaml`` is the reference example; ``*`` = optional)::

    name*: str                              default "rig"
    reference_temperature_c: float          unstressed as-built temperature (Table 2 starts at 25 C)
    materials: {<name>: {density_kg_m3, expansion_coefficient_per_c, temperature_c: [...],
                youngs_modulus_gpa: [...], poisson_ratio: [...], out_of_range*: error|extrapolate}}
    shafts: [{name, material, elements: [{length_mm, outer_diameter_mm, inner_diameter_mm*,
             material*}]}]                  nodes are numbered 1.. over all shafts in order
    shear_coefficient*: solid_circular | cowper | <number>    default cowper (Cowper 1966; for a
                                            solid section 6(1+nu)/(7+6nu), hollow per Cowper)
    rayleigh_damping*: {mass_per_s, stiffness_s}              shaft damping C = a M + b K, default 0
    bearing_types*: {<name>: {k_radial_n_per_m, k_axial_n_per_m, k_tilt_nm_per_rad,
                    c_radial_ns_per_m, c_axial_ns_per_m, c_tilt_nms_per_rad}}
                                            added to / overriding Table 5 (A#, B#, C#)
    bearings: [{node, type}]                numbered 1.. in this order
    gears*: [{name, node, teeth, material, bore_diameter_mm*, face_width_mm*, module_mm*}]
                                            face width and module come from the gear's mesh;
                                            a gear in no mesh needs face_width_mm and module_mm
    discs*: [{node, outer_diameter_mm, width_mm, material, bore_diameter_mm*}]
                                            plain rigid discs (no teeth), e.g. a rotor or coupling
    meshes*: [{pinion, gear, module_mm, pressure_angle_deg, face_width_mm, half_backlash_um,
              transmission_error_amplitude_um, friction_coefficient, damping_ratio,
              addendum_coefficient* (1.0), clearance_coefficient* (0.25),
              transmission_error_phase_rad* (0.0), thermal_backlash* (true),
              gear_mass_in_mesh_matrix* (false)}]   true: the gears' mass and inertia are
                                            assembled twice, in Eq 20 and in the gear-pair
                                            matrix of Eq 32 (the literal reading of Sec 3.5;
                                            config/paper_sun2021_as_published.yaml)
    drive: {node}                           theta_z of this node follows the commanded rotation
    load*: {node, torque_nm}                resisting torque on the load node (default none)

Every error is a ``ConfigError`` (a ``ValueError``) whose message starts with the field path, e.g.
``shafts[0].elements[3].length_mm: -1 must be > 0``, and states the allowed values.

``shear_coefficient`` and ``rayleigh_damping`` are top-level keys (they are listed with the shafts in
the paper file's comments, but they apply to every shaft element).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from gear_rotor_sim.config_fields import parse_rig
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

#: The configuration types live in :mod:`gear_rotor_sim.config_types`, the field parsers in
#: :mod:`gear_rotor_sim.config_fields`; both are importable from here as before.
__all__ = [
    "BearingConfig",
    "ConfigError",
    "DiscConfig",
    "DriveConfig",
    "GearConfig",
    "LoadConfig",
    "MeshConfig",
    "RayleighDamping",
    "RigConfig",
    "ShaftConfig",
    "ShaftElementConfig",
    "config_dirs",
    "load_config",
]


# ---------------------------------------------------------------------------------------------------
# Loading
# ---------------------------------------------------------------------------------------------------
def config_dirs() -> list[Path]:
    """Directories searched for named configs: the source tree's ``config/``, then the installed share."""
    dirs = [Path(__file__).resolve().parents[1] / "config"]
    try:
        from ament_index_python.packages import get_package_share_directory

        dirs.append(Path(get_package_share_directory("gear_rotor_sim")) / "config")
    except Exception:  # ament_index not installed or package not in the index
        pass
    return [d for d in dirs if d.is_dir()]


def _read_source(source: str | Path | Mapping[str, Any]) -> tuple[Mapping[str, Any], str]:
    if isinstance(source, Mapping):
        return source, "<dict>"
    path = Path(source)
    if not path.is_file():
        stem = path.name if path.suffix in (".yaml", ".yml") else f"{path.name}.yaml"
        candidates = [d / stem for d in config_dirs()] if path.parent == Path(".") else []
        found = [c for c in candidates if c.is_file()]
        if not found:
            # node parameter files (*_node.yaml) and sweep files live in config/ too; list rigs only
            names = sorted(
                {p.stem for d in config_dirs() for p in d.glob("*.yaml") if not p.stem.endswith("_node")}
            )
            raise ConfigError(
                f"source: {str(source)!r} is neither a file nor a config name; available names {names}"
            )
        path = found[0]
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except yaml.YAMLError as exc:
        raise ConfigError(f"source: {path} is not valid YAML: {exc}") from exc
    if not isinstance(data, Mapping):
        raise ConfigError(f"source: {path} must hold a mapping at the top level")
    return data, str(path)


def load_config(source: str | Path | Mapping[str, Any]) -> RigConfig:
    """Load and validate a rig configuration.

    Parameters
    ----------
    source : str, Path or mapping
        A YAML file path, the name of a file in ``config/`` (``"paper_sun2021"``), or a dict.

    Returns
    -------
    RigConfig
        Frozen, SI.

    Raises
    ------
    ConfigError
        Naming the field path and the allowed values.

    References
    ----------
    Sun et al. (2021), Tables 1, 3, 4, 5 and Sec 4.1 (the schema's paper example).
    """
    d, _ = _read_source(source)
    return parse_rig(d)
