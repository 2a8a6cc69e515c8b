"""A record whose speed varies, read in the angle domain (order tracking; issue 11, docs/calibration.md
Sec. 2 "Speed check", varying speed).

Every synchronous feature (order combs, mesh harmonics, sidebands, the synchronous average, the
bearing orders) assumes one speed over the record. A speed that drifts or fluctuates by ``dtheta(t)``
of input-shaft angle away from uniform rotation turns the phase of order ``K`` by ``K dtheta``: its
synchronous average keeps ``|mean exp(i K dtheta)| ~ 1 - K^2 rms(dtheta)^2 / 2`` of its amplitude.

:func:`check_speed_variation`:

1. tracks the angle (:func:`~gear_rotor_sim.calibration.speed_tracking.track_speed`);
2. **decides**: the speed varies when the rms of the angle about its straight line exceeds both
   ``K_SIGMA`` times its noise and the angle tolerance ``sqrt(2 FEATURE_LOSS) / K_max`` that keeps the
   highest order feature ``K_max = 3 z + 6`` within ``FEATURE_LOSS`` (0.1 %) of its amplitude (the
   constant-speed check's rule, ``speed_check.py``; 4.8e-4 rad for the paper's 29-tooth pinion);
3. if it varies, **resamples** every channel to uniform input-shaft angle at the record's mean speed
   (:func:`resample_to_angle`: the sample times where the tracked angle crosses a uniform grid spanning
   the record, each channel read there by a Kaiser-windowed sinc, :data:`SINC_HALF_WIDTH` samples each
   side: band-limited interpolation, flat within 1e-3 to 0.45 fs, so no content folds; each channel
   along its own path's angle, the tracked one less its lines' delay times the speed change,
   :func:`resample_channels`), so the model,
   running at the mean speed, and every feature see a constant-speed record; a line in ``issues`` names
   ``operating_point.speed_rpm`` with the range, the drift and the dominant fluctuation;
4. **refuses** (:class:`MeasurementError`) a record whose speed range exceeds :data:`MAX_RANGE` of its
   mean: beyond what resampling at one mean speed can stand for (the dynamics change with the speed).

A record whose speed does not vary is returned as it is (the same object).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from gear_rotor_sim.calibration.measurement import Measurement, MeasurementError
from gear_rotor_sim.calibration.speed_estimate import mesh_orders_per_input, slowest_shaft_ratio
from gear_rotor_sim.calibration.speed_fast import track_faster
from gear_rotor_sim.calibration.speed_order_locked import (
    order_locked_fluctuation,
    with_angle_modulation,
    without_angle_modulation,
)
from gear_rotor_sim.calibration.speed_tracking import SpeedTrack, refine_track, track_speed
from gear_rotor_sim.system import shaft_speed_ratios

#: the angle's rms about its straight line must exceed this many sigma of its noise
K_SIGMA = 5.0
#: relative loss of the highest synchronous order's amplitude allowed (as speed_check.FEATURE_LOSS)
FEATURE_LOSS = 1e-3
#: orders beyond the last mesh harmonic in the order features (``m z +- 6``, as speed_check.py)
ORDER_MARGIN = 6
#: largest speed range (max - min over the mean) that order tracking stands for
MAX_RANGE = 0.10
#: half-width (samples) of the windowed-sinc interpolation and its Kaiser beta (80 dB)
SINC_HALF_WIDTH = 32
SINC_BETA = 7.857


@dataclass
class SpeedVariation:
    """Outcome of :func:`check_speed_variation`.

    Attributes
    ----------
    track : SpeedTrack or None
        The tracked angle (None: the record has no usable mesh line).
    rms_deviation_rad : float
        Rms of the tracked angle about its straight line (edges of two kernel widths left out).
    tolerance_rad : float
        Angle tolerance of the features (module docstring).
    varies : bool
        Whether the record was resampled.
    """

    track: SpeedTrack | None
    rms_deviation_rad: float
    tolerance_rad: float
    varies: bool = False

    @property
    def limit_rad(self) -> float:
        """Largest rms deviation read as a constant speed."""
        s = self.track.sigma_angle_rad if self.track is not None else math.nan
        return max(K_SIGMA * s, self.tolerance_rad)

    def summary(self) -> dict[str, float]:
        """Range (% of the mean), drift over the record (%) and the dominant fluctuation (amplitude % and
        frequency Hz) of the tracked speed: a straight line and one sinusoid fitted together
        (:func:`drift_and_fluctuation`)."""
        tr = self.track
        assert tr is not None
        inner = _interior(tr)
        t, v = tr.t[inner], tr.speed_rpm[inner]
        mean = tr.mean_rpm
        slope, amp, f_hz = drift_and_fluctuation(t, v)
        return {
            "mean_rpm": mean,
            "range_pct": 100.0 * float(np.ptp(v)) / mean,
            "min_pct": 100.0 * (float(v.min()) / mean - 1.0),
            "max_pct": 100.0 * (float(v.max()) / mean - 1.0),
            "drift_pct": 100.0 * slope * float(tr.t[-1] - tr.t[0]) / mean,
            "fluctuation_pct": 100.0 * amp / mean,
            "fluctuation_hz": f_hz,
        }

    def describe(self) -> str:
        """The ``issues`` line: the measured variation and what was done."""
        s = self.summary()
        tr = self.track
        assert tr is not None
        return (
            f"operating_point.speed_rpm: the speed varies within the record (mesh-line phase tracking, "
            f"{tr.n_lines} lines): {s['min_pct']:+.3g} to {s['max_pct']:+.3g} % about its mean "
            f"{s['mean_rpm']:.6g} rpm (range {s['range_pct']:.3g} %, +- {tr.sigma_speed_rpm:.2g} rpm), drift "
            f"{s['drift_pct']:+.3g} % over the record, dominant fluctuation {s['fluctuation_pct']:.2g} % at "
            f"{s['fluctuation_hz']:.3g} Hz; angle {self.rms_deviation_rad:.3g} rad rms off uniform rotation "
            f"(limit {self.limit_rad:.2g}); every channel resampled to uniform shaft angle at the mean speed "
            "(order tracking) before the features"
        ) + self._order_locked_text()

    def _order_locked_text(self) -> str:
        """The order-locked part of the ``issues`` line (empty when none was read)."""
        mod = self.track.order_locked if self.track is not None else None
        if mod is None:
            return ""
        rel = mod.amplitude_rad * mod.order * mod.shaft_ratio
        f_hz = mod.order * mod.shaft_ratio * self.track.mean_rpm / 60.0
        return (
            f"; of it, an angle modulation locked to order {mod.order} of the shaft turning "
            f"{mod.shaft_ratio:.4g} x the input: {mod.amplitude_rad:.2g} rad ({100 * rel:.2g} % of the speed "
            f"at {f_hz:.3g} Hz; {mod.z:.0f} sigma, {mod.n_lines} lines' sidebands; no tracking kernel "
            f"follows it: {_ORDER_LOCKED_CAUSE.get(mod.order, _ORDER_LOCKED_CAUSE[2])}), added to the "
            "tracked angle"
        )


#: what an order-locked modulation may be, by order (the ``issues`` line)
_ORDER_LOCKED_CAUSE = {
    1: "a coupling or a torsional response at that shaft's rate",
    2: "a Cardan joint's ripple, a coupling or a torsional response at that shaft's order; every mesh "
    "harmonic reads it alike, a misaligned contact would not",
}


def drift_and_fluctuation(t: np.ndarray, v: np.ndarray) -> tuple[float, float, float]:
    """Slope (per s), amplitude and frequency (Hz) of ``v(t) ~ a + b t + c sin(2 pi f t + phi)``: ``f``
    from the Hann spectrum (zero-padded 8x) of the straight line's residual, refined on a grid of +-1 bin
    by the joint least-squares fit's residual (a straight line alone reads part of a sinusoid as a drift)."""
    tc = t - t.mean()
    c = np.polyfit(tc, v, 1)
    res = v - np.polyval(c, tc)
    n = res.size
    spec = np.abs(np.fft.rfft(res * np.hanning(n), 8 * n))
    f = np.fft.rfftfreq(8 * n, float(t[1] - t[0]))
    lo = 8  # one unpadded bin: below it a sinusoid is a drift
    if spec.size <= lo + 1:
        return float(c[0]), 0.0, 0.0
    f0 = float(f[lo + int(np.argmax(spec[lo:]))])
    best = (np.inf, float(c[0]), 0.0, f0)
    for fk in f0 + np.linspace(-1.0, 1.0, 41) / float(t[-1] - t[0]):
        if fk <= 0:
            continue
        a = np.column_stack([np.ones(n), tc, np.sin(2 * np.pi * fk * tc), np.cos(2 * np.pi * fk * tc)])
        coef, *_ = np.linalg.lstsq(a, v, rcond=None)
        r = float(np.sum((v - a @ coef) ** 2))
        if r < best[0]:
            best = (r, float(coef[1]), float(np.hypot(coef[2], coef[3])), float(fk))
    return best[1], best[2], best[3]


def _interior(tr: SpeedTrack) -> np.ndarray:
    """Samples more than two kernel widths from either end (the kernel's edges are biased)."""
    edge = 2.0 * tr.kernel_s
    inner = (tr.t >= tr.t[0] + edge) & (tr.t <= tr.t[-1] - edge)
    return inner if np.count_nonzero(inner) >= 16 else np.ones(tr.t.size, dtype=bool)


def angle_tolerance_rad(cfg: Any) -> float:
    """Rms angle deviation (rad) keeping the highest synchronous order within ``FEATURE_LOSS``."""
    z = max((m.pinion_teeth for m in getattr(cfg, "meshes", ())), default=0)
    k_max = 3 * z + ORDER_MARGIN
    return math.sqrt(2.0 * FEATURE_LOSS) / k_max if k_max > 0 else math.inf


def sinc_weights(u: np.ndarray) -> np.ndarray:
    """Kaiser-windowed sinc weights at distances ``u`` (samples, ``|u| <= SINC_HALF_WIDTH``) from the
    neighbours: the interpolation kernel of :func:`resample_to_angle` and ``fractional_delay.py``."""
    L = SINC_HALF_WIDTH
    win = np.i0(SINC_BETA * np.sqrt(np.clip(1.0 - (u / L) ** 2, 0.0, None))) / np.i0(SINC_BETA)
    return np.sinc(u) * win


def resample_to_angle(data: np.ndarray, angle_rad: np.ndarray, grid: np.ndarray | None = None) -> np.ndarray:
    """Each column of ``data`` at the instants where ``angle_rad`` (monotonic, one value per sample)
    crosses ``grid`` (default: uniform from its first to its last value, ``data.shape[0]`` points):
    Kaiser-windowed sinc interpolation, :data:`SINC_HALF_WIDTH` samples each side (ends mirrored)."""
    x = np.asarray(data, dtype=float)
    one = x.ndim == 1
    if one:
        x = x[:, None]
    n = x.shape[0]
    if grid is None:
        grid = np.linspace(angle_rad[0], angle_rad[-1], n)
    tk = np.interp(grid, angle_rad, np.arange(n, dtype=float))  # fractional sample index
    L = SINC_HALF_WIDTH
    pad = np.pad(x, ((L + 1, L + 1), (0, 0)), mode="reflect")
    i0 = np.floor(tk).astype(int)
    j = np.arange(-L + 1, L + 1)
    u = tk[:, None] - (i0[:, None] + j[None, :])  # distance to each neighbour, samples
    wts = sinc_weights(u)
    idx = i0[:, None] + j[None, :] + L + 1
    out = np.empty_like(x)
    for c in range(x.shape[1]):
        out[:, c] = np.sum(wts * pad[idx, c], axis=1)
    return out[:, 0] if one else out


def resample_channels(data: np.ndarray, tr: SpeedTrack) -> np.ndarray:
    """Every channel on the uniform grid of the tracked angle, each along its own path's angle
    ``angle - delay_c dw(t)`` (``tr.channel_delay_s``; ``dw`` the speed change): a channel whose transfer
    path delays the mesh lines is read where its own lines are synchronous."""
    x = np.asarray(data, dtype=float)
    grid = np.linspace(tr.angle_rad[0], tr.angle_rad[-1], x.shape[0])
    delays = tr.channel_delay_s if tr.channel_delay_s is not None else np.zeros(x.shape[1])
    dw = (tr.speed_rpm - tr.mean_rpm) * math.pi / 30.0
    out = np.empty_like(x)
    for c in range(x.shape[1]):
        out[:, c] = resample_to_angle(x[:, c], tr.angle_rad - delays[c] * dw, grid)
    return out


def speed_change_on_grid(tr: SpeedTrack, n: int) -> np.ndarray:
    """The relative speed change ``w / w_mean - 1`` at each of the ``n`` samples of the uniform angle grid
    of :func:`resample_channels` (the tracked speed where the tracked angle crosses each grid point):
    ``Measurement.speed_change`` of the resampled record (``speed_modulation.py``)."""
    grid = np.linspace(tr.angle_rad[0], tr.angle_rad[-1], n)
    return np.interp(grid, tr.angle_rad, tr.speed_rpm) / tr.mean_rpm - 1.0


def _refusal(measurement: Measurement, declared: float, rel_range: float) -> str:
    return (
        f"{measurement.source}: operating_point.speed_rpm: the speed varies by {100 * rel_range:.3g} % "
        f"within the record (mesh lines; declared {declared:g} rpm): beyond the {100 * MAX_RANGE:g} % that "
        "order tracking at one mean speed stands for; split the record into parts of steadier speed"
    )


def check_speed_variation(measurement: Measurement, cfg: Any) -> tuple[Measurement, SpeedVariation | None]:
    """The measurement in the angle domain where its speed varies (module docstring).

    Returns
    -------
    (Measurement, SpeedVariation or None)
        ``measurement`` itself and None for a rig without a mesh; ``measurement`` itself when the
        speed does not vary or cannot be tracked; otherwise the resampled measurement with the
        ``issues`` line.

    Raises
    ------
    MeasurementError
        The tracked speed's range exceeds ``MAX_RANGE`` of its mean.
    """
    orders = mesh_orders_per_input(cfg)
    if not orders:
        return measurement, None
    declared = measurement.operating_point.speed_rpm
    ratio = slowest_shaft_ratio(cfg)
    tr = track_speed(measurement.data, measurement.sample_rate_hz, declared, orders, ratio)
    # a fluctuation faster than the first angle follows (speed_fast.py, Sec. 8.55)
    tr = track_faster(measurement.data, measurement.sample_rate_hz, declared, orders, ratio, tr)
    tol = angle_tolerance_rad(cfg)
    if tr is None:
        return measurement, SpeedVariation(None, math.nan, tol)
    seg_range = float(np.ptp(tr.segment_rpm)) / float(np.mean(tr.segment_rpm))
    if tr.n_lines == 0:
        # no line survived the demodulation: only the segments' speeds are known
        if seg_range > MAX_RANGE:
            raise MeasurementError(_refusal(measurement, declared, seg_range))
        return measurement, SpeedVariation(None, math.nan, tol)
    # an angle modulation at a shaft's own order, which no kernel follows (speed_order_locked.py, Sec. 8.55)
    fs = measurement.sample_rate_hz
    mod = order_locked_fluctuation(measurement.data, fs, tr, orders, list(shaft_speed_ratios(cfg)), tol)
    first = tr
    inner = _interior(tr)
    # the paths' delays are regressed on the speed change the kernel follows: where that stays within its
    # limit they are noise (11.7 ms on a bearing force at 0.3 % at the gear's rate), so the channels are then
    # read along the common angle
    rms_first = float(np.sqrt(np.mean(first.deviation_rad()[inner] ** 2)))
    delays = rms_first > SpeedVariation(first, rms_first, tol).limit_rad
    if mod is not None:
        tr = with_angle_modulation(tr, mod, delays)
    rms = float(np.sqrt(np.mean(tr.deviation_rad()[inner] ** 2)))
    var = SpeedVariation(tr, rms, tol)
    if rms <= var.limit_rad:
        return measurement, var
    rng = float(np.ptp(tr.speed_rpm[inner])) / tr.mean_rpm
    if max(rng, seg_range) > MAX_RANGE:
        raise MeasurementError(_refusal(measurement, declared, max(rng, seg_range)))
    var.varies = True
    # the angle converged further before the resampling (speed_tracking.refine_track, Sec. 8.49); with an
    # order-locked part in it, so that the lines carry no shaft-order phase modulation that the kernel's
    # one-sided ends would take up
    tr = plain = var.track = refine_track(measurement.data, fs, tr, orders)
    if mod is not None:
        plain = without_angle_modulation(tr, mod)
        tr = var.track = with_angle_modulation(plain, mod, delays)
    data = resample_channels(measurement.data, tr)
    issues = [*measurement.issues, var.describe()]
    # the speed change whose response speed_modulation.py removes: an order-locked part is synchronous with
    # its shaft (the synchronous part holds its response), so it stays out of u (Sec. 8.55)
    u = speed_change_on_grid(plain, data.shape[0])
    return dataclasses.replace(measurement, data=data, issues=issues, speed_change=u), var
