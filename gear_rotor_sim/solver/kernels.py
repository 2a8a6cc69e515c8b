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
transition matrix ``T`` instead of the diagonal ``r``.
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


@njit(cache=True, error_model="numpy", inline="always")
def _mesh_solve_one(
    s: int, dm0: float, dmd0: float, am: float, bm: float, k: float, c: float, b: float
) -> tuple[int, float]:
    """One mesh: the consistent contact state and force, by the active set of :func:`mesh_solve`.

    ``delta_m = dm0 + am F``, ``delta_m' = dmd0 + bm F``. The same states, force laws and
    tolerances as ``_solve_states`` / ``_check_states`` for ``nm = 1``; returns state -9 when the
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


@njit(cache=True, fastmath=_FM, error_model="numpy")
def _table(tab: np.ndarray, phase: float) -> tuple[int, int, float]:
    """Periodic linear interpolation indices on the uniform grid ``arange(n) / n``."""
    nt = tab.shape[0]
    x = phase * nt
    i0 = int(np.floor(x))
    f = x - i0
    i0 = i0 % nt
    i1 = i0 + 1
    if i1 == nt:
        i1 = 0
    return i0, i1, f


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _range_dot(cr: np.ndarray, ci: np.ndarray, zr: np.ndarray, zi: np.ndarray, lo: int, hi: int) -> float:
    """``sum_{lo <= j < hi} cr_j zr_j - ci_j zi_j`` over slices (so that the loop vectorises)."""
    a = cr[lo:hi]
    b = ci[lo:hi]
    x = zr[lo:hi]
    y = zi[lo:hi]
    s = 0.0
    for j in range(a.shape[0]):
        s += a[j] * x[j] - b[j] * y[j]
    return s


@njit(cache=True, fastmath=_FM, error_model="numpy", nogil=True)
def run_chunk_one_mesh(
    zr: np.ndarray,
    zi: np.ndarray,
    rr: np.ndarray,
    ri: np.ndarray,
    c0r: np.ndarray,
    c0i: np.ndarray,
    swr: np.ndarray,
    swi: np.ndarray,
    n_forced: int,
    crd_r: np.ndarray,
    crd_i: np.ndarray,
    crv_r: np.ndarray,
    crv_i: np.ndarray,
    pq: np.ndarray,
    pq_static: np.ndarray,
    outr: np.ndarray,
    outi: np.ndarray,
    out_lo: np.ndarray,
    out_hi: np.ndarray,
    dfeed: np.ndarray,
    dfeed_static: np.ndarray,
    tab_k: np.ndarray,
    tab_c: np.ndarray,
    mesh_par: np.ndarray,
    phase: np.ndarray,
    phase_rate: np.ndarray,
    kfac: np.ndarray,
    te_add: np.ndarray,
    ted_add: np.ndarray,
    ampl: np.ndarray,
    beta_prev: np.ndarray,
    ypred: np.ndarray,
    state: np.ndarray,
    bound: float,
    out: np.ndarray,
    dte: np.ndarray,
    dted: np.ndarray,
    fmesh: np.ndarray,
    states: np.ndarray,
    kt_out: np.ndarray,
    et_out: np.ndarray,
    edt_out: np.ndarray,
    coef_out: np.ndarray,
) -> tuple[int, int, int]:
    """Advance ``n = phase.shape[0]`` steps of a system with exactly one mesh (modal map).

    The same exact Newmark map as :func:`run_chunk`, specialised: the mesh stiffness, force
    coefficients and transmission error (Eq 24) are looked up from the tables inside the loop; the
    static load (constant amplitude) is a fixed modal increment ``c0``; the line-of-action column
    ``-V`` and the mean-mesh compensation ``+V`` are one column ``u`` with amplitude
    ``comp - coef_0 F``; the mode loop is fused (update, mesh prediction) and runs the force
    columns only over the first ``n_forced`` modes (the modes a mesh or effect force reaches; the
    rest, e.g. the axial modes, only propagate).

    Active columns (``swr`` rows, ``pq`` columns, ``beta_prev``): 0 = u, 1..nb-1 = friction basis,
    nb.. = effects. ``mesh_par`` = (kbar, cbar, c_m, b*, e0, phi). Outputs as in :func:`run_chunk`, plus
    the per-step stiffness, transmission error, its rate and force coefficients (``*_out``).
    """
    nsteps = phase.shape[0]
    na = beta_prev.shape[0]
    nb = tab_c.shape[1]
    ne = ampl.shape[1]
    no = outr.shape[0]
    nmode = zr.shape[0]
    kbar = mesh_par[0]
    cbar = mesh_par[1]
    cm = mesh_par[2]
    bst = mesh_par[3]
    e0 = mesh_par[4]
    ephi = mesh_par[5]
    has_kfac = kfac.shape[0] > 0
    has_te = te_add.shape[0] > 0
    beta_new = np.zeros(na)
    alpha = np.zeros(na)
    coef = np.zeros(nb)
    # 1-mesh work arrays for the shared active-set solver
    prev_state = np.zeros(1, dtype=np.int64)
    new_state = np.zeros(1, dtype=np.int64)
    trial = np.zeros(1, dtype=np.int64)
    a1 = np.zeros(1)
    b1 = np.zeros(1)
    am = np.zeros((1, 1))
    bm = np.zeros((1, 1))
    kk = np.zeros(1)
    cc = np.zeros(1)
    cc[0] = cm
    ee = np.zeros(1)
    ed = np.zeros(1)
    bb = np.zeros(1)
    bb[0] = bst
    force = np.zeros(1)
    work = np.zeros((1, 1))
    rhs = np.zeros(1)
    prev_state[0] = state[0]
    n_fail = 0
    # comp = kbar delta + cbar delta' responds to its own column u: eliminate once
    h_d = pq[0, 0]
    h_v = pq[1, 0]
    einv = 1.0 / (1.0 - kbar * h_d - cbar * h_v)
    two_pi = 2.0 * np.pi
    zfr = zr[:n_forced]
    zfi = zi[:n_forced]
    zur = zr[n_forced:]
    zui = zi[n_forced:]
    n_unforced = nmode - n_forced
    rfr = rr[:n_forced]
    rfi = ri[:n_forced]
    rur = rr[n_forced:]
    rui = ri[n_forced:]
    c0fr = c0r[:n_forced]
    c0fi = c0i[:n_forced]
    c0ur = c0r[n_forced:]
    c0ui = c0i[n_forced:]
    na_mesh = nb  # active mesh columns (u and the friction columns); at most 4 (Eq 29)
    zero = np.zeros(n_forced)
    s0r = swr[0, :n_forced]
    s0i = swi[0, :n_forced]
    s1r = swr[1, :n_forced] if nb > 1 else zero
    s1i = swi[1, :n_forced] if nb > 1 else zero
    s2r = swr[2, :n_forced] if nb > 2 else zero
    s2i = swi[2, :n_forced] if nb > 2 else zero
    s3r = swr[3, :n_forced] if nb > 3 else zero
    s3i = swi[3, :n_forced] if nb > 3 else zero
    cdr = crd_r[:n_forced]
    cdi = crd_i[:n_forced]
    cvr = crv_r[:n_forced]
    cvi = crv_i[:n_forced]
    for n in range(nsteps):
        ph = phase[n]
        i0, i1, f = _table(tab_k, ph)
        k = tab_k[i0] + f * (tab_k[i1] - tab_k[i0])
        if has_kfac:
            k *= kfac[n]
        for j in range(nb):
            coef[j] = tab_c[i0, j] + f * (tab_c[i1, j] - tab_c[i0, j])
        arg = two_pi * ph + ephi
        e = e0 * np.sin(arg)
        ed_ = e0 * np.cos(arg) * two_pi * phase_rate[n]
        if has_te:
            e += te_add[n]
            ed_ += ted_add[n]
        for q in range(ne):
            beta_new[nb + q] = ampl[n, q]
        if not (np.isfinite(k) and np.isfinite(e) and np.isfinite(ed_)):
            state[0] = prev_state[0]
            return STATUS_NONFINITE, n, n_fail
        # delta, delta' at n+1 = prediction + known columns + response to the unknowns
        ad = ypred[0] + pq_static[0]
        av = ypred[1] + pq_static[1]
        for q in range(na):
            bq = beta_prev[q]
            ad += pq[0, q] * bq
            av += pq[1, q] * bq
        for q in range(ne):
            ad += pq[0, nb + q] * beta_new[nb + q]
            av += pq[1, nb + q] * beta_new[nb + q]
        gd = -coef[0] * pq[0, 0]
        gv = -coef[0] * pq[1, 0]
        for j in range(1, nb):
            gd += pq[0, j] * coef[j]
            gv += pq[1, j] * coef[j]
        pcomp = (kbar * ad + cbar * av) * einv
        qcomp = (kbar * gd + cbar * gv) * einv
        a1[0] = ad + h_d * pcomp
        b1[0] = av + h_v * pcomp
        am[0, 0] = gd + h_d * qcomp
        bm[0, 0] = gv + h_v * qcomp
        ns1, fm = _mesh_solve_one(prev_state[0], a1[0] - e, b1[0] - ed_, am[0, 0], bm[0, 0], k, cm, bst)
        if ns1 != -9:
            new_state[0] = ns1
        else:  # rare: exhaustive search of the general solver
            kk[0] = k
            ee[0] = e
            ed[0] = ed_
            its = mesh_solve(
                prev_state, a1, b1, am, bm, kk, cc, ee, ed, bb, new_state, force, work, rhs, trial
            )
            if its < 0:
                n_fail += 1
            fm = force[0]
        d = a1[0] + am[0, 0] * fm
        dd = b1[0] + bm[0, 0] * fm
        if not (np.isfinite(d) and np.isfinite(fm)):
            state[0] = prev_state[0]
            return STATUS_NONFINITE, n, n_fail
        if abs(d) >= bound:
            state[0] = prev_state[0]
            return STATUS_BOUND, n, n_fail
        dte[n, 0] = d
        dted[n, 0] = dd
        fmesh[n, 0] = fm
        states[n, 0] = new_state[0]
        kt_out[n] = k
        et_out[n] = e
        edt_out[n] = ed_
        for j in range(nb):
            coef_out[n, j] = coef[j]
        prev_state[0] = new_state[0]
        beta_new[0] = kbar * d + cbar * dd - coef[0] * fm
        for j in range(1, nb):
            beta_new[j] = coef[j] * fm
        for q in range(na):
            alpha[q] = beta_prev[q] + beta_new[q]
        # modal update z <- r z + c0 + sum_q sw_q alpha_q and the mesh prediction, in one pass over
        # the forced modes with the four mesh columns unrolled (loops run over slices from 0: LLVM
        # does not vectorise loops with run-time start offsets), then the unforced modes
        a0 = alpha[0]
        a1_ = alpha[1] if na_mesh > 1 else 0.0
        a2_ = alpha[2] if na_mesh > 2 else 0.0
        a3_ = alpha[3] if na_mesh > 3 else 0.0
        yd = 0.0
        yv = 0.0
        for j in range(n_forced):
            xr = zfr[j]
            xi = zfi[j]
            tr = (
                rfr[j] * xr - rfi[j] * xi + c0fr[j] + s0r[j] * a0 + s1r[j] * a1_ + s2r[j] * a2_ + s3r[j] * a3_
            )
            ti = (
                rfr[j] * xi + rfi[j] * xr + c0fi[j] + s0i[j] * a0 + s1i[j] * a1_ + s2i[j] * a2_ + s3i[j] * a3_
            )
            zfr[j] = tr
            zfi[j] = ti
            yd += cdr[j] * tr - cdi[j] * ti
            yv += cvr[j] * tr - cvi[j] * ti
        for q in range(na_mesh, na):  # effect columns
            aq = alpha[q]
            if aq != 0.0:
                sr = swr[q, :n_forced]
                si = swi[q, :n_forced]
                for j in range(n_forced):
                    zfr[j] += sr[j] * aq
                    zfi[j] += si[j] * aq
                    yd += (cdr[j] * sr[j] - cdi[j] * si[j]) * aq
                    yv += (cvr[j] * sr[j] - cvi[j] * si[j]) * aq
        for j in range(n_unforced):
            xr = zur[j]
            xi = zui[j]
            zur[j] = rur[j] * xr - rui[j] * xi + c0ur[j]
            zui[j] = rur[j] * xi + rui[j] * xr + c0ui[j]
        ypred[0] = yd
        ypred[1] = yv
        for o in range(no):
            s0 = _range_dot(outr[o], outi[o], zr, zi, out_lo[o], out_hi[o]) + dfeed_static[o]
            for q in range(na):
                s0 += dfeed[o, q] * beta_new[q]
            out[n, o] = s0
        for q in range(na):
            beta_prev[q] = beta_new[q]
        if not np.isfinite(yd):
            state[0] = prev_state[0]
            return STATUS_NONFINITE, n, n_fail
    state[0] = prev_state[0]
    return STATUS_OK, nsteps, n_fail
