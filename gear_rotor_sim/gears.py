"""Spur gear geometry, potential-energy mesh stiffness and thermal backlash (Sec 2.2-2.3, Eqs 13-18, 27).

Geometry
    Standard involute spur gears without profile shift: pitch radius ``r = m z / 2``, base radius
    ``r_b = r cos(alpha)``, tip radius ``r_a = r + h_a* m``, root radius ``r_f = r - (h_a* + c*) m``,
    centre distance ``a = r_1 + r_2``. The line of action runs from the pinion's base-circle tangency
    point T1 to the gear's T2 (length ``a sin(alpha)``); positions ``s`` along it are measured from T1.
    Contact starts where the gear tip circle cuts it, ``s_A = a sin(alpha) - sqrt(r_a2^2 - r_b2^2)``,
    and ends on the pinion tip circle, ``s_E = sqrt(r_a1^2 - r_b1^2)``; the pitch point is at
    ``s_P = r_b1 tan(alpha)``. Contact ratio ``eps = (s_E - s_A) / p_b``, base pitch
    ``p_b = pi m cos(alpha)``.

Mesh phase
    ``phase = frac(z_1 theta_1 / (2 pi))`` (theta_1 the nominal pinion rotation). At phase 0 a tooth pair
    enters contact at ``s_A``; pair j (j = 0, 1, ...) is at ``s_A + (phase + j) p_b`` and is in contact
    while that is <= ``s_E``. For 1 < eps < 2 two pairs share the load for ``phase < eps - 1``.

Mesh stiffness (Eqs 13-15)
    :meth:`SpurGearPair.mesh_stiffness_table` combines the tooth compliances of
    :mod:`gear_rotor_sim.tooth_stiffness` (bending, shear, axial, Hertzian contact, fillet foundation;
    the equations and references are there) over the pairs in contact at each mesh phase.

    Profile below the base circle (root radius < base radius, e.g. the 29-tooth pinion): the flank
    between the root circle and the base circle is the straight extension of the base-circle half
    thickness ``h_b = r_b sin(alpha_2)`` (Chen & Shao 2011 treatment), starting at
    ``y_f = sqrt(r_f^2 - h_b^2)``. Root above the base circle (the 49-tooth gear): the beam starts on
    the involute at the root circle. The involute part is parametrised by the roll parameter
    ``t = tan(alpha_r)`` (smooth), the straight part by y; both are integrated with vectorised
    Gauss-Legendre quadrature when a table is built, never inside a time loop.

Thermal profile error and backlash (Eqs 16-18, 27)
    ``de = dT l r_b inv(alpha_k) - dT l r_b (s/r + 2 inv(alpha)) / 2`` (Eq 18, l the linear expansion
    coefficient, s = pi m / 2 the pitch-circle tooth thickness). At the pitch point (alpha_k = alpha,
    the default) ``de = -dT l r_b pi / (2 z)``. ``b* = b - |de_p + de_g| / 2`` (Eq 27).

References
----------
Sun, Chen, Hu, Lei (2021), Nonlinear Dynamics, Eqs 13-18, 27; Ref [35].
Yang, D.C.H., Lin, J.Y. (1987) J. Mech. Transm. Autom. Des. 109, 189-196.
Tian, X. (2004) MSc thesis, Univ. of Alberta; Chaari, Fakhfakh, Haddar (2009) Eur. J. Mech. A 28, 461-468.
Sainsot, Velex, Duverger (2004) J. Mech. Des. 126, 748-752.
Chen, Z., Shao, Y. (2011) Eng. Fail. Anal. 18, 2149-2164.
ISO 6336-1:2019, Sec 9 (single stiffness c' and mesh stiffness c_gamma).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from gear_rotor_sim.tooth_stiffness import (
    MeshStiffnessTable,
    ToothCompliance,
    beam_compliances,
    iso_mesh_stiffness,
    sainsot_fillet_compliance,
)

_GAUSS_ORDER = 24


def involute(alpha: float | np.ndarray) -> float | np.ndarray:
    """inv(alpha) = tan(alpha) - alpha (Eq 16)."""
    return np.tan(alpha) - alpha


def contact_ratio_closed_form(z1: int, z2: int, m: float, alpha: float, ha: float) -> float:
    """Contact ratio of a standard pair from the tip and base circles (ISO 21771):
    ``(sqrt(r_a1^2 - r_b1^2) + sqrt(r_a2^2 - r_b2^2) - a sin(alpha)) / (pi m cos(alpha))``."""
    r1, r2 = m * z1 / 2.0, m * z2 / 2.0
    rb1, rb2 = r1 * math.cos(alpha), r2 * math.cos(alpha)
    ra1, ra2 = r1 + ha * m, r2 + ha * m
    g = math.sqrt(ra1**2 - rb1**2) + math.sqrt(ra2**2 - rb2**2) - (r1 + r2) * math.sin(alpha)
    return g / (math.pi * m * math.cos(alpha))


def validate_pair(
    pinion_teeth: int,
    gear_teeth: int,
    module: float,
    pressure_angle: float,
    face_width: float,
    addendum_coefficient: float = 1.0,
    clearance_coefficient: float = 0.25,
    allow_undercut: bool = False,
) -> None:
    """Check that the parameters describe a valid standard involute spur pair.

    Parameters
    ----------
    pinion_teeth, gear_teeth : int
        Tooth numbers z1, z2.
    module : float
        m, m.
    pressure_angle : float
        alpha, rad (allowed 10..35 deg).
    face_width : float
        L, m.
    addendum_coefficient, clearance_coefficient : float
        h_a*, c*.
    allow_undercut : bool
        Accept z < 2 h_a* / sin^2(alpha) (generation undercut of a standard gear).

    Raises
    ------
    ValueError
        Naming the offending field and the allowed values: non-integer or too few teeth, non-positive
        module/face width, pressure angle outside 10..35 deg, undercut, pointed tips, contact ratio
        below 1, or tip-to-flank interference (contact starting below a base circle).

    References
    ----------
    ISO 21771:2007 (involute geometry); Litvin & Fuentes (2004) Gear Geometry, Ch 10 (undercut).
    """
    for name, z in (("pinion_teeth", pinion_teeth), ("gear_teeth", gear_teeth)):
        if isinstance(z, bool) or not float(z).is_integer() or z < 5:
            raise ValueError(f"{name}: {z} must be an integer >= 5")
    for name, v in (("module", module), ("face_width", face_width)):
        if not (math.isfinite(v) and v > 0.0):
            raise ValueError(f"{name}: {v} must be a finite value > 0 m")
    if not (math.isfinite(pressure_angle) and math.radians(10.0) <= pressure_angle <= math.radians(35.0)):
        raise ValueError(f"pressure_angle: {math.degrees(pressure_angle):g} deg must be within 10..35 deg")
    if not (math.isfinite(addendum_coefficient) and 0.5 <= addendum_coefficient <= 1.5):
        raise ValueError(f"addendum_coefficient: {addendum_coefficient} must be within 0.5..1.5")
    if not (math.isfinite(clearance_coefficient) and 0.0 < clearance_coefficient <= 0.5):
        raise ValueError(f"clearance_coefficient: {clearance_coefficient} must be within (0, 0.5]")
    z_min = 2.0 * addendum_coefficient / math.sin(pressure_angle) ** 2
    if not allow_undercut:
        for name, z in (("pinion_teeth", pinion_teeth), ("gear_teeth", gear_teeth)):
            if z < z_min:
                raise ValueError(
                    f"{name}: {z} teeth undercut a standard gear (z >= {math.ceil(z_min)} needed for "
                    f"alpha = {math.degrees(pressure_angle):g} deg, h_a* = {addendum_coefficient:g}); "
                    "set allow_undercut to accept it"
                )
    for name, z in (("pinion_teeth", pinion_teeth), ("gear_teeth", gear_teeth)):
        r = module * z / 2.0
        ra = r + addendum_coefficient * module
        alpha_a = math.acos(r * math.cos(pressure_angle) / ra)
        s_a = 2.0 * ra * (math.pi / (2.0 * z) + involute(pressure_angle) - involute(alpha_a))
        if s_a <= 0.0:
            raise ValueError(
                f"{name}: {z} teeth with addendum_coefficient {addendum_coefficient:g} give a pointed tip "
                f"(tip thickness {s_a * 1e3:.3f} mm); more teeth or a smaller addendum are needed"
            )
    r1, r2 = module * pinion_teeth / 2.0, module * gear_teeth / 2.0
    rb1, rb2 = r1 * math.cos(pressure_angle), r2 * math.cos(pressure_angle)
    ra1, ra2 = r1 + addendum_coefficient * module, r2 + addendum_coefficient * module
    loa = (r1 + r2) * math.sin(pressure_angle)
    if math.sqrt(ra2**2 - rb2**2) >= loa or math.sqrt(ra1**2 - rb1**2) >= loa:
        raise ValueError(
            f"pinion_teeth/gear_teeth: {pinion_teeth}/{gear_teeth}: a tip circle reaches beyond the mating "
            "base-circle tangency point (involute interference); use more pinion teeth"
        )
    eps = contact_ratio_closed_form(pinion_teeth, gear_teeth, module, pressure_angle, addendum_coefficient)
    if eps < 1.0:
        raise ValueError(
            f"pinion_teeth/gear_teeth/addendum_coefficient: contact ratio {eps:.3f} < 1 (must be >= 1)"
        )


@dataclass(frozen=True)
class SpurGearPair:
    """A standard (unshifted) involute spur gear pair: pinion (driving, z1) and gear (z2).

    Parameters
    ----------
    pinion_teeth, gear_teeth : int
        z1, z2 (Table 3: 29, 49).
    module : float
        m, m.
    pressure_angle : float
        alpha, rad.
    face_width : float
        L = B, m.
    addendum_coefficient, clearance_coefficient : float
        h_a*, c*.
    material_pinion, material_gear : Material-like
        Objects with ``youngs_modulus(T)``, ``poisson_ratio(T)``, ``shear_modulus(T)``,
        ``expansion_coefficient`` (gear_rotor_sim.materials.Material).
    bore_diameter_pinion, bore_diameter_gear : float or None
        Hub bore diameters (m); they set ``h_f = r_f / r_int`` of the fillet-foundation stiffness. Needed
        only for the mesh stiffness.
    fillet_correction_pinion, fillet_correction_gear : float
        lambda_1, lambda_2 of Eq 13 (default 1).
    allow_undercut : bool
        Passed to ``validate_pair``.

    References
    ----------
    Sun et al. (2021), Table 3, Eqs 13-18, 27.
    """

    pinion_teeth: int
    gear_teeth: int
    module: float
    pressure_angle: float
    face_width: float
    addendum_coefficient: float = 1.0
    clearance_coefficient: float = 0.25
    material_pinion: Any = None
    material_gear: Any = None
    bore_diameter_pinion: float | None = None
    bore_diameter_gear: float | None = None
    fillet_correction_pinion: float = 1.0
    fillet_correction_gear: float = 1.0
    allow_undercut: bool = False
    _cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        validate_pair(
            self.pinion_teeth,
            self.gear_teeth,
            self.module,
            self.pressure_angle,
            self.face_width,
            self.addendum_coefficient,
            self.clearance_coefficient,
            self.allow_undercut,
        )
        for name in ("fillet_correction_pinion", "fillet_correction_gear"):
            v = getattr(self, name)
            if not (math.isfinite(v) and 0.0 < v <= 2.0):
                raise ValueError(f"{name}: {v} must be within (0, 2]")
        for name in ("bore_diameter_pinion", "bore_diameter_gear"):
            v = getattr(self, name)
            if v is not None:
                root = self.root_radius(name.endswith("pinion"))
                if not (math.isfinite(v) and 0.0 < v / 2.0 < root):
                    raise ValueError(
                        f"{name}: {v} m must be > 0 and below the root diameter {2 * root:.6g} m"
                    )

    # -- geometry ---------------------------------------------------------------------------------
    def teeth(self, pinion: bool) -> int:
        return int(self.pinion_teeth if pinion else self.gear_teeth)

    def pitch_radius(self, pinion: bool) -> float:
        """r = m z / 2, m."""
        return self.module * self.teeth(pinion) / 2.0

    def base_radius(self, pinion: bool) -> float:
        """r_b = r cos(alpha), m."""
        return self.pitch_radius(pinion) * math.cos(self.pressure_angle)

    def tip_radius(self, pinion: bool) -> float:
        """r_a = r + h_a* m, m."""
        return self.pitch_radius(pinion) + self.addendum_coefficient * self.module

    def root_radius(self, pinion: bool) -> float:
        """r_f = r - (h_a* + c*) m, m."""
        return (
            self.pitch_radius(pinion) - (self.addendum_coefficient + self.clearance_coefficient) * self.module
        )

    @property
    def center_distance(self) -> float:
        """a = r_1 + r_2, m."""
        return self.pitch_radius(True) + self.pitch_radius(False)

    @property
    def base_pitch(self) -> float:
        """p_b = pi m cos(alpha), m."""
        return math.pi * self.module * math.cos(self.pressure_angle)

    @property
    def line_of_action_length(self) -> float:
        """T1T2 = a sin(alpha), m."""
        return self.center_distance * math.sin(self.pressure_angle)

    @property
    def contact_start(self) -> float:
        """s_A: gear tip circle on the line of action, m from T1."""
        rb2, ra2 = self.base_radius(False), self.tip_radius(False)
        return self.line_of_action_length - math.sqrt(ra2**2 - rb2**2)

    @property
    def contact_end(self) -> float:
        """s_E: pinion tip circle on the line of action, m from T1."""
        rb1, ra1 = self.base_radius(True), self.tip_radius(True)
        return math.sqrt(ra1**2 - rb1**2)

    @property
    def pitch_point(self) -> float:
        """s_P = r_b1 tan(alpha), m from T1."""
        return self.base_radius(True) * math.tan(self.pressure_angle)

    @property
    def path_of_contact(self) -> float:
        """Length of the path of contact g = s_E - s_A, m."""
        return self.contact_end - self.contact_start

    @property
    def contact_ratio(self) -> float:
        """eps = g / p_b."""
        return self.path_of_contact / self.base_pitch

    @property
    def max_pairs(self) -> int:
        """Most tooth pairs in contact at once, floor(eps) + 1."""
        return math.floor(self.contact_ratio) + 1

    def half_base_angle(self, pinion: bool) -> float:
        """alpha_2 = pi/(2z) + inv(alpha): half tooth angle at the base circle, rad."""
        return math.pi / (2.0 * self.teeth(pinion)) + float(involute(self.pressure_angle))

    def contact_positions(self, phase: np.ndarray) -> np.ndarray:
        """Positions s (m from T1) of pairs j = 0..max_pairs-1 at mesh ``phase``; NaN when not in contact."""
        ph = np.mod(np.asarray(phase, dtype=float), 1.0)
        j = np.arange(self.max_pairs)
        s = self.contact_start + (ph[:, None] + j[None, :]) * self.base_pitch
        return np.where(s <= self.contact_end + 1e-15, s, np.nan)

    # -- stiffness --------------------------------------------------------------------------------
    def _bore_radius(self, pinion: bool) -> float:
        name = "bore_diameter_pinion" if pinion else "bore_diameter_gear"
        v = getattr(self, name)
        if v is None:
            raise ValueError(
                f"{name}: needed for the fillet-foundation stiffness (h_f = r_f / r_int); got None"
            )
        return v / 2.0

    def tooth_compliance(self, roll: np.ndarray, pinion: bool, temperature_c: float) -> ToothCompliance:
        """Compliances of one tooth loaded at involute roll parameter ``roll = tan(alpha_r)`` (Eq 15, k_f).

        Parameters
        ----------
        roll : ndarray, shape (n,)
            Roll parameter of the contact point on this gear's flank: distance from its base-circle
            tangency point along the line of action divided by r_b.
        pinion : bool
            Which gear.
        temperature_c : float
            Gear temperature for E*(T), G*(T).

        References
        ----------
        Sun et al. (2021) Eqs 13, 15; Tian (2004); Chen & Shao (2011); Sainsot et al. (2004).
        """
        mat = self.material_pinion if pinion else self.material_gear
        e, g = mat.youngs_modulus(temperature_c), mat.shear_modulus(temperature_c)
        rb, rf = self.base_radius(pinion), self.root_radius(pinion)
        a2 = self.half_base_angle(pinion)
        L = self.face_width
        tk = np.asarray(roll, dtype=float)
        # Contact point: psi = half angle from the centre line, r = r_b sqrt(1 + t^2).
        psi_k = a2 - tk + np.arctan(tk)
        rk = rb * np.sqrt(1.0 + tk**2)
        yk, hk = rk * np.cos(psi_k), rk * np.sin(psi_k)
        alpha1 = tk - a2  # angle between force and normal to the centre line (tan(alpha_r) - alpha_2)
        xg, wg = np.polynomial.legendre.leggauss(_GAUSS_ORDER)
        # Involute part of the beam from max(r_b, r_f) to the contact point, in the roll parameter.
        t0 = math.sqrt((rf / rb) ** 2 - 1.0) if rf > rb else 0.0
        half = (tk - t0)[:, None] / 2.0
        t = t0 + half * (xg[None, :] + 1.0)
        psi = a2 - t + np.arctan(t)
        dy_dt = rb * t / np.sqrt(1.0 + t**2) * (np.cos(psi) + t * np.sin(psi))
        y_inv = rb * np.sqrt(1.0 + t**2) * np.cos(psi)
        h_inv = rb * np.sqrt(1.0 + t**2) * np.sin(psi)
        kb, ks, ka = beam_compliances(y_inv, half * wg[None, :] * dy_dt, h_inv, yk, hk, alpha1, e, g, L)
        if rf < rb:
            # Straight flank of constant half thickness h_b from the root circle to the base circle.
            hb = rb * math.sin(a2)
            yf, yb = math.sqrt(rf**2 - hb**2), rb * math.cos(a2)
            ys = yf + (yb - yf) * (xg + 1.0) / 2.0
            n = tk.size
            y_str = np.broadcast_to(ys, (n, ys.size))
            w_str = np.broadcast_to(wg * (yb - yf) / 2.0, (n, ys.size))
            h_str = np.full((n, ys.size), hb)
            kb2, ks2, ka2 = beam_compliances(y_str, w_str, h_str, yk, hk, alpha1, e, g, L)
            kb, ks, ka = kb + kb2, ks + ks2, ka + ka2
            theta_f = math.asin(hb / rf)
        else:
            theta_f = a2 - t0 + math.atan(t0)
        # Fillet foundation: u_f from the root circle to where the force line crosses the centre line.
        u_f = yk - hk * np.tan(alpha1) - rf
        s_f = 2.0 * rf * theta_f
        h_f = rf / self._bore_radius(pinion)
        kf = sainsot_fillet_compliance(alpha1, u_f, s_f, theta_f, h_f, e, L)
        return ToothCompliance(bending=kb, shear=ks, axial=ka, fillet=kf)

    def hertz_stiffness(self, temperature_c: float) -> float:
        """Hertzian stiffness k_h = pi L / (2 [(1-nu_1^2)/E_1 + (1-nu_2^2)/E_2]), N/m.

        For equal materials this is ``pi E L / (4 (1 - nu^2))``.

        References
        ----------
        Sun et al. (2021) Eq 14 (k_h, Ref [35]); Yang & Lin (1987).
        """
        mp, mg = self.material_pinion, self.material_gear
        cp = (1.0 - mp.poisson_ratio(temperature_c) ** 2) / mp.youngs_modulus(temperature_c)
        cg = (1.0 - mg.poisson_ratio(temperature_c) ** 2) / mg.youngs_modulus(temperature_c)
        return math.pi * self.face_width / (2.0 * (cp + cg))

    def pair_stiffness(self, positions: np.ndarray, temperature_c: float) -> dict[str, np.ndarray]:
        """Stiffness terms of single tooth pairs in contact at ``positions`` (m from T1 along the LOA).

        Returns a dict with ``k_t`` (Eq 14 pair term: Hertz + both teeth in series), ``k_f1``, ``k_f2``
        (fillet foundations), each shape of ``positions``, N/m.
        """
        s = np.asarray(positions, dtype=float)
        flat = s.ravel()
        cp = self.tooth_compliance(flat / self.base_radius(True), True, temperature_c)
        cg = self.tooth_compliance(
            (self.line_of_action_length - flat) / self.base_radius(False), False, temperature_c
        )
        kt = 1.0 / (1.0 / self.hertz_stiffness(temperature_c) + cp.tooth + cg.tooth)
        return {
            "k_t": kt.reshape(s.shape),
            "k_f1": (1.0 / cp.fillet).reshape(s.shape),
            "k_f2": (1.0 / cg.fillet).reshape(s.shape),
        }

    def mesh_stiffness_table(self, temperature_c: float, n_points: int = 512) -> MeshStiffnessTable:
        """Tabulate K*(phase) over one mesh period with E*(T), G*(T), nu(T) at ``temperature_c`` (Eqs 13-15).

        Parameters
        ----------
        temperature_c : float
            Gear temperature, deg C.
        n_points : int
            Grid points on [0, 1).

        Returns
        -------
        MeshStiffnessTable

        References
        ----------
        Sun et al. (2021) Eqs 13-15, Sec 2.2 ("taking E*, G* into the above formula").
        """
        if not (isinstance(n_points, int | np.integer) and n_points >= 16):
            raise ValueError(f"n_points: {n_points} must be an integer >= 16")
        key = (float(temperature_c), int(n_points))
        if key in self._cache:
            return self._cache[key]
        table = self.mesh_stiffness_at(np.arange(n_points) / n_points, temperature_c)
        self._cache[key] = table
        return table

    def mesh_stiffness_at(self, phase: np.ndarray, temperature_c: float) -> MeshStiffnessTable:
        """K*(phase) and the contact kinematics at arbitrary mesh phases (Eqs 13-15), not cached.

        Right-continuous at the tooth-pair changes (:meth:`mesh_event_phases`).
        """
        phase = np.atleast_1d(np.asarray(phase, dtype=float))
        pos = self.contact_positions(phase)
        mask = np.isfinite(pos)
        terms = self.pair_stiffness(np.where(mask, pos, self.pitch_point), temperature_c)
        kt = np.where(mask, terms["k_t"], 0.0)
        k_tooth = kt.sum(axis=1)  # Eq 14
        kf1 = np.where(mask, terms["k_f1"], 0.0).sum(axis=1)
        kf2 = np.where(mask, terms["k_f2"], 0.0).sum(axis=1)
        lam1, lam2 = self.fillet_correction_pinion, self.fillet_correction_gear
        k = 1.0 / (1.0 / k_tooth + 1.0 / (lam1 * kf1) + 1.0 / (lam2 * kf2))  # Eq 13
        share = kt / k_tooth[:, None]
        sign = np.where(mask, np.sign(np.where(mask, pos, 0.0) - self.pitch_point), 0.0)
        return MeshStiffnessTable(
            temperature_c=float(temperature_c),
            phase=phase,
            stiffness=k,
            n_pairs=mask.sum(axis=1),
            load_share=share,
            contact_position=pos,
            sliding_sign=sign,
            pitch_point=self.pitch_point,
            line_of_action_length=self.line_of_action_length,
            contact_ratio=self.contact_ratio,
            base_pitch=self.base_pitch,
        )

    def mesh_event_phases(self) -> np.ndarray:
        """Mesh phases in [0, 1) where K* and the friction terms jump: a pair enters at the start of
        active contact (phase 0), a pair leaves (frac(eps)), a pair passes the pitch point (sliding
        reverses). Sorted, duplicates removed."""
        pb = self.base_pitch
        ph = [0.0, self.contact_ratio % 1.0, ((self.pitch_point - self.contact_start) / pb) % 1.0]
        out: list[float] = []
        for p in sorted(ph):
            if p >= 1.0 - 1e-12:
                p = 0.0
            if not any(abs(p - q) < 1e-12 for q in out):
                out.append(p)
        return np.array(sorted(out))

    def iso_mesh_stiffness(self, temperature_c: float | None = None) -> dict[str, float]:
        """ISO 6336-1 c', c_gamma_alpha and mesh stiffness of this pair
        (:func:`gear_rotor_sim.tooth_stiffness.iso_mesh_stiffness`), with E at ``temperature_c`` if given."""
        e = None
        if temperature_c is not None:
            e = (
                self.material_pinion.youngs_modulus(temperature_c),
                self.material_gear.youngs_modulus(temperature_c),
            )
        return iso_mesh_stiffness(self.pinion_teeth, self.gear_teeth, self.contact_ratio, self.face_width, e)

    # -- thermal profile error and backlash --------------------------------------------------------
    def thermal_profile_error(
        self,
        temperature_c: float,
        reference_temperature_c: float,
        pinion: bool,
        pressure_angle_k: float | None = None,
    ) -> float:
        """Thermal profile error de of one gear along the line of action (Eq 18), m.

        ``de = dT l r_b inv(alpha_k) - dT l r_b (s/r + 2 inv(alpha)) / 2`` with dT = T - T_ref, l the
        linear expansion coefficient, s = pi m / 2 and r the pitch-circle thickness and radius. It is
        ``-dT l r_b psi_k``: minus the growth, projected on the line of action, of the half tooth
        thickness at point k when the tooth expands by (1 + l dT). ``pressure_angle_k`` defaults to the
        pitch point (alpha_k = alpha), where ``de = -dT l r_b pi / (2 z)``.

        References
        ----------
        Sun et al. (2021) Eqs 16-18.
        """
        mat = self.material_pinion if pinion else self.material_gear
        dt = float(temperature_c) - float(reference_temperature_c)
        lam = mat.expansion_coefficient
        rb, r = self.base_radius(pinion), self.pitch_radius(pinion)
        s = math.pi * self.module / 2.0
        ak = self.pressure_angle if pressure_angle_k is None else float(pressure_angle_k)
        inv_a = float(involute(self.pressure_angle))
        return dt * lam * rb * float(involute(ak)) - dt * lam * rb / 2.0 * (s / r + 2.0 * inv_a)  # Eq 18

    def thermal_half_backlash(
        self,
        half_backlash: float,
        temperature_c: float,
        reference_temperature_c: float,
        thermal_backlash: bool = True,
        pressure_angle_k_pinion: float | None = None,
        pressure_angle_k_gear: float | None = None,
    ) -> float:
        """b* = b - |de_p + de_g| / 2 (Eq 27), m; ``thermal_backlash=False`` gives b* = b.

        Raises
        ------
        ValueError
            If the thermal expansion closes the backlash (b* < 0), naming ``temperature_c``.

        References
        ----------
        Sun et al. (2021) Eq 27 (with Eq 18 for de_p, de_g).
        """
        if not (math.isfinite(half_backlash) and half_backlash >= 0.0):
            raise ValueError(f"half_backlash: {half_backlash} m must be finite and >= 0")
        if not thermal_backlash:
            return float(half_backlash)
        dep = self.thermal_profile_error(
            temperature_c, reference_temperature_c, True, pressure_angle_k_pinion
        )
        deg = self.thermal_profile_error(temperature_c, reference_temperature_c, False, pressure_angle_k_gear)
        b_star = half_backlash - abs(dep + deg) / 2.0
        if b_star < 0.0:
            raise ValueError(
                f"temperature_c: {temperature_c} C closes the backlash (b* = {b_star * 1e6:.3f} um < 0 for "
                f"b = {half_backlash * 1e6:.3f} um); allowed temperatures keep b* >= 0"
            )
        return b_star


def paper_gear_pair(material: Any, bore_diameter: float = 0.030, **changes: Any) -> SpurGearPair:
    """The meshing pair of Table 3 (29/49 teeth, m = 3 mm, 20 deg, B = 20 mm, h_a* = 1, c* = 0.25).

    Both gears are of ``material`` and bored to the 30 mm shaft of Table 4 unless ``bore_diameter`` says
    otherwise.

    References
    ----------
    Sun et al. (2021), Tables 3 and 4.
    """
    kwargs: dict[str, Any] = {
        "pinion_teeth": 29,
        "gear_teeth": 49,
        "module": 3.0e-3,
        "pressure_angle": math.radians(20.0),
        "face_width": 20.0e-3,
        "addendum_coefficient": 1.0,
        "clearance_coefficient": 0.25,
        "material_pinion": material,
        "material_gear": material,
        "bore_diameter_pinion": bore_diameter,
        "bore_diameter_gear": bore_diameter,
    }
    kwargs.update(changes)
    return SpurGearPair(**kwargs)
