"""Measurement disturbances nobody declared, added to a noisy ``lumped_gearbox`` record (issue 11).

What a real acquisition chain does without saying so (docs/history/calibration_sessions.md Sec. 8.47):
impulsive interference (random spikes on one channel, or on all channels at once: a common-mode electrical
event), a sensor-mount resonance on an accelerometer, coloured instead of white noise, data-acquisition
dropouts (a run of zeros or of a held value, NaN samples), a gap in the time base (lost messages), a
duplicated block (a re-sent buffer), and a slow gain modulation (a loose cable or connector).

Each factory returns a function ``post(record, fs)`` that changes the record in place (``record.data``,
and for the time-base effects ``record.time_s``); ``benchmarks/calibration_undeclared.py`` applies it after
the generator, which is never changed. Every random draw comes from its own seeded generator, so a
record is the same whichever other effects or cases are run.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from scipy import signal

from lumped_gearbox.record import Record

Post = Callable[[Record, float], None]


def noise_of(rec: Record, col: str) -> np.ndarray:
    """The white noise the generator added to ``col`` (``data - gain * clean``)."""
    return rec.data[col] - rec.gain[col] * rec.clean[col]


def spikes(
    cols: Sequence[str],
    rate_hz: float = 20.0,
    scale: tuple[float, float] = (10.0, 50.0),
    width: tuple[int, int] = (1, 3),
    seed: int = 7,
) -> Post:
    """Random rectangular spikes (Poisson times at ``rate_hz``, ``width`` samples, height ``scale`` x the
    channel's noise standard deviation, random sign); the same times, widths, signs and scales on every
    column of ``cols`` (one column: interference on one channel; all: a common-mode event)."""

    def post(rec: Record, fs: float) -> None:
        rng = np.random.default_rng(seed)
        n = rec.time_s.size
        count = int(rng.poisson(rate_hz * n / fs))
        starts = np.sort(rng.integers(0, n - width[1], count))
        widths = rng.integers(width[0], width[1] + 1, count)
        heights = rng.uniform(*scale, count) * rng.choice([-1.0, 1.0], count)
        for c in cols:
            sigma = float(np.std(noise_of(rec, c)))
            x = rec.data[c].copy()
            for s, w, h in zip(starts, widths, heights, strict=True):
                x[s : s + w] += h * sigma
            rec.data[c] = x

    return post


def mount_resonance(col: str, f0_hz: float = 6000.0, q: float = 20.0) -> Post:
    """An accelerometer on a compliant mount: the channel through ``w0^2 / (s^2 + (w0 / Q) s + w0^2)``
    (gain 1 well below ``f0_hz``, ``Q`` at it), bilinear transform pre-warped at ``f0_hz``."""

    def post(rec: Record, fs: float) -> None:
        b, a = _prewarped(2.0 * math.pi * f0_hz, q, fs)
        x = rec.data[col]
        m = float(np.mean(x))
        rec.data[col] = m + signal.lfilter(b, a, x - m)

    return post


def _prewarped(w0: float, q: float, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Bilinear transform of the resonance with its frequency pre-warped (the digital peak at ``w0``)."""
    wp = 2.0 * fs * math.tan(w0 / (2.0 * fs))
    return signal.bilinear([wp**2], [1.0, wp / q, wp**2], fs=fs)


def pink_noise(seed: int = 11) -> Post:
    """Every channel's white noise replaced by 1/f (pink) noise of the same standard deviation."""

    def post(rec: Record, fs: float) -> None:
        rng = np.random.default_rng(seed)
        n = rec.time_s.size
        f = np.fft.rfftfreq(n, 1.0 / fs)
        shape = 1.0 / np.sqrt(np.maximum(f, f[1]))
        for c in rec.data:
            white = noise_of(rec, c)
            pink = np.fft.irfft(np.fft.rfft(rng.standard_normal(n)) * shape, n)
            pink *= float(np.std(white)) / float(np.std(pink))
            rec.data[c] = rec.data[c] - white + pink

    return post


def dropout(col: str, t_s: float = 0.9, length_s: float = 0.03, hold: bool = False) -> Post:
    """``length_s`` of one channel from ``t_s`` on replaced by zeros, or by the last value before it."""

    def post(rec: Record, fs: float) -> None:
        i0 = round(t_s * fs)
        x = rec.data[col].copy()
        x[i0 : i0 + round(length_s * fs)] = x[i0 - 1] if hold else 0.0
        rec.data[col] = x

    return post


def nan_samples(col: str, times_s: Sequence[float] = (0.3, 0.7, 1.1, 1.5, 1.9)) -> Post:
    """Single NaN samples on one channel (values the acquisition did not deliver)."""

    def post(rec: Record, fs: float) -> None:
        x = rec.data[col].copy()
        x[[round(t * fs) for t in times_s]] = np.nan
        rec.data[col] = x

    return post


def time_gap(t_s: float = 1.0, length_s: float = 0.05) -> Post:
    """Lost messages: ``length_s`` of samples from ``t_s`` on removed from every column and the time axis
    (the time column jumps by ``length_s`` plus one step)."""

    def post(rec: Record, fs: float) -> None:
        i0, n = round(t_s * fs), round(length_s * fs)
        keep = np.r_[0:i0, i0 + n : rec.time_s.size]
        rec.time_s = rec.time_s[keep]
        for c in rec.data:
            rec.data[c] = rec.data[c][keep]

    return post


def repeated_block(t_s: float = 1.0, length_s: float = 0.02, retime: bool = False) -> Post:
    """A re-sent buffer: the ``length_s`` block before ``t_s`` delivered twice, on every column. With its
    own time stamps again (``retime`` False: the time column steps back), or with the time column running
    on (``retime`` True: the later samples are ``length_s`` late, the record keeps its length)."""

    def post(rec: Record, fs: float) -> None:
        i0, n = round(t_s * fs), round(length_s * fs)
        idx = np.r_[0:i0, i0 - n : rec.time_s.size]
        if retime:
            idx = idx[: rec.time_s.size]
        else:
            rec.time_s = rec.time_s[idx]
        for c in rec.data:
            rec.data[c] = rec.data[c][idx]

    return post


def gain_modulation(col: str, depth: float = 0.08, hz: float = 3.7) -> Post:
    """A loose cable or connector: the channel times ``1 + depth sin(2 pi hz t + 0.4)`` (not synchronous
    with any shaft)."""

    def post(rec: Record, fs: float) -> None:
        t = np.arange(rec.data[col].size) / fs
        rec.data[col] = rec.data[col] * (1.0 + depth * np.sin(2.0 * math.pi * hz * t + 0.4))

    return post


def mains_hum(
    col: str, hz: float = 50.0, harmonics: dict[int, float] | None = None, phase: float = 0.3
) -> Post:
    """Mains pickup on one channel: lines at ``h x hz`` of amplitude ``sqrt(2) x fraction x`` the channel's
    RMS about its mean, ``harmonics`` mapping ``h`` to ``fraction`` (default the fundamental at 0.5), each
    at phase ``h x phase`` (not synchronous with any shaft: it follows the supply, not the speed)."""
    fractions = harmonics or {1: 0.5}

    def post(rec: Record, fs: float) -> None:
        x = rec.data[col]
        t = np.arange(x.size) / fs
        rms = float(np.std(x))
        hum = sum(
            math.sqrt(2.0) * a * rms * np.sin(2.0 * math.pi * h * hz * t + h * phase)
            for h, a in fractions.items()
        )
        rec.data[col] = x + hum

    return post


def neighbour_machine(
    cols: Sequence[str],
    hz: float = 24.7,
    harmonics: dict[int, float] | None = None,
    phase: float = 0.7,
) -> Post:
    """A neighbouring machine's vibration through the foundation (a motor or pump at 1482 rpm): lines at
    ``h x hz`` of amplitude ``sqrt(2) x fraction x`` each column's RMS about its mean, ``harmonics`` mapping
    ``h`` to ``fraction`` (default 0.3, 0.15, 0.1, 0.05 for h = 1-4), at phase ``h x phase + 0.9 x`` the
    column's index in ``cols`` (each path its own phase); locked to no shaft of the gearbox."""
    fractions = harmonics or {1: 0.3, 2: 0.15, 3: 0.1, 4: 0.05}

    def post(rec: Record, fs: float) -> None:
        for i, col in enumerate(cols):
            x = rec.data[col]
            t = np.arange(x.size) / fs
            rms = float(np.std(x))
            rec.data[col] = x + sum(
                math.sqrt(2.0) * a * rms * np.sin(2.0 * math.pi * h * hz * t + h * phase + 0.9 * i)
                for h, a in fractions.items()
            )

    return post
