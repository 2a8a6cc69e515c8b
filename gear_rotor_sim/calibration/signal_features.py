"""Features of one signal, the same for the measurement and the model: the shafts and their
analysed orders, synchronous-average order coefficients (Braun 1975; McFadden 1987), the
squared-envelope spectrum (Randall & Antoni 2011) and its most prominent band, and the plain
metrics of the report: time alignment, time and spectrum errors
(moved from ``residual.py`` in session 16, unchanged).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from gear_rotor_sim.analysis.signals import amplitude_spectrum, analytic_band, resample_to_angle
from gear_rotor_sim.calibration.order_dft import revolution_coefficients


@dataclass(frozen=True)
class ShaftOrders:
    """A shaft for order analysis: name, |speed ratio| to the input shaft, orders analysed."""

    name: str
    ratio: float
    orders: np.ndarray  # int orders
    teeth: int = 0  # teeth of the shaft's (first) gear: orders k * teeth are the mesh carriers
    #: teeth of every gear on the shaft (a shaft of a multi-stage train carries one gear per stage):
    #: the multiples of each are mesh carriers
    carrier_teeth: tuple[int, ...] = ()


def shaft_orders(
    cfg: object,
    speed_rpm: float,
    sample_rate_hz: float,
    low_orders: int = 6,
    sidebands: int = 6,
    mesh_harmonics: int = 3,
) -> list[ShaftOrders]:
    """Shafts and their analysed orders: 1..low_orders and m z +- sidebands (m = 1..mesh_harmonics)."""
    from gear_rotor_sim.system import shaft_speed_ratios

    ratios = np.abs(shaft_speed_ratios(cfg))
    out = []
    for s, shaft in enumerate(cfg.shafts):
        f = ratios[s] * speed_rpm / 60.0
        kmax = int(0.42 * sample_rate_hz / f)
        orders = set(range(1, low_orders + 1))
        teeth = 0
        all_teeth: list[int] = []
        for m in cfg.meshes:
            z = (
                m.pinion_teeth
                if cfg.gear(m.pinion).node0 in _shaft_nodes(cfg, s)
                else (m.gear_teeth if cfg.gear(m.gear).node0 in _shaft_nodes(cfg, s) else None)
            )
            if z is None:
                continue
            teeth = teeth or int(z)
            all_teeth.append(int(z))
            for h in range(1, mesh_harmonics + 1):
                orders.update(range(h * z - sidebands, h * z + sidebands + 1))
        arr = np.array(sorted(o for o in orders if 1 <= o <= kmax), dtype=int)
        if arr.size:
            out.append(ShaftOrders(shaft.name, float(ratios[s]), arr, teeth, tuple(dict.fromkeys(all_teeth))))
    return out


def _shaft_nodes(cfg: object, s: int) -> range:
    off = cfg.node_offsets[s]
    return range(off, off + cfg.shafts[s].n_nodes)


def order_coefficients(
    x: np.ndarray, fs: float, shaft_hz: float, orders: np.ndarray, angle0_rev: float, exact: bool = True
) -> tuple[np.ndarray, np.ndarray, int]:
    """Synchronous-average Fourier coefficients and their noise variance.

    Parameters
    ----------
    x : numpy.ndarray
        Signal (n,).
    fs : float
        Sample rate, Hz.
    shaft_hz : float
        Shaft rotation frequency, Hz.
    orders : numpy.ndarray
        Integer orders.
    angle0_rev : float
        Absolute shaft angle of the first sample, revolutions (the phase reference).
    exact : bool
        Each revolution's Fourier integral from the samples (``order_dft.py``, no images); False:
        the record resampled to ``2^k`` points per revolution by linear interpolation (computed
        order tracking as before session 9, kept where the teeth separate:
        docs/history/calibration_sessions.md Sec. 8.18).

    Returns
    -------
    coef : complex ndarray
        ``c_k`` such that the synchronous part is ``sum_k 2 Re(c_k e^{i k theta})``... (peak/2 scaling:
        ``|c_k|`` is half the peak amplitude of order k).
    var : ndarray
        Noise variance of each coefficient (between-revolution scatter / number of revolutions).
    n_rev : int
    """
    # at the constant declared speed: each revolution's Fourier integral directly, no resampling (a
    # linear interpolation onto an angle grid folds images of the mesh harmonics onto shaft orders:
    # order_dft.py)
    if exact:
        per = revolution_coefficients(np.asarray(x, dtype=float) - np.mean(x), fs, shaft_hz, orders)
    else:
        spr = int(2 ** math.ceil(math.log2(max(fs / shaft_hz, 2 * (orders.max() + 2)))))
        _, xa = resample_to_angle(x - np.mean(x), fs, shaft_hz * 60.0, spr)
        n_res = (xa.size - 1) // spr
        per = np.fft.rfft(xa[: n_res * spr].reshape(n_res, spr), axis=1)[:, orders] / spr
    n_rev = per.shape[0]
    if n_rev < 2:
        raise ValueError(f"record shorter than 2 revolutions of a {shaft_hz:.3g} Hz shaft")
    coef = per.mean(axis=0)
    var = np.sum(np.abs(per - coef) ** 2, axis=0) / max(n_rev - 1, 1) / n_rev
    rot = np.exp(-2j * np.pi * orders * (angle0_rev % 1.0))
    return coef * rot, var, n_rev


def envelope_power_spectrum(
    analytic: np.ndarray, fs: float, f_lo: float, f_hi: float, segment_s: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """Welch-averaged power spectrum of the squared envelope ``|analytic|^2``.

    Hann segments of ``segment_s`` (shortened to an eighth of the record if needed) with 50 %
    overlap, mean removed per segment, 3-bin moving sum. Returns the frequencies in ``[f_lo, f_hi]``,
    the averaged power per bin and the number of averages (Welch 1967: about ``1.9 N / L - 0.9``
    segments for 50 %-overlapped Hann segments, times the 3 summed bins; the correlation of adjacent
    Hann bins makes the equivalent number 1.61 times smaller: ``features_envelope_noise``).
    """
    env = np.abs(analytic) ** 2
    n = len(env)
    L = int(min(segment_s * fs, n))
    step = max(L // 2, 1)
    starts = np.arange(0, n - L + 1, step)
    w = np.hanning(L)
    segs = np.stack([env[s0 : s0 + L] for s0 in starts])
    segs = segs - segs.mean(axis=1, keepdims=True)
    spec = np.abs(np.fft.rfft(segs * w, axis=1)) ** 2 / (w.sum() ** 2) * 4.0
    f = np.fft.rfftfreq(L, 1.0 / fs)
    sel = (f >= f_lo) & (f <= f_hi)
    k_eff = max(1.0, 1.9 * n / L - 0.9) if starts.size > 1 else 1.0
    # 3-bin moving sum: a line smeared by random slip keeps its power (McFadden & Smith 1984); counted
    # as 3 independent bins (adjacent Hann bins are correlated: 3 / 1.61 would be exact, applied by
    # ``Comparison`` with ``ResidualSettings.envelope_noise_corrected``)
    avg = spec.mean(axis=0)
    avg = np.convolve(avg, np.ones(3), mode="same")
    return f[sel], avg[sel], 3.0 * k_eff


def prominent_envelope_band(
    x: np.ndarray,
    fs: float,
    f_lo: float,
    f_hi: float,
    segment_s: float,
    min_hz: float = 500.0,
    with_score: bool = False,
) -> Any:
    """One-octave band whose squared-envelope spectrum has the most prominent line.

    Candidate bands ``[lo, 2 lo]`` with ``lo`` from ``min_hz`` in steps of sqrt(2) up to ``0.45 fs``;
    the score is the largest envelope-spectrum bin in ``[f_lo, f_hi]`` over the median bin (the
    criterion of the protrugram, Barszcz & Jablonski 2011: periodic impacts give lines, random
    impulsiveness does not). Applied to the residual measurement - healthy model. Returns the band,
    or ``(band, score)`` with ``with_score``.
    """
    best = (-np.inf, (0.25 * fs, 0.45 * fs))
    lo = min_hz
    while lo * 1.5 <= 0.45 * fs:
        band = (lo, min(2 * lo, 0.45 * fs))
        _, p, _ = envelope_power_spectrum(analytic_band(x, fs, band), fs, f_lo, f_hi, segment_s)
        med = float(np.median(p))
        score = float(np.max(p)) / med if med > 0 else 0.0
        if score > best[0]:
            best = (score, band)
        lo *= math.sqrt(2.0)
    return (best[1], best[0]) if with_score else best[1]


def align_time(y: np.ndarray, m: np.ndarray, max_lag: int) -> tuple[int, float]:
    """Integer lag (samples) and gain that best map ``m`` onto ``y`` (cross-correlation, LS gain)."""
    y0 = y - y.mean()
    m0 = m - m.mean()
    if not np.any(m0):
        return 0, 1.0
    n = len(y0)
    nfft = 1 << math.ceil(math.log2(2 * n))
    xc = np.fft.irfft(np.fft.rfft(y0, nfft) * np.conj(np.fft.rfft(m0, nfft)), nfft)
    lags = np.concatenate([np.arange(0, max_lag + 1), np.arange(-max_lag, 0)])
    vals = np.concatenate([xc[: max_lag + 1], xc[nfft - max_lag :]])
    lag = int(lags[int(np.argmax(vals))])
    ms = np.roll(m0, lag)
    g = float(np.dot(y0, ms) / np.dot(ms, ms))
    return lag, g


def time_and_spectrum_errors(y: np.ndarray, m: np.ndarray, fs: float, max_lag: int) -> dict[str, float]:
    """Relative RMS of the aligned time residual and relative amplitude-spectrum error."""
    lag, g = align_time(y, m, max_lag)
    y0 = y - y.mean()
    r = y0 - g * np.roll(m - m.mean(), lag)
    sy = amplitude_spectrum(y0, fs).amplitude
    sm = amplitude_spectrum(m - m.mean(), fs).amplitude
    ny = float(np.sqrt(np.sum(y0**2)))
    return {
        "time": float(np.sqrt(np.sum(r**2)) / ny) if ny > 0 else float("nan"),
        "spectrum": float(np.linalg.norm(sy - abs(g) * sm) / np.linalg.norm(sy))
        if np.any(sy)
        else float("nan"),
    }


def residual_spectrum(
    y: np.ndarray, m: np.ndarray, fs: float, gain: float, max_lag: int
) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude spectrum of the aligned time residual ``y - g m``."""
    lag, _ = align_time(y, m, max_lag)
    r = (y - y.mean()) - gain * np.roll(m - m.mean(), lag)
    s = amplitude_spectrum(r, fs)
    return s.axis, s.amplitude
