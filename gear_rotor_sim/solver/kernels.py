"""Compiled per-step kernels of the exact modal Newmark map (numba, no Python objects inside).

Newmark average acceleration on ``M q'' + D q' + K_lin q = g(t)`` equals the trapezoidal rule on
the state ``x = [q; v]``. In the eigenbasis ``x = Re(Phi z)`` of the state matrix each step is

``z_{n+1} = r * z_n + SW @ alpha_n``,  ``alpha_n = beta_n + beta_{n+1}``,

with ``r_j = (1 + h lam_j / 2) / (1 - h lam_j / 2)``, ``SW[k, j] = s_j (Phi^-1 B f_k)_j`` and
``beta`` the scalar amplitudes of the fixed generalised force columns ``f_k`` (static load, mesh
force basis columns times ``F_m``, the mean-mesh compensation ``V^T (k_mean delta + c_m delta')`` and
effect columns). The mesh forces at ``n+1`` enter linearly, so ``delta`` and ``delta'`` at ``n+1`` are
affine in them and the piecewise-linear mesh law (Eqs 25-26) is solved exactly by an active set.

Mesh contact states (Eq 26 plus the set-valued closure at the boundary, see docs/solver.md):
``+2`` drive-side contact (delta_m > b*), ``+1`` pinned at delta_m = +b*, ``0`` dead zone,
``-1`` pinned at delta_m = -b*, ``-2`` back-side contact (delta_m < -b*).

The dense fallback (defective or ill-conditioned eigenbasis) runs the same map with a real
transition matrix ``T`` instead of the diagonal ``r``. This module holds the general kernel
:func:`run_chunk` (any number of meshes, per-step arrays) and the mesh solve shared with the
gear kernel in :mod:`gear_rotor_sim.solver.gear_kernel`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_FM = {"reassoc", "contract", "arcp", "nsz"}

STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_BOUND = 2


@njit(cache=True, error_model="numpy")
def _solve_small(a: np.ndarray, rhs: np.ndarray, n: int, out: np.ndarray) -> bool:
    """Gaussian elimination with partial pivoting on the leading n x n block (a, rhs modified)."""
    for c in range(n):
        p = c
        best = abs(a[c, c])
        for r in range(c + 1, n):
            if abs(a[r, c]) > best:
                best = abs(a[r, c])
                p = r
        if best == 0.0:
            return False
        if p != c:
            for j in range(n):
                tmp = a[c, j]
                a[c, j] = a[p, j]
                a[p, j] = tmp
            tmp = rhs[c]
            rhs[c] = rhs[p]
            rhs[p] = tmp
        for r in range(c + 1, n):
            f = a[r, c] / a[c, c]
            for j in range(c, n):
                a[r, j] -= f * a[c, j]
            rhs[r] -= f * rhs[c]
    for c in range(n - 1, -1, -1):
        s = rhs[c]
        for j in range(c + 1, n):
            s -= a[c, j] * out[j]
        out[c] = s / a[c, c]
    return True


@njit(cache=True, error_model="numpy")
def _solve_states(
    state: np.ndarray,
    a1: np.ndarray,
    b1: np.ndarray,
    am: np.ndarray,
    bm: np.ndarray,
    kk: np.ndarray,
    cc: np.ndarray,
    ee: np.ndarray,
    ed: np.ndarray,
    bb: np.ndarray,
    work: np.ndarray,
    rhs: np.ndarray,
    force: np.ndarray,
) -> None:
    """Mesh forces for given contact states: delta = a1 + am F, delta' = b1 + bm F."""
    nm = state.shape[0]
    for i in range(nm):
        s = state[i]
        for j in range(nm):
            work[i, j] = 0.0
        if s == 2 or s == -2:
            sg = 1.0 if s == 2 else -1.0
            for j in range(nm):
                work[i, j] = -kk[i] * am[i, j] - cc[i] * bm[i, j]
            work[i, i] += 1.0
            rhs[i] = kk[i] * (a1[i] - ee[i] - sg * bb[i]) + cc[i] * (b1[i] - ed[i])
        elif s == 0:
            work[i, i] = 1.0
            rhs[i] = 0.0
        else:
            sg = 1.0 if s == 1 else -1.0
            for j in range(nm):
                work[i, j] = am[i, j]
            rhs[i] = ee[i] + sg * bb[i] - a1[i]
    ok = _solve_small(work, rhs, nm, force)
    if not ok:
        for i in range(nm):
            force[i] = np.nan


@njit(cache=True, error_model="numpy")
def _natural_state(
    s: int, dm: float, dmd: float, f: float, c: float, b: float, tol_d: float, tol_f: float
) -> int:
    """The state a mesh should be in given its solution under state s (s itself if consistent)."""
    if s == 2:
        return 2 if dm > b - tol_d else 1
    if s == -2:
        return -2 if dm < -b + tol_d else -1
    if s == 0:
        if dm > b + tol_d:
            return 1
        if dm < -b - tol_d:
            return -1
        return 0
    # pinned at +-b: the force must lie in the hull of {0, c delta_m'} (set-valued Eq 25 at |delta_m| = b)
    hi = max(0.0, c * dmd)
    lo = min(0.0, c * dmd)
    if s == 1:
        if f > hi + tol_f:
            return 2
        if f < lo - tol_f:
            return 0
        return 1
    if f < lo - tol_f:
        return -2
    if f > hi + tol_f:
        return 0
    return -1


_MAX_ACTIVE_SET_ITER = 40


@njit(cache=True, error_model="numpy")
def _check_states(
    trial: np.ndarray,
    a1: np.ndarray,
    b1: np.ndarray,
    am: np.ndarray,
    bm: np.ndarray,
    cc: np.ndarray,
    ee: np.ndarray,
    ed: np.ndarray,
    bb: np.ndarray,
    force: np.ndarray,
    new_state: np.ndarray,
) -> bool:
    nm = trial.shape[0]
    ok = True
    for i in range(nm):
        d = a1[i]
        dd = b1[i]
        for j in range(nm):
            d += am[i, j] * force[j]
            dd += bm[i, j] * force[j]
        dm = d - ee[i]
        dmd = dd - ed[i]
        tol_d = 1e-12 * (abs(bb[i]) + abs(dm)) + 1e-20
        tol_f = 1e-12 * (abs(force[i]) + abs(cc[i] * dmd)) + 1e-20
        ns = _natural_state(trial[i], dm, dmd, force[i], cc[i], bb[i], tol_d, tol_f)
        new_state[i] = ns
        if ns != trial[i]:
            ok = False
    return ok


@njit(cache=True, error_model="numpy")
def mesh_solve(
    prev_state: np.ndarray,
    a1: np.ndarray,
    b1: np.ndarray,
    am: np.ndarray,
    bm: np.ndarray,
    kk: np.ndarray,
    cc: np.ndarray,
    ee: np.ndarray,
    ed: np.ndarray,
    bb: np.ndarray,
    new_state: np.ndarray,
    force: np.ndarray,
    work: np.ndarray,
    rhs: np.ndarray,
    trial: np.ndarray,
) -> int:
    """Exact piecewise-linear mesh solve (Eqs 25-26) by active set; returns iterations or -1.

    Starts from the previous step's states and moves each inconsistent mesh to the state its
    solution points to; if that does not settle within a fixed number of iterations, all ``5**nm``
    state combinations are tried in a fixed order. ``new_state`` receives the consistent states.
    """
    nm = prev_state.shape[0]
    for i in range(nm):
        trial[i] = prev_state[i]
    for it in range(_MAX_ACTIVE_SET_ITER):
        _solve_states(trial, a1, b1, am, bm, kk, cc, ee, ed, bb, work, rhs, force)
        if _check_states(trial, a1, b1, am, bm, cc, ee, ed, bb, force, new_state):
            return it
        for i in range(nm):
            trial[i] = new_state[i]
    order = np.array([2, 0, -2, 1, -1], dtype=np.int64)
    n_comb = 5**nm
    for code0 in range(n_comb):
        code = code0
        for i in range(nm):
            trial[i] = order[code % 5]
            code //= 5
        _solve_states(trial, a1, b1, am, bm, kk, cc, ee, ed, bb, work, rhs, force)
        if _check_states(trial, a1, b1, am, bm, cc, ee, ed, bb, force, new_state):
            for i in range(nm):
                new_state[i] = trial[i]
            return _MAX_ACTIVE_SET_ITER + code0
    for i in range(nm):
        new_state[i] = trial[i]
    return -1


@njit(cache=True, fastmath=_FM, error_model="numpy")
def _modal_update(
    zr: np.ndarray,
    zi: np.ndarray,
    rr: np.ndarray,
    ri: np.ndarray,
    swr: np.ndarray,
    swi: np.ndarray,
    alpha: np.ndarray,
) -> None:
    nmode = zr.shape[0]
    for j in range(nmode):
        tr = rr[j] * zr[j] - ri[j] * zi[j]
        ti = rr[j] * zi[j] + ri[j] * zr[j]
        zr[j] = tr
        zi[j] = ti
    for k in range(alpha.shape[0]):
        a = alpha[k]
        if a != 0.0:
            for j in range(nmode):
                zr[j] += swr[k, j] * a
                zi[j] += swi[k, j] * a


@njit(cache=True, fastmath=_FM, error_model="numpy")
def _dense_update(
    z: np.ndarray, tmat: np.ndarray, sw: np.ndarray, alpha: np.ndarray, tmp: np.ndarray
) -> None:
    n = z.shape[0]
    for i in range(n):
        tmp[i] = 0.0
    for j in range(n):  # tmat is column-major in memory (passed as tmat.T contiguous rows)
        zj = z[j]
        for i in range(n):
            tmp[i] += tmat[j, i] * zj
    for k in range(alpha.shape[0]):
        a = alpha[k]
        if a != 0.0:
            for i in range(n):
                tmp[i] += sw[k, i] * a
    for i in range(n):
        z[i] = tmp[i]


@njit(cache=True, error_model="numpy", nogil=True)
def modal_to_physical(
    phr: np.ndarray, phi: np.ndarray, zr: np.ndarray, zi: np.ndarray, rest: np.ndarray, beta: np.ndarray
) -> np.ndarray:
    """Physical state ``x = Re(Phi z) + R beta`` (Eq 39's modal back-transformation plus, with a reduced
    basis, the dropped modes' static part) by plain loops.

    ``phr``, ``phi`` (nk, N): real and imaginary parts of ``Phi^T``; ``rest`` (m, N): ``R^T`` ((0, N)
    without reduction). Once per chunk: a threaded BLAS call here measured 21-25 ms per call on a loaded
    2-core machine against about 0.5 ms for the whole single-mesh chunk (docs/solver.md).
    """
    n = phr.shape[1]
    x = np.zeros(n)
    for j in range(phr.shape[0]):
        a = zr[j]
        b = zi[j]
        for i in range(n):
            x[i] += phr[j, i] * a - phi[j, i] * b
    for k in range(rest.shape[0]):
        c = beta[k]
        if c != 0.0:
            for i in range(n):
                x[i] += rest[k, i] * c
    return x


@njit(cache=True, fastmath=_FM, error_model="numpy")
def _rows_dot(cr: np.ndarray, ci: np.ndarray, zr: np.ndarray, zi: np.ndarray, o: int) -> float:
    s = 0.0
    for j in range(zr.shape[0]):
        s += cr[o, j] * zr[j] - ci[o, j] * zi[j]
    return s


@njit(cache=True, fastmath=_FM, error_model="numpy", nogil=True)
def run_chunk(
    dense: bool,
    zr: np.ndarray,
    zi: np.ndarray,
    rr: np.ndarray,
    ri: np.ndarray,
    tmat: np.ndarray,
    swr: np.ndarray,
    swi: np.ndarray,
    crr: np.ndarray,
    cri: np.ndarray,
    pq: np.ndarray,
    outr: np.ndarray,
    outi: np.ndarray,
    dfeed: np.ndarray,
    col_basis: np.ndarray,
    col_comp: np.ndarray,
    col_eff0: int,
    kbar: np.ndarray,
    cbar: np.ndarray,
    cmesh: np.ndarray,
    bstar: np.ndarray,
    beta_prev: np.ndarray,
    ypred: np.ndarray,
    state: np.ndarray,
    kt: np.ndarray,
    et: np.ndarray,
    edt: np.ndarray,
    coef: np.ndarray,
    ampl: np.ndarray,
    bound: float,
    out: np.ndarray,
    dte: np.ndarray,
    dted: np.ndarray,
    fmesh: np.ndarray,
    states: np.ndarray,
) -> tuple[int, int, int]:
    """Advance ``n = kt.shape[0]`` steps in place.

    Parameters
    ----------
    dense : bool
        False: modal map (``zr``, ``zi``, ``rr``, ``ri``); True: dense real map ``z <- T z + ...``
        with ``tmat`` holding ``T`` transposed (``zi`` unused).
    swr, swi : (m, nmode)
        ``s_j (Phi^-1 B f_k)_j`` per force column k.
    crr, cri : (2 nm, nmode)
        Mesh rows ``(V Phi)_j r_j`` for delta (rows 0..nm-1) and delta' (rows nm..2nm-1), so the
        prediction at step n+1 is ``Re(CR . z_n)``.
    pq : (2 nm, m)
        ``Re((V Phi) . SW[k])``: response of delta, delta' at n+1 to ``alpha_k``.
    outr, outi, dfeed : (no, nmode), (no, m)
        Output rows ``y = Re(C . z_{n+1}) + dfeed @ beta_{n+1}``.
    col_basis : (nm, nb)
        Force-column index of each mesh's basis column (-1 if absent); ``col_comp`` (nm,) the
        compensation column. Column 0 is the static load; effect columns start at ``col_eff0``.
    beta_prev, ypred, state
        Carried state (modified in place): force amplitudes at step n, mesh predictions, contact states.
    kt, et, edt : (n, nm)
        Mesh stiffness, transmission error and its time derivative at the new step.
    coef : (n, nm, nb)
        Mesh force basis coefficients at the new step; ``ampl`` (n, ne) effect force amplitudes.
    out, dte, dted, fmesh, states
        Results per step (n, no), (n, nm), (n, nm), (n, nm), (n, nm).

    Returns
    -------
    (status, step, n_failed_mesh_solves)
    """
    nsteps = kt.shape[0]
    nm = kt.shape[1]
    nb = coef.shape[2]
    m = beta_prev.shape[0]
    ne = ampl.shape[1]
    no = outr.shape[0]
    nmode = zr.shape[0]
    beta_new = np.zeros(m)
    alpha = np.zeros(m)
    a1 = np.zeros(nm)
    b1 = np.zeros(nm)
    aF = np.zeros((nm, nm))
    bF = np.zeros((nm, nm))
    am = np.zeros((nm, nm))
    bm = np.zeros((nm, nm))
    ac = np.zeros((nm, nm))
    bc = np.zeros((nm, nm))
    einv = np.zeros((nm, nm))
    work = np.zeros((max(nm, 1), max(nm, 1)))
    rhs = np.zeros(max(nm, 1))
    trial = np.zeros(nm, dtype=np.int64)
    new_state = np.zeros(nm, dtype=np.int64)
    force = np.zeros(nm)
    comp = np.zeros(nm)
    tmp = np.zeros(nmode)
    ca = np.zeros(nm)
    cb = np.zeros(nm)
    prev_state = np.zeros(nm, dtype=np.int64)
    for i in range(nm):
        prev_state[i] = state[i]
    n_fail = 0
    # compensation response (constant): delta = ... + ac @ comp, delta' = ... + bc @ comp
    for i in range(nm):
        for l in range(nm):
            ac[i, l] = pq[i, col_comp[l]]
            bc[i, l] = pq[nm + i, col_comp[l]]
    # E = I - Kbar ac - Cbar bc ; einv = E^-1 (column by column)
    emat = np.zeros((max(nm, 1), max(nm, 1)))
    col = np.zeros(max(nm, 1))
    ecol = np.zeros(max(nm, 1))
    for l in range(nm):
        for i in range(nm):
            for j in range(nm):
                emat[i, j] = -kbar[i] * ac[i, j] - cbar[i] * bc[i, j]
            emat[i, i] += 1.0
            ecol[i] = 1.0 if i == l else 0.0
        _solve_small(emat, ecol, nm, col)
        for i in range(nm):
            einv[i, l] = col[i]
    for n in range(nsteps):
        # known part of the new force amplitudes
        for k in range(m):
            beta_new[k] = 0.0
        beta_new[0] = 1.0
        for e in range(ne):
            beta_new[col_eff0 + e] = ampl[n, e]
            if not np.isfinite(ampl[n, e]):
                return STATUS_NONFINITE, n, n_fail
        for i in range(nm):
            if not (np.isfinite(kt[n, i]) and np.isfinite(et[n, i]) and np.isfinite(edt[n, i])):
                return STATUS_NONFINITE, n, n_fail
        # delta, delta' at n+1 = prediction + response to alpha (known part) + response to unknowns
        for i in range(nm):
            sa = ypred[i]
            sb = ypred[nm + i]
            for k in range(m):
                sa += pq[i, k] * (beta_prev[k] + beta_new[k])
                sb += pq[nm + i, k] * (beta_prev[k] + beta_new[k])
            a1[i] = sa
            b1[i] = sb
            for l in range(nm):
                fa = 0.0
                fb = 0.0
                for j in range(nb):
                    c = col_basis[l, j]
                    if c >= 0:
                        fa += pq[i, c] * coef[n, l, j]
                        fb += pq[nm + i, c] * coef[n, l, j]
                aF[i, l] = fa
                bF[i, l] = fb
        # eliminate comp = Kbar delta + Cbar delta' :  comp = einv (Kbar a1 + Cbar b1 + (Kbar aF + Cbar bF) F)
        for i in range(nm):
            ca[i] = kbar[i] * a1[i] + cbar[i] * b1[i]
        for i in range(nm):
            s0 = 0.0
            for l in range(nm):
                s0 += einv[i, l] * ca[l]
            cb[i] = s0
        # delta = a1 + ac cb + (aF + ac einv (Kbar aF + Cbar bF)) F
        for i in range(nm):
            s0 = a1[i]
            s1 = b1[i]
            for l in range(nm):
                s0 += ac[i, l] * cb[l]
                s1 += bc[i, l] * cb[l]
            for j in range(nm):
                ga = aF[i, j]
                gb = bF[i, j]
                for l in range(nm):
                    t = 0.0
                    for q in range(nm):
                        t += einv[l, q] * (kbar[q] * aF[q, j] + cbar[q] * bF[q, j])
                    ga += ac[i, l] * t
                    gb += bc[i, l] * t
                am[i, j] = ga
                bm[i, j] = gb
            ca[i] = s0
            b1[i] = s1
        for i in range(nm):
            a1[i] = ca[i]
        if nm > 0:
            its = mesh_solve(
                prev_state,
                a1,
                b1,
                am,
                bm,
                kt[n],
                cmesh,
                et[n],
                edt[n],
                bstar,
                new_state,
                force,
                work,
                rhs,
                trial,
            )
            if its < 0:
                n_fail += 1
        for i in range(nm):
            d = a1[i]
            dd = b1[i]
            for j in range(nm):
                d += am[i, j] * force[j]
                dd += bm[i, j] * force[j]
            dte[n, i] = d
            dted[n, i] = dd
            fmesh[n, i] = force[i]
            states[n, i] = new_state[i]
            prev_state[i] = new_state[i]
            comp[i] = kbar[i] * d + cbar[i] * dd
            if not (np.isfinite(d) and np.isfinite(force[i])):
                return STATUS_NONFINITE, n, n_fail
            if abs(d) >= bound:
                return STATUS_BOUND, n, n_fail
        for l in range(nm):
            for j in range(nb):
                c = col_basis[l, j]
                if c >= 0:
                    beta_new[c] = coef[n, l, j] * force[l]
            beta_new[col_comp[l]] = comp[l]
        for k in range(m):
            alpha[k] = beta_prev[k] + beta_new[k]
        if dense:
            _dense_update(zr, tmat, swr, alpha, tmp)
        else:
            _modal_update(zr, zi, rr, ri, swr, swi, alpha)
        for o in range(2 * nm):
            ypred[o] = _rows_dot(crr, cri, zr, zi, o)
        for o in range(no):
            s0 = _rows_dot(outr, outi, zr, zi, o)
            for k in range(m):
                s0 += dfeed[o, k] * beta_new[k]
            out[n, o] = s0
        for k in range(m):
            beta_prev[k] = beta_new[k]
        if not np.isfinite(zr[0]) or (no > 0 and not np.isfinite(out[n, 0])):
            for l in range(nm):
                state[l] = prev_state[l]
            return STATUS_NONFINITE, n, n_fail
    for l in range(nm):
        state[l] = prev_state[l]
    return STATUS_OK, nsteps, n_fail
