"""Load zone of a rolling-bearing defect: centred on the bearing's static force in the FE model.

Independent truth: the hand calculation of the static reactions of the paper gearbox's input shaft.
The load torque T2 on the gear is balanced by the mesh force ``F_m = T2 / r_bg`` (``r_bg = m z_g
cos(alpha) / 2``), which acts on the pinion as ``-n F_m`` with ``n = (sin alpha, cos alpha)`` (the
line of action, Eq 22); the pinion sits at mid-span of a shaft on two identical bearings, so by
symmetry each bearing carries ``F_m / 2`` in that direction (the gear's bearings ``F_m / 2`` along
``+n``). The model has no gravity term (Eq 39), so nothing else loads the bearings radially.
"""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.config import load_config
from gear_rotor_sim.faults import BearingDefect, static_bearing_force, static_load_angle
from gear_rotor_sim.system import GearRotorSystem


def _hand_reaction(cfg, torque_nm: float) -> tuple[float, float]:
    """(magnitude, direction) of each input-shaft bearing's static force on the housing, by hand."""
    mesh = cfg.meshes[0]
    alpha = mesh.pressure_angle_rad
    r_bg = 0.5 * mesh.module_m * mesh.gear_teeth * math.cos(alpha)
    f_mesh = torque_nm / r_bg
    return 0.5 * f_mesh, math.atan2(-math.cos(alpha), -math.sin(alpha))


@pytest.mark.parametrize(("temperature_c", "torque_nm"), [(25.0, 200.0), (125.0, 200.0), (25.0, 80.0)])
def test_static_bearing_force_is_the_hand_reaction(temperature_c: float, torque_nm: float) -> None:
    cfg = load_config("paper_sun2021")
    cfg = dataclasses.replace(cfg, load=dataclasses.replace(cfg.load, torque_nm=torque_nm))
    system = GearRotorSystem.from_config(cfg, temperature_c)
    mag, ang = _hand_reaction(cfg, torque_nm)
    assert math.degrees(ang) == pytest.approx(-110.0, abs=1e-9)
    for bearing, sign in ((1, 1.0), (2, 1.0), (3, -1.0), (4, -1.0)):
        f = static_bearing_force(system, bearing)
        expected = sign * mag * np.array([math.cos(ang), math.sin(ang)])
        np.testing.assert_allclose(f[:2], expected, rtol=0, atol=1e-6 * mag)
        want = ang if sign > 0 else ang + math.pi
        assert static_load_angle(system, bearing) == pytest.approx(want, abs=1e-6)
    # the load zone of a defect that is not given a direction is centred there
    assert BearingDefect(kind="inner", bearing=2).load_angle(system) == pytest.approx(ang, abs=1e-6)
    assert BearingDefect(kind="ball", bearing=2, load_angle_rad=0.3).load_angle(system) == 0.3


def test_inner_race_impacts_are_centred_on_the_static_load() -> None:
    """Summed over many revolutions without slip, the impact force vectors of an inner-race defect point
    along the load-zone centre (the zone is symmetric about it), and no impact lands on the unloaded
    half."""
    cfg = load_config("paper_sun2021")
    system = GearRotorSystem.from_config(cfg, 25.0)
    _, ang = _hand_reaction(cfg, cfg.load.torque_nm)
    omega = 2 * math.pi * 50.0
    fs = 400_000.0
    t = np.arange(int(2.0 * fs)) / fs
    ratios = np.array([1.0, -29.0 / 49.0])
    ctx = SimpleNamespace(
        system=system,
        shaft_angle=np.outer(omega * t, ratios),
        shaft_speed=np.tile(omega * ratios, (t.size, 1)),
    )
    f = BearingDefect(kind="inner", bearing=2, force_n=100.0, slip=0.0, defect_angle_rad=0.4).impact_force(
        ctx
    )
    total = f.sum(axis=0)
    assert math.atan2(total[1], total[0]) == pytest.approx(ang, abs=math.radians(3.0))
    hit = np.hypot(f[:, 0], f[:, 1]) > 0
    direction = np.arctan2(f[hit, 1], f[hit, 0])
    assert np.all(np.cos(direction - ang) > -1e-9)
