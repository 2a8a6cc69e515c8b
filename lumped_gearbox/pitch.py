"""Manufacturing pitch errors on every tooth of both wheels: a healthy machine's tooth-by-tooth
transmission error (issue 11, an effect nobody declared).

No gear is cut exactly. ISO 1328-1 grades a wheel by its *single pitch deviation* ``f_pt`` (the
difference between the actual and the nominal spacing of two neighbouring flanks, measured on the
reference circle) and its *cumulative pitch deviation* ``F_p`` (the largest spread of the flanks'
positions around the wheel). For the paper's wheels (module 3 mm, 29 / 49 teeth) quality 5-7 allows
``f_pt`` of about 6-12 um and ``F_p`` of 20-40 um (ISO 1328-1:1995 Table formulas). Following the
indexing-error model of Inalpolat, Handschuh and Kahraman (2015, Mech. Syst. Signal Process. 60-61,
"Influence of indexing errors on dynamic response of spur gear pairs"), each flank's position error
on the reference circle is

    p_i = r_i + A cos(2 pi i / z + phi),     i = 0 .. z - 1 (0-based tooth index, mesh.py),

``r_i`` independent and normal with standard deviation ``f_pt_um / sqrt(2)`` (so that the single
pitch deviation ``f_pt,i = p_i - p_(i-1)`` has RMS ``f_pt_um``) and a long-wave part of amplitude
``A = runout_um`` (the cumulative deviation's once-per-turn form; 0 by default: the random part only,
whose own cumulative deviation is what the draw gives). Projected on the line of action (the flank
moves along the base circle's tangent), the error is ``e_i = p_i cos(alpha)``.

In the mesh, pair ``n`` (pinion tooth ``n mod z1``, gear tooth ``n mod z2``, mesh.py) carries the
relative flank position ``e_n = e_p[n mod z1] + e_g[n mod z2]`` (positive: the flanks meet early, the
pair is compressed more), and each pair in the contact zone takes its own force

    F_el = sum_n k_n [d_m + e_n + gamma xi - b]_+ - [-(d_m + e_n + gamma xi) - b]_+     (model.py),

so a pair whose flank lags more than the others' deflection leaves contact on its own (per face slice
where the wheel is misaligned). With every ``e_n = 0`` this is the kernel's single deadzone on the
summed stiffness; the kernel runs that expression unchanged when no pitch errors are given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from lumped_gearbox.faults import check_range
from lumped_gearbox.mesh import deadzone, pair_shape

#: allowed ranges, um on the reference circle (quality 5-7 of the paper's wheels: f_pt 6-12 um)
F_PT_UM_MAX = 30.0
RUNOUT_UM_MAX = 50.0
WHEELS = ("both", "pinion", "gear")


@dataclass(frozen=True)
class PitchErrors:
    """Random flank positions of every tooth (module docstring).

    Attributes
    ----------
    f_pt_um : float
        RMS single pitch deviation of each wheel, um on the reference circle (``0 .. 30``).
    runout_um : float
        Amplitude of the once-per-turn part of the cumulative pitch deviation, um (``0 .. 50``).
    seed : int
        Seed of the draw (pinion first, then gear).
    wheels : {"both", "pinion", "gear"}
        Which wheels carry the errors.
    """

    f_pt_um: float = 0.0
    runout_um: float = 0.0
    seed: int = 0
    wheels: str = "both"

    def __post_init__(self) -> None:
        check_range("pitch_errors.f_pt_um", self.f_pt_um, 0.0, F_PT_UM_MAX)
        check_range("pitch_errors.runout_um", self.runout_um, 0.0, RUNOUT_UM_MAX)
        if self.wheels not in WHEELS:
            raise ValueError(f"pitch_errors.wheels: {self.wheels!r} not one of {', '.join(WHEELS)}")

    def positions_um(self, z1: int, z2: int) -> tuple[np.ndarray, np.ndarray]:
        """Flank position errors ``p_i`` of the pinion and the gear on the reference circle, um."""
        rng = np.random.default_rng(self.seed)
        out = []
        for wheel, z in (("pinion", z1), ("gear", z2)):
            r = rng.normal(0.0, self.f_pt_um / math.sqrt(2.0), z)
            phi = float(rng.uniform(0.0, 2.0 * math.pi))
            p = r + self.runout_um * np.cos(2.0 * math.pi * np.arange(z) / z + phi)
            out.append(p if self.wheels in ("both", wheel) else np.zeros(z))
        return out[0], out[1]

    def vector(self, z1: int, z2: int, pressure_angle_rad: float) -> np.ndarray:
        """The kernel's ``pitch`` array: ``e`` on the line of action (m), the pinion's ``z1``, then the
        gear's ``z2``."""
        pp, pg = self.positions_um(z1, z2)
        return np.concatenate([pp, pg]) * 1e-6 * math.cos(pressure_angle_rad)

    def truth(self, z1: int, z2: int) -> dict[str, Any]:
        """The draw for ``.truth.json``: per-tooth positions (um) and each wheel's ``f_pt`` and ``F_p``."""
        out: dict[str, Any] = {"f_pt_um": self.f_pt_um, "runout_um": self.runout_um, "seed": self.seed}
        out["wheels"] = self.wheels
        for name, p in zip(("pinion", "gear"), self.positions_um(z1, z2), strict=True):
            fpt = p - np.roll(p, 1)
            out[name] = {
                "position_um": [round(float(v), 4) for v in p],
                "single_pitch_max_um": float(np.max(np.abs(fpt))),
                "single_pitch_rms_um": float(np.sqrt(np.mean(fpt**2))),
                "cumulative_um": float(np.max(p) - np.min(p)),
            }
        return out


@njit(cache=True)
def pitch_mesh_force(u, dm, b, gam, face, n_slices, eps, relief, k_pair, tooth_p, tooth_g, pitch):
    """Elastic mesh force and stiffness-weighted contact fraction with per-pair flank errors.

    ``u`` mesh position (cycles), ``dm`` the mesh deflection without pitch errors, ``b`` the half
    backlash, ``gam`` the misalignment angle over the face ``face`` in ``n_slices`` slices (``gam = 0``:
    one slice), ``pitch`` the kernel array of :meth:`PitchErrors.vector`. Returns ``(F_el, f_c)``.
    """
    z1 = tooth_p.size
    z2 = tooth_g.size
    base = math.floor(u)
    k = 0.0
    fel = 0.0
    fc = 0.0
    ns = n_slices if gam != 0.0 else 1
    for back in range(3):
        n = int(base) - back
        g = pair_shape(u - n, eps, relief)
        if g > 0.0:
            ki = k_pair * g * tooth_p[n % z1] * tooth_g[n % z2]
            d = dm + pitch[n % z1] + pitch[z1 + n % z2]
            k += ki
            for j in range(ns):
                xi = (j / (ns - 1.0) - 0.5) * face if ns > 1 else 0.0
                f, c = deadzone(d + gam * xi, b)
                fel += ki * f / ns
                fc += ki * c / ns
    return fel, (fc / k if k > 0.0 else 0.0)
