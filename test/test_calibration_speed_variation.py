"""A speed that varies within the record: the generator's speed profile, the tracked angle, the record
read in the angle domain (issue 11; ``lumped_gearbox/speed_profile.py``, ``calibration/speed_tracking.py``,
``calibration/order_tracking.py``; docs/calibration.md Sec. 2 "Speed check", varying speed).

- the tracker on an analytic mesh comb whose speed drifts and fluctuates, in white noise: the angle and
  the speed within 3 of their stated sigmas of the truth, the drift and the fluctuation read back;
- the resampling to uniform angle turns a chirped comb back into the constant-speed comb;
- a short ``lumped_gearbox`` record with a drift: the angle off uniform rotation within the features'
  tolerance, the speed within 3 of its stated sigmas plus 0.3 % of its change (the transfer paths'
  phase, which the record cannot separate from the speed), the record
  resampled and its ``issues`` line naming ``operating_point.speed_rpm``; a record whose speed varies by
  more than 10 % is refused naming the field;
- a constant-speed record: the same measurement object back (equal arrays), no issue;
- the generator: a profile of zeros leaves a record bit for bit; the true angle follows the profile;
- one CLI calibration of a 0.6 s pinion-tooth record whose speed fluctuates: tooth 7 named.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gear_rotor_sim.calibration.measurement import MeasurementError, load_measurement
from gear_rotor_sim.calibration.order_tracking import (
    SpeedVariation,
    check_speed_variation,
    resample_to_angle,
)
from gear_rotor_sim.calibration.speed_check import check_operating_speed
from gear_rotor_sim.calibration.speed_tracking import track_speed
from gear_rotor_sim.config import load_config

Z_PINION, Z_GEAR = 29, 49
FS = 20000.0


def _angle(t: np.ndarray, rpm: float, drift: float, fl: float, f_hz: float) -> np.ndarray:
    """Input angle of ``w = w0 (1 + drift (t / T - 1/2) + fl sin(2 pi f t))`` over ``T = t[-1] + dt``."""
    w0, big_t = rpm * math.pi / 30.0, t[-1] + t[1] - t[0]
    om = 2 * math.pi * f_hz
    return w0 * (t + drift * (t * t - big_t * t) / (2 * big_t) + fl * (1 - np.cos(om * t)) / om)


def _comb(theta: np.ndarray, noise: float, rng: np.random.Generator) -> np.ndarray:
    """Two channels: mesh harmonics 1-3 with +-1, +-2 pinion sidebands and the gear's orders 1-2 along
    the input angle ``theta``, white noise of standard deviation ``noise``."""
    out = np.zeros((theta.size, 2))
    for c, scale in enumerate((1.0, 0.4)):
        x = np.zeros(theta.size)
        for m, a in ((1, 1.0), (2, 0.5), (3, 0.25)):
            x += a * np.cos(m * Z_PINION * theta + 0.3 * m + c)
            for k in (-2, -1, 1, 2):
                x += 0.05 * a / abs(k) * np.cos((m * Z_PINION + k) * theta + k)
        g = theta * Z_PINION / Z_GEAR
        x += 0.3 * np.cos(g) + 0.1 * np.cos(2 * g + 1.0)
        out[:, c] = scale * x + noise * rng.standard_normal(theta.size)
    return out


def test_tracked_angle_and_speed_of_an_analytic_comb_are_within_their_sigmas() -> None:
    rng = np.random.default_rng(5)
    t = np.arange(20000) / FS  # 1 s at 3000 rpm: +1 % drift, 0.4 % at 3 Hz
    theta = _angle(t, 3000.0, 0.01, 0.004, 3.0)
    tr = track_speed(_comb(theta, 1.0, rng), FS, 3000.0, [float(Z_PINION)], Z_PINION / Z_GEAR)
    assert tr is not None and tr.n_lines >= 4
    inner = (t > 2 * tr.kernel_s) & (t < t[-1] - 2 * tr.kernel_s)
    err = tr.angle_rad - (theta - theta[0])
    err -= err[inner].mean()
    assert 1e-6 < tr.sigma_angle_rad < 1e-2, tr.sigma_angle_rad
    assert np.sqrt(np.mean(err[inner] ** 2)) < 3.0 * tr.sigma_angle_rad, (
        err[inner].std(),
        tr.sigma_angle_rad,
    )
    true_rpm = np.gradient(theta, 1.0 / FS) * 30.0 / math.pi
    serr = (tr.speed_rpm - true_rpm)[inner]
    assert np.sqrt(np.mean(serr**2)) < 3.0 * tr.sigma_speed_rpm, (
        np.sqrt(np.mean(serr**2)),
        tr.sigma_speed_rpm,
    )
    # the variation read back: drift and fluctuation fitted together
    s = SpeedVariation(tr, 0.0, 0.0).summary()
    assert abs(s["drift_pct"] - 1.0) < 0.05 and abs(s["fluctuation_pct"] - 0.4) < 0.02, s
    assert abs(s["fluctuation_hz"] - 3.0) < 0.1, s
    # a constant comb at the same noise: the angle's deviation from a straight line is noise
    flat = track_speed(_comb(_angle(t, 3000.0, 0, 0, 1), 1.0, rng), FS, 3000.0, [29.0], Z_PINION / Z_GEAR)
    assert flat is not None
    dev = flat.deviation_rad()[inner]
    assert np.sqrt(np.mean(dev**2)) < 3.0 * flat.sigma_angle_rad


def test_resampling_to_uniform_angle_restores_the_constant_speed_comb() -> None:
    t = np.arange(8000) / FS
    theta = _angle(t, 3000.0, 0.015, 0.005, 2.0)
    x = np.cos(87.0 * theta)  # the third mesh harmonic: 4.4 kHz, 0.22 fs
    y = resample_to_angle(x, theta)
    grid = np.linspace(theta[0], theta[-1], t.size)
    inner = slice(64, -64)  # the mirrored ends are not band-limited continuations
    assert np.max(np.abs(y[inner] - np.cos(87.0 * grid[inner]))) < 2e-3
    # a sample of a uniform angle grid is read back as it is
    assert np.allclose(resample_to_angle(x, np.linspace(0.0, 1.0, t.size)), x, atol=1e-12)


@pytest.fixture(scope="module")
def drift_record(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 0.6 s pinion-tooth record (tooth 7, depth 0.4) at a mean 3000 rpm drifting by +1.5 %."""
    from lumped_gearbox import make_record, write_record

    rec = make_record(
        3000.0,
        25.0,
        ["tooth_damage:wheel=pinion,tooth=7,depth=0.4"],
        duration_s=0.6,
        seed=21,
        speed_profile={"drift_pct": 1.5},
    )
    return write_record(tmp_path_factory.mktemp("speedvar") / "drift.csv", rec)


def test_lumped_record_with_a_drift_is_tracked_and_resampled(drift_record: Path) -> None:
    from lumped_gearbox.speed_profile import SpeedProfile, angle_extra, relative_speed

    cfg = load_config("paper_sun2021")
    m = load_measurement(drift_record)
    m2, var = check_speed_variation(m, cfg)
    assert var is not None and var.varies and m2 is not m
    tr = var.track
    inner = (tr.t > 2 * tr.kernel_s) & (tr.t < tr.t[-1] - 2 * tr.kernel_s)
    prof = SpeedProfile(drift_pct=1.5).vector(0.6)
    true_angle = 3000.0 * math.pi / 30.0 * (tr.t + angle_extra(prof, tr.t))
    # what the resampling needs: the angle off uniform rotation, within the features' tolerance (the
    # highest order keeps 99.9 % of its amplitude) though it is 0.03 rad rms; a straight line (a
    # constant speed or phase offset) is the constant-speed check's business
    err = tr.angle_rad - true_angle
    err = (err - np.polyval(np.polyfit(tr.t[inner], err[inner], 1), tr.t))[inner]
    assert var.rms_deviation_rad > 0.02 and np.sqrt(np.mean(err**2)) < var.tolerance_rad, (
        var.rms_deviation_rad,
        np.sqrt(np.mean(err**2)),
    )
    # the speed: the lines are the mesh excitation seen through the transfer paths, whose phase at the
    # sweeping mesh frequency (a delay of 0.06 ms on the DTE to 1.2 ms on the bearing forces, curving
    # near the mesh mode) the record cannot separate from the speed: within 3 stated sigmas plus 0.3 %
    # of the speed's change over the record
    true = 3000.0 * relative_speed(prof, tr.t)
    serr = (tr.speed_rpm - true)[inner]
    assert np.sqrt(np.mean(serr**2)) < 3.0 * tr.sigma_speed_rpm + 0.003 * 45.0, np.sqrt(np.mean(serr**2))
    # each channel's path delay against the combination: the bearing forces lag the DTE (measured on one
    # channel at a time: 1.0-1.2 ms against 0.06 ms, docs/history/calibration_sessions.md Sec. 8.45)
    d = dict(zip([c.column for c in m.channels], tr.channel_delay_s, strict=True))
    assert 2e-4 < d["bearing2_fx"] - d["dte"] < 2e-3 and 2e-4 < d["bearing2_fy"] - d["dte"] < 2e-3, d
    s = var.summary()
    assert abs(s["drift_pct"] - 1.5) < 0.05 and abs(s["mean_rpm"] - 3000.0) < 0.1, s
    line = [i for i in m2.issues if "speed varies within the record" in i]
    assert len(line) == 1 and line[0].startswith("operating_point.speed_rpm"), m2.issues
    assert m2.data.shape == m.data.shape and not np.array_equal(m2.data, m.data)
    # the whole speed check: the angle-domain record's mean speed agrees with the declared one
    _, chk = check_operating_speed(m, cfg)
    assert chk.variation is not None and chk.variation.varies and not chk.corrected
    assert abs(chk.estimate.measured_rpm - 3000.0) < 0.05, chk.estimate


def test_a_speed_varying_by_more_than_ten_percent_is_refused(tmp_path: Path) -> None:
    import yaml

    t = np.arange(12000) / FS
    x = _comb(_angle(t, 3000.0, 0.14, 0.0, 1.0), 0.3, np.random.default_rng(2))
    csv = tmp_path / "ramp.csv"
    np.savetxt(csv, np.column_stack([t, 1e-6 * x[:, 0]]), delimiter=",", header="time_s,dte", comments="")
    side = {
        "sample_rate_hz": FS,
        "operating_point": {"speed_rpm": 3000.0, "temperature_c": 25.0, "output_torque_nm": 200.0},
        "gearbox": "paper_sun2021",
        "channels": [{"column": "dte", "quantity": "dynamic_transmission_error", "unit": "m"}],
    }
    csv.with_suffix(".yaml").write_text(yaml.safe_dump(side))
    with pytest.raises(MeasurementError, match=r"operating_point\.speed_rpm: the speed varies by"):
        check_operating_speed(load_measurement(csv), load_config("paper_sun2021"))


def test_constant_speed_record_is_left_untouched(shared_records: dict[str, Path]) -> None:
    cfg = load_config("paper_sun2021")
    m = load_measurement(shared_records["pinion_tooth"])
    data, issues = m.data.copy(), list(m.issues)
    m2, var = check_speed_variation(m, cfg)
    assert m2 is m and not var.varies and var.rms_deviation_rad < var.limit_rad
    assert np.array_equal(m.data, data) and m.issues == issues
    m3, chk = check_operating_speed(m, cfg)
    assert m3 is m and chk.variation is not None and not chk.variation.varies
    assert check_speed_variation(m, load_config("cwru_rig")) == (m, None)


def test_generator_profile_follows_the_prescribed_angle() -> None:
    from lumped_gearbox import make_record
    from lumped_gearbox.speed_profile import SpeedProfile, angle_extra, time_at

    p = SpeedProfile(drift_pct=2.0, fluctuation_pct=1.0, fluctuation_hz=3.0).vector(1.0)
    t = np.linspace(-0.3, 1.0, 2001)
    ang = t + angle_extra(p, t)
    # the speed is the angle's derivative; the drift is centred (mean 1 over the record)
    assert np.allclose(
        np.gradient(ang, t)[1:-1], 1.0 + p[1] + p[2] * t[1:-1] + p[3] * np.sin(p[4] * t[1:-1]), atol=1e-5
    )
    assert np.allclose(time_at(p, ang), t, atol=1e-12)
    # the mesh stiffness follows the true angle: its passes at a constant pair count fall at the angle's
    a = make_record(3000.0, 25.0, [], duration_s=0.2, seed=1, sampling="point", noise=(0.0, 0.0))
    b = make_record(
        3000.0, 25.0, [], duration_s=0.2, seed=1, sampling="point", noise=(0.0, 0.0), speed_profile={}
    )
    assert all(np.array_equal(a.data[c], b.data[c]) for c in a.data)
    with pytest.raises(ValueError, match=r"speed_profile\.drift_pct"):
        SpeedProfile(drift_pct=12.0)


@pytest.mark.acceptance
@pytest.mark.slow
def test_cli_names_the_tooth_of_a_record_whose_speed_fluctuates(tmp_path: Path) -> None:
    from lumped_gearbox import make_record, write_record

    rec = make_record(
        3000.0,
        25.0,
        ["tooth_damage:wheel=pinion,tooth=7,depth=0.4"],
        duration_s=0.6,
        seed=8,
        speed_profile={"fluctuation_pct": 0.5, "fluctuation_hz": 5.0},
    )
    csv = write_record(tmp_path / "fluct.csv", rec)
    # the first effect is what is asserted: the search stops there (--max-effects 1; Sec. 8.74)
    cmd = [sys.executable, "-m", "gear_rotor_sim.cli", "calibrate", str(csv), "--json", "--max-effects", "1"]
    d = json.loads(subprocess.check_output(cmd))
    assert any("speed varies within the record" in i for i in d["issues"]), d["issues"]
    first = (d["effects"] or [{}])[0]
    assert first.get("label") == "tooth_damage@pinion" and first["parameters"]["tooth"] == 7, d["conclusion"]
