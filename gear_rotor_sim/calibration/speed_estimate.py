"""The input-shaft speed read from the record itself: the mesh line and its harmonics (issue 11).

Every synchronous feature of the calibration (order coefficients of the time-synchronous average,
the non-synchronous envelope, the model run itself) is computed at the declared speed. A declared
speed that is not the true one (an induction motor's slip, a tachometer's error, a sample clock
off by a percent) smears the synchronous average: the phase of order ``K`` drifts by
``2 pi K eps n_rev`` over ``n_rev`` revolutions at a relative speed error ``eps``, so at 3000 rpm
over 2 s (100 revolutions, mesh orders up to 93) the mesh comb is lost from ``eps`` of about
``1e-4`` on (docs/calibration.md Sec. 2 "Speed check"; docs/history/calibration_sessions.md Sec. 8.42).

Method (:func:`estimate_speed`):

1. **Coarse search**: the harmonic sum of the mesh comb (every mesh of the rig, harmonics ``m = 1, 2,
   ...`` below ``0.45 fs``) over input speeds within ``+- search`` of the declared one, each channel's
   Hann periodogram (zero-padded 4x) divided by its median level; the speed with the largest sum.
2. **Fine estimate per line**: for each channel and harmonic whose line stands ``min_snr`` above its
   local noise (median periodogram within ``+- 0.4`` of the slowest shaft's rate, the main lobe left
   out), the frequency maximising the Hann-windowed DTFT power (Newton steps on its derivative within
   one bin: the interpolated peak), divided by the harmonic's speed ratio.
3. **Combination and uncertainty**: the inverse-variance mean of the lines. A line's variance is the
   Cramer-Rao bound of a sinusoid's frequency in white noise (Rife & Boorstyn 1974),
   ``var(f) = 3 / (pi^2 SNR N T^2)`` with ``SNR = A^2 / sigma^2``; with the Hann periodogram's line
   power ``P`` over the noise mean ``P_n`` this is ``3 / (2 pi^2 (P / P_n) T^2)`` (Hann's main lobe:
   ``A^2 / sigma^2 = 6 (P / P_n) / N``), doubled for the Hann window's efficiency (its scatter
   measured in ``test/test_calibration_speed_estimate.py``). The combined sigma is scaled by the Birge
   ratio ``sqrt(chi2 / (n - 1))`` when the lines disagree beyond their own uncertainties (interference,
   coloured noise: a real record's lines are never pure tones).
4. **Constancy**: the same fine estimate on each half of the record; their difference and its sigma
   are reported (a speed that drifts over the record is not one speed; see :class:`SpeedEstimate`).

Assumptions: one constant speed over the record (the halves test it); a gear record whose channels
carry the mesh line (a rig without a mesh, such as the CWRU bearing rig, gets no estimate:
:func:`mesh_orders_per_input` is empty); the sample clock is right (a clock off by ``eps`` reads as a
speed off by ``eps``: the lines cannot tell the two apart).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

#: highest line frequency used, as a fraction of the sample rate (below an anti-aliasing filter's edge)
MAX_LINE_FRACTION = 0.45
#: a line is used by the fine estimate when its periodogram peak stands this far above the local noise
MIN_LINE_SNR = 100.0
#: factor on the Cramer-Rao variance for the Hann window (measured: the estimator's scatter over
#: noise realisations of an analytic comb, test_calibration_speed_estimate.py)
HANN_VARIANCE_FACTOR = 2.0


@dataclass(frozen=True)
class SpeedEstimate:
    """Input-shaft speed read from the record's mesh lines.

    Attributes
    ----------
    declared_rpm : float
        Speed declared by the record's description.
    measured_rpm : float or None
        Estimate (rpm); None when the record carries no usable mesh line (``reason`` says why).
    sigma_rpm : float
        One-sigma uncertainty of the estimate (Cramer-Rao bound of the lines, Birge-scaled).
    n_lines : int
        Lines (channel x harmonic) combined.
    birge_ratio : float
        ``sqrt(chi2 / (n - 1))`` of the lines about their mean (1 when a single line).
    halves_rpm : tuple of float, optional
        Estimates on the first and second half of the record.
    halves_sigma_rpm : float
        Uncertainty of the halves' difference.
    reason : str
        Why there is no estimate ("" when there is one).
    """

    declared_rpm: float
    measured_rpm: float | None
    sigma_rpm: float
    n_lines: int
    birge_ratio: float = 1.0
    halves_rpm: tuple[float, float] | None = None
    halves_sigma_rpm: float = math.nan
    reason: str = ""

    @property
    def z_score(self) -> float:
        """``(measured - declared) / sigma`` (NaN without an estimate)."""
        if self.measured_rpm is None or not self.sigma_rpm > 0:
            return math.nan
        return (self.measured_rpm - self.declared_rpm) / self.sigma_rpm

    @property
    def drift_z(self) -> float:
        """Difference of the halves' estimates over its sigma (NaN without them)."""
        if self.halves_rpm is None or not self.halves_sigma_rpm > 0:
            return math.nan
        return (self.halves_rpm[1] - self.halves_rpm[0]) / self.halves_sigma_rpm

    def as_dict(self) -> dict[str, Any]:
        return {
            "declared_rpm": self.declared_rpm,
            "measured_rpm": self.measured_rpm,
            "sigma_rpm": self.sigma_rpm,
            "n_lines": self.n_lines,
            "birge_ratio": self.birge_ratio,
            "halves_rpm": list(self.halves_rpm) if self.halves_rpm is not None else None,
            "halves_sigma_rpm": self.halves_sigma_rpm,
            "reason": self.reason,
        }


def mesh_orders_per_input(cfg: Any) -> list[float]:
    """Mesh frequency of each mesh of ``cfg`` per unit input-shaft rate (``z_pinion x`` the pinion
    shaft's speed ratio); empty for a rig without a mesh."""
    from gear_rotor_sim.system import shaft_speed_ratios

    meshes = list(getattr(cfg, "meshes", ()))
    if not meshes:
        return []
    ratios = [abs(float(r)) for r in shaft_speed_ratios(cfg)]
    return [m.pinion_teeth * ratios[cfg.shaft_of_node(cfg.gear(m.pinion).node0)] for m in meshes]


def slowest_shaft_ratio(cfg: Any) -> float:
    """Smallest shaft speed per unit input speed of ``cfg`` (1 for a single shaft)."""
    from gear_rotor_sim.system import shaft_speed_ratios

    return float(min(abs(float(r)) for r in shaft_speed_ratios(cfg)))


def _line_orders(mesh_orders: list[float], f_max_in: float, fs: float) -> np.ndarray:
    """Orders (per input-shaft rate) of every mesh harmonic below ``MAX_LINE_FRACTION fs`` at the
    highest input rate searched, ``f_max_in`` (Hz); at least each mesh's fundamental."""
    out: list[float] = []
    for z in mesh_orders:
        m = 1
        while m == 1 or m * z * f_max_in < MAX_LINE_FRACTION * fs:
            out.append(m * z)
            m += 1
    return np.array(sorted(set(out)))


def _periodograms(xc: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Hann periodograms of the mean-free channels ``xc``, zero-padded 4x (normalised so that white
    noise of variance ``s^2`` reads ``s^2``), and their frequency axis."""
    n = xc.shape[0]
    nfft = 1 << math.ceil(math.log2(4 * n))
    w = np.hanning(n)
    spec = np.abs(np.fft.rfft(xc * w[:, None], nfft, axis=0)) ** 2 / np.sum(w**2)
    return spec, np.fft.rfftfreq(nfft, 1.0 / fs)


def _coarse(
    x: np.ndarray, fs: float, orders: np.ndarray, f_lo: float, f_hi: float
) -> tuple[float, np.ndarray, np.ndarray]:
    """Input rate (Hz) maximising the harmonic sum of the normalised periodograms over ``orders``;
    the periodograms and their frequency axis are returned for the local noise levels."""
    n = x.shape[0]
    spec, freqs = _periodograms(x - x.mean(axis=0), fs)
    nfft = 2 * (spec.shape[0] - 1)
    band = freqs < MAX_LINE_FRACTION * fs
    floor = np.median(spec[band], axis=0)
    norm = spec / np.where(floor > 0, floor, np.inf)
    # grid step: the highest line moves a quarter of the unpadded bin between grid points
    step = 0.25 * (fs / n) / float(orders.max())
    grid = np.arange(f_lo, f_hi + step, step)
    idx = np.rint(np.outer(grid, orders) * nfft / fs).astype(int)
    idx = np.clip(idx, 0, norm.shape[0] - 1)
    score = norm[idx].sum(axis=(1, 2))
    return float(grid[int(np.argmax(score))]), spec, freqs


def _peak(y: np.ndarray, fs: float, f0: float, half_width: float, iterations: int = 6) -> tuple[float, float]:
    """Frequency (Hz) within ``f0 +- half_width`` maximising ``|sum y_n exp(-2 pi i f n / fs)|^2`` and
    that power: Newton steps on the power's derivative from ``f0`` (the DTFT and its first two
    derivatives in ``f`` share one complex exponential), each step bounded to the interval."""
    n = np.arange(y.shape[0], dtype=float)
    s = 2.0 * np.pi * n / fs
    f = f0
    for _ in range(iterations):
        e = y * np.exp(-1j * s * f)
        x0 = e.sum()
        x1 = (-1j * s * e).sum()
        x2 = (-(s**2) * e).sum()
        d1 = 2.0 * float(np.real(np.conj(x0) * x1))
        d2 = 2.0 * float(abs(x1) ** 2 + np.real(np.conj(x0) * x2))
        if d2 >= 0.0:
            # not in the main lobe's concave part: step towards the rising side
            step = math.copysign(0.25 * half_width, d1)
        else:
            step = -d1 / d2
        f_new = min(max(f + step, f0 - half_width), f0 + half_width)
        if abs(f_new - f) < 1e-9 * fs / y.shape[0]:
            f = f_new
            break
        f = f_new
    e = y * np.exp(-1j * s * f)
    return f, float(abs(e.sum()) ** 2)


def _fine(
    x: np.ndarray,
    fs: float,
    orders: np.ndarray,
    f_in: float,
    f_slow: float,
    spec: np.ndarray | None = None,
    freqs: np.ndarray | None = None,
) -> tuple[float, float, int, float] | None:
    """Interpolated peaks of the lines near ``orders x f_in``: (rate Hz, sigma Hz, lines, Birge
    ratio) or None if no line stands ``MIN_LINE_SNR`` above its local noise."""
    n, n_ch = x.shape
    t_rec = n / fs
    w = np.hanning(n)
    xc = x - x.mean(axis=0)
    if spec is None or freqs is None:
        spec, freqs = _periodograms(xc, fs)
    bin_hz = fs / n
    # the noise ring: within +-0.4 of the slowest shaft's rate (no shaft line) but at least 8 bins wide
    # beyond the main lobe (short records: 0.3 s at 3000 rpm has 3.3 Hz bins)
    half = max(0.4 * f_slow, 8.0 * bin_hz)
    est: list[float] = []
    var: list[float] = []
    for k in orders:
        f0 = float(k * f_in)
        if f0 >= MAX_LINE_FRACTION * fs:
            continue
        near = (np.abs(freqs - f0) <= half) & (np.abs(freqs - f0) > 3.0 * bin_hz)
        if np.count_nonzero(near) < 8:
            continue
        for c in range(n_ch):
            noise = float(np.median(spec[near, c])) / math.log(2.0)
            if not noise > 0:
                continue
            f_pk, p_pk = _peak(xc[:, c] * w, fs, f0, bin_hz)
            snr = p_pk / np.sum(w**2) / noise
            if snr < MIN_LINE_SNR:
                continue
            v = HANN_VARIANCE_FACTOR * 3.0 / (2.0 * math.pi**2 * snr * t_rec**2)
            est.append(f_pk / k)
            var.append(v / k**2)
    if not est:
        return None
    e, v = np.array(est), np.array(var)
    wgt = 1.0 / v
    mean = float(np.sum(wgt * e) / np.sum(wgt))
    sigma = float(1.0 / math.sqrt(np.sum(wgt)))
    birge = 1.0
    if e.size > 1:
        birge = max(1.0, math.sqrt(float(np.sum(wgt * (e - mean) ** 2)) / (e.size - 1)))
    return mean, sigma * birge, int(e.size), birge


def estimate_speed(
    data: np.ndarray,
    sample_rate_hz: float,
    declared_rpm: float,
    mesh_orders: list[float],
    slowest_ratio: float = 1.0,
    search: float = 0.15,
    halves: bool = True,
) -> SpeedEstimate:
    """Input-shaft speed of a record from its mesh lines (module docstring).

    Parameters
    ----------
    data : numpy.ndarray
        ``(n_samples, n_channels)`` record (any units per channel: each is normalised by its own
        noise).
    sample_rate_hz : float
    declared_rpm : float
        Declared input speed; the search spans ``declared x (1 +- search)``.
    mesh_orders : list of float
        Mesh frequency of each mesh per unit input rate (:func:`mesh_orders_per_input`).
    slowest_ratio : float
        Slowest shaft's speed per unit input speed (the local-noise window is ``+- 0.4`` of its rate).
    search : float
        Relative half-width of the coarse search.
    halves : bool
        Also estimate on each half of the record (the constancy check).

    Returns
    -------
    SpeedEstimate
    """
    x = np.asarray(data, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    fs = float(sample_rate_hz)
    f_decl = declared_rpm / 60.0
    if not mesh_orders:
        return SpeedEstimate(declared_rpm, None, math.nan, 0, reason="the rig has no mesh")
    orders = _line_orders(mesh_orders, f_decl * (1.0 + search), fs)
    if x.shape[0] < 16 or not np.all(np.isfinite(x)):
        return SpeedEstimate(declared_rpm, None, math.nan, 0, reason="record too short or not finite")
    f_c, spec, freqs = _coarse(x, fs, orders, f_decl * (1.0 - search), f_decl * (1.0 + search))
    f_slow = slowest_ratio * f_c
    fine = _fine(x, fs, orders, f_c, f_slow, spec, freqs)
    if fine is None:
        return SpeedEstimate(
            declared_rpm,
            None,
            math.nan,
            0,
            reason=f"no mesh line stands {MIN_LINE_SNR:g}x above the noise within +-{100 * search:g} % "
            "of the declared speed",
        )
    f_in, sig, n_lines, birge = fine
    hv: tuple[float, float] | None = None
    hs = math.nan
    if halves:
        h = x.shape[0] // 2
        parts = [_fine(x[:h], fs, orders, f_in, f_slow), _fine(x[h : 2 * h], fs, orders, f_in, f_slow)]
        if parts[0] is not None and parts[1] is not None:
            hv = (60.0 * parts[0][0], 60.0 * parts[1][0])
            hs = 60.0 * math.hypot(parts[0][1], parts[1][1])
    return SpeedEstimate(declared_rpm, 60.0 * f_in, 60.0 * sig, n_lines, birge, hv, hs)
