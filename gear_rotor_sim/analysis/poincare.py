"""Poincare sections (once per mesh period) and phase-portrait data.

The gear mesh is the forcing of the system: stiffness and transmission error repeat once per mesh
period ``T_m = 60 / (speed_rpm * z_pinion)``. A stroboscopic Poincare section samples the state once
per ``T_m`` at a fixed mesh phase; a period-n response shows ``n`` distinct points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def mesh_frequency_hz(speed_rpm: float, pinion_teeth: int) -> float:
    """Mesh frequency ``z1 * n / 60`` of a pinion of ``pinion_teeth`` teeth at ``speed_rpm``."""
    if not np.isfinite(speed_rpm) or speed_rpm <= 0:
        raise ValueError(f"speed_rpm: must be positive and finite, got {speed_rpm}")
    return pinion_teeth * speed_rpm / 60.0


def poincare_samples(x: np.ndarray, samples_per_period: int, offset: int = 0) -> np.ndarray:
    """Stroboscopic samples of a signal sampled an integer number of times per forcing period.

    Parameters
    ----------
    x : numpy.ndarray
        Signal with exactly ``samples_per_period`` samples per mesh period, shape ``(n, ...)``.
    samples_per_period : int
        Samples per mesh period (the simulator's steps per mesh, or its multiple of the output).
    offset : int
        Sample index of the section inside the period (fixes the mesh phase).

    Returns
    -------
    numpy.ndarray
        ``x[offset::samples_per_period]``.
    """
    if samples_per_period < 1:
        raise ValueError(f"samples_per_period: must be >= 1, got {samples_per_period}")
    if not 0 <= offset < samples_per_period:
        raise ValueError(f"offset: must lie in [0, {samples_per_period}), got {offset}")
    return np.asarray(x)[offset::samples_per_period]


def poincare_at_times(t: np.ndarray, x: np.ndarray, period_s: float, t_first: float) -> np.ndarray:
    """Poincare samples at ``t_first + k period_s`` by linear interpolation (any sample rate).

    Parameters
    ----------
    t : numpy.ndarray
        Increasing sample times, s.
    x : numpy.ndarray
        Samples, shape ``(n,)``.
    period_s : float
        Forcing period, s.
    t_first : float
        Time of the first section (sets the mesh phase); sections past ``t[-1]`` are dropped.
    """
    if period_s <= 0:
        raise ValueError(f"period_s: must be positive, got {period_s}")
    n = int(np.floor((t[-1] - t_first) / period_s + 1e-9)) + 1
    if n < 1:
        return np.zeros(0)
    ts = t_first + period_s * np.arange(n)
    return np.interp(ts, t, x)


@dataclass(frozen=True)
class PhasePortrait:
    """Trajectory in the (displacement, velocity) plane with its Poincare points.

    Attributes
    ----------
    x, v : numpy.ndarray
        Displacement and velocity along the whole window.
    px, pv : numpy.ndarray
        The once-per-mesh-period samples of the same trajectory.
    """

    x: np.ndarray
    v: np.ndarray
    px: np.ndarray
    pv: np.ndarray


def phase_portrait(
    x: np.ndarray,
    sample_rate_hz: float,
    samples_per_period: int,
    v: np.ndarray | None = None,
    offset: int = 0,
) -> PhasePortrait:
    """Phase-portrait data of one channel.

    Parameters
    ----------
    x : numpy.ndarray
        Displacement-like signal (e.g. DTE), sampled ``samples_per_period`` times per mesh period.
    sample_rate_hz : float
        Sampling rate, Hz.
    samples_per_period : int
        Samples per mesh period.
    v : numpy.ndarray, optional
        Velocity if the simulator provides it; otherwise the second-order central difference of
        ``x`` (``numpy.gradient``), which is exact for quadratics and accurate to O(dt^2).
    offset : int
        Sample index of the Poincare section in each period.
    """
    x = np.asarray(x, dtype=float)
    if v is None:
        v = np.gradient(x, 1.0 / sample_rate_hz)
    v = np.asarray(v, dtype=float)
    if v.shape != x.shape:
        raise ValueError(f"v: shape {v.shape} differs from x {x.shape}")
    return PhasePortrait(
        x,
        v,
        poincare_samples(x, samples_per_period, offset),
        poincare_samples(v, samples_per_period, offset),
    )
