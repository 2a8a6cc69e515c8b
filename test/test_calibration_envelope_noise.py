"""The envelope family's noise model against statistics of Gaussian noise (docs/calibration.md Sec. 8.15).

Truth here is independent of the calibration: Monte-Carlo averages of the calibration's own envelope
estimate on white Gaussian noise, the textbook correlation of Hann-windowed DFT bins, and the
defining property of a normalised residual (chi^2 per feature about 1 on pure noise).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from gear_rotor_sim.analysis.signals import analytic_band
from gear_rotor_sim.calibration.features_envelope_noise import (
    HANN_BIN_POWER_CORRELATION,
    band_noise_envelope_spectrum,
    bin_sum_variance_factor,
    gaussian_envelope_spectrum,
)
from gear_rotor_sim.calibration.residual import (
    Comparison,
    ModelFeatures,
    ResidualSettings,
    envelope_power_spectrum,
)

FS = 20000.0
BAND = (3186.65, 6373.3)  # the band chosen on the healthy 8000 rpm record's bearing2_fy
F_LO, F_HI, SEG = 5.0, 1593.0, 0.1


def test_hann_bin_power_correlation_matches_simulated_white_noise():
    rng = np.random.default_rng(0)
    L = 256
    x = rng.standard_normal((4000, L)) * np.hanning(L)
    p = np.abs(np.fft.rfft(x, axis=1)[:, 20:100]) ** 2
    for d, rho in enumerate(HANN_BIN_POWER_CORRELATION, start=1):
        r = np.mean([np.corrcoef(p[:, k], p[:, k + d])[0, 1] for k in range(p.shape[1] - d)])
        assert r == pytest.approx(rho, abs=0.03)
    assert bin_sum_variance_factor(3) == pytest.approx((3 + 2 * (2 * 4 / 9 + 1 / 36)) / 3)
    assert bin_sum_variance_factor(3, rho=()) == 1.0


def test_gaussian_envelope_spectrum_is_the_monte_carlo_mean_on_white_noise():
    rng = np.random.default_rng(1)
    n = int(1.0 * FS)
    runs, pred = [], []
    for _ in range(30):
        a = analytic_band(rng.standard_normal(n), FS, BAND)
        _, p, k = envelope_power_spectrum(a, FS, F_LO, F_HI, SEG)
        runs.append(p)
        pred.append(gaussian_envelope_spectrum(a, FS, F_LO, F_HI, SEG))
    mc = np.mean(runs, axis=0)
    g = np.mean(pred, axis=0)
    # the floor is shaped (not flat): the mean spectrum spans a wide range over 5-1593 Hz
    assert mc.max() / mc.min() > 1.6
    # standard error of the Monte-Carlo mean per bin: sqrt(1.7 / k / runs) of its level (k counts the
    # 3 summed bins as independent; their correlation makes the variance 1.61-1.7 times 1 / k)
    se = np.sqrt(1.7 / k / len(runs))
    z = (mc - g) / (g * se)
    assert np.median(np.abs(mc / g - 1.0)) < 2.0 * se
    assert np.mean(np.abs(z) < 3.0) > 0.95
    # the floor used by the calibration: white noise through the band-pass, known up to its level
    shape = band_noise_envelope_spectrum(BAND, FS, n, F_LO, F_HI, SEG)
    shape *= np.median(mc / shape)
    assert np.mean(np.abs((mc - shape) / (shape * se)) < 3.0) > 0.95
    # the measured relative variance per bin is the Hann bin-sum factor over the plain count
    relvar = np.var(runs, axis=0) / mc**2
    assert np.median(relvar) * k / bin_sum_variance_factor(3) == pytest.approx(1.0, rel=0.25)
    assert np.median(relvar) * k > 1.3  # not 3 independent bins


def _noise_comparison(x: np.ndarray, shaped: bool) -> Comparison:
    """A ``Comparison`` with the envelope family only on one noise channel (no model content)."""
    cmp = object.__new__(Comparison)
    cmp.s = ResidualSettings(
        families=("envelope",),
        envelope_band_hz=BAND,
        envelope_noise_corrected=shaped,
        fit_gain=False,
        envelope_non_synchronous=False,
        envelope_min_hz=F_LO,
    )
    cmp.families, cmp.fs, cmp.y, cmp.nc = ("envelope",), FS, x[:, None], 1
    cmp.names, cmp.env_use, cmp.env_hi = ["bearing2_fy"], np.ones(1, dtype=bool), F_HI
    cmp.m = SimpleNamespace(issues=[])
    cmp.mesh_hz, cmp.shafts, cmp.shift_held, cmp.gains_held = 0.0, [], True, True
    cmp.band_fallback = False
    cmp.set_baseline(np.zeros((x.size, 1)))
    return cmp


def test_pure_noise_scores_at_the_noise_level():
    rng = np.random.default_rng(2)
    shaped, flat = [], []
    for _ in range(6):
        x = rng.standard_normal(int(2.0 * FS))
        for out, sh in ((shaped, True), (flat, False)):
            cmp = _noise_comparison(x, sh)
            feats = ModelFeatures([], [np.zeros(x.size, dtype=complex)], np.zeros(1))
            sc = cmp.score(feats)
            out.append(sc.chi2["envelope"] / sc.n["envelope"])
    # normalised residual of pure noise: 1 by definition (measured 0.76-1.12 per record here, mean 0.93)
    assert np.mean(shaped) == pytest.approx(1.0, abs=0.25)
    # the flat floor reads the noise's own shape as misfit (3.4 here with the corrected bin count;
    # 4.9 with the old count of 3 independent bins per sum)
    assert np.mean(flat) > 2.5
