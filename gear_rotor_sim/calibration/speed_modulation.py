"""The synchronous response at the speed of the moment, on a record resampled to uniform shaft angle
(issue 11; docs/calibration.md Sec. 2 "Speed check", varying speed; history Sec. 8.49).

Order tracking (``order_tracking.py``) puts every shaft order of a record whose speed varies back on
one order, but it cannot make the machine's response the one at the mean speed: a mesh harmonic
passes through transfer paths whose resonances stay fixed in Hz, so its amplitude and phase follow the
speed of the moment. On ``lumped_gearbox`` at 3000 rpm the mesh fundamental at the bearing forces
changes by -10.5 % per % of speed (R^2 = 1.00 against the speed change; the inertia torque ``J2 w2'``
is 0.04 % of the mesh force), so a fluctuation of 0.5 % at 2 Hz modulates it by 3.8 % rms. That
modulation is not periodic with any shaft: the synchronous average keeps the mean line and the
rest stays in the non-synchronous part, 20-30 times the noise within +-20 Hz of the mesh frequency,
where the envelope family (``residual_envelope.py``) reads it as 10-20 Hz lines 20-60 times their
floor, which a model run at the mean speed cannot have.

To first order in the relative speed change ``u(t) = w(t) / w_mean - 1`` (``Measurement.speed_change``,
set by the order tracking on the resampled grid) each revolution ``r`` of a shaft holds

    x_r(phi) = S(phi) + u_r(phi) D(phi) + e_r(phi)

with ``S`` the synchronous average and ``D = dS / du`` the response's sensitivity to the speed, itself
periodic with the shaft. :func:`remove_speed_modulated` removes ``u D`` after ``S`` (the plain
synchronous part, ``features_orders.remove_synchronous``): ``D`` is the synchronous part of ``x u``
over ``mean(u^2)`` (the least-squares estimate for a ``u`` slow against the shaft), keeping only
the orders that stand 3 standard errors out of their between-revolution scatter, as the synchronous
average does, so that random content (noise, a bearing's slipping impacts) loses no more than the
synchronous average already takes. The same operation is applied to the measured and to every model
signal whose envelope is compared; a model run at constant speed has no content that follows ``u``
and keeps its signal.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gear_rotor_sim.calibration.features_orders import synchronous_part

#: ``mean(u^2)`` below which the speed is constant for this purpose (a 1e-6 relative rms change)
MIN_MEAN_SQUARE = 1e-12


def speed_modulated_part(x: np.ndarray, fs: float, shaft_hz: float, u: np.ndarray) -> np.ndarray:
    """``u(t) D(phi)``: the part of ``x`` that is periodic with the shaft times the speed change.

    Parameters
    ----------
    x : numpy.ndarray
        Signal (n,), uniform in shaft angle at the mean speed (its synchronous part already removed).
    fs : float
        Sample rate, Hz.
    shaft_hz : float
        The shaft's rotation frequency at the mean speed, Hz.
    u : numpy.ndarray
        Relative speed change at each sample (at least n samples; the first n are used).

    Returns
    -------
    numpy.ndarray
        ``u D`` (n,); zeros where ``mean(u^2) <= MIN_MEAN_SQUARE``.
    """
    x = np.asarray(x, dtype=float)
    uu = np.asarray(u, dtype=float)[: x.size]
    ms = float(np.mean(uu**2)) if uu.size == x.size else 0.0
    if not ms > MIN_MEAN_SQUARE:
        return np.zeros_like(x)
    return uu * synchronous_part(x * uu, fs, shaft_hz) / ms


def remove_speed_modulated(x: np.ndarray, fs: float, shafts_hz: Sequence[float], u: np.ndarray) -> np.ndarray:
    """``x`` without each shaft's speed-modulated synchronous part (module docstring), in the order given.

    Parameters
    ----------
    x : numpy.ndarray
        Non-synchronous part (n,) of a signal uniform in shaft angle.
    fs : float
        Sample rate, Hz.
    shafts_hz : sequence of float
        Rotation frequency of every shaft at the mean speed, Hz.
    u : numpy.ndarray
        Relative speed change per sample (``Measurement.speed_change``).
    """
    out = np.asarray(x, dtype=float)
    for f in shafts_hz:
        out = out - speed_modulated_part(out, fs, f, u)
    return out
