"""Signal analyses of sampled channels: spectra, order spectra, envelope spectra, synchronous averages.

These functions take plain arrays (one channel of a :class:`gear_rotor_sim.blocks.SampleBlock`, or a
measured signal) and never integrate the model, so the calibration code reuses them to compare
simulated and measured vibration on the same footing (same window, same amplitude scaling).

Amplitude convention: a pure tone ``A cos(2 pi f t + phi)`` whose frequency falls on a bin shows the
peak value ``A`` in :func:`amplitude_spectrum` for every supported window (coherent-gain
correction). Between bins the Hann/flat-top windows lose at most 15 % / 0.1 % of the amplitude
(scalloping loss).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from scipy import signal as _sig

_WINDOWS = ("rectangular", "hann", "hamming", "blackman", "flattop")


def _window(name: str, n: int) -> np.ndarray:
    if name not in _WINDOWS:
        raise ValueError(f"window: {name!r} is not one of {_WINDOWS}")
    if name == "rectangular":
        return np.ones(n)
    return _sig.get_window(name, n, fftbins=True)


@dataclass(frozen=True)
class Spectrum:
    """A single-sided amplitude spectrum.

    Attributes
    ----------
    axis : numpy.ndarray
        Frequencies in Hz (or orders, for an order spectrum).
    amplitude : numpy.ndarray
        Peak amplitude per bin, in the unit of the signal.
    unit : str
        ``"Hz"`` or ``"order"``.
    """

    axis: np.ndarray
    amplitude: np.ndarray
    unit: str = "Hz"

    def peak(self, lo: float = -np.inf, hi: float = np.inf) -> tuple[float, float]:
        """Location and amplitude of the largest bin with ``lo <= axis <= hi``."""
        sel = (self.axis >= lo) & (self.axis <= hi)
        if not np.any(sel):
            raise ValueError(f"peak: no bins in [{lo}, {hi}] {self.unit}")
        i = np.flatnonzero(sel)[np.argmax(self.amplitude[sel])]
        return float(self.axis[i]), float(self.amplitude[i])

    def at(self, value: float) -> float:
        """Amplitude at the bin nearest to ``value``."""
        return float(self.amplitude[int(np.argmin(np.abs(self.axis - value)))])


def amplitude_spectrum(
    x: np.ndarray, sample_rate_hz: float, window: str = "hann", detrend: bool = True
) -> Spectrum:
    """Single-sided peak-amplitude spectrum with window (coherent-gain) correction.

    Parameters
    ----------
    x : numpy.ndarray
        Uniformly sampled signal, shape ``(n,)``.
    sample_rate_hz : float
        Sampling rate, Hz.
    window : str
        ``"hann"`` (default), ``"rectangular"``, ``"hamming"``, ``"blackman"`` or ``"flattop"``
        (use the flat-top window when the amplitude of tones between bins matters).
    detrend : bool
        Remove the mean before the transform (the DC bin then holds only the residual).

    Returns
    -------
    Spectrum
        Frequencies ``k fs / n`` for ``k = 0 .. n//2`` and the peak amplitude per bin: ``2 |X_k| /
        sum(w)`` (the DC and Nyquist bins are not doubled).
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or x.size < 2:
        raise ValueError(f"x: a 1-D signal of at least 2 samples is required, got shape {x.shape}")
    if not np.isfinite(sample_rate_hz) or sample_rate_hz <= 0:
        raise ValueError(f"sample_rate_hz: must be positive and finite, got {sample_rate_hz}")
    if detrend:
        x = x - x.mean()
    w = _window(window, x.size)
    spec = np.abs(np.fft.rfft(x * w)) / w.sum()
    spec[1:] *= 2.0
    if x.size % 2 == 0:
        spec[-1] /= 2.0
    freqs = np.fft.rfftfreq(x.size, 1.0 / sample_rate_hz)
    return Spectrum(freqs, spec, "Hz")


def shaft_angle(speed_rpm: np.ndarray | float, sample_rate_hz: float, n: int) -> np.ndarray:
    """Shaft angle in revolutions at each sample, integrated from the speed (trapezoidal rule).

    Parameters
    ----------
    speed_rpm : numpy.ndarray or float
        Shaft speed per sample (shape ``(n,)``) or a constant, rpm.
    sample_rate_hz : float
        Sampling rate, Hz.
    n : int
        Number of samples.
    """
    rev_per_s = np.broadcast_to(np.asarray(speed_rpm, dtype=float) / 60.0, (n,))
    dt = 1.0 / sample_rate_hz
    angle = np.zeros(n)
    angle[1:] = np.cumsum(0.5 * (rev_per_s[1:] + rev_per_s[:-1]) * dt)
    return angle


def resample_to_angle(
    x: np.ndarray, sample_rate_hz: float, speed_rpm: np.ndarray | float, samples_per_rev: int
) -> tuple[np.ndarray, np.ndarray]:
    """Resample a signal uniformly in shaft angle (computed order tracking).

    Parameters
    ----------
    x : numpy.ndarray
        Time signal, shape ``(n,)``.
    sample_rate_hz : float
        Sampling rate, Hz.
    speed_rpm : numpy.ndarray or float
        Shaft speed per sample or constant, rpm (must be positive).
    samples_per_rev : int
        Samples per revolution of the output.

    Returns
    -------
    angle_rev, x_angle : numpy.ndarray
        The uniform angle grid in revolutions and the signal linearly interpolated onto it.
    """
    x = np.asarray(x, dtype=float)
    speed = np.asarray(speed_rpm, dtype=float)
    if np.any(~np.isfinite(speed)) or np.any(speed <= 0):
        raise ValueError("speed_rpm: must be positive and finite for order tracking")
    if samples_per_rev < 2:
        raise ValueError(f"samples_per_rev: must be >= 2, got {samples_per_rev}")
    angle = shaft_angle(speed, sample_rate_hz, x.size)
    n_out = int(np.floor(angle[-1] * samples_per_rev)) + 1
    grid = np.arange(n_out) / samples_per_rev
    return grid, np.interp(grid, angle, x)


def order_spectrum(
    x: np.ndarray,
    sample_rate_hz: float,
    speed_rpm: np.ndarray | float,
    samples_per_rev: int = 256,
    window: str = "hann",
    whole_revolutions: bool = True,
) -> Spectrum:
    """Amplitude spectrum against shaft order (multiples of the shaft rotation frequency).

    With a speed profile (an array, e.g. ``SampleBlock.speed_rpm``) the signal is first resampled
    uniformly in shaft angle, so orders stay sharp through a speed ramp; with a constant speed
    this is the ordinary spectrum with the frequency axis divided by the shaft frequency.

    Parameters
    ----------
    x : numpy.ndarray
        Time signal, shape ``(n,)``.
    sample_rate_hz : float
        Sampling rate, Hz.
    speed_rpm : numpy.ndarray or float
        Speed of the reference shaft per sample, or a constant, rpm.
    samples_per_rev : int
        Angular resampling density; the highest order shown is ``samples_per_rev / 2``.
    window : str
        Window as in :func:`amplitude_spectrum`.
    whole_revolutions : bool
        Trim the angle-domain signal to an integer number of revolutions (orders fall on bins).
    """
    _, xa = resample_to_angle(x, sample_rate_hz, speed_rpm, samples_per_rev)
    if whole_revolutions:
        n_rev = (xa.size - 1) // samples_per_rev
        if n_rev < 1:
            raise ValueError("x: shorter than one shaft revolution")
        xa = xa[: n_rev * samples_per_rev]
    spec = amplitude_spectrum(xa, float(samples_per_rev), window=window)
    return Spectrum(spec.axis, spec.amplitude, "order")


def envelope_spectrum(
    x: np.ndarray,
    sample_rate_hz: float,
    band_hz: tuple[float, float] | None = None,
    window: str = "hann",
) -> Spectrum:
    """Amplitude spectrum of the envelope (magnitude of the analytic signal).

    Parameters
    ----------
    x : numpy.ndarray
        Time signal.
    sample_rate_hz : float
        Sampling rate, Hz.
    band_hz : tuple of float, optional
        Band-pass ``(lo, hi)`` applied before demodulation (4th-order Butterworth, zero phase),
        as in bearing-fault envelope analysis.
    window : str
        Window as in :func:`amplitude_spectrum`.

    Notes
    -----
    For ``(1 + m cos(2 pi fm t)) cos(2 pi fc t)`` the envelope spectrum shows ``m`` at ``fm``.
    """
    x = np.asarray(x, dtype=float)
    if band_hz is None:
        env = np.abs(_sig.hilbert(x - np.mean(x)))
    else:
        lo, hi = band_hz
        nyq = 0.5 * sample_rate_hz
        if not 0 < lo < hi < nyq:
            raise ValueError(f"band_hz: need 0 < lo < hi < {nyq} Hz, got {band_hz}")
        env = np.abs(analytic_band(x, sample_rate_hz, (lo, hi)))
    return amplitude_spectrum(env, sample_rate_hz, window=window, detrend=True)


def analytic_band(x: np.ndarray, fs: float, band: tuple[float, float]) -> np.ndarray:
    """Analytic signal of ``x`` (mean removed) band-passed to ``band`` Hz.

    4th-order Butterworth band-pass, zero phase (forward-backward), then the Hilbert transform; its
    magnitude is the envelope used in bearing-fault analysis (here and in the calibration).
    """
    sos = _bandpass_sos(float(band[0]), float(band[1]), float(fs)).copy()  # sosfilt wants it writable
    return _sig.hilbert(_sig.sosfiltfilt(sos, np.asarray(x, dtype=float) - np.mean(x)))


@functools.lru_cache(maxsize=64)
def _bandpass_sos(lo: float, hi: float, fs: float) -> np.ndarray:
    """``butter(4, (lo, hi), "bandpass", fs=fs, output="sos")``, designed once per band and rate (the
    calibration asks for the same few bands thousands of times per record); read-only: callers copy it."""
    sos = _sig.butter(4, (lo, hi), btype="bandpass", fs=fs, output="sos")
    sos.flags.writeable = False
    return sos


def synchronous_average(
    x: np.ndarray,
    sample_rate_hz: float,
    speed_rpm: np.ndarray | float,
    samples_per_rev: int = 256,
    revs_per_cycle: int = 1,
) -> np.ndarray:
    """Time-synchronous average over whole cycles of the reference shaft.

    Parameters
    ----------
    x : numpy.ndarray
        Time signal.
    sample_rate_hz : float
        Sampling rate, Hz.
    speed_rpm : numpy.ndarray or float
        Reference shaft speed per sample or constant, rpm.
    samples_per_rev : int
        Angular samples per revolution.
    revs_per_cycle : int
        Revolutions per averaged cycle (e.g. the hunting period of a gear pair).

    Returns
    -------
    numpy.ndarray
        Shape ``(samples_per_rev * revs_per_cycle,)``: the mean over all complete cycles; components
        not synchronous with the cycle are attenuated by about ``1/sqrt(n_cycles)``.
    """
    _, xa = resample_to_angle(x, sample_rate_hz, speed_rpm, samples_per_rev)
    n = samples_per_rev * revs_per_cycle
    n_cycles = xa.size // n
    if n_cycles < 1:
        raise ValueError(f"x: shorter than one cycle of {revs_per_cycle} revolution(s)")
    return xa[: n_cycles * n].reshape(n_cycles, n).mean(axis=0)


def rms(x: np.ndarray, axis: int = 0) -> np.ndarray:
    """Root mean square (not mean-removed), along ``axis``."""
    x = np.asarray(x, dtype=float)
    return np.sqrt(np.mean(x * x, axis=axis))
