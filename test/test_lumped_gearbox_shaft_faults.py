"""The independent generator's out-of-library faults against analytic expectations
(``lumped_gearbox/shaft_faults.py``: a breathing shaft crack, a Cardan joint at the input)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lumped_gearbox import build, make_fault, parse_fault, run
from lumped_gearbox import model as mdl
from lumped_gearbox.params import Gearbox
from lumped_gearbox.shaft_faults import cardan_lag, crack_force


def _orders(x: np.ndarray, fs: float, f: float, ks: list[int]) -> np.ndarray:
    """Complex amplitudes of orders ``ks`` of ``f`` over whole revolutions."""
    m = round(int(x.size * f / fs) * fs / f)
    t = np.arange(m) / fs
    return np.array([2.0 * np.mean(x[:m] * np.exp(-2j * np.pi * k * f * t)) for k in ks])


def test_crack_force_only_while_open():
    k = 1e8
    loss = 0.2 * k
    psi = 0.3
    n = np.array([math.cos(psi), math.sin(psi)])
    d_open = 1e-5 * np.array([1.0, 0.5])  # n . d > 0: tension at the crack's mouth
    fx, fy = crack_force(*d_open, psi, 1.0, loss)
    np.testing.assert_allclose([fx, fy], loss * float(n @ d_open) * n, rtol=1e-12)
    assert crack_force(*(-d_open), psi, 1.0, loss) == (0.0, 0.0)  # closed: the full stiffness
    # the gear turns the other way: its crack mouth is at (cos, -sin) of its angle
    ng = np.array([math.cos(psi), -math.sin(psi)])
    dg = 1e-5 * ng
    np.testing.assert_allclose(crack_force(*dg, psi, -1.0, loss), loss * 1e-5 * ng, rtol=1e-12)


def test_kernel_stiffness_drop_normal_to_the_open_crack_only():
    """The pinion's lateral acceleration changes by ``dk (n . d) n / m1`` while the crack is open, not at all
    while it is closed (the kernel against the switching-crack stiffness ``k I - dk n n^T``)."""
    gb = Gearbox()
    healthy = build(gb, 3000.0, 25.0)
    cracked = build(gb, 3000.0, 25.0, [make_fault("shaft_crack", stiffness_loss=0.25, phase_rad=0.0)])
    k1, m1 = cracked.kk[mdl.K_L1], cracked.mass[mdl.M_M1]
    t = 0.0  # shaft angle 0: the crack's mouth along +x
    for dx, is_open in ((2e-5, True), (-2e-5, False)):
        q = healthy.static_state()
        q[0], q[1] = dx, -3e-5
        v = np.zeros(8)
        a0, a1 = np.empty(8), np.empty(8)
        s = healthy
        mdl._rhs(
            t, q, v, a0, s.geo, s.mass, s.kk, s.cc, s.load, s.fault, s.tooth_p, s.tooth_g, s.profile, s.pitch
        )
        s = cracked
        mdl._rhs(
            t, q, v, a1, s.geo, s.mass, s.kk, s.cc, s.load, s.fault, s.tooth_p, s.tooth_g, s.profile, s.pitch
        )
        expect = 0.25 * k1 * dx / m1 if is_open else 0.0
        assert a1[0] - a0[0] == pytest.approx(expect, rel=1e-9, abs=1e-9 * abs(a0[0]))
        assert a1[1] == a0[1]  # the mouth along x: no force across it
        np.testing.assert_array_equal(a1[2:], a0[2:])


def test_cracked_pinion_deflects_quasi_statically_with_orders_1_to_3():
    """At 3000 rpm the shaft orders (50-150 Hz) lie far below the lateral modes (874, 1366 Hz) and the free
    gear keeps the mesh force at T2 / rb2 there: the pinion's deflection is ``K(psi)^-1 F`` with
    ``K = k I - dk n n^T`` while ``n . d > 0``. Its orders 1-3 against that analytic deflection."""
    gb = Gearbox()
    loss, phase = 0.3, 0.7
    setup = build(gb, 3000.0, 25.0, [parse_fault(f"shaft_crack:stiffness_loss={loss},phase_rad={phase}")])
    out = run(setup, 1.0, substeps=8)
    k = setup.kk[mdl.K_L1]
    sa, ca = setup.geo[mdl.G_SA], setup.geo[mdl.G_CA]
    force = -float(np.mean(out["mesh_force"])) * np.array([sa, ca])
    psi = setup.geo[mdl.G_W1] * out["time_s"] + phase
    n = np.column_stack([np.cos(psi), np.sin(psi)])
    nf = n @ force
    d = force[None, :] / k + np.where(nf > 0, loss / (k * (1 - loss)) * nf, 0.0)[:, None] * n
    fr = 3000.0 / 60.0
    for j in range(2):
        got = _orders(out["q"][:, j], 20000.0, fr, [1, 2, 3])
        want = _orders(d[:, j], 20000.0, fr, [1, 2, 3])
        assert np.all(np.abs(want) > 1e-8)  # the crack's orders: microns
        np.testing.assert_allclose(np.abs(got), np.abs(want), rtol=0.05)
    healthy = run(build(gb, 3000.0, 25.0), 1.0, substeps=8)
    assert np.all(np.abs(_orders(healthy["q"][:, 0], 20000.0, fr, [1, 2, 3])) < 1e-3 * np.abs(want))


def test_cardan_lag_is_hookes_joint():
    beta = 0.1
    for psi in np.linspace(-3.0, 3.0, 13):
        lag, rate = cardan_lag(psi, beta, 100.0)
        # the driven end at psi + lag: tan(psi + lag) = tan(psi) / cos(beta)
        assert math.tan(psi + lag) == pytest.approx(math.tan(psi) / math.cos(beta), rel=1e-9, abs=1e-12)
        assert abs(lag - beta**2 / 4 * math.sin(2 * psi)) < beta**4  # the small-angle form
        h = 1e-6
        fd = (cardan_lag(psi + h, beta, 100.0)[0] - cardan_lag(psi - h, beta, 100.0)[0]) / (2 * h) * 100.0
        assert rate == pytest.approx(fd, rel=1e-5, abs=1e-9)


def test_cardan_pinion_follows_the_joint_at_twice_the_input_order():
    """At 3000 rpm the joint's 2x (100 Hz) lies below the drive train's first torsion mode (550 Hz): the
    pinion's angle follows the driven end's lag ``beta^2 / 4 sin(2 psi)`` within the quasi-static
    amplification ``1 / (1 - (100 / 550)^2) = 1.034``; a healthy drive has no 2x."""
    gb = Gearbox()
    beta = 0.06
    out = run(build(gb, 3000.0, 25.0, [make_fault("cardan_misalignment", angle_rad=beta)]), 1.0, substeps=8)
    a2 = abs(_orders(out["q"][:, 3], 20000.0, 50.0, [2])[0])
    assert a2 / (beta**2 / 4) == pytest.approx(1.0, abs=0.06)
    healthy = run(build(gb, 3000.0, 25.0), 1.0, substeps=8)
    assert abs(_orders(healthy["q"][:, 3], 20000.0, 50.0, [2])[0]) < 1e-3 * a2


def test_new_fault_fields_and_ranges():
    with pytest.raises(ValueError, match=r"shaft_crack\.stiffness_loss"):
        parse_fault("shaft_crack:stiffness_loss=0.7")
    with pytest.raises(ValueError, match=r"shaft_crack\.shaft"):
        parse_fault("shaft_crack:shaft=motor,stiffness_loss=0.1")
    with pytest.raises(ValueError, match=r"cardan_misalignment\.angle_rad"):
        parse_fault("cardan_misalignment:angle_rad=1.0")
    f = parse_fault("shaft_crack:shaft=gear,stiffness_loss=0.2,phase_rad=1")
    assert (f.shaft, f.stiffness_loss, f.phase_rad, f.main) == ("gear", 0.2, 1.0, "stiffness_loss")
