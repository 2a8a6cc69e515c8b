"""One channel delayed against the others by the acquisition: read from the order features and undone
(issue 11, an effect nobody declared; docs/calibration.md Sec. 1, docs/history/calibration_sessions.md
Sec. 8.57).

A channel skewed by ``tau`` (a multiplexed ADC's channel order, a digital filter on one channel, a
separate DAQ module) carries every line at ``f`` with the extra phase ``-2 pi f tau``: linear in
frequency, on that channel alone. The common time shift (``Comparison.best_shift``) absorbs a delay
shared by every channel; one channel's own delay stays in its order features' phases against the model.

Method (:func:`channel_delays`), on the order features of the healthy model after the common shift:

1. per channel, the lines where the record and the model both stand out (``|d|^2`` and ``|m|^2`` at least
   :data:`MIN_LINE_SNR2` times the feature's noise variance), each with the unit phasor
   ``u_k = d_k conj(m_k) / |d_k m_k|`` and the weight ``w_k = min(|d_k|^2, |m_k|^2) / v_k`` capped at
   :data:`WEIGHT_CAP` (a few strong carriers must not decide alone);
2. the channel's delay ``tau_c`` maximises the coherence ``R(tau) = |sum w u exp(2 pi i f tau)| / sum w``
   over one mesh period (a grid of a tenth of a sample, refined parabolically): the mesh harmonics, which
   carry most of the weight, repeat after a delay of one mesh period (13.8 samples at 3000 rpm and 20 kHz,
   5.2 at 8000 rpm), so a delay is read modulo that period, in ``(-P / 2, P / 2]``;
3. the channel's skew is ``tau_c`` less the (circular) median of the other channels' ``tau``, wrapped into
   the same interval; its significance is the
   coherence gained, ``R(tau_c) / R(tau_median)``: a delay moves the phase of every line by its frequency,
   so the right delay makes the lines cohere, while the model's own phase error at a path (a resonance's
   phase, the same at the channels of one path, or not linear in frequency) gains little.

:func:`skew_fix` reads a channel as skewed when its offset from the others is at least
:data:`MIN_SKEW_SAMPLES`, the coherence it gains at least :data:`MIN_GAIN`, the other channels agree on
their own delay within :data:`MAX_OTHERS_SPREAD` and no other channel passes too; the channel is then read
``tau`` earlier (``fractional_delay.delay_samples``: whole or fractional samples) before the setup, and
``issues`` names it. The thresholds are set from the statistic on the 71 benchmark records
(``benchmarks/channel_skew_stats.py``; Sec. 8.57).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gear_rotor_sim.calibration.fractional_delay import delay_samples

#: a line is used when both its measured and its model power stand this far above the noise variance
MIN_LINE_SNR2 = 25.0
#: a line's weight ``min(|d|^2, |m|^2) / v`` is capped here
WEIGHT_CAP = 1e4
#: the delays searched, samples either side of zero, where the rig has no mesh period to wrap them in
MAX_DELAY_SAMPLES = 8.0
#: grid step of the search, samples
GRID_STEP = 0.1
#: fewest lines for a channel's reading
MIN_LINES = 6
#: a channel's offset from the others' median that reads as a skew, samples
MIN_SKEW_SAMPLES = 0.5
#: coherence gained at the channel's own delay over the others' median that reads as a skew
MIN_GAIN = 1.5
#: largest spread (max - min, samples) of the other channels' delays: beyond it the model's phases are no
#: reference (the held-out 12 um contact wear: offsets of -4.9 to +6.3 samples on every channel)
MAX_OTHERS_SPREAD = 3.0


@dataclass(frozen=True)
class ChannelDelay:
    """Delay of one channel's lines against the model's (``channel_delays``)."""

    delay_samples: float  # tau_c (NaN: too few lines)
    coherence: float  # R(tau_c)
    coherence_at_median: float  # R(median of the other channels' tau)
    skew_samples: float  # tau_c less the other channels' median
    n_lines: int
    others_spread: float = float("nan")  # max - min of the other channels' delays about their median

    @property
    def gain(self) -> float:
        """Coherence gained at the channel's own delay over the others' median."""
        if not self.coherence_at_median > 0:
            return float("inf") if self.coherence > 0 else float("nan")
        return self.coherence / self.coherence_at_median


def _lines(
    d: Sequence[np.ndarray], v: Sequence[np.ndarray], m: Sequence[np.ndarray], f: Sequence[np.ndarray]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit phasors, weights and frequencies (Hz) of one channel's usable lines over every shaft."""
    us, ws, fs = [], [], []
    for ds, vs, ms, fq in zip(d, v, m, f, strict=True):
        ds, vs, ms = np.asarray(ds), np.asarray(vs, dtype=float), np.asarray(ms)
        pd, pm = np.abs(ds) ** 2, np.abs(ms) ** 2
        ok = (vs > 0) & np.isfinite(vs) & (pd >= MIN_LINE_SNR2 * vs) & (pm >= MIN_LINE_SNR2 * vs)
        if not ok.any():
            continue
        q = ds[ok] * np.conj(ms[ok])
        us.append(q / np.abs(q))
        ws.append(np.minimum(np.minimum(pd[ok], pm[ok]) / vs[ok], WEIGHT_CAP))
        fs.append(np.asarray(fq, dtype=float)[ok])
    if not us:
        return np.zeros(0, complex), np.zeros(0), np.zeros(0)
    return np.concatenate(us), np.concatenate(ws), np.concatenate(fs)


def _coherence(u: np.ndarray, w: np.ndarray, f: np.ndarray, tau_s: np.ndarray) -> np.ndarray:
    """``R(tau) = |sum w u exp(2 pi i f tau)| / sum w`` for each delay in ``tau_s`` (s)."""
    ph = np.exp(2j * np.pi * np.outer(tau_s, f))
    return np.abs(ph @ (w * u)) / float(np.sum(w))


def channel_delays(
    d_order: Sequence[Sequence[np.ndarray]],
    v_order: Sequence[Sequence[np.ndarray]],
    m_order: Sequence[Sequence[np.ndarray]],
    freqs_hz: Sequence[np.ndarray],
    sample_rate_hz: float,
    period_samples: float | None = None,
) -> list[ChannelDelay]:
    """Each channel's delay against the model and against the other channels (module docstring).

    Parameters
    ----------
    d_order, v_order : sequence of sequence of numpy.ndarray
        Measured order coefficients ``[channel][shaft]`` and their noise variances.
    m_order : sequence of sequence of numpy.ndarray
        The healthy model's order coefficients after the common time shift.
    freqs_hz : sequence of numpy.ndarray
        Each shaft's order frequencies (Hz).
    sample_rate_hz : float
        The record's sample rate.
    period_samples : float, optional
        The mesh period in samples: delays are read modulo it (default: ``+- MAX_DELAY_SAMPLES``, no wrap).

    Returns
    -------
    list of ChannelDelay
        One per channel (NaN delays where fewer than :data:`MIN_LINES` lines stand out).
    """
    fs = float(sample_rate_hz)
    P = float(period_samples) if period_samples and period_samples > 0 else None
    half = P / 2.0 if P else MAX_DELAY_SAMPLES
    grid = np.arange(-half, half + GRID_STEP / 2, GRID_STEP)
    lines, taus, peaks = [], [], []
    for c in range(len(d_order)):
        u, w, f = _lines(d_order[c], v_order[c], m_order[c], freqs_hz)
        lines.append((u, w, f))
        if u.size < MIN_LINES:
            taus.append(np.nan)
            peaks.append(np.nan)
            continue
        r = _coherence(u, w, f, grid / fs)
        k = int(np.argmax(r))
        t = grid[k]
        if 0 < k < grid.size - 1:  # parabolic refinement of the peak
            a, b, cc = r[k - 1], r[k], r[k + 1]
            den = a - 2.0 * b + cc
            if den < 0:
                t += 0.5 * (a - cc) / den * GRID_STEP
        taus.append(float(t))
        peaks.append(float(_coherence(u, w, f, np.array([t / fs]))[0]))
    out = []
    for c, (u, w, f) in enumerate(lines):
        others = np.array([t for j, t in enumerate(taus) if j != c and np.isfinite(t)])
        if not np.isfinite(taus[c]) or others.size == 0:
            out.append(ChannelDelay(taus[c], peaks[c], np.nan, np.nan, int(u.size)))
            continue
        med = _circular_median(others, P)
        r_med = float(_coherence(u, w, f, np.array([med / fs]))[0])
        dev = [_wrap(t - med, P) for t in others]
        out.append(
            ChannelDelay(taus[c], peaks[c], r_med, _wrap(taus[c] - med, P), int(u.size), max(dev) - min(dev))
        )
    return out


def _wrap(x: float, period: float | None) -> float:
    """``x`` wrapped into ``(-period / 2, period / 2]`` (unchanged without a period)."""
    if not period:
        return float(x)
    return float(x - period * np.ceil(x / period - 0.5))


def _circular_median(taus: np.ndarray, period: float | None) -> float:
    """Median of delays read modulo ``period``: about their circular mean (the plain median without one)."""
    if not period:
        return float(np.median(taus))
    mean = period / (2.0 * np.pi) * float(np.angle(np.mean(np.exp(2j * np.pi * taus / period))))
    return _wrap(mean + float(np.median([_wrap(t - mean, period) for t in taus])), period)


@dataclass(frozen=True)
class SkewFix:
    """Channels read as delayed, their delays (samples) and the ``issues`` entries."""

    channels: tuple[int, ...]
    delays: tuple[float, ...]
    issues: tuple[str, ...]

    def apply(self, data: np.ndarray) -> np.ndarray:
        """The corrected ``(n, nc)`` data (a new array): each skewed channel advanced by its delay."""
        out = np.array(data, dtype=float, copy=True)
        for c, d in zip(self.channels, self.delays, strict=True):
            out[:, c] = delay_samples(out[:, c], -d)
        return out


def skew_fix(delays: Sequence[ChannelDelay], columns: Sequence[str], sample_rate_hz: float) -> SkewFix:
    """The :class:`SkewFix` of the channels whose offset and coherence gain pass the thresholds (module
    docstring) while the other channels agree on their delay within :data:`MAX_OTHERS_SPREAD`; at most one
    channel (two or more offsets are the model's, not the acquisition's)."""
    hits = [
        c
        for c, cd in enumerate(delays)
        if np.isfinite(cd.skew_samples)
        and abs(cd.skew_samples) >= MIN_SKEW_SAMPLES
        and cd.gain >= MIN_GAIN
        and cd.others_spread <= MAX_OTHERS_SPREAD
    ]
    if len(hits) != 1:
        return SkewFix((), (), ())
    c = hits[0]
    cd = delays[c]
    d = cd.skew_samples
    text = (
        f"column {columns[c]!r}: delayed by {d:+.2f} samples ({1e6 * d / sample_rate_hz:+.0f} us) against "
        f"the other channels (its {cd.n_lines} order lines' phases against the model cohere {cd.gain:.2g} x "
        f"better at that delay, {cd.coherence:.2f} against {cd.coherence_at_median:.2f}): an acquisition "
        "skew; read that much earlier before the fit"
    )
    return SkewFix((c,), (float(d),), (text,))


def read_delays(cal: object, at_rattle: bool = False) -> list[ChannelDelay]:
    """:func:`channel_delays` of a set-up calibrator: its record's order features against its healthy
    model's after the common time shift. Empty without order features, and where the healthy model's teeth
    separate (``base_contact_loss`` above ``features_rattle.MIN_CONTACT_LOSS``) unless ``at_rattle``: there
    the mesh lines' phases are the rattle's, not a reference (on the 8000 rpm benchmark records four clean
    channels read offsets of 1.4-1.6 samples, and a force channel skewed by 3 samples put the largest
    reading on another channel; Sec. 8.57)."""
    from gear_rotor_sim.calibration.features_rattle import MIN_CONTACT_LOSS

    cmp = cal.cmp  # type: ignore[attr-defined]
    if "order" not in cmp.families or not cmp.shafts:
        return []
    if not at_rattle and getattr(cal, "base_contact_loss", 0.0) > MIN_CONTACT_LOSS:
        return []
    feats = cal._features(cal.base_raw)  # type: ignore[attr-defined]
    shifted = cmp.apply_shift(feats, cmp.best_shift(feats))
    freqs = [sh.orders * sh.ratio * cmp.speed_hz for sh in cmp.shafts]
    fs = cal.m.sample_rate_hz  # type: ignore[attr-defined]
    period = fs / cmp.mesh_hz if getattr(cmp, "mesh_hz", 0) else None
    return channel_delays(cmp.d_order, cmp.v_order, shifted.order, freqs, fs, period)


def correct_skew(cal: object, base_out: np.ndarray, n_notes: int) -> np.ndarray:
    """One channel delayed by the acquisition, read back before the fit (in
    ``channel_conventions.check_conventions``, after the sign check): where :func:`skew_fix` names a channel,
    the record is corrected, ``issues`` gets the entry and the comparison and the healthy run are set up
    again (the model runs come from the cache); otherwise nothing changes. Returns the healthy model's
    outputs."""
    from gear_rotor_sim.calibration.channel_conventions import _set_up_again

    ds = read_delays(cal)
    if not ds:
        return base_out
    columns = [c.column for c in cal.m.channels]  # type: ignore[attr-defined]
    fix = skew_fix(ds, columns, cal.m.sample_rate_hz)  # type: ignore[attr-defined]
    if not fix.channels:
        return base_out
    return _set_up_again(cal, fix.apply(cal.m.data), fix.issues, n_notes)  # type: ignore[attr-defined]
