"""The gear pair's inertia as a baseline parameter: the mesh mode apart from the static compliance.

One mesh stiffness scale ``s_k`` sets both the static mesh compliance ``F / k`` (the DTE's mean and its
quasi-static comb, which a damaged tooth's depth is read from) and the mesh mode ``sqrt(k / m_e)``. Two
models of one machine whose equivalent inertias differ cannot agree on both with one scale
(``docs/history/calibration_sessions.md`` Sec. 8.35 and 8.41). Scaling the gear discs' mass and inertia by
``s_m`` moves the mode by ``1 / sqrt(s_m)`` and leaves every static quantity as it was.

The discs are the rigid gear discs of Sun et al. (2021) Sec 3.1 (Eqs 19-20, mass and polar/diametral
inertia of the pitch-diameter annulus): the density of their material is scaled (a copy of the
material, so the shafts keep theirs). The mesh damping coefficient ``c_m = 2 zeta sqrt(k_mean m_e)``
(Eq 25) would follow ``sqrt(s_m)``; the damping ratio is divided by ``sqrt(s_m)`` so that ``c_m``
stays the mesh damping set's (``MeshStiffnessDamping``) alone.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from gear_rotor_sim.config import RigConfig
from gear_rotor_sim.faults.base import Effect, ParameterSpec


def scaled_gear_inertia(cfg: RigConfig, scale: float) -> RigConfig:
    """``cfg`` with every gear disc's mass and inertia times ``scale`` and the mesh ``c_m`` held.

    Parameters
    ----------
    cfg : RigConfig
        Rig with gears and meshes.
    scale : float
        Multiplier of the gear discs' density (> 0).

    Returns
    -------
    RigConfig
        Gears on copies of their materials (``<name>*gear_inertia``) with the density scaled; mesh
        damping ratios divided by ``sqrt(scale)``.
    """
    if not (math.isfinite(scale) and scale > 0.0):
        raise ValueError(f"scale: {scale} must be finite and > 0")
    if scale == 1.0:
        return cfg
    materials = dict(cfg.materials)
    gears = []
    for g in cfg.gears:
        name = f"{g.material}*gear_inertia"
        if name not in materials:
            base = cfg.materials[g.material]
            materials[name] = dataclasses.replace(base, name=name, density=base.density * scale)
        gears.append(dataclasses.replace(g, material=name))
    root = math.sqrt(scale)
    meshes = tuple(dataclasses.replace(m, damping_ratio=m.damping_ratio / root) for m in cfg.meshes)
    return cfg.replace(materials=materials, gears=tuple(gears), meshes=meshes)


@dataclass(frozen=True)
class MeshInertia(Effect):
    """Scale of the gear discs' mass and inertia, the mesh stiffness scaled with it (mode held).

    With ``s`` the inertia scale, the gear discs' mass and inertias are ``x s`` and the mesh stiffness
    ``k_m(t) x s``: the mesh mode ``sqrt(k / m_e)`` stays where the mesh set placed it, the static
    mesh compliance ``F / k`` moves by ``1 / s``. Together with ``mesh_stiffness_damping`` (``s_k``) the
    machine's mesh stiffness is ``s_k s`` and its gear inertia ``s``: the pair (stiffness, inertia)
    reparametrised as (mode frequency, static compliance), so the set is fitted on one scalar after
    the mesh set has placed the mode.

    Parameters
    ----------
    inertia_scale : float
        Multiplies the gear discs' mass and inertias and the mesh stiffness.
    """

    inertia_scale: float = 1.0
    name: ClassVar[str] = "mesh_inertia"
    signature: ClassVar[str] = (
        "static mesh compliance (DTE mean, quasi-static mesh harmonics) at a held mesh mode; the "
        "lateral and torsional modes of the gear discs"
    )
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec(
            "inertia_scale", "1", 0.5, 2.0, "scalar", "gear-disc mass/inertia and mesh stiffness multiplier"
        ),
    )

    def applicable(self, cfg: RigConfig) -> bool:
        return bool(cfg.meshes) and bool(cfg.gears)

    def mesh_stiffness_factor(self, ctx: Any) -> np.ndarray | None:
        return np.full(ctx.t.shape[0], self.inertia_scale)

    def modify_config(self, cfg: RigConfig) -> RigConfig:
        return scaled_gear_inertia(cfg, self.inertia_scale)


@dataclass(frozen=True)
class GearInertia(Effect):
    """Scale of the gear discs' mass and inertia alone (mesh stiffness as it is): the diagnosis's
    second axis (``benchmarks/mesh_inertia_diagnosis.py``); not offered to the fit.

    Parameters
    ----------
    inertia_scale : float
        Multiplies the gear discs' mass and inertias.
    """

    inertia_scale: float = 1.0
    name: ClassVar[str] = "gear_inertia"
    signature: ClassVar[str] = (
        "mesh mode (1 / sqrt of the scale), the gear discs' lateral and torsional modes"
    )
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("inertia_scale", "1", 0.5, 2.0, "scalar", "gear-disc mass/inertia multiplier"),
    )

    def applicable(self, cfg: RigConfig) -> bool:
        return bool(cfg.gears)

    def modify_config(self, cfg: RigConfig) -> RigConfig:
        return scaled_gear_inertia(cfg, self.inertia_scale)
