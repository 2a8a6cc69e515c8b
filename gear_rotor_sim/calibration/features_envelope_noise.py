"""Noise model of the squared-envelope spectrum (issue 11; ``docs/history/calibration_sessions.md``
Sec. 8.15).

The envelope family compares the Welch-averaged power spectrum of the squared envelope ``|a|^2`` of a
band-passed channel (``residual.envelope_power_spectrum``: Hann segments, 50 % overlap, segment mean
removed, 3-bin moving sum) with the model's plus a noise floor. Two properties of that estimate set
the floor and its scatter, whatever the machine:

* **The floor is not flat.** For a stationary circular Gaussian analytic signal ``a`` (noise, or any
  random content of the band) the autocovariance of ``|a|^2`` is ``|R_a(tau)|^2`` (Isserlis), so its
  spectrum is the autocorrelation of the band's spectrum: for a flat band of width ``B`` a triangle
  falling to zero at ``B``, shaped further by the band-pass filter's skirts and, in the lowest bins,
  by the removal of each segment's mean. Measured on white noise through the calibration's pipeline
  (2 s at 20 kHz, band 3187-6373 Hz, 5-1593 Hz): 0.62-1.27 times its median; a flat floor misreads
  that shape as model error (normalised envelope error 4.9 on pure noise).
  :func:`band_noise_envelope_spectrum` computes the expected estimate for white noise through the
  calibration's band-pass filter, exactly through the same windowing, mean removal and bin sum; its
  shape (median 1) multiplies the floor level (``Comparison.envelope_expected``). The shape is taken
  from the filter, not from the measured band: a Gaussian process with the measured band's spectrum
  carries a bearing defect's envelope lines too (tried: the CWRU inner-race defect was then not found).
* **The 3-bin sum is not 3 independent averages.** Adjacent bins of a Hann-windowed DFT of white
  noise correlate with coefficient ``-2/3`` (next-but-one ``1/6``) in amplitude, ``4/9`` (``1/36``) in
  power, so the variance of the sum of three bins is ``3 + 4 (4/9) + 2 (1/36) = 4.83`` single-bin
  variances, not 3 (:func:`bin_sum_variance_factor`: 1.61). Measured on white noise: 1.69-1.72 (the
  rest: overlap and the non-Gaussian squared envelope).

The default since session 11 (``ResidualSettings.envelope_noise_corrected``,
docs/history/calibration_sessions.md Sec. 8.23; ``False`` restores the flat floor and the plain count, under
which pure noise scores 4.9). With it a bearing defect whose own lines pass the signature checks qualifies
also on its share of the envelope family's excess (:func:`envelope_excess_share`): with the bin variances 1.61
times larger its envelope gain weighs less against the order family's model-form excess, which no bearing
defect touches (the contact inner race: 14.5 % of the whole excess, 25 % needed).

Assumes: the noise is white within the band (one octave; a sensor's or a housing resonance's
colouring within it bends the true floor away from this shape: measured on Gaussian noise, smooth
colouring (1/f, AR(1)) scores 0.79-0.86, a resonance of Q 2 inside the band 1.6-2.9, of Q 5
11-14); periodic modulation (a bearing defect's impacts) stands above this floor as lines, as it
should.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy import signal as _sig

#: power correlation of Hann-windowed DFT bins of white noise at a distance of 1 and 2 bins
HANN_BIN_POWER_CORRELATION: tuple[float, ...] = (4.0 / 9.0, 1.0 / 36.0)


def bin_sum_variance_factor(n_sum: int = 3, rho: tuple[float, ...] = HANN_BIN_POWER_CORRELATION) -> float:
    """Variance of a sum of ``n_sum`` adjacent periodogram bins over ``n_sum`` times one bin's variance.

    ``(n + 2 sum_d (n - d) rho_d) / n`` with ``rho_d`` the power correlation of bins ``d`` apart
    (1 for independent bins; 1.61 for three Hann bins).
    """
    n = int(n_sum)
    if n < 1:
        raise ValueError(f"n_sum: must be >= 1, got {n_sum!r}")
    extra = sum((n - d) * rho[d - 1] for d in range(1, n) if d - 1 < len(rho))
    return (n + 2.0 * extra) / n


def _expected_welch(r: np.ndarray, fs: float, L: int, f_lo: float, f_hi: float) -> np.ndarray:
    """Expected ``envelope_power_spectrum`` (segments of ``L`` samples) of ``|a|^2`` for a circular
    Gaussian ``a`` with autocorrelation ``r`` (lags 0..L-1): the autocovariance of ``|a|^2`` is ``|r|^2``."""
    c_pos = np.abs(r[:L]) ** 2
    c_full = np.concatenate([c_pos[:0:-1], c_pos])  # lags -(L-1)..(L-1)
    lags = np.arange(-(L - 1), L)
    w = np.hanning(L)
    ww = np.correlate(w, w, mode="full")  # sum_n w_n w_{n+tau}, lags -(L-1)..(L-1)
    # E|sum_n u_n x_n|^2 with u_n = w_n e_n - W_k / L (the segment mean removed), x = |a|^2:
    # term 1: sum_tau C(tau) ww(tau) e^{-i w_k tau} (DFT of the lag product wrapped onto L points)
    h = np.zeros(L)
    np.add.at(h, lags % L, c_full * ww)
    t1 = np.real(np.fft.rfft(h))
    # D_n = sum_m C(n - m) over the segment; cross terms with the mean and the mean's own variance
    cs = np.concatenate([[0.0], np.cumsum(c_full)])
    idx = np.arange(L)
    d = cs[idx + L] - cs[idx]
    beta = np.fft.rfft(w) / L
    fwd = np.fft.rfft(w * d)
    expected = t1 - 2.0 * np.real(np.conj(beta) * fwd) + np.abs(beta) ** 2 * float(d.sum())
    expected = np.maximum(expected, 0.0) / (w.sum() ** 2) * 4.0
    expected = np.convolve(expected, np.ones(3), mode="same")
    f = np.fft.rfftfreq(L, 1.0 / fs)
    return expected[(f >= f_lo) & (f <= f_hi)]


def _segment(segment_s: float, fs: float, n: int) -> int:
    L = int(min(segment_s * fs, n))
    if L < 4:
        raise ValueError(f"segment_s: {segment_s!r} s gives fewer than 4 samples at fs={fs!r} Hz")
    return L


def gaussian_envelope_spectrum(
    analytic: np.ndarray, fs: float, f_lo: float, f_hi: float, segment_s: float
) -> np.ndarray:
    """Expected ``envelope_power_spectrum`` of a circular Gaussian process with the autocorrelation of
    ``analytic`` (estimated over the whole record).

    Parameters
    ----------
    analytic : numpy.ndarray
        Analytic (band-passed) signal, complex (n,).
    fs, f_lo, f_hi, segment_s
        As ``residual.envelope_power_spectrum`` (same segment length, window, mean removal, 3-bin sum
        and frequency selection).

    Returns
    -------
    numpy.ndarray
        Expected power per bin in ``[f_lo, f_hi]`` (same bins as ``envelope_power_spectrum``).

    Not used for the floor: a periodic modulation (a bearing defect's impacts) puts lines into the
    band's spectrum, and the Gaussian process with that spectrum has the defect's envelope lines too
    (measured on the CWRU inner-race file: the defect was no longer found); the floor is
    :func:`band_noise_envelope_spectrum`. Kept to check the computation against simulated noise.
    """
    a = np.asarray(analytic, dtype=complex)
    n = a.size
    L = _segment(segment_s, fs, n)
    nfft = 1 << int(np.ceil(np.log2(2 * n)))
    r = np.fft.ifft(np.abs(np.fft.fft(a, nfft)) ** 2)[:L] / n
    return _expected_welch(r, fs, L, f_lo, f_hi)


def band_noise_envelope_spectrum(
    band: tuple[float, float], fs: float, n: int, f_lo: float, f_hi: float, segment_s: float
) -> np.ndarray:
    """Expected ``envelope_power_spectrum`` (up to a constant) of white Gaussian noise through the
    calibration's band-pass (``analysis.signals.analytic_band``: 4th-order Butterworth applied forward
    and backward, so ``|H|^4`` in power, then the Hilbert transform), for a record of ``n`` samples.

    Independent of the measured content: a defect's lines cannot enter the floor.
    """
    L = _segment(segment_s, fs, n)
    nfft = 1 << int(np.ceil(np.log2(max(8 * L, 4096))))
    sos = _sig.butter(4, band, btype="bandpass", fs=fs, output="sos")
    _, h = _sig.sosfreqz(sos, worN=nfft, whole=True, fs=fs)
    power = np.abs(h) ** 4
    power[nfft // 2 :] = 0.0  # the analytic signal: positive frequencies only
    r = np.fft.ifft(power)[:L]
    return _expected_welch(r, fs, L, f_lo, f_hi)


def envelope_noise_shape(
    band: tuple[float, float], fs: float, n: int, f_lo: float, f_hi: float, segment_s: float
) -> np.ndarray:
    """Shape of the envelope noise floor (:func:`band_noise_envelope_spectrum`) with median 1 (ones if
    the band holds nothing)."""
    g = band_noise_envelope_spectrum(band, fs, n, f_lo, f_hi, segment_s)
    med = float(np.median(g)) if g.size else 0.0
    if not med > 0 or not np.all(np.isfinite(g)):
        return np.ones(g.shape)
    return np.maximum(g / med, 1e-6)


def envelope_excess_share(before: Any, after: Any) -> float:
    """Share of the envelope family's excess (``chi2 - N``) that a candidate explains.

    The acceptance share of a bearing defect whose own lines passed the signature checks
    (``Calibrator._signature_check``: a significant gain on its characteristic lines and one of them
    6 dB above the local floor), used next to its share of the whole balanced excess, as a damaged
    tooth's share of its own comb's excess is (docs/history/calibration_sessions.md Sec. 8.23). A defect's
    impacts act on the envelope family only; where the order family's model-form excess (which no bearing
    defect touches) dominates the whole excess, the whole-excess share reads a correctly placed defect as
    unimportant (the contact inner race: 16 % of the whole excess with the corrected bin count).

    Parameters
    ----------
    before, after : Score
        Scores (``residual.Score``: ``chi2`` and ``n`` per family) of the current model and of the
        model with the candidate.

    Returns
    -------
    float
        ``(chi2_before - chi2_after) / (chi2_before - N)`` of the envelope family; 0 where the family
        is absent or has no excess.
    """
    n = before.n.get("envelope", 0)
    if n <= 0 or "envelope" not in after.chi2:
        return 0.0
    excess = before.chi2["envelope"] - n
    if not excess > 0:
        return 0.0
    return float((before.chi2["envelope"] - after.chi2["envelope"]) / excess)
