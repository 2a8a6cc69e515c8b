"""Mesh coupling (Eqs 21-29): line of action, friction, backlash, mesh force, damping, assembly data."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from roundoff import roundoff

from gear_rotor_sim.elements.mesh import (
    backlash_functions,
    build_mesh_coupling,
    equivalent_mass,
    friction_vector,
    line_of_action_vector,
    mesh_damping,
    mesh_force,
    mesh_phase,
    static_transmission_error,
)
from gear_rotor_sim.materials import carbon_steel

ALPHA = math.radians(20.0)
RBP = 0.003 * 29 / 2 * math.cos(ALPHA)
RBG = 0.003 * 49 / 2 * math.cos(ALPHA)
NDOF = 6 * 18
PINION, GEAR = 4, 13  # 0-based nodes 5 and 14 of Fig 5


def _cfg(**changes: object) -> SimpleNamespace:
    base = {
        "module_m": 3e-3,
        "pressure_angle_rad": ALPHA,
        "face_width_m": 0.02,
        "addendum_coefficient": 1.0,
        "clearance_coefficient": 0.25,
        "half_backlash_m": 35e-6,
        "transmission_error_amplitude_m": 20e-6,
        "transmission_error_phase_rad": 0.3,
        "friction_coefficient": 0.05,
        "damping_ratio": 0.07,
        "thermal_backlash": True,
        "pinion_teeth": 29,
        "gear_teeth": 49,
        "pinion_bore_diameter_m": 0.03,
        "gear_bore_diameter_m": 0.03,
    }
    base.update(changes)
    return SimpleNamespace(**base)


def _disc_inertia(d_out: float, d_in: float = 0.03, w: float = 0.02, rho: float = 7860.0) -> float:
    return rho * math.pi * w * (d_out**4 - d_in**4) / 32.0


IP, IG = _disc_inertia(0.087), _disc_inertia(0.147)


def _build(temperature_c: float = 25.0, **changes: object):
    mat = carbon_steel()
    cfg = _cfg(**changes)
    return build_mesh_coupling(cfg, PINION, GEAR, 0, 1, NDOF, temperature_c, mat, mat, 25.0, IP, IG, 29, 49)


def _global_vf_rows(mc, phase: np.ndarray) -> np.ndarray:
    return (mc.force_basis @ mc.force_coefficients(phase).T).T  # (n, ndof)


def _local(vec: np.ndarray) -> np.ndarray:
    return np.concatenate([vec[..., 6 * PINION : 6 * PINION + 6], vec[..., 6 * GEAR : 6 * GEAR + 6]], axis=-1)


def test_line_of_action_vector_eq22() -> None:
    v = line_of_action_vector(ALPHA, RBP, RBG)
    s, c = math.sin(ALPHA), math.cos(ALPHA)
    np.testing.assert_allclose(v, [s, c, 0, 0, 0, RBP, -s, -c, 0, 0, 0, RBG])
    mc = _build()
    np.testing.assert_allclose(_local(mc.line_of_action), v)
    assert np.count_nonzero(mc.line_of_action) == 6
    np.testing.assert_allclose(mc.force_basis[:, 0], -mc.line_of_action)


def test_static_mesh_force_balances_output_torque() -> None:
    # Pinion held (drive), gear free in torsion, load torque +200 N m on the gear (opposing its spin).
    mc = _build(friction_coefficient=0.0)
    k = mc.mean_stiffness
    ig = 6 * GEAR + 5
    # Equilibrium of the gear's theta_z: generalised mesh force (-V F_m) + T = 0 with F_m = k V q.
    th = 200.0 / (k * mc.line_of_action[ig] ** 2)
    q = np.zeros(NDOF)
    q[ig] = th
    f_m = k * mc.line_of_action @ q
    gen = mc.force_basis @ mc.force_coefficients(np.array([0.2]))[0] * f_m
    assert abs(gen[ig] + 200.0) <= roundoff(200.0, 12)
    assert f_m == pytest.approx(200.0 / 0.06906741, rel=1e-6)
    assert f_m > 0.0


def test_friction_vector_tends_to_minus_v() -> None:
    phase = np.linspace(0.0, 1.0, 97, endpoint=False)
    v = line_of_action_vector(ALPHA, RBP, RBG)
    for mu in (1e-6, 1e-9):
        rows = _local(_global_vf_rows(_build(friction_coefficient=mu), phase))
        np.testing.assert_allclose(rows, np.broadcast_to(-v, rows.shape), rtol=0, atol=mu)  # |a| <= mu
    rows0 = _local(_global_vf_rows(_build(friction_coefficient=0.0), phase))
    np.testing.assert_array_equal(rows0, np.broadcast_to(-v, rows0.shape))


def test_friction_basis_reproduces_eq29_columns() -> None:
    mc = _build(friction_coefficient=0.05)
    phase = np.linspace(0.0, 1.0, 50, endpoint=False)
    coef = mc.force_coefficients(phase)
    np.testing.assert_allclose(coef[:, 0], 1.0)
    expect = friction_vector(ALPHA, RBP, RBG, coef[:, 1], coef[:, 2], coef[:, 3])
    s, c = math.sin(ALPHA), math.cos(ALPHA)
    a = coef[:, 1]
    np.testing.assert_allclose(expect[:, 0], -s + a * c)  # Eq 29, pinion x
    np.testing.assert_allclose(expect[:, 7], c + a * s)  # Eq 29, gear y
    np.testing.assert_allclose(
        _local(_global_vf_rows(mc, phase)), expect, rtol=0, atol=roundoff(np.abs(expect).max(), 4)
    )


def test_friction_dissipates_and_reverses_at_pitch_point() -> None:
    mu = 0.05
    mc = _build(friction_coefficient=mu)
    phase = np.linspace(0.0, 1.0, 400, endpoint=False)
    rows = _local(_global_vf_rows(mc, phase))
    v = line_of_action_vector(ALPHA, RBP, RBG)
    # Rigid-body rotation at the kinematic ratio: pinion +1 rad/s, gear -r_bp/r_bg.
    qdot = np.zeros(12)
    qdot[5], qdot[11] = 1.0, -RBP / RBG
    assert abs(v @ qdot) <= roundoff(RBP, 12)
    power = (rows + v) @ qdot  # friction part of V_f per unit F_m
    assert np.all(power <= roundoff(np.abs(rows).max(), 12))
    # Single contact: the one pair sits at s = s_A + phase p_b; a = -mu before the pitch point, +mu after.
    loa = (0.003 * 39) * math.sin(ALPHA)
    s_a = loa - math.sqrt((73.5e-3 + 3e-3) ** 2 - RBG**2)
    p_b = math.pi * 3e-3 * math.cos(ALPHA)
    eps = (math.sqrt((46.5e-3) ** 2 - RBP**2) - s_a) / p_b
    single = phase[(phase > eps - 1.0 + 0.01) & (phase < 0.99)]
    s = s_a + single * p_b
    r_pinion = np.hypot(RBP, s)
    a = mc.force_coefficients(single)[:, 1]
    far = np.abs(r_pinion - 0.0435) > 2e-5  # away from the interpolation cell at the pitch point
    np.testing.assert_allclose(a[far], mu * np.sign(r_pinion - 0.0435)[far], rtol=1e-9)
    assert (a[far] < 0).any() and (a[far] > 0).any()
    # Moment arms: b1 = -a s (from T1), b2 = -a (T1T2 - s) in single contact.
    b = mc.force_coefficients(single[far])
    np.testing.assert_allclose(b[:, 2], -b[:, 1] * s[far], rtol=1e-6)
    np.testing.assert_allclose(b[:, 3], -b[:, 1] * (loa - s[far]), rtol=1e-6)


def test_backlash_functions_regions() -> None:
    b = 30e-6
    g0, g1 = backlash_functions(np.array([40e-6, 30e-6, 0.0, -30e-6, -40e-6]), b)
    np.testing.assert_array_equal(g1, [-1, 0, 0, 0, 1])
    np.testing.assert_array_equal(g0, [1, 0, 0, 0, 1])


def test_mesh_force_piecewise_and_continuous() -> None:
    k, c, b = 3e8, 1500.0, 30e-6
    d = np.array([50e-6, -50e-6, 10e-6])
    f = mesh_force(d, np.zeros(3), k, c, b)
    np.testing.assert_allclose(f, [k * 20e-6, -k * 20e-6, 0.0])
    h = 1e-12
    for edge in (b, -b):
        left = mesh_force(edge - h, 0.0, k, c, b)
        right = mesh_force(edge + h, 0.0, k, c, b)
        assert abs(float(left) - float(right)) <= k * 2.1 * h
    assert float(mesh_force(50e-6, 1e-3, k, c, b)) == pytest.approx(k * 20e-6 + c * 1e-3)
    assert float(mesh_force(0.0, 1e-3, k, c, b)) == 0.0  # no damping force inside the backlash


def test_static_transmission_error_and_phase() -> None:
    ph = np.linspace(0.0, 3.0, 31)
    e = static_transmission_error(ph, 20e-6, 0.3)
    np.testing.assert_allclose(e, 20e-6 * np.sin(2 * np.pi * ph + 0.3))
    # sin(2 pi (ph + 1) + 0.3): the argument (up to 2 pi 4) is rounded, the result carries that times e0
    np.testing.assert_allclose(
        static_transmission_error(ph + 1.0, 20e-6, 0.3), e, rtol=0, atol=roundoff(20e-6 * 2 * np.pi * 4.0)
    )
    # One pinion tooth pitch is one mesh period.
    assert mesh_phase(2 * math.pi / 29 * 2.25, 29) == pytest.approx(0.25)


def test_mesh_damping_matches_torsional_mode() -> None:
    k, zeta = 3e8, 0.07
    # Two discs coupled by a spring along the line of action: omega^2 = k (r_bp^2/I_p + r_bg^2/I_g).
    kk = k * np.array([[RBP**2, RBP * RBG], [RBP * RBG, RBG**2]])
    omega2 = np.linalg.eigvals(np.linalg.solve(np.diag([IP, IG]), kk)).real.max()
    m_e = k / omega2
    assert equivalent_mass(IP, IG, RBP, RBG) == pytest.approx(m_e, rel=1e-10)
    c = mesh_damping(k, zeta, IP, IG, RBP, RBG)
    assert c == pytest.approx(2 * zeta * math.sqrt(k * m_e), rel=1e-10)
    mc = _build()
    assert mc.damping == pytest.approx(2 * 0.07 * math.sqrt(mc.mean_stiffness * m_e), rel=1e-10)


def test_coupling_backlash_and_temperature() -> None:
    b = 35e-6
    assert _build(25.0).half_backlash == b
    assert _build(225.0, thermal_backlash=False).half_backlash == b
    hot = _build(225.0)
    expect = b - 200 * 1.17e-5 * math.pi * 3e-3 * math.cos(ALPHA) / 4
    assert hot.half_backlash == pytest.approx(expect, rel=1e-12)
    cold = _build(25.0)
    assert hot.mean_stiffness < cold.mean_stiffness
    assert hot.te_amplitude == 20e-6 and hot.te_phase == 0.3
    assert cold.contact_ratio == pytest.approx(1.6985, abs=1e-4)
    ph = np.linspace(0.0, 1.0, 64, endpoint=False)
    np.testing.assert_allclose(cold.stiffness(ph + 1.0), cold.stiffness(ph))
    assert cold.stiffness(ph).mean() == pytest.approx(cold.mean_stiffness, rel=0.02)


def test_coupling_input_errors() -> None:
    mat = carbon_steel()
    with pytest.raises(ValueError, match="gear_node0"):
        build_mesh_coupling(_cfg(), 4, 40, 0, 1, NDOF, 25.0, mat, mat, 25.0, IP, IG)
    with pytest.raises(ValueError, match="friction_coefficient"):
        build_mesh_coupling(_cfg(friction_coefficient=-0.1), 4, 13, 0, 1, NDOF, 25.0, mat, mat, 25.0, IP, IG)
    with pytest.raises(ValueError, match="pinion_bore_diameter"):
        build_mesh_coupling(_cfg(pinion_bore_diameter_m=None), 4, 13, 0, 1, NDOF, 25.0, mat, mat, 25.0)
    # Inertias default to the rigid annulus of the disc model (pitch diameter, bore, face width).
    mc = build_mesh_coupling(_cfg(), 4, 13, 0, 1, NDOF, 25.0, mat, mat, 25.0)
    assert mc.damping == pytest.approx(_build().damping, rel=1e-12)
