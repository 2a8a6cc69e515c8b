"""The mesh law of the gear kernel (numba): the exact mesh solve of Eqs 25-26 for one, two and any
number of meshes, delta and delta' affine in the mesh forces, and the mesh columns' amplitudes.

Part of the gear kernel (:mod:`.gear_kernel`; docs/solver.md, "Module layout", "Mesh law").
"""

from __future__ import annotations

import numpy as np
from numba import njit

from gear_rotor_sim.solver.kernels import (
    _FM,
    _MAX_ACTIVE_SET_ITER,
    _natural_state,
    _solve_small,
    mesh_solve,
)


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
