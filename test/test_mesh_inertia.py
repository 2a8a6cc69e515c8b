"""The gear inertia baseline set (faults/mesh_inertia.py; docs/history/calibration_sessions.md Sec. 8.41)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg as sla

from gear_rotor_sim.config import load_config
from gear_rotor_sim.faults.mesh_inertia import GearInertia, MeshInertia, scaled_gear_inertia
from gear_rotor_sim.system import GearRotorSystem, gear_disc


@pytest.fixture(scope="module")
def cfg():
    return load_config("paper_sun2021")


def _mesh_modes(system, k_scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and mesh strain-energy shares of the system linearised at its mean mesh stiffness."""
    mesh = system.meshes[0]
    f = system.free_dofs
    v = mesh.line_of_action[f]
    km = k_scale * mesh.mean_stiffness
    w2, x = sla.eigh(system.K[np.ix_(f, f)] + km * np.outer(v, v), system.M[np.ix_(f, f)])
    return np.sqrt(np.abs(w2)) / (2 * math.pi), km * (v @ x) ** 2 / np.abs(w2)


def test_gear_discs_scaled_shafts_and_mesh_damping_kept(cfg) -> None:
    s = 0.7
    mod = scaled_gear_inertia(cfg, s)
    for g0, g1 in zip(cfg.gears, mod.gears, strict=True):
        d0, d1 = gear_disc(cfg, g0), gear_disc(mod, g1)
        assert d1.mass == pytest.approx(s * d0.mass, rel=1e-12)
        assert d1.polar_inertia == pytest.approx(s * d0.polar_inertia, rel=1e-12)
    # the shafts keep their material (their mass matrix is unchanged)
    assert [e.material for sh in mod.shafts for e in sh.elements] == [
        e.material for sh in cfg.shafts for e in sh.elements
    ]
    a, b = GearRotorSystem.from_config(cfg, 75.0), GearRotorSystem.from_config(mod, 75.0)
    # c_m = 2 zeta sqrt(k m_e) (Eq 25) held: the damping ratio divided by sqrt(s)
    assert b.meshes[0].damping == pytest.approx(a.meshes[0].damping, rel=1e-12)
    assert b.meshes[0].mean_stiffness == pytest.approx(a.meshes[0].mean_stiffness, rel=1e-12)
    np.testing.assert_array_equal(a.K, b.K)
    # the mass matrix differs only at the two gear nodes
    nodes = {g.node0 for g in cfg.gears}
    diff = np.flatnonzero(np.any(a.M != b.M, axis=1))
    assert diff.size > 0 and {int(i) // 6 for i in diff} <= nodes
    assert scaled_gear_inertia(cfg, 1.0) is cfg
    with pytest.raises(ValueError, match="scale"):
        scaled_gear_inertia(cfg, 0.0)


def test_gear_inertia_moves_the_mesh_mode_and_mesh_inertia_holds_it(cfg) -> None:
    """A lighter gear pair raises the mesh-dominated mode; scaling the mesh stiffness with the inertia
    (MeshInertia) brings it back to within the share of the mode the shafts carry."""
    base = GearRotorSystem.from_config(cfg, 75.0)
    f0, e0 = _mesh_modes(base, 1.342)
    i0 = int(np.argmax(e0))
    light = GearRotorSystem.from_config(GearInertia(inertia_scale=0.7).modify_config(cfg), 75.0)
    f1, e1 = _mesh_modes(light, 1.342)
    # the mode of the largest mesh share at 1.342 (5872 Hz, 0.66 of its energy in the mesh) moves up
    assert f1[int(np.argmax(e1[f1 < 7000]))] > 1.05 * f0[i0]
    f2, e2 = _mesh_modes(light, 1.342 * 0.7)
    # both scaled: the mesh mode within 3 % of where it was (the shafts' mass and stiffness not scaled)
    j = int(np.argmax(e2))
    assert abs(f2[j] / f0[i0] - 1.0) < 0.03
    assert abs(e2[j] - e0[i0]) < 0.1


def test_mesh_inertia_scales_the_static_mesh_compliance(cfg) -> None:
    """The static mesh deflection F/k of MeshInertia(s) is 1/s of the nominal one (the mode held)."""
    from types import SimpleNamespace

    from gear_rotor_sim.system import static_solution

    sys0 = GearRotorSystem.from_config(cfg, 25.0)
    eff = MeshInertia(inertia_scale=1.6)
    sys1 = GearRotorSystem.from_config(eff.modify_config(cfg), 25.0)
    factor = float(eff.mesh_stiffness_factor(SimpleNamespace(t=np.zeros(3)))[0])
    assert factor == pytest.approx(1.6)
    m0, m1 = sys0.meshes[0], sys1.meshes[0]
    d0 = m0.line_of_action @ static_solution(sys0) - m0.half_backlash
    d1 = m1.line_of_action @ static_solution(sys1, factor * m1.mean_stiffness) - m1.half_backlash
    assert d1 == pytest.approx(d0 / 1.6, rel=1e-6)


def test_consistent_scale_is_where_the_two_depth_readings_meet() -> None:
    from gear_rotor_sim.calibration.baseline_mesh_inertia import CombReading, consistent_scale

    # the DTE-comb depth 10 % above the ratio depth at x1, 5 % below at x0.5: log-linear crossing
    rows = [CombReading(1.0, 0.40, 0.44), CombReading(0.8, 0.39, 0.41), CombReading(0.5, 0.38, 0.361)]
    s = consistent_scale(rows)
    g0, g1 = math.log(0.41 / 0.39), math.log(0.361 / 0.38)
    expect = math.exp(math.log(0.5) + g1 / (g1 - g0) * (math.log(0.8) - math.log(0.5)))
    assert s == pytest.approx(expect, rel=1e-12)
    assert 0.5 < s < 0.8
    # no crossing: None; unread depths (NaN) are left out
    assert consistent_scale([CombReading(1.0, 0.4, 0.5), CombReading(0.5, 0.4, 0.45)]) is None
    assert consistent_scale([CombReading(1.0, math.nan, 0.5), CombReading(0.5, 0.4, 0.3)]) is None
    assert consistent_scale([CombReading(0.7, 0.4, 0.4)]) == 0.7
