"""The input-shaft angle tracked through a record whose speed varies (issue 11; docs/calibration.md
Sec. 2 "Speed check", varying speed).

:func:`track_speed` reads the instantaneous input-shaft angle ``theta(t)`` from the record's mesh lines,
in two passes:

1. **Segments** (coarse): the mean-speed estimator of ``speed_estimate.py`` on overlapping segments of
   6 revolutions of the slowest shaft (hop half a segment; 3 or 1.5 revolutions where fewer than three
   segments carry a line: a fast change smears the longer ones, :data:`SEGMENT_SLOW_REVS`); the speeds at the
   segment centres, linearly interpolated (constant beyond the first and last centre), integrated to
   a first angle ``theta_0(t)``.
2. **Phase demodulation** (fine, :data:`ITERATIONS` times): each mesh harmonic ``K`` (orders per input
   revolution, below ``0.45 fs``) of each channel is shifted to zero frequency along the current angle,
   ``z(t) = x(t) exp(-i K theta(t))``, and low-passed by a Gaussian kernel of width ``sigma_t =``
   :data:`KERNEL_SLOW_PERIODS` periods of the slowest shaft (response ``1e-3`` at 0.8 of its rate: the
   shaft-order sidebands of a fault stay out). The unwrapped phase ``psi_K(t)`` of the filtered line,
   divided by ``K``, is the angle still missing; the lines are combined with weights
   ``K^2 / sigma_psi^2`` and added to ``theta``. A line is used when its phase noise is below
   :data:`MAX_PHASE_SIGMA` rad.

Uncertainty: a line of amplitude ``A`` in white noise of variance ``s^2`` (its level read from the
periodogram of the demodulated signal between 1.5 kernel bandwidths and 0.8 of the slowest shaft's
rate) keeps after the kernel ``h`` a complex noise ``s^2 sum(h^2)`` against the phasor ``|A| / 2``, so
``sigma_psi^2 = s^2 sum(h^2) / (2 |A / 2|^2)``; the combined angle's noise sigma is ``1 / sqrt(sum w)``
and the speed's ``sigma_theta / (sqrt(2) sigma_t)`` (the derivative of noise smoothed by the
Gaussian). Each line is the mesh excitation's phase seen through its own transfer path, whose group
delay ``tau`` shifts its angle by ``-tau dw(t)`` (``dw`` the speed change; about 1 ms on the bearing
forces and 0.06 ms on the DTE of ``lumped_gearbox`` at 3000 rpm): each line's delay against the
combination is regressed on ``dw``, and their weighted spread ``s_tau`` adds ``s_tau rms(dw)`` to the
angle's sigma and ``s_tau rms(dw')`` to the speed's (the common delay of all lines is not observable);
what the lines disagree beyond that scales the noise sigma (Birge ratio). Each channel's delay (its lines'
weighted mean) is returned for the resampling (``order_tracking.resample_channels``).

What it cannot follow: a speed change faster than the kernel (its -3 dB point is
``0.13 / sigma_t``: 5 Hz at 3000 rpm, 14 Hz at 8000 rpm) is averaged out, and a record without
mesh lines (a bearing rig) is not tracked.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.signal import fftconvolve

from gear_rotor_sim.calibration.speed_estimate import MAX_LINE_FRACTION, estimate_speed

#: segment lengths of the coarse pass, in revolutions of the slowest shaft (the next one where fewer
#: than three segments of the last carry a line)
SEGMENT_SLOW_REVS = (6.0, 3.0, 1.5)
#: Gaussian kernel's sigma in periods of the slowest shaft (response 1e-3 at 0.8 of its rate)
KERNEL_SLOW_PERIODS = 0.74
#: phase-demodulation passes
ITERATIONS = 3
#: further passes where a record is resampled (:func:`refine_track`)
REFINE_PASSES = 12
#: largest phase noise (rad) of a line used by the demodulation
MAX_PHASE_SIGMA = 0.2
#: the speed's smoothing kernel, relative to the demodulation kernel
SPEED_SMOOTH = 0.25
#: the speed search of the coarse segments, relative to the declared speed
SEGMENT_SEARCH = 0.15


@dataclass(frozen=True)
class SpeedTrack:
    """Input-shaft angle and speed through the record.

    Attributes
    ----------
    t : numpy.ndarray
        Sample times from the record's first sample, s.
    angle_rad : numpy.ndarray
        Input-shaft angle at each sample (0 at the first), rad.
    speed_rpm : numpy.ndarray
        Instantaneous speed (the angle's derivative, smoothed by the kernel), rpm.
    sigma_angle_rad : float
        One-sigma noise of ``angle_rad`` (module docstring).
    sigma_speed_rpm : float
        One-sigma noise of ``speed_rpm``.
    kernel_s : float
        Sigma of the Gaussian kernel, s.
    n_lines : int
        Lines (channel x harmonic) combined in the last pass.
    segment_rpm : numpy.ndarray
        Speeds of the coarse segments (rpm), at ``segment_t``.
    segment_t : numpy.ndarray
        Centres of the coarse segments, s.
    birge_ratio : float
        Rms disagreement of the lines' angle corrections over their noise sigmas, their delays taken
        out (>= 1; the noise sigma is scaled by it).
    delay_spread_s : float
        Weighted rms of the lines' delays against their combination (module docstring).
    channel_delay_s : numpy.ndarray or None
        Each channel's delay against the combination (its lines' weighted mean, s; 0 for a channel
        without a usable line): channel ``c``'s lines follow ``angle(t) - delay_c dw(t)``.
    fast_pass : bool
        Whether the angle comes from the wide passes of ``speed_fast.fast_track`` (a fluctuation faster
        than the first angle follows).
    fast_power_gain : float
        The wide passes' coherent mesh power over the first track's (NaN: not tried).
    order_locked : AngleModulation or None
        An angle modulation at a shaft's own order added to the angle
        (``speed_order_locked.with_angle_modulation``).
    """

    t: np.ndarray
    angle_rad: np.ndarray
    speed_rpm: np.ndarray
    sigma_angle_rad: float
    sigma_speed_rpm: float
    kernel_s: float
    n_lines: int
    segment_rpm: np.ndarray
    segment_t: np.ndarray
    birge_ratio: float = 1.0
    delay_spread_s: float = 0.0
    channel_delay_s: np.ndarray | None = None
    fast_pass: bool = False
    fast_power_gain: float = math.nan
    order_locked: Any = None

    @property
    def mean_rpm(self) -> float:
        """Mean speed over the record: the angle turned over the time taken."""
        return float((self.angle_rad[-1] - self.angle_rad[0]) / (self.t[-1] - self.t[0]) * 30.0 / math.pi)

    def deviation_rad(self) -> np.ndarray:
        """The angle minus its least-squares straight line (a constant speed): zero for a constant speed."""
        c = np.polyfit(self.t, self.angle_rad, 1)
        return self.angle_rad - np.polyval(c, self.t)


def _segments(
    x: np.ndarray, fs: float, declared_rpm: float, mesh_orders: list[float], slowest_ratio: float, revs: float
) -> tuple[np.ndarray, np.ndarray]:
    """Centres (s) and speeds (rpm) of the overlapping coarse segments of ``revs`` slowest-shaft
    revolutions that carry an estimate."""
    n = x.shape[0]
    f_slow = slowest_ratio * declared_rpm / 60.0
    m = min(n, max(64, round(revs / f_slow * fs)))
    hop = max(1, m // 2)
    starts = list(range(0, n - m + 1, hop))
    if starts[-1] != n - m:
        starts.append(n - m)
    tc, sp = [], []
    for s in starts:
        e = estimate_speed(
            x[s : s + m], fs, declared_rpm, mesh_orders, slowest_ratio, search=SEGMENT_SEARCH, halves=False
        )
        if e.measured_rpm is not None:
            tc.append((s + 0.5 * (m - 1)) / fs)
            sp.append(e.measured_rpm)
    return np.array(tc), np.array(sp)


def _line_orders(mesh_orders: list[float], f_hi: float, fs: float) -> list[float]:
    """Mesh harmonics (orders per input revolution) below ``MAX_LINE_FRACTION fs`` at input rate ``f_hi``."""
    out: set[float] = set()
    for z in mesh_orders:
        m = 1
        while m * z * f_hi < MAX_LINE_FRACTION * fs:
            out.add(m * z)
            m += 1
    return sorted(out)


def _kernels(sig_n: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Gaussian kernel ``g(k)`` (sigma ``sig_n`` samples, cut at 4 sigma), ``-k g(k)``, ``k^2 g(k)``."""
    k = np.arange(-math.ceil(4.0 * sig_n), math.ceil(4.0 * sig_n) + 1, dtype=float)
    g = np.exp(-0.5 * (k / sig_n) ** 2)
    return g, -k * g, k * k * g


def smooth(z: np.ndarray, sig_n: float) -> np.ndarray:
    """Gaussian-weighted local linear regression of ``z`` (sigma ``sig_n`` samples): the Gaussian
    smoother inside the record, and no lag at its ends (the local line's value, not a one-sided mean,
    so a phase that still ramps there is not pulled towards the inside)."""
    g, h1, h2 = _kernels(sig_n)
    if g.size > z.size:
        g, h1, h2 = _kernels(z.size / 8.0)
    one = np.ones(z.size)
    s0, s1, s2 = (fftconvolve(one, k, mode="same") for k in (g, h1, h2))
    t0, t1 = fftconvolve(z, g, mode="same"), fftconvolve(z, h1, mode="same")
    return (s2 * t0 - s1 * t1) / (s0 * s2 - s1 * s1)


def _line_phases(
    xc: np.ndarray,
    theta: np.ndarray,
    orders: list[float],
    sig_n: float,
    ring: np.ndarray,
    coherent: bool = True,
) -> Iterator[tuple[float, int, np.ndarray, float]]:
    """Each usable line's order ``K``, channel, unwrapped phase (rad) and phase variance: the line shifted to
    zero frequency along ``theta`` and low-passed by the Gaussian of ``sig_n`` samples; its white noise read
    over the frequencies ``ring`` of the demodulated signal, its amplitude the filtered line's mean
    (``coherent``) or its mean magnitude (the wide passes of ``speed_fast.py``: a phase that still swings)."""
    n = xc.shape[0]
    h2 = 1.0 / (2.0 * math.sqrt(math.pi) * sig_n)  # sum of the squared Gaussian kernel (unit sum)
    for k in orders:
        ph = np.exp(-1j * k * theta)
        for c in range(xc.shape[1]):
            z = xc[:, c] * ph
            zf = smooth(z, sig_n)
            a = abs(np.mean(zf)) if coherent else float(np.mean(np.abs(zf)))
            if not a > 0:
                continue
            s2 = float(np.median(np.abs(np.fft.fft(z)[ring]) ** 2) / n) / math.log(2.0)
            var_psi = s2 * h2 / (2.0 * a * a)
            if not var_psi < MAX_PHASE_SIGMA**2:
                continue
            yield k, c, np.unwrap(np.angle(zf)), var_psi


def _demodulate(
    xc: np.ndarray, fs: float, theta: np.ndarray, orders: list[float], sig_n: float, f_slow: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One phase-demodulation pass: each usable line's angle correction (rad, lines x samples, mean
    free), its weight ``K^2 / sigma_psi^2`` and its channel (empty when no line is usable)."""
    n = xc.shape[0]
    f3 = 0.1325 / (sig_n / fs)  # the kernel's -3 dB frequency (Hz)
    freqs = np.fft.fftfreq(n, 1.0 / fs)
    ring = (np.abs(freqs) >= 1.5 * f3) & (np.abs(freqs) <= 0.8 * f_slow)
    dev: list[np.ndarray] = []
    wts: list[float] = []
    chans: list[int] = []
    if np.count_nonzero(ring) < 8:
        return np.zeros((0, n)), np.zeros(0), np.zeros(0, dtype=int)
    for k, c, psi, var_psi in _line_phases(xc, theta, orders, sig_n, ring):
        dev.append((psi - psi.mean()) / k)
        wts.append(k * k / var_psi)
        chans.append(c)
    return np.array(dev).reshape(len(dev), n), np.array(wts), np.array(chans, dtype=int)


def _uncertainty(
    d: np.ndarray, w: np.ndarray, theta: np.ndarray, fs: float, sig_n: float
) -> tuple[float, float, float, float, np.ndarray]:
    """Angle sigma (rad), speed sigma (rad/s), Birge ratio, delay spread (s) and each line's delay (s)
    of the last pass's lines ``d`` (weights ``w``) about the angle ``theta`` they were combined into
    (module docstring)."""
    edge = min(int(2 * sig_n), theta.size // 4)
    inner = slice(edge, theta.size - edge)
    mean = w @ d / w.sum()
    dw = np.gradient(theta, 1.0 / fs)
    dw = smooth(dw - dw[inner].mean(), sig_n).real
    acc = np.gradient(dw, 1.0 / fs)
    r = d - mean
    # each line's delay against the combination: its disagreement regressed on the speed change
    den = float(np.sum(dw[inner] ** 2))
    tau = -(r[:, inner] @ dw[inner]) / den if den > 0 else np.zeros(w.size)
    spread = math.sqrt(float(w @ tau**2 / w.sum()))
    birge = 1.0
    if w.size > 1:
        rest = r + tau[:, None] * dw[None, :]
        birge = max(1.0, math.sqrt(float(np.mean((w @ rest**2)[inner])) / (w.size - 1)))
    sig_noise = birge / math.sqrt(float(w.sum()))
    rms_dw = math.sqrt(float(np.mean(dw[inner] ** 2)))
    rms_acc = math.sqrt(float(np.mean(acc[inner] ** 2)))
    sig_angle = math.hypot(sig_noise, spread * rms_dw)
    sig_speed = math.hypot(sig_noise / (math.sqrt(2.0) * sig_n / fs), spread * rms_acc)
    return sig_angle, sig_speed, birge, spread, tau


def track_speed(
    data: np.ndarray,
    sample_rate_hz: float,
    declared_rpm: float,
    mesh_orders: list[float],
    slowest_ratio: float = 1.0,
) -> SpeedTrack | None:
    """Input-shaft angle and speed through the record (module docstring).

    Parameters
    ----------
    data : numpy.ndarray
        ``(n_samples, n_channels)`` record.
    sample_rate_hz : float
    declared_rpm : float
        Declared input speed (the segments search ``+- SEGMENT_SEARCH`` about it).
    mesh_orders : list of float
        Mesh frequency of each mesh per unit input rate (``speed_estimate.mesh_orders_per_input``).
    slowest_ratio : float
        Slowest shaft's speed per unit input speed.

    Returns
    -------
    SpeedTrack or None
        None when fewer than three segments carry a usable mesh line; the coarse track alone
        (``n_lines`` 0, sigmas NaN) when no line survives the demodulation.
    """
    x = np.asarray(data, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    fs = float(sample_rate_hz)
    n = x.shape[0]
    if not mesh_orders or n < 256 or not np.all(np.isfinite(x)):
        return None
    for revs in SEGMENT_SLOW_REVS:
        # shorter segments where a fast change smears the lines of the longer ones
        tc, sp = _segments(x, fs, declared_rpm, mesh_orders, slowest_ratio, revs)
        if tc.size >= 3:
            break
    else:
        return None
    t = np.arange(n) / fs
    w = np.interp(t, tc, sp) * math.pi / 30.0
    theta = np.concatenate(([0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) / fs)))
    f_slow = slowest_ratio * float(np.mean(sp)) / 60.0
    sig_n = KERNEL_SLOW_PERIODS / f_slow * fs
    orders = _line_orders(mesh_orders, float(np.max(sp)) / 60.0, fs)
    xc = x - x.mean(axis=0)
    fine = _fine_passes(xc, fs, theta, orders, sig_n, f_slow, ITERATIONS)
    if fine is None:
        speed = w * 30.0 / math.pi
        return SpeedTrack(t, theta, speed, math.nan, math.nan, sig_n / fs, 0, sp, tc)
    return _track(t, fs, sig_n, sp, tc, x.shape[1], *fine)


def _fine_passes(
    xc: np.ndarray,
    fs: float,
    theta: np.ndarray,
    orders: list[float],
    sig_n: float,
    f_slow: float,
    passes: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """``passes`` phase-demodulation passes from ``theta``. Returns (theta, the last pass's line
    corrections, weights, channels), None when no line is usable."""
    for _ in range(passes):
        d, wl, ch = _demodulate(xc, fs, theta, orders, sig_n, f_slow)
        if wl.size == 0:
            return None
        corr = wl @ d / wl.sum()
        theta = theta + corr - corr[0]
    return theta, d, wl, ch


def _track(
    t: np.ndarray,
    fs: float,
    sig_n: float,
    sp: np.ndarray,
    tc: np.ndarray,
    n_channels: int,
    theta: np.ndarray,
    d: np.ndarray,
    wl: np.ndarray,
    ch: np.ndarray,
) -> SpeedTrack:
    """The :class:`SpeedTrack` of the last pass's angle and lines (uncertainty, delays, speed)."""
    sig_theta, sig_w, birge, spread, tau = _uncertainty(d, wl, theta, fs, sig_n)
    # each channel's delay against the combination: its lines' weighted mean
    delays = np.zeros(n_channels)
    for c in range(n_channels):
        sel = ch == c
        if np.any(sel):
            delays[c] = float(wl[sel] @ tau[sel] / wl[sel].sum())
    speed = speed_of_angle(theta, fs, sig_n)
    return SpeedTrack(
        t,
        theta - theta[0],
        speed,
        sig_theta,
        sig_w * 30.0 / math.pi,
        sig_n / fs,
        int(wl.size),
        sp,
        tc,
        birge,
        spread,
        delays,
    )


def speed_of_angle(theta: np.ndarray, fs: float, sig_n: float) -> np.ndarray:
    """The speed (rpm) of the angle ``theta``: its derivative, lightly smoothed (:data:`SPEED_SMOOTH` of the
    kernel of ``sig_n`` samples; the angle is already band-limited by the kernel)."""
    return smooth(np.gradient(theta, 1.0 / fs), SPEED_SMOOTH * sig_n).real * 30.0 / math.pi


def refine_track(
    data: np.ndarray, sample_rate_hz: float, tr: SpeedTrack, mesh_orders: list[float]
) -> SpeedTrack:
    """:data:`REFINE_PASSES` more phase-demodulation passes from ``tr``'s angle.

    Each pass removes ``H(f)`` of what the angle still misses at frequency ``f`` (``H`` the kernel's
    response, 0.91 at 2 Hz but 0.45 at 8 Hz and 0.17 at 12 Hz at 3000 rpm), so the harmonics of a
    fluctuation that the coarse segments put into the first angle outlive the three passes of
    :func:`track_speed`: on the 3000 rpm records fluctuating 0.5 % at 2 Hz they leave the mesh
    fundamental of the resampled bearing forces with +-8 and +-12 Hz sidebands, 10-20 times the noise in
    the envelope's 10-20 Hz bins after the speed-modulated part is removed; after 12 more passes they
    are at the constant-speed record's level (Sec. 8.49). A pass's correction does not fall below the
    lines' noise sigma (it wanders between 0.3 and 1.4 sigma from the seventh pass on), so the count is
    fixed. Used where the record is resampled (``order_tracking.check_speed_variation``: about 3.5 s
    CPU on a 2 s record at 3000 rpm); the decision itself rests on :func:`track_speed`'s three passes.
    """
    x = np.asarray(data, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    fs = float(sample_rate_hz)
    sig_n = tr.kernel_s * fs
    f_slow = KERNEL_SLOW_PERIODS / tr.kernel_s
    orders = _line_orders(mesh_orders, float(np.max(tr.segment_rpm)) / 60.0, fs)
    fine = _fine_passes(x - x.mean(axis=0), fs, tr.angle_rad, orders, sig_n, f_slow, REFINE_PASSES)
    if fine is None:
        return tr
    return _track(tr.t, fs, sig_n, tr.segment_rpm, tr.segment_t, x.shape[1], *fine)
