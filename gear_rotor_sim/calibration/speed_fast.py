"""A speed fluctuation faster than the tracker's first angle follows (issue 11; docs/calibration.md Sec. 2
"Speed check", varying speed; history Sec. 8.55).

The phase-demodulation passes of :func:`~gear_rotor_sim.calibration.speed_tracking.track_speed` converge
on any fluctuation their kernel passes (each pass removes ``H(f)`` of the angle still missing, ``H(5 Hz)
= 0.7`` at 3000 rpm), but only from a first angle close enough that a mesh line's phase error stays
small over the kernel's width. The first angle comes from segments of 6 revolutions of the slowest shaft
(0.2 s at 3000 rpm), which average a 5 Hz fluctuation out: with 1 % at 5 Hz the input angle swings
+-0.1 rad and the mesh fundamental's phase (order 29) +-2.9 rad, so the kernel's mean of
``exp(i beta sin(2 pi f t))`` is ``J0(beta)`` (-0.22) with a phase that says nothing, the passes stall
and the record reads as constant speed (Sec. 8.49).

:func:`fast_track` therefore tries, from the first track's angle, :data:`FAST_PASSES` wide passes:

1. each mesh line ``K`` of each channel is shifted to zero frequency along the current angle and
   low-passed by a Gaussian whose -3 dB point is :data:`FAST_BAND_SLOW` of the slowest shaft's rate (20 Hz
   at 3000 rpm): wide enough for the phasor of a fluctuation of a few Hz (Carson: ``(beta + 1) f``), so
   its unwrapped phase ``psi_K(t)`` follows the fluctuation; a line is used when its phase noise, from
   the demodulated signal's white level (median over ``2 f_3 .. 0.4 f_mesh``) and its mean magnitude, is
   below :data:`~gear_rotor_sim.calibration.speed_tracking.MAX_PHASE_SIGMA`;
2. the lines' ``psi_K / K`` are combined with weights ``K^2 / sigma_psi^2`` (as the fine passes) and
   the combined correction is low-passed by the tracking kernel itself before it is added: a linear
   operation on an unwrapped angle, so the shaft-order sidebands the wide band let in (a fault's) are
   removed as the fine passes remove them, and the fixed point stays the fine passes';

then the fine passes of ``track_speed`` from that angle. The new track replaces the first one only when
its coherent mesh power ``P = sum_{K,c} |mean x_c exp(-i K theta)|^2 / var(x_c)`` exceeds the first
one's by the factor :data:`FAST_MIN_GAIN`: a record at constant speed, or with a slow fluctuation the
first track follows, gains nothing (the power ratio is printed by ``benchmarks/speed_track_error.py``)
and keeps its first track bit for bit, so its decision and report are unchanged.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from gear_rotor_sim.calibration.speed_estimate import estimate_speed
from gear_rotor_sim.calibration.speed_tracking import (
    ITERATIONS,
    KERNEL_SLOW_PERIODS,
    SpeedTrack,
    _fine_passes,
    _line_orders,
    _line_phases,
    _track,
    smooth,
)

#: -3 dB point of the wide passes' kernel, in units of the slowest shaft's rate
FAST_BAND_SLOW = 0.7
#: wide passes before the fine ones
FAST_PASSES = 2
#: coherent mesh power the new track must add (ratio) to replace the first one
FAST_MIN_GAIN = 1.5
#: the wide passes are tried only where the first angle keeps less than this share of the lines' power
#: coherent (:func:`line_coherence`; 0.99-1.06 on tracked and constant-speed records, 0.008 with 1 % at 5 Hz)
FAST_GATE = 0.5
#: the Gaussian's sigma (s) times its -3 dB frequency (Hz)
_SIGMA_F3 = 0.1325


def coherent_power(xc: np.ndarray, theta: np.ndarray, orders: list[float]) -> float:
    """``sum_{K,c} |mean x_c exp(-i K theta)|^2 / var(x_c)`` over the lines ``orders`` and the (mean-free)
    channels ``xc``: the mesh comb's power that stays coherent along the angle ``theta``."""
    var = np.maximum(np.mean(xc * xc, axis=0), 1e-300)
    p = 0.0
    for k in orders:
        z = np.exp(-1j * k * theta) @ xc / xc.shape[0]
        p += float(np.sum(np.abs(z) ** 2 / var))
    return p


def line_coherence(
    xc: np.ndarray, fs: float, theta: np.ndarray, orders: list[float], f_in: float, f_slow: float
) -> float:
    """The coherent mesh power along ``theta`` (:func:`coherent_power`) over the power of the record within
    ``+- f_slow / 2`` of each line at the mean input rate ``f_in`` (Parseval on the one-sided spectrum):
    near 1 where the angle follows the lines, ``J0(beta)^2`` of a line whose phase swings ``+-beta``."""
    n = xc.shape[0]
    var = np.maximum(np.mean(xc * xc, axis=0), 1e-300)
    spec = np.abs(np.fft.rfft(xc, axis=0)) ** 2 / (n * n) / var
    f = np.fft.rfftfreq(n, 1.0 / fs)
    band = 0.0
    for k in orders:
        band += float(np.sum(spec[np.abs(f - k * f_in) <= 0.5 * f_slow]))
    return coherent_power(xc, theta, orders) / band if band > 0 else 1.0


def _wide_pass(
    xc: np.ndarray, fs: float, theta: np.ndarray, orders: list[float], sig_w: float, f_mesh: float
) -> np.ndarray | None:
    """One wide pass: the lines' combined angle correction (rad, mean free), None without a usable line."""
    n = xc.shape[0]
    f3 = _SIGMA_F3 / (sig_w / fs)
    freqs = np.abs(np.fft.fftfreq(n, 1.0 / fs))
    ring = (freqs >= 2.0 * f3) & (freqs <= 0.4 * f_mesh)
    if np.count_nonzero(ring) < 16:
        return None
    num = np.zeros(n)
    den = 0.0
    for k, _, psi, var_psi in _line_phases(xc, theta, orders, sig_w, ring, coherent=False):
        w = k * k / var_psi
        num += w * (psi - psi.mean()) / k
        den += w
    return num / den if den > 0 else None


def fast_track(
    data: np.ndarray, sample_rate_hz: float, tr: SpeedTrack, mesh_orders: list[float]
) -> SpeedTrack:
    """The track after the wide passes (module docstring) where it holds :data:`FAST_MIN_GAIN` times the
    coherent mesh power of ``tr``; otherwise ``tr`` itself. Tried only where ``tr``'s angle keeps less than
    :data:`FAST_GATE` of the lines' power coherent (:func:`line_coherence`).

    Parameters
    ----------
    data : numpy.ndarray
        ``(n_samples, n_channels)`` record (as given to ``track_speed``).
    sample_rate_hz : float
    tr : SpeedTrack
        ``track_speed``'s track of ``data`` (with at least one line).
    mesh_orders : list of float
        Mesh frequency of each mesh per unit input rate.

    Returns
    -------
    SpeedTrack
        ``tr``, or the new track with ``fast_pass`` True and ``fast_power_gain`` its power ratio; ``tr``
        carries the ratio too (``fast_power_gain``) when the wide passes ran.
    """
    x = np.asarray(data, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    fs = float(sample_rate_hz)
    xc = x - x.mean(axis=0)
    sig_n = tr.kernel_s * fs
    f_slow = KERNEL_SLOW_PERIODS / tr.kernel_s
    f_in = float(np.max(tr.segment_rpm)) / 60.0
    orders = _line_orders(mesh_orders, f_in, fs)
    if line_coherence(xc, fs, tr.angle_rad, orders, tr.mean_rpm / 60.0, f_slow) >= FAST_GATE:
        return tr
    sig_w = _SIGMA_F3 / (FAST_BAND_SLOW * f_slow) * fs
    theta = tr.angle_rad
    for _ in range(FAST_PASSES):
        corr = _wide_pass(xc, fs, theta, orders, sig_w, min(mesh_orders) * f_in)
        if corr is None:
            return tr
        corr = smooth(corr, sig_n).real
        theta = theta + corr - corr[0]
    fine = _fine_passes(xc, fs, theta, orders, sig_n, f_slow, ITERATIONS)
    if fine is None:
        return tr
    gain = coherent_power(xc, fine[0], orders) / max(coherent_power(xc, tr.angle_rad, orders), 1e-300)
    if not gain >= FAST_MIN_GAIN:
        return dataclasses.replace(tr, fast_power_gain=gain)
    new = _track(tr.t, fs, sig_n, tr.segment_rpm, tr.segment_t, x.shape[1], *fine)
    return dataclasses.replace(new, fast_pass=True, fast_power_gain=gain)


def _constant_track(
    x: np.ndarray, fs: float, declared_rpm: float, mesh_orders: list[float], slowest_ratio: float
) -> SpeedTrack:
    """A constant speed over the record (the whole record's mesh-line estimate, else the declared speed):
    the wide passes' first angle where no segment carried a line."""
    est = estimate_speed(x, fs, declared_rpm, mesh_orders, slowest_ratio, halves=False)
    rpm = est.measured_rpm if est.measured_rpm is not None else declared_rpm
    n = x.shape[0]
    t = np.arange(n) / fs
    f_slow = slowest_ratio * rpm / 60.0
    return SpeedTrack(
        t,
        rpm * math.pi / 30.0 * t,
        np.full(n, rpm),
        math.nan,
        math.nan,
        KERNEL_SLOW_PERIODS / f_slow,
        0,
        np.array([rpm]),
        np.array([0.5 * t[-1]]),
    )


def track_faster(
    data: np.ndarray,
    sample_rate_hz: float,
    declared_rpm: float,
    mesh_orders: list[float],
    slowest_ratio: float,
    tr: SpeedTrack | None,
) -> SpeedTrack | None:
    """``track_speed``'s track ``tr``, or the wide passes' (:func:`fast_track`) where they replace it.

    Parameters
    ----------
    data, sample_rate_hz, declared_rpm, mesh_orders, slowest_ratio
        As given to ``track_speed``.
    tr : SpeedTrack or None
        Its track; where it is None or has no line (no segment or no line followed the fluctuation) the
        wide passes start from a constant speed.

    Returns
    -------
    SpeedTrack or None
        The wide passes' track where it was accepted, else ``tr``.
    """
    x = np.asarray(data, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    if not mesh_orders or x.shape[0] < 256 or not np.all(np.isfinite(x)):
        return tr
    base = tr
    if tr is None or tr.n_lines == 0:
        base = _constant_track(x, float(sample_rate_hz), declared_rpm, mesh_orders, slowest_ratio)
    new = fast_track(x, sample_rate_hz, base, mesh_orders)
    return new if new.fast_pass else tr
