"""Condition indicators (gear_rotor_sim.indicators) on signals with known answers; no ROS."""

from __future__ import annotations

import numpy as np
import pytest

from gear_rotor_sim.indicators import (
    amplitude_spectrum,
    compute_indicators,
    dominant_frequency,
    order_amplitude,
    statistics,
)

FS = 20000.0


def _time(duration_s: float, fs: float = FS) -> np.ndarray:
    return np.arange(round(duration_s * fs)) / fs


def test_sine_statistics() -> None:
    t = _time(1.0)
    x = 5.0 + 2.0 * np.sin(2 * np.pi * 100.0 * t)
    rms, peak, crest, kurt = statistics(x)
    assert rms[0] == pytest.approx(2.0 / np.sqrt(2.0), rel=1e-6)
    assert peak[0] == pytest.approx(2.0, rel=1e-4)
    assert crest[0] == pytest.approx(np.sqrt(2.0), rel=1e-4)
    assert kurt[0] == pytest.approx(1.5, rel=1e-4)


def test_gaussian_kurtosis_and_impulses() -> None:
    rng = np.random.default_rng(1)
    noise = rng.normal(0.0, 1.0, 400_000)
    _, _, _, kurt = statistics(noise)
    assert kurt[0] == pytest.approx(3.0, abs=0.05)
    spiky = noise.copy()
    spiky[::1000] += 20.0
    _, _, crest_spiky, kurt_spiky = statistics(spiky)
    assert kurt_spiky[0] > 10.0
    assert crest_spiky[0] > 10.0


def test_constant_channel_is_degenerate_not_nan() -> None:
    rms, peak, crest, kurt = statistics(np.full((100, 2), 3.0))
    assert np.all(rms == 0.0) and np.all(peak == 0.0) and np.all(crest == 0.0) and np.all(kurt == 0.0)


def test_amplitude_spectrum_is_amplitude_corrected() -> None:
    t = _time(0.5)
    x = 3.0 * np.sin(2 * np.pi * 1000.0 * t)  # bin-centred (2 Hz resolution)
    freqs, amp = amplitude_spectrum(x, FS)
    k = int(np.argmax(amp[:, 0]))
    assert freqs[k] == pytest.approx(1000.0)
    assert amp[k, 0] == pytest.approx(3.0, rel=1e-6)


def test_mesh_order_and_sidebands() -> None:
    speed_rpm, teeth = 3000.0, 29
    f_shaft = speed_rpm / 60.0
    f_mesh = teeth * f_shaft  # 1450 Hz
    t = _time(0.5)
    # amplitude-modulated mesh line: carrier A, sidebands A*m/2 at f_mesh -+ f_shaft
    a, m = 4.0e-6, 0.5
    dte = a * (1.0 + m * np.cos(2 * np.pi * f_shaft * t)) * np.sin(2 * np.pi * f_mesh * t)
    force = 100.0 * np.sin(2 * np.pi * 2 * f_mesh * t)  # line at twice the mesh order only
    ind = compute_indicators(np.column_stack([dte, force]), FS, speed_rpm, teeth)
    assert ind.mesh_frequency_hz == pytest.approx(1450.0)
    assert ind.window_s == pytest.approx(0.5)
    assert ind.mesh_order_amplitude[0] == pytest.approx(a, rel=1e-3)
    assert ind.sideband_amplitude[0] == pytest.approx(a * m / 2.0, rel=1e-3)
    assert ind.mesh_order_amplitude[1] < 1e-3 * 100.0
    assert ind.rms[1] == pytest.approx(100.0 / np.sqrt(2.0), rel=1e-4)


def test_order_line_not_observable_is_nan() -> None:
    t = _time(0.2)
    x = np.sin(2 * np.pi * 50.0 * t)
    ind = compute_indicators(x, FS, 0.0, 29)
    assert ind.mesh_frequency_hz == 0.0
    assert np.isnan(ind.mesh_order_amplitude[0]) and np.isnan(ind.sideband_amplitude[0])
    freqs, amp = amplitude_spectrum(x, FS)
    # 29 * 25000/60 Hz = 12083 Hz is above the 10 kHz Nyquist frequency
    assert np.isnan(order_amplitude(freqs, amp, 25000.0 / 60.0, 29.0)[0])


def test_dominant_frequency_interpolates_between_bins() -> None:
    t = _time(0.25)
    x = np.sin(2 * np.pi * 1234.5 * t) + 0.1 * np.sin(2 * np.pi * 50.0 * t)
    assert dominant_frequency(x, FS) == pytest.approx(1234.5, abs=0.5)
    assert dominant_frequency(x, FS, min_hz=2000.0) > 2000.0


@pytest.mark.parametrize(
    "bad",
    [np.zeros(1), np.zeros((1, 3)), np.zeros((2, 2, 2))],
)
def test_bad_shapes_are_refused(bad: np.ndarray) -> None:
    with pytest.raises(ValueError, match="data"):
        statistics(bad)


def test_bad_arguments_are_refused() -> None:
    with pytest.raises(ValueError, match="pinion_teeth"):
        compute_indicators(np.zeros((10, 1)), FS, 3000.0, 0)
    with pytest.raises(ValueError, match="sample_rate_hz"):
        amplitude_spectrum(np.zeros((10, 1)), float("nan"))
