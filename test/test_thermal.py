"""Thermal node load (Eqs 9-12) against Table 2 and against thermoelastic statics.

Independent truth: free expansion a dT L of an unrestrained bar, the clamped-bar reaction E A a dT, the
series-spring split k_s a dT L / (1 + 2 k_s / k_b) between a shaft and its two axial bearings, the
paper's Table 2, and Table 1 values of E at the tabulated temperatures.
"""

from __future__ import annotations

import numpy as np
import pytest
from roundoff import roundoff

from gear_rotor_sim.elements import ShaftElement
from gear_rotor_sim.examples import single_rotor
from gear_rotor_sim.materials import carbon_steel
from gear_rotor_sim.system import GearRotorSystem, static_solution

A_EXP = 1.17e-5
# Table 2: temperature rise (C) and the paper's numerical thermal node load (N)
TABLE2 = [
    (50, 0.84346e5),
    (100, 1.6538e5),
    (150, 2.4187e5),
    (200, 3.1257e5),
    (250, 3.7624e5),
    (300, 4.3164e5),
]
E_TABLE1 = {125.0: 200e9, 225.0: 189e9, 325.0: 174e9}


def _shaft(n_el: int, length: float, d: float, t: float):
    el = ShaftElement(length / n_el, d, 0.0, carbon_steel())
    n = 6 * (n_el + 1)
    K, F = np.zeros((n, n)), np.zeros(n)
    for e in range(n_el):
        s = slice(6 * e, 6 * e + 12)
        K[s, s] += el.stiffness_matrix(t)
        F[s] += el.thermal_node_load(t, 25.0)
    return el, K, F


@pytest.mark.parametrize(("rise", "paper"), TABLE2)
def test_table2_axial_thermal_node_load(rise: float, paper: float) -> None:
    el = ShaftElement(0.020, 0.030, 0.0, carbon_steel())
    f = el.thermal_node_load(25.0 + rise, 25.0)
    assert f[8] == pytest.approx(paper, rel=1e-3)
    assert f[2] == pytest.approx(-paper, rel=1e-3)


@pytest.mark.parametrize("t", [125.0, 225.0, 325.0])
def test_free_shaft_expands_without_stress(t: float) -> None:
    L, d, n_el = 0.16, 0.03, 8
    el, K, F = _shaft(n_el, L, d, t)
    free = np.arange(6, K.shape[0])  # node 1 clamped: statically determinate
    q = np.zeros(K.shape[0])
    q[free] = np.linalg.solve(K[np.ix_(free, free)], F[free])
    assert q[6 * n_el + 2] == pytest.approx(A_EXP * (t - 25.0) * L, rel=1e-12)
    lateral = [i for i in range(K.shape[0]) if i % 6 != 2]
    assert np.max(np.abs(q[lateral])) <= roundoff(A_EXP * (t - 25.0) * L, K.shape[0])
    for e in range(n_el):  # element stress resultants K q - F_T vanish (zero thermal stress)
        s = slice(6 * e, 6 * e + 12)
        r = el.stiffness_matrix(t) @ q[s] - el.thermal_node_load(t, 25.0)
        assert np.max(np.abs(r)) < 1e-9 * E_TABLE1[t] * el.area * A_EXP * (t - 25.0)


@pytest.mark.parametrize("t", [125.0, 225.0, 325.0])
def test_clamped_shaft_reaction(t: float) -> None:
    L, d, n_el = 0.16, 0.03, 8
    _, K, F = _shaft(n_el, L, d, t)
    n = K.shape[0]
    fixed = [0, 1, 2, 3, 4, 5, 6 * n_el + 2]  # clamp node 1, axial restraint at the far end
    free = np.setdiff1d(np.arange(n), fixed)
    q = np.zeros(n)
    q[free] = np.linalg.solve(K[np.ix_(free, free)], F[free])
    reaction = (K @ q - F)[6 * n_el + 2]  # support force on the far end node (negative: compressive)
    expected = E_TABLE1[t] * np.pi * d**2 / 4 * A_EXP * (t - 25.0)
    assert -reaction == pytest.approx(expected, rel=1e-9)
    assert np.max(np.abs(q)) <= roundoff(A_EXP * (t - 25.0) * L, n)  # none (the free expansion is the scale)


@pytest.mark.parametrize("t", [125.0, 225.0, 325.0])
def test_axial_bearing_force_with_paper_bearings(t: float) -> None:
    L, d = 0.14, 0.03  # the paper's input shaft (Table 4) on two A# bearings (Table 5)
    cfg = single_rotor(L, d, 8, bearing_type="A#")
    system = GearRotorSystem.from_config(cfg, t)
    q = static_solution(system)
    k_b = 2.28e7  # Table 5, A#
    k_s = E_TABLE1[t] * np.pi * d**2 / 4 / L
    expected = k_s * A_EXP * (t - 25.0) * L / (1.0 + 2.0 * k_s / k_b)
    f1 = k_b * q[system.dof(1, "z")]
    f9 = k_b * q[system.dof(9, "z")]
    assert -f1 == pytest.approx(expected, rel=1e-9)
    assert f9 == pytest.approx(expected, rel=1e-9)


def test_uniform_temperature_gives_no_lateral_load() -> None:
    _, _, F = _shaft(8, 0.16, 0.03, 225.0)
    lateral = [i for i in range(F.size) if i % 6 != 2]
    assert np.all(F[lateral] == 0.0)
    assert abs(F[2::6].sum()) < 1e-9 * np.abs(F).max()  # self-equilibrated
    assert np.count_nonzero(F) == 2  # internal nodes cancel: only the shaft ends are loaded


def test_zero_temperature_rise_gives_zero_load_and_room_stiffness() -> None:
    el = ShaftElement(0.02, 0.03, 0.0, carbon_steel())
    assert np.all(el.thermal_node_load(25.0, 25.0) == 0.0)
    k = el.stiffness_matrix(25.0)
    area = np.pi * 0.03**2 / 4
    assert k[2, 2] == pytest.approx(207e9 * area / 0.02, rel=1e-13)
    assert k[5, 5] == pytest.approx(207e9 / (2 * 1.29) * np.pi * 0.03**4 / 32 / 0.02, rel=1e-13)
    system = GearRotorSystem.from_config(single_rotor(0.16, 0.03, 8, bearing_type="A#"), 25.0)
    assert np.all(system.static_load == 0.0)
    assert np.all(system.thermal_load == 0.0)


def test_bearing_baseline_set_leaves_the_thermal_axial_load_alone() -> None:
    """The bearing baseline set (a lateral stiffness scale identified from the shaft-bearing modes)
    must not move the calibration's thermometer: with it applied, the axial bearing force is still
    the series-spring split with the NOMINAL axial stiffness (Table 5), while the radial stiffness is
    scaled (issue 11: a lateral scale 0.522 carried to k_b read a +60 C offset as +111 C)."""
    from gear_rotor_sim.faults import BearingStiffnessDamping

    L, d, t = 0.14, 0.03, 125.0
    cfg = BearingStiffnessDamping(0.522, 1.3).modify_config(single_rotor(L, d, 8, bearing_type="A#"))
    system = GearRotorSystem.from_config(cfg, t)
    q = static_solution(system)
    k_b = 2.28e7  # Table 5, A#
    k_s = E_TABLE1[t] * np.pi * d**2 / 4 / L
    expected = k_s * A_EXP * (t - 25.0) * L / (1.0 + 2.0 * k_s / k_b)
    assert k_b * q[system.dof(9, "z")] == pytest.approx(expected, rel=1e-9)
    props = [b.properties for b in cfg.bearings]
    assert all(p.k_axial == k_b and p.k_radial == pytest.approx(0.522 * 1.15e8, rel=1e-12) for p in props)
