"""The arrays of the gear kernel (``gear_kernel.run_chunk_gear``) at one step map: the mesh tables split
into continuous parts and jumps (``split_table_jumps``), the modal, mesh and output arrays
(``GearMap``, ``gear_map``)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gear_rotor_sim.solver.arrays import aligned
from gear_rotor_sim.solver.channels import ChannelSpec
from gear_rotor_sim.solver.linear_model import LinearModel
from gear_rotor_sim.solver.modal_map import StepMap

OUTPUT_BLOCK_STEPS = 64  # steps per output matrix product in the gear kernel (fits L1/L2)


def split_table_jumps(
    tab_k: np.ndarray, tab_c: np.ndarray, jumps: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Continuous tables plus periodic steps: ``k(f) = kc(f) + sum_j dk_j ([f >= p_j] - f)``.

    ``jumps`` rows are (phase, dk, dcoef...) as :attr:`MeshCoupling.table_jumps` (right minus left
    limit). Each ``[f >= p_j] - f`` is periodic on [0, 1) and jumps by 1 at ``p_j`` only (the ramp
    carries the net change, as the jumps of a periodic table need not sum to zero), so ``kc`` is
    continuous and periodic and its linear interpolation on the table grid is second-order accurate.
    Returns ``(kc, cc, jump_p, jump_k, jump_c)`` with the phases sorted.
    """
    nt = tab_k.size
    nb = tab_c.shape[1]
    if jumps is None or len(jumps) == 0:
        z = np.zeros(0)
        return tab_k.copy(), tab_c.copy(), z, z, np.zeros((0, nb))
    jumps = np.asarray(jumps, float)
    jumps = jumps[np.argsort(jumps[:, 0])]
    p, jk, jc = jumps[:, 0], jumps[:, 1], np.ascontiguousarray(jumps[:, 2 : 2 + nb])
    grid = np.arange(nt) / nt
    saw = (grid[:, None] >= p[None, :]).astype(float) - grid[:, None]  # (nt, nj)
    return tab_k - saw @ jk, tab_c - saw @ jc, p.copy(), jk.copy(), jc


def _jump_intervals(nt: int, jump_p: np.ndarray) -> np.ndarray:
    """int8 flag per interval [i/nt, (i+1)/nt) of the table grid: 1 if a jump phase lies in it."""
    flag = np.zeros(nt, dtype=np.int8)
    for p in jump_p:
        i = int(np.floor(p * nt)) % nt
        flag[i] = 1
        flag[(i - 1) % nt] = 1  # guard the interval before (phase round-off at a grid point)
    return flag


def _static_feed(mp: StepMap, specs: Sequence[ChannelSpec] | None) -> np.ndarray:
    """Output offset of the static-load column (amplitude 1), per output column of the gear map."""
    rows = mp.dfeed[:, 0] if mp.dfeed.size else np.zeros(mp.outr.shape[0])
    if specs is None or rows.size == 0:
        return rows.copy()
    out = np.zeros(len(specs))
    o = 0
    for i, sp in enumerate(specs):
        if sp.kind == "row":
            out[i] = rows[o]
            o += 1
    return out


def _output_stack(
    lin: LinearModel, mp: StepMap, specs: Sequence[ChannelSpec] | None, cols: np.ndarray, ucol: list[int]
) -> tuple[np.ndarray, np.ndarray]:
    """Output matrix ``[z_r, z_i, beta] -> channels`` of the gear kernel and the static offsets.

    With ``specs`` every channel in order (``dte_i = V_i x``, mesh force ``F_i = kbar_i delta_i + c_i
    delta_i' - u_i``, both linear in the modal state and the active column amplitudes; ``ucol[i]`` is
    the active column of ``u_i``); without, or with no state-row channel, only the state rows. With a
    reduced basis (``mp.resid``) each channel also reads the dropped modes' static part through the
    column amplitudes (the static-load column's into the offset).
    """
    npad = mp.nmode
    nk = mp.basis.lam.size
    n = lin.nfree
    nrow = mp.outr.shape[0]
    cx = rres = None
    if mp.resid is not None:
        cx, _ = lin.output_rows([sp for sp in specs or () if sp.kind == "row"], mp.basis.omega)
        rres = cx @ mp.resid  # (nrow, m)
    rows = np.zeros((2 * npad + cols.size, nrow))
    static_add = np.zeros(nrow)
    if nrow:
        rows[:npad] = mp.outr.T
        rows[npad : 2 * npad] = -mp.outi.T
        rows[2 * npad :] = mp.dfeed[:, cols].T
        if rres is not None and rres.shape[0] == nrow:
            rows[2 * npad :] += rres[:, cols].T
            static_add += rres[:, 0]
    if specs is None or nrow == 0:
        return rows, static_add
    cstack = np.zeros((rows.shape[0], len(specs)))
    static_add = np.zeros(len(specs))
    o = 0
    for i, sp in enumerate(specs):
        if sp.kind == "row":
            cstack[:, i] = rows[:, o]
            if rres is not None:
                static_add[i] = rres[o, 0]
            o += 1
            continue
        vd = np.zeros(npad, dtype=complex)
        vv = np.zeros(npad, dtype=complex)
        vd[:nk] = lin.V[sp.mesh] @ mp.basis.phi[:n]
        vv[:nk] = lin.V[sp.mesh] @ mp.basis.phi[n:]
        rd = np.zeros(lin.m)
        if mp.resid is not None:
            rd = lin.V[sp.mesh] @ mp.resid[:n]
        if sp.kind == "force":
            vd = lin.kbar[sp.mesh] * vd + lin.cmesh[sp.mesh] * vv
            cstack[2 * npad + ucol[sp.mesh], i] = -1.0
            if mp.resid is not None:
                rd = lin.kbar[sp.mesh] * rd + lin.cmesh[sp.mesh] * (lin.V[sp.mesh] @ mp.resid[n:])
        cstack[:npad, i] = vd.real
        cstack[npad : 2 * npad, i] = -vd.imag
        cstack[2 * npad :, i] += rd[cols]
        static_add[i] = rd[0]
    return cstack, static_add


@dataclass
class GearMap:
    """Arrays of :func:`gear_kernel.run_chunk_gear` (any number of table meshes, full or reduced modal
    basis), grouped by role as the kernel takes them (see its module docstring).

    Active force columns: mesh i owns ``i nb .. i nb + nb - 1`` (``u_i`` = the compensation column
    ``+V_i``, which also carries the line-of-action part ``-V_i F_i``, then the friction basis),
    then the effects.
    """

    cols: np.ndarray  # LinearModel column index of each active column
    # (zr, zi) are filled per chunk; (rr, ri, c0r, c0i, swr, swi, crr, cri, vrr, vri, mur, mui, pmr, pmi)
    modal: tuple
    n_forced: int
    mesh: tuple  # (pq, pqn, pq_static, rstat, pd, pv, mesh_par)
    tables: tuple  # (tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k, jump_c, n_jump)
    cstack: np.ndarray
    dfeed_static: np.ndarray


def gear_map(lin: LinearModel, mp: StepMap, specs: Sequence[ChannelSpec] | None = None) -> GearMap | None:
    """The gear kernel's arrays for a modal step map, or None if the kernel does not apply.

    Applies when every mesh has uniform tables of one common length and force basis width, whose first
    basis column is ``-V`` and first coefficient 1 (Eq 22 / Eq 29). With ``specs`` the output matrix
    gives every channel in their order (``dte_i = V_i x`` and ``F_i = kbar_i delta_i + c_i delta_i' -
    u_i`` are linear in the modal state and the column amplitudes too); without, only the state rows.
    With a reduced basis (``mp.resid``) delta, delta' and the outputs read the dropped modes' static
    response to the new column amplitudes (``pqn``, ``rstat``, :func:`_output_stack`).
    """
    nm = lin.nm
    if mp.dense or nm == 0:
        return None
    meshes = lin.system.meshes
    nb = lin.nb
    nt = None
    for i, mc in enumerate(meshes):
        if mc.table_stiffness is None or mc.table_coefficients is None:
            return None
        cb = lin.col_basis[i]
        if np.any(cb[:nb] < 0) or not np.array_equal(lin.Fc[:, cb[0]], -lin.Fc[:, lin.col_comp[i]]):
            return None
        tc = np.asarray(mc.table_coefficients, float).reshape(mc.table_stiffness.size, -1)
        if nt is None:
            nt = mc.table_stiffness.size
        if mc.table_stiffness.size != nt or tc.shape[1] != nb or not np.all(tc[:, 0] == 1.0):
            return None
    assert nt is not None
    cols_l: list[int] = []
    ucol: list[int] = []
    for i in range(nm):
        ucol.append(len(cols_l))
        cols_l += [int(lin.col_comp[i]), *(int(c) for c in lin.col_basis[i, 1:nb])]
    cols = np.array([*cols_l, *range(lin.col_eff0, lin.m)], dtype=np.int64)
    nf = mp.basis.n_forced if mp.basis.n_forced >= 0 else mp.basis.lam.size
    pq = mp.pq[:, cols]
    pq_static = 2.0 * mp.pq[:, 0]
    pqn = pq.copy()  # response to the new amplitudes (with a reduced basis: plus the dropped modes')
    rstat = np.zeros(2 * nm)
    n = lin.nfree
    if mp.resid is not None:
        rm = np.vstack([lin.V @ mp.resid[:n], lin.V @ mp.resid[n:]])  # (2 nm, m)
        pqn += rm[:, cols]
        rstat = rm[:, 0].copy()
        pq_static = pq_static + rstat
    hd = pqn[:nm, ucol]
    hv = pqn[nm:, ucol]
    emat = np.eye(nm) - lin.kbar[:, None] * hd - lin.cmesh[:, None] * hv
    einv = np.linalg.inv(emat)
    tab_kf = np.zeros((nm, nt))
    tab_cf = np.zeros((nm, nt, nb))
    tab_k = np.zeros((nm, nt))
    tab_c = np.zeros((nm, nt, nb))
    jflag = np.zeros((nm, nt), dtype=np.int8)
    split = []
    for i, mc in enumerate(meshes):
        tc = np.asarray(mc.table_coefficients, float).reshape(nt, nb)
        tab_kf[i] = mc.table_stiffness
        tab_cf[i] = tc
        split.append(split_table_jumps(np.asarray(mc.table_stiffness, float), tc, mc.table_jumps))
    nj = max(1, max(sp[2].size for sp in split))
    jump_p = np.zeros((nm, nj))
    jump_k = np.zeros((nm, nj))
    jump_c = np.zeros((nm, nj, nb))
    n_jump = np.zeros(nm, dtype=np.int64)
    for i, (kc, cc, jp, jk, jc) in enumerate(split):
        tab_k[i] = kc
        tab_c[i] = cc
        n_jump[i] = jp.size
        jump_p[i, : jp.size] = jp
        jump_k[i, : jp.size] = jk
        jump_c[i, : jp.size] = jc
        jflag[i] = _jump_intervals(nt, jp)
    mesh_par = np.array(
        [[lin.kbar[i], lin.cmesh[i], lin.cmesh[i], lin.bstar[i], mc.te_amplitude, mc.te_phase]
         for i, mc in enumerate(meshes)]
    )  # fmt: skip
    # sub-steps: mesh rows V Phi, h lambda, and the responses pm of the mesh rows to each mesh column
    # and to the static increment (rows q 2 nm + r)
    npad = mp.nmode
    nk = mp.basis.lam.size
    mrows = np.zeros((2 * nm, lin.nstate))
    mrows[:nm, :n] = lin.V
    mrows[nm:, n:] = lin.V
    vrow = np.zeros((2 * nm, npad), dtype=complex)
    vrow[:, :nk] = mrows @ mp.basis.phi
    mu = np.zeros(npad, dtype=complex)
    mu[:nk] = mp.dt * mp.basis.lam
    sw_act = mp.swr[cols] + 1j * mp.swi[cols]
    c0 = 2.0 * (mp.swr[0] + 1j * mp.swi[0])
    nmc = nm * nb
    pm = np.zeros(((nmc + 1) * 2 * nm, npad), dtype=complex)
    for q in range(nmc + 1):
        col = sw_act[q] if q < nmc else c0
        pm[q * 2 * nm : (q + 1) * 2 * nm] = vrow * col[None, :]
    modal = (
        mp.rr,
        mp.ri,
        aligned(c0.real),
        aligned(c0.imag),
        aligned(mp.swr[cols]),
        aligned(mp.swi[cols]),
        mp.crr,
        mp.cri,
        aligned(vrow.real),
        aligned(vrow.imag),
        aligned(mu.real),
        aligned(mu.imag),
        aligned(pm.real),
        aligned(pm.imag),
    )
    mesh = (
        aligned(pq), aligned(pqn), aligned(pq_static), aligned(rstat), aligned(hd @ einv), aligned(hv @ einv),
        mesh_par,
    )  # fmt: skip
    tables = (
        aligned(tab_kf), aligned(tab_cf), jflag, aligned(tab_k), aligned(tab_c),
        jump_p, jump_k, jump_c, n_jump,
    )  # fmt: skip
    cstack, static_add = _output_stack(lin, mp, specs, cols, ucol)
    return GearMap(
        cols, modal, int(nf), mesh, tables, aligned(cstack), aligned(_static_feed(mp, specs) + static_add)
    )
