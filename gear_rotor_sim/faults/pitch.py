"""Manufacturing pitch deviations of every tooth: a per-tooth static transmission error (issue 11).

No wheel is cut exactly. ISO 1328-1 grades a wheel by its single pitch deviation ``f_pt`` (the
difference between the actual and the nominal spacing of two neighbouring flanks on the reference
circle) and its cumulative pitch deviation ``F_p`` (the spread of the flanks' positions round the wheel).
A flank ``p_j`` ahead of its nominal position (measured along the line of action) meets its mate early:
the pair carries the elastic deflection ``delta + p_j`` at the rigid-body approach ``delta``. The pairs in
contact act in parallel (Sun et al. 2021, Eq 14: the mesh stiffness is the sum of the pairs'), so at the
mesh force ``F = sum_n k_n (delta + p_n)`` the mesh sees the stiffness-weighted mean of the pairs' flank
positions, ``e = -sum_n lambda_n p_n`` with ``lambda_n = k_n / sum k`` (Inalpolat, Handschuh & Kahraman 2015,
Mech. Syst. Signal Process. 60-61, indexing errors of spur gear pairs; Velex & Maatar 1996 for the
transmission error as an excitation), which enters the model as ``delta_m = delta - e`` (Eqs 24-25): in the
quasi-static limit the DTE is ``F / k - sum_n lambda_n p_n`` (flanks ahead: the pairs meet at a smaller
approach).

Pair ``n`` (mesh cycles counted from time 0, as :class:`~gear_rotor_sim.faults.gear.ToothDamage`) is
pinion tooth ``n mod z_p`` and gear tooth ``n mod z_g`` (0-based), and carries ``p_n = pinion[n mod z_p] +
gear[n mod z_g]``. Its share ``lambda_n`` is the one the library's tooth damage uses
(:func:`~gear_rotor_sim.faults.gear.tooth_share`: a half in the double-contact zones, all of it in single
contact), so that a pitch deviation and a damaged tooth of one wheel are engaged over the same angles.
The effect holds the flanks in contact (linear in the deviations); where a flank lags by more than the
pair's deflection that pair leaves contact on its own, which this form does not follow (the independent
generator does, ``lumped_gearbox/pitch.py``).

The deviations are a baseline of the machine (its wheels as cut), never a fault: the calibration reads
them from the record's synchronous averages (``calibration/pitch_pattern.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from gear_rotor_sim.config import RigConfig
from gear_rotor_sim.faults.base import Effect
from gear_rotor_sim.faults.gear import check_mesh, on_mesh


def share_antiderivative(s: np.ndarray, contact_ratio: float) -> np.ndarray:
    """Integral over ``[0, s]`` (mesh cycles) of one pair's share of the mesh stiffness
    (:func:`~gear_rotor_sim.faults.gear.tooth_share`: 1/2 on ``[0, eps - 1)``, 1 on ``[eps - 1, 1)``, 1/2 on
    ``[1, eps)``, 0 elsewhere); 0 below ``s = 0`` and 1 (the pair's whole engagement) above ``eps``."""
    eps = float(np.clip(contact_ratio, 1.0, 2.0))
    x = np.clip(np.asarray(s, dtype=float), 0.0, eps)
    a = 0.5 * np.minimum(x, eps - 1.0)
    a += np.clip(x - (eps - 1.0), 0.0, 2.0 - eps)
    a += 0.5 * np.clip(x - 1.0, 0.0, eps - 1.0)
    return a


def flank_position(
    u: np.ndarray, width: np.ndarray, pinion: np.ndarray, gear: np.ndarray, eps: float
) -> np.ndarray:
    """Stiffness-weighted mean flank position ``sum_n lambda_n p_n`` of the pairs in contact (m), averaged
    over ``[u - width/2, u + width/2]`` (mesh cycles; exact for the piecewise-constant shares, the point
    value where ``width`` is 0).

    Parameters
    ----------
    u : numpy.ndarray
        Mesh position, cycles counted from time 0 (pair ``n`` enters at ``u = n``).
    width : numpy.ndarray
        Averaging width, cycles (one integration step; 0 for the point value).
    pinion, gear : numpy.ndarray
        Flank positions of the pinion's ``z_p`` and the gear's ``z_g`` teeth, m (0-based tooth index).
    eps : float
        Contact ratio.
    """
    u = np.asarray(u, dtype=float)
    w = np.broadcast_to(np.asarray(width, dtype=float), u.shape)
    lo, hi = u - 0.5 * w, u + 0.5 * w
    zp, zg = pinion.size, gear.size
    top = np.floor(hi).astype(np.int64)
    total = np.zeros(u.shape)
    point = np.zeros(u.shape)
    wide = w > 1e-12
    for back in range(4):  # pairs entered within the last eps (<= 2) cycles of the interval's ends
        n = top - back
        p = pinion[np.mod(n, zp)] + gear[np.mod(n, zg)]
        total += p * (share_antiderivative(hi - n, eps) - share_antiderivative(lo - n, eps))
        s = u - n
        engaged = (s >= 0.0) & (s < eps)
        double = engaged & ((s < eps - 1.0) | (s >= 1.0))
        point += p * np.where(double, 0.5, np.where(engaged, 1.0, 0.0))
    return np.where(wide, total / np.where(wide, w, 1.0), point)


@dataclass(frozen=True)
class PitchDeviation(Effect):
    """Flank positions of every tooth of both wheels of a mesh (ISO 1328-1 pitch deviations).

    Parameters
    ----------
    pinion_m, gear_m : tuple of float
        Position of each flank along the line of action, m, positive ahead of nominal (0-based tooth index:
        tooth ``i`` of :class:`~gear_rotor_sim.faults.gear.ToothDamage` is index ``i - 1``). Empty: exact
        teeth on that wheel. A common offset of every flank of a wheel moves the DTE's mean only.
    mesh : int
        1-based mesh.
    """

    pinion_m: tuple[float, ...] = ()
    gear_m: tuple[float, ...] = ()
    mesh: int = 1
    name: ClassVar[str] = "pitch_deviation"
    signature: ClassVar[str] = (
        "each wheel's tooth-by-tooth pattern in its synchronous average: every shaft order of the wheel and "
        "the mesh sidebands, independent of the load"
    )

    def applicable(self, cfg: RigConfig) -> bool:
        return check_mesh(cfg, self.mesh)

    @property
    def label(self) -> str:
        return "pitch_deviation" if self.mesh == 1 else f"pitch_deviation@mesh{self.mesh}"

    def parameters(self) -> dict[str, float]:
        """Each wheel's RMS single pitch deviation ``f_pt`` and cumulative deviation ``F_p`` (ISO 1328-1),
        m, on the line of action."""
        out = {}
        for wheel, p in (("pinion", self.pinion_m), ("gear", self.gear_m)):
            a = np.asarray(p, dtype=float)
            single = a - np.roll(a, 1) if a.size else np.zeros(1)
            out[f"{wheel}_single_pitch_rms_m"] = float(np.sqrt(np.mean(single**2)))
            out[f"{wheel}_cumulative_m"] = float(np.ptp(a)) if a.size else 0.0
        return out

    def positions(self, system: Any) -> tuple[np.ndarray, np.ndarray]:
        """Both wheels' flank positions (m) as arrays of their tooth counts (zeros where not given)."""
        m = system.meshes[self.mesh - 1]
        out = []
        for vals, z in ((self.pinion_m, int(m.pinion_teeth)), (self.gear_m, int(m.gear_teeth))):
            a = np.asarray(vals, dtype=float)
            if a.size == 0:
                a = np.zeros(z)
            if a.size != z:
                raise ValueError(f"pitch_deviation: {a.size} flank positions for a wheel of {z} teeth")
            out.append(a)
        return out[0], out[1]

    def transmission_error(self, ctx: Any) -> np.ndarray | None:
        """``e = -sum_n lambda_n p_n`` (module docstring), averaged over each integration step so that a
        share's jump keeps its place inside the step (as the sliding wear,
        :func:`~gear_rotor_sim.faults.gear.step_average_periodic`)."""
        m = ctx.system.meshes[self.mesh - 1]
        pinion, gear = self.positions(ctx.system)
        theta = np.abs(np.asarray(ctx.shaft_angle, dtype=float)[:, m.pinion_shaft])
        u = m.pinion_teeth * theta / (2.0 * math.pi)
        t = np.asarray(ctx.t, dtype=float)
        speed = np.abs(np.asarray(ctx.shaft_speed, dtype=float)[:, m.pinion_shaft])
        dt = np.gradient(t) if t.size > 1 else np.zeros(t.size)
        width = m.pinion_teeth * speed * dt / (2.0 * math.pi)
        eps = float(m.contact_ratio)
        return on_mesh(ctx, self.mesh, -flank_position(u, width, pinion, gear, eps), 0.0)
