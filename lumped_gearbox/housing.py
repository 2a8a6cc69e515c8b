"""Housing transfer path: bearing force -> housing acceleration through one housing mode per direction.

The housing around bearing 2 is a mass ``m_h`` on a spring-damper to ground (the rest of the
casing and the foundation), driven by the force the bearing pushes into it:

    m_h x'' + c_h x' + k_h x = F_b(t),      a_h = (F_b - c_h x' - k_h x) / m_h,

with ``k_h = m_h (2 pi f_h)^2`` and ``c_h = 2 zeta_h sqrt(k_h m_h)``. The sampled force is
band-limited-interpolated to 8 times the sample rate (polyphase), taken as piecewise linear between
those points, and the state is advanced exactly over each interval (matrix exponential of the 2x2
state matrix with its first-order-hold input terms). Below resonance the acceleration is the small
difference of ``F/m`` and ``k x / m``, which is why the interpolation has to be fine.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy.linalg import expm
from scipy.signal import resample_poly

HOUSING_MASS_KG = 4.0
HOUSING_FREQUENCY_HZ = 2600.0
HOUSING_DAMPING_RATIO = 0.04
OVERSAMPLE = 8


@njit(cache=True)
def _advance(f, phi, g0, g1, x0, k, c, m, every):
    out = np.empty(f.size // every)
    x = x0.copy()
    for i in range(f.size):
        if i % every == 0 and i // every < out.size:
            out[i // every] = (f[i] - c * x[1] - k * x[0]) / m
        if i + 1 < f.size:
            df = f[i + 1] - f[i]
            x0n = phi[0, 0] * x[0] + phi[0, 1] * x[1] + g0[0] * f[i] + g1[0] * df
            x[1] = phi[1, 0] * x[0] + phi[1, 1] * x[1] + g0[1] * f[i] + g1[1] * df
            x[0] = x0n
    return out


def housing_acceleration(
    force: np.ndarray,
    sample_rate_hz: float,
    mass_kg: float = HOUSING_MASS_KG,
    frequency_hz: float = HOUSING_FREQUENCY_HZ,
    damping_ratio: float = HOUSING_DAMPING_RATIO,
    oversample: int = OVERSAMPLE,
) -> np.ndarray:
    """Housing acceleration (m/s^2) for a sampled bearing force (N), starting from rest.

    The static part of the force deflects the housing and gives no acceleration. ``oversample`` is
    the band-limited interpolation factor before the first-order-hold stepping (1: the force is
    already finely sampled, as in the data-acquisition chain of ``daq.py``).
    """
    f = np.asarray(force, dtype=float)
    k = mass_kg * (2.0 * math.pi * frequency_hz) ** 2
    c = 2.0 * damping_ratio * math.sqrt(k * mass_kg)
    a_mat = np.array([[0.0, 1.0], [-k / mass_kg, -c / mass_kg]])
    b_vec = np.array([0.0, 1.0 / mass_kg])
    if not (isinstance(oversample, int) and oversample >= 1):
        raise ValueError(f"oversample: {oversample!r} must be an integer >= 1")
    h = 1.0 / (sample_rate_hz * oversample)
    # augmented exponential: [[A, B, 0], [0, 0, 1/h], [0, 0, 0]] gives the first-order-hold terms
    aug = np.zeros((4, 4))
    aug[:2, :2] = a_mat * h
    aug[:2, 2] = b_vec * h
    aug[2, 3] = 1.0
    e = expm(aug)
    phi, g0, g1 = e[:2, :2], e[:2, 2], e[:2, 3]
    mean = float(np.mean(f))  # static part: interpolated separately (no end effects)
    fine = resample_poly(f - mean, oversample, 1) + mean if oversample > 1 else f
    x0 = np.array([f[0] / k, 0.0])  # statically deflected by the first sample's force
    return _advance(fine, phi, g0, g1, x0, k, c, mass_kg, oversample)[: f.size]
