"""Session 20's undeclared effects (benchmarks/undeclared_probe.py, history Sec. 8.53) against their analytic
definitions: a sample clock off by 0.3 % puts the mesh line at ``f / 1.003`` of the file's time (a speed
error would not move the resonances; the clock moves every line), quantisation rounds to ``2 R / 2**bits``,
a zero drift and cross-talk add exactly what they say, the baseline wander stays in its band, and the mount
resonance amplifies by ``Q`` at ``f0``."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import undeclared_probe as up

from lumped_gearbox import make_record
from lumped_gearbox.record import Record

FS = 20000.0


def _record(data: dict[str, np.ndarray]) -> Record:
    n = next(iter(data.values())).size
    return Record(np.arange(n) / FS, dict(data), 3000.0, 25.0, [], {}, {}, 0, {}, 25.0, 0.0, "daq", 32)


def test_a_fast_clock_moves_every_line_by_its_factor():
    kw, post = up.clock_error(0.003)
    rec = make_record(3000.0, 25.0, [], duration_s=0.5, seed=3, sampling="daq", **kw)
    post(rec, kw["sample_rate_hz"])
    assert rec.time_s[1] == pytest.approx(1.0 / up.CLOCK_RATE_HZ, rel=1e-12)
    assert rec.time_s.size == round(0.5 * kw["sample_rate_hz"])
    # the mesh fundamental (29 x 50 Hz) and its second harmonic read 1/1.003 of their frequency; a 0.5 s
    # record's line resolves to 0.02 Hz (4.3 Hz of shift)
    for f in (1450.0, 2900.0):
        got = up.line_frequency(rec.data["dte"], up.CLOCK_RATE_HZ, f / 1.003)
        assert got == pytest.approx(f / 1.003, abs=0.05)
        assert abs(got - f) > 3.0


def test_quantisation_drift_crosstalk_and_wander_add_what_they_say():
    rng = np.random.default_rng(5)
    t = np.arange(40000) / FS
    x = 100.0 + 10.0 * np.sin(2 * math.pi * 1450.0 * t) + rng.normal(0.0, 1.0, t.size)
    y = rng.normal(0.0, 3.0, t.size)
    rec = _record({"a": x.copy(), "b": y.copy()})
    up.quantise(10, 8.0)(rec, FS)
    step = 2.0 * 8.0 * float(np.max(np.abs(x))) / 1024.0
    assert np.allclose(rec.data["a"] / step, np.round(rec.data["a"] / step), atol=1e-9)
    assert np.max(np.abs(rec.data["a"] - x)) <= 0.5 * step + 1e-12
    rec = _record({"a": x.copy(), "b": y.copy()})
    up.zero_drift("a", 0.0, 60.0)(rec, FS)
    assert np.allclose(rec.data["a"] - x, np.linspace(0.0, 60.0, x.size)) and np.array_equal(rec.data["b"], y)
    rec = _record({"a": x.copy(), "b": y.copy()})
    up.crosstalk("a", "b", 0.05)(rec, FS)
    assert np.allclose(rec.data["b"], y + 0.05 * x) and np.array_equal(rec.data["a"], x)
    rec = _record({"a": x.copy(), "b": y.copy()})
    up.baseline_wander(0.2, (0.3, 5.0))(rec, FS)
    w = rec.data["a"] - x
    assert float(np.std(w)) == pytest.approx(0.2 * float(np.std(x)), rel=1e-9)
    f = np.fft.rfftfreq(w.size, 1.0 / FS)
    power = np.abs(np.fft.rfft(w)) ** 2
    assert np.sum(power[(f < 0.3) | (f > 5.0)]) < 1e-20 * np.sum(power)


def test_the_mount_resonance_amplifies_q_times_at_its_frequency():
    n = 40000
    t = np.arange(n) / FS
    for f, gain in ((6000.0, 15.0), (600.0, 1.0 / (1.0 - 0.01))):
        rec = _record({"ax": np.sin(2 * math.pi * f * t), "ay": np.zeros(n)})
        up.mount_resonances(("ax", "ay"))(rec, FS)
        steady = rec.data["ax"][n // 2 :]
        assert np.sqrt(2.0) * float(np.std(steady)) == pytest.approx(gain, rel=0.01)
        assert np.allclose(rec.data["ay"], 0.0)
