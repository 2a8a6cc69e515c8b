"""Systems between the nodes of a temperature-ramp grid, without an assembly or eigendecomposition.

While the temperature ramps (docs/solver.md "Ramps") the Simulator uses three grids:

* **assembly grid** (``RAMP_ASSEMBLY_QUANTUM_C``, 25 C, plus the ramp's two ends): exact systems
  (``GearRotorSystem.from_config``);
* **basis grid** (``ramp_temperature_quantum_c``, 5 C): node systems with their own eigenbases. Between
  two assembly points a node is :func:`interpolated_system`: M, K, C, G, the mesh tables and their
  jumps, the mean mesh stiffness, c_m and b* linearly interpolated, the thermal node load exact.
  E*(T) is a quadratic fit (Table 1), nu(T) linear, so over 25 C the interpolation misses K and
  the mesh stiffness by about 1.5e-4 of their values (measured for the paper gearbox);
* **fine quanta** (0.5 C, as at a constant set-point): :func:`ramp_system`, the nearer node's linear
  part (M, K, C, G, mean mesh stiffness and c_m: its state matrix bit for bit, so the node's
  eigenbases serve unchanged, ``NewmarkStepper.basis_source``) with, at the quantum itself, the
  thermal node load (Eqs 9-11) and the interpolated mesh tables, jumps and b* (Eq 27, linear in T).
  The mesh force follows the tables whatever mean stiffness the linear part holds: the kernels
  compensate ``kbar delta + c_m delta'`` with the same ``kbar`` (docs/solver.md "Mesh law").
  With the default assembly a :class:`RampSpan` per node sets these quanta on one stepper as
  corrections of the node's kernel arrays, without a map build per quantum.

What a ramp system holds at its node's value is the shafts' E*(T), nu(T) (3.4 % of stiffness over
25-125 C for the carbon steel of Table 1) and c_m: at most half a basis-grid step. A first-order
eigenvalue correction toward the other node (``diag(Psi dA Phi)``) did not help (the measured error
stayed 1.0 % against 0.94 % at a 25 C basis grid): the shaft stiffness change mixes the nearly
degenerate bending pairs, which a diagonal correction leaves out.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import scipy.linalg as sla

from gear_rotor_sim.solver.newmark import LinearModel, NewmarkStepper, aligned, effect_columns, gear_map
from gear_rotor_sim.system_data import AssembledSystem, MeshCoupling

__all__ = [
    "RampSpan",
    "ThermalLoad",
    "interpolated_system",
    "ramp_linear_model",
    "ramp_nodes",
    "ramp_system",
]


def ramp_nodes(temperature_c: float, quantum_c: float, lo_c: float, hi_c: float) -> tuple[float, float]:
    """The grid nodes that bracket ``temperature_c``: multiples of ``quantum_c``, clipped to the ramp's
    range ``[lo_c, hi_c]`` (its two ends are nodes too)."""
    a = float(np.clip(np.floor(temperature_c / quantum_c) * quantum_c, lo_c, hi_c))
    b = float(np.clip(np.ceil(temperature_c / quantum_c) * quantum_c, lo_c, hi_c))
    return a, b


class ThermalLoad:
    """Thermal node loads (Eqs 9-11) of a rig's shaft elements at any uniform temperature.

    Each element's load is ``E*(T) A a (T - T_ref)`` on its two axial DOFs (Eq 11,
    :meth:`ShaftElement.thermal_node_load`), so the assembled load is ``sum_mat E_mat(T) (T - T_ref)
    U_mat`` with one fixed vector ``U_mat`` per material: one modulus evaluation per material instead
    of the element loop of :meth:`GearRotorSystem.from_config`. The vectors are formed from that loop
    at ``T_ref + 100 C`` and checked against it at ``T_ref + 50 C`` (relative 1e-12 of the load's
    norm); if the check fails the element loop is used at every call.
    """

    def __init__(self, cfg: Any) -> None:
        from gear_rotor_sim.system import shaft_elements

        self.reference_c = float(cfg.reference_temperature_c)
        self.ndof = 6 * int(cfg.n_nodes)
        self._elements = [(np.arange(6 * node0, 6 * node0 + 12), el) for _, node0, el in shaft_elements(cfg)]
        mats: dict[int, Any] = {id(el.material): el.material for _, el in self._elements}
        self.units: list[tuple[Any, np.ndarray]] | None = None
        self._moduli: dict[tuple[int, float], float] = {}
        t1, t2 = self.reference_c + 100.0, self.reference_c + 50.0
        try:
            units = []
            for key, mat in mats.items():
                u = np.zeros(self.ndof)
                for idx, el in self._elements:
                    if id(el.material) == key:
                        u[idx] += el.thermal_node_load(t1, self.reference_c)
                units.append((mat, u / (mat.youngs_modulus(t1) * (t1 - self.reference_c))))
            self.units = units
            direct = self._direct(t2)
            if not np.linalg.norm(self(t2) - direct) <= 1e-12 * np.linalg.norm(direct):
                self.units = None
        except ValueError:  # a material policy that refuses the check temperatures
            self.units = None

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_moduli"] = {}  # keyed by id(): not valid in another process
        return state

    def modulus(self, mat: Any, temperature_c: float) -> float:
        """``mat.youngs_modulus(temperature_c)``, memoised per material and temperature (a ramp asks for
        the same fine quanta and nodes again and again)."""
        key = (id(mat), float(temperature_c))
        hit = self._moduli.get(key)
        if hit is None:
            hit = mat.youngs_modulus(temperature_c)
            if len(self._moduli) >= 4096:
                self._moduli.clear()
            self._moduli[key] = hit
        return hit

    def _direct(self, temperature_c: float) -> np.ndarray:
        out = np.zeros(self.ndof)
        for idx, el in self._elements:
            out[idx] += el.thermal_node_load(temperature_c, self.reference_c)
        return out

    def __call__(self, temperature_c: float) -> np.ndarray:
        """The assembled thermal node load at ``temperature_c``, (ndof,)."""
        if self.units is None:
            return self._direct(temperature_c)
        dt = float(temperature_c) - self.reference_c
        out = np.zeros(self.ndof)
        for mat, u in self.units:
            out += (self.modulus(mat, temperature_c) * dt) * u
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
    near: MeshCoupling, m0: MeshCoupling, m1: MeshCoupling, w: float, nodes_c: tuple[float, float]
) -> MeshCoupling:
    """Mesh of a ramp system: ``near``'s mean stiffness and c_m; tables, jumps and b* interpolated."""
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
        near,
        stiffness=_lerp_callable(m0.stiffness, m1.stiffness, w),
        force_coefficients=_lerp_callable(m0.force_coefficients, m1.force_coefficients, w),
        half_backlash=(1.0 - w) * m0.half_backlash + w * m1.half_backlash,
        table_stiffness=_lerp(m0.table_stiffness, m1.table_stiffness, w),
        table_coefficients=_lerp(m0.table_coefficients, m1.table_coefficients, w),
        table_jumps=jumps,
    )


def ramp_system(
    near: AssembledSystem,
    lo: AssembledSystem,
    hi: AssembledSystem,
    temperature_c: float,
    thermal_load: np.ndarray | None = None,
) -> AssembledSystem:
    """The ramp system at ``temperature_c`` between the node systems ``lo`` and ``hi``.

    Parameters
    ----------
    near : AssembledSystem
        The nearer node (``lo`` or ``hi``), whose matrices and mean mesh terms are kept (the linear
        model's eigenvalue corrections are in :func:`ramp_linear_model`).
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
        ``near``'s M, K, C, G and mean mesh terms; mesh tables, jumps and b* interpolated; static load
        = the load torque part + the thermal load at ``temperature_c``.
    """
    t0, t1 = lo.temperature_c, hi.temperature_c
    if not t0 <= temperature_c <= t1:
        raise ValueError(f"temperature_c: {temperature_c} must lie between the nodes {t0} and {t1} C")
    w = 0.0 if t1 == t0 else (temperature_c - t0) / (t1 - t0)
    if near.thermal_load.size != near.static_load.size:  # a builder without the thermal part
        thermal_load = near.thermal_load
        static = (1.0 - w) * lo.static_load + w * hi.static_load
    else:
        if thermal_load is None:
            thermal_load = (1.0 - w) * lo.thermal_load + w * hi.thermal_load
        static = near.static_load - near.thermal_load + thermal_load  # the load torque does not depend on T
    meshes: Sequence[MeshCoupling] = tuple(
        _ramp_mesh(mn, m0, m1, w, (t0, t1))
        for mn, m0, m1 in zip(near.meshes, lo.meshes, hi.meshes, strict=True)
    )
    return dataclasses.replace(
        near,
        temperature_c=float(temperature_c),
        static_load=static,
        thermal_load=np.asarray(thermal_load, float),
        meshes=tuple(meshes),
    )


def interpolated_system(
    lo: AssembledSystem, hi: AssembledSystem, temperature_c: float, thermal_load: np.ndarray | None = None
) -> AssembledSystem:
    """A node system at ``temperature_c`` between two exact systems: everything interpolated linearly
    (M, K, C, G, mesh tables and jumps, mean mesh stiffness, c_m, b*) except the thermal node load,
    which is ``thermal_load`` if given (:class:`ThermalLoad`)."""
    t0, t1 = lo.temperature_c, hi.temperature_c
    if not t0 <= temperature_c <= t1:
        raise ValueError(f"temperature_c: {temperature_c} must lie between the nodes {t0} and {t1} C")
    w = 0.0 if t1 == t0 else (temperature_c - t0) / (t1 - t0)
    near = ramp_system(lo, lo, hi, temperature_c, thermal_load)
    meshes = tuple(
        dataclasses.replace(
            mr,
            mean_stiffness=(1.0 - w) * m0.mean_stiffness + w * m1.mean_stiffness,
            damping=(1.0 - w) * m0.damping + w * m1.damping,
        )
        for mr, m0, m1 in zip(near.meshes, lo.meshes, hi.meshes, strict=True)
    )
    return dataclasses.replace(
        near,
        M=(1.0 - w) * lo.M + w * hi.M,
        K=(1.0 - w) * lo.K + w * hi.K,
        C=(1.0 - w) * lo.C + w * hi.C,
        G=(1.0 - w) * lo.G + w * hi.G,
        meshes=meshes,
    )


def ramp_linear_model(
    near: LinearModel,
    system: AssembledSystem,
    effects: Sequence[object] = (),
) -> LinearModel:
    """The :class:`LinearModel` of a ramp system (:func:`ramp_system`) from its near node's model.

    The matrices (and their factorisation) are the node's; the static-load column (``Fc``,
    ``M^-1 Fc``) and b* are the ramp system's. If the effects' force
    columns are not the node's, the model is built in full from ``system`` (no correction).
    """
    cols = effect_columns(system, effects)
    if near.ne != (0 if cols is None else cols.shape[1]) or (
        cols is not None and not np.array_equal(cols[near.free], near.Fc[:, near.col_eff0 :])
    ):
        return LinearModel(system, cols)
    lin = copy.copy(near)
    lin.system = system
    f0 = np.asarray(system.static_load, float)[near.free]
    lin.Fc = near.Fc.copy()
    lin.Fc[:, 0] = f0
    lin.MinvF = near.MinvF.copy()
    lin.MinvF[:, 0] = sla.lu_solve(near.lu_M, f0)
    lin.bstar = np.array([mc.half_backlash for mc in system.meshes], float)
    return lin


# ----------------------------------------------------------------------------------------------
# kernel arrays of the ramp systems of one node as affine corrections (no map build per quantum)


def _diff(a: Any, b: Any) -> Any:
    """``b - a`` over the float arrays of a map (tuples and dataclasses recursed); None where equal.

    Everything that is not a float array (ints, flags, the basis, dt) must be equal in ``a`` and ``b``.
    """
    if isinstance(a, np.ndarray):
        if a.dtype.kind in "fc":
            return None if np.array_equal(a, b) else b - a
        if not np.array_equal(a, b):
            raise ValueError("ramp span: an integer array of the kernel maps changed")
        return None
    if isinstance(a, tuple):
        d = tuple(_diff(x, y) for x, y in zip(a, b, strict=True))
        return d if any(x is not None for x in d) else None
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        out = {}
        for f in dataclasses.fields(a):
            if f.name in ("basis", "xrec"):
                continue
            x, y = getattr(a, f.name), getattr(b, f.name)
            if x is None and y is None:
                continue
            d = _diff(x, y)
            if d is not None:
                out[f.name] = d
        return out or None
    if a != b:
        raise ValueError("ramp span: a scalar of the kernel maps changed")
    return None


def _template(a: Any, diffs: Sequence[Any], out: list[tuple[np.ndarray, np.ndarray, list]]) -> Any:
    """A copy of the map ``a`` whose arrays that any of ``diffs`` (:func:`_diff`, one per coefficient)
    changes are new aligned buffers; appends ``(buffer, base, [(k, d_k)])`` to ``out`` for each, so that
    :func:`_fill` sets ``a + sum_k c_k d_k`` in place (the operations of a copy of ``a`` corrected term
    by term, in the same order: bit for bit the arrays a new map per quantum held)."""
    live = [(k, d) for k, d in enumerate(diffs) if d is not None]
    if not live:
        return a
    if isinstance(a, np.ndarray):
        buf = aligned(a)
        out.append((buf, a, live))
        return buf
    if isinstance(a, tuple):
        return tuple(_template(x, [None if d is None else d[i] for d in diffs], out) for i, x in enumerate(a))
    changes = {}
    for name in {k for _, d in live for k in d}:
        changes[name] = _template(getattr(a, name), [None if d is None else d.get(name) for d in diffs], out)
    if any(f.name == "xrec" for f in dataclasses.fields(a)):
        changes["xrec"] = None
    return dataclasses.replace(a, **changes)


def _fill(entries: Sequence[tuple[np.ndarray, np.ndarray, list]], coefs: Sequence[float]) -> None:
    """``buffer = base + sum_k c_k d_k`` for the entries of :func:`_template`, in place."""
    for buf, base, live in entries:
        np.copyto(buf, base)
        for k, d in live:
            c = coefs[k]
            if c != 0.0:
                buf += c * d


class RampSpan:
    """The ramp systems around one basis-grid node ("near"), on one stepper, without a map build per
    quantum.

    The kernel arrays (``NewmarkStepper.map`` and ``.gear``) are linear in the static-load column and
    in the mesh tables, jumps and b*; everything else is the node's. The static load of a ramp system
    is the node's plus ``sum_k c_k u_k`` (``u_k`` the thermal-load vectors of :class:`ThermalLoad`
    per material, ``c_k = E_k(T) (T - T_ref) - E_k(T_n) (T_n - T_ref)``), its tables the node's moved
    by the fraction ``w`` toward a neighbouring node's (``lower`` below the node, ``upper`` above). So
    per speed and step the span builds the maps A of the node, B_k of the node loaded by ``u_k`` more,
    and C of the node with each neighbour's tables, and at each quantum sets ``A + sum_k c_k (B_k - A)
    + w (C - A)`` on its stepper (microseconds): the map a rebuild would give (to round-off, tested),
    while the modal state carries on in the same basis.
    """

    def __init__(
        self,
        near: tuple[AssembledSystem, NewmarkStepper],
        lower: AssembledSystem | None,
        upper: AssembledSystem | None,
        thermal: ThermalLoad,
        make_stepper: Callable[[AssembledSystem, LinearModel], NewmarkStepper],
        effects: Sequence[object] = (),
    ) -> None:
        if thermal.units is None:
            raise ValueError("RampSpan: the thermal load has no per-material form")
        self.near_system, self.near = near
        self.lower, self.upper = lower, upper
        self.thermal = thermal
        self.effects = tuple(effects)
        self._make = make_stepper
        self.stepper = self._new_stepper(self.near_system)
        self._key: tuple[float, float, float | None, bool] | None = None
        self._base: tuple[Any, Any] | None = None
        self._diffs: list[tuple[Any, Any]] = []
        self._entries: list[tuple[np.ndarray, np.ndarray, list]] = []
        self._maps: tuple[Any, Any] = (None, None)
        self._scales: list[float] = []

    def _new_stepper(self, system: AssembledSystem) -> NewmarkStepper:
        st = self._make(system, ramp_linear_model(self.near.lin, system, self.effects))
        st.basis_source = self.near.basis  # the same state matrix: the node's bases
        return st

    def _coefficients(self, temperature_c: float) -> list[float]:
        t_n = self.near_system.temperature_c
        ref = self.thermal.reference_c
        cs = [
            (
                self.thermal.modulus(mat, temperature_c) * (temperature_c - ref)
                - self.thermal.modulus(mat, t_n) * (t_n - ref)
            )
            / sc
            for (mat, _), sc in zip(self.thermal.units, self._scales, strict=True)  # type: ignore[arg-type]
        ]
        for side, other in ((-1.0, self.lower), (1.0, self.upper)):
            if other is None:
                continue
            w = (temperature_c - t_n) / (other.temperature_c - t_n)
            cs.append(w if w > 0.0 and side * (temperature_c - t_n) > 0.0 else 0.0)
        return cs

    def _prepare(self, omega: float, dt: float, cut: float | None, exact: bool, state: Any) -> None:
        """Maps of the node, of each unit load added, of each neighbour's tables at (omega, dt)."""
        ns = self.near_system
        # each unit load scaled to the static load's norm: the difference of the two maps then keeps
        # full precision (a bare u, ~1e-9 N per Pa C, vanished in the round-off of the node's load)
        size = float(np.linalg.norm(ns.static_load)) or 1.0
        units = [u for _, u in self.thermal.units]  # type: ignore[union-attr]
        self._scales = [size / max(float(np.linalg.norm(u)), 1e-300) for u in units]
        variants = [
            dataclasses.replace(
                ns, static_load=ns.static_load + sc * u, thermal_load=ns.thermal_load + sc * u
            )
            for sc, u in zip(self._scales, units, strict=True)
        ]
        maps = []
        for system in [ns, *variants]:
            st = self._new_stepper(system)
            st.modal_cutoff_hz = cut
            st.exact_map = exact
            st.set_operating_point(omega, dt, state)
            maps.append((st.map, st.gear))
        # the tables enter the gear kernel's arrays only (the step map holds no table): the node's
        # step map with each neighbour's tables
        nodes = (ns.temperature_c, ns.temperature_c)
        for other in (self.lower, self.upper):
            if other is not None:
                meshes = tuple(
                    _ramp_mesh(mn, mn, mf, 1.0, nodes) for mn, mf in zip(ns.meshes, other.meshes, strict=True)
                )
                system = dataclasses.replace(ns, meshes=meshes)
                lin = ramp_linear_model(self.near.lin, system, self.effects)
                a_map, a_gear = maps[0]
                gear = None if a_gear is None else gear_map(lin, a_map, self.stepper.specs)
                maps.append((a_map, gear))
        self._base = maps[0]
        self._diffs = [(_diff(maps[0][0], m[0]), _diff(maps[0][1], m[1])) for m in maps[1:]]
        # the corrected maps' buffers, filled in place at each quantum (retarget)
        self._entries = []
        self._maps = (
            _template(maps[0][0], [d[0] for d in self._diffs], self._entries),
            _template(maps[0][1], [d[1] for d in self._diffs], self._entries),
        )
        self._key = (omega, dt, cut, exact)

    def retarget(
        self,
        system: AssembledSystem,
        omega: float,
        dt: float,
        cut: float | None,
        state: Any,
        exact: bool = False,
    ) -> tuple[NewmarkStepper, bool]:
        """Set the span's stepper to the ramp system ``system`` (:func:`ramp_system` at a quantum
        within half a grid step of the node) at speed omega, step dt, modal cut-off ``cut`` and
        modal map (``exact``: ``NewmarkStepper.exact_map``); ``state`` (a SolverState) is only read to
        build the maps. Returns the stepper and whether its
        modal state carries on (True: it already ran this span at the same speed and step; False:
        load the state into it)."""
        if self._key != (omega, dt, cut, exact):
            self._prepare(omega, dt, cut, exact, state)
        st = self.stepper
        carry = st.map is not None and st.map.basis.omega == omega and st.map.dt == dt
        carry = carry and st.map.exact == self._base[0].exact  # type: ignore[index]
        carry = carry and self._base is not None and st.map.basis is self._base[0].basis
        coefs = self._coefficients(system.temperature_c)
        _fill(self._entries, coefs)
        st.map, st.gear = self._maps
        st.map.xrec = None  # rebuilt from the new arrays on first use
        st.system = system
        st.lin = ramp_linear_model(self.near.lin, system, self.effects)
        st.modal_cutoff_hz = cut
        st.exact_map = exact
        st._reduced.clear()  # residual flexibilities hold the previous static-load column
        return st, carry
