"""Equations of motion of the lumped gearbox and their fixed-step RK4 integration.

Degrees of freedom (8): pinion ``x1, y1, z1, theta1`` and gear ``x2, y2, z2, q2``. ``theta1`` is the
pinion's angle ahead of the rigidly driven input end (node 1, constant speed), ``q2`` the gear's
angle behind its nominal rotation. The shafts are massless equivalent springs (``params.springs``);
the bearings' dampers act on the wheel's lateral/axial motion.

    delta    = sin(a) (x1 - x2) + cos(a) (y1 - y2) + rb1 theta1 + rb2 q2           (DTE, channel dte)
    delta_m  = delta - e0 sin(2 pi u + phi) + e_ecc(t) - e_wear(t)                 (deflection)
    F_m      = sum_slices k(t)/n [delta_m + g xi_j - b]_+ - [-(delta_m + g xi_j) - b]_+
               + c_m f_c d(delta)/dt                                              (mesh force)
    m1 x1''  = -k_l x1 - c_l x1' - F_m sin(a) + f_p,x(t)       (and y with cos(a))
    m1 z1''  = -k_z z1 - c_z z1' - F_m g(t)
    J1 th1'' = -k_t (th1 - D(t)) - c_t (th1' - D'(t)) - F_m rb1  (D: Cardan joint lag, else 0)
    m2 x2''  = -k_l x2 - c_l x2' + F_m sin(a) + f_g,x(t)       (and y)
    m2 z2''  = -k_z z2 - c_z z2' + F_m g(t)
    J2 q2''  = T2(t) - F_m rb2                                    (T2 constant unless load_profile.py)

With manufacturing pitch errors (``pitch.py``) each pair in contact takes its own deadzone at its flanks'
position error ``e_n``: ``F_m = sum_n k_n [delta_m + e_n + g xi_j - b]_+ - ...``.
``u = z1 w1 t / 2 pi`` is the mesh position in cycles, ``b`` the thermal half backlash, ``g(t)`` the
misalignment wobble angle, ``f_c`` the fraction of face slices in contact. With a speed profile
(``speed_profile.py``) the input end turns by ``psi(t)`` instead of ``w1 t``: ``u = z1 psi / 2 pi``, the
wheels' angles and rotating forces follow ``psi`` and ``psi'``, and ``-psi''`` (pinion) and
``+psi'' z1 / z2`` (gear) join the torsional accelerations (coordinates relative to the driven rotation).
A load-torque profile (``load_profile.py``) makes ``T2(t) = T0 [1 + A sin(omega t + k psi2 + phi)]``.
A breathing shaft crack adds ``dk (n . d)_+ n`` to that wheel's lateral force ``f_p`` / ``f_g``
(``shaft_faults.py``); a loose bearing-2 housing adds ``D(n . d) n`` to ``f_p`` (``loose_housing.py``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from lumped_gearbox.loose_housing import loose_relief
from lumped_gearbox.mesh import deadzone as _deadzone
from lumped_gearbox.mesh import pair_shape
from lumped_gearbox.pitch import pitch_mesh_force
from lumped_gearbox.shaft_faults import cardan_lag, crack_force

# indices of the parameter vectors (grouped by role)
G_Z1, G_Z2, G_EPS, G_RB1, G_RB2, G_SA, G_CA, G_W1, G_W2, G_PITCH, G_FACE, G_RELIEF = range(12)
M_M1, M_J1, M_M2, M_J2, M_ME1, M_ME2 = range(6)  # ME: wheel body masses (eccentric whirl)
K_L1, K_L2, K_Z1, K_Z2, K_T1, K_PAIR = range(6)
C_L1, C_L2, C_Z1, C_Z2, C_T1, C_M = range(6)
L_T2, L_B, L_E0, L_EPH, L_TA, L_TW, L_TK, L_TPH = range(8)  # L_TA..: load_profile.py
(
    F_ECC_P,
    F_ECC_P_PH,
    F_ECC_G,
    F_ECC_G_PH,
    F_UNB_P,
    F_UNB_P_PH,
    F_UNB_G,
    F_UNB_G_PH,
    F_MIS,
    F_MIS_PH,
    F_MIS_GEAR,
    F_WEAR,
    F_CRACK,
    F_CRACK_PH,
    F_CRACK_GEAR,
    F_CARDAN,
    F_CARDAN_PH,
    F_LOOSE,
    F_LOOSE_BOLT,
    F_LOOSE_LIFT,
    F_LOOSE_GAP,
    F_LOOSE_NX,
    F_LOOSE_NY,
    F_LOOSE_SHARE,
) = range(24)
N_FAULT = 24
N_SLICES = 9
N_OUT = 26  # q (8), v (8), a (8), mesh force, mesh stiffness


@njit(cache=True, inline="always")
def _mesh_state(t, geo, kk, fault, tooth_p, tooth_g, ex):
    """Mesh stiffness, stiffness-weighted wear gap and mesh position at time t (``ex``: the input
    angle beyond ``w1 t`` divided by ``w1``, speed_profile.py; 0 at a constant speed)."""
    u = geo[G_Z1] * geo[G_W1] * t / (2.0 * math.pi)
    if ex != 0.0:
        u += geo[G_Z1] * geo[G_W1] * ex / (2.0 * math.pi)
    eps = geo[G_EPS]
    sp = geo[G_PITCH]
    wmax = max(sp, 1.0 - sp)
    base = math.floor(u)
    k = 0.0
    kw = 0.0
    z1 = int(geo[G_Z1])
    z2 = int(geo[G_Z2])
    for back in range(3):
        n = int(base) - back
        s = u - n
        g = pair_shape(s, eps, geo[G_RELIEF])
        if g > 0.0:
            ki = kk[K_PAIR] * g * tooth_p[n % z1] * tooth_g[n % z2]
            k += ki
            kw += ki * abs(s / eps - sp) / wmax
    wear = fault[F_WEAR] * kw / k if k > 0.0 else 0.0
    return k, wear, u


@njit(cache=True, inline="always")
def _profile(t, prof):
    """Input angle beyond ``w1 t`` over ``w1`` (s), speed over ``w1``, input angular acceleration
    over ``w1`` (1/s) of the speed profile ``prof`` (speed_profile.py; all zero: constant speed)."""
    if prof[0] == 0.0:
        return 0.0, 1.0, 0.0
    ph = prof[4] * t + prof[5]
    ex = prof[1] * t + 0.5 * prof[2] * t * t + prof[3] * (math.cos(prof[5]) - math.cos(ph)) / prof[4]
    return (
        ex,
        1.0 + prof[1] + prof[2] * t + prof[3] * math.sin(ph),
        prof[2] + prof[3] * prof[4] * math.cos(ph),
    )


@njit(cache=True)
def _rhs(t, q, v, a, geo, mass, kk, cc, load, fault, tooth_p, tooth_g, prof, pitch):
    """Accelerations ``a`` (in place); returns (mesh force, mesh stiffness). ``pitch``: the flank errors
    of pitch.py (empty: none, the single deadzone below)."""
    sa = geo[G_SA]
    ca = geo[G_CA]
    rb1 = geo[G_RB1]
    rb2 = geo[G_RB2]
    psi1 = geo[G_W1] * t
    psi2 = geo[G_W2] * t
    w1 = geo[G_W1]
    w2 = geo[G_W2]
    ex, rel, acc = _profile(t, prof)
    if prof[0] != 0.0:
        # the input end driven at the prescribed angle (speed_profile.py)
        psi1 += w1 * ex
        psi2 += w2 * ex
        w1 = w1 * rel
        w2 = w2 * rel
    k, wear, u = _mesh_state(t, geo, kk, fault, tooth_p, tooth_g, ex)
    # geometric centre offsets projected on the line of action (gear turns the other way)
    pp = psi1 + fault[F_ECC_P_PH]
    pg = psi2 + fault[F_ECC_G_PH]
    e_ecc = fault[F_ECC_P] * (sa * math.cos(pp) + ca * math.sin(pp)) - fault[F_ECC_G] * (
        sa * math.cos(pg) - ca * math.sin(pg)
    )
    ste = load[L_E0] * math.sin(2.0 * math.pi * u + load[L_EPH])
    delta = sa * (q[0] - q[4]) + ca * (q[1] - q[5]) + rb1 * q[3] + rb2 * q[7]
    ddelta = sa * (v[0] - v[4]) + ca * (v[1] - v[5]) + rb1 * v[3] + rb2 * v[7]
    dm = delta - ste + e_ecc - wear
    b = load[L_B]
    gam = 0.0
    if fault[F_MIS] > 0.0:
        psi = (psi2 if fault[F_MIS_GEAR] > 0.5 else psi1) + fault[F_MIS_PH]
        gam = fault[F_MIS] * math.cos(psi)
    if pitch.size > 0:  # every pair at its own flank position (pitch.py)
        fel, fc = pitch_mesh_force(
            u,
            dm,
            b,
            gam,
            geo[G_FACE],
            N_SLICES,
            geo[G_EPS],
            geo[G_RELIEF],
            kk[K_PAIR],
            tooth_p,
            tooth_g,
            pitch,
        )
    elif fault[F_MIS] > 0.0:
        fel = 0.0
        fc = 0.0
        for j in range(N_SLICES):
            xi = (j / (N_SLICES - 1.0) - 0.5) * geo[G_FACE]
            f, c = _deadzone(dm + gam * xi, b)
            fel += f
            fc += c
        fel *= k / N_SLICES
        fc /= N_SLICES
    else:
        f, fc = _deadzone(dm, b)
        fel = k * f
    fm = fel + cc[C_M] * fc * ddelta
    # rotating forces: unbalance and the whirl of an eccentric wheel's mass centre
    fpx = fault[F_UNB_P] * w1 * w1 * math.cos(psi1 + fault[F_UNB_P_PH]) + mass[M_ME1] * fault[
        F_ECC_P
    ] * w1 * w1 * math.cos(pp)
    fpy = fault[F_UNB_P] * w1 * w1 * math.sin(psi1 + fault[F_UNB_P_PH]) + mass[M_ME1] * fault[
        F_ECC_P
    ] * w1 * w1 * math.sin(pp)
    fgx = fault[F_UNB_G] * w2 * w2 * math.cos(psi2 + fault[F_UNB_G_PH]) + mass[M_ME2] * fault[
        F_ECC_G
    ] * w2 * w2 * math.cos(pg)
    fgy = -fault[F_UNB_G] * w2 * w2 * math.sin(psi2 + fault[F_UNB_G_PH]) - mass[M_ME2] * fault[
        F_ECC_G
    ] * w2 * w2 * math.sin(pg)
    fax = fm * gam
    if fault[F_CRACK] > 0.0:  # breathing shaft crack (shaft_faults.py)
        if fault[F_CRACK_GEAR] > 0.5:
            cx, cy = crack_force(q[4], q[5], psi2 + fault[F_CRACK_PH], -1.0, fault[F_CRACK] * kk[K_L2])
            fgx += cx
            fgy += cy
        else:
            cx, cy = crack_force(q[0], q[1], psi1 + fault[F_CRACK_PH], 1.0, fault[F_CRACK] * kk[K_L1])
            fpx += cx
            fpy += cy
    if fault[F_LOOSE] > 0.0:  # a loose bearing-2 housing lifting off its foot (loose_housing.py)
        nx = fault[F_LOOSE_NX]
        ny = fault[F_LOOSE_NY]
        relief = loose_relief(
            nx * q[0] + ny * q[1],
            fault[F_LOOSE_LIFT],
            fault[F_LOOSE_GAP],
            fault[F_LOOSE],
            fault[F_LOOSE_BOLT],
        )
        fpx += relief * nx
        fpy += relief * ny
    tors = -kk[K_T1] * q[3] - cc[C_T1] * v[3]
    if fault[F_CARDAN] > 0.0:  # Cardan joint at the input (shaft_faults.py)
        lag, rate = cardan_lag(psi1 + fault[F_CARDAN_PH], fault[F_CARDAN], w1)
        tors = -kk[K_T1] * (q[3] - lag) - cc[C_T1] * (v[3] - rate)
    a[0] = (-kk[K_L1] * q[0] - cc[C_L1] * v[0] - fm * sa + fpx) / mass[M_M1]
    a[1] = (-kk[K_L1] * q[1] - cc[C_L1] * v[1] - fm * ca + fpy) / mass[M_M1]
    a[2] = (-kk[K_Z1] * q[2] - cc[C_Z1] * v[2] - fax) / mass[M_M1]
    a[3] = (tors - fm * rb1) / mass[M_J1]
    a[4] = (-kk[K_L2] * q[4] - cc[C_L2] * v[4] + fm * sa + fgx) / mass[M_M2]
    a[5] = (-kk[K_L2] * q[5] - cc[C_L2] * v[5] + fm * ca + fgy) / mass[M_M2]
    a[6] = (-kk[K_Z2] * q[6] - cc[C_Z2] * v[6] + fax) / mass[M_M2]
    t2 = load[L_T2]
    if load[L_TA] != 0.0:  # the driven machine's fluctuating torque (load_profile.py)
        t2 = t2 * (1.0 + load[L_TA] * math.sin(load[L_TW] * t + load[L_TK] * psi2 + load[L_TPH]))
    a[7] = (t2 - fm * rb2) / mass[M_J2]
    if prof[0] != 0.0:
        # coordinates relative to the driven rotation: its angular acceleration (speed_profile.py)
        a[3] -= geo[G_W1] * acc
        a[7] += geo[G_W2] * acc
    return fm, k


@njit(cache=True)
def integrate(
    t0, dt, n_sub, n_out, q0, v0, geo, mass, kk, cc, load, fault, tooth_p, tooth_g, n_skip, prof, pitch
):
    """Classical RK4 with step ``dt`` from ``t0``; every ``n_sub``-th step after ``n_skip`` output
    samples' worth of steps is stored: q, v, a (8 each), mesh force, mesh stiffness. ``prof``: the
    input speed profile (speed_profile.py; zeros: constant speed); ``pitch``: flank errors (pitch.py; empty:
    none)."""
    out = np.empty((n_out, N_OUT))
    q = q0.copy()
    v = v0.copy()
    a1 = np.empty(8)
    a2 = np.empty(8)
    a3 = np.empty(8)
    a4 = np.empty(8)
    qt = np.empty(8)
    vt = np.empty(8)
    total = (n_skip + n_out) * n_sub
    h = dt
    for step in range(total):
        t = t0 + step * h
        fm, km = _rhs(t, q, v, a1, geo, mass, kk, cc, load, fault, tooth_p, tooth_g, prof, pitch)
        if step % n_sub == 0 and step >= n_skip * n_sub:
            i = step // n_sub - n_skip
            out[i, 0:8] = q
            out[i, 8:16] = v
            out[i, 16:24] = a1
            out[i, 24] = fm
            out[i, 25] = km
        for j in range(8):
            qt[j] = q[j] + 0.5 * h * v[j]
            vt[j] = v[j] + 0.5 * h * a1[j]
        _rhs(t + 0.5 * h, qt, vt, a2, geo, mass, kk, cc, load, fault, tooth_p, tooth_g, prof, pitch)
        for j in range(8):
            qt[j] = q[j] + 0.5 * h * (v[j] + 0.5 * h * a1[j])
            vt[j] = v[j] + 0.5 * h * a2[j]
        _rhs(t + 0.5 * h, qt, vt, a3, geo, mass, kk, cc, load, fault, tooth_p, tooth_g, prof, pitch)
        for j in range(8):
            qt[j] = q[j] + h * (v[j] + 0.5 * h * a2[j])
            vt[j] = v[j] + h * a3[j]
        _rhs(t + h, qt, vt, a4, geo, mass, kk, cc, load, fault, tooth_p, tooth_g, prof, pitch)
        for j in range(8):
            q[j] += h * (v[j] + h / 6.0 * (a1[j] + a2[j] + a3[j]))
            v[j] += h / 6.0 * (a1[j] + 2.0 * a2[j] + 2.0 * a3[j] + a4[j])
        if not (math.isfinite(q[0]) and math.isfinite(q[7])):
            return out[:0]
    return out
