"""A channel whose mean drifts over the record (issue 11, an effect nobody declared;
calibration/channel_drift.py, hooked in channel_conventions.check_conventions before the setup;
docs/calibration.md Sec. 1).

The trend estimator on analytic signals (a ramp in white noise, white noise alone, a mean oscillating at a few
Hz), and on the shared 0.6 s ``lumped_gearbox`` pinion-tooth record: as made nothing fires; its axial force
drifting 0 -> 60 N is found on that column alone, the ramp removed about the middle (the mean kept), and the
calibrator's setup names it and then reads the remaining +30 N mean as the axial sensor's zero
(``axial_zero.py``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gear_rotor_sim.calibration.channel_drift import T_MIN, channel_drift, trend

FS, F_SLOW = 20000.0, 50.0 * 29.0 / 49.0  # the gear shaft at 3000 rpm


def test_the_trend_on_analytic_signals():
    rng = np.random.default_rng(3)
    t = np.arange(40000) / FS
    noise = rng.normal(0.0, 1.0, t.size)
    ramp = trend(noise + 30.0 * t, FS, F_SLOW)
    assert ramp is not None and ramp.blocks == 59
    # the slope within 4 of its standard errors (slope / t), far beyond T_MIN
    assert abs(ramp.slope - 30.0) < 4.0 * abs(ramp.slope / ramp.t)
    assert ramp.t > 10 * T_MIN and ramp.change == pytest.approx(60.0, rel=0.01)
    for seed in range(5):
        quiet = trend(np.random.default_rng(seed).normal(0.0, 1.0, t.size), FS, F_SLOW)
        assert quiet is not None and abs(quiet.t) < 5.0
    # a mean oscillating (10 % of 100 at 3.7 Hz, 7.4 periods) is not a trend: its scatter widens the error
    wave = trend(100.0 + 10.0 * np.sin(2 * math.pi * 3.7 * t + 0.4) + noise, FS, F_SLOW)
    assert wave is not None and abs(wave.t) < T_MIN
    # too short for a trend
    assert trend(noise[:2000], FS, F_SLOW) is None


@pytest.fixture(scope="module")
def record(shared_records):
    from gear_rotor_sim.calibration.measurement import load_measurement

    return shared_records["pinion_tooth"], load_measurement


def _slow(m) -> float:
    return m.operating_point.speed_rpm / 60.0 * 29.0 / 49.0


def test_a_drifting_axial_force_is_found_and_its_trend_removed(record):
    path, load = record
    m = load(path)
    cols = [c.column for c in m.channels]
    units = [c.si_unit for c in m.channels]
    fs = m.sample_rate_hz
    assert channel_drift(m.data, cols, units, fs, _slow(m)).channels == ()
    k = cols.index("bearing2_fz")
    drifted = np.array(m.data, copy=True)
    drifted[:, k] += np.linspace(0.0, 60.0, drifted.shape[0])
    fix = channel_drift(drifted, cols, units, fs, _slow(m))
    assert fix.channels == (k,) and "'bearing2_fz'" in fix.issues[0] and "drifts by +60" in fix.issues[0]
    out = fix.apply(drifted)
    # the ramp removed about the middle: the record plus the ramp's mean, 30 N, to the slope's error x T / 2
    assert np.max(np.abs(out[:, k] - m.data[:, k] - 30.0)) < 1.0
    others = [i for i in range(len(cols)) if i != k]
    assert np.array_equal(out[:, others], drifted[:, others])


def test_the_calibrator_names_the_drift_and_the_zero_it_leaves(record):
    from gear_rotor_sim.calibration.channel_conventions import check_conventions
    from gear_rotor_sim.calibration.fit import Calibrator

    path, load = record
    m = load(path)
    k = [c.column for c in m.channels].index("bearing2_fz")
    clean_mean = float(np.mean(m.data[:, k]))
    m.data[:, k] += np.linspace(0.0, 60.0, m.data.shape[0])
    cal = Calibrator(m)
    check_conventions(cal)
    assert sum("drifts by" in i for i in cal.m.issues) == 1
    assert sum("zero offset" in i and "'bearing2_fz'" in i for i in cal.m.issues) == 1
    assert abs(float(np.mean(cal.m.data[:, k])) - clean_mean) < 0.5
