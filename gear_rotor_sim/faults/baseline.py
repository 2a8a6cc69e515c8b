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
    """Scale of the lateral stiffness and damping of every bearing (Eq 37: radial and tilt terms of
    K^b and C^b).

    Catalogue or Table 5 bearing stiffnesses are nominal: preload, fits and housing compliance make
    the real values differ by tens of percent. The scale moves the shaft-bearing modes, so it is a
    baseline parameter of the machine, never a finding.

    The axial terms (``k_axial``, ``c_axial``) are left at their nominal values on purpose. In a
    spur gearbox only a misaligned gear (an effect of the library, not of the baseline) excites the
    axial direction, so the scale is identified by the lateral modes; what the axial bearing
    stiffness ``k_b`` sets is the static thermal axial load ``k_s a dT L / (1 + 2 k_s / k_b)``
    (nearly ``k_b a dT L / 2`` for the paper's shafts on A# bearings, ``2 k_s / k_b = 91``), the
    calibration's thermometer (``docs/calibration.md`` Sec. 8.3). Carrying a lateral scale over to
    ``k_b`` turns a model-form correction of the lateral modes into a temperature error: the scale
    0.522 fitted on a healthy 2000 rpm reference of the independent lumped gearbox, applied to
    ``k_b`` too, lowers the static axial force of bearing 2 at 85 C from 1108 N to 581 N (FE static
    solution), and a +60 C offset at 3000 rpm was read as +111 C.

    Parameters
    ----------
    stiffness_scale : float
        Multiplies k_radial and k_tilt of all bearings.
    damping_scale : float
        Multiplies c_radial and c_tilt of all bearings.
    """

    stiffness_scale: float = 1.0
    damping_scale: float = 1.0
    name: ClassVar[str] = "bearing_stiffness_damping"
    signature: ClassVar[str] = "shaft-bearing (lateral) mode frequencies and peak heights"
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("stiffness_scale", "1", 0.3, 3.0, "scalar", "bearing radial/tilt stiffness multiplier"),
        ParameterSpec("damping_scale", "1", 0.3, 3.0, "scalar", "bearing radial/tilt damping multiplier"),
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
                    k_tilt=b.properties.k_tilt * ks,
                    c_radial=b.properties.c_radial * cs,
                    c_tilt=b.properties.c_tilt * cs,
                ),
            )
            for b in cfg.bearings
        )
        return cfg.replace(bearings=bearings)


#: Baseline parameter sets: fitted to the healthy machine first, reported as ``baseline_updates``.
BASELINE_TYPES: tuple[type[Effect], ...] = (MeshStiffnessDamping, BearingStiffnessDamping)
