"""The physical state carried between chunks, bases and rebuilds (``SolverState``), the mesh law of
Eqs 25-26 evaluated directly (``mesh_law``) and the static equilibrium (``static_equilibrium``)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from gear_rotor_sim.solver.excitation import effect_columns
from gear_rotor_sim.solver.linear_model import LinearModel
from gear_rotor_sim.system_data import AssembledSystem


@dataclass
class SolverState:
    """Physical state carried across chunks, bases and temperature rebuilds (basis independent).

    ``x = [q_free; v_free]``; per mesh at the last step: ``delta``, ``delta_dot``, ``force``,
    ``coef`` (basis coefficients), contact ``state``; effect amplitudes ``ampl``; the integrated
    input-shaft angle (rad) and simulated time.
    """

    x: np.ndarray
    delta: np.ndarray
    delta_dot: np.ndarray
    force: np.ndarray
    coef: np.ndarray
    contact: np.ndarray
    ampl: np.ndarray
    angle: float = 0.0
    time: float = 0.0
    free_dofs: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def copy(self) -> SolverState:
        return SolverState(
            self.x.copy(),
            self.delta.copy(),
            self.delta_dot.copy(),
            self.force.copy(),
            self.coef.copy(),
            self.contact.copy(),
            self.ampl.copy(),
            self.angle,
            self.time,
            self.free_dofs.copy(),
        )

    def q_full(self, ndof: int) -> np.ndarray:
        """Displacements on all DOFs (constrained ones zero)."""
        q = np.zeros(ndof)
        q[self.free_dofs] = self.x[: self.free_dofs.size]
        return q


def mesh_law(
    delta: np.ndarray,
    delta_dot: np.ndarray,
    k: np.ndarray,
    c: np.ndarray,
    e: np.ndarray,
    e_dot: np.ndarray,
    b: np.ndarray,
) -> np.ndarray:
    """Eq 25-26 evaluated directly: F = k (gamma0 delta_m + gamma1 b) + c gamma0 delta_m'."""
    dm = delta - e
    g0 = (np.abs(dm) > b).astype(float)
    g1 = np.where(dm > b, -1.0, np.where(dm < -b, 1.0, 0.0))
    return k * (g0 * dm + g1 * b) + c * g0 * (delta_dot - e_dot)


def static_equilibrium(system: AssembledSystem, effects: Sequence[object] = ()) -> SolverState:
    """Static state at mean mesh stiffness, no transmission error, phase-mean friction coefficients.

    Solves ``K q = f_static + sum u_m F_m`` with ``F_m = k_mean (V q -/+ b*)`` per the contact state of
    Eq 26, the states found by an active set (consistent: ``V q > b*`` on the drive side, etc.).
    """
    lin = LinearModel(system, effect_columns(system, effects))
    free = lin.free
    n, nm = lin.nfree, lin.nm
    ph = np.linspace(0.0, 1.0, 64, endpoint=False)
    u = np.zeros((nm, n))
    for i, m in enumerate(system.meshes):
        cf = np.asarray(m.force_coefficients(ph), float).reshape(ph.size, -1).mean(axis=0)
        u[i] = np.asarray(m.force_basis, float)[free] @ cf
    K0 = np.asarray(system.K, float)[np.ix_(free, free)]
    f0 = np.asarray(system.static_load, float)[free]
    contact = np.ones(nm, dtype=np.int64)
    q = np.zeros(n)
    for _ in range(3 ** max(nm, 1) + 2):
        kk = K0.copy()
        rhs = f0.copy()
        for i in range(nm):
            if contact[i]:
                kk -= lin.kbar[i] * np.outer(u[i], lin.V[i])
                rhs -= lin.kbar[i] * contact[i] * lin.bstar[i] * u[i]
        try:
            q = np.linalg.solve(kk, rhs)
        except np.linalg.LinAlgError:
            q = np.linalg.lstsq(kk, rhs, rcond=None)[0]
        d = lin.V @ q
        new = np.where(d > lin.bstar, 1, np.where(d < -lin.bstar, -1, 0))
        if np.array_equal(new, contact):
            break
        contact = new
    d = lin.V @ q
    force = lin.kbar * (d - contact * lin.bstar) * (contact != 0)
    coef = np.zeros((nm, lin.nb))
    for i, m in enumerate(system.meshes):
        cf = np.asarray(m.force_coefficients(np.zeros(1)), float).reshape(-1)
        coef[i, : cf.size] = cf
    x = np.concatenate([q, np.zeros(n)])
    return SolverState(
        x,
        d,
        np.zeros(nm),
        force,
        coef,
        (2 * contact).astype(np.int64),
        np.zeros(lin.ne),
        0.0,
        0.0,
        free.copy(),
    )
