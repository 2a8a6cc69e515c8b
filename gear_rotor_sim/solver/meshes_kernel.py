"""Compiled kernel of the multi-mesh fast path (numba): any number of meshes, tables in the loop.

:func:`run_chunk_meshes` advances the exact modal Newmark map of :mod:`.kernels` for a system with
one or more meshes whose stiffness, force coefficients and transmission error are looked up from
tables inside the loop (no per-step arrays built in Python), the static load as a constant modal
increment, the force columns applied to the *forced* modes only and the outputs formed by blocks of
matrix products. It is the single-mesh fast path's technique (:mod:`.mesh_kernel`) for ``nm``
meshes; contact changes and table jumps are taken at the step instants (no event location).

The step body is written out in the loop, with calls only on rare paths (a table interval holding a
jump, an active set that does not settle): every array handed to a function inside the loop, inlined
or not, costs a reference-count increment and decrement per step, and with the ~20 arrays of a step
that measured 3-4x the cost of the step itself (0.25 against 1.08 us CPU per step, paper gearbox).

The arrays are passed grouped by role, as tuples:

``modal``   (zr, zi, rr, ri, c0r, c0i, swr, swi, crr, cri): modal state (updated), diagonal map,
            static increment, force-column responses ``SW`` (na, nmode) and mesh prediction rows
            ``(V Phi) r`` (2 nm, nmode: delta rows, then delta' rows).
``mesh``    (pq, pqn, pq_static, pd, pv, mesh_par): responses of delta, delta' (2 nm, na) to the
            carried and to the new column amplitudes (equal for the full basis; with a reduced one
            ``pqn`` adds the dropped modes' static response) and to the static load; ``pd``, ``pv``
            (nm, nm) the elimination of the mean-mesh compensation; ``mesh_par`` (nm, 6) =
            (kbar, cbar, c_m, b*, e0, phi_te).
``tables``  (tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k, jump_c, n_jump): per mesh, the
            full tables (nm, nt) / (nm, nt, nb), the flag of the intervals holding a jump, the
            continuous parts and the jumps (nm, nj) / (nm, nj, nb), ``n_jump`` (nm,) jumps per mesh
            (:func:`newmark.split_table_jumps`).
``exc``     (phase, phase_rate, kfac, te_add, ted_add, ampl): (n + 1, nm) mesh phases and their
            rates (cycles/s), effect stiffness factors, added TE and its rate ((0, nm) if none) and
            effect force amplitudes (n + 1, ne); index 0 the carried step.
``carry``   (beta_prev, ypred, state): column amplitudes, mesh predictions, contact states (updated).
``outs``    (cstack, dfeed_static, hbuf, out, dte, dted, fmesh, states, kt, et, edt, coef).

Active columns: mesh i owns ``i nb .. i nb + nb - 1`` (``u_i`` = compensation ``+V_i`` carrying the
line-of-action part ``-V_i F_i`` too, then the friction basis), effects from ``nm nb``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from gear_rotor_sim.solver.kernels import (
    _FM,
    _MAX_ACTIVE_SET_ITER,
    STATUS_BOUND,
    STATUS_NONFINITE,
    STATUS_OK,
    _natural_state,
    mesh_solve,
)


@njit(cache=True, fastmath=_FM, error_model="numpy")
def _tables_with_jumps(
    i: int,
    f: float,
    tab_k: np.ndarray,
    tab_c: np.ndarray,
    jump_p: np.ndarray,
    jump_k: np.ndarray,
    jump_c: np.ndarray,
    n_jump: np.ndarray,
    coef: np.ndarray,
) -> float:
    """Stiffness (returned) and force coefficients (into ``coef[i]``) of mesh ``i`` at phase ``f`` on
    a table interval that holds a jump: the continuous parts plus the periodic steps of
    :func:`newmark.split_table_jumps` (right-continuous), as :func:`mesh_kernel._tables_at`."""
    nt = tab_k.shape[1]
    nb = tab_c.shape[2]
    x = f * nt
    i0 = int(np.floor(x))
    fr = x - i0
    i0 = i0 % nt
    i1 = i0 + 1
    if i1 == nt:
        i1 = 0
    k = tab_k[i, i0] + fr * (tab_k[i, i1] - tab_k[i, i0])
    for j in range(nb):
        coef[i, j] = tab_c[i, i0, j] + fr * (tab_c[i, i1, j] - tab_c[i, i0, j])
    for q in range(n_jump[i]):
        saw = (1.0 if f >= jump_p[i, q] else 0.0) - f
        k += jump_k[i, q] * saw
        for j in range(nb):
            coef[i, j] += jump_c[i, q, j] * saw
    return k


@njit(cache=True, fastmath=_FM, error_model="numpy", nogil=True)
def run_chunk_meshes(
    modal: tuple,
    n_forced: int,
    mesh: tuple,
    tables: tuple,
    exc: tuple,
    carry: tuple,
    outs: tuple,
    bound: float,
    fuse: bool = True,
) -> tuple[int, int, int]:
    """Advance ``n = phase.shape[0] - 1`` steps of the modal map with ``nm`` table meshes.

    Per step (Eq 39 by the exact modal Newmark map):

    1. excitation: per mesh the stiffness and force coefficients from the tables (Eqs 13-15, 29) at
       the mesh phase, the transmission error of Eq 24 and its rate, the effect inputs;
    2. delta, delta' at the step end as affine functions of the mesh forces, ``a1 + am F`` and
       ``b1 + bm F``: prediction, static load, carried and new effect amplitudes; the unknown new
       amplitudes ``u_l = comp_l - coef_l0 F_l`` and ``coef_lj F_l`` with the compensation
       ``comp = kbar delta + cbar delta'`` eliminated exactly (``pd = H_d E^-1``, ``pv = H_v E^-1``
       with ``E = I - Kbar H_d - Cbar H_v``, ``H`` the responses to the ``u`` columns);
    3. the exact piecewise-linear mesh solve of Eqs 25-26 for all meshes together: the active set of
       :func:`kernels.mesh_solve` from the previous states (that function, with its exhaustive
       search, when it does not settle);
    4. the new amplitudes, then ``z <- r z + c0 + sum_q SW_q alpha_q`` over the forced modes (the
       rest only propagate) and the predictions ``Re((V Phi) r z)`` of the next step: for up to two
       meshes (``fuse``) in one pass with the eight mesh columns and four prediction rows unrolled
       (1-D views made before the loop); otherwise one pass per mesh and per prediction row;
    5. the outputs in blocks of ``hbuf.shape[0]`` steps by one matrix product.

    Returns
    -------
    (status, step, n_failed_mesh_solves)
    """
    zr, zi, rr, ri, c0r, c0i, swr2, swi2, crr2, cri2 = modal
    pq, pqn, pq_static, pd, pv, mesh_par = mesh
    phase, phase_rate, kfac, te_add, ted_add, ampl = exc
    tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k, jump_c, n_jump = tables
    beta_prev, ypred, state = carry
    cstack, dfeed_static, hbuf, out, dte, dted, fmesh, states, kt_out, et_out, edt_out, coef_out = outs
    # flattened row-major views (rows of nmode): 1-D indexing from 0 vectorises, a row slice per
    # step would cost a reference count
    swr = swr2.ravel()
    swi = swi2.ravel()
    crr = crr2.ravel()
    cri = cri2.ravel()
    nsteps = phase.shape[0] - 1
    nm = phase.shape[1]
    nt = tab_kf.shape[1]
    nb = tab_cf.shape[2]
    na = beta_prev.shape[0]
    ne = ampl.shape[1]
    no = cstack.shape[1]
    nmode = zr.shape[0]
    nf = n_forced
    e0 = nm * nb
    has_kfac = kfac.shape[0] > 0
    has_te = te_add.shape[0] > 0
    two_pi = 2.0 * np.pi
    beta_new = np.zeros(na)
    alpha = np.zeros(na)
    coef = np.zeros((nm, nb))
    kk = np.zeros(nm)
    ee = np.zeros(nm)
    ed = np.zeros(nm)
    a1 = np.zeros(nm)
    b1 = np.zeros(nm)
    am = np.zeros((nm, nm))
    bm = np.zeros((nm, nm))
    gd = np.zeros((nm, nm))
    gv = np.zeros((nm, nm))
    wv = np.zeros(nm)
    cm = np.zeros(nm)
    bst = np.zeros(nm)
    for i in range(nm):
        cm[i] = mesh_par[i, 2]
        bst[i] = mesh_par[i, 3]
    prev_state = state.copy()
    new_state = np.zeros(nm, dtype=np.int64)
    trial = np.zeros(nm, dtype=np.int64)
    force = np.zeros(nm)
    work = np.zeros((nm, nm))
    rhs = np.zeros(nm)
    # fused path for up to two meshes: the column rows and prediction rows as 1-D views from 0, made
    # once (rows of a mesh that does not exist, or beyond nb, point at a zero row)
    fused = fuse and nm <= 2 and nb <= 4
    zero = np.zeros(max(nf, 1))
    zfr = zr[:nf]
    zfi = zi[:nf]
    rfr = rr[:nf]
    rfi = ri[:nf]
    c0fr = c0r[:nf]
    c0fi = c0i[:nf]
    gr = np.zeros(nf)  # effect-column increments of a step
    gi = np.zeros(nf)
    qa = np.full(8, -1, dtype=np.int64)  # active column of each fused slot (-1: none)
    for i in range(min(nm, 2)):
        for j in range(min(nb, 4)):
            qa[4 * i + j] = i * nb + j
    s0r = swr2[qa[0], :nf] if qa[0] >= 0 else zero[:nf]
    s0i = swi2[qa[0], :nf] if qa[0] >= 0 else zero[:nf]
    s1r = swr2[qa[1], :nf] if qa[1] >= 0 else zero[:nf]
    s1i = swi2[qa[1], :nf] if qa[1] >= 0 else zero[:nf]
    s2r = swr2[qa[2], :nf] if qa[2] >= 0 else zero[:nf]
    s2i = swi2[qa[2], :nf] if qa[2] >= 0 else zero[:nf]
    s3r = swr2[qa[3], :nf] if qa[3] >= 0 else zero[:nf]
    s3i = swi2[qa[3], :nf] if qa[3] >= 0 else zero[:nf]
    s4r = swr2[qa[4], :nf] if qa[4] >= 0 else zero[:nf]
    s4i = swi2[qa[4], :nf] if qa[4] >= 0 else zero[:nf]
    s5r = swr2[qa[5], :nf] if qa[5] >= 0 else zero[:nf]
    s5i = swi2[qa[5], :nf] if qa[5] >= 0 else zero[:nf]
    s6r = swr2[qa[6], :nf] if qa[6] >= 0 else zero[:nf]
    s6i = swi2[qa[6], :nf] if qa[6] >= 0 else zero[:nf]
    s7r = swr2[qa[7], :nf] if qa[7] >= 0 else zero[:nf]
    s7i = swi2[qa[7], :nf] if qa[7] >= 0 else zero[:nf]
    # prediction rows: delta_1, delta_1', delta_2, delta_2'
    p0r = crr2[0, :nf]
    p0i = cri2[0, :nf]
    p1r = crr2[nm, :nf]
    p1i = cri2[nm, :nf]
    p2r = crr2[1, :nf] if nm > 1 else zero[:nf]
    p2i = cri2[1, :nf] if nm > 1 else zero[:nf]
    p3r = crr2[nm + 1, :nf] if nm > 1 else zero[:nf]
    p3i = cri2[nm + 1, :nf] if nm > 1 else zero[:nf]
    al = np.zeros(8)
    n_fail = 0
    n_buf = hbuf.shape[0]
    hb = 0
    o0 = 0
    for n in range(1, nsteps + 1):
        o = n - 1
        # 1. excitation
        finite = True
        for i in range(nm):
            f = phase[n, i]
            x = f * nt
            i0 = int(np.floor(x))
            fr = x - i0
            i0 = i0 % nt
            i1 = i0 + 1
            if i1 == nt:
                i1 = 0
            if jflag[i, i0] == 0:
                k = tab_kf[i, i0] + fr * (tab_kf[i, i1] - tab_kf[i, i0])
                for j in range(nb):
                    coef[i, j] = tab_cf[i, i0, j] + fr * (tab_cf[i, i1, j] - tab_cf[i, i0, j])
            else:
                k = _tables_with_jumps(i, f, tab_k, tab_c, jump_p, jump_k, jump_c, n_jump, coef)
            if has_kfac:
                k *= kfac[n, i]
            arg = two_pi * f + mesh_par[i, 5]
            e = mesh_par[i, 4] * np.sin(arg)
            edot = mesh_par[i, 4] * np.cos(arg) * two_pi * phase_rate[n, i]
            if has_te:
                e += te_add[n, i]
                edot += ted_add[n, i]
            kk[i] = k
            ee[i] = e
            ed[i] = edot
            if not (np.isfinite(k) and np.isfinite(e) and np.isfinite(edot)):
                finite = False
        if not finite:
            state[:] = prev_state
            return STATUS_NONFINITE, o, n_fail
        for q in range(ne):
            beta_new[e0 + q] = ampl[n, q]
        # 2. delta, delta' affine in the mesh forces
        for i in range(nm):
            sd = ypred[i] + pq_static[i]
            sv = ypred[nm + i] + pq_static[nm + i]
            for q in range(na):
                sd += pq[i, q] * beta_prev[q]
                sv += pq[nm + i, q] * beta_prev[q]
            for q in range(e0, na):
                sd += pqn[i, q] * beta_new[q]
                sv += pqn[nm + i, q] * beta_new[q]
            a1[i] = sd
            b1[i] = sv
            for l in range(nm):
                c = l * nb
                td = -coef[l, 0] * pqn[i, c]
                tv = -coef[l, 0] * pqn[nm + i, c]
                for j in range(1, nb):
                    td += pqn[i, c + j] * coef[l, j]
                    tv += pqn[nm + i, c + j] * coef[l, j]
                gd[i, l] = td
                gv[i, l] = tv
        for l in range(nm):
            wv[l] = mesh_par[l, 0] * a1[l] + mesh_par[l, 1] * b1[l]
        for i in range(nm):
            for l in range(nm):
                a1[i] += pd[i, l] * wv[l]
                b1[i] += pv[i, l] * wv[l]
            for j in range(nm):
                td = gd[i, j]
                tv = gv[i, j]
                for l in range(nm):
                    w = mesh_par[l, 0] * gd[l, j] + mesh_par[l, 1] * gv[l, j]
                    td += pd[i, l] * w
                    tv += pv[i, l] * w
                am[i, j] = td
                bm[i, j] = tv
        # 3. mesh solve: active set from the previous states (as kernels.mesh_solve)
        for i in range(nm):
            trial[i] = prev_state[i]
        settled = False
        for _ in range(_MAX_ACTIVE_SET_ITER):
            for i in range(nm):  # Eq 25 in each trial state (kernels._solve_states)
                s = trial[i]
                for j in range(nm):
                    work[i, j] = 0.0
                if s == 2 or s == -2:
                    sg = 1.0 if s == 2 else -1.0
                    for j in range(nm):
                        work[i, j] = -kk[i] * am[i, j] - cm[i] * bm[i, j]
                    work[i, i] += 1.0
                    rhs[i] = kk[i] * (a1[i] - ee[i] - sg * bst[i]) + cm[i] * (b1[i] - ed[i])
                elif s == 0:
                    work[i, i] = 1.0
                    rhs[i] = 0.0
                else:
                    sg = 1.0 if s == 1 else -1.0
                    for j in range(nm):
                        work[i, j] = am[i, j]
                    rhs[i] = ee[i] + sg * bst[i] - a1[i]
            singular = False
            for c in range(nm):  # Gaussian elimination with partial pivoting
                p = c
                best = abs(work[c, c])
                for r in range(c + 1, nm):
                    if abs(work[r, c]) > best:
                        best = abs(work[r, c])
                        p = r
                if best == 0.0:
                    singular = True
                    break
                if p != c:
                    for j in range(nm):
                        tmp = work[c, j]
                        work[c, j] = work[p, j]
                        work[p, j] = tmp
                    tmp = rhs[c]
                    rhs[c] = rhs[p]
                    rhs[p] = tmp
                for r in range(c + 1, nm):
                    fac = work[r, c] / work[c, c]
                    for j in range(c, nm):
                        work[r, j] -= fac * work[c, j]
                    rhs[r] -= fac * rhs[c]
            if singular:
                break
            for c in range(nm - 1, -1, -1):
                sm = rhs[c]
                for j in range(c + 1, nm):
                    sm -= work[c, j] * force[j]
                force[c] = sm / work[c, c]
            settled = True
            for i in range(nm):  # consistency of each state (kernels._check_states)
                d = a1[i]
                dd = b1[i]
                for j in range(nm):
                    d += am[i, j] * force[j]
                    dd += bm[i, j] * force[j]
                dm = d - ee[i]
                dmd = dd - ed[i]
                tol_d = 1e-12 * (abs(bst[i]) + abs(dm)) + 1e-20
                tol_f = 1e-12 * (abs(force[i]) + abs(cm[i] * dmd)) + 1e-20
                ns = _natural_state(trial[i], dm, dmd, force[i], cm[i], bst[i], tol_d, tol_f)
                new_state[i] = ns
                if ns != trial[i]:
                    settled = False
            if settled:
                break
            for i in range(nm):
                trial[i] = new_state[i]
        if not settled:  # rare: the general solver with its exhaustive search
            its = mesh_solve(
                prev_state, a1, b1, am, bm, kk, cm, ee, ed, bst, new_state, force, work, rhs, trial
            )
            if its < 0:
                n_fail += 1
        # 4. new amplitudes, results, modal update
        for i in range(nm):
            d = a1[i]
            dd = b1[i]
            for j in range(nm):
                d += am[i, j] * force[j]
                dd += bm[i, j] * force[j]
            if not (np.isfinite(d) and np.isfinite(force[i])):
                state[:] = prev_state
                return STATUS_NONFINITE, o, n_fail
            if abs(d) >= bound:
                state[:] = prev_state
                return STATUS_BOUND, o, n_fail
            c = i * nb
            beta_new[c] = mesh_par[i, 0] * d + mesh_par[i, 1] * dd - coef[i, 0] * force[i]
            for j in range(1, nb):
                beta_new[c + j] = coef[i, j] * force[i]
            prev_state[i] = new_state[i]
            dte[o, i] = d
            dted[o, i] = dd
            fmesh[o, i] = force[i]
            states[o, i] = new_state[i]
            kt_out[o, i] = kk[i]
            et_out[o, i] = ee[i]
            edt_out[o, i] = ed[i]
            for j in range(nb):
                coef_out[o, i, j] = coef[i, j]
        for q in range(na):
            alpha[q] = beta_prev[q] + beta_new[q]
            beta_prev[q] = beta_new[q]
        if fused:
            # one pass over the forced modes: update with the (up to) eight mesh columns and the
            # effect increments, and the four predictions of the next step
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
            if not has_g and ne > 0:
                for j in range(nf):
                    gr[j] = 0.0
                    gi[j] = 0.0
            for u in range(8):
                al[u] = alpha[qa[u]] if qa[u] >= 0 else 0.0
            b0, b1_, b2_, b3_, b4_, b5_, b6_, b7_ = al[0], al[1], al[2], al[3], al[4], al[5], al[6], al[7]
            y0 = 0.0
            y1 = 0.0
            y2 = 0.0
            y3 = 0.0
            for j in range(nf):
                xr = zfr[j]
                xi = zfi[j]
                tr = (
                    rfr[j] * xr - rfi[j] * xi + c0fr[j] + s0r[j] * b0 + s1r[j] * b1_ + s2r[j] * b2_
                    + s3r[j] * b3_ + s4r[j] * b4_ + s5r[j] * b5_ + s6r[j] * b6_ + s7r[j] * b7_
                )  # fmt: skip
                ti = (
                    rfr[j] * xi + rfi[j] * xr + c0fi[j] + s0i[j] * b0 + s1i[j] * b1_ + s2i[j] * b2_
                    + s3i[j] * b3_ + s4i[j] * b4_ + s5i[j] * b5_ + s6i[j] * b6_ + s7i[j] * b7_
                )  # fmt: skip
                if ne > 0:
                    tr += gr[j]
                    ti += gi[j]
                zfr[j] = tr
                zfi[j] = ti
                y0 += p0r[j] * tr - p0i[j] * ti
                y1 += p1r[j] * tr - p1i[j] * ti
                y2 += p2r[j] * tr - p2i[j] * ti
                y3 += p3r[j] * tr - p3i[j] * ti
            for j in range(nf, nmode):  # unforced modes only propagate
                xr = zr[j]
                xi = zi[j]
                zr[j] = rr[j] * xr - ri[j] * xi + c0r[j]
                zi[j] = rr[j] * xi + ri[j] * xr + c0i[j]
            ypred[0] = y0
            ypred[nm] = y1
            if nm > 1:
                ypred[1] = y2
                ypred[nm + 1] = y3
        for i in range(nm if not fused else 0):
            c = i * nb
            a0 = alpha[c]
            a1_ = alpha[c + 1] if nb > 1 else 0.0
            a2_ = alpha[c + 2] if nb > 2 else 0.0
            a3_ = alpha[c + 3] if nb > 3 else 0.0
            q0 = c * nmode
            q1 = (c + 1 if nb > 1 else c) * nmode
            q2 = (c + 2 if nb > 2 else c) * nmode
            q3 = (c + 3 if nb > 3 else c) * nmode
            if i == 0:
                for j in range(nf):
                    xr = zr[j]
                    xi = zi[j]
                    zr[j] = (
                        rr[j] * xr - ri[j] * xi + c0r[j] + swr[q0 + j] * a0 + swr[q1 + j] * a1_
                        + swr[q2 + j] * a2_ + swr[q3 + j] * a3_
                    )  # fmt: skip
                    zi[j] = (
                        rr[j] * xi + ri[j] * xr + c0i[j] + swi[q0 + j] * a0 + swi[q1 + j] * a1_
                        + swi[q2 + j] * a2_ + swi[q3 + j] * a3_
                    )  # fmt: skip
            else:
                for j in range(nf):
                    zr[j] += swr[q0 + j] * a0 + swr[q1 + j] * a1_ + swr[q2 + j] * a2_ + swr[q3 + j] * a3_
                    zi[j] += swi[q0 + j] * a0 + swi[q1 + j] * a1_ + swi[q2 + j] * a2_ + swi[q3 + j] * a3_
        if not fused:
            for q in range(e0, na):  # effect columns
                aq = alpha[q]
                if aq != 0.0:
                    q0 = q * nmode
                    for j in range(nf):
                        zr[j] += swr[q0 + j] * aq
                        zi[j] += swi[q0 + j] * aq
            for j in range(nf, nmode):  # unforced modes only propagate
                xr = zr[j]
                xi = zi[j]
                zr[j] = rr[j] * xr - ri[j] * xi + c0r[j]
                zi[j] = rr[j] * xi + ri[j] * xr + c0i[j]
        for r in range(2 * nm if not fused else 0):
            q0 = r * nmode
            sm = 0.0
            for j in range(nf):
                sm += crr[q0 + j] * zr[j] - cri[q0 + j] * zi[j]
            ypred[r] = sm
        if not np.isfinite(ypred[0]):
            state[:] = prev_state
            return STATUS_NONFINITE, o, n_fail
        # 5. outputs
        if no > 0:
            for j in range(nmode):
                hbuf[hb, j] = zr[j]
                hbuf[hb, nmode + j] = zi[j]
            for q in range(na):
                hbuf[hb, 2 * nmode + q] = beta_prev[q]
            hb += 1
            if hb == n_buf or n == nsteps:
                blk = out[o0 : o0 + hb]
                np.dot(hbuf[:hb], cstack, blk)
                for r in range(hb):
                    for c in range(no):
                        blk[r, c] += dfeed_static[c]
                o0 += hb
                hb = 0
    state[:] = prev_state
    return STATUS_OK, nsteps, n_fail
