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

Hot path: the regular step is written out in the loop, with calls only on rare paths (a table
interval holding a jump, an event step, an active set that does not settle) or with scalar
arguments: every array handed to a function inside the loop, inlined or not, costs a reference
count increment and decrement per step (docs/solver.md, "One kernel").

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
    _solve_small,
    mesh_solve,
)

_MAX_PIECES = 24
#: :func:`_te_sin_cos` takes sin/cos directly every this many steps (and where the phase step is
#: larger than 0.25 rad) and rotates by the phase increment in between.
TE_ANCHOR_STEPS = 64
_C4, _C6, _C8, _C10 = 1.0 / 24.0, -1.0 / 720.0, 1.0 / 40320.0, -1.0 / 3628800.0
_S3, _S5, _S7, _S9, _S11 = -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0, -1.0 / 39916800.0
#: A jump closer than this fraction of a step to a step boundary is taken at that boundary (with
#: dt = T_mesh / s the phase-0 jump falls on grid points, up to the round-off of the accumulated mesh
#: phase). 1e-9 let that round-off (3.6e-11 of a mesh period after 3 s at 13275 rpm) leave a sub-step
#: of 1.8e-9 of a step in which the teeth reached the back flank: the pinned state's force
#: (-b* - delta_m0) / a_m, a_m proportional to the sub-step length, was 1e236 N and the state
#: non-finite (speed continuation of the as-published configuration, 225 C, mesh damping ratio
#: 0.099). Taking a jump up to 1e-6 of a step early or late is an error of that order in its impulse.
_EVENT_SNAP = 1e-6


# ----------------------------------------------------------------------------------------------
# per-mesh physics (scalar arguments, or rare paths)


@njit(cache=True, fastmath=_FM, error_model="numpy", _nrt=False)
def _tables_at(
    i: int,
    f: float,
    strict: bool,
    tables: tuple,
    coef: np.ndarray,
) -> float:
    """Stiffness (returned) and force coefficients (into ``coef[i]``) of mesh ``i`` at cycle fraction
    ``f`` in [0, 1].

    On a table interval without a jump (``jflag == 0``) the full tables are interpolated linearly;
    otherwise, and for ``strict`` (the left limit at a jump phase; at the period wrap ``f = 1``), the
    continuous parts plus the jumps through the periodic steps ``[f >= p] - f``
    (``newmark.split_table_jumps``). Right-continuous.

    Compiled without the numba runtime (``_nrt=False``: it allocates nothing), so that its array
    arguments cost no atomic reference-count increment and decrement per call: with them, the
    calls from the event steps were half of the NRT_incref/NRT_decref calls at 20000 rpm (gdb
    backtraces with NUMBA_DEBUGINFO), and the atomics 20-38 % of the run (perf). The arrays of
    ``tables`` (tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k, jump_c, n_jump) are indexed
    where they are used.
    """
    nt = tables[3].shape[1]
    nb = tables[4].shape[2]
    x = f * nt
    i0 = int(np.floor(x))
    fr = x - i0
    i0 = i0 % nt
    i1 = i0 + 1
    if i1 == nt:
        i1 = 0
    if tables[2][i, i0] == 0 and not strict:
        for j in range(nb):
            c0 = tables[1][i, i0, j]
            coef[i, j] = c0 + fr * (tables[1][i, i1, j] - c0)
        k0 = tables[0][i, i0]
        return k0 + fr * (tables[0][i, i1] - k0)
    k0 = tables[3][i, i0]
    k = k0 + fr * (tables[3][i, i1] - k0)
    for j in range(nb):
        c0 = tables[4][i, i0, j]
        coef[i, j] = c0 + fr * (tables[4][i, i1, j] - c0)
    for q in range(tables[8][i]):
        p = tables[5][i, q]
        saw = (1.0 if (f > p or (f == p and not strict)) else 0.0) - f
        k += tables[6][i, q] * saw
        for j in range(nb):
            coef[i, j] += tables[7][i, q, j] * saw
    return k


@njit(cache=True, error_model="numpy", inline="always")
def _mesh_solve_one(
    s: int, dm0: float, dmd0: float, am: float, bm: float, k: float, c: float, b: float
) -> tuple[int, float]:
    """One mesh: the consistent contact state and force, by the active set of ``kernels.mesh_solve``.

    ``delta_m = dm0 + am F``, ``delta_m' = dmd0 + bm F``. The same states, force laws and tolerances
    as ``kernels._solve_states`` / ``_check_states`` for ``nm = 1``; returns state -9 when the
    iteration does not settle (the caller then falls back to the general solver).
    """
    for _ in range(_MAX_ACTIVE_SET_ITER):
        if s == 2 or s == -2:
            sg = 1.0 if s == 2 else -1.0
            f = (k * (dm0 - sg * b) + c * dmd0) / (1.0 - k * am - c * bm)  # Eq 25 in contact
        elif s == 0:
            f = 0.0
        else:
            sg = 1.0 if s == 1 else -1.0
            f = (sg * b - dm0) / am  # pinned at delta_m = +-b*
        dm = dm0 + am * f
        dmd = dmd0 + bm * f
        tol_d = 1e-12 * (abs(b) + abs(dm)) + 1e-20
        tol_f = 1e-12 * (abs(f) + abs(c * dmd)) + 1e-20
        ns = _natural_state(s, dm, dmd, f, c, b, tol_d, tol_f)
        if ns == s:
            return s, f
        s = ns
    return -9, 0.0


@njit(cache=True, error_model="numpy", inline="always")
def _row_two(
    s: int,
    i: int,
    a1: float,
    b1: float,
    ai0: float,
    ai1: float,
    bi0: float,
    bi1: float,
    k: float,
    e: float,
    ed: float,
    c: float,
    b: float,
) -> tuple[float, float, float]:
    """Row ``(w_i0, w_i1 | rhs_i)`` of Eq 25 for mesh ``i`` of two in trial state ``s``
    (``kernels._solve_states``)."""  # fmt: skip
    if s == 2 or s == -2:
        sg = 1.0 if s == 2 else -1.0
        w0 = -k * ai0 - c * bi0
        w1 = -k * ai1 - c * bi1
        if i == 0:
            w0 += 1.0
        else:
            w1 += 1.0
        return w0, w1, k * (a1 - e - sg * b) + c * (b1 - ed)
    if s == 0:
        return (1.0, 0.0, 0.0) if i == 0 else (0.0, 1.0, 0.0)
    sg = 1.0 if s == 1 else -1.0
    return ai0, ai1, e + sg * b - a1


@njit(cache=True, error_model="numpy", inline="always")
def _mesh_solve_two(
    s0: int,
    s1: int,
    a10: float,
    a11: float,
    b10: float,
    b11: float,
    am00: float,
    am01: float,
    am10: float,
    am11: float,
    bm00: float,
    bm01: float,
    bm10: float,
    bm11: float,
    k0: float,
    k1: float,
    e0: float,
    e1: float,
    ed0: float,
    ed1: float,
    c0: float,
    c1: float,
    bs0: float,
    bs1: float,
) -> tuple[int, int, float, float]:
    """Two meshes: the consistent contact states and forces by the active set of
    ``kernels.mesh_solve`` (2 x 2 solve by Cramer's rule, scalars only); state -9 when it does not
    settle or the system is singular (the caller then falls back to :func:`_solve_meshes`)."""  # fmt: skip
    for _ in range(_MAX_ACTIVE_SET_ITER):
        w00, w01, r0 = _row_two(s0, 0, a10, b10, am00, am01, bm00, bm01, k0, e0, ed0, c0, bs0)
        w10, w11, r1 = _row_two(s1, 1, a11, b11, am10, am11, bm10, bm11, k1, e1, ed1, c1, bs1)
        det = w00 * w11 - w01 * w10
        if det == 0.0:
            return -9, -9, 0.0, 0.0
        f0 = (r0 * w11 - w01 * r1) / det
        f1 = (w00 * r1 - w10 * r0) / det
        dm0 = a10 + am00 * f0 + am01 * f1 - e0
        dmd0 = b10 + bm00 * f0 + bm01 * f1 - ed0
        dm1 = a11 + am10 * f0 + am11 * f1 - e1
        dmd1 = b11 + bm10 * f0 + bm11 * f1 - ed1
        n0 = _natural_state(
            s0, dm0, dmd0, f0, c0, bs0, 1e-12 * (abs(bs0) + abs(dm0)) + 1e-20,
            1e-12 * (abs(f0) + abs(c0 * dmd0)) + 1e-20,
        )  # fmt: skip
        n1 = _natural_state(
            s1, dm1, dmd1, f1, c1, bs1, 1e-12 * (abs(bs1) + abs(dm1)) + 1e-20,
            1e-12 * (abs(f1) + abs(c1 * dmd1)) + 1e-20,
        )  # fmt: skip
        if n0 == s0 and n1 == s1:
            return s0, s1, f0, f1
        s0 = n0
        s1 = n1
    return -9, -9, 0.0, 0.0


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _state_force(s: int, dm: float, dmd: float, k: float, c: float, b: float, f_now: float) -> float:
    """Eq 25 in contact state ``s`` (pinned states keep ``f_now``: their force is set-valued)."""
    if s == 2:
        return k * (dm - b) + c * dmd
    if s == -2:
        return k * (dm + b) + c * dmd
    if s == 0:
        return 0.0
    return f_now


@njit(cache=True, error_model="numpy", _nrt=True)
def _solve_meshes(
    s_prev: np.ndarray,
    forced: int,
    a1: np.ndarray,
    b1: np.ndarray,
    am: np.ndarray,
    bm: np.ndarray,
    kk: np.ndarray,
    ee: np.ndarray,
    ed: np.ndarray,
    cm: np.ndarray,
    bst: np.ndarray,
    force: np.ndarray,
    new_state: np.ndarray,
    work: np.ndarray,
    rhs: np.ndarray,
    trial: np.ndarray,
) -> int:
    """Joint exact mesh solve (Eqs 25-26) of all meshes; returns 1 if it failed, else 0.

    ``delta = a1 + am F``, ``delta' = b1 + bm F``. Active set from ``s_prev`` (as
    ``kernels.mesh_solve``); mesh ``forced`` (>= 0, in contact or in the dead zone) keeps its state
    and force law even slightly past the boundary (the sub-step that ends at its located contact
    change). If the active set does not settle: ``kernels.mesh_solve`` with its exhaustive search.
    """
    nm = s_prev.shape[0]
    fix = -1
    if forced >= 0:
        sf = s_prev[forced]
        if sf == 2 or sf == -2 or sf == 0:
            fix = forced
    for i in range(nm):
        trial[i] = s_prev[i]
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
        if not _solve_small(work, rhs, nm, force):
            break
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
            ns = (
                trial[i]
                if i == fix
                else _natural_state(trial[i], dm, dmd, force[i], cm[i], bst[i], tol_d, tol_f)
            )
            new_state[i] = ns
            if ns != trial[i]:
                settled = False
        if settled:
            return 0
        for i in range(nm):
            trial[i] = new_state[i]
    its = mesh_solve(s_prev, a1, b1, am, bm, kk, cm, ee, ed, bst, new_state, force, work, rhs, trial)
    return 1 if its < 0 else 0


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
def _lerp(a: float, b: float, th: float) -> float:
    return b if th == 1.0 else a + th * (b - a)


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _affine_forces(
    base: np.ndarray,
    resp: tuple,
    beta_prev: np.ndarray,
    beta_new: np.ndarray,
    e0: int,
    coef: np.ndarray,
    mesh_par: np.ndarray,
    mats: tuple,
) -> None:
    """delta, delta' of every mesh at the (sub-)step end as affine functions of the mesh forces F:
    ``delta = a1 + am F``, ``delta' = b1 + bm F`` (Eqs 25-26 are then solved for F).

    ``base`` (2 nm): the part independent of the column amplitudes (free response, static load);
    ``resp`` = (qc, qn, pd, pv): responses of delta (rows 0..nm-1) and delta' (rows nm..2nm-1) to the
    carried amplitudes ``beta_prev`` (qc, all columns) and to the new ones (qn; the effect columns
    from ``e0`` are known, ``beta_new``), and the elimination of the mean-mesh compensation
    ``pd = H_d E^-1``, ``pv = H_v E^-1``. Mesh l's new columns are ``u_l = comp_l - coef_l0 F_l`` and
    ``coef_lj F_l`` (``gd``, ``gv``: their responses per unit F_l), ``comp = kbar delta + cbar delta'``.
    ``mats`` = (a1, b1, am, bm, gd, gv, wv) receive the result (gd, gv, wv work arrays). One copy for
    full steps (several meshes; one mesh has its scalar form in :func:`run_chunk_gear`) and sub-steps.

    Inlined: in the loop compiled without the numba runtime (:func:`_run_loop`) the inlined copies
    cost no reference counting, and the call (its two tuples of arrays passed by value) was 25 % of
    the paper gearbox's step at 20000 rpm (0.330 -> 0.240 us; outputs bit-identical). In session 7,
    with the runtime, inlining it had cost the two-stage rig 21 %.
    """
    qc, qn, pd, pv = resp
    a1, b1, am, bm, gd, gv, wv = mats
    nm = a1.shape[0]
    nb = coef.shape[1]
    na = beta_prev.shape[0]
    for i in range(nm):
        sd = base[i]
        sv = base[nm + i]
        for q in range(na):
            sd += qc[i, q] * beta_prev[q]
            sv += qc[nm + i, q] * beta_prev[q]
        for q in range(e0, na):
            sd += qn[i, q] * beta_new[q]
            sv += qn[nm + i, q] * beta_new[q]
        a1[i] = sd
        b1[i] = sv
        for l in range(nm):
            c = l * nb
            td = -coef[l, 0] * qn[i, c]
            tv = -coef[l, 0] * qn[nm + i, c]
            for j in range(1, nb):
                td += qn[i, c + j] * coef[l, j]
                tv += qn[nm + i, c + j] * coef[l, j]
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
                ww = mesh_par[l, 0] * gd[l, j] + mesh_par[l, 1] * gv[l, j]
                td += pd[i, l] * ww
                tv += pv[i, l] * ww
            am[i, j] = td
            bm[i, j] = tv


# ----------------------------------------------------------------------------------------------
# sub-steps (event steps only)


@njit(cache=True, fastmath=_FM, error_model="numpy", _nrt=False)
def _set_columns(
    i: int, beta: np.ndarray, coef: np.ndarray, fm: float, d: float, dd: float, mesh_par: np.ndarray
) -> None:
    """Amplitudes of mesh i's columns: u = compensation - coef_0 F, friction columns coef_j F.

    Without the numba runtime (no reference counting of its arguments, as :func:`_tables_at`)."""
    nb = coef.shape[1]
    c = i * nb
    beta[c] = mesh_par[i, 0] * d + mesh_par[i, 1] * dd - coef[i, 0] * fm
    for j in range(1, nb):
        beta[c + j] = coef[i, j] * fm


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
    the solver's numbers bit for bit (docs/solver.md, "Session 12").

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


# ----------------------------------------------------------------------------------------------
# the chunk


@njit(cache=True, fastmath=_FM, error_model="numpy", _nrt=False)
def _jump_average_start(
    n: int,
    pha: np.ndarray,
    exc: tuple,
    tables: tuple,
    mesh_par: np.ndarray,
    prev: tuple,
    cur: tuple,
    ja: tuple,
) -> None:
    """``average_jumps``: the tables of the meshes with a jump in step ``n`` replaced by their average
    over the step (``cur``'s ``kk``, ``coef``; the step end's kept in ``jk[0]``, ``jc[0]``), and their
    carried columns by those of the start force with the average (the originals kept in ``jc[2]``).

    ``pha`` the meshes' phases at the step start; ``exc``, ``tables``, ``prev`` (per-mesh state at
    the step start), ``cur`` (end values) as in :func:`_event_step`; ``ja`` = (jc, jk, jm): per mesh
    the step end's coefficients, the weighted sums and the saved carried columns (jc, (3, nm, nb));
    the end stiffness, the average, the jump's fraction and phase (jk, (4, nm)); whether the mesh
    has a jump (jm). A call, not inlined: the step loop's regular path keeps its code (and speed)
    when the option is off; without the numba runtime, its tuples of arrays cost no reference count.
    """
    phase, kfac = exc[0], exc[2]
    d_p, dd_p, e_p, ed_p, f_p, s_p = prev
    kk, coef, beta_prev = cur[0], cur[3], cur[4]
    jc, jk, jm = ja
    has_kfac = kfac.shape[0] > 0
    nm = kk.shape[0]
    nb = coef.shape[1]
    for i in range(nm):
        if jm[i] == 0:
            continue
        th = jk[2, i]
        w1 = 0.5 * th
        w2 = 0.5 * (1.0 - th)
        jk[0, i] = kk[i]  # the step end's, kept for the carried force
        for j in range(nb):
            jc[0, i, j] = coef[i, j]
        # pieces: start -> jump (left limit), jump (right limit) -> end; trapezoid each
        k_ = _tables_at(i, phase[n, i], False, tables, coef)
        ksum = w2 * k_
        for j in range(nb):
            jc[1, i, j] = w2 * k_ * coef[i, j]
        k_ = _tables_at(i, pha[i], False, tables, coef)
        ksum += w1 * k_
        for j in range(nb):
            jc[1, i, j] += w1 * k_ * coef[i, j]
        k_ = _tables_at(i, jk[3, i], True, tables, coef)
        ksum += w1 * k_
        for j in range(nb):
            jc[1, i, j] += w1 * k_ * coef[i, j]
        k_ = _tables_at(i, jk[3, i], False, tables, coef)
        ksum += w2 * k_
        for j in range(nb):
            jc[1, i, j] += w2 * k_ * coef[i, j]
        for j in range(nb):
            coef[i, j] = jc[1, i, j] / ksum
        jk[1, i] = ksum
        ka = ksum * kfac[n - 1, i] if has_kfac else ksum
        fa = _state_force(
            s_p[i], d_p[i] - e_p[i], dd_p[i] - ed_p[i], ka, mesh_par[i, 2], mesh_par[i, 3], f_p[i]
        )
        for j in range(nb):
            jc[2, i, j] = beta_prev[i * nb + j]
        _set_columns(i, beta_prev, coef, fa, d_p[i], dd_p[i], mesh_par)
        kk[i] = ksum * kfac[n, i] if has_kfac else ksum


@njit(cache=True, fastmath=_FM, error_model="numpy", _nrt=False)
def _jump_average_end(mesh_par: np.ndarray, prev: tuple, cur: tuple, ja: tuple) -> None:
    """``average_jumps``: after the step, the end force with the end's own tables (``jk[0]``,
    ``jc[0]``), carried (``prev``'s force and ``cur``'s carried columns) into the next step."""
    d_p, dd_p, e_p, ed_p, f_p, s_p = prev
    kk, coef, beta_prev = cur[0], cur[3], cur[4]
    jc, jk, jm = ja
    nm = kk.shape[0]
    nb = coef.shape[1]
    for i in range(nm):
        if jm[i] == 0:
            continue
        kk[i] = jk[0, i]
        for j in range(nb):
            coef[i, j] = jc[0, i, j]
        fb = _state_force(
            s_p[i], d_p[i] - e_p[i], dd_p[i] - ed_p[i], kk[i], mesh_par[i, 2], mesh_par[i, 3], f_p[i]
        )
        f_p[i] = fb
        _set_columns(i, beta_prev, coef, fb, d_p[i], dd_p[i], mesh_par)


@njit(cache=True, fastmath=_FM, error_model="numpy", _nrt=False)
def _te_sin_cos(phase: np.ndarray, mesh_par: np.ndarray, out: np.ndarray) -> None:
    """sin and cos of the transmission error's argument ``2 pi phase + phi_te`` (Eq 24) for every
    step and mesh of a chunk into ``out`` ``(n + 1, 2 nm)`` (sin columns, then cos), read by the
    regular steps of :func:`_run_loop` (the event sub-steps evaluate them at their own phases).

    A rotation by the phase increment ``x`` from one step to the next (Taylor series of sin x, cos x
    to x^11 / x^10: exact to round-off for ``|x| <= 0.25``), sin/cos directly every
    ``TE_ANCHOR_STEPS`` steps and wherever the increment is larger: 1e-16-level differences from
    sin/cos at every step, at a fraction of their cost (measured: sin/cos at every step were 15 % of
    the paper gearbox's regular step; NumPy's ``np.sin``/``np.cos`` of the chunk cost as much again).
    """
    nm = phase.shape[1]
    two_pi = 2.0 * np.pi
    for i in range(nm):
        sv = 0.0
        cv = 1.0
        for n in range(phase.shape[0]):
            x = 0.0
            if n > 0:
                x = phase[n, i] - phase[n - 1, i]
                if x < 0.0:
                    x += 1.0
                x *= two_pi
            if n % TE_ANCHOR_STEPS == 0 or x > 0.25:
                arg = two_pi * phase[n, i] + mesh_par[i, 5]
                sv = np.sin(arg)
                cv = np.cos(arg)
            else:
                x2 = x * x
                cx = 1.0 + x2 * (-0.5 + x2 * (_C4 + x2 * (_C6 + x2 * (_C8 + x2 * _C10))))
                sx = x * (1.0 + x2 * (_S3 + x2 * (_S5 + x2 * (_S7 + x2 * (_S9 + x2 * _S11)))))
                sn = sv * cx + cv * sx
                cv = cv * cx - sv * sx
                sv = sn
            out[n, i] = sv
            out[n, nm + i] = cv


@njit(cache=True, error_model="numpy", _nrt=True)
def _emit_block(
    hbuf: np.ndarray, hb: int, cstack: np.ndarray, dfeed_static: np.ndarray, out: np.ndarray, o0: int
) -> None:
    """Outputs of ``hb`` buffered steps ``[z_r, z_i, beta]`` by one matrix product (BLAS) into
    ``out[o0 : o0 + hb]``, plus the static feed-through (a call every ``hbuf.shape[0]`` steps)."""
    blk = out[o0 : o0 + hb]
    np.dot(hbuf[:hb], cstack, blk)
    no = cstack.shape[1]
    for r in range(hb):
        for c in range(no):
            blk[r, c] += dfeed_static[c]


@njit(cache=True, error_model="numpy", inline="always")
def _copy_int(src: np.ndarray, dst: np.ndarray) -> None:
    for i in range(src.shape[0]):
        dst[i] = src[i]


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
