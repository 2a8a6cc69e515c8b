"""An input speed that varies within the record: a linear drift plus a sinusoidal fluctuation.

A real machine never runs at one exact speed: a motor warming or a load change drifts it, a torsional
mode, a slipping belt or the supply makes it fluctuate. The input end (node 1) is driven at the
prescribed angle, the integral of the speed

    w(t)   = w0 [1 + d (t / T - 1/2) + f sin(2 pi f_hz t + phi)]
    psi(t) = w0 [t + d (t^2 - T t) / (2 T) + f (cos(phi) - cos(2 pi f_hz t + phi)) / (2 pi f_hz)]

with ``w0`` the declared speed, ``d = drift_pct / 100`` the change over the record of length ``T``
(the drift is centred: the declared speed is its mean) and ``f = fluctuation_pct / 100`` the
fluctuation's amplitude (its mean over the record is zero for a whole number of periods). The kernel
(``model.py``) adds ``psi(t) - w0 t`` to the constant-speed angle of both wheels (the mesh position,
the eccentricity, unbalance and misalignment phases), uses ``w(t)`` in the rotating forces and adds the
input end's angular acceleration ``w'(t)`` to the torsional equations (the coordinates are relative to
the driven rotation); the bearing-defect impacts fall at equal increments of the true angle
(``bearing.py`` through :meth:`SpeedProfile.time_at`). The tangential force ``m e w'`` of an
unbalance (relative size ``w' / w^2 < 1e-3`` within the allowed ranges) is left out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .faults import check_range

#: allowed ranges (docs/independent_data.md "Speed profile"): the drift over the record and the
#: fluctuation's amplitude in percent of the declared speed, and the fluctuation's frequency (up to 400 Hz
#: since session 21: a fluctuation at a shaft's order 2, a Cardan joint's ripple, is 100 Hz for the input
#: at 3000 rpm and 267 Hz at 8000 rpm; session 18-20's 50 Hz held the records made until then)
DRIFT_PCT_MAX = 10.0
FLUCTUATION_PCT_MAX = 5.0
FLUCTUATION_HZ_MAX = 400.0
#: length of the kernel's profile vector (model.py): [active, a, b, c, omega, phi]
N_PROFILE = 6


@dataclass(frozen=True)
class SpeedProfile:
    """A drift and a fluctuation of the input speed about the declared one (module docstring).

    Attributes
    ----------
    drift_pct : float
        Change of the speed over the record, percent of the declared speed (``-10 .. 10``); centred
        on the record (the speed at its middle is the declared one).
    fluctuation_pct : float
        Amplitude of the sinusoidal fluctuation, percent of the declared speed (``0 .. 5``).
    fluctuation_hz : float
        Its frequency, Hz (``0 .. 400``; with ``fluctuation_pct`` 0 it is ignored). At ``j`` times a shaft's
        rate (the mean speed's) it is locked to that shaft's order ``j`` (to first order in its amplitude).
    fluctuation_phase_rad : float
        Its phase at ``t = 0``.
    """

    drift_pct: float = 0.0
    fluctuation_pct: float = 0.0
    fluctuation_hz: float = 0.0
    fluctuation_phase_rad: float = 0.0

    def __post_init__(self) -> None:
        check_range("speed_profile.drift_pct", self.drift_pct, -DRIFT_PCT_MAX, DRIFT_PCT_MAX)
        check_range("speed_profile.fluctuation_pct", self.fluctuation_pct, 0.0, FLUCTUATION_PCT_MAX)
        check_range("speed_profile.fluctuation_hz", self.fluctuation_hz, 0.0, FLUCTUATION_HZ_MAX)
        check_range("speed_profile.fluctuation_phase_rad", self.fluctuation_phase_rad, -10.0, 10.0)
        if self.fluctuation_pct > 0.0 and self.fluctuation_hz <= 0.0:
            raise ValueError("speed_profile.fluctuation_hz: must be > 0 with a fluctuation_pct > 0")

    @property
    def constant(self) -> bool:
        """Whether the speed is the declared one throughout."""
        return self.drift_pct == 0.0 and self.fluctuation_pct == 0.0

    def vector(self, duration_s: float) -> np.ndarray:
        """The kernel's profile ``[active, a, b, c, omega, phi]``: ``w / w0 = 1 + a + b t + c sin(omega t +
        phi)``; all zero for a constant speed (the kernel then runs the constant-speed expressions)."""
        p = np.zeros(N_PROFILE)
        if self.constant:
            return p
        d = self.drift_pct / 100.0
        c = self.fluctuation_pct / 100.0
        p[:] = [
            1.0,
            -0.5 * d,
            d / duration_s,
            c,
            2.0 * math.pi * self.fluctuation_hz,
            self.fluctuation_phase_rad,
        ]
        if c == 0.0:
            p[4] = 1.0  # unused; keeps the angle's division finite
        return p

    def truth(self) -> dict[str, Any]:
        return {
            "drift_pct": self.drift_pct,
            "fluctuation_pct": self.fluctuation_pct,
            "fluctuation_hz": self.fluctuation_hz,
            "fluctuation_phase_rad": self.fluctuation_phase_rad,
        }


def relative_speed(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``w(t) / w0`` of a profile vector (:meth:`SpeedProfile.vector`)."""
    t = np.asarray(t, dtype=float)
    if p[0] == 0.0:
        return np.ones_like(t)
    return 1.0 + p[1] + p[2] * t + p[3] * np.sin(p[4] * t + p[5])


def angle_extra(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``psi(t) / w0 - t`` (s): the angle beyond the constant-speed one, divided by ``w0``."""
    t = np.asarray(t, dtype=float)
    if p[0] == 0.0:
        return np.zeros_like(t)
    return p[1] * t + 0.5 * p[2] * t * t + p[3] * (math.cos(p[5]) - np.cos(p[4] * t + p[5])) / p[4]


def time_at(p: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Times ``t`` at which the true angle equals ``w0 tau`` (the inverse of ``t + angle_extra``):
    Newton iterations from ``t = tau`` (the speed stays within 0.8-1.2 of ``w0``)."""
    tau = np.asarray(tau, dtype=float)
    if p[0] == 0.0:
        return tau
    t = tau.copy()
    for _ in range(30):
        step = (t + angle_extra(p, t) - tau) / relative_speed(p, t)
        t = t - step
        if np.max(np.abs(step), initial=0.0) < 1e-13:
            break
    return t
