"""Timoshenko shaft element, rigid disc and bearing against analytic beam and rotor-dynamics results.

Independent truth: Timoshenko beam formulas (bending + shear) for static point loads, the closed-form
Timoshenko frequency equation of a pinned-pinned (spinning) shaft, and the Campbell frequencies of a
rigid disc on a tilt spring. Material constants are taken from Table 1 at 25 C (E = 207 GPa,
nu = 0.290), where the fit must reproduce the table exactly.
"""

from __future__ import annotations

import numpy as np
import pytest

from gear_rotor_sim.elements import BEARING_TYPES, GearDisc, ShaftElement
from gear_rotor_sim.materials import carbon_steel

E25, NU25, RHO = 207e9, 0.290, 7860.0
G25 = E25 / (2.0 * (1.0 + NU25))
KAPPA25 = 6.0 * (1.0 + NU25) / (7.0 + 6.0 * NU25)  # Cowper, solid circle


def _assemble(n_el: int, length: float, diameter: float, temperature_c: float = 25.0, spin: bool = False):
    el = ShaftElement(length / n_el, diameter, 0.0, carbon_steel())
    n = 6 * (n_el + 1)
    M, K, G = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    me, ke, ge = (
        el.mass_matrix(temperature_c),
        el.stiffness_matrix(temperature_c),
        el.gyroscopic_matrix(temperature_c),
    )
    for e in range(n_el):
        s = slice(6 * e, 6 * e + 12)
        M[s, s] += me
        K[s, s] += ke
        G[s, s] += ge
    return M, K, G


def _section(d: float) -> tuple[float, float]:
    return np.pi * d**2 / 4.0, np.pi * d**4 / 64.0


@pytest.mark.parametrize("direction", ["x", "y"])
def test_cantilever_tip_load_matches_timoshenko(direction: str) -> None:
    L, d, P, n_el = 0.15, 0.05, 1000.0, 6  # stubby: shear is ~6 % of the deflection
    A, I = _section(d)
    _, K, _ = _assemble(n_el, L, d)
    free = np.arange(6, K.shape[0])  # node 1 clamped
    f = np.zeros(K.shape[0])
    tip = 6 * n_el
    f[tip + (0 if direction == "x" else 1)] = P
    q = np.zeros_like(f)
    q[free] = np.linalg.solve(K[np.ix_(free, free)], f[free])
    w_ref = P * L**3 / (3 * E25 * I) + P * L / (KAPPA25 * G25 * A)
    rot_ref = P * L**2 / (2 * E25 * I)  # section rotation, unaffected by shear for a tip load
    if direction == "x":  # x-z plane: theta_y = +dx/dz
        w, rot = q[tip + 0], q[tip + 4]
    else:  # y-z plane: theta_x = -dy/dz
        w, rot = q[tip + 1], -q[tip + 3]
    assert w == pytest.approx(w_ref, rel=5e-3)
    assert rot == pytest.approx(rot_ref, rel=5e-3)
    assert P * L / (KAPPA25 * G25 * A) > 0.03 * w_ref  # the check is sensitive to the shear term


def test_simply_supported_midspan_load_matches_timoshenko() -> None:
    L, d, P, n_el = 0.3, 0.05, 2000.0, 8
    A, I = _section(d)
    _, K, _ = _assemble(n_el, L, d)
    n = K.shape[0]
    last = 6 * n_el
    fixed = [0, 1, 2, 5, last + 0, last + 1]  # pins in x and y, axial and torsional restraint at node 1
    free = np.setdiff1d(np.arange(n), fixed)
    f = np.zeros(n)
    mid = 6 * (n_el // 2)
    f[mid + 0] = P
    f[mid + 1] = -P
    q = np.zeros(n)
    q[free] = np.linalg.solve(K[np.ix_(free, free)], f[free])
    w_ref = P * L**3 / (48 * E25 * I) + P * L / (4 * KAPPA25 * G25 * A)
    assert q[mid + 0] == pytest.approx(w_ref, rel=5e-3)
    assert q[mid + 1] == pytest.approx(-w_ref, rel=5e-3)
    # end slopes: theta_y(0) = +PL^2/(16EI) (x load), theta_x(0) = +PL^2/(16EI) for a -y load
    assert q[4] == pytest.approx(P * L**2 / (16 * E25 * I), rel=5e-3)
    assert q[3] == pytest.approx(P * L**2 / (16 * E25 * I), rel=5e-3)


def _timoshenko_pinned(k: float, L: float, d: float, spin: float = 0.0) -> tuple[float, float]:
    """Lowest forward and backward whirl frequency (rad/s) of the mode sin(k z), pinned-pinned.

    Timoshenko equations in complex form r = x + i y, psi = theta_y - i theta_x:
    kGA (r'' - psi') + rho A w^2 r = 0,  EI psi'' + kGA (r' - psi) + rho I (w^2 - 2 Omega w) psi = 0,
    with r = R sin kz, psi = Psi cos kz; w > 0 is forward whirl.
    """
    A, I = _section(d)
    kga = KAPPA25 * G25 * A
    w = np.polynomial.Polynomial([0.0, 1.0])
    a11 = kga * k**2 - RHO * A * w**2
    a22 = E25 * I * k**2 + kga - RHO * I * (w**2 - 2.0 * spin * w)
    roots = (a11 * a22 - (kga * k) ** 2).roots()
    roots = np.real(roots[np.abs(np.imag(roots)) < 1e-6 * np.abs(roots)])
    return float(np.min(roots[roots > 0])), float(np.min(-roots[roots < 0]))


def _pinned_reduced(n_el: int, L: float, d: float):
    M, K, G = _assemble(n_el, L, d)
    n = M.shape[0]
    lateral = np.array([i for i in range(n) if i % 6 in (0, 1, 3, 4)])
    last = 6 * n_el
    keep = np.setdiff1d(lateral, [0, 1, last, last + 1])
    return M[np.ix_(keep, keep)], K[np.ix_(keep, keep)], G[np.ix_(keep, keep)], keep


def test_pinned_pinned_natural_frequencies_match_timoshenko() -> None:
    L, d, n_el = 0.4, 0.05, 16  # L/d = 8: shear and rotary inertia lower mode 3 by ~8 %
    M, K, _, _ = _pinned_reduced(n_el, L, d)
    w_fe = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real))
    w_fe = w_fe[::2]  # x-z and y-z planes give equal pairs
    A, I = _section(d)
    for mode in (1, 2, 3):
        w_ref, _ = _timoshenko_pinned(mode * np.pi / L, L, d)
        assert w_fe[mode - 1] == pytest.approx(w_ref, rel=1e-2)
        euler = (mode * np.pi / L) ** 2 * np.sqrt(E25 * I / (RHO * A))
        if mode == 3:
            assert w_ref < 0.95 * euler  # the check distinguishes Timoshenko from Euler-Bernoulli


def test_spinning_shaft_forward_backward_whirl() -> None:
    L, d, n_el, spin = 0.4, 0.05, 16, 3000.0
    M, K, G, keep = _pinned_reduced(n_el, L, d)
    n = M.shape[0]
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, spin * G)]])
    lam, vec = np.linalg.eig(a)
    pos = lam.imag > 1.0
    lam, vec = lam[pos], vec[:, pos]
    order = np.argsort(lam.imag)
    w_fe = lam.imag[order][:2]
    w_f_ref, w_b_ref = _timoshenko_pinned(np.pi / L, L, d, spin)
    assert w_fe[0] == pytest.approx(w_b_ref, rel=1e-2)
    assert w_fe[1] == pytest.approx(w_f_ref, rel=1e-2)
    assert w_f_ref - w_b_ref > 0.01 * w_b_ref  # visible split
    # The higher one whirls forward (same sense as the spin): y lags x by 90 deg, y/x = -i.
    v = vec[:, order[1]]
    ix, iy = np.where(keep % 6 == 0)[0], np.where(keep % 6 == 1)[0]
    j = np.argmax(np.abs(v[ix]))
    assert v[iy[j]] / v[ix[j]] == pytest.approx(-1j, abs=1e-6)


def test_disc_on_tilt_spring_campbell_frequencies() -> None:
    disc = GearDisc(outer_diameter=0.3, bore_diameter=0.03, width=0.02, density=RHO)
    kt = BEARING_TYPES["A#"].k_tilt
    kr = BEARING_TYPES["A#"].k_radial
    m = RHO * np.pi / 4 * (0.3**2 - 0.03**2) * 0.02
    ip = m * (0.15**2 + 0.015**2) / 2
    i_d = m * (3 * (0.15**2 + 0.015**2) + 0.02**2) / 12
    M, G = disc.mass_matrix(), disc.gyroscopic_matrix()
    K = BEARING_TYPES["A#"].stiffness_matrix()
    keep = [0, 1, 2, 3, 4]  # theta_z is free (no torsional bearing stiffness)
    M, G, K = (x[np.ix_(keep, keep)] for x in (M, G, K))
    for spin in (0.0, 500.0, 2000.0):
        a = np.block([[np.zeros((5, 5)), np.eye(5)], [-np.linalg.solve(M, K), -np.linalg.solve(M, spin * G)]])
        w = np.sort(np.linalg.eigvals(a).imag)
        w = w[w > 0]
        w_f = (ip * spin + np.sqrt((ip * spin) ** 2 + 4 * i_d * kt)) / (2 * i_d)
        w_b = (-ip * spin + np.sqrt((ip * spin) ** 2 + 4 * i_d * kt)) / (2 * i_d)
        ref = np.sort([w_b, w_f, np.sqrt(kr / m), np.sqrt(kr / m), np.sqrt(BEARING_TYPES["A#"].k_axial / m)])
        np.testing.assert_allclose(w, ref, rtol=1e-9)


def test_matrix_properties() -> None:
    el = ShaftElement(0.02, 0.03, 0.01, carbon_steel())
    for t in (25.0, 225.0):
        M, K, G = el.mass_matrix(t), el.stiffness_matrix(t), el.gyroscopic_matrix(t)
        np.testing.assert_allclose(M, M.T, atol=0)
        np.testing.assert_allclose(K, K.T, atol=1e-6 * np.abs(K).max())
        np.testing.assert_allclose(G, -G.T, atol=0)
        assert np.linalg.eigvalsh(M).min() > 0
        ev = np.linalg.eigvalsh(K)
        assert ev.min() > -1e-9 * ev.max()
        assert np.sum(ev < 1e-9 * ev.max()) == 6  # six rigid-body modes
    # Rigid-body translation carries the element mass, rigid rotation about z its polar inertia.
    area = np.pi / 4 * (0.03**2 - 0.01**2)
    r = np.zeros(12)
    r[[0, 6]] = 1.0
    assert r @ el.mass_matrix(25.0) @ r == pytest.approx(RHO * area * 0.02, rel=1e-12)
    r = np.zeros(12)
    r[[5, 11]] = 1.0
    assert r @ el.mass_matrix(25.0) @ r == pytest.approx(
        RHO * np.pi / 32 * (0.03**4 - 0.01**4) * 0.02, rel=1e-12
    )
