"""Bearing envelope features: sensor gains from the static bearing load, modulation sidebands, impulse.

Independent truths: the gains the independent lumped generator drew for its record (a model that
shares no code with the FE model), the FE model's static bearing force checked by hand in
test_bearing_load_zone.py, the bearing kinematics by hand (6206: 9 balls, d 9.525 mm, D 46 mm), and
the time integral of the library's own impact pulse for the impulse.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.calibration.features_bearing import modulation_sidebands_hz, static_sensor_gains
from gear_rotor_sim.config import load_config
from gear_rotor_sim.faults import BearingDefect, static_bearing_force
from gear_rotor_sim.system import GearRotorSystem
from lumped_gearbox import make_record

CHANNELS = ("dte", "bearing2_fx", "bearing2_fy", "bearing2_fz", "node5_ax", "node5_ay")
QUANTITIES = (
    "dynamic_transmission_error",
    "bearing_force",
    "bearing_force",
    "bearing_force",
    "acceleration",
    "acceleration",
)
DIRECTIONS = (None, "x", "y", "z", "x", "y")


def test_static_gains_read_the_independent_records_sensor_gains() -> None:
    """Gains drawn within +-8 % by the lumped generator are read from the radial means to 0.5 %; the
    other channels (DTE, axial force, accelerations) do not identify a gain."""
    rec = make_record(3000.0, 25.0, duration_s=0.5, gain_error=0.08, seed=4)
    fs = 20000.0
    n_rev = round(fs / 50.0)
    y = np.column_stack([rec.data[c] for c in CHANNELS])
    nb = y.shape[0] // n_rev
    blocks = y[: nb * n_rev].reshape(nb, n_rev, -1).mean(axis=1)
    system = GearRotorSystem.from_config(load_config("paper_sun2021"), 25.0)
    f = static_bearing_force(system, 2)
    model = np.array([4.2e-5, f[0], f[1], f[2], 0.0, 0.0])
    g = static_sensor_gains(
        y.mean(axis=0), blocks.var(axis=0, ddof=1) / nb, model, QUANTITIES, DIRECTIONS, (0.8, 1.25)
    )
    for c in (1, 2):
        assert g[c] == pytest.approx(rec.gain[CHANNELS[c]], rel=5e-3)
    assert np.all(np.isnan(g[[0, 3, 4, 5]]))
    assert abs(rec.gain["bearing2_fx"] - 1.0) > 0.01 or abs(rec.gain["bearing2_fy"] - 1.0) > 0.01
    # a ratio no real sensor has (the declared load is not the machine's): the order gain is kept
    narrow = static_sensor_gains(
        2.0 * y.mean(axis=0), blocks.var(axis=0, ddof=1) / nb, model, QUANTITIES, DIRECTIONS, (0.8, 1.25)
    )
    assert np.all(np.isnan(narrow))


def test_modulation_sidebands_from_the_kinematics() -> None:
    shaft_hz = 50.0
    ftf = 0.5 * (1.0 - 9.525 / 46.0) * shaft_hz  # cage rate, hand formula
    inner = modulation_sidebands_hz(BearingDefect(kind="inner", bearing=2), shaft_hz)
    ball = modulation_sidebands_hz(BearingDefect(kind="ball", bearing=2), shaft_hz)
    assert sorted(inner) == pytest.approx([-150.0, -100.0, -50.0, 50.0, 100.0, 150.0])
    assert sorted(ball) == pytest.approx([-3 * ftf, -2 * ftf, -ftf, ftf, 2 * ftf, 3 * ftf], rel=1e-9)
    assert modulation_sidebands_hz(BearingDefect(kind="outer", bearing=2), shaft_hz) == []


def test_impulse_is_the_time_integral_of_one_impact() -> None:
    omega = 3000.0 * math.pi / 30.0
    d, big_d = 9.525e-3, 46.0e-3
    v = omega * big_d * (1.0 - (d / big_d) ** 2) / 4.0  # rolling speed by hand: 3.458 m/s
    tau = 0.35e-3 / v
    defect = BearingDefect(kind="outer", bearing=2, force_n=300.0, slip=0.0, defect_angle_rad=-0.5 * math.pi)
    assert defect.impact_duration(omega) == pytest.approx(tau, rel=1e-12)
    assert tau == pytest.approx(1.012e-4, rel=1e-3)
    fs = 5.0e6
    t = np.arange(int(0.02 * fs)) / fs  # 3.6 impacts at BPFO = 178 Hz
    system = SimpleNamespace(
        ndof=108, shaft_of_node=np.zeros(18, dtype=int), bearings=[None, SimpleNamespace(node0=8)]
    )
    ctx = SimpleNamespace(
        system=system, shaft_angle=(omega * t)[:, None], shaft_speed=np.full((t.size, 1), omega)
    )
    f = np.hypot(*defect.impact_force(ctx).T)
    starts = np.flatnonzero((f[1:] > 0) & (f[:-1] == 0)) + 1
    one = f[starts[0] : starts[1]].sum() / fs
    assert one == pytest.approx(defect.impulse(omega), rel=1e-3)
    assert defect.impulse(omega) == pytest.approx(2.0 / math.pi * 300.0 * tau, rel=1e-12)
