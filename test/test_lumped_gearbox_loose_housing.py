"""The generator's loose bearing housing (lumped_gearbox/loose_housing.py) against analytic limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lumped_gearbox import Gearbox, build, make_record, parse_fault, run, springs

T2 = 200.0  # Table 3, N m
A = math.radians(20.0)
RB2 = 0.5 * 3e-3 * 49 * math.cos(A)


def _k(loss: float) -> tuple[float, float]:
    """``k_0`` and ``k_c`` from the beam formula and the bearing (Table 5), independently of the module."""
    sp = springs(Gearbox(), 25.0)
    kb = Gearbox().k_radial
    k0 = 1.0 / (1.0 / sp.lateral_bending + 1.0 / (2.0 * kb))
    kc = 1.0 / (1.0 / sp.lateral_bending + 1.0 / ((2.0 - loss) * kb))
    return k0, kc


def test_a_tight_foot_is_the_healthy_record_bit_for_bit():
    """No stiffness lost, no clearance, no unbalance: the support is linear, the record unchanged."""
    healthy = make_record(speed_rpm=3000.0, duration_s=0.1, seed=5)
    tight = make_record(speed_rpm=3000.0, duration_s=0.1, seed=5, faults=["loose_housing:stiffness_loss=0"])
    for ch, x in healthy.data.items():
        assert np.array_equal(x, tight.data[ch]), ch


def _static(loss: float, p: float) -> tuple[float, float, float]:
    """Bearing 2's mean force and the pinion's mean displacement along the lift direction ``-(sin a, cos a)``
    (the mesh load's push, ``direction_rad = -pi/2``), and the mean mesh force, without STE."""
    fault = f"loose_housing:stiffness_loss={loss},preload_n={p},direction_rad={-math.pi / 2}"
    r = run(build(Gearbox(), 3000.0, 25.0, [parse_fault(fault)], ste=False), 0.1)
    n = -np.array([math.sin(A), math.cos(A)])
    b = np.mean(np.column_stack([r["bearing2_fx"], r["bearing2_fy"]]) @ n)
    return float(b), float(np.mean(r["q"][:, 0:2] @ n)), float(np.mean(r["mesh_force"]))


def test_static_lift_off_under_the_mesh_load():
    """The lift direction along the mesh load's push: the foot lifts once bearing 2's push exceeds the
    hold-down ``P``; statically ``B = P + (1 - loss) / (2 - loss) (F - 2 P)`` and
    ``u = u_l + (F - 2 P) / k_c``."""
    loss, p = 0.6, 400.0
    f = T2 / RB2
    assert f > 2.0 * p  # bearing 2's static share f / 2 exceeds the hold-down: lifted
    b, u, fm = _static(loss, p)
    k0, kc = _k(loss)
    assert abs(fm - f) < 0.01 * f
    assert b == pytest.approx(p + (1.0 - loss) / (2.0 - loss) * (fm - 2.0 * p), rel=0.01)
    assert u == pytest.approx(2.0 * p / k0 + (fm - 2.0 * p) / kc, rel=0.01)
    # held down (P above bearing 2's share): the linear support, B = F / 2
    b, _, fm = _static(loss, f)
    assert b == pytest.approx(0.5 * fm, rel=0.01)


def test_rotating_load_far_below_resonance_gives_the_half_wave_bilinear_force():
    """A rotating force ``F = U w^2`` across the line of action, 50 Hz against a lateral mode near 1 kHz: the
    quasi-static bilinear response. Bearing 2 passes ``F cos / 2`` while the foot is down and ``s_2 F cos``
    while it is lifted, so its force holds ``1x = F (1/4 + s_2/2)``, ``2x = F (1/2 - s_2) 2 / (3 pi)`` and no
    odd harmonic (a half-wave rectified cosine)."""
    loss, unb = 0.8, 3e-4
    s = build(
        Gearbox(),
        3000.0,
        25.0,
        [parse_fault(f"loose_housing:stiffness_loss={loss},unbalance_kg_m={unb}")],
        ste=False,
    )
    r = run(s, 0.2)  # 10 turns
    n = np.array([math.cos(A), -math.sin(A)])  # across the line of action (direction_rad = 0)
    b = np.column_stack([r["bearing2_fx"], r["bearing2_fy"]]) @ n
    spec = np.abs(np.fft.rfft(b - b.mean())) * 2.0 / b.size
    f = unb * (3000.0 * 2.0 * math.pi / 60.0) ** 2
    s2 = (1.0 - loss) / (2.0 - loss)
    assert spec[10] == pytest.approx(f * (0.25 + 0.5 * s2), rel=0.02)
    assert spec[20] == pytest.approx(f * (0.5 - s2) * 2.0 / (3.0 * math.pi), rel=0.05)
    assert spec[30] < 0.02 * spec[20] and spec[50] < 0.02 * spec[20]


def test_bad_loose_housing_fields_are_named():
    with pytest.raises(ValueError, match=r"loose_housing\.stiffness_loss"):
        parse_fault("loose_housing:stiffness_loss=1.5")
    with pytest.raises(ValueError, match=r"loose_housing\.clearance_m"):
        parse_fault("loose_housing:clearance_m=-1e-6")
    with pytest.raises(ValueError, match=r"loose_housing\.unknown"):
        parse_fault("loose_housing:unknown=1")
