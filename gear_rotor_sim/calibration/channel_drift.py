"""A channel whose mean drifts over the record (issue 11: effects nobody declared; docs/calibration.md Sec. 1,
"Sensor conventions and faults nobody declared"; history Sec. 8.53).

A record of a machine at a constant operating point has constant channel means; the calibration's features
assume it (the static family reads each mean as one number, the synchronous averages assume a stationary
signal). A force sensor's zero that drifts (a load cell warming), a charge amplifier's baseline, or an axial
force following a temperature that rises during the record break that: a linear drift ``b t`` enters
every shaft's synchronous average as a sawtooth of peak-to-peak ``b T_rev`` over one revolution, that is as
lines at every order ``k`` of amplitude ``b T_rev / (pi k)``. Measured on the independent 3000 rpm healthy
record with its axial force drifting 0 -> 60 N over 2 s (history Sec. 8.53): the sawtooth, 0.6 N at the
pinion's orders against the channel's 0.06 N noise of a synchronous average, was claimed as a gear and a
pinion misalignment (the library effects that put content at the low orders of the axial force) at
confidence 1.0.

Rule (:func:`channel_drift`). Per DC-coupled channel (a force, the DTE, a displacement: the channels
whose mean the static family reads; not an accelerometer), the means of consecutive whole revolutions of
the slowest shaft (:data:`MIN_BLOCKS` at least), a straight line fitted to them over time, and the slope's
t value with the standard error from the block means' own scatter about the line (so that a mean that
oscillates, a load fluctuation or the hunting period's beat, widens it and does not read as a trend).
``|t| >= T_MIN`` is a drift: the line's slope is removed about the record's middle (the channel's mean is
kept) and ``issues`` names the column and the change over the record. On the 71 benchmark records the
largest ``|t|`` is 2.7 (``benchmarks/sensor_zero_stats.py``); the CWRU files hold accelerometers only.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: a channel's trend is a drift from this t value of its slope on (71 benchmark records: at most 2.7)
T_MIN = 10.0
#: whole revolutions of the slowest shaft needed for a trend (fewer: no reading)
MIN_BLOCKS = 8


@dataclass(frozen=True)
class Trend:
    """The linear trend of one channel's revolution means."""

    slope: float  # per second, SI
    t: float  # slope / its standard error
    blocks: int
    duration_s: float

    @property
    def change(self) -> float:
        """The change over the record, SI."""
        return self.slope * self.duration_s


def trend(x: np.ndarray, fs: float, f_slow_hz: float) -> Trend | None:
    """Linear trend of the means of whole revolutions of the slowest shaft (module docstring).

    Parameters
    ----------
    x : numpy.ndarray
        One channel's samples.
    fs : float
        Sample rate, Hz.
    f_slow_hz : float
        The slowest shaft's rate, Hz.

    Returns
    -------
    Trend or None
        None for fewer than :data:`MIN_BLOCKS` revolutions; ``t`` infinite for block means exactly on a line.
    """
    per = fs / f_slow_hz
    nb = int(x.size // per)
    if nb < MIN_BLOCKS:
        return None
    edges = np.round(np.arange(nb + 1) * per).astype(int)
    means = np.add.reduceat(x[: edges[-1]], edges[:-1]) / np.diff(edges)
    tc = 0.5 * (edges[:-1] + edges[1:]) / fs
    tc = tc - tc.mean()
    slope = float(np.sum(tc * (means - means.mean())) / np.sum(tc * tc))
    resid = means - means.mean() - slope * tc
    se = float(np.sqrt(np.sum(resid**2) / (nb - 2) / np.sum(tc * tc)))
    t = slope / se if se > 0 else (0.0 if slope == 0 else float("inf") * np.sign(slope))
    return Trend(slope, float(t), nb, x.size / fs)


@dataclass(frozen=True)
class DriftFix:
    """Channels whose trend is removed, their trends and the ``issues`` entries."""

    channels: tuple[int, ...]
    trends: tuple[Trend, ...]
    issues: tuple[str, ...]
    fs: float

    def apply(self, data: np.ndarray) -> np.ndarray:
        """The ``(n, nc)`` data with each drifting channel's line removed about the middle (a new array)."""
        out = np.array(data, dtype=float, copy=True)
        t = np.arange(out.shape[0]) / self.fs
        t -= 0.5 * (t[0] + t[-1])
        for k, tr in zip(self.channels, self.trends, strict=True):
            out[:, k] -= tr.slope * t
        return out


def channel_drift(
    data: np.ndarray,
    columns: Sequence[str],
    units: Sequence[str],
    fs: float,
    f_slow_hz: float,
    static: Sequence[bool] | None = None,
) -> DriftFix:
    """The channels of ``data`` (n, nc; SI) whose mean drifts (``|t| >= T_MIN``), with their ``issues``.

    ``static`` marks the DC-coupled channels whose mean is a signal (forces, DTE, displacements); only they
    are read (default: all). An accelerometer's mean is an offset the features never use, and its baseline
    wanders with the conditioning (a CWRU drive-end accelerometer reads ``t = 14``)."""
    ks, trends, issues = [], [], []
    for k, col in enumerate(columns):
        if static is not None and not static[k]:
            continue
        tr = trend(np.asarray(data[:, k], float), fs, f_slow_hz)
        if tr is None or not abs(tr.t) >= T_MIN:
            continue
        ks.append(k)
        trends.append(tr)
        issues.append(
            f"column {col!r}: its mean drifts by {tr.change:+.4g} {units[k]} over the record "
            f"(t = {tr.t:+.3g} over {tr.blocks} revolutions of the slowest shaft), where the operating "
            "point is declared constant: a drifting sensor zero or amplifier baseline (or the machine's "
            "temperature, load or speed drifting); the linear trend is removed, the mean kept (a drift puts "
            "a sawtooth on every synchronous average)"
        )
    return DriftFix(tuple(ks), tuple(trends), tuple(issues), fs)
