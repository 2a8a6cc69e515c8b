"""Potential-energy tooth compliances and the tabulated mesh stiffness (Sun et al. 2021, Eqs 13-15).

Mesh stiffness (Eqs 13-15, Ref [35]: Yang & Lin 1987, Tian 2004, Chaari et al. 2009, Sainsot et al. 2004)
    Each tooth is a cantilever of variable section on its foundation circle, loaded at the contact
    point by a unit force along the line of action. With ``alpha_1`` the angle between the force and
    the normal to the tooth centre line, ``y`` the coordinate along the centre line, ``h(y)`` the
    half tooth thickness, ``I = 2 h^3 L / 3``, ``A = 2 h L`` (plane-stress beam, modulus E*, G* at
    the gear temperature):

    * bending ``1/k_b = int [(y_k - y) cos(alpha_1) - h_k sin(alpha_1)]^2 / (E I) dy``
    * shear ``1/k_s = int 1.2 cos^2(alpha_1) / (G A) dy``
    * axial compression ``1/k_a = int sin^2(alpha_1) / (E A) dy``
    * Hertzian contact ``1/k_h = 2 / (pi L) [(1 - nu_1^2)/E_1 + (1 - nu_2^2)/E_2]``, which is
      ``k_h = pi E L / (4 (1 - nu^2))`` for equal materials.
    * fillet foundation (Sainsot, Velex, Duverger 2004):
      ``1/k_f = cos^2(alpha_1)/(E L) [L* (u_f/S_f)^2 + M* (u_f/S_f) + P* (1 + Q* tan^2(alpha_1))]``
      with the published polynomial coefficients of ``h_f = r_f / r_int`` and ``theta_f``.

    Combination (Eqs 13-14): pair i has ``k_t^i = 1/(1/k_h + 1/k_r1 + 1/k_r2)`` with
    ``1/k_r = 1/k_b + 1/k_s + 1/k_a`` (Eq 15); ``k_tooth = sum_i k_t^i``; the fillet foundations of the
    teeth in contact act in parallel, ``k_fj = sum_i k_fj^i``; and
    ``K* = 1/(1/k_tooth + 1/(lambda_1 k_f1) + 1/(lambda_2 k_f2))``. The correction coefficients
    ``lambda_1, lambda_2`` (Eq 13) default to 1: the paper gives no values, and with lambda = 1 the
    single-contact stiffness is exactly the classical series form. Values < 1 model the coupling of the
    foundations of adjacent loaded teeth in double contact (Xie et al. 2018, Mech. Syst. Signal
    Process. 111, 331-347). Load share of pair i: ``k_t^i / k_tooth`` (equal mesh deflection).

    The geometry (contact points, tooth profile, quadrature) and the combination over the pairs in
    contact are :class:`gear_rotor_sim.gears.SpurGearPair`'s; this module holds the compliance
    integrals, the table type and the ISO 6336-1 stiffness the potential-energy one is compared with.

References
----------
Sun, Chen, Hu, Lei (2021), Nonlinear Dynamics, Eqs 13-15; Ref [35].
Yang, D.C.H., Lin, J.Y. (1987) J. Mech. Transm. Autom. Des. 109, 189-196.
Tian, X. (2004) MSc thesis, Univ. of Alberta; Chaari, Fakhfakh, Haddar (2009) Eur. J. Mech. A 28, 461-468.
Sainsot, Velex, Duverger (2004) J. Mech. Des. 126, 748-752.
ISO 6336-1:2019, Sec 9 (single stiffness c' and mesh stiffness c_gamma).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Sainsot et al. (2004), Table 1: X*(h_f, theta_f) = A/theta_f^2 + B h_f^2 + C h_f/theta_f + D/theta_f
# + E h_f + F for X* = L*, M*, P*, Q* (rows).
SAINSOT_COEFFICIENTS = np.array(
    [
        [-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045],  # L*
        [60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086],  # M*
        [-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236],  # P*
        [-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904],  # Q*
    ]
)

# ISO 6336-1:2019 Eq 9.4 coefficients C1..C9 of q' (mm um / N) for the theoretical single stiffness.
ISO_Q_COEFFICIENTS = (0.04723, 0.15551, 0.25791, -0.00635, -0.11654, -0.00193, -0.24188, 0.00529, 0.00182)
ISO_STEEL_MODULUS = 206.0e9  # E_st of ISO 6336-1 (Pa); c' scales with E/E_st for other materials


@dataclass(frozen=True)
class ToothCompliance:
    """Compliances (m/N) of one gear's tooth at contact points: bending, shear, axial, fillet."""

    bending: np.ndarray
    shear: np.ndarray
    axial: np.ndarray
    fillet: np.ndarray

    @property
    def tooth(self) -> np.ndarray:
        """1/k_r = 1/k_b + 1/k_s + 1/k_a (Eq 15)."""
        return self.bending + self.shear + self.axial


def beam_compliances(
    y: np.ndarray,
    weights: np.ndarray,
    half_thickness: np.ndarray,
    y_contact: np.ndarray,
    h_contact: np.ndarray,
    alpha1: np.ndarray,
    youngs_modulus: float,
    shear_modulus: float,
    face_width: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Potential-energy compliances of a variable-section cantilever tooth (Eq 15 terms).

    Parameters
    ----------
    y, weights, half_thickness : ndarray, shape (n, q)
        Quadrature abscissae along the centre line (m), weights (dy, m) and half thickness h(y) (m).
    y_contact, h_contact, alpha1 : ndarray, shape (n,)
        Centre-line coordinate and half thickness of the contact point, and the load angle alpha_1.
    youngs_modulus, shear_modulus : float
        E*, G* (Pa).
    face_width : float
        L (m).

    Returns
    -------
    (1/k_b, 1/k_s, 1/k_a) : tuple of ndarray, shape (n,), m/N.

    References
    ----------
    Sun et al. (2021) Eq 15; Yang & Lin (1987); Tian (2004): U_b = int M^2/(2EI), U_s = int 1.2 F_b^2/(2GA),
    U_a = int F_a^2/(2EA).
    """
    c = np.cos(alpha1)[:, None]
    s = np.sin(alpha1)[:, None]
    moment = (y_contact[:, None] - y) * c - h_contact[:, None] * s
    inertia = 2.0 * half_thickness**3 * face_width / 3.0
    area = 2.0 * half_thickness * face_width
    kb = np.sum(weights * moment**2 / (youngs_modulus * inertia), axis=1)
    ks = np.sum(weights * 1.2 * c**2 / (shear_modulus * area), axis=1)
    ka = np.sum(weights * s**2 / (youngs_modulus * area), axis=1)
    return kb, ks, ka


def sainsot_fillet_compliance(
    alpha1: np.ndarray,
    u_f: np.ndarray,
    s_f: float,
    theta_f: float,
    h_f: float,
    youngs_modulus: float,
    face_width: float,
) -> np.ndarray:
    """Fillet-foundation compliance 1/k_f of Sainsot, Velex, Duverger (2004), m/N.

    ``1/k_f = cos^2(alpha_1)/(E L) [L* (u_f/S_f)^2 + M* (u_f/S_f) + P* (1 + Q* tan^2(alpha_1))]``,
    ``X* = A/theta_f^2 + B h_f^2 + C h_f/theta_f + D/theta_f + E h_f + F`` (``SAINSOT_COEFFICIENTS``).

    References
    ----------
    Sainsot et al. (2004) J. Mech. Des. 126, 748-752, Eq 7 and Table 1; Sun et al. (2021) Eq 13 (k_f).
    """
    basis = np.array([1.0 / theta_f**2, h_f**2, h_f / theta_f, 1.0 / theta_f, h_f, 1.0])
    lstar, mstar, pstar, qstar = SAINSOT_COEFFICIENTS @ basis
    ratio = u_f / s_f
    return (np.cos(alpha1) ** 2 / (youngs_modulus * face_width)) * (
        lstar * ratio**2 + mstar * ratio + pstar * (1.0 + qstar * np.tan(alpha1) ** 2)
    )


@dataclass(frozen=True)
class MeshStiffnessTable:
    """Mesh stiffness and contact kinematics over one mesh period at one temperature (Eqs 13-15).

    Attributes
    ----------
    temperature_c : float
        Gear temperature of the table, deg C.
    phase : ndarray, shape (n,)
        Uniform mesh-phase grid on [0, 1).
    stiffness : ndarray, shape (n,)
        K* (Eq 13), N/m.
    n_pairs : ndarray of int, shape (n,)
        Tooth pairs in contact.
    load_share : ndarray, shape (n, p)
        Share of the mesh force carried by pair j (0 where not in contact; rows sum to 1).
    contact_position : ndarray, shape (n, p)
        Contact point of pair j along the line of action, measured from the pinion's base-circle
        tangency point T1, m (NaN where not in contact). The gear's arm is ``line_of_action_length - s``.
    sliding_sign : ndarray, shape (n, p)
        sign(s - s_P): direction of the pinion's sliding relative to the gear along the off-line-of-action
        direction ``t`` (see elements/mesh.py); -1 before, +1 after the pitch point, 0 where not in contact.
    pitch_point : float
        s_P = r_b1 tan(alpha), m.
    line_of_action_length : float
        T1T2 = a sin(alpha), m.
    contact_ratio : float
    base_pitch : float
        m.
    """

    temperature_c: float
    phase: np.ndarray
    stiffness: np.ndarray
    n_pairs: np.ndarray
    load_share: np.ndarray
    contact_position: np.ndarray
    sliding_sign: np.ndarray
    pitch_point: float
    line_of_action_length: float
    contact_ratio: float
    base_pitch: float

    @property
    def mean(self) -> float:
        """Mean mesh stiffness over one period, N/m."""
        return float(np.mean(self.stiffness))

    @property
    def min(self) -> float:
        return float(np.min(self.stiffness))

    @property
    def max(self) -> float:
        return float(np.max(self.stiffness))

    @property
    def double_contact_fraction(self) -> float:
        """Fraction of the period with more than one pair in contact (= eps - 1 for 1 < eps < 2)."""
        return float(np.mean(self.n_pairs > 1))

    def interpolate(self, phase: np.ndarray | float, values: np.ndarray | None = None) -> np.ndarray:
        """Periodic linear interpolation of ``values`` (default the stiffness) at mesh ``phase``."""
        v = self.stiffness if values is None else values
        return np.interp(np.asarray(phase, dtype=float), self.phase, v, period=1.0)


def iso_mesh_stiffness(
    pinion_teeth: int,
    gear_teeth: int,
    contact_ratio: float,
    face_width: float,
    youngs_moduli: tuple[float, float] | None = None,
) -> dict[str, float]:
    """ISO 6336-1 single stiffness c' and mesh stiffness c_gamma_alpha (spur, no profile shift).

    ``q' = C1 + C2/z1 + C3/z2`` (mm um/N), ``c'_th = 1/q'``, ``c' = c'_th C_M C_R C_B`` with
    C_M = 0.8, C_R = 1 (solid disc), C_B = 1 (standard basic rack), and
    ``c_gamma_alpha = c' (0.75 eps_alpha + 0.25)``; both scaled by ``E/E_st`` (E_st = 206 GPa, ISO's
    rule for other materials) with ``E = 2 E1 E2/(E1 + E2)`` when ``youngs_moduli`` (E1, E2) are given.

    Returns
    -------
    dict with ``c_prime`` and ``c_gamma_alpha`` (N/m per m of face width, i.e. Pa) and
    ``mesh_stiffness`` = c_gamma_alpha * b (N/m).

    References
    ----------
    ISO 6336-1:2019, Eqs 9.1-9.4, 9.10 (valid for F_t/b >= 100 N/mm).
    """
    c = ISO_Q_COEFFICIENTS
    q = c[0] + c[1] / pinion_teeth + c[2] / gear_teeth  # x1 = x2 = 0
    c_prime = (1.0 / q) * 0.8 * 1.0 * 1.0 * 1e9  # N/(mm um) -> N/m^2
    if youngs_moduli is not None:
        e1, e2 = youngs_moduli
        c_prime *= (2.0 * e1 * e2 / (e1 + e2)) / ISO_STEEL_MODULUS
    c_gamma = c_prime * (0.75 * contact_ratio + 0.25)
    return {"c_prime": c_prime, "c_gamma_alpha": c_gamma, "mesh_stiffness": c_gamma * face_width}
