"""The regular step of the gear kernel's loop (numba), in parts inlined into :func:`.gear_loop._run_loop`.

Part of the gear kernel (:mod:`.gear_kernel`; docs/solver.md, "Module layout"): the numbered parts
of :func:`.gear_kernel.run_chunk_gear`'s docstring: 1. the table jumps inside a step, 2. the
excitation at the step end, 3.-4. delta, delta' affine in the mesh forces and the mesh solve (and a
contact change located from it), 5. the new mesh columns. Each is ``inline="always"`` and takes the
loop's role tuples (``exc``, ``tables``, ``mesh``, ``carry``, ``meshw``, ``ev``, ``upd``; see
:func:`.gear_loop._run_loop`), unpacking only what it reads: inlined into the loop compiled without
the numba runtime, they cost no call and no reference counting.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from gear_rotor_sim.solver.gear_events import _EVENT_SNAP, _MAX_PIECES, _locate_crossing
from gear_rotor_sim.solver.gear_mesh_solve import (
    _affine_forces,
    _mesh_solve_one,
    _mesh_solve_two,
    _set_columns,
    _solve_meshes,
    _state_force,
)
from gear_rotor_sim.solver.gear_tables import _table_cell, _tables_at
from gear_rotor_sim.solver.kernels import _FM, STATUS_BOUND, STATUS_NONFINITE, STATUS_OK


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _step_jumps(
    n: int, exc: tuple, tables: tuple, mesh_par: np.ndarray, carry: tuple, meshw: tuple, ev: tuple
) -> tuple[int, bool]:
    """1. The table jumps of every mesh inside step ``n - 1 -> n`` (from its phases), sorted into the
    event step's boundaries (``ev``: fractions ``bnd[1..nev]``, jump phases ``bfe``, meshes ``bmesh``);
    per mesh the start phase ``pha``, the phase advance ``dph`` and a jump at the step end ``endfe``.
    A jump at the step start (to round-off, ``_EVENT_SNAP``) is taken there: the mesh starts from its
    right limit. Returns (jumps inside the step, a jump at its end)."""
    phase, kfac = exc[0], exc[2]
    jump_p, n_jump = tables[5], tables[8]
    beta_prev = carry[0]
    prev, cur, solve = meshw[0], meshw[1], meshw[3]
    d_p, dd_p, e_p, ed_p, f_p, s_p = prev
    coef = cur[3]
    cm, bst = solve[1], solve[2]
    bnd, bfe, bmesh, endfe, dph, pha = ev[0], ev[1], ev[2], ev[6], ev[7], ev[8]
    nm = phase.shape[1]
    has_kfac = kfac.shape[0] > 0
    nev = 0
    has_end = False
    for i in range(nm):
        endfe[i] = -1.0
        ph_a = phase[n - 1, i]
        dp = phase[n, i] - ph_a
        if dp < 0.0:
            dp += 1.0
        pha[i] = ph_a
        dph[i] = dp
        for q in range(n_jump[i]):
            x = jump_p[i, q] - ph_a
            if x <= 0.0:
                x += 1.0
            if x < dp and nev < _MAX_PIECES - 2 - nm:
                th = x / dp
                if th <= _EVENT_SNAP:
                    # the jump is at the step start (to round-off): start from its right limit
                    k0 = _tables_at(i, jump_p[i, q], False, tables, coef)
                    if has_kfac:
                        k0 *= kfac[n - 1, i]
                    f_p[i] = _state_force(
                        s_p[i], d_p[i] - e_p[i], dd_p[i] - ed_p[i], k0, cm[i], bst[i], f_p[i]
                    )
                    _set_columns(i, beta_prev, coef, f_p[i], d_p[i], dd_p[i], mesh_par)
                    continue
                if th >= 1.0 - _EVENT_SNAP:
                    endfe[i] = jump_p[i, q]  # at the step end: left limit there, then the right limit
                    has_end = True
                    continue
                pos = nev + 1  # insertion sort into bnd[1..nev]
                while pos > 1 and bnd[pos - 1] > th:
                    bnd[pos] = bnd[pos - 1]
                    bfe[pos] = bfe[pos - 1]
                    bmesh[pos] = bmesh[pos - 1]
                    pos -= 1
                bnd[pos] = th
                bfe[pos] = jump_p[i, q]
                bmesh[pos] = i
                nev += 1
    return nev, has_end


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _end_excitation(
    n: int, exc: tuple, tables: tuple, mesh_par: np.ndarray, te_sc: np.ndarray, cur: tuple
) -> bool:
    """2. Per mesh at the step end: stiffness and force coefficients from the tables (Eqs 13-15, 29)
    at its phase (the full tables' interval, or :func:`_tables_at` on an interval holding a jump),
    the effects' stiffness factor, the transmission error of Eq 24 and its rate (``te_sc`` from
    :func:`_te_sin_cos`) plus the effects' TE, into ``cur``'s ``kk``, ``ee``, ``ed``, ``coef``.
    Returns False if any is not finite."""
    phase, phase_rate, kfac, te_add, ted_add = exc[0], exc[1], exc[2], exc[3], exc[4]
    tab_kf, tab_cf, jflag = tables[0], tables[1], tables[2]
    kk, ee, ed, coef = cur[0], cur[1], cur[2], cur[3]
    nm = phase.shape[1]
    nt = tab_kf.shape[1]
    nb = tab_cf.shape[2]
    has_kfac = kfac.shape[0] > 0
    has_te = te_add.shape[0] > 0
    two_pi = 2.0 * np.pi
    finite = True
    for i in range(nm):
        f = phase[n, i]
        i0, i1, fr = _table_cell(f, nt)
        if jflag[i, i0] == 0:
            k = tab_kf[i, i0] + fr * (tab_kf[i, i1] - tab_kf[i, i0])
            for j in range(nb):
                coef[i, j] = tab_cf[i, i0, j] + fr * (tab_cf[i, i1, j] - tab_cf[i, i0, j])
        else:
            k = _tables_at(i, f, False, tables, coef)
        if has_kfac:
            k *= kfac[n, i]
        e = mesh_par[i, 4] * te_sc[n, i]  # sin, cos of Eq 24's argument (_te_sin_cos)
        edot = mesh_par[i, 4] * te_sc[n, nm + i] * two_pi * phase_rate[n, i]
        if has_te:
            e += te_add[n, i]
            edot += ted_add[n, i]
        kk[i] = k
        ee[i] = e
        ed[i] = edot
        if not (np.isfinite(k) and np.isfinite(e) and np.isfinite(edot)):
            finite = False
    return finite


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _full_step_solve(mesh: tuple, carry: tuple, meshw: tuple, upd: tuple) -> int:
    """3.-4. delta, delta' at the step end affine in the mesh forces (``meshw``'s ``mats``: one mesh by
    scalars, several by :func:`_affine_forces`), then the exact mesh solve of Eqs 25-26 (scalar active
    set for one and two meshes, :func:`_solve_meshes` as fallback and for more): the new contact
    states and forces into ``new_state``, ``force``. Returns 1 if the fallback failed, else 0."""
    pq, pqn, pq_static, _rstat, pd, pv, mesh_par = mesh
    beta_prev, ypred = carry[0], carry[1]
    prev, cur, mats, solve = meshw
    s_p = prev[5]
    kk, ee, ed, coef, _beta_prev, beta_new, _alpha, force = cur
    a1, b1, am, bm = mats[0], mats[1], mats[2], mats[3]
    new_state, cm, bst, swork, srhs, trial = solve
    qb_full, resp_full = upd[6], upd[7]
    nm = s_p.shape[0]
    nb = coef.shape[1]
    na = beta_prev.shape[0]
    e0 = nm * nb
    fail = 0
    if nm == 1:  # scalars (the paper gearbox)
        sd = ypred[0] + pq_static[0]
        sv = ypred[1] + pq_static[1]
        for q in range(na):
            sd += pq[0, q] * beta_prev[q]
            sv += pq[1, q] * beta_prev[q]
        for q in range(e0, na):
            sd += pqn[0, q] * beta_new[q]
            sv += pqn[1, q] * beta_new[q]
        td = -coef[0, 0] * pqn[0, 0]
        tv = -coef[0, 0] * pqn[1, 0]
        for j in range(1, nb):
            td += pqn[0, j] * coef[0, j]
            tv += pqn[1, j] * coef[0, j]
        kb = mesh_par[0, 0]
        cb = mesh_par[0, 1]
        wc = kb * sd + cb * sv
        wg = kb * td + cb * tv
        a10 = sd + pd[0, 0] * wc
        b10 = sv + pv[0, 0] * wc
        am0 = td + pd[0, 0] * wg
        bm0 = tv + pv[0, 0] * wg
        a1[0] = a10
        b1[0] = b10
        am[0, 0] = am0
        bm[0, 0] = bm0
        ns1, f1 = _mesh_solve_one(s_p[0], a10 - ee[0], b10 - ed[0], am0, bm0, kk[0], cm[0], bst[0])
        if ns1 == -9:  # rare: the general solver with its exhaustive search
            fail = _solve_meshes(
                s_p, -1, a1, b1, am, bm, kk, ee, ed, cm, bst, force, new_state, swork, srhs, trial
            )
        else:
            new_state[0] = ns1
            force[0] = f1
    else:
        for r in range(2 * nm):
            qb_full[r] = ypred[r] + pq_static[r]
        _affine_forces(qb_full, resp_full, beta_prev, beta_new, e0, coef, mesh_par, mats)
        ns0 = ns1 = -9
        if nm == 2:  # scalars (two-stage trains)
            ns0, ns1, f0, f1 = _mesh_solve_two(
                s_p[0], s_p[1], a1[0], a1[1], b1[0], b1[1], am[0, 0], am[0, 1], am[1, 0], am[1, 1],
                bm[0, 0], bm[0, 1], bm[1, 0], bm[1, 1], kk[0], kk[1], ee[0], ee[1], ed[0], ed[1],
                cm[0], cm[1], bst[0], bst[1],
            )  # fmt: skip
        if ns0 != -9:
            new_state[0] = ns0
            new_state[1] = ns1
            force[0] = f0
            force[1] = f1
        else:
            fail = _solve_meshes(
                s_p, -1, a1, b1, am, bm, kk, ee, ed, cm, bst, force, new_state, swork, srhs, trial
            )
    return fail


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _full_step_crossing(meshw: tuple, dt: float) -> tuple[float, int, int]:
    """A contact change inside the full step: its fraction of the step, located by Hermite
    interpolation of delta_m (:func:`_locate_crossing`) from the full-step solution, the earliest
    over the meshes; returns (fraction or -1, the state after it, the mesh or -1)."""
    prev, cur, mats, solve = meshw
    d_p, dd_p, e_p, ed_p, _f_p, s_p = prev
    ee, ed, force = cur[1], cur[2], cur[7]
    a1, b1, am, bm = mats[0], mats[1], mats[2], mats[3]
    new_state, bst = solve[0], solve[2]
    nm = s_p.shape[0]
    tc0 = -1.0
    dest0 = 0
    mesh0 = -1
    for i in range(nm):
        if new_state[i] != s_p[i]:
            d = a1[i]
            dd = b1[i]
            for j in range(nm):
                d += am[i, j] * force[j]
                dd += bm[i, j] * force[j]
            t = _locate_crossing(d_p[i] - e_p[i], dd_p[i] - ed_p[i], d - ee[i], dd - ed[i], bst[i], dt)
            if t > 0.0 and (tc0 < 0.0 or t < tc0):
                tc0 = t
                dest0 = new_state[i]
                mesh0 = i
    return tc0, dest0, mesh0


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _commit_meshes(mesh_par: np.ndarray, carry: tuple, meshw: tuple, bound: float) -> int:
    """5. The solved step's meshes committed: delta, delta', the new column amplitudes
    ``u = kbar delta + cbar delta' - coef_0 F`` and ``coef_j F``, the per-mesh state, and the
    columns' two-point sums ``alpha = beta_prev + beta_new`` for the modal update. Returns
    ``STATUS_NONFINITE`` / ``STATUS_BOUND`` (nothing committed past that mesh) or ``STATUS_OK``."""
    beta_prev = carry[0]
    prev, cur, mats, solve = meshw
    d_p, dd_p, e_p, ed_p, f_p, s_p = prev
    ee, ed, coef, beta_new, alpha, force = cur[1], cur[2], cur[3], cur[5], cur[6], cur[7]
    a1, b1, am, bm = mats[0], mats[1], mats[2], mats[3]
    new_state = solve[0]
    nm = s_p.shape[0]
    nb = coef.shape[1]
    na = beta_prev.shape[0]
    for i in range(nm):
        d = a1[i]
        dd = b1[i]
        for j in range(nm):
            d += am[i, j] * force[j]
            dd += bm[i, j] * force[j]
        fi = force[i]
        if not (np.isfinite(d) and np.isfinite(fi)):
            return STATUS_NONFINITE
        if abs(d) >= bound:
            return STATUS_BOUND
        c = i * nb
        beta_new[c] = mesh_par[i, 0] * d + mesh_par[i, 1] * dd - coef[i, 0] * fi
        for j in range(1, nb):
            beta_new[c + j] = coef[i, j] * fi
        s_p[i] = new_state[i]
        d_p[i] = d
        dd_p[i] = dd
        e_p[i] = ee[i]
        ed_p[i] = ed[i]
        f_p[i] = fi
    for q in range(na):
        alpha[q] = beta_prev[q] + beta_new[q]
        beta_prev[q] = beta_new[q]
    return STATUS_OK


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _update_fused(
    nf: int, nu: int, e0: int, alpha: np.ndarray, qa: np.ndarray, ypred: np.ndarray, fz: tuple
) -> None:
    """The regular step's modal update ``z <- r z + c0 + sum_q SW_q alpha_q`` and the next step's
    mesh predictions ``Re((V Phi) r z)`` in one pass over the forced modes (the unforced modes
    ``nf .. nu - 1`` only propagate; those from ``nu`` are exactly zero and stay so, see
    :func:`.gear_loop._run_loop`),
    the mesh columns unrolled (4 slots a mesh, 2 meshes at most: ``qa`` the column of each slot or
    -1), the effect columns summed first into ``gr``, ``gi``. ``fz`` = (modes, forced, slots, rows,
    g, flat): the modal state and map (zr, zi, rr, ri, c0r, c0i), their forced-mode views, the slots'
    response rows (s0r, s0i, ..., s7r, s7i), the prediction rows (delta_1, delta_1', delta_2,
    delta_2': p0r, p0i, ..., p3i), the increments (gr, gi) and the flat responses (swr, swi)."""
    modes, forced, slots, rows, g, flat = fz
    zr, zi, rr, ri, c0r, c0i = modes
    zfr, zfi, rfr, rfi, c0fr, c0fi = forced
    s0r, s0i, s1r, s1i, s2r, s2i, s3r, s3i, s4r, s4i, s5r, s5i, s6r, s6i, s7r, s7i = slots
    p0r, p0i, p1r, p1i, p2r, p2i, p3r, p3i = rows
    gr, gi = g
    swr, swi = flat
    nm = ypred.shape[0] // 2
    na = alpha.shape[0]
    nmode = zr.shape[0]
    has_g = False
    for q in range(e0, na):
        aq = alpha[q]
        if aq != 0.0:
            q0 = q * nmode
            if not has_g:
                for j in range(nf):
                    gr[j] = swr[q0 + j] * aq
                    gi[j] = swi[q0 + j] * aq
                has_g = True
            else:
                for j in range(nf):
                    gr[j] += swr[q0 + j] * aq
                    gi[j] += swi[q0 + j] * aq
    b0 = alpha[0]
    b1_ = alpha[qa[1]] if qa[1] >= 0 else 0.0
    b2_ = alpha[qa[2]] if qa[2] >= 0 else 0.0
    b3_ = alpha[qa[3]] if qa[3] >= 0 else 0.0
    b4_ = b5_ = b6_ = b7_ = 0.0
    if nm > 1:
        b4_ = alpha[qa[4]]
        b5_ = alpha[qa[5]] if qa[5] >= 0 else 0.0
        b6_ = alpha[qa[6]] if qa[6] >= 0 else 0.0
        b7_ = alpha[qa[7]] if qa[7] >= 0 else 0.0
    y0 = 0.0
    y1 = 0.0
    y2 = 0.0
    y3 = 0.0
    if nm == 1 and not has_g:
        for j in range(nf):
            xr = zfr[j]
            xi = zfi[j]
            tr = (
                rfr[j] * xr - rfi[j] * xi + c0fr[j] + s0r[j] * b0 + s1r[j] * b1_ + s2r[j] * b2_ + s3r[j] * b3_
            )
            ti = (
                rfr[j] * xi + rfi[j] * xr + c0fi[j] + s0i[j] * b0 + s1i[j] * b1_ + s2i[j] * b2_ + s3i[j] * b3_
            )
            zfr[j] = tr
            zfi[j] = ti
            y0 += p0r[j] * tr - p0i[j] * ti
            y1 += p1r[j] * tr - p1i[j] * ti
    elif nm == 1:
        for j in range(nf):
            xr = zfr[j]
            xi = zfi[j]
            tr = (
                rfr[j] * xr - rfi[j] * xi + c0fr[j] + s0r[j] * b0 + s1r[j] * b1_ + s2r[j] * b2_
                + s3r[j] * b3_ + gr[j]
            )  # fmt: skip
            ti = (
                rfr[j] * xi + rfi[j] * xr + c0fi[j] + s0i[j] * b0 + s1i[j] * b1_ + s2i[j] * b2_
                + s3i[j] * b3_ + gi[j]
            )  # fmt: skip
            zfr[j] = tr
            zfi[j] = ti
            y0 += p0r[j] * tr - p0i[j] * ti
            y1 += p1r[j] * tr - p1i[j] * ti
    else:
        if not has_g:
            for j in range(nf):
                gr[j] = 0.0
                gi[j] = 0.0
        for j in range(nf):
            xr = zfr[j]
            xi = zfi[j]
            tr = (
                rfr[j] * xr - rfi[j] * xi + c0fr[j] + s0r[j] * b0 + s1r[j] * b1_ + s2r[j] * b2_
                + s3r[j] * b3_ + s4r[j] * b4_ + s5r[j] * b5_ + s6r[j] * b6_ + s7r[j] * b7_ + gr[j]
            )  # fmt: skip
            ti = (
                rfr[j] * xi + rfi[j] * xr + c0fi[j] + s0i[j] * b0 + s1i[j] * b1_ + s2i[j] * b2_
                + s3i[j] * b3_ + s4i[j] * b4_ + s5i[j] * b5_ + s6i[j] * b6_ + s7i[j] * b7_ + gi[j]
            )  # fmt: skip
            zfr[j] = tr
            zfi[j] = ti
            y0 += p0r[j] * tr - p0i[j] * ti
            y1 += p1r[j] * tr - p1i[j] * ti
            y2 += p2r[j] * tr - p2i[j] * ti
            y3 += p3r[j] * tr - p3i[j] * ti
    for j in range(nf, nu):  # unforced modes only propagate
        xr = zr[j]
        xi = zi[j]
        zr[j] = rr[j] * xr - ri[j] * xi + c0r[j]
        zi[j] = rr[j] * xi + ri[j] * xr + c0i[j]
    ypred[0] = y0
    ypred[nm] = y1
    if nm > 1:
        ypred[1] = y2
        ypred[nm + 1] = y3


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _update_plain(nf: int, nu: int, alpha: np.ndarray, ypred: np.ndarray, fz: tuple, flat: tuple) -> None:
    """The modal update without the fused pass (more than two meshes or four columns a mesh): the
    forced modes' map, then each column with a non-zero amplitude, the unforced modes up to ``nu``
    (as :func:`_update_fused`), then the predictions. ``fz`` as :func:`_update_fused`'s, ``flat`` =
    (swr, swi, crr, cri)."""
    zr, zi, rr, ri, c0r, c0i = fz[0]
    swr, swi, crr, cri = flat
    nm = ypred.shape[0] // 2
    na = alpha.shape[0]
    nmode = zr.shape[0]
    for j in range(nf):
        xr = zr[j]
        xi = zi[j]
        zr[j] = rr[j] * xr - ri[j] * xi + c0r[j]
        zi[j] = rr[j] * xi + ri[j] * xr + c0i[j]
    for q in range(na):
        aq = alpha[q]
        if aq != 0.0:
            q0 = q * nmode
            for j in range(nf):
                zr[j] += swr[q0 + j] * aq
                zi[j] += swi[q0 + j] * aq
    for j in range(nf, nu):
        xr = zr[j]
        xi = zi[j]
        zr[j] = rr[j] * xr - ri[j] * xi + c0r[j]
        zi[j] = rr[j] * xi + ri[j] * xr + c0i[j]
    for r in range(2 * nm):
        q0 = r * nmode
        sm = 0.0
        for j in range(nf):
            sm += crr[q0 + j] * zr[j] - cri[q0 + j] * zi[j]
        ypred[r] = sm
