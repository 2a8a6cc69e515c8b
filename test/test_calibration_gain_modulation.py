"""A channel's own slow gain (a loose connector; issue 11): found, named and divided out
(calibration/gain_modulation.py, hooked in channel_conventions.correct_gain_modulation).

On the shared 0.6 s ``lumped_gearbox`` records (conftest.py): without a modulation nothing fires; 8 % at
3.7 Hz on one channel (a force with its static load, an accelerometer without one) is named and divided
out; the same modulation on every channel (a machine's, e.g. a load fluctuation) is left alone.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.calibration import gain_modulation as gm
from gear_rotor_sim.calibration.measurement import load_measurement

DEPTH, HZ = 0.08, 3.7


def _f_slow(m) -> float:
    return m.operating_point.speed_rpm / 60.0 * 29.0 / 49.0  # the gear shaft of paper_sun2021


def _modulate(data: np.ndarray, fs: float, cols: list[int], depth: float = DEPTH) -> np.ndarray:
    t = np.arange(data.shape[0]) / fs
    out = np.array(data, copy=True)
    out[:, cols] *= (1.0 + depth * np.sin(2.0 * math.pi * HZ * t + 0.4))[:, None]
    return out


@pytest.fixture(scope="module")
def record(shared_records):
    return load_measurement(shared_records["pinion_tooth"])


def test_nothing_fires_on_the_unmodulated_record(record):
    cols = [c.column for c in record.channels]
    fix = gm.gain_modulation_fix(record.data, cols, record.sample_rate_hz, _f_slow(record))
    assert fix.channels == ()
    fs, f_c = record.sample_rate_hz, 0.5 * _f_slow(record)
    gains = [gm.channel_gain(record.data[:, k], fs, f_c) for k in range(len(cols))]
    assert max(g.chi2_n for g in gains) < gm.CHI2N_MIN / 3  # noise reads about 1


@pytest.mark.parametrize("column", ["bearing2_fy", "node5_ax"])
def test_one_channel_modulated_is_named_and_divided_out(record, column):
    cols = [c.column for c in record.channels]
    k = cols.index(column)
    fs, f_slow = record.sample_rate_hz, _f_slow(record)
    data = _modulate(record.data, fs, [k])
    fix = gm.gain_modulation_fix(data, cols, fs, f_slow)
    assert fix.channels == (k,)
    assert repr(column) in fix.issues[0] and "gain varies" in fix.issues[0]
    # the estimated gain is the applied one to a sixth of its rms (0.6 s: 2.2 periods, the ends leak)
    t = np.arange(data.shape[0]) / fs
    truth = DEPTH * np.sin(2.0 * math.pi * HZ * t + 0.4)
    assert np.sqrt(np.mean((fix.gains[0] - truth) ** 2)) < DEPTH / math.sqrt(2.0) / 6.0
    corrected = fix.apply(data)
    again = gm.channel_gain(corrected[:, k], fs, 0.5 * f_slow)
    assert again.chi2_n < gm.CHI2N_MIN and again.depth < 0.25 * DEPTH / math.sqrt(2.0)
    others = [i for i in range(len(cols)) if i != k]
    assert np.array_equal(corrected[:, others], data[:, others])


def test_a_modulation_every_channel_shares_is_the_machines(record):
    cols = [c.column for c in record.channels]
    data = _modulate(record.data, record.sample_rate_hz, list(range(len(cols))))
    fs, f_c = record.sample_rate_hz, 0.5 * _f_slow(record)
    gains = [gm.channel_gain(data[:, k], fs, f_c) for k in range(len(cols))]
    assert max(g.chi2_n for g in gains) > 10 * gm.CHI2N_MIN  # each channel alone would read as modulated
    assert gm.gain_modulation_fix(data, cols, record.sample_rate_hz, _f_slow(record)).channels == ()


def test_a_single_channel_record_is_never_corrected(record):
    k = [c.column for c in record.channels].index("bearing2_fy")
    data = _modulate(record.data, record.sample_rate_hz, [k])[:, [k]]
    fix = gm.gain_modulation_fix(data, ["bearing2_fy"], record.sample_rate_hz, _f_slow(record))
    assert fix.channels == ()


def test_the_calibrators_hook_corrects_and_keeps_the_issue(record, monkeypatch):
    from gear_rotor_sim.calibration import channel_conventions, residual
    from gear_rotor_sim.config import load_config

    monkeypatch.setattr(residual, "Comparison", lambda m, *a: ("comparison of", m))
    k = [c.column for c in record.channels].index("node5_ay")
    m = SimpleNamespace(
        data=_modulate(record.data, record.sample_rate_hz, [k]),
        channels=record.channels,
        sample_rate_hz=record.sample_rate_hz,
        operating_point=record.operating_point,
        issues=[],
    )
    cal = SimpleNamespace(
        m=m,
        runner=SimpleNamespace(cfg=load_config("paper_sun2021")),
        _issues_at_init=[],
        log=lambda s: None,
        settings=None,
        _env_max=None,
        cmp=None,
    )
    before = np.array(m.data, copy=True)
    channel_conventions.correct_gain_modulation(cal)
    assert len(m.issues) == 1 and "'node5_ay'" in m.issues[0] and cal._issues_at_init == m.issues
    assert cal.cmp == ("comparison of", m)
    assert not np.array_equal(m.data[:, k], before[:, k])
    plain = SimpleNamespace(**{**vars(m), "data": record.data, "issues": []})
    cal2 = SimpleNamespace(**{**vars(cal), "m": plain, "cmp": None})
    channel_conventions.correct_gain_modulation(cal2)  # the unmodulated record: untouched
    assert cal2.cmp is None and cal2.m.issues == []
