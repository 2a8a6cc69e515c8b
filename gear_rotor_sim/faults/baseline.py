"""Baseline parameters: uncertain nominal values of a healthy machine (mesh stiffness and damping).

They are updated to fit a machine, never reported as faults (``../shared/ARCHITECTURE.md``,
"Effects and faults").
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from gear_rotor_sim.config import RigConfig
from gear_rotor_sim.faults.base import Effect, ParameterSpec


@dataclass(frozen=True)
class MeshStiffnessDamping(Effect):
    """Scale of the mesh stiffness (all phases) and of the mesh damping ratio.

    Parameters
    ----------
    stiffness_scale : float
        Multiplies k_m(t).
    damping_scale : float
        Multiplies the mesh damping ratio.
    """

    stiffness_scale: float = 1.0
    damping_scale: float = 1.0
    name: ClassVar[str] = "mesh_stiffness_damping"
    signature: ClassVar[str] = (
        "mesh resonance frequency (sqrt of the stiffness scale) and peak height (damping)"
    )
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("stiffness_scale", "1", 0.3, 2.0, "scalar", "mesh stiffness multiplier"),
        ParameterSpec("damping_scale", "1", 0.3, 3.0, "scalar", "mesh damping-ratio multiplier"),
    )

    def applicable(self, cfg: RigConfig) -> bool:
        return bool(cfg.meshes)

    def mesh_stiffness_factor(self, ctx: Any) -> np.ndarray | None:
        return np.full(ctx.t.shape[0], self.stiffness_scale)

    def modify_config(self, cfg: RigConfig) -> RigConfig:
        meshes = tuple(
            dataclasses.replace(m, damping_ratio=m.damping_ratio * self.damping_scale) for m in cfg.meshes
        )
        return cfg.replace(meshes=meshes)


@dataclass(frozen=True)
class BearingStiffnessDamping(Effect):
    """Scale of the stiffness and damping of every bearing (Eq 37: K^b and C^b, all directions).

    Catalogue or Table 5 bearing stiffnesses are nominal: preload, fits and housing compliance make
    the real values differ by tens of percent. The scale moves the shaft-bearing modes (and, through
    ``k_b``, the share of the thermal axial load ``k_s a dT L / (1 + 2 k_s / k_b)`` the bearings
    carry), so it is a baseline parameter of the machine, never a finding.

    Parameters
    ----------
    stiffness_scale : float
        Multiplies k_radial, k_axial and k_tilt of all bearings.
    damping_scale : float
        Multiplies c_radial, c_axial and c_tilt of all bearings.
    """

    stiffness_scale: float = 1.0
    damping_scale: float = 1.0
    name: ClassVar[str] = "bearing_stiffness_damping"
    signature: ClassVar[str] = "shaft-bearing mode frequencies and peak heights; thermal axial load share"
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("stiffness_scale", "1", 0.3, 3.0, "scalar", "bearing stiffness multiplier"),
        ParameterSpec("damping_scale", "1", 0.3, 3.0, "scalar", "bearing damping multiplier"),
    )

    def applicable(self, cfg: RigConfig) -> bool:
        return bool(cfg.bearings)

    def modify_config(self, cfg: RigConfig) -> RigConfig:
        ks, cs = self.stiffness_scale, self.damping_scale
        bearings = tuple(
            dataclasses.replace(
                b,
                properties=dataclasses.replace(
                    b.properties,
                    k_radial=b.properties.k_radial * ks,
                    k_axial=b.properties.k_axial * ks,
                    k_tilt=b.properties.k_tilt * ks,
                    c_radial=b.properties.c_radial * cs,
                    c_axial=b.properties.c_axial * cs,
                    c_tilt=b.properties.c_tilt * cs,
                ),
            )
            for b in cfg.bearings
        )
        return cfg.replace(bearings=bearings)


#: Baseline parameter sets: fitted to the healthy machine first, reported as ``baseline_updates``.
BASELINE_TYPES: tuple[type[Effect], ...] = (MeshStiffnessDamping, BearingStiffnessDamping)
