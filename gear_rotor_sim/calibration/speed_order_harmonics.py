"""Is a shaft-order angle modulation kinematic? The same modulation read from each mesh harmonic alone
(issue 11; docs/calibration.md Sec. 2 "Speed check", varying speed; history Sec. 8.60).

A speed that fluctuates at order ``j`` of a shaft (a Cardan joint's 2x ripple) turns both wheels of the mesh
together: the mesh position, and with it every mesh harmonic ``K = m z``, is phase-modulated by ``K delta``,
so the angle modulation ``d`` read from harmonic ``m`` alone (every channel's line ``m z`` combined,
``speed_order_locked.line_readings``) is the same number for every ``m`` (1-6 at 3000 rpm) up to the
transfer paths' phase at the sideband offsets. A misaligned wheel's tilted contact (edge loading twice a
revolution of that wheel) changes the mesh's effective stiffness instead, and each harmonic answers it
differently: on the independent records some harmonic reads 0.03-0.29 or 2.6-20.6 times the combination, or
1.4-3.1 rad off its phase, where a speed ripple's harmonics read 0.76-1.6 times it within 0.44 rad
(``benchmarks/speed_order2_stats.py``, history Sec. 8.60).

:func:`kinematic` is that test: every harmonic whose own reading stands :data:`MIN_HARMONIC_Z` noise
sigmas out (at least :data:`MIN_HARMONICS` of them) must read within :data:`MAGNITUDE_RATIO` of the
combination's magnitude and :data:`MAX_PHASE_RAD` of its phase.
"""

from __future__ import annotations

import math

import numpy as np

from gear_rotor_sim.calibration.speed_order_locked import AngleModulation, LineReadings, combine

#: a harmonic's own reading is tested when it stands this many noise sigmas out
MIN_HARMONIC_Z = 3.0
#: harmonics that must carry a reading for the test to be made
MIN_HARMONICS = 2
#: each harmonic's ``|d_m|`` within this factor of the combination's ``|d|`` (either way)
MAGNITUDE_RATIO = 2.0
#: and its phase within this many radians of the combination's
MAX_PHASE_RAD = 1.0


def _harmonic_keys(orders: np.ndarray, mesh_orders: list[float]) -> list[tuple[int, int]]:
    """(mesh index, harmonic) of each line order: the first mesh of which it is a whole harmonic."""
    keys = []
    for k in orders:
        key = (-1, 0)
        for i, o in enumerate(mesh_orders):
            m = round(float(k) / o)
            if m >= 1 and abs(float(k) - m * o) < 1e-6 * o:
                key = (i, m)
                break
        keys.append(key)
    return keys


def harmonic_readings(rd: LineReadings, mesh_orders: list[float]) -> list[AngleModulation]:
    """The angle modulation read from each mesh harmonic alone (every channel's line combined), for the
    harmonics that stand :data:`MIN_HARMONIC_Z` out.

    Parameters
    ----------
    rd : LineReadings
        Per-line readings at one shaft order (``speed_order_locked.line_readings``).
    mesh_orders : list of float
        Each mesh's frequency per unit input rate (its harmonics are the lines' orders).

    Returns
    -------
    list of AngleModulation
        One per harmonic that stands out, ``order`` holding the harmonic ``m``.
    """
    keys = _harmonic_keys(rd.harmonic, mesh_orders)
    out = []
    for key in sorted(set(keys)):
        mod = combine(rd, 0.0, key[1], np.array([k == key for k in keys], dtype=bool))
        if mod is not None and mod.z >= MIN_HARMONIC_Z:
            out.append(mod)
    return out


def kinematic(rd: LineReadings, mod: AngleModulation, mesh_orders: list[float]) -> bool:
    """Whether the combined reading ``mod`` is read alike by every mesh harmonic (module docstring): the
    form of a speed fluctuation, not of a contact that changes along a wheel's revolution.

    Parameters
    ----------
    rd : LineReadings
        The per-line readings ``mod`` combines.
    mod : AngleModulation
        Their combination.
    mesh_orders : list of float
        Each mesh's frequency per unit input rate.

    Returns
    -------
    bool
    """
    per = harmonic_readings(rd, mesh_orders)
    if len(per) < MIN_HARMONICS or mod.amplitude_rad <= 0.0:
        return False
    for h in per:
        ratio = h.amplitude_rad / mod.amplitude_rad
        dphi = abs(math.remainder(h.phase_rad - mod.phase_rad, 2.0 * math.pi))
        if not (1.0 / MAGNITUDE_RATIO <= ratio <= MAGNITUDE_RATIO and dphi <= MAX_PHASE_RAD):
            return False
    return True
