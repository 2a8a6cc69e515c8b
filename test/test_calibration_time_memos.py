"""The calibration's performance memos (docs/history/calibration_sessions.md Sec. 8.70) return what the
computation they replace returns, and never a stale result: the shifted feature set, the carrier masks
and the filter designs."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from gear_rotor_sim.calibration.residual import Comparison
from gear_rotor_sim.calibration.residual_types import ModelFeatures

FS = 20000.0


def _comparison(shafts: list) -> SimpleNamespace:
    """The attributes ``Comparison.shifted`` and ``Comparison.carriers`` read."""
    return SimpleNamespace(shafts=shafts, speed_hz=2000.0 / 60.0, fs=FS)


def test_shifted_by_a_delay_turns_a_line_by_its_phase():
    """A complex line ``exp(2 pi i f0 t)`` on the FFT grid delayed by ``dt`` is the line times
    ``exp(-2 pi i f0 dt)`` (exact), and each delay of the same features is its own."""
    n = 400
    t = np.arange(n) / FS
    f0 = 25 * FS / n
    line = np.exp(2j * np.pi * f0 * t)
    sh = SimpleNamespace(orders=np.array([1.0, 2.0, 29.0]), ratio=1.0)
    cmp = _comparison([sh])
    feats = ModelFeatures([[np.array([1.0 + 0j, 2.0, 3.0])]], [line], np.zeros(1))
    for dt in (0.0, 1.0 / 29 / cmp.speed_hz, 3.3e-4):
        out = Comparison.shifted(cmp, feats, dt)
        np.testing.assert_allclose(out.analytic[0], line * np.exp(-2j * np.pi * f0 * dt), atol=1e-12)
        turn = np.exp(-2j * np.pi * sh.orders * cmp.speed_hz * dt)
        np.testing.assert_allclose(out.order[0][0], feats.order[0][0] * turn, rtol=1e-15)
    assert np.array_equal(Comparison.shifted(cmp, feats, 0.0, analytic=False).analytic[0], line)
    # to the bit the direct formula (FFT, delay phasor, inverse FFT) on a signal off the grid
    rng = np.random.default_rng(3)
    noise = rng.normal(size=n) + 1j * rng.normal(size=n)
    other = ModelFeatures([[np.array([1.0 + 0j, 2.0, 3.0])]], [noise, line], np.zeros(2))
    for dt in (1.1e-4, -2.7e-4):
        out = Comparison.shifted(cmp, other, dt)
        f = np.fft.fftfreq(n, 1.0 / FS)
        for a, b in zip(other.analytic, out.analytic, strict=True):
            assert np.array_equal(b, np.fft.ifft(np.fft.fft(a) * np.exp(-2j * np.pi * f * dt)))


def test_carrier_mask_follows_the_shaft_object():
    a = SimpleNamespace(orders=np.arange(1, 60), carrier_teeth=(), teeth=29)
    b = SimpleNamespace(orders=np.arange(1, 60), carrier_teeth=(), teeth=20)
    cmp = _comparison([a])
    first = Comparison.carriers(cmp, 0)
    assert np.flatnonzero(first).tolist() == [28, 57]
    assert Comparison.carriers(cmp, 0) is first  # kept
    cmp.shafts = [b]  # another shaft at the same index: its own mask
    assert np.flatnonzero(Comparison.carriers(cmp, 0)).tolist() == [19, 39]


def test_band_pass_and_upsampling_filters_designed_once_are_the_designs():
    """The analytic band of a record and its 4x upsampling with the kept filter designs equal scipy's
    own designs to the bit; another band gets its own filter."""
    from scipy import signal

    from gear_rotor_sim.analysis.signals import analytic_band
    from gear_rotor_sim.calibration.features_orders import _upsampling_taps

    x = np.random.default_rng(4).normal(size=4001)
    for band in ((1200.0, 4000.0), (2500.5, 7000.25), (1200.0, 4000.0)):
        sos = signal.butter(4, band, btype="bandpass", fs=FS, output="sos")
        direct = signal.hilbert(signal.sosfiltfilt(sos, x - np.mean(x)))
        assert np.array_equal(analytic_band(x, FS, band), direct)
    a = analytic_band(x, FS, (1200.0, 4000.0))
    b = analytic_band(x, FS, (1200.0, 4100.0))
    assert np.max(np.abs(a - b)) > 1e-3 * np.max(np.abs(a))
    assert np.array_equal(
        signal.resample_poly(x, 4, 1), signal.resample_poly(x, 4, 1, window=_upsampling_taps(4))
    )
