"""Rolling-bearing kinematics and localised defects (outer race, inner race, rolling element).

Impulse trains at BPFO / BPFI / 2 BSF (from the bearing geometry) acting as a radial force at the
bearing node; inner-race and ball impacts amplitude-modulated by the load zone at the shaft and
the cage rate; 1-2 % random slip of the inter-impact interval (McFadden & Smith 1984; Antoni &
Randall 2002; Randall & Antoni 2011).
"""

from __future__ import annotations

import math
import warnings
import weakref
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from gear_rotor_sim.faults.base import Effect, ParameterSpec, node_xy_columns, shaft_index


@dataclass(frozen=True)
class BearingGeometry:
    """Rolling-element bearing geometry for defect frequencies.

    Attributes
    ----------
    n_balls : int
        Number of rolling elements.
    ball_diameter_m, pitch_diameter_m : float
        Rolling-element and pitch diameters, m.
    contact_angle_rad : float
        Contact angle (0 for a deep-groove ball bearing under radial load).
    name : str
        Designation, e.g. ``"6205"``.
    """

    n_balls: int
    ball_diameter_m: float
    pitch_diameter_m: float
    contact_angle_rad: float = 0.0
    name: str = ""

    def __post_init__(self) -> None:
        if self.n_balls < 3 or not 0 < self.ball_diameter_m < self.pitch_diameter_m:
            raise ValueError(f"bearing geometry: need n_balls >= 3 and 0 < d < D, got {self}")

    @property
    def _r(self) -> float:
        return self.ball_diameter_m / self.pitch_diameter_m * math.cos(self.contact_angle_rad)

    def multiples(self) -> dict[str, float]:
        """Defect frequencies as multiples of the shaft rate (inner ring rotating, outer fixed).

        ``ftf = (1 - r)/2``, ``bpfo = n (1 - r)/2``, ``bpfi = n (1 + r)/2``,
        ``bsf = D/(2 d) (1 - r^2)`` with ``r = d cos(alpha) / D`` (Harris & Kotzalas 2007, Ch. 8;
        Randall & Antoni 2011, Eq 1-4).
        """
        r = self._r
        n = self.n_balls
        return {
            "ftf": 0.5 * (1.0 - r),
            "bpfo": 0.5 * n * (1.0 - r),
            "bpfi": 0.5 * n * (1.0 + r),
            "bsf": self.pitch_diameter_m / (2.0 * self.ball_diameter_m) * (1.0 - r * r),
        }

    def frequencies_hz(self, shaft_hz: float) -> dict[str, float]:
        """Defect frequencies in Hz at a shaft rate in Hz."""
        return {k: v * shaft_hz for k, v in self.multiples().items()}

    def rolling_speed(self, omega: np.ndarray | float) -> np.ndarray | float:
        """Speed (m/s) at which a contact rolls over a point of the outer race, the inner race or a
        ball at shaft speed ``omega`` (rad/s): ``omega D (1 - r^2) / 4``, the same for the three.

        Outer race: the cage turns at ``omega (1 - r)/2`` and the contact runs on the race radius
        ``D (1 + r)/2``; inner race: ``omega (1 + r)/2`` relative to the cage on ``D (1 - r)/2``; ball:
        spin ``omega D/(2 d) (1 - r^2)`` on the ball radius ``d/2`` (rolling without slip).
        """
        r = self._r
        return np.abs(omega) * self.pitch_diameter_m * (1.0 - r * r) / 4.0


#: Nominal spall width (m) of a localised defect: the transit time of a ball over it is the impact
#: duration. 0.35 mm gives 0.10 ms on the 6206 at 3000 rpm (the fixed pulse of earlier versions at
#: the paper gearbox's contact point); seeded and early natural spalls are 0.2-0.5 mm.
SPALL_WIDTH_M = 0.35e-3

INCH = 0.0254
# SKF 6205-2RS JEM (CWRU README): 9 balls, d = 0.3126 in, D = 1.537 in.
BEARING_6205 = BearingGeometry(9, 0.3126 * INCH, 1.537 * INCH, 0.0, "6205")
# SKF 6206 (30 mm bore, the paper gearbox's 30 mm shafts): 9 balls of 9.525 mm on a 46 mm pitch circle.
BEARING_6206 = BearingGeometry(9, 9.525e-3, 46.0e-3, 0.0, "6206")


def static_bearing_force(system: Any, bearing: int) -> np.ndarray:
    """Static force of a bearing on the housing, (3,) x/y/z, N, from the model's quasi-static solution.

    ``K_b q_node`` (the bearing force of Eq 37 at rest) with ``q`` the quasi-static displacement of
    every mesh engaged on its drive flank (:func:`gear_rotor_sim.system.static_solution`, Eqs 21-26:
    load torque, mesh force along the line of action, thermal loads at the system's temperature).
    On the paper gearbox at 25 C, bearing 2 (input shaft, node 9) carries half the mesh force
    ``T2 / r_bg = 2896 N``, i.e. 1448 N at -110 deg: the force ``-n F_m`` on the pinion,
    ``n = (sin 20 deg, cos 20 deg)``, shared by the two bearings of a pinion at mid-span. The model
    holds no weight (the paper's Eq 39 has no gravity term).
    """
    from gear_rotor_sim.system import static_solution

    site = system.bearings[bearing - 1]
    i = 6 * int(site.node0)
    with warnings.catch_warnings():  # a rig without a load torque has no engaged mesh: no radial load
        warnings.simplefilter("ignore")
        q = static_solution(system)
    return np.asarray(site.stiffness, float)[:3] @ q[i : i + 6]


#: static load angles per assembled system: id -> (weak reference, {bearing: angle}); the weak
#: reference guards against a reused id, and nothing here is pickled with an effect
_LOAD_ANGLES: dict[int, tuple[Any, dict[int, float]]] = {}


def static_load_angle(system: Any, bearing: int, default: float = -0.5 * math.pi) -> float:
    """Direction (rad, in the x-y plane) of a bearing's static radial force on the housing: the centre
    of its load zone (:func:`static_bearing_force`; memoised per system, 8 ms per solve).

    ``default`` (downward, the direction of the rotor's weight) where the model holds no radial static
    load at that bearing, e.g. a rig without a mesh such as the CWRU motor: its radial static force is
    zero to round-off (below ``1e-9`` of the largest static load entry, N or N m).
    """
    hit = _LOAD_ANGLES.get(id(system))
    if hit is None or hit[0]() is not system:
        if len(_LOAD_ANGLES) > 64:
            _LOAD_ANGLES.clear()
        hit = (weakref.ref(system), {})
        _LOAD_ANGLES[id(system)] = hit
    angle = hit[1].get(bearing)
    if angle is None:
        f = static_bearing_force(system, bearing)
        scale = float(np.max(np.abs(np.asarray(system.static_load, float)), initial=0.0))
        radial = math.hypot(f[0], f[1])
        angle = math.atan2(f[1], f[0]) if radial > 1e-9 * max(scale, 1.0) else default
        hit[1][bearing] = angle
    return angle


def load_zone(
    angle_rad: np.ndarray, load_angle_rad: float, extent: float = 0.5, exponent: float = 1.5
) -> np.ndarray:
    """Stribeck/Harris load distribution ``(1 - (1 - cos psi) / (2 extent))^n``, 0 outside the zone.

    ``psi`` is the angle from the load direction; ``extent = 0.5`` is the half-loaded zone of a
    radially loaded bearing with zero clearance, ``n = 1.5`` for ball bearings (Harris & Kotzalas
    2007, Eq 7.26).
    """
    psi = np.asarray(angle_rad) - load_angle_rad
    q = 1.0 - (1.0 - np.cos(psi)) / (2.0 * extent)
    return np.where(q > 0, np.abs(q) ** exponent, 0.0)


@dataclass(frozen=True)
class BearingDefect(Effect):
    """Localised defect in a rolling bearing: radial impulse train at the bearing node.

    Impacts occur when the defect phase ``m theta / 2 pi`` (``m`` the defect multiple of the shaft
    rate, ``theta`` the shaft angle) passes the impact instants, whose spacing is ``1 + slip xi_k``
    with ``xi_k`` standard normal (random slip; Antoni & Randall 2002). Each impact is a half-sine
    force pulse and peak ``force_n`` times the load-zone factor at the defect's position, directed
    radially at that position. The pulse lasts the transit time of a ball over the spall,
    ``spall_width_m / v`` with ``v`` the rolling speed (:meth:`BearingGeometry.rolling_speed`; Sawalhi
    & Randall 2008 model the entry and exit of the ball over the spall the same way), so it shortens
    as the speed rises (0.10 ms at 3000 rpm, 0.038 ms at 8000 rpm on the 6206); ``pulse_s`` fixes
    the duration instead. Where the pulse is shorter than the sampling interval only its impulse is
    observed, and a fixed 0.1 ms pulse read an impact of the true transit time at 8000 rpm as half
    its peak force (docs/history/calibration_sessions.md Sec. 8.9):

    * outer race: fixed at ``defect_angle_rad``; BPFO; no modulation;
    * inner race: rotates with the shaft (``theta + defect_angle_rad``); BPFI; load-zone
      modulation at the shaft rate;
    * ball: spins at BSF and strikes both races (2 BSF); carried by the cage (angle
      ``FTF theta + defect_angle_rad``): modulation at the cage rate.

    Parameters
    ----------
    kind : str
        ``"outer"``, ``"inner"`` or ``"ball"``.
    bearing : int
        1-based bearing (paper numbering).
    force_n : float
        Peak impact force, N.
    geometry : BearingGeometry
        For the defect frequencies.
    slip : float
        Relative standard deviation of the inter-impact interval (0.01-0.02 in real bearings). A
        calibration fits it on the defect's direct path (``calibration.candidates_bearing.fit_slip``,
        docs/history/calibration_sessions.md Sec. 8.36).
    load_angle_rad : float, optional
        Direction of the bearing load (centre of the load zone) in the x-y plane, rad. Default: the
        direction of the bearing's static force on the housing in the model the defect acts on
        (:func:`static_load_angle`: mesh force along the line of action, shared by the shaft's
        bearings; -110 deg at bearing 2 of the paper gearbox, +70 deg at bearing 3), computed from the
        model at its own temperature, never from a record; -90 deg where the model has no radial static
        load (a rig without a mesh).
    defect_angle_rad : float
        Outer race: defect position; inner race/ball: position at shaft angle 0.
    pulse_s : float, optional
        Impact duration, s (default: the transit time over ``spall_width_m``).
    spall_width_m : float
        Width of the spall along the rolling direction, m (sets the impact duration).
    seed : int
        Seed of the slip sequence (reproducible).
    shaft_path_share : float
        Share of the impact's reaction that acts on the shaft (:meth:`force_amplitudes`), 1 the full
        internal pair. A calibration nuisance, not a finding: the race's share reaches a force sensor
        under the bearing directly, the shaft's through the shaft-bearing dynamics in the kHz band,
        which a model knows least (docs/history/calibration_sessions.md Sec. 8.30;
        ``calibration/candidates_bearing.py``).
    """

    kind: str = "outer"
    bearing: int = 1
    force_n: float = 0.0
    geometry: BearingGeometry = BEARING_6206
    slip: float = 0.015
    load_angle_rad: float | None = None
    defect_angle_rad: float = -0.5 * math.pi
    pulse_s: float | None = None
    seed: int = 0
    spall_width_m: float = SPALL_WIDTH_M
    shaft_path_share: float = 1.0
    _cache: dict = field(default_factory=dict, compare=False, repr=False)
    name: ClassVar[str] = "bearing_defect"
    signature: ClassVar[str] = (
        "envelope-spectrum lines at the defect frequency and harmonics (+- modulation sidebands)"
    )
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("force_n", "N", 0.0, 5.0e4, "amplitude", "peak impact force"),
    )
    KINDS: ClassVar[dict[str, str]] = {"outer": "bpfo", "inner": "bpfi", "ball": "bsf"}

    def __post_init__(self) -> None:
        if self.kind not in self.KINDS:
            raise ValueError(f"kind: {self.kind!r} is not one of {list(self.KINDS)}")
        if self.pulse_s is not None and not self.pulse_s > 0:
            raise ValueError(f"pulse_s: must be positive (s), got {self.pulse_s!r}")
        if not self.spall_width_m > 0:
            raise ValueError(f"spall_width_m: must be positive (m), got {self.spall_width_m!r}")
        if not 0.0 <= self.shaft_path_share <= 1.0:
            raise ValueError(f"shaft_path_share: must lie in [0, 1], got {self.shaft_path_share!r}")

    @property
    def label(self) -> str:
        return (
            f"{self.kind}_race_defect@bearing{self.bearing}"
            if self.kind != "ball"
            else (f"ball_defect@bearing{self.bearing}")
        )

    @property
    def effect_name(self) -> str:
        return "ball_defect" if self.kind == "ball" else f"{self.kind}_race_defect"

    def impact_multiple(self) -> float:
        """Impacts per shaft revolution."""
        m = self.geometry.multiples()
        return 2.0 * m["bsf"] if self.kind == "ball" else m[self.KINDS[self.kind]]

    def _node0(self, system: Any) -> int:
        return int(system.bearings[self.bearing - 1].node0)

    def key_frequencies_hz(self, shaft_hz: float, harmonics: int = 2) -> list[float]:
        """The characteristic envelope lines: first harmonics of BPFO, BPFI or 2 BSF."""
        f = self.impact_multiple() * shaft_hz
        return [h * f for h in range(1, harmonics + 1)]

    def impact_duration(self, shaft_rad_s: float) -> float:
        """Duration (s) of one impact at shaft speed ``shaft_rad_s``: ``pulse_s``, else the transit time
        of the rolling contact over the spall, ``spall_width_m / v``."""
        if self.pulse_s is not None:
            return float(self.pulse_s)
        return self.spall_width_m / max(float(self.geometry.rolling_speed(abs(shaft_rad_s))), 1e-9)

    def impulse(self, shaft_rad_s: float) -> float:
        """Impulse (N s) of one full-load impact, ``2 force_n tau / pi`` (half-sine of duration tau).

        Below about ``1 / (2 tau)`` (4-5 kHz at 0.1 ms) the spectrum of an impact is its impulse, so
        an envelope analysed there identifies ``force_n tau`` and not the peak force alone: the
        fitted ``force_n`` is the peak force of the identified impulse over the nominal spall
        (``spall_width_m``), and a real spall of width ``w`` had a peak force
        ``force_n * spall_width_m / w`` (docs/history/calibration_sessions.md Sec. 8.13)."""
        return 2.0 / math.pi * self.force_n * self.impact_duration(shaft_rad_s)

    def _instants(self, upto: float) -> np.ndarray:
        """Impact instants in defect-phase units (cumulative, seeded), at least up to ``upto``."""
        key = ("instants", self.seed, self.slip)
        arr = self._cache.get(key)
        if arr is None or arr[-1] < upto + 2:
            n = int(max(upto, 1.0) * 1.3 + 64)
            rng = np.random.default_rng(self.seed)
            steps = 1.0 + self.slip * rng.standard_normal(n)
            arr = np.concatenate([[0.25], 0.25 + np.cumsum(np.maximum(steps, 0.2))])
            self._cache[key] = arr
        return arr

    def load_angle(self, system: Any) -> float:
        """Centre of the load zone in ``system``: ``load_angle_rad`` if given, else
        :func:`static_load_angle` of this bearing in this system."""
        if self.load_angle_rad is not None:
            return float(self.load_angle_rad)
        return static_load_angle(system, self.bearing)

    def external_forces(self, system: Any) -> np.ndarray | None:
        return node_xy_columns(system, self._node0(system))

    def force_amplitudes(self, ctx: Any) -> np.ndarray | None:
        """Force on the shaft at the bearing node: the reaction of :meth:`impact_force` (inward), times
        ``shaft_path_share``."""
        f = self.impact_force(ctx)
        return -self.shaft_path_share * f

    def impact_force(self, ctx: Any) -> np.ndarray:
        """Impact force on the race that carries the defect's far edge, pushed outward into the
        housing, (n, 2) x/y, N.

        The impact is an internal force pair of the bearing: the outer ring (a thin ring seated in
        the housing) passes this force straight to the housing and to a force sensor under it,
        while the shaft receives the opposite force (:meth:`force_amplitudes`) and answers through
        its own dynamics. The measured bearing force is the sum of both paths
        (``calibration.residual.add_direct_bearing_forces``); quasi-statically they cancel (an
        internal pair exerts no net force), above the shaft-bearing resonances the direct path
        dominates.
        """
        system = ctx.system
        s = shaft_index(system, self._node0(system))
        theta = np.abs(ctx.shaft_angle[:, s])
        omega = np.abs(ctx.shaft_speed[:, s])
        mult = self.impact_multiple()
        phase = mult * theta / (2.0 * math.pi)  # defect phase in impacts
        inst = self._instants(float(phase.max()) if phase.size else 1.0)
        k = np.searchsorted(inst, phase, side="right") - 1
        valid = k >= 0
        rate = np.maximum(mult * omega / (2.0 * math.pi), 1e-9)  # impacts per second
        duration = (
            self.pulse_s
            if self.pulse_s is not None
            else self.spall_width_m / np.maximum(self.geometry.rolling_speed(omega), 1e-9)
        )
        width = duration * rate  # pulse width in phase units
        since = np.where(valid, phase - inst[np.maximum(k, 0)], np.inf)
        pulse = np.where(since < width, np.sin(math.pi * np.clip(since / width, 0, 1)), 0.0)
        # position of the defect at the impact
        if self.kind == "outer":
            pos = np.full_like(theta, self.defect_angle_rad)
            amp = np.ones_like(theta)
        else:
            rot = theta if self.kind == "inner" else self.geometry.multiples()["ftf"] * theta
            pos = rot + self.defect_angle_rad
            amp = load_zone(pos, self.load_angle(system))
        f = self.force_n * pulse * amp
        return np.column_stack([f * np.cos(pos), f * np.sin(pos)])


def outer_race_defect(**kw: Any) -> BearingDefect:
    return BearingDefect(kind="outer", **kw)


def inner_race_defect(**kw: Any) -> BearingDefect:
    return BearingDefect(kind="inner", **kw)


def ball_defect(**kw: Any) -> BearingDefect:
    return BearingDefect(kind="ball", **kw)
