"""Spur gear mesh coupling (Sec 3.2, Eqs 21-33).

Geometry and sign convention (shared by V, V_f and the friction terms)
    Gear centres: pinion O_p at the origin, gear O_g at ``a (1, 0)`` in the gears' x-y plane. With
    ``n = (sin(alpha), cos(alpha))`` and ``t = (cos(alpha), -sin(alpha))`` (t x n = +z), the line of
    action passes through the pinion's base-circle tangency point ``T1 = r_bp t`` and the gear's
    ``T2 = O_g - r_bg t``; a contact point is ``C = T1 + s n`` with s measured from T1 (0 <= s <=
    T1T2 = a sin(alpha)). Positive theta_z is about +z for both gears; the pinion drives with
    positive speed, the gear turns negatively (speed ratio -z_p/z_g).

    The mesh deflection is ``delta = V q`` (Eq 22), positive when the drive-side flanks are pressed
    together; the mesh force F_m (Eq 25) is positive in compression and acts as ``-n F_m`` on the
    pinion (torque ``-r_bp F_m``) and ``+n F_m`` on the gear (torque ``-r_bg F_m``). These are the
    a_i = b_i = 0 entries of Eq 29, ``V_f = -V``. A load torque T on the gear (positive, opposing its
    negative rotation) is balanced by ``F_m = T / r_bg``.

Friction (Eq 29)
    The friction force mu F_m acts along +-t, perpendicular to the line of action, at the contact
    point. The pinion's sliding velocity relative to the gear is ``omega_p (r_bp/r_bg (T1T2 - s) - s) t``:
    along +t before the pitch point (s < s_P = r_bp tan(alpha)), along -t after it. Per tooth pair i
    (load share lambda_i, contact s_i) the friction on the pinion is ``+mu sgn(s_i - s_P) lambda_i F_m t``
    and on the gear the opposite. Its moment about O_p is ``-(s_i) x (friction)`` because
    ``(C - O_p) x t = s_i (n x t) = -s_i``; about O_g the arm is ``T1T2 - s_i``. Summing over the pairs:

    * ``a_1 = a_2 = a = mu sum_i lambda_i sgn(s_i - s_P)``
    * ``b_1 = -mu sum_i lambda_i sgn(s_i - s_P) s_i``  (pinion, arm from T1)
    * ``b_2 = -mu sum_i lambda_i sgn(s_i - s_P) (T1T2 - s_i)``  (gear, arm from T2)

    so that the pinion column of Eq 29 is ``(-sin + a cos, -cos - a sin, 0, 0, 0, -r_bp + b_1)`` and the
    gear column ``(sin - a cos, cos + a sin, 0, 0, 0, -r_bg + b_2)``. The friction power is never
    positive (checked in tests), and ``V_f -> -V`` as ``mu -> 0``. The sign change at the pitch point is
    smeared over one table cell by the linear interpolation of the tabulated coefficients.

    ``MeshCoupling.force_basis`` has column 0 = -V and, when mu > 0, the columns
    ``t`` (pinion x, y) / ``-t`` (gear x, y), the pinion theta_z unit vector and the gear theta_z unit
    vector, all scattered to the global DOFs; ``force_coefficients(phase)`` returns ``(1, a, b_1, b_2)``.
    Then ``force_basis @ force_coefficients(phase).T`` is V_f(phase)^T (global) and the generalised
    mesh force is that times F_m (Eq 28).

Transmission error, backlash, force, damping
    e = e0 sin(2 pi phase + phi) (Eq 24 with omega t = 2 pi phase, so speed ramps are handled);
    gamma_m0, gamma_m1 of Eq 26; F_m = k (gamma_m0 delta_m + gamma_m1 b*) + c gamma_m0 delta_m' (Eq 25);
    c_m = 2 zeta sqrt(k_mean m_e), m_e = I_p I_g / (I_p r_bg^2 + I_g r_bp^2) (the equivalent mass of the
    torsional mesh mode; zeta from the config, 0.07 for the paper: the paper gives no value, 0.03-0.17
    is the range reported for spur gears by Kasuba & Evans 1981 and used by Kahraman & Singh 1990).

References
----------
Sun, Chen, Hu, Lei (2021), Nonlinear Dynamics, Eqs 21-33; Ref [37] for the friction coefficients.
Kahraman, A., Singh, R. (1990) J. Sound Vib. 142, 49-75 (mesh damping ratio).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gear_rotor_sim.gears import MeshStiffnessTable, SpurGearPair
from gear_rotor_sim.system_data import MeshCoupling

_THETA_Z = 5


def line_of_action_vector(
    pressure_angle: float, base_radius_pinion: float, base_radius_gear: float
) -> np.ndarray:
    """V of Eq 22 (12 entries, order of Eq 23: pinion x..theta_z, gear x..theta_z).

    References
    ----------
    Sun et al. (2021) Eq 22.
    """
    s, c = math.sin(pressure_angle), math.cos(pressure_angle)
    return np.array([s, c, 0.0, 0.0, 0.0, base_radius_pinion, -s, -c, 0.0, 0.0, 0.0, base_radius_gear])


def friction_vector(
    pressure_angle: float,
    base_radius_pinion: float,
    base_radius_gear: float,
    a: np.ndarray | float,
    b1: np.ndarray | float,
    b2: np.ndarray | float,
) -> np.ndarray:
    """V_f of Eq 29 as rows, shape (n, 12) (or (12,) for scalar inputs), a_1 = a_2 = a.

    References
    ----------
    Sun et al. (2021) Eq 29.
    """
    s, c = math.sin(pressure_angle), math.cos(pressure_angle)
    a_, b1_, b2_ = np.broadcast_arrays(np.asarray(a, float), np.asarray(b1, float), np.asarray(b2, float))
    out = np.zeros((*a_.shape, 12))
    out[..., 0] = -s + a_ * c
    out[..., 1] = -c - a_ * s
    out[..., 5] = -base_radius_pinion + b1_
    out[..., 6] = s - a_ * c
    out[..., 7] = c + a_ * s
    out[..., 11] = -base_radius_gear + b2_
    return out


def friction_coefficients(table: MeshStiffnessTable, friction_coefficient: float) -> np.ndarray:
    """a, b_1, b_2 of Eq 29 on the table's phase grid, shape (n, 3) (convention in the module docstring).

    References
    ----------
    Sun et al. (2021) Eq 29; Ref [37].
    """
    mu = float(friction_coefficient)
    in_contact = np.isfinite(table.contact_position)
    s = np.where(in_contact, table.contact_position, 0.0)
    w = table.load_share * table.sliding_sign  # lambda_i sgn(s_i - s_P), 0 out of contact
    a = mu * w.sum(axis=1)
    b1 = -mu * (w * s).sum(axis=1)
    b2 = -mu * (w * np.where(in_contact, table.line_of_action_length - s, 0.0)).sum(axis=1)
    return np.column_stack([a, b1, b2])


def mesh_phase(pinion_angle: np.ndarray | float, pinion_teeth: int) -> np.ndarray:
    """Mesh phase frac(z_p theta_p / (2 pi)) in [0, 1) of the nominal pinion rotation theta_p (rad)."""
    return np.mod(pinion_teeth * np.asarray(pinion_angle, dtype=float) / (2.0 * math.pi), 1.0)


def static_transmission_error(phase: np.ndarray | float, amplitude: float, phase_offset: float) -> np.ndarray:
    """e = e0 sin(2 pi phase + phi), m (Eq 24 with omega t = 2 pi phase).

    References
    ----------
    Sun et al. (2021) Eq 24.
    """
    return amplitude * np.sin(2.0 * math.pi * np.asarray(phase, dtype=float) + phase_offset)


def static_transmission_error_rate(
    phase: np.ndarray | float, phase_rate: np.ndarray | float, amplitude: float, phase_offset: float
) -> np.ndarray:
    """de/dt = 2 pi phase_rate e0 cos(2 pi phase + phi), m/s; phase_rate = mesh frequency in Hz (Eq 24)."""
    ph = np.asarray(phase, dtype=float)
    return (
        2.0
        * math.pi
        * np.asarray(phase_rate, dtype=float)
        * amplitude
        * np.cos(2.0 * math.pi * ph + phase_offset)
    )


def backlash_functions(delta_m: np.ndarray | float, half_backlash: float) -> tuple[np.ndarray, np.ndarray]:
    """gamma_m0, gamma_m1 of Eq 26 for the relative deflection delta_m and half backlash b*.

    ``gamma_m1 = -1, 0, +1`` for ``delta_m > b*``, ``|delta_m| <= b*``, ``delta_m < -b*``;
    ``gamma_m0 = 1`` outside the backlash, 0 inside.

    References
    ----------
    Sun et al. (2021) Eq 26.
    """
    d = np.asarray(delta_m, dtype=float)
    gamma1 = np.where(d > half_backlash, -1.0, np.where(d < -half_backlash, 1.0, 0.0))
    gamma0 = np.abs(gamma1)
    return gamma0, gamma1


def mesh_force(
    delta_m: np.ndarray | float,
    delta_m_rate: np.ndarray | float,
    stiffness: np.ndarray | float,
    damping: float,
    half_backlash: float,
) -> np.ndarray:
    """F_m = k (gamma_m0 delta_m + gamma_m1 b*) + c gamma_m0 delta_m' (Eq 25), N, positive in compression.

    The elastic part is continuous at +-b* (it is k (delta_m -+ b*) outside, 0 inside); the damping part
    switches with gamma_m0 as in the paper.

    References
    ----------
    Sun et al. (2021) Eqs 25-26.
    """
    g0, g1 = backlash_functions(delta_m, half_backlash)
    d = np.asarray(delta_m, dtype=float)
    return np.asarray(stiffness) * (g0 * d + g1 * half_backlash) + damping * g0 * np.asarray(delta_m_rate)


def equivalent_mass(
    pinion_polar_inertia: float, gear_polar_inertia: float, base_radius_pinion: float, base_radius_gear: float
) -> float:
    """m_e = I_p I_g / (I_p r_bg^2 + I_g r_bp^2), kg: the mass of the torsional mesh oscillator."""
    ip, ig = pinion_polar_inertia, gear_polar_inertia
    return ip * ig / (ip * base_radius_gear**2 + ig * base_radius_pinion**2)


def mesh_damping(
    mean_stiffness: float,
    damping_ratio: float,
    pinion_polar_inertia: float,
    gear_polar_inertia: float,
    base_radius_pinion: float,
    base_radius_gear: float,
) -> float:
    """c_m = 2 zeta sqrt(k_mean m_e), N s/m (the paper's c_m of Eq 25; zeta from the config).

    References
    ----------
    Sun et al. (2021) Eq 25; Kahraman & Singh (1990).
    """
    if not (math.isfinite(damping_ratio) and damping_ratio >= 0.0):
        raise ValueError(f"damping_ratio: {damping_ratio} must be finite and >= 0")
    for name, v in (
        ("pinion_polar_inertia", pinion_polar_inertia),
        ("gear_polar_inertia", gear_polar_inertia),
    ):
        if not (math.isfinite(v) and v > 0.0):
            raise ValueError(f"{name}: {v} must be > 0 kg m^2")
    m_e = equivalent_mass(pinion_polar_inertia, gear_polar_inertia, base_radius_pinion, base_radius_gear)
    return 2.0 * damping_ratio * math.sqrt(mean_stiffness * m_e)


def _annulus_polar_inertia(pair: SpurGearPair, pinion: bool, density: float) -> float:
    """I_p = rho pi w (D^4 - d^4) / 32 of the rigid gear disc (pitch diameter D, bore d, face width w)."""
    d_out = 2.0 * pair.pitch_radius(pinion)
    d_in = pair.bore_diameter_pinion if pinion else pair.bore_diameter_gear
    return density * math.pi * pair.face_width * (d_out**4 - float(d_in) ** 4) / 32.0


def table_jumps(pair: SpurGearPair, temperature_c: float, mu: float, eps: float = 1e-9) -> np.ndarray:
    """Rows (phase, dk, dcoef...) of the jumps of K* and the force coefficients at the mesh events.

    The limits are the values ``eps`` of a mesh period either side (K* is smooth on each side).
    """
    events = pair.mesh_event_phases()
    left = pair.mesh_stiffness_at(np.mod(events - eps, 1.0), temperature_c)
    right = pair.mesh_stiffness_at(events + eps, temperature_c)

    def coefficients(t: MeshStiffnessTable) -> np.ndarray:
        ones = np.ones((t.phase.size, 1))
        return np.hstack([ones, friction_coefficients(t, mu)]) if mu > 0.0 else ones

    dk = right.stiffness - left.stiffness
    dc = coefficients(right) - coefficients(left)
    return np.column_stack([events, dk, dc])


def uniform_table(grid: np.ndarray, values: np.ndarray) -> np.ndarray | None:
    """``values`` if ``grid`` is the uniform periodic grid ``arange(n) / n``, else None."""
    g = np.asarray(grid, dtype=float)
    if np.allclose(g, np.arange(g.size) / g.size, rtol=0.0, atol=1e-12):
        return np.ascontiguousarray(values, dtype=float)
    return None


def _periodic_interpolator(grid: np.ndarray, values: np.ndarray):
    g = np.asarray(grid, dtype=float).copy()
    v = np.asarray(values, dtype=float).copy()

    if v.ndim == 1:

        def f(phase: np.ndarray) -> np.ndarray:
            return np.interp(np.asarray(phase, dtype=float), g, v, period=1.0)

        return f

    def fm(phase: np.ndarray) -> np.ndarray:
        ph = np.atleast_1d(np.asarray(phase, dtype=float))
        return np.column_stack([np.interp(ph, g, v[:, j], period=1.0) for j in range(v.shape[1])])

    return fm


def build_mesh_coupling(
    mesh_cfg: Any,
    pinion_node0: int,
    gear_node0: int,
    pinion_shaft: int,
    gear_shaft: int,
    ndof: int,
    temperature_c: float,
    material_pinion: Any,
    material_gear: Any,
    reference_temperature_c: float,
    pinion_polar_inertia: float | None = None,
    gear_polar_inertia: float | None = None,
    pinion_teeth: int | None = None,
    gear_teeth: int | None = None,
    *,
    pinion_bore_diameter: float | None = None,
    gear_bore_diameter: float | None = None,
    n_points: int = 512,
    pinion_spin: float = 1.0,
) -> MeshCoupling:
    """Build the solver's view of one spur mesh at a uniform gear temperature (Eqs 13-29).

    Parameters
    ----------
    mesh_cfg : MeshConfig-like
        Fields module_m, pressure_angle_rad, face_width_m, addendum_coefficient, clearance_coefficient,
        half_backlash_m, transmission_error_amplitude_m, transmission_error_phase_rad,
        friction_coefficient, damping_ratio, thermal_backlash.
    pinion_node0, gear_node0 : int
        0-based nodes of the pinion and gear discs.
    pinion_shaft, gear_shaft : int
        Shaft indices.
    ndof : int
        Global DOF count.
    temperature_c, reference_temperature_c : float
        Gear temperature and the as-built temperature (deg C).
    material_pinion, material_gear : Material-like
    pinion_polar_inertia, gear_polar_inertia : float or None
        Polar inertias of the gear discs, kg m^2 (for c_m). None: the rigid annulus of the disc model
        (pitch diameter, bore, face width, material density), ``I_p = rho pi w (D^4 - d^4) / 32``.
    pinion_teeth, gear_teeth : int or None
        None: ``mesh_cfg.pinion_teeth`` / ``mesh_cfg.gear_teeth``.
    pinion_bore_diameter, gear_bore_diameter : float or None
        Hub bores, m (fillet-foundation stiffness). None: ``mesh_cfg.pinion_bore_diameter_m`` /
        ``mesh_cfg.gear_bore_diameter_m``.
    n_points : int
        Mesh-phase grid of the stiffness table.
    pinion_spin : float
        Sign of the pinion's spin about +z. The module's geometry (the pinion driving with positive
        speed) holds for +1; for -1 (e.g. the second stage of a train, whose pinion shaft turns
        negative) the pair is its mirror image in the plane of the centre line (y -> -y; the
        rotations theta_x, theta_z change sign), so that a driving pinion again loads the drive
        flank (delta > b*) and the sliding directions of Eq 29 follow.

    Returns
    -------
    MeshCoupling
        Mesh phase convention ``phase = frac(z_p theta_p / (2 pi))``; ``force_basis[:, 0] = -V``.

    References
    ----------
    Sun et al. (2021) Eqs 13-18, 21-29.
    """
    for name, node in (("pinion_node0", pinion_node0), ("gear_node0", gear_node0)):
        if not 0 <= node < ndof // 6:
            raise ValueError(f"{name}: {node} is outside 0..{ndof // 6 - 1}")
    if pinion_node0 == gear_node0:
        raise ValueError(f"gear_node0: {gear_node0} must differ from pinion_node0")
    if pinion_teeth is None:
        pinion_teeth = getattr(mesh_cfg, "pinion_teeth", None)
    if gear_teeth is None:
        gear_teeth = getattr(mesh_cfg, "gear_teeth", None)
    if pinion_bore_diameter is None:
        pinion_bore_diameter = getattr(mesh_cfg, "pinion_bore_diameter_m", None)
    if gear_bore_diameter is None:
        gear_bore_diameter = getattr(mesh_cfg, "gear_bore_diameter_m", None)
    for name, value in (
        ("pinion_teeth", pinion_teeth),
        ("gear_teeth", gear_teeth),
        ("pinion_bore_diameter", pinion_bore_diameter),
        ("gear_bore_diameter", gear_bore_diameter),
    ):
        if value is None:
            raise ValueError(f"{name}: not given and not in the mesh config (needed for the mesh stiffness)")
    mu = float(mesh_cfg.friction_coefficient)
    if not (math.isfinite(mu) and 0.0 <= mu < 1.0):
        raise ValueError(f"friction_coefficient: {mu} must be within [0, 1)")
    pair = SpurGearPair(
        pinion_teeth=int(pinion_teeth),
        gear_teeth=int(gear_teeth),
        module=float(mesh_cfg.module_m),
        pressure_angle=float(mesh_cfg.pressure_angle_rad),
        face_width=float(mesh_cfg.face_width_m),
        addendum_coefficient=float(mesh_cfg.addendum_coefficient),
        clearance_coefficient=float(mesh_cfg.clearance_coefficient),
        material_pinion=material_pinion,
        material_gear=material_gear,
        bore_diameter_pinion=pinion_bore_diameter,
        bore_diameter_gear=gear_bore_diameter,
    )
    table = pair.mesh_stiffness_table(float(temperature_c), n_points=n_points)
    rbp, rbg = pair.base_radius(True), pair.base_radius(False)
    alpha = pair.pressure_angle
    idx = np.concatenate([6 * pinion_node0 + np.arange(6), 6 * gear_node0 + np.arange(6)])
    v_global = np.zeros(ndof)
    v_global[idx] = line_of_action_vector(alpha, rbp, rbg)  # Eq 22
    if mu > 0.0:
        basis = np.zeros((ndof, 4))
        coef = np.column_stack([np.ones(table.phase.size), friction_coefficients(table, mu)])
        c, s = math.cos(alpha), math.sin(alpha)
        basis[idx[[0, 1, 6, 7]], 1] = [c, -s, -c, s]  # friction direction t on pinion, -t on gear
        basis[6 * pinion_node0 + _THETA_Z, 2] = 1.0
        basis[6 * gear_node0 + _THETA_Z, 3] = 1.0
    else:
        basis = np.zeros((ndof, 1))
        coef = np.ones((table.phase.size, 1))
    basis[:, 0] = -v_global
    if pinion_spin < 0.0:  # mirror image: y, theta_x, theta_z of both gears change sign
        mirror = np.ones(ndof)
        for node0 in (pinion_node0, gear_node0):
            mirror[6 * node0 + np.array([1, 3, _THETA_Z])] = -1.0
        v_global = v_global * mirror
        basis = basis * mirror[:, None]
    jumps = table_jumps(pair, float(temperature_c), mu)
    from gear_rotor_sim.faults.gear import mesh_wear_profile  # faults import elements: no cycle at load

    coef_interp = _periodic_interpolator(table.phase, coef)
    stiff_interp = _periodic_interpolator(table.phase, table.stiffness)
    if pinion_polar_inertia is None:
        pinion_polar_inertia = _annulus_polar_inertia(pair, True, material_pinion.density)
    if gear_polar_inertia is None:
        gear_polar_inertia = _annulus_polar_inertia(pair, False, material_gear.density)
    damping = mesh_damping(
        table.mean, float(mesh_cfg.damping_ratio), pinion_polar_inertia, gear_polar_inertia, rbp, rbg
    )
    b_star = pair.thermal_half_backlash(
        float(mesh_cfg.half_backlash_m),
        float(temperature_c),
        float(reference_temperature_c),
        thermal_backlash=bool(mesh_cfg.thermal_backlash),
    )  # Eq 27
    return MeshCoupling(
        pinion_node0=int(pinion_node0),
        gear_node0=int(gear_node0),
        pinion_shaft=int(pinion_shaft),
        gear_shaft=int(gear_shaft),
        pinion_teeth=int(pinion_teeth),
        gear_teeth=int(gear_teeth),
        line_of_action=v_global,
        force_basis=basis,
        force_coefficients=coef_interp,
        stiffness=stiff_interp,
        mean_stiffness=table.mean,
        damping=damping,
        half_backlash=b_star,
        te_amplitude=float(mesh_cfg.transmission_error_amplitude_m),
        te_phase=float(mesh_cfg.transmission_error_phase_rad),
        base_radius_pinion=rbp,
        base_radius_gear=rbg,
        contact_ratio=pair.contact_ratio,
        table_stiffness=uniform_table(table.phase, table.stiffness),
        table_coefficients=uniform_table(table.phase, coef),
        table_jumps=jumps,
        table_wear_profile=uniform_table(table.phase, mesh_wear_profile(table)),
    )
