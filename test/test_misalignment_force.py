"""The axial force of a misaligned gear follows the instantaneous mesh force (faults/misalignment_force.py).

Truths used: the product of two Fourier series (hand computation of the sidebands), the torque balance
of the gear (the mean normal tooth force is ``T / r_b``), the decoupling of the axial degrees of
freedom from the spur mesh (the fixed point is reached in one pass), the orthogonality of the other
wheel's orders over a hunting period.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.faults import GearMisalignment
from gear_rotor_sim.faults.misalignment_force import (
    simulate_mesh_force,
    wheel_hz,
    wheel_orders,
    with_mesh_force,
)
from gear_rotor_sim.system import GearRotorSystem

SPEED_RPM = 3000.0


@pytest.fixture(scope="module")
def rig():
    cfg = paper_gearbox()
    return cfg, GearRotorSystem.from_config(cfg, 25.0)


def _ctx(system, theta_gear: np.ndarray) -> SimpleNamespace:
    """Step context with the gear shaft at ``theta_gear`` (what ``force_amplitudes`` reads)."""
    n_shafts = int(np.max(system.shaft_of_node)) + 1
    angle = np.zeros((theta_gear.size, n_shafts))
    m = system.meshes[0]
    angle[:, m.gear_shaft] = theta_gear
    return SimpleNamespace(system=system, shaft_angle=angle)


def _orders_of(theta: np.ndarray, x: np.ndarray, orders: list[int]) -> np.ndarray:
    """Order coefficients (peak/2) of samples uniform over one revolution."""
    return np.array([np.mean(x * np.exp(-1j * k * theta)) for k in orders])


def test_static_limit_is_the_static_mesh_force_times_the_tilt(rig):
    cfg, system = rig
    e = GearMisalignment(angle_rad=1e-3, phase_rad=0.4)
    theta = 2 * np.pi * np.arange(512) / 512
    amp = e.force_amplitudes(_ctx(system, theta))[:, 0]
    # T / r_b of the paper gearbox's load, by hand from the config
    f0 = cfg.load.torque_nm / system.meshes[0].base_radius_gear
    np.testing.assert_allclose(amp, f0 * 1e-3 * np.cos(theta + 0.4), rtol=1e-12)
    # with the orders of a constant force F0 the same
    e0 = GearMisalignment(angle_rad=1e-3, phase_rad=0.4, mesh_force_orders=(complex(f0),))
    np.testing.assert_allclose(e0.force_amplitudes(_ctx(system, theta))[:, 0], amp, rtol=1e-12)


def test_mesh_harmonic_gives_sidebands_of_the_wheel_orders(rig):
    """``2 Re(c e^{i z theta}) cos(theta + phi)`` has the orders ``z +- 1`` with ``c e^{+-i phi} / 2``."""
    _, system = rig
    z = int(system.meshes[0].gear_teeth)
    f0, c, angle, phi = 2900.0, 40.0 - 25.0j, 1e-3, 0.7
    coef = np.zeros(z + 1, dtype=complex)
    coef[0], coef[z] = f0, c
    e = GearMisalignment(angle_rad=angle, phase_rad=phi, mesh_force_orders=tuple(coef))
    n = 64 * z
    theta = 2 * np.pi * np.arange(n) / n
    amp = e.force_amplitudes(_ctx(system, theta))[:, 0]
    got = _orders_of(theta, amp, [1, z - 1, z + 1, 2])
    want = np.array(
        [
            f0 * angle * np.exp(1j * phi) / 2,
            angle * c * np.exp(-1j * phi) / 2,
            angle * c * np.exp(1j * phi) / 2,
            0,
        ]
    )
    # the grid interpolation's error is below 0.5 % of the highest order's amplitude (order_grid)
    np.testing.assert_allclose(got, want, rtol=0, atol=5e-3 * abs(want[1]))


def test_wheel_orders_recover_a_synthetic_force_and_drop_the_other_wheel(rig):
    cfg, _ = rig
    e = GearMisalignment(angle_rad=1e-3)
    f_g = wheel_hz(cfg, e, SPEED_RPM)
    f_p = wheel_hz(cfg, GearMisalignment(member="pinion"), SPEED_RPM)
    m = cfg.meshes[0]
    zp, zg = m.pinion_teeth, m.gear_teeth
    period = math.lcm(zp, zg) / (zp * abs(f_p))  # hunting period
    fs = 20000.0
    t = np.arange(round(period * fs)) / fs
    th_g, th_p = 2 * np.pi * f_g * t, 2 * np.pi * f_p * t
    x = 2900.0 + 2 * np.real(30.0 * np.exp(1j * (zg * th_g + 0.3))) + 2 * np.real(5.0 * np.exp(2j * th_g))
    x += 20.0 * np.cos(3 * th_p + 1.0)  # the pinion's order 3: not synchronous with the gear
    coef = wheel_orders(t, x, f_g, 120)
    want = np.zeros(121, dtype=complex)
    want[0], want[2], want[zg] = 2900.0, 5.0, 30.0 * np.exp(0.3j)
    np.testing.assert_allclose(coef, want, rtol=0, atol=1e-6 * 2900.0)


def test_wheel_orders_reject_bad_input():
    t = np.arange(100) / 1000.0
    with pytest.raises(ValueError, match="max_order"):
        wheel_orders(t, np.ones(100), 10.0, 60)
    with pytest.raises(ValueError, match="shaft_hz"):
        wheel_orders(t, np.ones(100), 0.0, 3)
    with pytest.raises(ValueError, match="t, force"):
        wheel_orders(t, np.ones(99), 10.0, 3)


def test_wheel_orders_memo_returns_the_first_solution_and_tells_inputs_apart():
    """The memo of repeated solves (``misalignment_force._ORDERS``, docs/history/calibration_sessions.md
    Sec. 8.39): a repeated call returns the first solution bit for bit, a caller changing its copy does not
    change the stored one, and a force, a shaft frequency or an order count differing anywhere is solved
    anew."""
    from gear_rotor_sim.faults import misalignment_force as mf

    fs, f_s = 4000.0, 25.0
    t = np.arange(1600) / fs  # ten revolutions
    th = 2 * np.pi * f_s * t
    x = 2900.0 + 40.0 * np.cos(3 * th + 0.2) + 7.0 * np.sin(11 * th)
    mf._ORDERS.clear()
    first = wheel_orders(t, x, f_s, 20)
    assert len(mf._ORDERS) == 1
    kept = first.copy()
    first[:] = 0.0  # the caller's copy
    again = wheel_orders(t, x, f_s, 20)
    assert len(mf._ORDERS) == 1
    np.testing.assert_array_equal(again, kept)
    mf._ORDERS.clear()
    np.testing.assert_array_equal(wheel_orders(t, x, f_s, 20), kept)  # solved anew: the same bits
    y = x.copy()
    y[977] += 1e-6  # one sample, 3e-10 of the force
    moved = wheel_orders(t, y, f_s, 20)
    assert len(mf._ORDERS) == 2 and not np.array_equal(moved, kept)
    assert not np.array_equal(wheel_orders(t, x, 1.0001 * f_s, 20), kept)
    assert wheel_orders(t, x, f_s, 19).shape == (20,) and len(mf._ORDERS) == 4


def test_mean_mesh_force_is_the_torque_balance_and_one_pass_is_the_fixed_point(rig):
    """A full simulation at 3000 rpm (teeth in contact), 1 mrad on the gear: the run's mean mesh force
    equals ``T / r_b`` (the gear's torque balance), and a second pass (the mesh force of a run with the
    first pass's axial force) returns the same orders: the axial force does not act on the spur mesh."""
    cfg, system = rig
    run = simulate_mesh_force(cfg, SPEED_RPM, 25.0, min_window_s=0.3)
    e = GearMisalignment(angle_rad=1e-3, phase_rad=0.2)
    (e1,) = with_mesh_force(cfg, (e,), SPEED_RPM, 20000.0, run)
    c1 = np.asarray(e1.mesh_force_orders)
    f0 = cfg.load.torque_nm / system.meshes[0].base_radius_gear
    assert abs(c1[0].real - f0) <= 5e-3 * f0
    z = int(system.meshes[0].gear_teeth)
    # the mesh fundamental is a few percent of F0 in contact (not zero: the sidebands are real)
    assert 0.005 * f0 < 2 * abs(c1[z]) < 0.2 * f0
    (e2,) = with_mesh_force(cfg, (e,), SPEED_RPM, 20000.0, lambda eff, ch: run((e1,), ch))
    c2 = np.asarray(e2.mesh_force_orders)
    np.testing.assert_allclose(c2, c1, rtol=0, atol=1e-9 * f0)
