"""Compiled kernel of the single-mesh fast path, with mesh events located inside steps (numba).

:func:`run_chunk_one_mesh` advances the exact modal Newmark map of :mod:`.kernels` for a system with
exactly one mesh whose stiffness, force coefficients and transmission error are looked up from
tables inside the loop, and outputs formed by blocks of matrix products. With ``locate`` a step that
contains a table jump (tooth-pair change, pitch point) or a contact change is integrated as Newmark
sub-steps split at the event (:func:`_event_step`; docs/solver.md, "Events inside a step").
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


@njit(cache=True, error_model="numpy")
def _mesh_fallback(
    s_prev: int,
    a1v: float,
    b1v: float,
    amv: float,
    bmv: float,
    k: float,
    e: float,
    ed_: float,
    cm: float,
    bst: float,
) -> tuple[int, float, int]:
    """One mesh through the general active-set solver (exhaustive search as last resort)."""
    prev_state = np.full(1, s_prev, dtype=np.int64)
    new_state = np.zeros(1, dtype=np.int64)
    trial = np.zeros(1, dtype=np.int64)
    a1 = np.full(1, a1v)
    b1 = np.full(1, b1v)
    am = np.full((1, 1), amv)
    bm = np.full((1, 1), bmv)
    force = np.zeros(1)  # receives the force of the consistent state
    its = mesh_solve(
        prev_state,
        a1,
        b1,
        am,
        bm,
        np.full(1, k),
        np.full(1, cm),
        np.full(1, e),
        np.full(1, ed_),
        np.full(1, bst),
        new_state,
        force,
        np.zeros((1, 1)),
        np.zeros(1),
        trial,
    )
    return new_state[0], force[0], 1 if its < 0 else 0


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _tables_at(
    f: float,
    strict: bool,
    tab_kf: np.ndarray,
    tab_cf: np.ndarray,
    jflag: np.ndarray,
    tab_k: np.ndarray,
    tab_c: np.ndarray,
    jump_p: np.ndarray,
    jump_k: np.ndarray,
    jump_c: np.ndarray,
    coef: np.ndarray,
) -> float:
    """Mesh stiffness (returned) and force coefficients (into ``coef``) at cycle fraction ``f`` in [0, 1].

    On a table interval without a jump (``jflag == 0``) the full tables ``tab_kf``, ``tab_cf`` are
    interpolated linearly; otherwise, and for ``strict`` (the left limit at a jump phase; at the
    period wrap ``f = 1``), the continuous parts ``tab_k``, ``tab_c`` plus the jumps through the
    periodic steps ``[f >= p] - f`` (``newmark.split_table_jumps``). Right-continuous.
    """
    nt = tab_k.shape[0]
    x = f * nt
    i0 = int(np.floor(x))
    fr = x - i0
    i0 = i0 % nt
    i1 = i0 + 1
    if i1 == nt:
        i1 = 0
    nb = coef.shape[0]
    if jflag[i0] == 0 and not strict:
        for j in range(nb):
            coef[j] = tab_cf[i0, j] + fr * (tab_cf[i1, j] - tab_cf[i0, j])
        return tab_kf[i0] + fr * (tab_kf[i1] - tab_kf[i0])
    k = tab_k[i0] + fr * (tab_k[i1] - tab_k[i0])
    for j in range(nb):
        coef[j] = tab_c[i0, j] + fr * (tab_c[i1, j] - tab_c[i0, j])
    for q in range(jump_p.shape[0]):
        p = jump_p[q]
        saw = (1.0 if (f > p or (f == p and not strict)) else 0.0) - f
        k += jump_k[q] * saw
        for j in range(nb):
            coef[j] += jump_c[q, j] * saw
    return k


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _lerp(a: float, b: float, th: float) -> float:
    return b if th == 1.0 else a + th * (b - a)


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _excite(
    n: int,
    th: float,
    phi: float,
    fe: float,
    strict: bool,
    phase_rate: np.ndarray,
    tab_kf: np.ndarray,
    tab_cf: np.ndarray,
    jflag: np.ndarray,
    tab_k: np.ndarray,
    tab_c: np.ndarray,
    jump_p: np.ndarray,
    jump_k: np.ndarray,
    jump_c: np.ndarray,
    mesh_par: np.ndarray,
    kfac: np.ndarray,
    te_add: np.ndarray,
    ted_add: np.ndarray,
    ampl: np.ndarray,
    coef: np.ndarray,
    beta_new: np.ndarray,
) -> tuple[float, float, float]:
    """Mesh stiffness, TE and its rate (Eq 24) at fraction ``th`` of step n-1 -> n (phase ``phi``).

    ``fe`` >= 0: the tables are read at that exact cycle fraction (a jump; ``strict`` = left limit).
    Effect inputs are interpolated linearly between the grid steps. Fills ``coef`` and the effect
    amplitudes of ``beta_new``.
    """
    f = fe if fe >= 0.0 else phi - np.floor(phi)
    k = _tables_at(f, strict, tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k, jump_c, coef)
    if kfac.shape[0] > 0:
        k *= _lerp(kfac[n - 1], kfac[n], th)
    arg = 2.0 * np.pi * phi + mesh_par[5]
    e = mesh_par[4] * np.sin(arg)
    ed_ = mesh_par[4] * np.cos(arg) * 2.0 * np.pi * _lerp(phase_rate[n - 1], phase_rate[n], th)
    if te_add.shape[0] > 0:
        e += _lerp(te_add[n - 1], te_add[n], th)
        ed_ += _lerp(ted_add[n - 1], ted_add[n], th)
    nb = coef.shape[0]
    for q in range(ampl.shape[1]):
        beta_new[nb + q] = _lerp(ampl[n - 1, q], ampl[n, q], th)
    return k, e, ed_


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _mesh_step(
    ypd: float,
    ypv: float,
    psd: float,
    psv: float,
    pq: np.ndarray,
    beta_prev: np.ndarray,
    beta_new: np.ndarray,
    coef: np.ndarray,
    k: float,
    e: float,
    ed_: float,
    mesh_par: np.ndarray,
    s_prev: int,
    forced: bool,
    einv: float,
) -> tuple[int, float, float, float, int]:
    """Exact mesh solve of one (sub)step (Eqs 25-26): state, force, delta, delta' at its end, failure.

    ``delta = ypd + psd + pq[0] . (beta_prev + beta_new)`` (and ``delta'`` with row 1), where the new
    amplitudes of the mesh columns depend on the unknown force and on delta, delta' themselves (the
    mean-mesh compensation column, eliminated here). ``forced``: keep the contact state ``s_prev``
    (contact or dead zone) and apply its force law even slightly past the boundary (the sub-step that
    ends at a located contact change; ending it in the boundary state instead would add a spurious
    constraint impulse of order c_m delta_m' dt).
    """
    kbar = mesh_par[0]
    cbar = mesh_par[1]
    na = beta_prev.shape[0]
    nb = coef.shape[0]
    ad = ypd + psd
    av = ypv + psv
    for q in range(na):
        ad += pq[0, q] * beta_prev[q]
        av += pq[1, q] * beta_prev[q]
    for q in range(nb, na):
        ad += pq[0, q] * beta_new[q]
        av += pq[1, q] * beta_new[q]
    h_d = pq[0, 0]
    h_v = pq[1, 0]
    gd = -coef[0] * h_d
    gv = -coef[0] * h_v
    for j in range(1, nb):
        gd += pq[0, j] * coef[j]
        gv += pq[1, j] * coef[j]
    if einv == 0.0:  # not precomputed (sub-steps): eliminate the compensation column here
        einv = 1.0 / (1.0 - kbar * h_d - cbar * h_v)
    pcomp = (kbar * ad + cbar * av) * einv
    qcomp = (kbar * gd + cbar * gv) * einv
    a1 = ad + h_d * pcomp
    b1 = av + h_v * pcomp
    am = gd + h_d * qcomp
    bm = gv + h_v * qcomp
    if forced and (s_prev == 2 or s_prev == -2 or s_prev == 0):
        if s_prev == 0:
            fm = 0.0
        else:
            sg = 1.0 if s_prev == 2 else -1.0
            cm = mesh_par[2]
            fm = (k * (a1 - e - sg * mesh_par[3]) + cm * (b1 - ed_)) / (1.0 - k * am - cm * bm)  # Eq 25
        return s_prev, fm, a1 + am * fm, b1 + bm * fm, 0
    ns, fm = _mesh_solve_one(s_prev, a1 - e, b1 - ed_, am, bm, k, mesh_par[2], mesh_par[3])
    fail = 0
    if ns == -9:  # rare: the general solver with its exhaustive search
        ns, fm, fail = _mesh_fallback(s_prev, a1, b1, am, bm, k, e, ed_, mesh_par[2], mesh_par[3])
    return ns, fm, a1 + am * fm, b1 + bm * fm, fail


@njit(cache=True, fastmath=_FM, error_model="numpy", inline="always")
def _set_mesh_columns(
    beta: np.ndarray, coef: np.ndarray, fm: float, d: float, dd: float, kbar: float, cbar: float
) -> None:
    """Amplitudes of the mesh columns: u = compensation - coef_0 F, friction columns coef_j F."""
    beta[0] = kbar * d + cbar * dd - coef[0] * fm
    for j in range(1, coef.shape[0]):
        beta[j] = coef[j] * fm


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


@njit(cache=True, fastmath=_FM, error_model="numpy")
def _substep_prepare(
    w: float,
    nf: int,
    mur: np.ndarray,
    mui: np.ndarray,
    rpr: np.ndarray,
    rpi: np.ndarray,
    rhr: np.ndarray,
    rhi: np.ndarray,
    pmr: np.ndarray,
    pmi: np.ndarray,
    vd_r: np.ndarray,
    vd_i: np.ndarray,
    vv_r: np.ndarray,
    vv_i: np.ndarray,
    zr: np.ndarray,
    zi: np.ndarray,
    swr: np.ndarray,
    swi: np.ndarray,
    nb: int,
    pqs: np.ndarray,
) -> tuple[float, float, float, float]:
    """Trapezoidal map of a sub-step ``w h`` and the responses of delta, delta' at its end.

    Per mode (``mu = h lambda``): ``r' = (1 + w mu/2)/(1 - w mu/2)`` and the force-column scale
    ``rho = s'/s = w (1 - mu/2)/(1 - w mu/2)`` (into ``rp*``, ``rh*``). Responses: ``pqs[:, q]`` to the
    column amplitudes (from ``pm* = [V Phi] * SW_q`` precomputed per dt, rows 2q and 2q + 1 for
    delta and delta', rows 8, 9 for the static increment), the static part and the free part
    ``Re(V Phi r' z)`` (returned as ``ypd, ypv, psd, psv``).
    """
    for j in range(mur.shape[0]):
        ar = 0.5 * w * mur[j]
        ai = 0.5 * w * mui[j]
        dr = 1.0 - ar
        inv = 1.0 / (dr * dr + ai * ai)
        nr = 1.0 + ar
        rpr[j] = (nr * dr - ai * ai) * inv
        rpi[j] = (ai * dr + nr * ai) * inv
        er = 1.0 - 0.5 * mur[j]
        ei = -0.5 * mui[j]
        rhr[j] = w * (er * dr - ei * ai) * inv
        rhi[j] = w * (ei * dr + er * ai) * inv
    # (2-D indexing rather than row slices: a slice is a new array with a reference count)
    s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = s8 = s9 = 0.0
    ypd = 0.0
    ypv = 0.0
    for j in range(nf):
        a = rhr[j]
        c = rhi[j]
        s0 += a * pmr[0, j] - c * pmi[0, j]
        s1 += a * pmr[1, j] - c * pmi[1, j]
        s2 += a * pmr[2, j] - c * pmi[2, j]
        s3 += a * pmr[3, j] - c * pmi[3, j]
        s4 += a * pmr[4, j] - c * pmi[4, j]
        s5 += a * pmr[5, j] - c * pmi[5, j]
        s6 += a * pmr[6, j] - c * pmi[6, j]
        s7 += a * pmr[7, j] - c * pmi[7, j]
        s8 += a * pmr[8, j] - c * pmi[8, j]
        s9 += a * pmr[9, j] - c * pmi[9, j]
        tr = rpr[j] * zr[j] - rpi[j] * zi[j]
        ti = rpr[j] * zi[j] + rpi[j] * zr[j]
        ypd += vd_r[j] * tr - vd_i[j] * ti
        ypv += vv_r[j] * tr - vv_i[j] * ti
    pqs[0, 0] = s0
    pqs[1, 0] = s1
    if nb > 1:
        pqs[0, 1] = s2
        pqs[1, 1] = s3
    if nb > 2:
        pqs[0, 2] = s4
        pqs[1, 2] = s5
    if nb > 3:
        pqs[0, 3] = s6
        pqs[1, 3] = s7
    for q in range(nb, swr.shape[0]):  # effect columns
        sd = 0.0
        sv = 0.0
        for j in range(nf):
            tr = rhr[j] * swr[q, j] - rhi[j] * swi[q, j]
            ti = rhr[j] * swi[q, j] + rhi[j] * swr[q, j]
            sd += vd_r[j] * tr - vd_i[j] * ti
            sv += vv_r[j] * tr - vv_i[j] * ti
        pqs[0, q] = sd
        pqs[1, q] = sv
    return ypd, ypv, s8, s9


@njit(cache=True, fastmath=_FM, error_model="numpy")
def _substep_commit(
    zr: np.ndarray,
    zi: np.ndarray,
    rpr: np.ndarray,
    rpi: np.ndarray,
    rhr: np.ndarray,
    rhi: np.ndarray,
    c0r: np.ndarray,
    c0i: np.ndarray,
    swr: np.ndarray,
    swi: np.ndarray,
    alpha: np.ndarray,
    nb: int,
) -> None:
    """``z <- r' z + rho (c0 + sum_q SW_q alpha_q)`` over all modes (mesh columns unrolled)."""
    nmode = zr.shape[0]
    a0 = alpha[0]
    a1 = alpha[1] if nb > 1 else 0.0
    a2 = alpha[2] if nb > 2 else 0.0
    a3 = alpha[3] if nb > 3 else 0.0
    q1 = 1 if nb > 1 else 0
    q2 = 2 if nb > 2 else 0
    q3 = 3 if nb > 3 else 0
    for j in range(nmode):
        gr = c0r[j] + swr[0, j] * a0 + swr[q1, j] * a1 + swr[q2, j] * a2 + swr[q3, j] * a3
        gi = c0i[j] + swi[0, j] * a0 + swi[q1, j] * a1 + swi[q2, j] * a2 + swi[q3, j] * a3
        xr = zr[j]
        xi = zi[j]
        zr[j] = rpr[j] * xr - rpi[j] * xi + rhr[j] * gr - rhi[j] * gi
        zi[j] = rpr[j] * xi + rpi[j] * xr + rhr[j] * gi + rhi[j] * gr
    for q in range(nb, swr.shape[0]):  # effect columns
        aq = alpha[q]
        if aq != 0.0:
            for j in range(nmode):
                gr = swr[q, j] * aq
                gi = swi[q, j] * aq
                zr[j] += rhr[j] * gr - rhi[j] * gi
                zi[j] += rhr[j] * gi + rhi[j] * gr


@njit(cache=True, fastmath=_FM, error_model="numpy")
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


_MAX_PIECES = 16
#: A jump closer than this fraction of a step to a step boundary is taken at that boundary (no
#: sub-step of zero length; with dt = T_mesh / s the phase-0 jump falls on grid points).
_EVENT_SNAP = 1e-9


@njit(cache=True, fastmath=_FM, error_model="numpy")
def _event_step(
    n: int,
    nev: int,
    end_jump: float,
    tc0: float,
    dest0: int,
    bnd: np.ndarray,
    bfe: np.ndarray,
    ph_a: float,
    dph: float,
    zr: np.ndarray,
    zi: np.ndarray,
    c0r: np.ndarray,
    c0i: np.ndarray,
    swr: np.ndarray,
    swi: np.ndarray,
    n_forced: int,
    vd_r: np.ndarray,
    vd_i: np.ndarray,
    vv_r: np.ndarray,
    vv_i: np.ndarray,
    mur: np.ndarray,
    mui: np.ndarray,
    pmr: np.ndarray,
    pmi: np.ndarray,
    tab_kf: np.ndarray,
    tab_cf: np.ndarray,
    jflag: np.ndarray,
    tab_k: np.ndarray,
    tab_c: np.ndarray,
    jump_p: np.ndarray,
    jump_k: np.ndarray,
    jump_c: np.ndarray,
    mesh_par: np.ndarray,
    phase: np.ndarray,
    phase_rate: np.ndarray,
    kfac: np.ndarray,
    te_add: np.ndarray,
    ted_add: np.ndarray,
    ampl: np.ndarray,
    beta_prev: np.ndarray,
    beta_new: np.ndarray,
    alpha: np.ndarray,
    coef: np.ndarray,
    rpr: np.ndarray,
    rpi: np.ndarray,
    rhr: np.ndarray,
    rhi: np.ndarray,
    pqs: np.ndarray,
    bkind: np.ndarray,
    bdest: np.ndarray,
    allow: np.ndarray,
    sc: np.ndarray,
    isc: np.ndarray,
    bound: float,
) -> int:
    """Step n-1 -> n as Newmark sub-steps split at the table jumps ``bnd[1..nev]`` (fractions of
    the step, event phases ``bfe``) and at located contact changes (see :func:`run_chunk_one_mesh`);
    ``end_jump`` >= 0: the phase of a jump at the step end itself.

    ``sc`` carries (delta, delta', e, e') at the step start and returns (delta, delta', e, e', k, F)
    at its end; ``isc`` = (contact state, failed solves, sub-steps). Returns a status.
    """
    kbar = mesh_par[0]
    cbar = mesh_par[1]
    cm = mesh_par[2]
    bst = mesh_par[3]
    dt = mesh_par[6]
    nb = coef.shape[0]
    na = beta_prev.shape[0]
    # bkind: 0 step end, 1 table jump, 2 located contact change (bdest: the state after it)
    d_prev, dd_prev, e_prev, ed_prev = sc[0], sc[1], sc[2], sc[3]
    s_prev = isc[0]
    ph_b = phase[n]
    m = nev + 1
    bnd[0] = 0.0
    for i in range(1, m):
        bkind[i] = 1
    bnd[m] = 1.0
    bkind[m] = 0
    if end_jump >= 0.0:  # a jump at the step end (to round-off)
        bkind[m] = 1
        bfe[m] = end_jump
    for i in range(m):
        allow[i] = 1
    if tc0 > 0.0:  # contact change already located on the full step (no jump in it): split there
        bnd[2] = bnd[1]
        bkind[2] = bkind[1]
        bfe[2] = bfe[1]
        bnd[1] = tc0
        bkind[1] = 2
        bdest[1] = dest0
        allow[0] = 0
        allow[1] = 0
        m = 2
    k = e = ed_ = fm = d = dd = 0.0
    i = 0
    while i < m:
        ta = bnd[i]
        tb = bnd[i + 1]
        kind = bkind[i + 1]
        w = tb - ta
        ypd, ypv, psd, psv = _substep_prepare(
            w, n_forced, mur, mui, rpr, rpi, rhr, rhi, pmr, pmi, vd_r, vd_i, vv_r, vv_i, zr, zi, swr, swi,
            nb, pqs,
        )  # fmt: skip
        if kind == 1:
            fe = bfe[i + 1]
            k, e, ed_ = _excite(
                n, tb, ph_a + tb * dph, fe if fe > 0.0 else 1.0, True, phase_rate,
                tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k, jump_c,
                mesh_par, kfac, te_add, ted_add, ampl, coef, beta_new,
            )  # fmt: skip
        else:
            k, e, ed_ = _excite(
                n, tb, ph_b if kind == 0 else ph_a + tb * dph, -1.0, False, phase_rate,
                tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k, jump_c,
                mesh_par, kfac, te_add, ted_add, ampl, coef, beta_new,
            )  # fmt: skip
        if not (np.isfinite(k) and np.isfinite(e) and np.isfinite(ed_)):
            isc[0] = s_prev
            return STATUS_NONFINITE
        ns, fm, d, dd, fail = _mesh_step(
            ypd, ypv, psd, psv, pqs, beta_prev, beta_new, coef, k, e, ed_, mesh_par, s_prev, kind == 2, 0.0
        )
        if allow[i] == 1 and ns != s_prev and m < _MAX_PIECES:
            tc = _locate_crossing(d_prev - e_prev, dd_prev - ed_prev, d - e, dd - ed_, bst, w * dt)
            if tc > 0.0:
                for j in range(m, i, -1):
                    bnd[j + 1] = bnd[j]
                    bfe[j + 1] = bfe[j]
                    bkind[j + 1] = bkind[j]
                    bdest[j + 1] = bdest[j]
                    allow[j + 1] = allow[j]
                bnd[i + 1] = ta + tc * w
                bkind[i + 1] = 2
                bdest[i + 1] = ns
                allow[i] = 0
                allow[i + 1] = 0
                m += 1
                continue
        isc[1] += fail
        if not (np.isfinite(d) and np.isfinite(fm)):
            isc[0] = s_prev
            return STATUS_NONFINITE
        if abs(d) >= bound:
            isc[0] = s_prev
            return STATUS_BOUND
        _set_mesh_columns(beta_new, coef, fm, d, dd, kbar, cbar)
        for q in range(na):
            alpha[q] = beta_prev[q] + beta_new[q]
        _substep_commit(zr, zi, rpr, rpi, rhr, rhi, c0r, c0i, swr, swi, alpha, nb)
        isc[2] += 1
        for q in range(na):
            beta_prev[q] = beta_new[q]
        s_prev = ns
        d_prev = d
        dd_prev = dd
        e_prev = e
        ed_prev = ed_
        if kind == 1:
            # right limit of the tables at the jump, same contact state and deflection
            k = _tables_at(
                bfe[i + 1], False, tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k, jump_c, coef
            )
            if kfac.shape[0] > 0:
                k *= _lerp(kfac[n - 1], kfac[n], tb)
            fm = _state_force(s_prev, d - e, dd - ed_, k, cm, bst, fm)
            _set_mesh_columns(beta_prev, coef, fm, d, dd, kbar, cbar)
        elif kind == 2:
            sd = bdest[i + 1]
            if s_prev != sd and (sd == 0 or sd == 2 or sd == -2):
                # right limit of Eq 25 at the located contact change (its damping term jumps)
                fm = _state_force(sd, d - e, dd - ed_, k, cm, bst, fm)
                s_prev = sd
                _set_mesh_columns(beta_prev, coef, fm, d, dd, kbar, cbar)
        i += 1
    sc[0] = d
    sc[1] = dd
    sc[2] = e
    sc[3] = ed_
    sc[4] = k
    sc[5] = fm
    isc[0] = s_prev
    return STATUS_OK


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
    vd_r: np.ndarray,
    vd_i: np.ndarray,
    vv_r: np.ndarray,
    vv_i: np.ndarray,
    mur: np.ndarray,
    mui: np.ndarray,
    pmr: np.ndarray,
    pmi: np.ndarray,
    cstack: np.ndarray,
    dfeed_static: np.ndarray,
    hbuf: np.ndarray,
    tab_kf: np.ndarray,
    tab_cf: np.ndarray,
    jflag: np.ndarray,
    tab_k: np.ndarray,
    tab_c: np.ndarray,
    jump_p: np.ndarray,
    jump_k: np.ndarray,
    jump_c: np.ndarray,
    mesh_par: np.ndarray,
    locate: bool,
    phase: np.ndarray,
    phase_rate: np.ndarray,
    kfac: np.ndarray,
    te_add: np.ndarray,
    ted_add: np.ndarray,
    ampl: np.ndarray,
    beta_prev: np.ndarray,
    ypred: np.ndarray,
    state: np.ndarray,
    mcarry: np.ndarray,
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
) -> tuple[int, int, int, int]:
    """Advance ``n = phase.shape[0] - 1`` steps of a system with exactly one mesh (modal map).

    The same exact Newmark map as :func:`run_chunk`, specialised: the mesh stiffness, force
    coefficients and transmission error (Eq 24) are looked up from the tables inside the loop; the
    static load (constant amplitude) is a fixed modal increment ``c0``; the line-of-action column
    ``-V`` and the mean-mesh compensation ``+V`` are one column ``u`` with amplitude
    ``comp - coef_0 F``; the mode loop is fused (update, mesh prediction) and runs the force
    columns only over the first ``n_forced`` modes (the modes a mesh or effect force reaches; the
    rest, e.g. the axial modes, only propagate).

    Events inside a step (``locate``): the tooth-pair changes and pitch-point passages are jumps of
    the stiffness and force-coefficient tables at known phases ``jump_p``; a contact-state change
    (separation, impact, back-side contact) is a kink of Eq 25 in delta_m and a jump of its damping
    term. A step containing either is integrated as Newmark sub-steps split at the event (jump
    phases exactly; contact changes at the Hermite-interpolated crossing of +-b*), with the force
    law's left limit at the end of one sub-step and its right limit at the start of the next. This
    keeps the scheme's second order at the events (without it, the error there is first order in dt).

    ``phase``, ``phase_rate`` (n + 1,) and the optional effect arrays ``kfac``, ``te_add``,
    ``ted_add`` (n + 1,) and ``ampl`` (n + 1, ne) hold the carried step at index 0 and the new steps
    at 1..n. ``tab_kf``, ``tab_cf``: the full tables, ``jflag`` their intervals that hold a jump,
    ``tab_k``, ``tab_c`` the continuous parts (:func:`_tables_at`). ``mesh_par`` = (kbar, cbar, c_m,
    b*, e0, phi, dt); ``pmr``, ``pmi``: see :func:`_substep_prepare`. ``mcarry`` = (delta, delta', F)
    at the carried step, updated. Outputs ``out[n - 1] = [z_r, z_i, beta] @ cstack + dfeed_static`` are
    formed in blocks of ``hbuf.shape[0]`` steps by one matrix product (BLAS), which costs a fraction
    of per-step dot products.

    Active columns (``swr`` rows, ``pq`` columns, ``beta_prev``): 0 = u, 1..nb-1 = friction basis,
    nb.. = effects.

    Returns
    -------
    (status, step, n_failed_mesh_solves, n_substeps)
    """
    nsteps = phase.shape[0] - 1
    na = beta_prev.shape[0]
    nb = tab_c.shape[1]
    no = cstack.shape[1]
    nmode = zr.shape[0]
    kbar = mesh_par[0]
    cbar = mesh_par[1]
    beta_new = np.zeros(na)
    alpha = np.zeros(na)
    coef = np.zeros(nb)
    if nsteps == 0:
        return STATUS_OK, 0, 0, 0
    rpr = np.zeros(nmode)
    rpi = np.zeros(nmode)
    rhr = np.zeros(nmode)
    rhi = np.zeros(nmode)
    pqs = np.zeros((2, na))
    bkind = np.zeros(_MAX_PIECES + 2, dtype=np.int64)
    bdest = np.zeros(_MAX_PIECES + 2, dtype=np.int64)
    allow = np.zeros(_MAX_PIECES + 2, dtype=np.int64)
    bnd = np.zeros(_MAX_PIECES + 2)
    bfe = np.zeros(_MAX_PIECES + 2)
    sc = np.zeros(6)
    isc = np.zeros(3, dtype=np.int64)
    n_fail = 0
    s_prev = state[0]
    d_prev = mcarry[0]
    dd_prev = mcarry[1]
    f_prev = mcarry[2]
    _, e_prev, ed_prev = _excite(
        1, 0.0, phase[0], -1.0, False, phase_rate, tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k,
        jump_c, mesh_par,
        kfac, te_add, ted_add, ampl, coef, beta_new,
    )  # fmt: skip
    n_buf = hbuf.shape[0]
    hb = 0
    o0 = 0
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
    n_jump = jump_p.shape[0] if locate else 0
    einv_reg = 1.0 / (1.0 - kbar * pq[0, 0] - cbar * pq[1, 0])  # compensation column, full steps
    dt = mesh_par[6]
    nt_tab = tab_kf.shape[0]
    has_kfac = kfac.shape[0] > 0
    has_te = te_add.shape[0] > 0
    ne = ampl.shape[1]
    two_pi = 2.0 * np.pi
    te_amp = mesh_par[4]
    te_phase = mesh_par[5]
    for n in range(1, nsteps + 1):
        ph_a = phase[n - 1]
        ph_b = phase[n]
        dph = ph_b - ph_a
        if dph < 0.0:
            dph += 1.0
        nev = 0
        end_jump = -1.0
        for q in range(n_jump):
            x = jump_p[q] - ph_a
            if x <= 0.0:
                x += 1.0
            if x < dph and nev < _MAX_PIECES - 2:
                th = x / dph
                if th <= _EVENT_SNAP:
                    # the jump is at the step start (to round-off): start from its right limit
                    k0 = _tables_at(
                        jump_p[q], False, tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k, jump_c, coef
                    )
                    if kfac.shape[0] > 0:
                        k0 *= kfac[n - 1]
                    f_prev = _state_force(
                        s_prev, d_prev - e_prev, dd_prev - ed_prev, k0, mesh_par[2], mesh_par[3], f_prev
                    )
                    _set_mesh_columns(beta_prev, coef, f_prev, d_prev, dd_prev, kbar, cbar)
                    continue
                if th >= 1.0 - _EVENT_SNAP:
                    end_jump = jump_p[q]  # at the step end: left limit there, then the right limit
                    continue
                pos = nev + 1  # insertion sort into bnd[1..nev]
                while pos > 1 and bnd[pos - 1] > th:
                    bnd[pos] = bnd[pos - 1]
                    bfe[pos] = bfe[pos - 1]
                    pos -= 1
                bnd[pos] = th
                bfe[pos] = jump_p[q]
                nev += 1
        regular = nev == 0 and end_jump < 0.0
        ns = s_prev
        fm = d = dd = k = e = ed_ = 0.0
        tc0 = -1.0
        dest0 = 0
        if regular:
            # tables, TE and effect inputs at the step end (the body of _excite, written out: the
            # inlined call costs measurably more in this loop)
            xx = ph_b * nt_tab
            i0 = int(np.floor(xx))
            ff = xx - i0
            i0 = i0 % nt_tab
            i1 = i0 + 1
            if i1 == nt_tab:
                i1 = 0
            if jflag[i0] == 0:
                k = tab_kf[i0] + ff * (tab_kf[i1] - tab_kf[i0])
                for j in range(nb):
                    coef[j] = tab_cf[i0, j] + ff * (tab_cf[i1, j] - tab_cf[i0, j])
            else:
                k = _tables_at(ph_b, False, tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k, jump_c, coef)
            if has_kfac:
                k *= kfac[n]
            arg = two_pi * ph_b + te_phase
            e = te_amp * np.sin(arg)
            ed_ = te_amp * np.cos(arg) * two_pi * phase_rate[n]
            if has_te:
                e += te_add[n]
                ed_ += ted_add[n]
            for q in range(ne):
                beta_new[nb + q] = ampl[n, q]
            if not (np.isfinite(k) and np.isfinite(e) and np.isfinite(ed_)):
                state[0] = s_prev
                return STATUS_NONFINITE, n - 1, n_fail, isc[2]
            ns, fm, d, dd, fail = _mesh_step(
                ypred[0], ypred[1], pq_static[0], pq_static[1], pq, beta_prev, beta_new, coef, k, e, ed_,
                mesh_par, s_prev, False, einv_reg,
            )  # fmt: skip
            if locate and ns != s_prev:
                # a contact change inside the step: locate it from this full-step solution, then redo
                # the step as two sub-steps split there (none if no crossing is found)
                tc0 = _locate_crossing(d_prev - e_prev, dd_prev - ed_prev, d - e, dd - ed_, mesh_par[3], dt)
                regular = tc0 <= 0.0
                dest0 = ns
                if regular:
                    n_fail += fail
            else:
                n_fail += fail
        if regular:
            if not (np.isfinite(d) and np.isfinite(fm)):
                state[0] = s_prev
                return STATUS_NONFINITE, n - 1, n_fail, isc[2]
            if abs(d) >= bound:
                state[0] = s_prev
                return STATUS_BOUND, n - 1, n_fail, isc[2]
            _set_mesh_columns(beta_new, coef, fm, d, dd, kbar, cbar)
            for q in range(na):
                alpha[q] = beta_prev[q] + beta_new[q]
            # z <- r z + c0 + sum_q sw_q alpha_q and the mesh prediction in one pass over the forced
            # modes, mesh columns unrolled (slices from 0 vectorise), then the unforced modes
            a0 = alpha[0]
            a1_ = alpha[1] if nb > 1 else 0.0
            a2_ = alpha[2] if nb > 2 else 0.0
            a3_ = alpha[3] if nb > 3 else 0.0
            yd = 0.0
            yv = 0.0
            for j in range(n_forced):
                xr = zfr[j]
                xi = zfi[j]
                tr = (
                    rfr[j] * xr - rfi[j] * xi + c0fr[j] + s0r[j] * a0 + s1r[j] * a1_ + s2r[j] * a2_
                    + s3r[j] * a3_
                )  # fmt: skip
                ti = (
                    rfr[j] * xi + rfi[j] * xr + c0fi[j] + s0i[j] * a0 + s1i[j] * a1_ + s2i[j] * a2_
                    + s3i[j] * a3_
                )  # fmt: skip
                zfr[j] = tr
                zfi[j] = ti
                yd += cdr[j] * tr - cdi[j] * ti
                yv += cvr[j] * tr - cvi[j] * ti
            for q in range(nb, na):  # effect columns
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
            for q in range(na):
                beta_prev[q] = beta_new[q]
            s_prev = ns
            if not np.isfinite(yd):
                state[0] = s_prev
                return STATUS_NONFINITE, n - 1, n_fail, isc[2]
        else:
            sc[0] = d_prev
            sc[1] = dd_prev
            sc[2] = e_prev
            sc[3] = ed_prev
            isc[0] = s_prev
            isc[1] = 0
            status = _event_step(
                n, nev, end_jump, tc0, dest0, bnd, bfe, ph_a, dph, zr, zi, c0r, c0i, swr, swi, n_forced,
                vd_r, vd_i, vv_r, vv_i, mur, mui, pmr, pmi,
                tab_kf, tab_cf, jflag, tab_k, tab_c, jump_p, jump_k, jump_c, mesh_par, phase, phase_rate,
                kfac, te_add, ted_add, ampl, beta_prev, beta_new, alpha, coef,
                rpr, rpi, rhr, rhi, pqs, bkind, bdest, allow, sc, isc, bound,
            )  # fmt: skip
            n_fail += isc[1]
            s_prev = isc[0]
            if status != STATUS_OK:
                state[0] = s_prev
                return status, n - 1, n_fail, isc[2]
            d = sc[0]
            dd = sc[1]
            e = sc[2]
            ed_ = sc[3]
            k = sc[4]
            fm = sc[5]
            ns = s_prev
            # prediction of the next full step from the new state
            yd = 0.0
            yv = 0.0
            for j in range(n_forced):
                yd += cdr[j] * zfr[j] - cdi[j] * zfi[j]
                yv += cvr[j] * zfr[j] - cvi[j] * zfi[j]
            ypred[0] = yd
            ypred[1] = yv
            if not np.isfinite(yd):
                state[0] = s_prev
                return STATUS_NONFINITE, n - 1, n_fail, isc[2]
        d_prev = d
        dd_prev = dd
        e_prev = e
        ed_prev = ed_
        f_prev = fm
        o = n - 1
        dte[o, 0] = d
        dted[o, 0] = dd
        fmesh[o, 0] = fm
        states[o, 0] = ns
        kt_out[o] = k
        et_out[o] = e
        edt_out[o] = ed_
        for j in range(nb):
            coef_out[o, j] = coef[j]
        if no > 0:
            row = hbuf[hb]
            for j in range(nmode):
                row[j] = zr[j]
                row[nmode + j] = zi[j]
            for q in range(na):
                row[2 * nmode + q] = beta_prev[q]
            hb += 1
            if hb == n_buf or n == nsteps:
                blk = out[o0 : o0 + hb]
                np.dot(hbuf[:hb], cstack, blk)
                for r in range(hb):
                    for c in range(no):
                        blk[r, c] += dfeed_static[c]
                o0 += hb
                hb = 0
    state[0] = s_prev
    mcarry[0] = d_prev
    mcarry[1] = dd_prev
    mcarry[2] = f_prev
    return STATUS_OK, nsteps, n_fail, isc[2]
