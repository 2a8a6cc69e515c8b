"""Events inside a step of the gear kernel (numba): location of a contact change, and the event step
integrated as Newmark sub-steps split at the table jumps and located contact changes.

Part of the gear kernel (:mod:`.gear_kernel`; docs/solver.md, "Module layout", "Events inside a
step").
"""

from __future__ import annotations

import numpy as np
from numba import njit

from gear_rotor_sim.solver.gear_mesh_solve import (
    _affine_forces,
    _mesh_solve_one,
    _set_columns,
    _solve_meshes,
    _state_force,
)
from gear_rotor_sim.solver.gear_tables import _lerp, _tables_at
from gear_rotor_sim.solver.kernels import _FM, STATUS_BOUND, STATUS_NONFINITE, STATUS_OK

#: Most boundaries (table jumps, located contact changes) of one event step.
_MAX_PIECES = 24

#: A jump closer than this fraction of a step to a step boundary is taken at that boundary (with
#: dt = T_mesh / s the phase-0 jump falls on grid points, up to the round-off of the accumulated mesh
#: phase). 1e-9 let that round-off (3.6e-11 of a mesh period after 3 s at 13275 rpm) leave a sub-step
#: of 1.8e-9 of a step in which the teeth reached the back flank: the pinned state's force
#: (-b* - delta_m0) / a_m, a_m proportional to the sub-step length, was 1e236 N and the state
#: non-finite (speed continuation of the as-published configuration, 225 C, mesh damping ratio
#: 0.099). Taking a jump up to 1e-6 of a step early or late is an error of that order in its impulse.
_EVENT_SNAP = 1e-6


@njit(cache=True, fastmath=_FM, error_model="numpy", _nrt=False)
def _locate_crossing(dma: float, dmda: float, dmb: float, dmdb: float, b: float, hw: float) -> float:
    """Fraction in (0, 1) of a (sub)step of length ``hw`` at which ``delta_m`` first crosses +-b*.

    Cubic Hermite interpolation of ``delta_m`` from its values and rates at both ends, root by
    Newton from the linear estimate; -1 if there is no sign change (e.g. a pinned boundary state).
    """
    best = -1.0
    for side in range(2):
        lev = b if side == 0 else -b
        fa = dma - lev
        fb = dmb - lev
        if fa * fb < 0.0:
            t = fa / (fa - fb)
            ga = hw * dmda
            gb = hw * dmdb
            for _ in range(4):
                t2 = t * t
                t3 = t2 * t
                hh = (
                    (2 * t3 - 3 * t2 + 1) * fa
                    + (t3 - 2 * t2 + t) * ga
                    + (3 * t2 - 2 * t3) * fb
                    + (t3 - t2) * gb
                )
                dh = (
                    (6 * t2 - 6 * t) * fa
                    + (3 * t2 - 4 * t + 1) * ga
                    + (6 * t - 6 * t2) * fb
                    + (3 * t2 - 2 * t) * gb
                )
                if dh == 0.0:
                    break
                tn = t - hh / dh
                if not (0.0 < tn < 1.0):
                    break
                t = tn
            if best < 0.0 or t < best:
                best = t
    if best <= 1e-9 or best >= 1.0 - 1e-9:
        return -1.0
    return best


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _event_step(
    n: int,
    m0: int,
    tc0: float,
    dest0: int,
    mesh0: int,
    nf: int,
    ev: tuple,
    avg: tuple,
    modal: tuple,
    mesh: tuple,
    tables: tuple,
    exc: tuple,
    prev: tuple,
    cur: tuple,
    work: tuple,
    dt: float,
    bound: float,
    expo: bool,
    mu_max: float,
) -> tuple[int, int, int]:
    """Step n-1 -> n as Newmark sub-steps split at the table jumps ``bnd[1..m0-1]`` (fractions of the
    step, phases ``bfe``, mesh ``bmesh``), at a jump of mesh i at the step end (``endfe[i]`` >= 0) and
    at located contact changes (see :func:`run_chunk_gear`); ``tc0`` > 0: a contact change of mesh
    ``mesh0`` into state ``dest0`` already located on the full step (no jump in it).

    A sub-step of length ``w h`` (``mu = h lambda`` per mode): ``r' = (1 + w mu/2)/(1 - w mu/2)``,
    force-column scale ``rho = s'/s = w (1 - mu/2)/(1 - w mu/2)``; delta, delta' at its end read the
    free part ``Re(V Phi r' z)``, the responses ``Re(sum_j rho_j pm_j)`` to the mesh columns and the
    static increment (``pm`` per dt), those to the effect columns, and with a reduced basis the
    dropped modes' static part of the new amplitudes; the compensation is eliminated with
    ``E(w) = I - Kbar H_d - Cbar H_v`` of the sub-step. The bodies are written out here: split into
    small inlined functions (map, responses, excitation, compensation, solve, crossing, commit, right
    limits; tried in session 12) every one of them changed the outputs' round-off (LLVM then
    contracts and vectorises the same arithmetic differently), and the calibration's rows depend on
    the solver's numbers bit for bit (docs/solver.md, "Session 12"); the same seven cuts at once,
    tried again in session 17, changed 43 of 360 arrays of ``benchmarks/kernel_bitwise.py``.

    Arrays by role: ``ev`` = (bnd, bfe, bmesh, bkind, bdest, allow, endfe, dph, pha, fe, ph): the
    step's boundaries (fractions, jump phases, meshes, kinds, states after a located contact change,
    whether a piece may be split again) and per mesh the end jump phase, phase advance, start phase,
    and the sub-step end's jump phase and phase; ``avg`` = (azr, azi, abeta, adf, avg_mode, zsr, zsi,
    bs, dfs): ``event_average``'s sums over the step and its start values; ``prev`` = (d, dd, e, ed,
    f, s) per mesh at the step start, updated to the step end; ``cur`` = (kk, ee, ed, coef, beta_prev,
    beta_new, alpha, force) receive the end values; ``work`` = (rp, sub, resp, mats, solve, swork,
    g): the sub-step map (r', rho), the responses (qs, qn, qb, acc), the compensation's (qs, qn, pd,
    pv), the affine form (a1, b1, am, bm, ...), the mesh solve's (new_state, cm, bst, work, rhs,
    trial), the Gauss-Jordan work and the modal increments (gr, gi). ``expo``: the map is the exact
    modal propagator (``newmark.step_map(exact=True)``), and so are its sub-steps. Returns (status,
    failed solves, sub-steps).
    """
    bnd, bfe, bmesh, bkind, bdest, allow, endfe, dph, pha, fe, ph = ev
    azr, azi, abeta, adf, avg_mode = avg[:5]
    zr, zi, rr, ri, c0r, c0i, swr, swi, _crr, _cri, vrr, vri, mur, mui, pmr, pmi = modal
    pq, pqn, _pq_static, rstat, _pd, _pv, mesh_par = mesh
    _phase, phase_rate, kfac, te_add, ted_add, ampl = exc
    d_p, dd_p, e_p, ed_p, f_p, s_p = prev
    kk, ee, edv, coef, beta_prev, beta_new, alpha, force = cur
    rp, sub, resp, mats, solve, swork, g = work
    gr, gi = g
    new_state, cm, bst, swn, srhs, strial = solve
    qs, qn, pdm, pvm = resp
    qb, acc = sub[2], sub[3]
    rpr, rpi, rhr, rhi = rp
    a1, b1, am, bm, _gd, _gv, _wv = mats
    nm = d_p.shape[0]
    nr = 2 * nm
    nb = coef.shape[1]
    na = beta_prev.shape[0]
    e0 = nm * nb
    nmode = zr.shape[0]
    npm = pmr.shape[0]  # (mesh columns + static increment) x 2 nm
    ne = ampl.shape[1]
    has_kfac = kfac.shape[0] > 0
    has_te = te_add.shape[0] > 0
    two_pi = 2.0 * np.pi
    # bkind: 0 step end, 1 table jump, 2 located contact change (bdest: the state after it)
    m = m0
    bnd[0] = 0.0
    for i in range(1, m):
        bkind[i] = 1
    bnd[m] = 1.0
    bkind[m] = 0
    for i in range(m):
        allow[i] = 1
    if tc0 > 0.0:  # contact change already located on the full step (no jump in it): split there
        bnd[2] = bnd[1]
        bkind[2] = bkind[1]
        bnd[1] = tc0
        bkind[1] = 2
        bdest[1] = dest0
        bmesh[1] = mesh0
        allow[0] = 0
        allow[1] = 0
        m = 2
    n_fail = 0
    n_sub = 0
    amode = avg_mode[0]
    if amode > 0:  # the step's averages over its committed sub-steps (event_average)
        for j in range(nm):
            adf[0, j] = 0.0
            adf[1, j] = 0.0
        if amode == 2:
            for j in range(nmode):
                azr[j] = 0.0
                azi[j] = 0.0
            for q in range(na):
                abeta[q] = 0.0
    i = 0
    while i < m:
        ta = bnd[i]
        tb = bnd[i + 1]
        kind = bkind[i + 1]
        w = tb - ta
        # --- sub-step map r', rho over all modes: Newmark's, then with ``expo`` the exact propagator
        # where |mu| <= mu_max, in a loop of its own (LLVM speculates exp/sin/cos across a branch in a
        # loop: in one loop with a per-mode branch they ran for every mode of every sub-step, 28 % of
        # the 20000 rpm run with Newmark's map)
        for j in range(nmode):  # Newmark: r' = (1 + w mu/2)/(1 - w mu/2), rho = w (1 - mu/2)/(1 - w mu/2)
            ar = 0.5 * w * mur[j]
            ai = 0.5 * w * mui[j]
            dr = 1.0 - ar
            inv = 1.0 / (dr * dr + ai * ai)
            nr_ = 1.0 + ar
            rpr[j] = (nr_ * dr - ai * ai) * inv
            rpi[j] = (ai * dr + nr_ * ai) * inv
            er = 1.0 - 0.5 * mur[j]
            ei = -0.5 * mui[j]
            rhr[j] = w * (er * dr - ei * ai) * inv
            rhi[j] = w * (ei * dr + er * ai) * inv
        if expo:
            for j in range(nmode):
                if mur[j] * mur[j] + mui[j] * mui[j] <= mu_max * mu_max:
                    # exact propagator: r' = exp(w mu), rho = (exp(w mu) - 1) / (exp(mu) - 1), exp(mu) = r
                    ex = np.exp(w * mur[j])
                    cr = ex * np.cos(w * mui[j])
                    ci = ex * np.sin(w * mui[j])
                    rpr[j] = cr
                    rpi[j] = ci
                    dr = rr[j] - 1.0
                    di = ri[j]
                    den = dr * dr + di * di
                    if den > 1e-30:
                        rhr[j] = ((cr - 1.0) * dr + ci * di) / den
                        rhi[j] = (ci * dr - (cr - 1.0) * di) / den
                    else:  # mu -> 0: rho -> w
                        rhr[j] = w
                        rhi[j] = 0.0
        # --- responses of delta, delta' at the sub-step end (reductions over the forced modes)
        for r in range(npm):
            sm = 0.0
            for j in range(nf):
                sm += rhr[j] * pmr[r, j] - rhi[j] * pmi[r, j]
            acc[r] = sm
        for r in range(nr):
            sm = 0.0
            for j in range(nf):
                tr = rpr[j] * zr[j] - rpi[j] * zi[j]
                ti = rpr[j] * zi[j] + rpi[j] * zr[j]
                sm += vrr[r, j] * tr - vri[r, j] * ti
            acc[npm + r] = sm
        nmc = npm // nr - 1  # mesh columns
        for r in range(nr):
            for q in range(nmc):
                qs[r, q] = acc[q * nr + r]
            qb[r] = acc[nmc * nr + r] + rstat[r] + acc[npm + r]  # static increment and free part
        for q in range(nmc, na):  # effect columns, on the fly
            for r in range(nr):
                sm = 0.0
                for j in range(nf):
                    tr = rhr[j] * swr[q, j] - rhi[j] * swi[q, j]
                    ti = rhr[j] * swi[q, j] + rhi[j] * swr[q, j]
                    sm += vrr[r, j] * tr - vri[r, j] * ti
                qs[r, q] = sm
        for r in range(nr):
            for q in range(na):
                qn[r, q] = qs[r, q] + (pqn[r, q] - pq[r, q])  # plus the dropped modes' static part
        # --- excitation at the sub-step end
        finite = True
        for j in range(nm):
            fe[j] = -1.0
            ph[j] = pha[j] + tb * dph[j]
            if kind == 1 and bmesh[i + 1] == j:
                fe[j] = bfe[i + 1] if bfe[i + 1] > 0.0 else 1.0
            elif kind == 0 and endfe[j] >= 0.0:
                fe[j] = endfe[j] if endfe[j] > 0.0 else 1.0
            if fe[j] >= 0.0:  # the left limit at the jump
                k = _tables_at(j, fe[j], True, tables, coef)
            else:
                k = _tables_at(j, ph[j] - np.floor(ph[j]), False, tables, coef)
            if has_kfac:
                k *= _lerp(kfac[n - 1, j], kfac[n, j], tb)
            arg = two_pi * ph[j] + mesh_par[j, 5]
            e = mesh_par[j, 4] * np.sin(arg)
            edot = mesh_par[j, 4] * np.cos(arg) * two_pi * _lerp(phase_rate[n - 1, j], phase_rate[n, j], tb)
            if has_te:
                e += _lerp(te_add[n - 1, j], te_add[n, j], tb)
                edot += _lerp(ted_add[n - 1, j], ted_add[n, j], tb)
            kk[j] = k
            ee[j] = e
            edv[j] = edot
            if not (np.isfinite(k) and np.isfinite(e) and np.isfinite(edot)):
                finite = False
        if not finite:
            return STATUS_NONFINITE, n_fail, n_sub
        for q in range(ne):
            beta_new[e0 + q] = _lerp(ampl[n - 1, q], ampl[n, q], tb)
        # --- compensation: pd = H_d E^-1, pv = H_v E^-1 (Gauss-Jordan on [E | I], nm x 2 nm)
        for r in range(nm):
            for l in range(nm):
                swork[r, l] = (
                    (1.0 if r == l else 0.0)
                    - mesh_par[r, 0] * qn[r, l * nb]
                    - mesh_par[r, 1] * qn[nm + r, l * nb]
                )
                swork[r, nm + l] = 1.0 if r == l else 0.0
        for c in range(nm):
            p = c
            best = abs(swork[c, c])
            for r in range(c + 1, nm):
                if abs(swork[r, c]) > best:
                    best = abs(swork[r, c])
                    p = r
            if p != c:
                for l in range(2 * nm):
                    tmp = swork[c, l]
                    swork[c, l] = swork[p, l]
                    swork[p, l] = tmp
            piv = swork[c, c]
            for l in range(2 * nm):
                swork[c, l] /= piv
            for r in range(nm):
                if r != c:
                    fac = swork[r, c]
                    for l in range(2 * nm):
                        swork[r, l] -= fac * swork[c, l]
        for r in range(nm):
            for l in range(nm):
                sd = 0.0
                sv = 0.0
                for mm in range(nm):
                    sd += qn[r, mm * nb] * swork[mm, nm + l]
                    sv += qn[nm + r, mm * nb] * swork[mm, nm + l]
                pdm[r, l] = sd
                pvm[r, l] = sv
        # --- delta, delta' affine in the mesh forces
        _affine_forces(qb, resp, beta_prev, beta_new, e0, coef, mesh_par, mats)
        # --- mesh solve (the mesh whose located contact change ends this sub-step keeps its old law)
        forced = bmesh[i + 1] if kind == 2 else -1
        fail = 0
        if nm == 1:
            s0 = s_p[0]
            if forced == 0 and (s0 == 2 or s0 == -2 or s0 == 0):
                if s0 == 0:
                    f0 = 0.0
                else:
                    sg = 1.0 if s0 == 2 else -1.0
                    f0 = (
                        kk[0] * (a1[0] - ee[0] - sg * mesh_par[0, 3]) + mesh_par[0, 2] * (b1[0] - edv[0])
                    ) / (1.0 - kk[0] * am[0, 0] - mesh_par[0, 2] * bm[0, 0])  # Eq 25
                new_state[0] = s0
                force[0] = f0
            else:
                ns1, f1 = _mesh_solve_one(
                    s0,
                    a1[0] - ee[0],
                    b1[0] - edv[0],
                    am[0, 0],
                    bm[0, 0],
                    kk[0],
                    mesh_par[0, 2],
                    mesh_par[0, 3],
                )
                if ns1 == -9:
                    fail = _solve_meshes(
                        s_p, -1, a1, b1, am, bm, kk, ee, edv, cm, bst, force, new_state, swn, srhs, strial
                    )
                else:
                    new_state[0] = ns1
                    force[0] = f1
        else:
            fail = _solve_meshes(
                s_p, forced, a1, b1, am, bm, kk, ee, edv, cm, bst, force, new_state, swn, srhs, strial
            )
        changed = False
        for j in range(nm):
            if new_state[j] != s_p[j]:
                changed = True
        if allow[i] == 1 and changed and m < _MAX_PIECES - 1:
            tc = -1.0
            jc = -1
            for j in range(nm):
                if new_state[j] != s_p[j]:
                    d = a1[j]
                    dd = b1[j]
                    for l in range(nm):
                        d += am[j, l] * force[l]
                        dd += bm[j, l] * force[l]
                    t = _locate_crossing(
                        d_p[j] - e_p[j], dd_p[j] - ed_p[j], d - ee[j], dd - edv[j], mesh_par[j, 3], w * dt
                    )
                    if t > 0.0 and (tc < 0.0 or t < tc):
                        tc = t
                        jc = j
            if tc > 0.0:
                for j in range(m, i, -1):
                    bnd[j + 1] = bnd[j]
                    bfe[j + 1] = bfe[j]
                    bmesh[j + 1] = bmesh[j]
                    bkind[j + 1] = bkind[j]
                    bdest[j + 1] = bdest[j]
                    allow[j + 1] = allow[j]
                bnd[i + 1] = ta + tc * w
                bkind[i + 1] = 2
                bdest[i + 1] = new_state[jc]
                bmesh[i + 1] = jc
                allow[i] = 0
                allow[i + 1] = 0
                m += 1
                continue
        n_fail += fail
        # --- commit: new amplitudes, z <- r' z + rho (c0 + sum_q SW_q alpha_q)
        for j in range(nm):
            d = a1[j]
            dd = b1[j]
            for l in range(nm):
                d += am[j, l] * force[l]
                dd += bm[j, l] * force[l]
            if not (np.isfinite(d) and np.isfinite(force[j])):
                return STATUS_NONFINITE, n_fail, n_sub
            if abs(d) >= bound:
                return STATUS_BOUND, n_fail, n_sub
            c = j * nb
            beta_new[c] = mesh_par[j, 0] * d + mesh_par[j, 1] * dd - coef[j, 0] * force[j]
            for l in range(1, nb):
                beta_new[c + l] = coef[j, l] * force[j]
            if amode > 0:  # trapezoid of the sub-step: its start (right limits) and end (left limits)
                adf[0, j] += 0.5 * w * (d_p[j] + d)
                adf[1, j] += 0.5 * w * (f_p[j] + force[j])
            d_p[j] = d
            dd_p[j] = dd
            e_p[j] = ee[j]
            ed_p[j] = edv[j]
            f_p[j] = force[j]
            s_p[j] = new_state[j]
        for q in range(na):
            alpha[q] = beta_prev[q] + beta_new[q]
            beta_prev[q] = beta_new[q]
        if amode == 2:
            for q in range(na):
                abeta[q] += 0.5 * w * alpha[q]
        for j in range(nmode):
            gr[j] = c0r[j]
            gi[j] = c0i[j]
        for q in range(na):
            aq = alpha[q]
            if aq != 0.0:
                for j in range(nf):
                    gr[j] += swr[q, j] * aq
                    gi[j] += swi[q, j] * aq
        if amode == 2:
            for j in range(nmode):
                xr = zr[j]
                xi = zi[j]
                zr[j] = rpr[j] * xr - rpi[j] * xi + rhr[j] * gr[j] - rhi[j] * gi[j]
                zi[j] = rpr[j] * xi + rpi[j] * xr + rhr[j] * gi[j] + rhi[j] * gr[j]
                azr[j] += 0.5 * w * (xr + zr[j])
                azi[j] += 0.5 * w * (xi + zi[j])
        else:
            for j in range(nmode):
                xr = zr[j]
                xi = zi[j]
                zr[j] = rpr[j] * xr - rpi[j] * xi + rhr[j] * gr[j] - rhi[j] * gi[j]
                zi[j] = rpr[j] * xi + rpi[j] * xr + rhr[j] * gi[j] + rhi[j] * gr[j]
        n_sub += 1
        # --- right limits at the boundary
        for j in range(nm):
            if fe[j] >= 0.0:
                # right limit of mesh j's tables at its jump, same contact state and deflection
                k = _tables_at(j, fe[j] if fe[j] < 1.0 else 0.0, False, tables, coef)
                if has_kfac:
                    k *= _lerp(kfac[n - 1, j], kfac[n, j], tb)
                kk[j] = k
                f_p[j] = _state_force(
                    s_p[j], d_p[j] - e_p[j], dd_p[j] - ed_p[j], k, mesh_par[j, 2], mesh_par[j, 3], f_p[j]
                )
                _set_columns(j, beta_prev, coef, f_p[j], d_p[j], dd_p[j], mesh_par)
        if kind == 2:
            j = bmesh[i + 1]
            sd_ = bdest[i + 1]
            if s_p[j] != sd_ and (sd_ == 0 or sd_ == 2 or sd_ == -2):
                # right limit of Eq 25 at the located contact change (its damping term jumps)
                f_p[j] = _state_force(
                    sd_, d_p[j] - e_p[j], dd_p[j] - ed_p[j], kk[j], mesh_par[j, 2], mesh_par[j, 3], f_p[j]
                )
                s_p[j] = sd_
                _set_columns(j, beta_prev, coef, f_p[j], d_p[j], dd_p[j], mesh_par)
        i += 1
    return STATUS_OK, n_fail, n_sub
