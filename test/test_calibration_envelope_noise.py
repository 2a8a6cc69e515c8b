"""The envelope family's noise model against statistics of Gaussian noise
(docs/history/calibration_sessions.md Sec. 8.15).

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
    envelope_excess_share,
    gaussian_envelope_spectrum,
)
from gear_rotor_sim.calibration.residual import (
    Comparison,
    ModelFeatures,
    ResidualSettings,
    Score,
    envelope_power_spectrum,
    order_coefficients,
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


def _noise_comparison(x: np.ndarray, corrected: bool | None = None) -> Comparison:
    """A ``Comparison`` with the envelope family only on one noise channel (no model content);
    ``corrected=None``: the default noise model."""
    kw = {} if corrected is None else {"envelope_noise_corrected": corrected}
    cmp = object.__new__(Comparison)
    cmp.s = ResidualSettings(
        families=("envelope",),
        envelope_band_hz=BAND,
        fit_gain=False,
        envelope_non_synchronous=False,
        envelope_min_hz=F_LO,
        **kw,
    )
    cmp.families, cmp.fs, cmp.y, cmp.nc = ("envelope",), FS, x[:, None], 1
    cmp.names, cmp.env_use, cmp.env_hi = ["bearing2_fy"], np.ones(1, dtype=bool), F_HI
    cmp.m = SimpleNamespace(issues=[])
    cmp.mesh_hz, cmp.shafts, cmp.shift_held, cmp.gains_held = 0.0, [], True, True
    cmp.band_fallback = False
    cmp.set_baseline(np.zeros((x.size, 1)))
    return cmp


def _envelope_chi2_per_feature(x: np.ndarray, corrected: bool | None = None) -> tuple[float, int]:
    cmp = _noise_comparison(x, corrected)
    sc = cmp.score(ModelFeatures([], [np.zeros(x.size, dtype=complex)], np.zeros(1)))
    return sc.chi2["envelope"] / sc.n["envelope"], sc.n["envelope"]


def _pink(w: np.ndarray) -> np.ndarray:
    """Gaussian noise with a 1/f power spectrum (a factor 2 across the one-octave band)."""
    f = np.fft.rfftfreq(w.size, 1.0 / FS)
    spec = np.fft.rfft(w)
    spec[0] = 0.0
    spec[1:] /= np.sqrt(f[1:])
    return np.fft.irfft(spec, w.size)


@pytest.mark.parametrize("colour", ["white", "pink"])
def test_pure_noise_scores_one_per_family_by_default(colour: str) -> None:
    """Gaussian noise alone (the independent generator's sensor noise is white Gaussian,
    ``lumped_gearbox/record.py``) scored against a model without content: the normalised residual
    ``chi2 / N`` of each family is 1 by definition, within the scatter that ``N`` features allow.

    Scatter per 2 s record: envelope ``sqrt(2 x 3 / N)`` (a chi^2 of ``N`` bins, each of about 1
    degree of freedom, neighbours sharing their summed bins, so about ``N / 3`` independent;
    measured 0.15 over 40 records at ``N = 159``, mean 0.86); order family ``sqrt(2 / N)`` for ``N``
    complex coefficients (measured 0.11 at ``N = 199``, mean 1.00). The band is 4 such standard
    errors of the mean over the records.
    """
    rng = np.random.default_rng(7)
    colour_fn = _pink if colour == "pink" else (lambda w: w)
    runs = 8
    env, old, order = [], [], []
    for _ in range(runs):
        x = colour_fn(rng.standard_normal(int(2.0 * FS)))
        e, n_env = _envelope_chi2_per_feature(x)
        env.append(e)
        old.append(_envelope_chi2_per_feature(x, corrected=False)[0])
        orders = np.arange(1, 200)
        c, v, _ = order_coefficients(x, FS, 8000.0 / 60.0, orders, 0.0)
        order.append(float(np.mean(np.abs(c) ** 2 / v)))
    # measured (seed 7): envelope 0.92 white, 0.93 pink (band 1 +- 0.27); order 1.01, 0.99 (1 +- 0.14)
    assert np.mean(env) == pytest.approx(1.0, abs=4.0 * np.sqrt(6.0 / (n_env * runs)))
    assert np.mean(order) == pytest.approx(1.0, abs=4.0 * np.sqrt(2.0 / (orders.size * runs)))
    # the old flat floor with 3 independent bins per sum (``envelope_noise_corrected=False``) reads the
    # noise's own envelope shape as misfit: 5.3 white, 5.7 pink here
    assert np.mean(old) > 3.5


def test_envelope_excess_share_is_the_envelope_familys_own_share() -> None:
    """A bearing defect's share of the envelope family's excess ``chi2 - N``, computed by hand: 400
    bins at chi^2 1000 (excess 600) falling to 550 explain 450 / 600 = 0.75, whatever the other
    families hold; no excess or no envelope family: 0."""
    before = Score({"order": 9000.0, "envelope": 1000.0}, {"order": 600, "envelope": 400}, np.ones(1), {}, {})
    after = Score({"order": 9000.0, "envelope": 550.0}, {"order": 600, "envelope": 400}, np.ones(1), {}, {})
    assert envelope_excess_share(before, after) == pytest.approx(0.75, rel=1e-12)
    # the whole balanced excess (the 25 % rule's other share) is dominated by the order family here
    whole = (before.balanced_chi2 - after.balanced_chi2) / (before.balanced_chi2 - 1000)
    assert whole < 0.25 < envelope_excess_share(before, after)
    at_noise = Score({"envelope": 380.0}, {"envelope": 400}, np.ones(1), {}, {})
    assert envelope_excess_share(at_noise, after) == 0.0
    no_env = Score({"order": 9000.0}, {"order": 600}, np.ones(1), {}, {})
    assert envelope_excess_share(no_env, no_env) == 0.0
