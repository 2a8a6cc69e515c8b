"""Time-varying mesh stiffness of the lumped model: per tooth pair, with smoothed entry and exit.

Each tooth pair is engaged over ``eps`` mesh cycles (``eps`` = transverse contact ratio). Along its
path its stiffness follows a shape that is highest mid-path (the Ishikawa/Weber observation that a
pair is stiffest near the pitch point, where the load acts low on both teeth),

    g(x) = (1 - 0.25 (2x - 1)^2) r(s),     x = s / eps, s in [0, eps) cycles since the pair entered,

and ``r`` is a half-cosine ramp over the first and last ``s_r`` cycles that stands for tip relief
(the pair picks up and sheds load gradually instead of in a step). The amplitude is set so that the
mesh stiffness averaged over a cycle equals the ISO 6336-1 mean mesh stiffness (``params.springs``).
Pair ``n`` (counted from time 0) is formed by pinion tooth ``n mod z1`` and gear tooth ``n mod z2``
(0-based), so pinion tooth 1 and gear tooth 1 enter contact together at time 0.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

RELIEF_CYCLES = 0.2  # length of the entry/exit ramps, mesh cycles


@njit(cache=True, inline="always")
def deadzone(d: float, b: float) -> tuple[float, float]:
    """Backlash deadzone: the mesh deflection beyond the half clearance ``b`` and whether in contact."""
    if d > b:
        return d - b, 1.0
    if d < -b:
        return d + b, 1.0
    return 0.0, 0.0


@njit(cache=True, inline="always")
def pair_shape(s: float, eps: float, relief: float) -> float:
    """Relative stiffness of one pair ``s`` cycles after it entered (0 outside ``[0, eps)``)."""
    if s < 0.0 or s >= eps:
        return 0.0
    x = s / eps
    g = 1.0 - 0.25 * (2.0 * x - 1.0) ** 2
    if s < relief:
        g *= 0.5 * (1.0 - math.cos(math.pi * s / relief))
    elif eps - s < relief:
        g *= 0.5 * (1.0 - math.cos(math.pi * (eps - s) / relief))
    return g


def shape_integral(eps: float, relief: float = RELIEF_CYCLES, n: int = 20001) -> float:
    """``int_0^eps g(s) ds``: the cycle-mean of the summed shapes of all pairs (trapezoidal rule)."""
    s = np.linspace(0.0, eps, n)
    g = np.array([pair_shape(v, eps, relief) for v in s])
    return float(np.sum(0.5 * (g[1:] + g[:-1]) * np.diff(s)))


def pair_amplitude(mean_stiffness: float, eps: float, relief: float = RELIEF_CYCLES) -> float:
    """Amplitude ``K0`` of one pair so that the cycle-mean mesh stiffness is ``mean_stiffness``."""
    return mean_stiffness / shape_integral(eps, relief)


def mesh_stiffness(
    u: np.ndarray,
    k0: float,
    eps: float,
    pinion_factor: np.ndarray,
    gear_factor: np.ndarray,
    relief: float = RELIEF_CYCLES,
) -> np.ndarray:
    """Mesh stiffness at mesh positions ``u`` (cycles since time 0), N/m (vectorised reference).

    ``pinion_factor[i]``, ``gear_factor[j]`` multiply the pairs formed by pinion tooth i / gear
    tooth j (1 - depth for a damaged tooth, 1 otherwise).
    """
    u = np.asarray(u, dtype=float)
    out = np.zeros_like(u)
    z1, z2 = len(pinion_factor), len(gear_factor)
    base = np.floor(u)
    for back in range(math.ceil(eps) + 1):
        n = base - back
        s = u - n
        g = np.array([pair_shape(v, eps, relief) for v in s.ravel()]).reshape(s.shape)
        ni = n.astype(np.int64)
        out += k0 * g * pinion_factor[np.mod(ni, z1)] * gear_factor[np.mod(ni, z2)]
    return out
