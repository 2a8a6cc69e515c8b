"""The effect library: physical model terms that the calibration can add to the model.

Every effect implements the simulator's ``Effect`` protocol (``docs/design.md``): it may multiply
the mesh stiffness, add to the static transmission error, apply forces (fixed DOF vectors times
per-step amplitudes) or modify the configuration. Effects also declare their fitted parameters with
bounds and units, and a predicted signature (where in the residual they show). Operating-point
effects (a temperature different from the declared one) additionally implement
``operating_point(speed_rpm, temperature_c)``, used by the calibration's model runner.

Models (details and references in ``docs/calibration.md``):

* ``pinion_eccentricity`` / ``gear_eccentricity``: geometric run-out ``e`` of the pitch circle adds
  ``e sin(theta_s + phi)`` to the transmission error (shaft order 1 of that gear and sidebands of the
  mesh orders) and the rotating force ``m_g e Omega_s^2`` of the displaced gear mass at its node
  (Randall 2011, Sec 2.2.1; Mohammed et al. 2009).
* ``mass_unbalance``: rotating force ``U Omega^2 (cos(theta+phi), sin(theta+phi))`` at a node
  (ISO 21940-11), ``U = m e`` in kg m.
* ``shaft_misalignment``: parallel offset ``delta`` at the coupling of the driven shaft, represented
  as the reaction ``k_c delta`` of a flexible coupling that rotates at twice the shaft speed (the
  2x order that characterises misalignment; Sekhar & Prabhu 1995, J. Sound Vib. 185(4) 655-671;
  Redmond 2010). One fitted parameter: the offset; the coupling lateral stiffness is fixed.
* ``tooth_damage``: a root crack or chipped tooth on pinion tooth ``i`` lowers the mesh stiffness
  by the fraction ``depth`` of that tooth's share while it is engaged (Chaari et al. 2009; Mohammed
  et al. 2009): once-per-pinion-revolution modulation, sidebands around the mesh orders.
* ``tooth_wear``: uniform wear depth ``h``: the half backlash grows by ``h`` and a profile error
  that is zero at the pitch point and grows towards root and tip with the sliding distance (Archard
  wear; Flodin & Andersson 1997) adds ``h (|2 p - 1| - 1/2)`` to the transmission error over each
  mesh cycle (phase ``p``): odd mesh harmonics.
* ``temperature_offset``: the machine runs ``dT`` warmer than declared (Sun et al. 2021: E(T),
  thermal deformation, backlash and profile error all change with T).
* ``mesh_stiffness_damping``: scale of the mesh stiffness and of the mesh damping ratio.
* ``outer_race_defect`` / ``inner_race_defect`` / ``ball_defect``: localised rolling-bearing defect:
  impulse trains at BPFO / BPFI / 2 BSF (from the bearing geometry) acting as a radial force at
  the bearing node; inner-race and ball impacts amplitude-modulated by the load zone at the shaft
  and the cage rate; 1-2 % random slip of the inter-impact interval (McFadden & Smith 1984; Antoni
  & Randall 2002; Randall & Antoni 2011).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from gear_rotor_sim.config import RigConfig

# ---------------------------------------------------------------------------------------------------
# Bearing kinematics
# ---------------------------------------------------------------------------------------------------


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


INCH = 0.0254
# SKF 6205-2RS JEM (CWRU README): 9 balls, d = 0.3126 in, D = 1.537 in.
BEARING_6205 = BearingGeometry(9, 0.3126 * INCH, 1.537 * INCH, 0.0, "6205")
# SKF 6206 (30 mm bore, the paper gearbox's 30 mm shafts): 9 balls of 9.525 mm on a 46 mm pitch circle.
BEARING_6206 = BearingGeometry(9, 9.525e-3, 46.0e-3, 0.0, "6206")


# ---------------------------------------------------------------------------------------------------
# Parameters and the base class
# ---------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ParameterSpec:
    """A fitted parameter: name, unit, bounds, and how the fit treats it.

    ``role`` is ``"amplitude"`` (enters linearly through a basis response), ``"phase"`` (paired
    with the amplitude through a cos/sin basis), ``"scalar"`` (nonlinear, fitted on a grid then
    refined) or ``"index"`` (integer, searched exhaustively).
    """

    name: str
    unit: str
    lower: float
    upper: float
    role: str = "scalar"
    description: str = ""


def _node_xy(system: Any, node0: int) -> np.ndarray:
    cols = np.zeros((system.ndof, 2))
    cols[6 * node0, 0] = 1.0
    cols[6 * node0 + 1, 1] = 1.0
    return cols


def _shaft_index(system: Any, node0: int) -> int:
    return int(np.asarray(system.shaft_of_node)[node0])


@dataclass(frozen=True)
class Effect:
    """Base of the library: parameter bookkeeping and the protocol's neutral defaults."""

    name: ClassVar[str] = "effect"
    signature: ClassVar[str] = ""
    specs: ClassVar[tuple[ParameterSpec, ...]] = ()

    @property
    def label(self) -> str:
        """Name plus the fixed location (e.g. ``outer_race_defect@bearing2``)."""
        return self.name

    def parameters(self) -> dict[str, float]:
        """Current values of the fitted parameters."""
        return {s.name: float(getattr(self, s.name)) for s in self.specs}

    def with_parameters(self, **values: float) -> Effect:
        """Copy with parameters replaced (clipped to bounds; index parameters rounded)."""
        changes: dict[str, Any] = {}
        for s in self.specs:
            if s.name in values:
                v = float(np.clip(values[s.name], s.lower, s.upper))
                changes[s.name] = round(v) if s.role == "index" else v
        return dataclasses.replace(self, **changes)

    def applicable(self, cfg: RigConfig) -> bool:
        """Whether the effect makes sense for the rig (e.g. gear effects need a mesh)."""
        return True

    def main_parameter(self) -> str:
        """The parameter compared with the truth in the self-test (amplitude-like)."""
        return self.specs[0].name

    # Effect protocol (docs/design.md); neutral defaults
    def mesh_stiffness_factor(self, ctx: Any) -> np.ndarray | None:
        return None

    def transmission_error(self, ctx: Any) -> np.ndarray | None:
        return None

    def external_forces(self, system: Any) -> np.ndarray | None:
        return None

    def force_amplitudes(self, ctx: Any) -> np.ndarray | None:
        return None

    def modify_config(self, cfg: RigConfig) -> RigConfig:
        return cfg

    def operating_point(self, speed_rpm: float, temperature_c: float) -> tuple[float, float]:
        """Actual operating point given the declared one (only temperature_offset changes it)."""
        return speed_rpm, temperature_c


# ---------------------------------------------------------------------------------------------------
# Gear and shaft effects
# ---------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class GearEccentricity(Effect):
    """Geometric eccentricity (run-out) of the pinion or the gear.

    Transmission error ``e sin(theta_s + phi)`` along the line of action, plus the rotating inertia
    force ``m_g e Omega_s^2`` of the gear body displaced by ``e``.

    Parameters
    ----------
    member : str
        ``"pinion"`` or ``"gear"`` (the mesh's pinion/gear).
    eccentricity_m : float
        Run-out e, m.
    phase_rad : float
        Angular position of the high point at shaft angle 0, rad.
    """

    member: str = "pinion"
    eccentricity_m: float = 0.0
    phase_rad: float = 0.0
    name: ClassVar[str] = "eccentricity"
    signature: ClassVar[str] = (
        "shaft order 1 of the eccentric gear; sidebands +-1 order around the mesh orders"
    )
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("eccentricity_m", "m", 0.0, 200e-6, "amplitude", "pitch-circle run-out"),
        ParameterSpec("phase_rad", "rad", -math.pi, math.pi, "phase", "high point at shaft angle 0"),
    )

    @property
    def label(self) -> str:
        return f"{self.member}_eccentricity"

    def applicable(self, cfg: RigConfig) -> bool:
        return bool(cfg.meshes)

    def _gear(self, system: Any) -> tuple[int, int]:
        m = system.meshes[0]
        return (m.pinion_node0, m.pinion_shaft) if self.member == "pinion" else (m.gear_node0, m.gear_shaft)

    def transmission_error(self, ctx: Any) -> np.ndarray | None:
        _, shaft = self._gear(ctx.system)
        theta = np.abs(ctx.shaft_angle[:, shaft])
        return self.eccentricity_m * np.sin(theta + self.phase_rad)

    def external_forces(self, system: Any) -> np.ndarray | None:
        node0, _ = self._gear(system)
        return _node_xy(system, node0)

    def force_amplitudes(self, ctx: Any) -> np.ndarray | None:
        node0, shaft = self._gear(ctx.system)
        mass = float(np.asarray(ctx.system.M)[6 * node0, 6 * node0])
        th = ctx.shaft_angle[:, shaft] + self.phase_rad
        f = mass * self.eccentricity_m * ctx.shaft_speed[:, shaft] ** 2
        return np.column_stack([f * np.cos(th), f * np.sin(th)])


@dataclass(frozen=True)
class MassUnbalance(Effect):
    """Mass unbalance ``U = m e`` at a node: rotating force ``U Omega^2`` (ISO 21940-11).

    Parameters
    ----------
    node : int
        1-based node (Fig 5 numbering).
    unbalance_kg_m : float
        Unbalance U, kg m.
    phase_rad : float
        Angle of the heavy spot at shaft angle 0, rad.
    """

    node: int = 5
    unbalance_kg_m: float = 0.0
    phase_rad: float = 0.0
    name: ClassVar[str] = "mass_unbalance"
    signature: ClassVar[str] = (
        "shaft order 1 of the unbalanced shaft, forward whirl, growing with speed squared"
    )
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("unbalance_kg_m", "kg m", 0.0, 1e-3, "amplitude", "m e"),
        ParameterSpec("phase_rad", "rad", -math.pi, math.pi, "phase", "heavy spot at shaft angle 0"),
    )

    @property
    def label(self) -> str:
        return f"mass_unbalance@node{self.node}"

    def external_forces(self, system: Any) -> np.ndarray | None:
        return _node_xy(system, self.node - 1)

    def force_amplitudes(self, ctx: Any) -> np.ndarray | None:
        s = _shaft_index(ctx.system, self.node - 1)
        th = ctx.shaft_angle[:, s] + self.phase_rad
        f = self.unbalance_kg_m * ctx.shaft_speed[:, s] ** 2
        return np.column_stack([f * np.cos(th), f * np.sin(th)])


@dataclass(frozen=True)
class ShaftMisalignment(Effect):
    """Parallel misalignment at a flexible coupling: reaction ``k_c delta`` rotating at 2x.

    Parameters
    ----------
    node : int
        1-based coupling node (default the drive node 1).
    offset_m : float
        Parallel offset delta, m.
    phase_rad : float
        Phase of the 2x reaction at shaft angle 0, rad.
    coupling_stiffness_n_per_m : float
        Lateral stiffness of the coupling (fixed, not fitted).
    """

    node: int = 1
    offset_m: float = 0.0
    phase_rad: float = 0.0
    coupling_stiffness_n_per_m: float = 1.0e6
    name: ClassVar[str] = "shaft_misalignment"
    signature: ClassVar[str] = "shaft order 2 (and its growth with the coupling stiffness), no 1x"
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("offset_m", "m", 0.0, 2e-3, "amplitude", "parallel offset at the coupling"),
        ParameterSpec("phase_rad", "rad", -math.pi, math.pi, "phase", "phase of the 2x reaction"),
    )

    @property
    def label(self) -> str:
        return f"shaft_misalignment@node{self.node}"

    def external_forces(self, system: Any) -> np.ndarray | None:
        return _node_xy(system, self.node - 1)

    def force_amplitudes(self, ctx: Any) -> np.ndarray | None:
        s = _shaft_index(ctx.system, self.node - 1)
        th = 2.0 * ctx.shaft_angle[:, s] + self.phase_rad
        f = self.coupling_stiffness_n_per_m * self.offset_m
        return np.column_stack([f * np.cos(th), f * np.sin(th)])


def tooth_share(u: np.ndarray, tooth0: int, teeth: int, contact_ratio: float) -> np.ndarray:
    """Share of the mesh stiffness carried by one pinion tooth.

    ``u`` is the pinion position in mesh cycles (``z_p theta_p / 2 pi``); tooth ``j`` (0-based)
    engages over ``j <= u mod z_p < j + eps``. It carries half the stiffness in the double-contact
    zones (first and last ``eps - 1`` cycles) and all of it in single contact.
    """
    eps = float(np.clip(contact_ratio, 1.0, 2.0))
    s = np.mod(u - tooth0, teeth)
    share = np.zeros_like(s)
    engaged = s < eps
    double = engaged & ((s < eps - 1.0) | (s >= 1.0))
    share[engaged] = 1.0
    share[double] = 0.5
    return share


@dataclass(frozen=True)
class ToothDamage(Effect):
    """Localised tooth damage (root crack, chipped tooth) on one pinion tooth.

    The mesh stiffness is multiplied by ``1 - depth * share_i(t)`` where ``share_i`` is the part of
    the mesh stiffness carried by tooth ``i`` (see :func:`tooth_share`).

    Parameters
    ----------
    tooth : int
        1-based pinion tooth; tooth 1 engages first after pinion angle 0.
    depth : float
        Fraction of that tooth's stiffness lost (0 = healthy, 1 = tooth missing).
    """

    tooth: int = 1
    depth: float = 0.0
    name: ClassVar[str] = "tooth_damage"
    signature: ClassVar[str] = (
        "once per pinion revolution impulse: many pinion orders, sidebands at the mesh orders"
    )
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("depth", "1", 0.0, 0.9, "scalar", "fraction of the tooth's stiffness lost"),
        ParameterSpec("tooth", "1", 1, 200, "index", "damaged pinion tooth, 1-based"),
    )

    def applicable(self, cfg: RigConfig) -> bool:
        return bool(cfg.meshes)

    def mesh_stiffness_factor(self, ctx: Any) -> np.ndarray | None:
        m = ctx.system.meshes[0]
        u = m.pinion_teeth * np.abs(ctx.shaft_angle[:, m.pinion_shaft]) / (2.0 * math.pi)
        return 1.0 - self.depth * tooth_share(
            u, (self.tooth - 1) % m.pinion_teeth, m.pinion_teeth, m.contact_ratio
        )


def wear_profile(phase: np.ndarray) -> np.ndarray:
    """Normalised wear profile error over a mesh cycle: ``|2 p - 1| - 1/2`` (zero mean)."""
    return np.abs(2.0 * np.asarray(phase) - 1.0) - 0.5


@dataclass(frozen=True)
class ToothWear(Effect):
    """Uniform tooth wear of depth ``h``: larger backlash plus a sliding-wear profile error.

    Parameters
    ----------
    wear_depth_m : float
        Wear depth h, m: adds h to the half backlash and ``h (|2p - 1| - 1/2)`` to the
        transmission error over each mesh cycle.
    """

    wear_depth_m: float = 0.0
    name: ClassVar[str] = "tooth_wear"
    signature: ClassVar[str] = "odd mesh harmonics (1, 3, 5 ...) of the transmission error; larger backlash"
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("wear_depth_m", "m", 0.0, 100e-6, "amplitude", "wear depth"),
    )

    def applicable(self, cfg: RigConfig) -> bool:
        return bool(cfg.meshes)

    def transmission_error(self, ctx: Any) -> np.ndarray | None:
        return self.wear_depth_m * wear_profile(ctx.mesh_phase)

    def modify_config(self, cfg: RigConfig) -> RigConfig:
        meshes = tuple(
            dataclasses.replace(m, half_backlash_m=m.half_backlash_m + self.wear_depth_m) for m in cfg.meshes
        )
        return cfg.replace(meshes=meshes)


@dataclass(frozen=True)
class TemperatureOffset(Effect):
    """The machine's steady temperature differs from the declared one by ``offset_c``.

    Parameters
    ----------
    offset_c : float
        Actual minus declared temperature, degC.
    """

    offset_c: float = 0.0
    name: ClassVar[str] = "temperature_offset"
    signature: ClassVar[str] = (
        "mesh stiffness (E(T)), backlash and thermal profile error change: amplitudes and "
        "phases of all mesh harmonics, shift of the mesh resonances"
    )
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("offset_c", "degC", -300.0, 300.0, "scalar", "actual - declared temperature"),
    )

    def operating_point(self, speed_rpm: float, temperature_c: float) -> tuple[float, float]:
        return speed_rpm, temperature_c + self.offset_c


@dataclass(frozen=True)
class MeshStiffnessDamping(Effect):
    """Scale of the mesh stiffness (all phases) and of the mesh damping ratio.

    Parameters
    ----------
    stiffness_scale : float
        Multiplies k_m(t).
    damping_scale : float
        Multiplies the mesh damping ratio.
    """

    stiffness_scale: float = 1.0
    damping_scale: float = 1.0
    name: ClassVar[str] = "mesh_stiffness_damping"
    signature: ClassVar[str] = (
        "mesh resonance frequency (sqrt of the stiffness scale) and peak height (damping)"
    )
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("stiffness_scale", "1", 0.3, 2.0, "scalar", "mesh stiffness multiplier"),
        ParameterSpec("damping_scale", "1", 0.3, 3.0, "scalar", "mesh damping-ratio multiplier"),
    )

    def applicable(self, cfg: RigConfig) -> bool:
        return bool(cfg.meshes)

    def mesh_stiffness_factor(self, ctx: Any) -> np.ndarray | None:
        return np.full(ctx.t.shape[0], self.stiffness_scale)

    def modify_config(self, cfg: RigConfig) -> RigConfig:
        meshes = tuple(
            dataclasses.replace(m, damping_ratio=m.damping_ratio * self.damping_scale) for m in cfg.meshes
        )
        return cfg.replace(meshes=meshes)


# ---------------------------------------------------------------------------------------------------
# Rolling-bearing defects
# ---------------------------------------------------------------------------------------------------


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
    force pulse of ``pulse_s`` duration and peak ``force_n`` times the load-zone factor at the
    defect's position, directed radially at that position:

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
        Relative standard deviation of the inter-impact interval (0.01-0.02 in real bearings).
    load_angle_rad : float
        Direction of the bearing load (centre of the load zone) in the x-y plane.
    defect_angle_rad : float
        Outer race: defect position; inner race/ball: position at shaft angle 0.
    pulse_s : float
        Impact duration, s.
    seed : int
        Seed of the slip sequence (reproducible).
    """

    kind: str = "outer"
    bearing: int = 1
    force_n: float = 0.0
    geometry: BearingGeometry = BEARING_6206
    slip: float = 0.015
    load_angle_rad: float = -0.5 * math.pi
    defect_angle_rad: float = -0.5 * math.pi
    pulse_s: float = 1.0e-4
    seed: int = 0
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

    def external_forces(self, system: Any) -> np.ndarray | None:
        return _node_xy(system, self._node0(system))

    def force_amplitudes(self, ctx: Any) -> np.ndarray | None:
        system = ctx.system
        s = _shaft_index(system, self._node0(system))
        theta = np.abs(ctx.shaft_angle[:, s])
        omega = np.abs(ctx.shaft_speed[:, s])
        mult = self.impact_multiple()
        phase = mult * theta / (2.0 * math.pi)  # defect phase in impacts
        inst = self._instants(float(phase.max()) if phase.size else 1.0)
        k = np.searchsorted(inst, phase, side="right") - 1
        valid = k >= 0
        rate = np.maximum(mult * omega / (2.0 * math.pi), 1e-9)  # impacts per second
        width = self.pulse_s * rate  # pulse width in phase units
        since = np.where(valid, phase - inst[np.maximum(k, 0)], np.inf)
        pulse = np.where(since < width, np.sin(math.pi * np.clip(since / width, 0, 1)), 0.0)
        # position of the defect at the impact
        if self.kind == "outer":
            pos = np.full_like(theta, self.defect_angle_rad)
            amp = np.ones_like(theta)
        else:
            rot = theta if self.kind == "inner" else self.geometry.multiples()["ftf"] * theta
            pos = rot + self.defect_angle_rad
            amp = load_zone(pos, self.load_angle_rad)
        f = self.force_n * pulse * amp
        return np.column_stack([f * np.cos(pos), f * np.sin(pos)])


def outer_race_defect(**kw: Any) -> BearingDefect:
    return BearingDefect(kind="outer", **kw)


def inner_race_defect(**kw: Any) -> BearingDefect:
    return BearingDefect(kind="inner", **kw)


def ball_defect(**kw: Any) -> BearingDefect:
    return BearingDefect(kind="ball", **kw)


def effect_name(effect: Effect) -> str:
    """Library name of an effect instance (``pinion_eccentricity``, ``inner_race_defect``, ...)."""
    if isinstance(effect, GearEccentricity):
        return f"{effect.member}_eccentricity"
    if isinstance(effect, BearingDefect):
        return effect.effect_name
    return effect.name


LIBRARY_NAMES: tuple[str, ...] = (
    "pinion_eccentricity",
    "gear_eccentricity",
    "mass_unbalance",
    "shaft_misalignment",
    "tooth_damage",
    "tooth_wear",
    "temperature_offset",
    "mesh_stiffness_damping",
    "outer_race_defect",
    "inner_race_defect",
    "ball_defect",
)


def candidate_effects(
    cfg: RigConfig,
    bearing_geometry: BearingGeometry = BEARING_6206,
    bearings: tuple[int, ...] | None = None,
    unbalance_nodes: tuple[int, ...] | None = None,
    misalignment_nodes: tuple[int, ...] | None = None,
    names: tuple[str, ...] | None = None,
) -> list[Effect]:
    """All library effects applicable to a rig, each at its neutral value with its location fixed.

    Parameters
    ----------
    cfg : RigConfig
        The rig; gear effects are offered only when it has a mesh.
    bearing_geometry : BearingGeometry
        Geometry used for the bearing-defect frequencies.
    bearings : tuple of int, optional
        1-based bearings considered for defects (default all).
    unbalance_nodes, misalignment_nodes : tuple of int, optional
        1-based nodes; default the gear/disc nodes (unbalance) and the drive node (misalignment).
    names : tuple of str, optional
        Restrict to these library names.
    """
    out: list[Effect] = []
    has_mesh = bool(cfg.meshes)
    if unbalance_nodes is None:
        nodes = [g.node0 + 1 for g in cfg.gears] + [d.node0 + 1 for d in cfg.discs]
        if not nodes:
            nodes = [cfg.n_nodes // 2 + 1]
        unbalance_nodes = tuple(dict.fromkeys(nodes))
    if misalignment_nodes is None:
        misalignment_nodes = (cfg.drive.node0 + 1,)
    if bearings is None:
        bearings = tuple(range(1, len(cfg.bearings) + 1))
    if has_mesh:
        out += [GearEccentricity(member="pinion"), GearEccentricity(member="gear")]
    out += [MassUnbalance(node=n) for n in unbalance_nodes]
    out += [ShaftMisalignment(node=n) for n in misalignment_nodes]
    if has_mesh:
        out += [ToothDamage(), ToothWear()]
    out.append(TemperatureOffset())
    if has_mesh:
        out.append(MeshStiffnessDamping())
    for kind in ("outer", "inner", "ball"):
        out += [BearingDefect(kind=kind, bearing=b, geometry=bearing_geometry) for b in bearings]
    if names is not None:
        out = [e for e in out if effect_name(e) in names]
    return out
