"""Operating cases of the paper gearbox and the models built from them (sweeps, bifurcations, studies).

A :class:`Case` names a temperature, bearing type, backlash model, named configuration and parameter
overrides; :func:`build_config` turns it into a :class:`~gear_rotor_sim.config.RigConfig`,
:func:`build_system` into an assembled (cached) system, :func:`scale_mesh_stiffness` scales the
potential-energy mesh stiffness of an assembled system.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

MESH_OVERRIDES = (
    "friction_coefficient",
    "damping_ratio",
    "half_backlash_m",
    "transmission_error_amplitude_m",
    "transmission_error_phase_rad",
)
RAYLEIGH_OVERRIDES = ("mass_per_s", "stiffness_s")
#: Overrides of the configuration's load: the output torque T2 (Table 3: 200 N m), N m.
LOAD_OVERRIDES = ("load_torque_nm",)
#: Overrides applied to the assembled system (not expressible in the configuration).
SYSTEM_OVERRIDES = ("mesh_stiffness_scale",)
#: Overrides of other configuration fields: the reference (stress-free) temperature, C; the Timoshenko
#: shear coefficient; the node (1-based, Fig 5) of the output torque; a factor on every bearing's tilt
#: stiffness; every bearing's tilt damping, N m s/rad.
CONFIG_OVERRIDES = (
    "reference_temperature_c",
    "shear_coefficient",
    "load_node",
    "bearing_tilt_stiffness_scale",
    "bearing_tilt_damping",
)


@dataclass(frozen=True)
class Case:
    """One model variant: the paper's gearbox at a temperature, bearing type and backlash model.

    Attributes
    ----------
    temperature_c : float
        Uniform steady temperature, C.
    bearing_type : str
        ``"A#"``, ``"B#"`` or ``"C#"`` (Table 5).
    thermal_backlash : bool
        Whether the backlash shrinks with temperature (Eq 27); ``False`` is the paper's Fig 6c.
    overrides : tuple of (str, float)
        Parameter changes for sensitivity studies: mesh fields (``friction_coefficient``,
        ``damping_ratio``, ``half_backlash_m``, ``transmission_error_amplitude_m``,
        ``transmission_error_phase_rad``), shaft
        Rayleigh damping (``mass_per_s``, ``stiffness_s``), the output torque ``load_torque_nm``,
        ``mesh_stiffness_scale`` (multiplies the potential-energy mesh stiffness at every phase, see
        :func:`scale_mesh_stiffness`) and the fields of :data:`CONFIG_OVERRIDES`.
    config : str
        Named paper configuration (:data:`gear_rotor_sim.examples.PAPER_CONFIGS`): ``"paper_sun2021"``
        (default) or ``"paper_sun2021_as_published"``.
    """

    temperature_c: float
    bearing_type: str = "A#"
    thermal_backlash: bool = True
    overrides: tuple[tuple[str, float], ...] = ()
    config: str = "paper_sun2021"

    def label(self) -> str:
        """Short human-readable name, e.g. ``"225 C, A#, thermal backlash"``."""
        bl = "thermal backlash" if self.thermal_backlash else "fixed backlash"
        extra = "".join(f", {k}={v:g}" for k, v in self.overrides)
        if self.config != "paper_sun2021":
            extra += f", {self.config}"
        return f"{self.temperature_c:g} C, {self.bearing_type}, {bl}{extra}"

    def to_json(self) -> str:
        """The case as JSON (saved with sweep results)."""
        return json.dumps(dataclasses.asdict(self))

    @staticmethod
    def from_json(text: str) -> Case:
        """The case of :meth:`to_json` (``config`` defaults to ``paper_sun2021`` for older files)."""
        d = json.loads(text)
        return Case(
            float(d["temperature_c"]),
            str(d["bearing_type"]),
            bool(d["thermal_backlash"]),
            tuple((str(k), float(v)) for k, v in d["overrides"]),
            str(d.get("config", "paper_sun2021")),
        )


def build_config(case: Case) -> Any:
    """The paper gearbox configuration of ``case`` (a :class:`gear_rotor_sim.config.RigConfig`)."""
    from gear_rotor_sim.examples import paper_gearbox

    cfg = paper_gearbox(
        bearing_type=case.bearing_type, thermal_backlash=case.thermal_backlash, config=case.config
    )
    mesh_changes = {k: v for k, v in case.overrides if k in MESH_OVERRIDES}
    ray_changes = {k: v for k, v in case.overrides if k in RAYLEIGH_OVERRIDES}
    load_changes = {k: v for k, v in case.overrides if k in LOAD_OVERRIDES}
    cfg_changes = {k: v for k, v in case.overrides if k in CONFIG_OVERRIDES}
    known = MESH_OVERRIDES + RAYLEIGH_OVERRIDES + SYSTEM_OVERRIDES + LOAD_OVERRIDES + CONFIG_OVERRIDES
    unknown = {k for k, _ in case.overrides} - set(known)
    if unknown:
        raise ValueError(f"overrides: {sorted(unknown)} not in {known}")
    if mesh_changes:
        cfg = cfg.replace(meshes=tuple(dataclasses.replace(m, **mesh_changes) for m in cfg.meshes))
    if ray_changes:
        cfg = cfg.replace(rayleigh_damping=dataclasses.replace(cfg.rayleigh_damping, **ray_changes))
    if load_changes and cfg.load is not None:
        cfg = cfg.replace(load=dataclasses.replace(cfg.load, torque_nm=float(load_changes["load_torque_nm"])))
    if cfg_changes:
        cfg = _apply_config_overrides(cfg, cfg_changes)
    return cfg


def _apply_config_overrides(cfg: Any, changes: dict[str, float]) -> Any:
    """``cfg`` with the :data:`CONFIG_OVERRIDES` of ``changes`` applied (errors name the field)."""
    if "reference_temperature_c" in changes:
        cfg = cfg.replace(reference_temperature_c=float(changes["reference_temperature_c"]))
    if "shear_coefficient" in changes:
        mu = float(changes["shear_coefficient"])
        if not (np.isfinite(mu) and 0.0 < mu <= 2.0):
            raise ValueError(f"shear_coefficient: {mu!r} must be within (0, 2]")
        cfg = cfg.replace(shear_coefficient=mu)
    if "load_node" in changes and cfg.load is not None:
        node = changes["load_node"]
        n_nodes = sum(sh.n_nodes for sh in cfg.shafts)
        if not (float(node).is_integer() and 1 <= node <= n_nodes):
            raise ValueError(f"load_node: {node!r} must be a node number 1..{n_nodes}")
        cfg = cfg.replace(load=dataclasses.replace(cfg.load, node0=int(node) - 1))
    scale = float(changes.get("bearing_tilt_stiffness_scale", 1.0))
    if not (np.isfinite(scale) and scale > 0.0):
        raise ValueError(f"bearing_tilt_stiffness_scale: {scale!r} must be finite and > 0")
    tilt_c = changes.get("bearing_tilt_damping")
    if tilt_c is not None and not (np.isfinite(tilt_c) and tilt_c >= 0.0):
        raise ValueError(f"bearing_tilt_damping: {tilt_c!r} must be finite and >= 0 N m s/rad")
    if scale != 1.0 or tilt_c is not None:
        bearings = []
        for b in cfg.bearings:
            prop = dataclasses.replace(b.properties, k_tilt=b.properties.k_tilt * scale)
            if tilt_c is not None:
                prop = dataclasses.replace(prop, c_tilt=float(tilt_c))
            bearings.append(dataclasses.replace(b, properties=prop))
        cfg = cfg.replace(bearings=tuple(bearings))
    return cfg


class _ScaledStiffness:
    """``phase -> scale * k(phase)`` (a picklable replacement of ``MeshCoupling.stiffness``)."""

    def __init__(self, base: Callable[[np.ndarray], np.ndarray], scale: float) -> None:
        self.base, self.scale = base, float(scale)

    def __call__(self, phase: np.ndarray) -> np.ndarray:
        return self.scale * np.asarray(self.base(phase))


def _scale_jumps(jumps: np.ndarray, scale: float) -> np.ndarray:
    out = np.array(jumps, dtype=float)
    out[:, 1] *= scale  # the stiffness jumps; phases and coefficient jumps are unchanged
    return out


def scale_mesh_stiffness(system: Any, scale: float) -> Any:
    """The assembled system with every mesh stiffness multiplied by ``scale`` at every phase.

    ``MeshCoupling.stiffness`` (callable), ``table_stiffness`` (the compiled kernel's table) and
    ``mean_stiffness`` are scaled; the mesh damping ``c_m = 2 zeta sqrt(k_mean m_e)`` is scaled by
    ``sqrt(scale)`` so that the damping ratio ``zeta`` stays the configured one. The shape of the
    stiffness over the mesh cycle (single/double contact) is unchanged. ``scale = 1.34`` turns the
    potential-energy mean stiffness of the paper's gears (3.16e8 N/m at 25 C) into the ISO 6336-1
    ``c_gamma_alpha b`` value (4.23e8 N/m), see ``docs/mesh_stiffness.md``.

    Parameters
    ----------
    system : AssembledSystem
        Assembled system (``GearRotorSystem.from_config``).
    scale : float
        Positive, finite stiffness multiplier.
    """
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"mesh_stiffness_scale: {scale!r} must be finite and > 0")
    if scale == 1.0:
        return system
    meshes = tuple(
        dataclasses.replace(
            m,
            stiffness=_ScaledStiffness(m.stiffness, scale),
            mean_stiffness=float(m.mean_stiffness) * scale,
            damping=float(m.damping) * float(np.sqrt(scale)),
            table_stiffness=None if m.table_stiffness is None else np.asarray(m.table_stiffness) * scale,
            table_jumps=None if m.table_jumps is None else _scale_jumps(m.table_jumps, scale),
        )
        for m in system.meshes
    )
    return dataclasses.replace(system, meshes=meshes)


_SYSTEM_CACHE: dict[Case, Any] = {}


def build_system(case: Case) -> Any:
    """Assembled system of ``case`` (cached per process; forked workers inherit the cache)."""
    if case not in _SYSTEM_CACHE:
        from gear_rotor_sim.system import GearRotorSystem

        system = GearRotorSystem.from_config(build_config(case), case.temperature_c)
        for k, v in case.overrides:
            if k == "mesh_stiffness_scale":
                system = scale_mesh_stiffness(system, v)
        _SYSTEM_CACHE[case] = system
    return _SYSTEM_CACHE[case]
