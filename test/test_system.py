"""Assembly of the paper's gearbox (Fig 5, Eq 39) and its quasi-static balance.

Independent truth: the paper's topology (108 DOF, bearings at nodes 1, 9, 10, 18, gears at 5 and 14),
the kinematic ratio -z1/z2, rigid-body mass/inertia sums computed from the geometry, skew-symmetry of
G, and moment balance of the output shaft (mean mesh force = T2 / r_bg).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from roundoff import assert_psd, assert_symmetric, matrix_roundoff

from gear_rotor_sim.examples import paper_gearbox, single_rotor
from gear_rotor_sim.system import GearRotorSystem, shaft_rates_hz, static_solution

RHO = 7860.0


@pytest.fixture(scope="module")
def paper_system():
    return GearRotorSystem.from_config(paper_gearbox("A#"), 125.0)


def test_paper_topology(paper_system) -> None:
    s = paper_system
    assert s.ndof == 108 and s.n_nodes == 18
    assert [b.node0 + 1 for b in s.bearings] == [1, 9, 10, 18]
    assert len(s.free_dofs) == 107
    assert s.dof(1, "theta_z") not in s.free_dofs
    assert s.shaft_speed_ratios == pytest.approx([1.0, -29.0 / 49.0], rel=1e-15)
    # shaft rates: 3000 rpm input = 50 Hz, gear shaft 50 z1 / z2 (Table 3: z1 = 29, z2 = 49)
    assert shaft_rates_hz(paper_gearbox("A#"), 3000.0) == pytest.approx([50.0, 50.0 * 29.0 / 49.0], rel=1e-15)
    np.testing.assert_array_equal(s.shaft_of_node, [0] * 9 + [1] * 9)
    assert s.node_positions[4] == pytest.approx(0.070) and s.node_positions[8] == pytest.approx(0.140)
    np.testing.assert_allclose(s.G, -s.G.T, atol=0)
    np.testing.assert_allclose(s.M, s.M.T, atol=0)
    assert_symmetric(s.K, "K")
    assert np.linalg.eigvalsh(s.M).min() > matrix_roundoff(s.M)  # positive definite beyond round-off
    kf = s.K[np.ix_(s.free_dofs, s.free_dofs)]
    # positive semi-definite to round-off (entries reach 4.6e10: the zero eigenvalue comes out as
    # +-1e-6 depending on the CPU); only the output-shaft torsional mode is free (mesh absent)
    assert_psd(kf, "free K")
    assert int(np.sum(np.linalg.eigvalsh(kf) <= matrix_roundoff(kf))) == 1
    bearing_k = sum(b.stiffness[2, 2] for b in s.bearings)
    assert bearing_k == pytest.approx(4 * 2.28e7)
    # With the discs at nodes 5 and 14, the output shaft's gyroscopic terms are scaled by -29/49.
    i5, i14 = s.dof(5, "theta_x"), s.dof(14, "theta_x")
    disc_ip = [RHO * math.pi / 4 * (d**2 - 0.03**2) * 0.02 * (d**2 + 0.03**2) / 8 for d in (0.087, 0.147)]
    shaft_g = s.G[i5, i5 + 1] - disc_ip[0]
    assert s.G[i14, i14 + 1] == pytest.approx(-29 / 49 * (shaft_g + disc_ip[1]), rel=1e-12)


def test_rigid_body_mass_and_inertia(paper_system) -> None:
    s = paper_system
    shaft_mass = RHO * math.pi / 4 * 0.03**2 * 0.140  # Table 4: 3x20 + 2x10 + 3x20 mm
    discs = {5: (0.087,), 14: (0.147,)}
    m = {n: RHO * math.pi / 4 * (d**2 - 0.03**2) * 0.020 for n, (d,) in discs.items()}
    for shaft, node in ((0, 5), (1, 14)):
        nodes = np.arange(9) + 9 * shaft
        for k, ref in ((0, shaft_mass + m[node]), (2, shaft_mass + m[node])):
            r = np.zeros(s.ndof)
            r[6 * nodes + k] = 1.0
            assert r @ s.M @ r == pytest.approx(ref, rel=1e-12)
        r = np.zeros(s.ndof)
        r[6 * nodes + 5] = 1.0
        d = discs[node][0]
        ip_ref = RHO * math.pi / 32 * 0.03**4 * 0.140 + m[node] * (d**2 + 0.03**2) / 8
        assert r @ s.M @ r == pytest.approx(ip_ref, rel=1e-12)


def test_static_mean_mesh_force_equals_torque_over_base_radius(paper_system) -> None:
    s = paper_system
    mesh = s.meshes[0]
    q = static_solution(s)
    f_m = mesh.mean_stiffness * (mesh.line_of_action @ q - mesh.half_backlash)
    r_bg = 0.5 * 3e-3 * 49 * math.cos(math.radians(20.0))
    assert f_m == pytest.approx(200.0 / r_bg, rel=5e-3)
    # torque balance: the motor torque (reaction at the held theta_z of node 1) is T2 * r_bp / r_bg
    r_bp = 0.5 * 3e-3 * 29 * math.cos(math.radians(20.0))
    assert (s.K @ q)[s.dof(1, "theta_z")] == pytest.approx(200.0 * r_bp / r_bg, rel=5e-3)


def test_single_rotor_and_rayleigh_damping() -> None:
    cfg = single_rotor(0.5, 0.02, 10, bearing_type="B#", rayleigh_stiffness_s=1e-6, disc_node=6)
    s = GearRotorSystem.from_config(cfg, 25.0)
    assert s.ndof == 66 and s.meshes == () and len(s.free_dofs) == 65
    assert s.shaft_speed_ratios == pytest.approx([1.0])
    bearing_c = np.zeros_like(s.C)
    for b in s.bearings:
        idx = np.arange(6 * b.node0, 6 * b.node0 + 6)
        bearing_c[np.ix_(idx, idx)] += b.damping
    shaft_k = s.K.copy()
    for b in s.bearings:
        idx = np.arange(6 * b.node0, 6 * b.node0 + 6)
        shaft_k[np.ix_(idx, idx)] -= b.stiffness
    np.testing.assert_allclose(
        s.C - bearing_c, 1e-6 * shaft_k, rtol=1e-12, atol=1e-12 * np.abs(shaft_k).max()
    )
    m_disc = RHO * math.pi / 4 * (0.1**2 - 0.02**2) * 0.02
    r = np.zeros(s.ndof)
    r[0::6] = 1.0
    assert r @ s.M @ r == pytest.approx(m_disc + RHO * math.pi / 4 * 0.02**2 * 0.5, rel=1e-12)


def test_mesh_mode_shares_sum_to_the_mesh_springs_static_share(paper_system) -> None:
    """Mass-normalised modes give ``K_t^-1 = sum x x^T / w^2``, so the shares ``k_m (v . x)^2 / w^2`` sum
    to ``k_m v^T K_t^-1 v`` with ``K_t = K + k_m v v^T``. The output shaft turns against a load torque, not a
    spring, so without the mesh ``K`` is singular along ``v`` and that sum is 1 (Sherman-Morrison): the mesh
    spring takes all the strain energy of a load along its line of action.
    The mesh mode holds a large part."""
    from gear_rotor_sim.system import mesh_mode_shares

    m = paper_system.meshes[0]
    f = paper_system.free_dofs
    v = m.line_of_action[f]
    km = m.mean_stiffness
    f_hz, share = mesh_mode_shares(paper_system, km)
    k_t = paper_system.K[np.ix_(f, f)] + km * np.outer(v, v)
    static = km * float(v @ np.linalg.solve(k_t, v))
    assert np.all(np.diff(f_hz) >= 0) and np.all(share >= 0)
    assert math.isclose(float(share.sum()), static, rel_tol=1e-6)
    assert math.isclose(static, 1.0, rel_tol=1e-6) and share.max() > 0.4
