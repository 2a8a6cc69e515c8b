"""The step loop of the gear kernel (numba), compiled without the numba runtime.

Part of the gear kernel (:mod:`.gear_kernel`; docs/solver.md, "Module layout"): the chunk driver
:func:`.gear_kernel.run_chunk_gear` allocates the work arrays and calls :func:`_run_loop`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from gear_rotor_sim.solver.gear_events import _event_step
from gear_rotor_sim.solver.gear_jumps import _jump_average_end, _jump_average_start
from gear_rotor_sim.solver.gear_output import _copy_int, _emit_outputs
from gear_rotor_sim.solver.gear_step import (
    _commit_meshes,
    _end_excitation,
    _full_step_crossing,
    _full_step_solve,
    _step_jumps,
    _update_fused,
    _update_plain,
)
from gear_rotor_sim.solver.kernels import _FM, STATUS_NONFINITE, STATUS_OK


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
    the full step's affine form (several meshes). The numbered parts of :func:`run_chunk_gear`'s
    docstring are ``inline="always"`` functions of :mod:`.gear_step` (1.-5. and the modal update)
    and :mod:`.gear_output` (6.) taking these tuples; the loop keeps the control flow between them
    and ``average_jumps``' choice. This function allocates nothing (the output block product is the
    call :func:`_emit_block`). Without the runtime, binding an array (tuple unpacking,
    views, the inlined :func:`_event_step`'s ~80 arrays) costs no atomic reference-count increment and
    decrement: with it, the event steps spent about half their time in them at 20000 rpm
    (docs/solver.md, "Session 8").
    """
    zr, zi, rr, ri, c0r, c0i, swr2, swi2, crr2, cri2 = modal[:10]
    mesh_par = mesh[6]
    phase, ampl = exc[0], exc[5]
    beta_prev, ypred, state, mcarry = carry
    prev, cur, _mats, _solve = meshw
    ev, avg, work, ja = evw
    beta_new, alpha = cur[5], cur[6]
    zero, gr, gi, qa, flat, te_sc = upd[:6]
    swr, swi, crr, cri = flat
    bnd, bfe, bmesh, pha = ev[0], ev[1], ev[2], ev[8]
    avg_mode, zsr, zsi, bs, dfs = avg[4:]  # event_average
    d_p, dd_p, f_p, s_p = prev[0], prev[1], prev[4], prev[5]
    jc, jk, jm = ja
    nsteps = phase.shape[0] - 1
    nm = phase.shape[1]
    nb = tables[1].shape[2]
    na = beta_prev.shape[0]
    ne = ampl.shape[1]
    nmode = zr.shape[0]
    e0 = nm * nb
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
    fz = (
        (zr, zi, rr, ri, c0r, c0i),
        (zfr, zfi, rfr, rfi, c0fr, c0fi),
        (s0r, s0i, s1r, s1i, s2r, s2i, s3r, s3i, s4r, s4i, s5r, s5i, s6r, s6i, s7r, s7i),
        (p0r, p0i, p1r, p1i, p2r, p2i, p3r, p3i),
        (gr, gi),
        (swr, swi),
    )

    # the unforced modes: exactly zero with a zero static increment (a fixed set point from the static
    # equilibrium; nothing forces them) they stay zero, bit for bit, and are not propagated
    nu = nf
    for j in range(nf, nmode):
        if zr[j] != 0.0 or zi[j] != 0.0 or c0r[j] != 0.0 or c0i[j] != 0.0:
            nu = nmode
            break

    n_fail = 0
    n_sub = 0
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
            nev, has_end = _step_jumps(n, exc, tables, mesh_par, carry, meshw, ev)
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
            finite = _end_excitation(n, exc, tables, mesh_par, te_sc, cur)
            if not finite:
                _copy_int(s_p, state)
                return STATUS_NONFINITE, o, n_fail, n_sub
            if javg:
                _jump_average_start(n, pha, exc, tables, mesh_par, prev, cur, ja)
            for q in range(ne):
                beta_new[e0 + q] = ampl[n, q]
            # 3. delta, delta' affine in the mesh forces; 4. the mesh solve
            fail = _full_step_solve(mesh, carry, meshw, upd)
            if locate:
                # a contact change inside the step: locate it from this full-step solution, then redo
                # the step as two sub-steps split there (none if no crossing is found)
                tc0, dest0, mesh0 = _full_step_crossing(meshw, dt)
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
            status = _commit_meshes(mesh_par, carry, meshw, bound)
            if status != STATUS_OK:
                _copy_int(s_p, state)
                return status, o, n_fail, n_sub
            if fused:
                _update_fused(nf, nu, e0, alpha, qa, ypred, fz)
            else:
                _update_plain(nf, nu, alpha, ypred, fz, flat)
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
        hb, o0 = _emit_outputs(n, nsteps, hb, o0, ev_step, modal, carry, outs, meshw, avg)
    _copy_int(s_p, state)
    for i in range(nm):
        mcarry[0, i] = d_p[i]
        mcarry[1, i] = dd_p[i]
        mcarry[2, i] = f_p[i]
    return STATUS_OK, nsteps, n_fail, n_sub
