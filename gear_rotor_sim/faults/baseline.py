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
