"""The compiled gear kernel (numba): any number of meshes, located events, full or reduced modal basis.

:func:`run_chunk_gear` advances the exact modal Newmark map of :mod:`.kernels` for a system with one
or more meshes whose stiffness, force coefficients and transmission error are looked up from tables
inside the loop, the static load as a constant modal increment, the force columns applied to the
*forced* modes only and the outputs formed by blocks of matrix products. The basis may be the full
one or a reduced one (``newmark.reduce_basis``) whose dropped modes follow the excitation
quasi-statically (residual flexibility, ``newmark.residual_flexibility``): delta, delta' and every
output then read the dropped modes' static part through the new column amplitudes.

With ``locate`` a step that contains a table jump of any mesh (tooth-pair change, pitch point) or a
contact change of any mesh is integrated as Newmark sub-steps split at the event
(:func:`_event_step`; docs/solver.md, "Events inside a step").

Hot path: the step loop (:func:`.gear_loop._run_loop`) is compiled without the numba runtime, so its
parts (the regular step's in :mod:`.gear_step`, the outputs, the event step) are ``inline="always"``
functions taking the role tuples below, with calls only on rare paths (a table interval holding a
jump, an active set that does not settle, the output block product): with the runtime, every array
handed to a function inside the loop, inlined or not, cost a reference count increment and decrement
per step (docs/solver.md, "One gear kernel", "Session 8").

The arrays are passed grouped by role, as tuples:

``modal``   (zr, zi, rr, ri, c0r, c0i, swr, swi, crr, cri, vrr, vri, mur, mui, pmr, pmi): modal
            state (updated), diagonal map ``r``, static increment ``c0``, force-column responses
            ``SW`` (na, nmode), mesh prediction rows ``(V Phi) r`` (2 nm, nmode: delta rows, then
            delta' rows); for the sub-steps the mesh rows ``V Phi`` (2 nm, nmode), ``h lambda`` per
            mode and the responses ``pm = (V Phi)_r * SW_q`` (row ``q 2 nm + r`` for the mesh columns
            q < nm nb, then ``q = nm nb`` the static increment).
``mesh``    (pq, pqn, pq_static, rstat, pd, pv, mesh_par): responses of delta, delta' (2 nm, na)
            to the carried and to the new column amplitudes (equal for the full basis; with a reduced
            one ``pqn`` adds the dropped modes' static response), to the static load (full step),
            the dropped modes' static response to the static load alone ``rstat`` (2 nm,);
            ``pd``, ``pv`` (nm, nm) the elimination of the mean-mesh compensation on a full step;
            ``mesh_par`` (nm, 6) = (kbar, cbar, c_m, b*, e0, phi_te).
``tables``  (tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k, jump_c, n_jump): per mesh, the
            full tables (nm, nt) / (nm, nt, nb), the flag of the intervals holding a jump, the
            continuous parts and the jumps (nm, nj) / (nm, nj, nb), ``n_jump`` (nm,) jumps per mesh
            (:func:`newmark.split_table_jumps`).
``exc``     (phase, phase_rate, kfac, te_add, ted_add, ampl): (n + 1, nm) mesh phases in [0, 1) and
            their rates (cycles/s), effect stiffness factors, added TE and its rate ((0, nm) if none)
            and effect force amplitudes (n + 1, ne); index 0 the carried step.
``carry``   (beta_prev, ypred, state, mcarry): column amplitudes, mesh predictions, contact states,
            (3, nm) delta, delta', F at the carried step (all updated).
``outs``    (cstack, dfeed_static, hbuf, out, dte, dted, fmesh, states, kt, et, edt, coef).

Active columns: mesh i owns ``i nb .. i nb + nb - 1`` (``u_i`` = compensation ``+V_i`` carrying the
line-of-action part ``-V_i F_i`` too, then the friction basis), effects from ``nm nb``.

Module layout (docs/solver.md, "Module layout"): this module holds the chunk driver
:func:`run_chunk_gear` (work arrays, grouped by role) and re-exports every name it had; the compiled
parts are in modules of one role each: :mod:`.gear_tables` (table look-up, the TE's sin/cos),
:mod:`.gear_mesh_solve` (the mesh law: exact mesh solve, delta and delta' affine in the forces, the
mesh columns), :mod:`.gear_events` (contact-change location, the event step as sub-steps),
:mod:`.gear_jumps` (``average_jumps``), :mod:`.gear_step` (the regular step's parts: table jumps
in the step, excitation, affine form and mesh solve, commit of the meshes), :mod:`.gear_output` (a
step's outputs, the output block product) and :mod:`.gear_loop` (the step loop, :func:`_run_loop`).
Each inlined part was checked bit for bit against the written-out loop it replaces (docs/solver.md,
"Module layout"). numba's cache of a function is checked against
its own source file only, and a caller's cached machine code holds its callees': after editing one
of these modules, delete the solver's numba cache (``gear_rotor_sim/solver/__pycache__/*.nb[ic]``,
or the ``NUMBA_CACHE_DIR`` mirror) so that the callers in the other modules are compiled again.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from gear_rotor_sim.solver.gear_events import _EVENT_SNAP, _MAX_PIECES, _event_step, _locate_crossing
from gear_rotor_sim.solver.gear_jumps import _jump_average_end, _jump_average_start
from gear_rotor_sim.solver.gear_loop import _run_loop
from gear_rotor_sim.solver.gear_mesh_solve import (
    _affine_forces,
    _mesh_solve_one,
    _mesh_solve_two,
    _row_two,
    _set_columns,
    _solve_meshes,
    _state_force,
)
from gear_rotor_sim.solver.gear_output import _copy_int, _emit_block
from gear_rotor_sim.solver.gear_tables import TE_ANCHOR_STEPS, _lerp, _tables_at, _te_sin_cos
from gear_rotor_sim.solver.kernels import _FM, STATUS_OK

__all__ = [
    "TE_ANCHOR_STEPS",
    "_EVENT_SNAP",
    "_MAX_PIECES",
    "_affine_forces",
    "_copy_int",
    "_emit_block",
    "_event_step",
    "_jump_average_end",
    "_jump_average_start",
    "_lerp",
    "_locate_crossing",
    "_mesh_solve_one",
    "_mesh_solve_two",
    "_row_two",
    "_run_loop",
    "_set_columns",
    "_solve_meshes",
    "_state_force",
    "_tables_at",
    "_te_sin_cos",
    "run_chunk_gear",
]


@njit(cache=True, fastmath=_FM, error_model="numpy", nogil=True)
def run_chunk_gear(
    modal: tuple,
    n_forced: int,
    mesh: tuple,
    tables: tuple,
    exc: tuple,
    carry: tuple,
    outs: tuple,
    dt: float,
    locate: bool,
    bound: float,
    fuse: bool = True,
    expo: bool = False,
    mu_max: float = 1.0,
    event_average: bool = False,
    average_jumps: bool = False,
) -> tuple[int, int, int, int]:
    """Advance ``n = phase.shape[0] - 1`` steps of the modal map with ``nm >= 1`` table meshes.

    Per step (Eq 39 by the exact modal Newmark map):

    1. events (``locate``): the table jumps of every mesh inside the step (from its phase);
    2. excitation: per mesh the stiffness and force coefficients from the tables (Eqs 13-15, 29) at
       the mesh phase, the transmission error of Eq 24 and its rate, the effect inputs;
    3. delta, delta' at the step end as affine functions of the mesh forces, ``a1 + am F`` and
       ``b1 + bm F``: prediction, static load, carried and new effect amplitudes; the unknown new
       amplitudes ``u_l = comp_l - coef_l0 F_l`` and ``coef_lj F_l`` with the compensation
       ``comp = kbar delta + cbar delta'`` eliminated exactly (``pd = H_d E^-1``, ``pv = H_v E^-1``
       with ``E = I - Kbar H_d - Cbar H_v``, ``H`` the responses to the ``u`` columns);
    4. the exact piecewise-linear mesh solve of Eqs 25-26 (one mesh: scalar active set; several:
       jointly, :func:`_solve_meshes`); with ``locate`` a contact change of any mesh is located in
       the step (Hermite interpolation of its delta_m) and the step redone as sub-steps;
    5. the new amplitudes, then ``z <- r z + c0 + sum_q SW_q alpha_q`` over the forced modes (the
       rest only propagate) and the predictions ``Re((V Phi) r z)`` of the next step in one pass
       (mesh columns unrolled for one and two meshes);
    6. the outputs in blocks of ``hbuf.shape[0]`` steps by one matrix product (BLAS).

    ``event_average``: on a step holding an event the channels are ``x_n + A_n - (x_{n-1} + x_n)/2``
    instead of the end value ``x_n``, ``A_n`` their average over the step's committed sub-steps (each
    linear between its start and end, as the trapezoidal rule takes it): the end value shifted by
    what the events inside the step change in the step's mean, so that their times reach the output
    (docs/solver.md, "Session 10", aliasing). Regular steps are unchanged. The mesh channels go to
    ``outs[12]``, ``outs[13]`` (the per-step mesh arrays stay end values: the state), the others
    through the output product's rows.

    ``average_jumps`` (with ``locate``): a step whose only events are table jumps, at most one per
    mesh, is not split but taken as a regular step with the tables' average over the step (the
    trapezoidal average of each piece, weighted by its share of the step; the force coefficients
    weighted by the stiffness, so that ``coef F`` integrates right) at both ends; the end force is then
    re-evaluated with the end's own tables and carried (docs/solver.md, "Session 11"). Where the full
    step finds a contact change it falls back to the sub-steps.

    A step holding an event is integrated by :func:`_event_step`: Newmark sub-steps split exactly
    at the jump phases (left limit of the tables at the end of one sub-step, right limit at the start
    of the next, same deflection and contact state) and at located contact changes (the sub-step
    that ends there keeps the old state's force law; the next starts from the right limit of Eq 25).

    Returns
    -------
    (status, step, n_failed_mesh_solves, n_substeps)
    """
    zr = modal[0]
    swr2, swi2, crr2, cri2 = modal[6], modal[7], modal[8], modal[9]
    pmr = modal[14]
    pq, pqn, _pq_static, _rstat, pd, pv, mesh_par = mesh
    phase, phase_rate, _kfac, te_add, ted_add, _ampl = exc
    beta_prev, _ypred, state, mcarry = carry
    nsteps = phase.shape[0] - 1
    nm = phase.shape[1]
    nb = tables[4].shape[2]
    na = beta_prev.shape[0]
    nmode = zr.shape[0]
    nf = n_forced
    has_te = te_add.shape[0] > 0
    two_pi = 2.0 * np.pi
    if nsteps == 0:
        return STATUS_OK, 0, 0, 0
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
    s_p = state.copy()
    new_state = np.zeros(nm, dtype=np.int64)
    trial = np.zeros(nm, dtype=np.int64)
    force = np.zeros(nm)
    swork = np.zeros((nm, nm))
    swork2 = np.zeros((nm, 2 * nm))
    srhs = np.zeros(nm)
    # per mesh at the carried step: delta, delta', TE, its rate, force
    d_p = mcarry[0].copy()
    dd_p = mcarry[1].copy()
    f_p = mcarry[2].copy()
    e_p = np.zeros(nm)
    ed_p = np.zeros(nm)
    for i in range(nm):
        arg = two_pi * phase[0, i] + mesh_par[i, 5]
        e_p[i] = mesh_par[i, 4] * np.sin(arg)
        ed_p[i] = mesh_par[i, 4] * np.cos(arg) * two_pi * phase_rate[0, i]
        if has_te:
            e_p[i] += te_add[0, i]
            ed_p[i] += ted_add[0, i]
    # event-step work arrays
    npc = _MAX_PIECES + 2
    bnd = np.zeros(npc)
    bfe = np.zeros(npc)
    bmesh = np.zeros(npc, dtype=np.int64)
    bkind = np.zeros(npc, dtype=np.int64)
    bdest = np.zeros(npc, dtype=np.int64)
    allow = np.zeros(npc, dtype=np.int64)
    endfe = np.zeros(nm)
    dph = np.zeros(nm)
    pha = np.zeros(nm)
    fev = np.zeros(nm)
    phv = np.zeros(nm)
    # event_average: 1 the mesh channels, 2 the output product's rows too
    avg_mode = np.zeros(1, dtype=np.int64)
    if event_average:
        avg_mode[0] = 2 if outs[0].shape[1] > 0 else 1
    ev = (bnd, bfe, bmesh, bkind, bdest, allow, endfe, dph, pha, fev, phv)
    # event_average: the step's averages (azr, azi, abeta, adf), the mode, then its start values
    avg = (np.zeros(nmode), np.zeros(nmode), np.zeros(na), np.zeros((2, nm)), avg_mode, np.zeros(nmode),
           np.zeros(nmode), np.zeros(na), np.zeros((2, nm)))  # fmt: skip
    rp = (np.zeros(nmode), np.zeros(nmode), np.zeros(nmode), np.zeros(nmode))
    qs = np.zeros((2 * nm, na))
    qn = np.zeros((2 * nm, na))
    acc = np.zeros(pmr.shape[0] + 2 * nm)
    pdm = np.zeros((nm, nm))
    pvm = np.zeros((nm, nm))
    mats = (a1, b1, am, bm, gd, gv, wv)
    solve = (new_state, cm, bst, swork, srhs, trial)
    # sub-steps: the responses (to the carried and new amplitudes, the rest, work), the compensation's
    sub = (qs, qn, np.zeros(2 * nm), acc)
    resp_sub = (qs, qn, pdm, pvm)
    work = (rp, sub, resp_sub, mats, solve, swork2, (np.zeros(nmode), np.zeros(nmode)))
    resp_full = (pq, pqn, pd, pv)  # full steps: responses to the carried and new amplitudes, compensation
    qb_full = np.zeros(2 * nm)
    prev = (d_p, dd_p, e_p, ed_p, f_p, s_p)
    cur = (kk, ee, ed, coef, beta_prev, beta_new, alpha, force)
    # fused update: the mesh column rows and prediction rows as 1-D views from 0, made once (rows of a
    # mesh that does not exist, or beyond nb, point at a zero row)
    fused = fuse and nm <= 2 and nb <= 4
    zero = np.zeros(max(nf, 1))
    gr = np.zeros(nf)  # effect-column increments of a step
    gi = np.zeros(nf)
    qa = np.full(8, -1, dtype=np.int64)  # active column of each fused slot (-1: none)
    for i in range(min(nm, 2)):
        for j in range(min(nb, 4)):
            qa[4 * i + j] = i * nb + j
    flat = (swr2.ravel(), swi2.ravel(), crr2.ravel(), cri2.ravel())
    te_sc = np.empty((nsteps + 1, 2 * nm))
    _te_sin_cos(phase, mesh_par, te_sc)
    upd = (zero, gr, gi, qa, flat, te_sc, qb_full, resp_full)
    # average_jumps: per mesh the step end's coefficients, the weighted sums, the saved carried columns;
    # the end stiffness, the average, the jump's fraction and phase; whether the mesh has a jump
    ja = (np.zeros((3, nm, nb)), np.zeros((4, nm)), np.zeros(nm, dtype=np.int64))
    return _run_loop(
        modal, nf, mesh, tables, exc, carry, outs, (prev, cur, mats, solve), (ev, avg, work, ja), upd, dt,
        locate, bound, fused, expo, mu_max, bool(average_jumps and locate),
    )  # fmt: skip
