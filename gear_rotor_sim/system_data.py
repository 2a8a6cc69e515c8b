"""Data that crosses the boundary between assembly (system.py) and the solver/simulator.

The assembly fills these; the solver only reads them. SI units, 0-based indices, global DOF
``6 * node0 + dof`` with dof order x, y, z, theta_x, theta_y, theta_z.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

DOF_NAMES: tuple[str, ...] = ("x", "y", "z", "theta_x", "theta_y", "theta_z")


@dataclass(frozen=True)
class MeshCoupling:
    """One spur mesh as the solver sees it (Eqs 21-33).

    The generalised mesh force on the system is ``basis @ coefficients(phase) * F_m`` where the
    first basis column is ``-V`` (Eq 22, line of action) and the others are the friction parts of
    V_f (Eq 29); column 0 of ``coefficients`` is always 1.
    """

    pinion_node0: int
    gear_node0: int
    pinion_shaft: int
    gear_shaft: int
    pinion_teeth: int
    gear_teeth: int
    line_of_action: np.ndarray  # (ndof,) V of Eq 22 scattered to global DOFs: delta = V @ q
    force_basis: np.ndarray  # (ndof, nb), column 0 = -V
    force_coefficients: Callable[[np.ndarray], np.ndarray]  # mesh phase (n,) -> (n, nb)
    stiffness: Callable[[np.ndarray], np.ndarray]  # mesh phase in [0, 1) (n,) -> k_m* (n,), N/m
    mean_stiffness: float  # N/m
    damping: float  # c_m, N s/m
    half_backlash: float  # b* of Eq 27, m
    te_amplitude: float  # e0 of Eq 24, m
    te_phase: float  # phi of Eq 24, rad
    base_radius_pinion: float  # m
    base_radius_gear: float  # m
    contact_ratio: float
    # The same tables on the uniform phase grid ``arange(n) / n`` (periodic linear interpolation), for
    # compiled kernels that look them up per step; None when only the callables are given.
    table_stiffness: np.ndarray | None = None  # (n,) N/m
    table_coefficients: np.ndarray | None = None  # (n, nb)
    # Phases in [0, 1) where stiffness and coefficients jump (tooth-pair changes, pitch point) and the
    # jumps: rows (phase, dk, dcoef_0..nb-1), right limit minus left limit; None if not known. Kernels
    # that locate these events inside a step split the step there (docs/solver.md).
    table_jumps: np.ndarray | None = None
    # Sliding-wear transmission error per unit wear depth on the same uniform phase grid (dimensionless,
    # faults.gear.mesh_wear_profile: zero at the pitch point, 1 at the far end of the path of contact);
    # None when the mesh geometry is not known.
    table_wear_profile: np.ndarray | None = None


@dataclass(frozen=True)
class BearingSite:
    """A bearing at a node (Eq 37); force on the housing is ``Kb @ q_node + Cb @ v_node``."""

    number: int  # 1-based as in the paper
    node0: int
    stiffness: np.ndarray  # (6, 6)
    damping: np.ndarray  # (6, 6)
    type_name: str = ""


@dataclass(frozen=True)
class AssembledSystem:
    """Eq 39 at one temperature: M q'' + (Omega G + C) q' + K q = static_load + mesh + effects.

    ``G`` is per rad/s of the input (drive) shaft: each shaft's gyroscopic matrix is already scaled
    by its signed speed ratio. ``K`` and ``C`` hold no mesh terms; meshes are in ``meshes``.
    ``free_dofs`` excludes the DOFs fixed by the drive condition (the drive node's theta_z).
    """

    temperature_c: float
    M: np.ndarray
    K: np.ndarray
    C: np.ndarray
    G: np.ndarray
    static_load: np.ndarray  # (ndof,) thermal node load + load torque, N or N m
    free_dofs: np.ndarray  # (nfree,) int
    meshes: tuple[MeshCoupling, ...]
    bearings: tuple[BearingSite, ...]
    shaft_of_node: np.ndarray  # (n_nodes,) shaft index of each node
    shaft_speed_ratios: np.ndarray  # (n_shafts,) signed spin speed / input speed
    node_positions: np.ndarray  # (n_nodes,) axial position along its shaft, m
    thermal_load: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (ndof,) part of static_load

    @property
    def ndof(self) -> int:
        return int(self.M.shape[0])

    @property
    def n_nodes(self) -> int:
        return self.ndof // 6

    def dof(self, node: int, name: str) -> int:
        """Global 0-based DOF of a 1-based node and a DOF name (``"x"``, ..., ``"theta_z"``)."""
        if not 1 <= node <= self.n_nodes:
            raise ValueError(f"node: {node} is outside 1..{self.n_nodes}")
        if name not in DOF_NAMES:
            raise ValueError(f"dof: {name!r} is not one of {DOF_NAMES}")
        return 6 * (node - 1) + DOF_NAMES.index(name)
