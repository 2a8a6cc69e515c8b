"""Pitch deviations of every tooth as a per-tooth static transmission error (``faults/pitch.py``).

Checked against analytic truths: the step average equals the numerical mean of the point values; a
common offset ``c`` of every flank of a wheel moves the DTE by exactly ``-c`` (the shares sum to 1: no
dynamics); at 300 rpm (mesh 145 Hz, far below the mesh-coupled modes) the DTE's change follows the
quasi-static ``-sum lambda_n p_n`` of random flank positions tooth by tooth.
"""

from __future__ import annotations

import numpy as np
import pytest

from gear_rotor_sim.calibration.residual import cached_system
from gear_rotor_sim.config import load_config
from gear_rotor_sim.faults.pitch import PitchDeviation, flank_position, share_antiderivative
from gear_rotor_sim.simulator import Simulator

FS = 20000.0


@pytest.fixture(scope="module")
def cfg():
    return load_config("paper_sun2021")


def test_share_integrates_to_one_and_step_average_is_exact() -> None:
    eps = 1.7
    assert share_antiderivative(np.array([-1.0, 0.0, eps, 5.0]), eps).tolist() == [0.0, 0.0, 1.0, 1.0]
    rng = np.random.default_rng(0)
    pin, gear = rng.normal(0, 1.0, 29), rng.normal(0, 1.0, 49)
    u = rng.uniform(0.0, 200.0, 50)
    w = np.full(u.size, 0.3)
    fine = np.linspace(-0.5, 0.5, 20001)
    num = np.array([np.mean(flank_position(x + 0.3 * fine, np.zeros(fine.size), pin, gear, eps)) for x in u])
    got = flank_position(u, w, pin, gear, eps)
    # the point values' mean over 20001 points: within the rectangle rule's jump error (1 / 20000 of a jump)
    assert np.max(np.abs(got - num)) <= 4.0 * np.max(np.abs(pin)) * 1e-4 + 1e-12


def _dte(cfg, rpm: float, effects: tuple, seconds: float) -> np.ndarray:
    return Simulator(cfg, rpm, 25.0, FS, channels=["dte"], effects=effects).advance(seconds).data[:, 0]


def test_common_flank_offset_moves_the_dte_by_minus_the_offset(cfg) -> None:
    c = 4e-6
    healthy = _dte(cfg, 3000.0, (), 0.12)
    ahead = _dte(cfg, 3000.0, (PitchDeviation(pinion_m=(c,) * 29),), 0.12)
    # after the start's transient (the run starts from the healthy static equilibrium; measured: the
    # difference from -c is 1.2 c at 0, 0.03 c at 0.01 s, 1.1e-3 c at 0.1 s)
    d = (ahead - healthy)[2000:]
    assert np.max(np.abs(d + c)) <= 5e-3 * c, np.max(np.abs(d + c))


def test_dte_follows_the_tooth_pattern_quasi_statically(cfg) -> None:
    rng = np.random.default_rng(3)
    pin, gear = rng.normal(0, 4e-6, 29), rng.normal(0, 4e-6, 49)
    rpm, seconds = 300.0, 0.3
    d = _dte(cfg, rpm, (PitchDeviation(tuple(pin), tuple(gear)),), seconds) - _dte(cfg, rpm, (), seconds)
    t = np.arange(d.size) / FS
    u = 29 * rpm / 60.0 * t
    eps = float(cached_system(cfg, 25.0).meshes[0].contact_ratio)
    want = -flank_position(u, np.zeros(u.size), pin, gear, eps)
    # away from the shares' jumps (the response's transients) and the start's transient
    phase = np.mod(u, 1.0)
    near = np.min([np.abs(phase - x) for x in (0.0, 1.0, eps - 1.0)], axis=0)
    keep = (near > 0.1) & (t > 0.15)
    scale = float(np.dot(d[keep], want[keep]) / np.dot(want[keep], want[keep]))
    rel = float(np.sqrt(np.mean((d[keep] - want[keep]) ** 2) / np.mean(want[keep] ** 2)))
    # measured: scale 1.013, relative RMS 0.12 (the lateral modes' ringing after each jump)
    assert abs(scale - 1.0) <= 0.05, scale
    assert rel <= 0.2, rel
    # and the wrong sign or a pattern shifted by one tooth is far off
    shifted = -flank_position(u, np.zeros(u.size), np.roll(pin, 1), np.roll(gear, 1), eps)
    rel_shift = float(np.sqrt(np.mean((d[keep] - shifted[keep]) ** 2) / np.mean(want[keep] ** 2)))
    assert rel_shift >= 0.8, rel_shift


def test_pattern_size_is_checked(cfg) -> None:
    with pytest.raises(ValueError, match="29 teeth"):
        _dte(cfg, 3000.0, (PitchDeviation(pinion_m=(1e-6,) * 28),), 0.002)
    p = PitchDeviation(pinion_m=(0.0, 1e-6, 0.0), gear_m=())
    assert p.parameters()["pinion_cumulative_m"] == 1e-6
