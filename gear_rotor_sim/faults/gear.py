"""Gear faults: eccentricity (run-out), localised tooth damage, uniform tooth wear, misalignment.

* ``pinion_eccentricity`` / ``gear_eccentricity``: geometric run-out ``e`` of the pitch circle: the
  wheel's centre runs ``d = e (cos, sin)(theta_s + phi)`` off its rotation centre. The same vector
  moves the tooth profile, whose projection on the line of action ``V . d`` enters the mesh deflection
  (shaft order 1 of that gear and sidebands of the mesh orders; Velex & Maatar 1996), and the mass
  centre, a rotating force ``m_g Omega_s^2 d`` at its node (Randall 2011, Sec 2.2.1; Mohammed et al.
  2009). docs/history/calibration_sessions.md Sec. 8.33: with an unrelated error ``e sin(theta_s + phi)``
  the two parts were 160 deg out of their physical relative phase on the pinion.
* ``tooth_damage``: a root crack or chipped tooth lowers the mesh stiffness by the fraction
  ``depth`` of that tooth's share while it is engaged (Chaari et al. 2009; Mohammed et al. 2009):
  once-per-revolution modulation, sidebands around the mesh orders.
* ``tooth_wear``: wear depth ``h``: uniform removal ``h`` on the loaded flank (the half backlash
  grows by ``h``) plus sliding wear (Archard 1953; Flodin & Andersson 1997) ``h |s - s_P| / max reach``
  along the path of contact, zero at the pitch point, ``h`` at the far path end, load-share weighted
  over the pairs in contact: mesh harmonics, and in contact the mean transmission error grows by ``h``
  plus the profile's mean (1.40 h on the paper pair; docs/history/calibration_sessions.md Sec. 8.8).
* ``gear_misalignment``: tooth lines of one wheel tilted (wobbling) about the middle of the face by
  an angle: axial mesh-force component at its order 1; once the tilt exceeds what the mesh
  deflection covers, an edge-loaded, softer mesh twice per revolution of that wheel.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from gear_rotor_sim.config import RigConfig
from gear_rotor_sim.faults.base import Effect, ParameterSpec, node_xy_columns


def on_mesh(ctx: Any, mesh: int, values: np.ndarray, neutral: float) -> np.ndarray:
    """Per-mesh array (n, n_meshes): ``values`` on 1-based ``mesh``, ``neutral`` on the others."""
    nm = len(ctx.system.meshes)
    if nm == 1:
        return values
    out = np.full((values.shape[0], nm), neutral)
    out[:, mesh - 1] = values
    return out


def check_mesh(cfg: RigConfig, mesh: int) -> bool:
    """Whether the rig has the 1-based ``mesh``."""
    return 1 <= mesh <= len(cfg.meshes)


@dataclass(frozen=True)
class GearEccentricity(Effect):
    """Geometric eccentricity (run-out) of the pinion or the gear.

    The wheel's centre runs ``d = e (cos, sin)(theta_s + phi)`` off its rotation centre (``theta_s``
    the signed shaft angle): the profile moved by ``d`` adds ``V . d`` to the mesh deflection (its
    projection on the line of action, Eq 22), the mass centre moved by ``d`` gives the rotating
    inertia force ``m_g Omega_s^2 d``.

    Parameters
    ----------
    member : str
        ``"pinion"`` or ``"gear"`` (the mesh's pinion/gear).
    eccentricity_m : float
        Run-out e, m.
    phase_rad : float
        Angular position of the high point at shaft angle 0 in the global x-y plane (the wheel's centre
        offset points there), rad.
    mesh : int
        1-based mesh (order of ``meshes:`` in the rig).
    """

    member: str = "pinion"
    eccentricity_m: float = 0.0
    phase_rad: float = 0.0
    mesh: int = 1
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
        suffix = "" if self.mesh == 1 else f"@mesh{self.mesh}"
        return f"{self.member}_eccentricity{suffix}"

    def applicable(self, cfg: RigConfig) -> bool:
        return check_mesh(cfg, self.mesh)

    def _gear(self, system: Any) -> tuple[int, int]:
        m = system.meshes[self.mesh - 1]
        return (m.pinion_node0, m.pinion_shaft) if self.member == "pinion" else (m.gear_node0, m.gear_shaft)

    def centre_offset(self, ctx: Any) -> tuple[np.ndarray, np.ndarray]:
        """The wheel's geometric (and mass) centre offset from its rotation centre, (x, y) in m.

        The high point sits at the signed shaft angle plus ``phase_rad`` in the global x-y plane: the
        same vector moves the tooth profile (:meth:`transmission_error`) and the body's mass centre
        (:meth:`force_amplitudes`).
        """
        _, shaft = self._gear(ctx.system)
        th = ctx.shaft_angle[:, shaft] + self.phase_rad
        return self.eccentricity_m * np.cos(th), self.eccentricity_m * np.sin(th)

    def transmission_error(self, ctx: Any) -> np.ndarray | None:
        """``-V . d``: the profile moved by the centre offset ``d`` adds its projection on the line of
        action to the mesh deflection ``delta = V q`` (Eq 22; Velex & Maatar 1996), and the effect's
        error enters as ``delta_m = delta - e`` (Eqs 24-25)."""
        node0, _ = self._gear(ctx.system)
        v = np.asarray(ctx.system.meshes[self.mesh - 1].line_of_action)
        dx, dy = self.centre_offset(ctx)
        return on_mesh(ctx, self.mesh, -(v[6 * node0] * dx + v[6 * node0 + 1] * dy), 0.0)

    def external_forces(self, system: Any) -> np.ndarray | None:
        node0, _ = self._gear(system)
        return node_xy_columns(system, node0)

    def force_amplitudes(self, ctx: Any) -> np.ndarray | None:
        node0, shaft = self._gear(ctx.system)
        mass = float(np.asarray(ctx.system.M)[6 * node0, 6 * node0])
        dx, dy = self.centre_offset(ctx)
        w2 = ctx.shaft_speed[:, shaft] ** 2
        return np.column_stack([mass * w2 * dx, mass * w2 * dy])


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
    """Localised tooth damage (root crack, chipped tooth) on one tooth of the pinion or the gear.

    The mesh stiffness is multiplied by ``1 - depth * share_i(t)`` where ``share_i`` is the part of
    the mesh stiffness carried by tooth ``i`` (see :func:`tooth_share`).

    Parameters
    ----------
    tooth : int
        1-based tooth of ``wheel``. Mesh cycles are counted from time 0 (``u = z_p theta_p / 2 pi``,
        the same count on both wheels); tooth ``i`` of a wheel with ``z`` teeth enters contact at
        the cycles ``u = i - 1 (mod z)``, so pinion tooth 1 and gear tooth 1 enter together at 0.
    depth : float
        Fraction of that tooth's stiffness lost (0 = healthy, 1 = tooth missing).
    wheel : str
        ``"pinion"`` or ``"gear"`` of the mesh.
    mesh : int
        1-based mesh (order of ``meshes:`` in the rig).
    """

    tooth: int = 1
    depth: float = 0.0
    wheel: str = "pinion"
    mesh: int = 1
    name: ClassVar[str] = "tooth_damage"
    signature: ClassVar[str] = (
        "once per pinion revolution impulse: many pinion orders, sidebands at the mesh orders"
    )
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("depth", "1", 0.0, 0.9, "scalar", "fraction of the tooth's stiffness lost"),
        ParameterSpec("tooth", "1", 1, 200, "index", "damaged tooth of the wheel, 1-based"),
    )

    def __post_init__(self) -> None:
        if self.wheel not in ("pinion", "gear"):
            raise ValueError(f"wheel: {self.wheel!r} is not one of ['pinion', 'gear']")

    @property
    def label(self) -> str:
        suffix = "" if self.mesh == 1 else f"@mesh{self.mesh}"
        return f"tooth_damage@{self.wheel}{suffix}"

    def applicable(self, cfg: RigConfig) -> bool:
        return check_mesh(cfg, self.mesh)

    def teeth(self, system: Any) -> int:
        """Number of teeth of the damaged wheel."""
        m = system.meshes[self.mesh - 1]
        return int(m.pinion_teeth if self.wheel == "pinion" else m.gear_teeth)

    def mesh_stiffness_factor(self, ctx: Any) -> np.ndarray | None:
        m = ctx.system.meshes[self.mesh - 1]
        u = m.pinion_teeth * np.abs(ctx.shaft_angle[:, m.pinion_shaft]) / (2.0 * math.pi)
        z = self.teeth(ctx.system)
        share = tooth_share(u, (self.tooth - 1) % z, z, m.contact_ratio)
        return on_mesh(ctx, self.mesh, 1.0 - self.depth * share, 1.0)


def wear_profile(
    position: np.ndarray, pitch_point: float, contact_start: float, contact_end: float
) -> np.ndarray:
    """Sliding-wear depth of a flank point, per unit wear depth (Archard's law).

    Archard (1953): the worn depth is proportional to contact pressure times sliding distance. On an
    involute pair the sliding speed is proportional to the distance ``|s - s_P|`` of the contact point
    from the pitch point along the line of action (the flanks roll without sliding at ``s_P``), so the
    removal grows linearly from zero at the pitch point to its largest value at the far end of the
    path of contact ``[s_A, s_E]`` (Flodin & Andersson 1997 use the same sliding distance per contact
    cycle). Normalised to 1 there; never negative (material is only removed).

    Parameters
    ----------
    position : ndarray
        Contact position s along the line of action, m from T1 (NaN where not in contact: gives 0).
    pitch_point, contact_start, contact_end : float
        s_P, s_A, s_E, m from T1 (:class:`~gear_rotor_sim.gears.SpurGearPair`).
    """
    s = np.asarray(position, dtype=float)
    reach = max(contact_end - pitch_point, pitch_point - contact_start)
    if not (reach > 0.0 and contact_start <= pitch_point <= contact_end):
        raise ValueError(
            f"pitch_point: {pitch_point} must lie within the path of contact [{contact_start}, {contact_end}]"
        )
    r = np.abs(s - pitch_point) / reach
    return np.where(np.isfinite(r), r, 0.0)


def step_average_periodic(table: np.ndarray, phase: np.ndarray, width: np.ndarray) -> np.ndarray:
    """Mean of a periodic table over ``[phase - width/2, phase + width/2]`` (phase in cycles).

    The table holds the values at ``arange(n) / n`` of a period, linear in between (as
    ``np.interp(..., period=1)``); its mean over an interval is the difference of its exact
    antiderivative. A table that jumps within one of its cells (the sliding-wear transmission error
    where a pair enters or leaves contact) is then seen by the integrator as the mean over each step:
    the jump's place inside the step sets the value, where a sample at the step instant would move
    the jump to the step grid. That timing error repeats with the grid's beat against the tooth
    count and puts numerical lines at the shaft orders between the mesh harmonics
    (docs/history/calibration_sessions.md Sec. 8.18: 0.83 m/s^2 RMS over the pinion orders of ``node5_ay`` for
    17.7 um of wear at 3000 rpm and 69 steps per mesh period, falling as the step). ``width`` 0 gives
    the point value.
    """
    p = np.asarray(table, dtype=float)
    n = p.size
    x = np.asarray(phase, dtype=float)
    w = np.broadcast_to(np.asarray(width, dtype=float), x.shape)
    nxt = np.roll(p, -1)
    node = np.concatenate([[0.0], np.cumsum(0.5 * (p + nxt) / n)])  # antiderivative at the nodes
    period = node[-1]

    def antider(u: np.ndarray) -> np.ndarray:
        k = np.floor(u)
        f = (u - k) * n
        j = np.minimum(f.astype(int), n - 1)
        d = (f - j) / n
        return k * period + node[j] + d * p[j] + 0.5 * d * d * n * (nxt[j] - p[j])

    point = np.interp(x, np.arange(n) / n, p, period=1.0)
    wide = w > 1e-12
    out = point.copy()
    if np.any(wide):
        xs, ws = x[wide], w[wide]
        out[wide] = (antider(xs + 0.5 * ws) - antider(xs - 0.5 * ws)) / ws
    return out


def mesh_wear_profile(table: Any) -> np.ndarray:
    """Transmission error of the sliding-wear profile over a mesh cycle, per unit wear depth.

    The pairs in contact act in parallel, so the mesh sees the load-share weighted mean of their
    flank removals (``sum_j lambda_j r(s_j)``, ``lambda_j`` the pair's share of Eq 14). The pitch
    point's phase is the mesh geometry's (``(s_P - s_A) / p_b``), not mid-cycle.

    Parameters
    ----------
    table : MeshStiffnessTable
        Mesh stiffness table (``contact_position``, ``load_share``, ``pitch_point``).

    Returns
    -------
    ndarray, shape (n,)
        Non-negative, at most 1.
    """
    pos = np.asarray(table.contact_position, dtype=float)
    s_a = float(np.nanmin(pos))
    s_e = s_a + float(table.contact_ratio) * float(table.base_pitch)
    r = wear_profile(pos, float(table.pitch_point), s_a, s_e)
    return np.sum(np.asarray(table.load_share, dtype=float) * r, axis=1)


@dataclass(frozen=True)
class ToothWear(Effect):
    """Tooth wear of depth ``h``: uniform removal h on the loaded flank plus a sliding-wear profile.

    The uniform part adds h to the half backlash (the DTE mean grows by h in contact); the sliding
    part (Archard 1953; Flodin & Andersson 1997) removes ``h r(s)`` with ``r`` zero at the pitch point
    and 1 at the far end of the path of contact (:func:`wear_profile`), added to the transmission
    error as the load-share weighted mean over the pairs in contact (:func:`mesh_wear_profile`).
    Both parts are material removal, never added material.

    Parameters
    ----------
    wear_depth_m : float
        Wear depth h, m: the uniform removal and the largest sliding-wear removal (path ends).
    mesh : int
        1-based mesh (order of ``meshes:`` in the rig).
    profile_scale : float
        Amplitude of the sliding-wear profile's variation over the mesh cycle relative to Archard's,
        in [0, 1] (1: the profile above; 0: its mean removal at every phase, no mesh-harmonic
        content). The mean removal, hence the DTE mean in contact, does not depend on it: the depth
        sets the mean, and how the removal varies along the path is the assumption two models of a
        gear disagree on, which the diagnosis against a reference fits as a nuisance
        (``candidates_wear_reference.py``).
    """

    wear_depth_m: float = 0.0
    mesh: int = 1
    profile_scale: float = 1.0
    name: ClassVar[str] = "tooth_wear"
    signature: ClassVar[str] = "mesh harmonics of the transmission error; larger backlash and DTE mean"
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("wear_depth_m", "m", 0.0, 100e-6, "amplitude", "wear depth"),
    )

    def __post_init__(self) -> None:
        if not (math.isfinite(self.profile_scale) and 0.0 <= self.profile_scale <= 1.0):
            raise ValueError(f"profile_scale: {self.profile_scale!r} must be a number in [0, 1]")

    @property
    def label(self) -> str:
        return "tooth_wear" if self.mesh == 1 else f"tooth_wear@mesh{self.mesh}"

    def applicable(self, cfg: RigConfig) -> bool:
        return check_mesh(cfg, self.mesh)

    def transmission_error(self, ctx: Any) -> np.ndarray | None:
        phase = ctx.mesh_phases[:, self.mesh - 1] if ctx.mesh_phases is not None else ctx.mesh_phase
        table = ctx.system.meshes[self.mesh - 1].table_wear_profile
        if table is None:
            raise ValueError(
                f"mesh: {self.mesh} has no sliding-wear table (its gear geometry is not known); tooth_wear "
                "needs a mesh built by elements.mesh.build_mesh_coupling"
            )
        # the profile jumps where a pair enters or leaves (its load share does): averaged over each
        # integration step, so that the jump's place inside the step is kept (step_average_periodic)
        m = ctx.system.meshes[self.mesh - 1]
        t = np.asarray(ctx.t, dtype=float)
        speed = np.abs(np.asarray(ctx.shaft_speed, dtype=float)[:, m.pinion_shaft])
        dt = np.gradient(t) if t.size > 1 else np.zeros(t.size)
        width = m.pinion_teeth * speed * dt / (2.0 * np.pi)
        profile = step_average_periodic(table, np.asarray(phase, dtype=float), width)
        if self.profile_scale != 1.0:
            mean = float(np.mean(table))  # the cycle mean of the periodic piecewise-linear table
            profile = mean + self.profile_scale * (profile - mean)
        return on_mesh(ctx, self.mesh, self.wear_depth_m * profile, 0.0)

    def modify_config(self, cfg: RigConfig) -> RigConfig:
        meshes = tuple(
            dataclasses.replace(m, half_backlash_m=m.half_backlash_m + self.wear_depth_m)
            if i == self.mesh - 1
            else m
            for i, m in enumerate(cfg.meshes)
        )
        return cfg.replace(meshes=meshes)


def tilted_contact_stiffness_factor(rho: np.ndarray) -> np.ndarray:
    """Tangent mesh stiffness factor of a tooth line tilted about the middle of the face.

    A wheel tilted on its shaft turns its tooth lines about its mid-plane: across the face width
    ``b`` the separation from the mating flank is ``gamma y`` (``-b/2 <= y <= b/2``) on top of the
    approach ``d`` at the face centre (the rigid-body approach the transmission error measures). On a
    linear (Winkler) tooth foundation (``k' = k / b``) the mesh force is ``F = k d`` while the whole
    face is in contact (``d >= G``, ``G = gamma b / 2``): the tilt changes nothing there. Below, only
    the band ``y > -d/gamma`` towards the loaded edge carries load and ``F = k (d + G)^2 / (4 G)``
    (``|d| < G``). At the static force ``F0 = k delta0`` the face stays in full contact up to
    ``rho = G / delta0 = 1``; beyond, ``d* = delta0 (2 sqrt(rho) - rho)`` and the tangent stiffness
    ``dF/dd = k (d* + G) / (2 G)`` is ``k / sqrt(rho)``. Returns ``min(1, 1 / sqrt(rho))``.
    Edge loading of misaligned spur gears in this sense: Velex & Maatar (1996), J Sound Vib 191(5);
    ISO 6336-1 K_Hbeta (the load concentrates at one edge once the mesh deflection no longer covers the
    tilt).
    """
    rho = np.maximum(np.asarray(rho, dtype=float), 0.0)
    return 1.0 / np.sqrt(np.maximum(rho, 1.0))


def tilted_contact_offset(rho: np.ndarray) -> np.ndarray:
    """Transmission-error offset of the linearised tilted contact, in units of ``delta0``.

    With the tangent stiffness ``k s`` (:func:`tilted_contact_stiffness_factor`) the force law is
    ``F = k s (d - e)`` about the static point: ``e = d* - delta0 / s = delta0 (sqrt(rho) - rho)`` for
    ``rho > 1`` (the loaded edge carries the force with a smaller centre approach: negative), 0 in
    full contact. Returns ``e / delta0``.
    """
    rho = np.maximum(np.asarray(rho, dtype=float), 1.0)
    return np.sqrt(rho) - rho


#: grid points per period of the highest order when an order series is evaluated by interpolation
ORDER_GRID_PER_PERIOD = 32


def order_grid(coef: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``Re c_0 + 2 sum_{k>=1} Re(c_k e^{i k theta})`` on a grid over one revolution: ``(theta, value)``
    with ``ORDER_GRID_PER_PERIOD`` points per period of the highest order ``K`` (linear interpolation
    on it: relative error of order ``k`` at most ``(pi k / (K ORDER_GRID_PER_PERIOD))^2 / 2``, 0.5 %
    at ``K``), so that the cost per step does not grow with the number of orders. The sum is an
    inverse real FFT on the grid (``n >= 32 K`` points, so no order folds): the cost grows as
    ``K log K`` (the streaming simulator re-evaluates it at every update of its estimate,
    ``faults/misalignment_stream.py``)."""
    coef = np.asarray(coef, dtype=complex)
    kmax = coef.size - 1
    n = max(8, ORDER_GRID_PER_PERIOD * max(kmax, 1))
    grid = 2.0 * np.pi * np.arange(n + 1) / n
    spec = np.zeros(n // 2 + 1, dtype=complex)
    spec[0] = n * coef[0].real
    spec[1 : kmax + 1] = n * coef[1:]
    vals = np.fft.irfft(spec, n)
    return grid, np.append(vals, vals[0])


def evaluate_orders(coef: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """The order series of ``coef`` (:func:`order_grid`) at the angles ``theta`` (rad)."""
    grid, vals = order_grid(coef)
    return np.interp(np.mod(theta, 2.0 * np.pi), grid, vals)


@dataclass(frozen=True)
class GearMisalignment(Effect):
    """Angular misalignment of a gear on its shaft: tooth lines tilted by ``angle_rad``.

    The wheel's tooth lines wobble relative to the mating wheel by ``gamma(t) = angle |cos(theta +
    phi)|`` in the plane of action as it turns (``theta`` its shaft angle), about the middle of the
    face (the wheel tilts about its mid-plane). While the mesh deflection covers the tilt across the
    face (``rho = gamma b / (2 delta0) <= 1``, ``delta0`` the aligned approach from the static mesh
    force ``T / r_b`` of the output torque and the mean mesh stiffness) nothing changes in the mesh;
    beyond, the contact shrinks towards the loaded edge: a softer mesh
    (:func:`tilted_contact_stiffness_factor`) with a smaller centre approach
    (:func:`tilted_contact_offset`, a transmission-error offset), twice per revolution of the wheel.
    The tilted contact normal gives the mesh force an axial component ``F(t) angle cos(theta + phi)``
    on both wheels (opposite), ``F(t)`` the instantaneous normal tooth force: at order 0 of ``F`` (the
    static mesh force ``F0``) the wheel's order 1 in the axial bearing forces, at the mesh harmonics of
    ``F`` the sidebands ``m z +- 1`` of the wheel's orders; for small tilts it is the only signature.
    The force amplitudes of an effect are set before each step from the kinematics, so ``F(t)`` enters
    as the part of a previous run's mesh force synchronous with the tilted wheel
    (``mesh_force_orders``, set by :func:`gear_rotor_sim.faults.misalignment_force.with_mesh_force`, a
    fixed-point pass: the axial force does not act back on the spur mesh); without it, ``F0``.

    Parameters
    ----------
    angle_rad : float
        Tilt amplitude of the tooth lines, rad.
    phase_rad : float
        Wheel angle of the largest tilt at shaft angle 0, rad.
    member : str
        ``"pinion"`` or ``"gear"`` of the mesh.
    mesh : int
        1-based mesh.
    face_width_m : float
        Face width b (the paper's gears: 20 mm).
    mesh_force_orders : tuple of complex
        Order coefficients ``c_k`` (``k = 0 .. K``, N) of the mesh force over one revolution of the
        tilted wheel, ``F(theta) = Re c_0 + 2 sum_k Re(c_k e^{i k theta})`` with ``theta`` its signed
        shaft angle (:func:`gear_rotor_sim.faults.misalignment_force.wheel_orders`); empty: the static
        mesh force ``F0``.
    """

    angle_rad: float = 0.0
    phase_rad: float = 0.0
    member: str = "gear"
    mesh: int = 1
    face_width_m: float = 0.02
    mesh_force_orders: tuple[complex, ...] = dataclasses.field(default=(), repr=False)
    name: ClassVar[str] = "gear_misalignment"
    signature: ClassVar[str] = (
        "2x order of the tilted wheel's shaft and sidebands +-2 around the mesh orders; axial bearing "
        "force at its order 1"
    )
    specs: ClassVar[tuple[ParameterSpec, ...]] = (
        ParameterSpec("angle_rad", "rad", 0.0, 5e-3, "amplitude", "tooth-line tilt"),
        ParameterSpec("phase_rad", "rad", -math.pi, math.pi, "phase", "wheel angle of the largest tilt"),
    )

    def __post_init__(self) -> None:
        if self.member not in ("pinion", "gear"):
            raise ValueError(f"member: {self.member!r} is not one of ['pinion', 'gear']")

    @property
    def label(self) -> str:
        suffix = "" if self.mesh == 1 else f"@mesh{self.mesh}"
        return f"{self.member}_misalignment{suffix}"

    def applicable(self, cfg: RigConfig) -> bool:
        return check_mesh(cfg, self.mesh)

    def _static_force(self, system: Any) -> float:
        """Static mesh force ``T_g / r_b`` of this mesh: the load torque referred to this mesh's gear
        shaft through the speed ratios (power through a serial train, frictionless), so that on a
        multi-stage rig each stage carries its own share (a single mesh: the load torque itself)."""
        m = system.meshes[self.mesh - 1]
        tz = np.abs(np.asarray(system.static_load)[5::6])
        torque = float(np.max(tz))
        ratios = getattr(system, "shaft_speed_ratios", None)
        if ratios is not None and torque > 0:
            load_shaft = int(system.shaft_of_node[int(np.argmax(tz))])
            torque *= abs(float(ratios[load_shaft])) / abs(float(ratios[m.gear_shaft]))
        return torque / float(m.base_radius_gear) if m.base_radius_gear > 0 else 0.0

    def _shaft(self, system: Any) -> int:
        m = system.meshes[self.mesh - 1]
        return m.pinion_shaft if self.member == "pinion" else m.gear_shaft

    def _rho(self, ctx: Any) -> tuple[np.ndarray, float]:
        """``rho(t) = gamma(t) b / (2 delta0)`` and ``delta0``."""
        m = ctx.system.meshes[self.mesh - 1]
        f0 = self._static_force(ctx.system)
        delta0 = f0 / float(m.mean_stiffness) if f0 > 0 else 1e-6
        gamma = self.angle_rad * np.abs(np.cos(ctx.shaft_angle[:, self._shaft(ctx.system)] + self.phase_rad))
        return gamma * self.face_width_m / (2.0 * delta0), delta0

    def full_contact(self, system: Any) -> bool:
        """Whether the mesh deflection covers the largest tilt across the face (``rho <= 1`` at every
        wheel angle): then the mesh part is neutral (stiffness factor 1, no offset) and only the
        axial force acts."""
        m = system.meshes[self.mesh - 1]
        f0 = self._static_force(system)
        delta0 = f0 / float(m.mean_stiffness) if f0 > 0 else 1e-6
        return self.angle_rad * self.face_width_m / (2.0 * delta0) <= 1.0

    def mesh_stiffness_factor(self, ctx: Any) -> np.ndarray | None:
        if self.full_contact(ctx.system):  # factor 1 at every angle: nothing to evaluate per step
            return None
        rho, _ = self._rho(ctx)
        return on_mesh(ctx, self.mesh, tilted_contact_stiffness_factor(rho), 1.0)

    def transmission_error(self, ctx: Any) -> np.ndarray | None:
        if self.full_contact(ctx.system):  # offset 0 at every angle
            return None
        rho, delta0 = self._rho(ctx)
        return on_mesh(ctx, self.mesh, delta0 * tilted_contact_offset(rho), 0.0)

    def external_forces(self, system: Any) -> np.ndarray | None:
        m = system.meshes[self.mesh - 1]
        cols = np.zeros((system.ndof, 1))
        cols[6 * m.pinion_node0 + 2, 0] = 1.0
        cols[6 * m.gear_node0 + 2, 0] = -1.0
        return cols

    def mesh_force(self, system: Any, theta: np.ndarray) -> np.ndarray:
        """Normal tooth force (N) at the tilted wheel's signed shaft angles ``theta`` (rad): the order
        series ``mesh_force_orders`` when set, else the static mesh force ``F0`` (:meth:`_static_force`).
        """
        theta = np.asarray(theta, dtype=float)
        if not self.mesh_force_orders:
            return np.full(theta.shape, self._static_force(system))
        grid, vals = self._force_grid
        return np.interp(np.mod(theta, 2.0 * np.pi), grid, vals)

    @functools.cached_property
    def _force_grid(self) -> tuple[np.ndarray, np.ndarray]:
        return order_grid(np.asarray(self.mesh_force_orders, dtype=complex))

    def force_amplitudes(self, ctx: Any) -> np.ndarray | None:
        theta = ctx.shaft_angle[:, self._shaft(ctx.system)]
        force = self.mesh_force(ctx.system, theta)
        return (force * self.angle_rad * np.cos(theta + self.phase_rad))[:, None]
