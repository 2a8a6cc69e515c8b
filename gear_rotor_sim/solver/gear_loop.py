"""The step loop of the gear kernel (numba), compiled without the numba runtime.

Part of the gear kernel (:mod:`.gear_kernel`; docs/solver.md, "Module layout"): the chunk driver
:func:`.gear_kernel.run_chunk_gear` allocates the work arrays and calls :func:`_run_loop`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from gear_rotor_sim.solver.gear_events import _EVENT_SNAP, _MAX_PIECES, _event_step, _locate_crossing
from gear_rotor_sim.solver.gear_jumps import _jump_average_end, _jump_average_start
from gear_rotor_sim.solver.gear_mesh_solve import (
    _affine_forces,
    _mesh_solve_one,
    _mesh_solve_two,
    _set_columns,
    _solve_meshes,
    _state_force,
)
from gear_rotor_sim.solver.gear_output import _copy_int, _emit_block
from gear_rotor_sim.solver.gear_tables import _tables_at
from gear_rotor_sim.solver.kernels import _FM, STATUS_BOUND, STATUS_NONFINITE, STATUS_OK


@njit(cache=True, fastmath=_FM, error_model="numpy", nogil=True, _nrt=False)
def _run_loop(
    modal: tuple,
    nf: int,
    mesh: tuple,
    tables: tuple,
    exc: tuple,
    carry: tuple,
    outs: tuple,
    meshw: tuple,
    evw: tuple,
    upd: tuple,
    dt: float,
    locate: bool,
    bound: float,
    fused: bool,
    expo: bool,
    mu_max: float,
    avg_jumps: bool,
) -> tuple[int, int, int, int]:
    """The step loop of :func:`run_chunk_gear`, compiled without the numba runtime.

    Everything it needs is allocated by :func:`run_chunk_gear` and handed over grouped by role:
    ``modal``, ``mesh``, ``tables``, ``exc``, ``carry``, ``outs`` as there; ``meshw`` = (prev, cur,
    mats, solve): the per-mesh state at the step start (d, dd, e, ed, f, s), the step end's values
    (kk, ee, ed, coef, beta_prev, beta_new, alpha, force), the affine form of delta, delta' in the
    forces (a1, b1, am, bm and work) and the mesh solve's arrays (new_state, cm, bst, work, rhs,
    trial); ``evw`` = (ev, avg, work, ja): the event steps' (:func:`_event_step`) boundaries and
    phases, ``event_average``'s sums, the sub-steps' work, ``average_jumps``' arrays
    (:func:`_jump_average_start`); ``upd`` = (zero, gr, gi, qa, flat, te_sc, qb_full, resp_full): the
    regular step's fused update (column slots, flat rows), the TE's sin/cos (:func:`_te_sin_cos`) and
    the full step's affine form (several meshes). This function allocates nothing (the output block
    product is the call :func:`_emit_block`). Without the runtime, binding an array (tuple unpacking,
    views, the inlined :func:`_event_step`'s ~80 arrays) costs no atomic reference-count increment and
    decrement: with it, the event steps spent about half their time in them at 20000 rpm
    (docs/solver.md, "Session 8").
    """
    zr, zi, rr, ri, c0r, c0i, swr2, swi2, crr2, cri2, _vrr, _vri, _mur, _mui, _pmr, _pmi = modal
    pq, pqn, pq_static, _rstat, pd, pv, mesh_par = mesh
    phase, phase_rate, kfac, te_add, ted_add, ampl = exc
    tab_kf, tab_cf, jflag, _tab_k, _tab_c, jump_p, _jump_k, _jump_c, n_jump = tables
    beta_prev, ypred, state, mcarry = carry
    cstack, dfeed_static, hbuf, out, dte, dted, fmesh, states, kt_out, et_out, edt_out, coef_out = outs[:12]
    dte_ch, fm_ch = outs[12], outs[13]  # the mesh channels (event_average; else not written)
    prev, cur, mats, solve = meshw
    ev, avg, work, ja = evw
    kk, ee, ed, coef, _beta_prev, beta_new, alpha, force = cur
    a1, b1, am, bm = mats[0], mats[1], mats[2], mats[3]
    new_state, cm, bst, swork, srhs, trial = solve
    zero, gr, gi, qa, flat, te_sc, qb_full, resp_full = upd
    swr, swi, crr, cri = flat
    bnd, bfe, bmesh, endfe, dph, pha = ev[0], ev[1], ev[2], ev[6], ev[7], ev[8]
    azr, azi, abeta, adf, avg_mode, zsr, zsi, bs, dfs = avg  # event_average
    d_p, dd_p, e_p, ed_p, f_p, s_p = prev
    jc, jk, jm = ja
    nsteps = phase.shape[0] - 1
    nm = phase.shape[1]
    nt = tab_kf.shape[1]
    nb = tab_cf.shape[2]
    na = beta_prev.shape[0]
    ne = ampl.shape[1]
    no = cstack.shape[1]
    nmode = zr.shape[0]
    e0 = nm * nb
    has_kfac = kfac.shape[0] > 0
    has_te = te_add.shape[0] > 0
    two_pi = 2.0 * np.pi
    zfr = zr[:nf]
    zfi = zi[:nf]
    rfr = rr[:nf]
    rfi = ri[:nf]
    c0fr = c0r[:nf]
    c0fi = c0i[:nf]
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

    n_fail = 0
    n_sub = 0
    n_buf = hbuf.shape[0]
    hb = 0
    o0 = 0
    amode = avg_mode[0]
    for n in range(1, nsteps + 1):
        o = n - 1
        ev_step = False
        # 1. events inside the step (table jumps of every mesh)
        nev = 0
        has_end = False
        if locate:
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
        regular = nev == 0 and not has_end
        javg = False
        if avg_jumps and nev > 0 and not has_end:
            # only table jumps, at most one per mesh: a regular step with the tables' step average
            javg = True
            for i in range(nm):
                jm[i] = 0
            for q in range(1, nev + 1):
                i = bmesh[q]
                if jm[i] != 0:
                    javg = False
                jm[i] = 1
                jk[2, i] = bnd[q]
                jk[3, i] = bfe[q]
            regular = javg
        tc0 = -1.0
        dest0 = 0
        mesh0 = -1
        if regular:
            # 2. excitation at the step end
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
            if not finite:
                _copy_int(s_p, state)
                return STATUS_NONFINITE, o, n_fail, n_sub
            if javg:
                _jump_average_start(n, pha, exc, tables, mesh_par, prev, cur, ja)
            for q in range(ne):
                beta_new[e0 + q] = ampl[n, q]
            # 3. delta, delta' affine in the mesh forces; 4. the mesh solve
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
            if locate:
                # a contact change inside the step: locate it from this full-step solution, then redo
                # the step as two sub-steps split there (none if no crossing is found)
                for i in range(nm):
                    if new_state[i] != s_p[i]:
                        d = a1[i]
                        dd = b1[i]
                        for j in range(nm):
                            d += am[i, j] * force[j]
                            dd += bm[i, j] * force[j]
                        t = _locate_crossing(
                            d_p[i] - e_p[i], dd_p[i] - ed_p[i], d - ee[i], dd - ed[i], bst[i], dt
                        )
                        if t > 0.0 and (tc0 < 0.0 or t < tc0):
                            tc0 = t
                            dest0 = new_state[i]
                            mesh0 = i
                if tc0 > 0.0:
                    regular = False
                    for i in range(nm):
                        pha[i] = phase[n - 1, i]
                    if javg:  # back to the sub-steps at the jumps, which locate the contact change
                        for i in range(nm):
                            if jm[i] != 0:
                                for j in range(nb):
                                    beta_prev[i * nb + j] = jc[2, i, j]
                        tc0 = -1.0
                        javg = False
            if regular:
                n_fail += fail
        if regular:
            # 5. new amplitudes, results, modal update
            for i in range(nm):
                d = a1[i]
                dd = b1[i]
                for j in range(nm):
                    d += am[i, j] * force[j]
                    dd += bm[i, j] * force[j]
                fi = force[i]
                if not (np.isfinite(d) and np.isfinite(fi)):
                    _copy_int(s_p, state)
                    return STATUS_NONFINITE, o, n_fail, n_sub
                if abs(d) >= bound:
                    _copy_int(s_p, state)
                    return STATUS_BOUND, o, n_fail, n_sub
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
            if fused:
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
                            rfr[j] * xr
                            - rfi[j] * xi
                            + c0fr[j]
                            + s0r[j] * b0
                            + s1r[j] * b1_
                            + s2r[j] * b2_
                            + s3r[j] * b3_
                        )
                        ti = (
                            rfr[j] * xi
                            + rfi[j] * xr
                            + c0fi[j]
                            + s0i[j] * b0
                            + s1i[j] * b1_
                            + s2i[j] * b2_
                            + s3i[j] * b3_
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
            else:
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
                for j in range(nf, nmode):
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
            if javg:  # the end force with the end's own tables, carried into the next step
                _jump_average_end(mesh_par, prev, cur, ja)
        else:
            # a step holding an event: Newmark sub-steps split there
            ev_step = True
            if amode > 0:
                for i in range(nm):
                    dfs[0, i] = d_p[i]
                    dfs[1, i] = f_p[i]
                if amode == 2:
                    for j in range(nmode):
                        zsr[j] = zr[j]
                        zsi[j] = zi[j]
                    for q in range(na):
                        bs[q] = beta_prev[q]
            status, nfl, nsb = _event_step(
                n, nev + 1, tc0, dest0, mesh0, nf, ev, avg, modal, mesh, tables, exc, prev, cur, work, dt,
                bound, expo, mu_max,
            )  # fmt: skip
            n_fail += nfl
            n_sub += nsb
            if status != STATUS_OK:
                _copy_int(s_p, state)
                return status, o, n_fail, n_sub
            for r in range(2 * nm):  # prediction of the next full step from the new state
                q0 = r * nmode
                sm = 0.0
                for j in range(nf):
                    sm += crr[q0 + j] * zr[j] - cri[q0 + j] * zi[j]
                ypred[r] = sm
        if not np.isfinite(ypred[0]):
            _copy_int(s_p, state)
            return STATUS_NONFINITE, o, n_fail, n_sub
        # 6. outputs
        for i in range(nm):
            dte[o, i] = d_p[i]
            dted[o, i] = dd_p[i]
            fmesh[o, i] = f_p[i]
            states[o, i] = s_p[i]
            kt_out[o, i] = kk[i]
            et_out[o, i] = ee[i]
            edt_out[o, i] = ed[i]
            for j in range(nb):
                coef_out[o, i, j] = coef[i, j]
            if amode > 0:  # x_n + A_n - (x_{n-1} + x_n) / 2 on an event step
                if ev_step:
                    dte_ch[o, i] = adf[0, i] + 0.5 * (d_p[i] - dfs[0, i])
                    fm_ch[o, i] = adf[1, i] + 0.5 * (f_p[i] - dfs[1, i])
                else:
                    dte_ch[o, i] = d_p[i]
                    fm_ch[o, i] = f_p[i]
        if no > 0:
            if amode == 2 and ev_step:
                for j in range(nmode):
                    hbuf[hb, j] = azr[j] + 0.5 * (zr[j] - zsr[j])
                    hbuf[hb, nmode + j] = azi[j] + 0.5 * (zi[j] - zsi[j])
                for q in range(na):
                    hbuf[hb, 2 * nmode + q] = abeta[q] + 0.5 * (beta_prev[q] - bs[q])
            else:
                for j in range(nmode):
                    hbuf[hb, j] = zr[j]
                    hbuf[hb, nmode + j] = zi[j]
                for q in range(na):
                    hbuf[hb, 2 * nmode + q] = beta_prev[q]
            hb += 1
            if hb == n_buf or n == nsteps:
                _emit_block(hbuf, hb, cstack, dfeed_static, out, o0)
                o0 += hb
                hb = 0
    _copy_int(s_p, state)
    for i in range(nm):
        mcarry[0, i] = d_p[i]
        mcarry[1, i] = dd_p[i]
        mcarry[2, i] = f_p[i]
    return STATUS_OK, nsteps, n_fail, n_sub
