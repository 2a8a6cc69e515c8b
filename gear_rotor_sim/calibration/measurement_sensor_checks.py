"""Sensor faults a record can hold without any sidecar field being wrong: a clipped channel and a DC
offset on an accelerometer (issue 11; docs/calibration.md Sec. 1, "Validation").

Both are reported in ``Measurement.issues`` naming the column; the data are left as they are.

- **Clipping.** A sensor or an acquisition channel driven beyond its range holds its full-scale value:
  many samples sit exactly at the channel's largest (or smallest) value. A signal that is not clipped
  reaches its extreme in one sample, or, coarsely quantised, in about as many samples as the next
  quantisation level below it. A channel is reported when at least :data:`CLIP_MIN_SAMPLES` samples
  equal its extreme, more than :data:`CLIP_PILE_UP` times as many as hold the next value inward, and
  the extreme is not the median (a constant channel is not clipped). Clipping cuts the peaks a
  bearing defect's impacts and a damaged tooth put into the signal; the features of that channel
  are then biased low.
- **DC offset of an accelerometer.** The mean acceleration of a machine running at constant speed is
  zero (the velocity stays bounded), so a mean of an ``acceleration`` or ``housing_acceleration``
  channel is a sensor or conditioning offset (or gravity on a DC-coupled sensor tilted off its axis).
  Reported when it exceeds :data:`DC_FRACTION` of the channel's standard deviation and
  :data:`DC_SIGMAS` standard errors of the mean of :data:`DC_BLOCKS` consecutive blocks. The
  calibration's features do not use an accelerometer's mean (orders from 1, band-passed envelopes),
  so the offset changes no result; the entry says so.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gear_rotor_sim.calibration.measurement_contract import ChannelSpec

#: fewest samples at the extreme value for a clipped channel
CLIP_MIN_SAMPLES = 5
#: the extreme value holds more than this many times the samples of the next value inward
CLIP_PILE_UP = 3.0
#: an accelerometer mean beyond this fraction of the standard deviation ...
DC_FRACTION = 0.25
#: ... and beyond this many standard errors (from block means) is an offset
DC_SIGMAS = 5.0
DC_BLOCKS = 20

ACCELERATIONS = ("acceleration", "housing_acceleration")


def clipped_side(x: np.ndarray) -> list[tuple[str, float, int]]:
    """The ends at which ``x`` is clipped: ``(\"maximum\" | \"minimum\", value, samples at it)``.

    Parameters
    ----------
    x : numpy.ndarray
        One channel's finite samples.

    Returns
    -------
    list of (str, float, int)
        Empty for a channel that is not clipped (module docstring).
    """
    f = x[np.isfinite(x)]
    if f.size < 2 * CLIP_MIN_SAMPLES:
        return []
    med = float(np.median(f))
    out = []
    for name, ext in (("maximum", np.max), ("minimum", np.min)):
        v = float(ext(f))
        at = int(np.count_nonzero(f == v))
        if at < CLIP_MIN_SAMPLES or v == med:
            continue
        rest = f[f != v]
        beyond = rest[rest > med] if name == "maximum" else rest[rest < med]
        nxt = int(np.count_nonzero(rest == ext(beyond))) if beyond.size else 0
        if at > CLIP_PILE_UP * max(nxt, 1):
            out.append((name, v, at))
    return out


def acceleration_offset(x: np.ndarray) -> tuple[float, float] | None:
    """Mean of an acceleration channel and its size in standard errors, if it is an offset.

    Parameters
    ----------
    x : numpy.ndarray
        One accelerometer channel's samples (SI).

    Returns
    -------
    (float, float) or None
        ``(mean, mean / standard error)`` beyond :data:`DC_FRACTION` x std and :data:`DC_SIGMAS`
        standard errors of the :data:`DC_BLOCKS` block means; None otherwise, and for a constant
        channel (standard deviation below 1e-6 of the mean: no vibration to compare the mean with).
    """
    f = x[np.isfinite(x)]
    n = f.size // DC_BLOCKS
    if n < 2:
        return None
    mean, std = float(np.mean(f)), float(np.std(f))
    if not std > 1e-6 * abs(mean):
        return None  # a constant channel carries no vibration to hold an offset against
    blocks = f[: n * DC_BLOCKS].reshape(DC_BLOCKS, n).mean(axis=1)
    se = float(np.std(blocks, ddof=1)) / np.sqrt(DC_BLOCKS)
    if abs(mean) > DC_FRACTION * std and abs(mean) > DC_SIGMAS * se:
        return mean, abs(mean) / se if se > 0 else float("inf")
    return None


def sensor_issues(data: np.ndarray, channels: Sequence[ChannelSpec], si_units: Sequence[str]) -> list[str]:
    """``issues`` entries for clipped channels and accelerometer offsets of SI ``data`` (n, nc)."""
    out = []
    for k, c in enumerate(channels):
        x = data[:, k]
        for side, v, at in clipped_side(x):
            out.append(
                f"column {c.column!r}: {at} samples sit exactly at its {side} {v:.6g} {si_units[k]} "
                "(clipped at the sensor's or the acquisition's range?): the peaks of this channel are "
                "cut, its features read low"
            )
        if c.quantity in ACCELERATIONS:
            dc = acceleration_offset(x)
            if dc is not None:
                out.append(
                    f"column {c.column!r}: mean {dc[0]:.4g} {si_units[k]} ({dc[1]:.3g} standard errors), "
                    f"where a vibration acceleration averages to zero: a DC offset of the sensor or its "
                    "conditioning (not used by the features: orders from 1, band-passed envelopes)"
                )
    return out
