"""An input angle modulated at a shaft's own order (issue 11; ``calibration/speed_order_locked.py``;
docs/calibration.md Sec. 2 "Speed check", varying speed; history Sec. 8.55).

- an analytic mesh comb phase-modulated at the gear's order 1 (and amplitude-modulated there too): the
  angle modulation read back within 3 % and 0.05 rad of phase, the amplitude modulation dropping out;
- a comb with a local event once a gear revolution (a damaged tooth: every gear order alike) is not read
  as a speed fluctuation;
- a short ``lumped_gearbox`` record fluctuating 0.3 % at the gear's rate: read, resampled, named in
  ``issues``; the angle within 15 % of the fluctuation's angle against the profile's analytic angle.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.calibration.order_tracking import check_speed_variation
from gear_rotor_sim.calibration.speed_order_locked import angle_modulation, order_locked_fluctuation
from gear_rotor_sim.calibration.speed_tracking import track_speed
from gear_rotor_sim.config import load_config

Z_P, Z_G, FS = 29, 49, 20000.0
R = Z_P / Z_G
LINES = [29.0, 58.0, 87.0]


def _comb(theta: np.ndarray, rng: np.random.Generator, am: np.ndarray | None = None) -> np.ndarray:
    """Mesh harmonics 1-3 along ``theta``, optionally amplitude-modulated by ``1 + am``, in white noise."""
    x = sum(a * np.cos(m * Z_P * theta + 0.4 * m) for m, a in ((1, 1.0), (2, 0.6), (3, 0.3)))
    if am is not None:
        x = x * (1.0 + am)
    return (x + 0.05 * rng.standard_normal(theta.size))[:, None]


def test_a_gear_order_phase_modulation_is_read_and_an_amplitude_modulation_drops_out() -> None:
    rng = np.random.default_rng(7)
    t = np.arange(40000) / FS
    th = 3000.0 * math.pi / 30.0 * t  # the uniform (tracked) angle
    amp, ph = 5e-3, 0.7
    true = th + amp * np.cos(R * th + ph)
    x = _comb(true, rng, am=0.05 * np.cos(R * th + 2.0))
    mod = angle_modulation(x, th, LINES, R, 1)
    assert mod is not None and abs(mod.amplitude_rad / amp - 1.0) < 0.03, mod
    assert abs(math.remainder(mod.phase_rad - ph, 2 * math.pi)) < 0.05, mod
    two = angle_modulation(x, th, LINES, R, 2)
    # second-order terms of the phase modulation (K d)^2 / (4 K) read 2 % at order 2
    assert two is not None and two.amplitude_rad < 0.05 * amp, two


def test_a_local_event_once_a_gear_revolution_is_not_a_speed_fluctuation() -> None:
    from dataclasses import replace

    rng = np.random.default_rng(8)
    t = np.arange(40000) / FS
    th = 3000.0 * math.pi / 30.0 * t
    # a damaged gear tooth: the mesh phase jumps by 0.05 rad for 1/49 of each gear revolution
    g = np.mod(R * th, 2 * math.pi)
    x = _comb(th + 0.05 / Z_P * (g < 2 * math.pi / Z_G), rng)
    tr = track_speed(x, FS, 3000.0, [float(Z_P)], R)
    assert tr is not None and tr.n_lines > 0
    tr = replace(tr, angle_rad=th)
    amps = [angle_modulation(x, th, LINES, R, j).amplitude_rad for j in (1, 2, 3)]
    assert max(amps) < 1.5 * min(amps), amps  # flat over the gear's orders
    assert order_locked_fluctuation(x, FS, tr, [float(Z_P)], [1.0, R], 1e-5) is None


@pytest.fixture(scope="module")
def gear_rate_record(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 0.8 s healthy record at a mean 3000 rpm fluctuating 0.3 % at the gear's rate."""
    from lumped_gearbox import make_record, write_record

    prof = {"fluctuation_pct": 0.3, "fluctuation_hz": 3000.0 * R / 60.0}
    rec = make_record(3000.0, 25.0, [], duration_s=0.8, seed=41, speed_profile=prof)
    return write_record(tmp_path_factory.mktemp("speedlock") / "gear_rate.csv", rec)


def test_a_fluctuation_at_the_gears_rate_is_read_against_the_profiles_angle(gear_rate_record: Path) -> None:
    from lumped_gearbox.speed_profile import SpeedProfile, angle_extra

    cfg = load_config("paper_sun2021")
    m = load_measurement(gear_rate_record)
    m2, var = check_speed_variation(m, cfg)
    assert var is not None and var.varies and m2 is not m
    tr = var.track
    assert tr.order_locked is not None and tr.order_locked.order == 1
    assert abs(tr.order_locked.shaft_ratio - R) < 1e-9
    prof = SpeedProfile(fluctuation_pct=0.3, fluctuation_hz=3000.0 * R / 60.0).vector(0.8)
    true = 3000.0 * math.pi / 30.0 * (tr.t + angle_extra(prof, tr.t))
    # the profile's angle amplitude: w0 0.3 % / (2 pi 29.6 Hz) = 5.07e-3 rad
    assert abs(tr.order_locked.amplitude_rad / 5.07e-3 - 1.0) < 0.1, tr.order_locked
    inner = (tr.t > 2 * tr.kernel_s) & (tr.t < tr.t[-1] - 2 * tr.kernel_s)
    err = tr.angle_rad - true
    err = err - np.polyval(np.polyfit(tr.t[inner], err[inner], 1), tr.t)
    assert np.sqrt(np.mean(err[inner] ** 2)) < 0.15 * 5.07e-3 / math.sqrt(2.0)
    line = [i for i in m2.issues if "angle modulation locked to order 1" in i]
    assert len(line) == 1, m2.issues
