"""Effects nobody declared that sessions 17-19 never tried (issue 11, session 20, history Sec. 8.53).

Each factory returns a function ``post(record, fs)`` that changes a noisy ``lumped_gearbox`` record in place,
after the generator (which is not changed); ``benchmarks/calibration_undeclared.py`` applies it
(:func:`calibration_undeclared_cases.probe_cases`). What a real chain does without saying so:

- a sample clock off by ``eps``: the record is generated at ``fs (1 + eps)`` and its time column written at
  the declared ``fs`` (:data:`CLOCK_RATE_HZ`), so every frequency in the file, the machine's fixed resonances
  too, reads ``1 / (1 + eps)`` of its true value (a wrong speed moves only the orders);
- a force sensor's zero offset, constant or drifting linearly over the record (the axial force is the model's
  thermometer, calibration.md Sec. 8.2; a drift of a few newtons per second is also what a temperature
  drifting by a few C over the record puts on it, the stiffness change of a few C being 0.1 %);
- an accelerometer's mounting resonance (:func:`undeclared_disturbances.mount_resonance`, here on several
  columns at once);
- coarse quantisation: ``bits`` over a symmetric range ``range_factor`` x the channel's peak about zero;
- a slow baseline wander: band-limited random noise below the slowest shaft's rate on every channel;
- cross-talk: a fraction of one channel (its mean too: DC-coupled) summed into another;
- a channel skew: :func:`calibration_undeclared_cases.delay`.

Every random draw comes from its own seeded generator, so a record is the same whichever cases are run.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from scipy import signal

from lumped_gearbox.record import Record

Post = Callable[[Record, float], None]

#: the sample rate the benchmark records declare (their sidecar and time column)
CLOCK_RATE_HZ = 20000.0


def clock_error(rel: float) -> tuple[dict[str, float], Post]:
    """A sample clock off by ``rel`` (0.003: the true rate 0.3 % above the declared one).

    Returns the ``make_record`` keywords (``sample_rate_hz``: the true rate, ``fs (1 + rel)``) and the post
    that writes the time column at the declared :data:`CLOCK_RATE_HZ`; a line at ``f`` Hz of the machine then
    sits at ``f / (1 + rel)`` Hz of the file's time.
    """

    def post(rec: Record, fs: float) -> None:
        rec.time_s = np.arange(rec.time_s.size) / CLOCK_RATE_HZ

    return {"sample_rate_hz": CLOCK_RATE_HZ * (1.0 + rel)}, post


def zero_drift(col: str, start: float, end: float) -> Post:
    """Add a zero that runs linearly from ``start`` to ``end`` (SI) over the record to one column."""

    def post(rec: Record, fs: float) -> None:
        x = rec.data[col]
        rec.data[col] = x + np.linspace(start, end, x.size)

    return post


def quantise(bits: int = 10, range_factor: float = 8.0, cols: Sequence[str] | None = None) -> Post:
    """Round each column to ``2 R / 2**bits`` steps, ``R = range_factor`` x its largest absolute value (an ADC
    whose symmetric range was set for a larger signal)."""

    def post(rec: Record, fs: float) -> None:
        for c in cols or list(rec.data):
            x = rec.data[c]
            step = 2.0 * range_factor * float(np.max(np.abs(x))) / 2.0**bits
            rec.data[c] = np.round(x / step) * step

    return post


def baseline_wander(
    rms_fraction: float = 0.2, band_hz: tuple[float, float] = (0.3, 5.0), seed: int = 13
) -> Post:
    """Add to every channel random noise band-passed to ``band_hz`` (below the gear's 29.6 Hz shaft rate at
    3000 rpm), of ``rms_fraction`` x the channel's RMS about its mean."""

    def post(rec: Record, fs: float) -> None:
        rng = np.random.default_rng(seed)
        n = rec.time_s.size
        f = np.fft.rfftfreq(n, 1.0 / fs)
        keep = (f >= band_hz[0]) & (f <= band_hz[1])
        for c in rec.data:
            w = np.fft.irfft(np.fft.rfft(rng.standard_normal(n)) * keep, n)
            w *= rms_fraction * float(np.std(rec.data[c])) / float(np.std(w))
            rec.data[c] = rec.data[c] + w

    return post


def crosstalk(src: str, dst: str, fraction: float) -> Post:
    """Sum ``fraction`` x column ``src`` (mean included) into column ``dst``."""

    def post(rec: Record, fs: float) -> None:
        rec.data[dst] = rec.data[dst] + fraction * rec.data[src]

    return post


def mount_resonances(cols: Sequence[str], f0_hz: float = 6000.0, q: float = 15.0) -> Post:
    """Each column of ``cols`` through the mount resonance ``w0^2 / (s^2 + (w0 / Q) s + w0^2)``."""
    from undeclared_disturbances import mount_resonance

    posts = [mount_resonance(c, f0_hz, q) for c in cols]

    def post(rec: Record, fs: float) -> None:
        for p in posts:
            p(rec, fs)

    return post


def line_frequency(x: np.ndarray, fs: float, near_hz: float, half_width_hz: float = 20.0) -> float:
    """Frequency of the largest line of ``x`` within ``near_hz +- half_width_hz`` (Hann window, zero-padded
    16x, parabolic interpolation of the log peak): for checking where a line sits in a record's time."""
    n = x.size
    spec = np.abs(np.fft.rfft((x - np.mean(x)) * signal.windows.hann(n), 16 * n))
    f = np.fft.rfftfreq(16 * n, 1.0 / fs)
    idx = np.flatnonzero(np.abs(f - near_hz) <= half_width_hz)
    k = int(idx[np.argmax(spec[idx])])
    a, b, c = np.log(spec[k - 1 : k + 2])
    return float(f[k] + 0.5 * (a - c) / (a - 2.0 * b + c) * (f[1] - f[0]))
