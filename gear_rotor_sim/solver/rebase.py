"""Systems between the nodes of a temperature-ramp grid, without an assembly or eigendecomposition.

While the temperature ramps, the Simulator assembles the system exactly (``GearRotorSystem.from_config``)
and diagonalises its state matrix only at the nodes of a coarse grid (``ramp_temperature_quantum_c``,
docs/solver.md "Ramps"). At every fine quantum between two nodes it runs a *ramp system*:

* the linear part (M, K, C, G, the mean mesh stiffness and the mesh damping c_m that the linear part
  holds) of the nearer node, so that its state matrix is the node's bit for bit and the node's
  eigenbases serve it unchanged (:meth:`NewmarkStepper.share_bases`);
* the quantities that move the operating point, at the fine quantum itself: the thermal node load
  (Eqs 9-11) evaluated exactly for the default assembly (linearly interpolated between the nodes for
  a custom ``system_builder``), and the mesh stiffness and friction-coefficient tables with their
  jumps (Eqs 13-17, 29) and the thermal half backlash (Eq 27, linear in the temperature) linearly
  interpolated between the two nodes.

The mesh force follows the interpolated tables exactly although the linear part holds the node's
mean stiffness: the kernels add the mean-mesh compensation column ``kbar delta + c_m delta'`` with the
same ``kbar`` the linear part holds (docs/solver.md "Mesh law"), so only the tables set the force.
What stays at the node value is the shafts' and bearings' E*(T), G*(T) (3.4 % over 25-125 C for the
carbon steel of Table 1) and ``c_m`` (proportional to the square root of the mean stiffness).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from gear_rotor_sim.system_data import AssembledSystem, MeshCoupling

__all__ = ["ThermalLoad", "ramp_nodes", "ramp_system"]


def ramp_nodes(temperature_c: float, quantum_c: float, lo_c: float, hi_c: float) -> tuple[float, float]:
    """The grid nodes that bracket ``temperature_c``: multiples of ``quantum_c``, clipped to the ramp's
    range ``[lo_c, hi_c]`` (its two ends are nodes too)."""
    a = float(np.clip(np.floor(temperature_c / quantum_c) * quantum_c, lo_c, hi_c))
    b = float(np.clip(np.ceil(temperature_c / quantum_c) * quantum_c, lo_c, hi_c))
    return a, b


class ThermalLoad:
    """Thermal node loads (Eqs 9-11) of a rig's shaft elements at any uniform temperature.

    The same per-element sum as :meth:`GearRotorSystem.from_config`, in the same order, so at a node
    temperature it equals the assembled ``thermal_load`` bit for bit; the elements are built once.
    """

    def __init__(self, cfg: Any) -> None:
        from gear_rotor_sim.system import shaft_elements

        self.reference_c = float(cfg.reference_temperature_c)
        self.ndof = 6 * int(cfg.n_nodes)
        self._elements = [(np.arange(6 * node0, 6 * node0 + 12), el) for _, node0, el in shaft_elements(cfg)]

    def __call__(self, temperature_c: float) -> np.ndarray:
        out = np.zeros(self.ndof)
        for idx, el in self._elements:
            out[idx] += el.thermal_node_load(temperature_c, self.reference_c)
        return out


def _lerp_callable(
    f0: Callable[[np.ndarray], np.ndarray], f1: Callable[[np.ndarray], np.ndarray], w: float
) -> Callable[[np.ndarray], np.ndarray]:
    if w == 0.0:
        return f0
    if w == 1.0:
        return f1

    def f(phase: np.ndarray) -> np.ndarray:
        return (1.0 - w) * f0(phase) + w * f1(phase)

    return f


def _lerp(a: np.ndarray | None, b: np.ndarray | None, w: float) -> np.ndarray | None:
    if a is None or b is None:
        return None
    return (1.0 - w) * np.asarray(a, float) + w * np.asarray(b, float)


def _ramp_mesh(
    lin: MeshCoupling, m0: MeshCoupling, m1: MeshCoupling, w: float, nodes_c: tuple[float, float]
) -> MeshCoupling:
    """Mesh of a ramp system: ``lin``'s mean stiffness and damping, tables interpolated (weight w)."""
    jumps = None
    if m0.table_jumps is not None and m1.table_jumps is not None:
        j0, j1 = np.asarray(m0.table_jumps, float), np.asarray(m1.table_jumps, float)
        if j0.shape != j1.shape or not np.array_equal(j0[:, 0], j1[:, 0]):
            raise ValueError(
                "ramp_temperature_quantum_c: the mesh-table jump phases differ between the grid nodes "
                f"{nodes_c[0]:g} and {nodes_c[1]:g} C; use the per-quantum rebuild "
                "(ramp_temperature_quantum_c = TEMPERATURE_QUANTUM_C) for this rig"
            )
        jumps = j0.copy()
        jumps[:, 1:] = (1.0 - w) * j0[:, 1:] + w * j1[:, 1:]
    return dataclasses.replace(
        lin,
        stiffness=_lerp_callable(m0.stiffness, m1.stiffness, w),
        force_coefficients=_lerp_callable(m0.force_coefficients, m1.force_coefficients, w),
        half_backlash=(1.0 - w) * m0.half_backlash + w * m1.half_backlash,
        table_stiffness=_lerp(m0.table_stiffness, m1.table_stiffness, w),
        table_coefficients=_lerp(m0.table_coefficients, m1.table_coefficients, w),
        table_jumps=jumps,
    )


def ramp_system(
    lin: AssembledSystem,
    lo: AssembledSystem,
    hi: AssembledSystem,
    temperature_c: float,
    thermal_load: np.ndarray | None = None,
) -> AssembledSystem:
    """The ramp system at ``temperature_c`` between the node systems ``lo`` and ``hi``.

    Parameters
    ----------
    lin : AssembledSystem
        The node whose linear part (M, K, C, G, mean mesh stiffness, c_m) is kept (``lo`` or ``hi``).
    lo, hi : AssembledSystem
        Exact systems at the bracketing nodes (``lo.temperature_c <= temperature_c <= hi.temperature_c``).
    temperature_c : float
        The fine quantum, C.
    thermal_load : ndarray, optional
        Exact thermal node load at ``temperature_c`` (:class:`ThermalLoad`); None interpolates the
        nodes' ``thermal_load`` linearly.

    Returns
    -------
    AssembledSystem
        Same linear part as ``lin``; static load, mesh tables, jumps and half backlash at
        ``temperature_c``.
    """
    t0, t1 = lo.temperature_c, hi.temperature_c
    if not t0 <= temperature_c <= t1:
        raise ValueError(f"temperature_c: {temperature_c} must lie between the nodes {t0} and {t1} C")
    w = 0.0 if t1 == t0 else (temperature_c - t0) / (t1 - t0)
    if lin.thermal_load.size != lin.static_load.size:  # a builder without the thermal part
        thermal_load = lin.thermal_load
        static = (1.0 - w) * lo.static_load + w * hi.static_load
    else:
        if thermal_load is None:
            thermal_load = (1.0 - w) * lo.thermal_load + w * hi.thermal_load
        static = lin.static_load - lin.thermal_load + thermal_load  # the load torque does not depend on T
    meshes: Sequence[MeshCoupling] = tuple(
        _ramp_mesh(ml, m0, m1, w, (t0, t1))
        for ml, m0, m1 in zip(lin.meshes, lo.meshes, hi.meshes, strict=True)
    )
    return dataclasses.replace(
        lin,
        temperature_c=float(temperature_c),
        static_load=static,
        thermal_load=np.asarray(thermal_load, float),
        meshes=tuple(meshes),
    )
