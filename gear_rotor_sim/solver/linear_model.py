"""The linear part of Eq 39 on the free DOFs: matrices with the mean mesh terms, force columns and
output rows of one assembled system (``LinearModel``; module docstring of ``newmark``)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.linalg as sla

from gear_rotor_sim.solver.channels import ChannelSpec
from gear_rotor_sim.system_data import AssembledSystem


class LinearModel:
    """Free-DOF matrices, force columns and output rows of one AssembledSystem (one temperature).

    Parameters
    ----------
    system : AssembledSystem
    effect_columns : ndarray, optional
        (ndof, ne) fixed generalised force vectors of effects (their amplitudes vary per step).
    """

    def __init__(self, system: AssembledSystem, effect_columns: np.ndarray | None = None) -> None:
        self.system = system
        free = np.asarray(system.free_dofs, dtype=np.int64)
        self.free = free
        self.nfree = n = free.size
        self.nstate = 2 * n
        pos = np.full(system.ndof, -1, dtype=np.int64)
        pos[free] = np.arange(n)
        self.pos = pos
        ix = np.ix_(free, free)
        self.M = np.asarray(system.M, float)[ix]
        self.K = np.asarray(system.K, float)[ix].copy()
        self.C = np.asarray(system.C, float)[ix].copy()
        self.G = np.asarray(system.G, float)[ix]
        meshes = system.meshes
        self.nm = nm = len(meshes)
        self.nb = nb = max((mc.force_basis.shape[1] for mc in meshes), default=1)
        self.V = np.zeros((nm, n))
        for i, mc in enumerate(meshes):
            v = np.asarray(mc.line_of_action, float)[free]
            self.V[i] = v
            self.K += mc.mean_stiffness * np.outer(v, v)
            self.C += mc.damping * np.outer(v, v)
        self.kbar = np.array([mc.mean_stiffness for mc in meshes], float)
        self.cmesh = np.array([mc.damping for mc in meshes], float)
        self.bstar = np.array([mc.half_backlash for mc in meshes], float)
        ne = 0 if effect_columns is None else effect_columns.shape[1]
        self.ne = ne
        cols = [np.asarray(system.static_load, float)[free]]
        self.col_basis = np.full((nm, nb), -1, dtype=np.int64)
        self.col_comp = np.zeros(nm, dtype=np.int64)
        for i, mc in enumerate(meshes):
            fb = np.asarray(mc.force_basis, float)
            for j in range(fb.shape[1]):
                self.col_basis[i, j] = len(cols)
                cols.append(fb[free, j])
            self.col_comp[i] = len(cols)
            cols.append(self.V[i].copy())
        self.col_eff0 = len(cols)
        for j in range(ne):
            cols.append(np.asarray(effect_columns[:, j], float)[free])  # type: ignore[index]
        self.Fc = np.column_stack(cols)
        self.m = self.Fc.shape[1]
        self.lu_M = sla.lu_factor(self.M)
        self.MinvF = sla.lu_solve(self.lu_M, self.Fc)
        self.MinvK = sla.lu_solve(self.lu_M, self.K)
        self.MinvC = sla.lu_solve(self.lu_M, self.C)
        self.MinvG = sla.lu_solve(self.lu_M, self.G)

    def damping(self, omega: float) -> np.ndarray:
        """``M^-1 D`` at input speed omega (rad/s)."""
        return self.MinvC + omega * self.MinvG

    def state_matrix(self, omega: float) -> np.ndarray:
        """``A = [[0, I], [-M^-1 K_lin, -M^-1 D]]``."""
        n = self.nfree
        a = np.zeros((2 * n, 2 * n))
        a[:n, n:] = np.eye(n)
        a[n:, :n] = -self.MinvK
        a[n:, n:] = -self.damping(omega)
        return a

    def output_rows(self, specs: Sequence[ChannelSpec], omega: float) -> tuple[np.ndarray, np.ndarray]:
        """State rows (no, 2n) and force feed-through rows (no, m) of the ``row`` channels."""
        n = self.nfree
        rows = [s for s in specs if s.kind == "row"]
        cx = np.zeros((len(rows), 2 * n))
        df = np.zeros((len(rows), self.m))
        md = None
        for o, s in enumerate(rows):
            if s.bearing >= 0:
                site = self.system.bearings[s.bearing]
                for d in range(6):
                    p = self.pos[6 * site.node0 + d]
                    if p >= 0:
                        cx[o, p] += site.stiffness[s.component, d]
                        cx[o, n + p] += site.damping[s.component, d]
                continue
            p = self.pos[s.dof]
            if p < 0:
                continue  # a constrained DOF has no vibration
            if s.order == 0:
                cx[o, p] = 1.0
            elif s.order == 1:
                cx[o, n + p] = 1.0
            else:
                if md is None:
                    md = self.damping(omega)
                cx[o, :n] = -self.MinvK[p]
                cx[o, n:] = -md[p]
                df[o] = self.MinvF[p]
        return cx, df
