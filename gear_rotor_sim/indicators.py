"""Condition indicators of a window of vibration samples (pure NumPy, no ROS).

The monitoring node (``gear_rotor_sim.ros.monitor_node``) publishes exactly what
:func:`compute_indicators` returns, so a test or an offline analysis can recompute the published
figures from the same samples.

Definitions (per channel, over one window of ``n`` samples ``x``):

- The statistics use the fluctuating part ``x - mean(x)`` (a gear's DTE and bearing forces carry a
  large static part that would otherwise dominate RMS, peak and crest factor).
- ``rms = sqrt(mean((x - mean)^2))``, ``peak = max |x - mean|``, ``crest_factor = peak / rms``,
  ``kurtosis = mean((x - mean)^4) / rms^4`` (Pearson: 3 for Gaussian noise, 1.5 for a sine).
  For a constant window (``rms == 0``) crest factor and kurtosis are 0.
- Order lines: single-sided amplitude spectrum with a Hann window, amplitude-corrected
  (``2 |X_k| / sum(w)``, so a sine of amplitude A shows A at its bin). The amplitude at order ``o``
  of the input shaft (``f_shaft = speed_rpm / 60``) is the largest bin within
  ``+-order_halfwidth`` orders of ``o * f_shaft`` (the nearest bin when that band is narrower than a
  bin). The mesh order is the pinion tooth count; the sideband amplitude is the mean of the
  amplitudes at the mesh order -1 and +1. A line that is not observable (speed <= 0, or the line at
  or above the Nyquist frequency) is reported as NaN.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Half-width of the band searched around an order line, in shaft orders (sidebands are 1 order away).
DEFAULT_ORDER_HALFWIDTH = 0.4


@dataclass(frozen=True)
class Indicators:
    """Indicators of one window; every array has one entry per channel.

    Attributes
    ----------
    rms, peak, crest_factor, kurtosis : numpy.ndarray
        Statistics of the fluctuating part of each channel (see the module docstring).
    mesh_order_amplitude, sideband_amplitude : numpy.ndarray
        Amplitude of the line at the mesh order and mean amplitude of its +-1 shaft-order sidebands,
        in the channel's unit; NaN when not observable.
    mesh_frequency_hz : float
        ``pinion_teeth * speed_rpm / 60``; 0 when ``speed_rpm <= 0``.
    window_s : float
        Window length, ``n / sample_rate_hz``.
    """

    rms: np.ndarray
    peak: np.ndarray
    crest_factor: np.ndarray
    kurtosis: np.ndarray
    mesh_order_amplitude: np.ndarray
    sideband_amplitude: np.ndarray
    mesh_frequency_hz: float
    window_s: float


def _as_2d(data: np.ndarray) -> np.ndarray:
    x = np.asarray(data, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2 or x.shape[0] < 2:
        raise ValueError(f"data: expected shape (n_samples >= 2, n_channels), got {np.shape(data)}")
    return x


def statistics(data: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """RMS, peak, crest factor and kurtosis of each column of ``data`` about its mean.

    Parameters
    ----------
    data : numpy.ndarray
        Shape ``(n_samples, n_channels)`` (or ``(n_samples,)`` for one channel).

    Returns
    -------
    rms, peak, crest_factor, kurtosis : numpy.ndarray
        Shape ``(n_channels,)`` each.
    """
    x = _as_2d(data)
    dev = x - x.mean(axis=0)
    m2 = np.mean(dev * dev, axis=0)
    m4 = np.mean(dev**4, axis=0)
    rms = np.sqrt(m2)
    peak = np.max(np.abs(dev), axis=0)
    nonzero = m2 > 0.0
    safe_rms = np.where(nonzero, rms, 1.0)
    safe_m2 = np.where(nonzero, m2, 1.0)
    crest = np.where(nonzero, peak / safe_rms, 0.0)
    kurt = np.where(nonzero, m4 / (safe_m2 * safe_m2), 0.0)
    return rms, peak, crest, kurt


def amplitude_spectrum(data: np.ndarray, sample_rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Hann-windowed, amplitude-corrected single-sided spectrum of each column.

    Parameters
    ----------
    data : numpy.ndarray
        Shape ``(n_samples, n_channels)`` or ``(n_samples,)``.
    sample_rate_hz : float
        Sampling rate, Hz.

    Returns
    -------
    freqs : numpy.ndarray
        Bin frequencies, Hz, shape ``(n_samples // 2 + 1,)``.
    amplitude : numpy.ndarray
        Shape ``(n_bins, n_channels)``, in the channel's unit (a sine of amplitude A shows A).
    """
    if not np.isfinite(sample_rate_hz) or sample_rate_hz <= 0.0:
        raise ValueError(f"sample_rate_hz: must be finite and > 0, got {sample_rate_hz}")
    x = _as_2d(data)
    n = x.shape[0]
    w = np.hanning(n)
    spec = np.fft.rfft((x - x.mean(axis=0)) * w[:, None], axis=0)
    amp = 2.0 * np.abs(spec) / w.sum()
    amp[0] *= 0.5
    return np.fft.rfftfreq(n, 1.0 / sample_rate_hz), amp


def order_amplitude(
    freqs: np.ndarray,
    amplitude: np.ndarray,
    shaft_frequency_hz: float,
    order: float,
    halfwidth: float = DEFAULT_ORDER_HALFWIDTH,
) -> np.ndarray:
    """Amplitude of the line at ``order`` times the shaft frequency, per channel.

    Parameters
    ----------
    freqs, amplitude : numpy.ndarray
        Output of :func:`amplitude_spectrum`.
    shaft_frequency_hz : float
        Input-shaft rotation frequency, Hz.
    order : float
        Shaft order of the line.
    halfwidth : float
        Search half-width in orders.

    Returns
    -------
    numpy.ndarray
        Shape ``(n_channels,)``; NaN when the line is not observable.
    """
    n_ch = amplitude.shape[1]
    f = order * shaft_frequency_hz
    nyquist = freqs[-1] if freqs.size else 0.0
    df = freqs[1] - freqs[0] if freqs.size > 1 else np.inf
    if not (shaft_frequency_hz > 0.0) or order <= 0.0 or f >= nyquist + 0.5 * df:
        return np.full(n_ch, np.nan)
    lo = f - halfwidth * shaft_frequency_hz
    hi = f + halfwidth * shaft_frequency_hz
    band = (freqs >= lo) & (freqs <= hi)
    if not band.any():
        return amplitude[int(np.argmin(np.abs(freqs - f)))].copy()
    return amplitude[band].max(axis=0)


def compute_indicators(
    data: np.ndarray,
    sample_rate_hz: float,
    speed_rpm: float,
    pinion_teeth: int,
    order_halfwidth: float = DEFAULT_ORDER_HALFWIDTH,
) -> Indicators:
    """All indicators of one window of samples.

    Parameters
    ----------
    data : numpy.ndarray
        Shape ``(n_samples, n_channels)`` (or ``(n_samples,)``), contiguous samples of one stream.
    sample_rate_hz : float
        Sampling rate, Hz.
    speed_rpm : float
        Input (pinion) shaft speed, rpm; orders are relative to this shaft.
    pinion_teeth : int
        Tooth count of the pinion on the input shaft (the mesh order).
    order_halfwidth : float
        Search half-width around each order line, in orders.

    Returns
    -------
    Indicators
    """
    if pinion_teeth < 1:
        raise ValueError(f"pinion_teeth: must be >= 1, got {pinion_teeth}")
    x = _as_2d(data)
    rms, peak, crest, kurt = statistics(x)
    f_shaft = float(speed_rpm) / 60.0 if np.isfinite(speed_rpm) and speed_rpm > 0.0 else 0.0
    freqs, amp = amplitude_spectrum(x, sample_rate_hz)
    mesh = order_amplitude(freqs, amp, f_shaft, float(pinion_teeth), order_halfwidth)
    lower = order_amplitude(freqs, amp, f_shaft, float(pinion_teeth - 1), order_halfwidth)
    upper = order_amplitude(freqs, amp, f_shaft, float(pinion_teeth + 1), order_halfwidth)
    return Indicators(
        rms=rms,
        peak=peak,
        crest_factor=crest,
        kurtosis=kurt,
        mesh_order_amplitude=mesh,
        sideband_amplitude=0.5 * (lower + upper),
        mesh_frequency_hz=pinion_teeth * f_shaft,
        window_s=x.shape[0] / float(sample_rate_hz),
    )


def dominant_frequency(signal: np.ndarray, sample_rate_hz: float, min_hz: float = 0.0) -> float:
    """Frequency of the largest line of a single-channel signal's amplitude spectrum above ``min_hz``.

    Parameters
    ----------
    signal : numpy.ndarray
        Shape ``(n_samples,)``.
    sample_rate_hz : float
        Sampling rate, Hz.
    min_hz : float
        Lines below this frequency are ignored (e.g. the slow drift of a ramp).

    Returns
    -------
    float
        Frequency, Hz, refined by parabolic interpolation of the log amplitude around the peak bin.
    """
    freqs, amp = amplitude_spectrum(np.asarray(signal, dtype=np.float64), sample_rate_hz)
    a = amp[:, 0]
    valid = np.flatnonzero(freqs >= min_hz)
    if valid.size == 0:
        raise ValueError(f"min_hz: {min_hz} is above the Nyquist frequency {freqs[-1]}")
    k = int(valid[np.argmax(a[valid])])
    if 0 < k < a.size - 1 and a[k - 1] > 0 and a[k] > 0 and a[k + 1] > 0:
        l0, l1, l2 = np.log(a[k - 1]), np.log(a[k]), np.log(a[k + 1])
        denom = l0 - 2.0 * l1 + l2
        delta = 0.5 * (l0 - l2) / denom if denom != 0.0 else 0.0
        return float(freqs[k] + delta * (freqs[1] - freqs[0]))
    return float(freqs[k])
