"""Shaft faults: mass unbalance and coupling misalignment.

* ``mass_unbalance``: rotating force ``U Omega^2 (cos(theta+phi), sin(theta+phi))`` at a node
  (ISO 21940-11), ``U = m e`` in kg m.
* ``shaft_misalignment``: parallel offset ``delta`` at the coupling of the driven shaft, represented
  as the reaction ``k_c delta`` of a flexible coupling that rotates at twice the shaft speed (the
  2x order that characterises misalignment; Sekhar & Prabhu 1995, J. Sound Vib. 185(4) 655-671;
  Redmond 2010). One fitted parameter: the offset; the coupling lateral stiffness is fixed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from gear_rotor_sim.faults.base import Effect, ParameterSpec, node_xy_columns, shaft_index


@dataclass(frozen=True)
class MassUnbalance(Effect):
    """Mass unbalance ``U = m e`` at a node: rotating force ``U Omega^2`` (ISO 21940-11).

    Parameters
    ----------
    node : int
        1-based node (Fig 5 numbering).
    unbalance_kg_m : float
        Unbalance U, kg m.
    phase_rad : float
        Angle of the heavy spot at shaft angle 0, rad.
    """

    node: int = 5
    unbalance_kg_m: float = 0.0
    phase_rad: float = 0.0
    name: ClassVar[str] = "mass_unbalance"
    signature: ClassVar[str] = (
        "shaft order 1 of the unbalanced shaft, forward whirl, growing with speed squared"
    )
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("unbalance_kg_m", "kg m", 0.0, 1e-3, "amplitude", "m e"),
        ParameterSpec("phase_rad", "rad", -math.pi, math.pi, "phase", "heavy spot at shaft angle 0"),
    )

    @property
    def label(self) -> str:
        return f"mass_unbalance@node{self.node}"

    def external_forces(self, system: Any) -> np.ndarray | None:
        return node_xy_columns(system, self.node - 1)

    def force_amplitudes(self, ctx: Any) -> np.ndarray | None:
        s = shaft_index(ctx.system, self.node - 1)
        th = ctx.shaft_angle[:, s] + self.phase_rad
        f = self.unbalance_kg_m * ctx.shaft_speed[:, s] ** 2
        return np.column_stack([f * np.cos(th), f * np.sin(th)])


@dataclass(frozen=True)
class ShaftMisalignment(Effect):
    """Parallel misalignment at a flexible coupling: reaction ``k_c delta`` rotating at 2x.

    Parameters
    ----------
    node : int
        1-based coupling node (default the drive node 1).
    offset_m : float
        Parallel offset delta, m.
    phase_rad : float
        Phase of the 2x reaction at shaft angle 0, rad.
    coupling_stiffness_n_per_m : float
        Lateral stiffness of the coupling (fixed, not fitted).
    """

    node: int = 1
    offset_m: float = 0.0
    phase_rad: float = 0.0
    coupling_stiffness_n_per_m: float = 1.0e6
    name: ClassVar[str] = "shaft_misalignment"
    signature: ClassVar[str] = "shaft order 2 (and its growth with the coupling stiffness), no 1x"
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("offset_m", "m", 0.0, 2e-3, "amplitude", "parallel offset at the coupling"),
        ParameterSpec("phase_rad", "rad", -math.pi, math.pi, "phase", "phase of the 2x reaction"),
    )

    @property
    def label(self) -> str:
        return f"shaft_misalignment@node{self.node}"

    def external_forces(self, system: Any) -> np.ndarray | None:
        return node_xy_columns(system, self.node - 1)

    def force_amplitudes(self, ctx: Any) -> np.ndarray | None:
        s = shaft_index(ctx.system, self.node - 1)
        th = 2.0 * ctx.shaft_angle[:, s] + self.phase_rad
        f = self.coupling_stiffness_n_per_m * self.offset_m
        return np.column_stack([f * np.cos(th), f * np.sin(th)])
