"""Two-node Timoshenko shaft element, 6 DOF per node (Sec 3.3, Eqs 9-12, 34-36).

Element DOF order (Eq 35): ``x_i, y_i, z_i, theta_x_i, theta_y_i, theta_z_i, x_j, ..., theta_z_j``.
The shaft axis is z; node i is at z = 0 and node j at z = L.

Sign conventions of the two bending planes (right-handed rotations about the global axes):

* x-z plane: the displacement is x and the cross-section rotation is ``theta_y`` (a positive rotation
  about y turns the z axis towards +x), so for pure bending ``theta_y = +dx/dz``.
* y-z plane: the displacement is y and the rotation is ``theta_x`` (a positive rotation about x turns
  the z axis towards -y), so ``theta_x = -dy/dz``.

Each plane is the classical planar Timoshenko element with DOFs (w, beta), beta the bending slope
(Friswell et al. 2010, Sec 5.4; Przemieniecki 1968). The 12x12 matrices are assembled as
``T_p^T K_plane T_p`` with the signed selection matrices ``T_xz`` (x, theta_y) and ``T_yz``
(y, -theta_x), so the sign coupling of the y-z plane is explicit rather than hand-edited.

Gyroscopic matrix (per rad/s of spin about +z): for a spinning section the angular momentum is
``rho I_p Omega`` along the tilted axis ``(theta_y, -theta_x, 1)``; its rate gives the moments
``m_x = +rho I_p Omega theta_y'`` and ``m_y = -rho I_p Omega theta_x'`` on the left-hand side, i.e. the
equation ``M q'' + Omega G q' + K q = F`` with ``G = 2 (T_xz^T R T_yz - T_yz^T R T_xz)``, R the
rotary-inertia matrix of one plane (rho I per length; ``I_p = 2 I``). G is skew-symmetric.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gear_rotor_sim.materials import Material

# Signed selection of the plane DOFs (w_i, beta_i, w_j, beta_j) from the 12 element DOFs (Eq 35).
_T_XZ = np.zeros((4, 12))
_T_XZ[0, 0] = _T_XZ[1, 4] = _T_XZ[2, 6] = _T_XZ[3, 10] = 1.0  # x, +theta_y
_T_YZ = np.zeros((4, 12))
_T_YZ[0, 1] = _T_YZ[2, 7] = 1.0  # y
_T_YZ[1, 3] = _T_YZ[3, 9] = -1.0  # beta = dy/dz = -theta_x
_AXIAL = (2, 8)  # z_i, z_j
_TORSION = (5, 11)  # theta_z_i, theta_z_j


def cowper_shear_coefficient(poisson_ratio: float, inner_to_outer: float = 0.0) -> float:
    """Timoshenko shear coefficient of a solid or hollow circular section (Cowper 1966).

    ``mu = 6 (1+nu) (1+m^2)^2 / ((7+6nu) (1+m^2)^2 + (20+12nu) m^2)``, m = d_i/d_o; for m = 0 this is
    ``6 (1+nu) / (7+6nu)``.

    References
    ----------
    Cowper, G.R. (1966), J. Appl. Mech. 33, 335-340. Used as mu of Eq 12 (Sun et al. 2021).
    """
    m2 = inner_to_outer**2
    nu = poisson_ratio
    return 6.0 * (1.0 + nu) * (1.0 + m2) ** 2 / ((7.0 + 6.0 * nu) * (1.0 + m2) ** 2 + (20.0 + 12.0 * nu) * m2)


def _plane_stiffness(ei: float, length: float, phi: float) -> np.ndarray:
    """Planar Timoshenko bending stiffness for DOFs (w_i, beta_i, w_j, beta_j), beta = dw/dz."""
    L = length
    return (
        ei
        / (L**3 * (1.0 + phi))
        * np.array(
            [
                [12.0, 6.0 * L, -12.0, 6.0 * L],
                [6.0 * L, (4.0 + phi) * L**2, -6.0 * L, (2.0 - phi) * L**2],
                [-12.0, -6.0 * L, 12.0, -6.0 * L],
                [6.0 * L, (2.0 - phi) * L**2, -6.0 * L, (4.0 + phi) * L**2],
            ]
        )
    )


def _plane_translational_mass(rho_a: float, length: float, phi: float) -> np.ndarray:
    """Planar Timoshenko consistent translational mass (Friswell et al. 2010, Eq 5.76)."""
    L = length
    m1 = 13.0 / 35.0 + 7.0 * phi / 10.0 + phi**2 / 3.0
    m2 = 11.0 / 210.0 + 11.0 * phi / 120.0 + phi**2 / 24.0
    m3 = 9.0 / 70.0 + 3.0 * phi / 10.0 + phi**2 / 6.0
    m4 = 13.0 / 420.0 + 3.0 * phi / 40.0 + phi**2 / 24.0
    m5 = 1.0 / 105.0 + phi / 60.0 + phi**2 / 120.0
    m6 = 1.0 / 140.0 + phi / 60.0 + phi**2 / 120.0
    return (
        rho_a
        * L
        / (1.0 + phi) ** 2
        * np.array(
            [
                [m1, m2 * L, m3, -m4 * L],
                [m2 * L, m5 * L**2, m4 * L, -m6 * L**2],
                [m3, m4 * L, m1, -m2 * L],
                [-m4 * L, -m6 * L**2, -m2 * L, m5 * L**2],
            ]
        )
    )


def _plane_rotary_mass(rho_i: float, length: float, phi: float) -> np.ndarray:
    """Planar Timoshenko consistent rotary-inertia mass (Friswell et al. 2010, Eq 5.77)."""
    L = length
    m7 = 6.0 / 5.0
    m8 = 1.0 / 10.0 - phi / 2.0
    m9 = 2.0 / 15.0 + phi / 6.0 + phi**2 / 3.0
    m10 = 1.0 / 30.0 + phi / 6.0 - phi**2 / 6.0
    return (
        rho_i
        / (L * (1.0 + phi) ** 2)
        * np.array(
            [
                [m7, m8 * L, -m7, m8 * L],
                [m8 * L, m9 * L**2, -m8 * L, -m10 * L**2],
                [-m7, -m8 * L, m7, -m8 * L],
                [m8 * L, -m10 * L**2, -m8 * L, m9 * L**2],
            ]
        )
    )


def _two_node(value: float) -> np.ndarray:
    """Bar/torsion matrix ``value * [[1, -1], [-1, 1]]``."""
    return value * np.array([[1.0, -1.0], [-1.0, 1.0]])


@dataclass(frozen=True)
class ShaftElement:
    """Timoshenko beam element of a solid or hollow circular shaft.

    Parameters
    ----------
    length : float
        Element length l, m.
    outer_diameter : float
        Outer diameter, m.
    inner_diameter : float
        Bore diameter, m (0 for a solid shaft).
    material : Material
        Temperature-dependent material (E*, G* of Eqs 11-12).
    shear_coefficient : float or None
        Timoshenko shear factor mu of Eq 12; None uses Cowper's value for the section at the
        element's Poisson ratio.

    References
    ----------
    Sun et al. (2021), Sec 3.3, Eqs 34-36 (element), Eq 12 (phi), Eqs 9-11 (thermal node load).
    Nelson, H.D. (1980), J. Mech. Des. 102, 793-803 (Timoshenko rotor element).
    Friswell, Penny, Garvey, Lees (2010), Dynamics of Rotating Machines, Sec 5.4.
    """

    length: float
    outer_diameter: float
    inner_diameter: float
    material: Material
    shear_coefficient: float | None = None

    def __post_init__(self) -> None:
        if not self.length > 0.0:
            raise ValueError(f"length: {self.length} must be > 0 m")
        if not self.outer_diameter > 0.0:
            raise ValueError(f"outer_diameter: {self.outer_diameter} must be > 0 m")
        if not 0.0 <= self.inner_diameter < self.outer_diameter:
            raise ValueError(
                f"inner_diameter: {self.inner_diameter} must satisfy "
                f"0 <= inner < outer ({self.outer_diameter}) m"
            )

    # -- section properties ---------------------------------------------------------------------
    @property
    def area(self) -> float:
        """Cross-section area A, m^2."""
        return np.pi / 4.0 * (self.outer_diameter**2 - self.inner_diameter**2)

    @property
    def second_moment(self) -> float:
        """Diametral second moment of area I, m^4."""
        return np.pi / 64.0 * (self.outer_diameter**4 - self.inner_diameter**4)

    @property
    def polar_moment(self) -> float:
        """Polar second moment of area I_ps = 2 I, m^4 (Eq 11)."""
        return 2.0 * self.second_moment

    def mu(self, temperature_c: float) -> float:
        """Shear coefficient mu of Eq 12 at ``temperature_c``."""
        if self.shear_coefficient is not None:
            return float(self.shear_coefficient)
        return cowper_shear_coefficient(
            self.material.poisson_ratio(temperature_c), self.inner_diameter / self.outer_diameter
        )

    def phi(self, temperature_c: float) -> float:
        """Shear deformation factor phi = 12 E* I / (mu A G* l^2) (Eq 12)."""
        e = self.material.youngs_modulus(temperature_c)
        g = self.material.shear_modulus(temperature_c)
        return 12.0 * e * self.second_moment / (self.mu(temperature_c) * self.area * g * self.length**2)

    # -- matrices -------------------------------------------------------------------------------
    def stiffness_matrix(self, temperature_c: float) -> np.ndarray:
        """Element stiffness K^e (Eq 36), 12x12, at E*(T), G*(T).

        Two bending planes with shear factor phi (Eq 12), axial E A / l, torsion G J / l (J = I_ps).
        """
        e = self.material.youngs_modulus(temperature_c)
        g = self.material.shear_modulus(temperature_c)
        phi = self.phi(temperature_c)
        kb = _plane_stiffness(e * self.second_moment, self.length, phi)
        k = _T_XZ.T @ kb @ _T_XZ + _T_YZ.T @ kb @ _T_YZ
        k[np.ix_(_AXIAL, _AXIAL)] += _two_node(e * self.area / self.length)
        k[np.ix_(_TORSION, _TORSION)] += _two_node(g * self.polar_moment / self.length)
        return k

    def mass_matrix(self, temperature_c: float) -> np.ndarray:
        """Consistent element mass M^e (Eq 36), 12x12: translational + rotary inertia, axial, torsion.

        Temperature enters only through phi (density is constant).
        """
        rho = self.material.density
        phi = self.phi(temperature_c)
        L = self.length
        mp = _plane_translational_mass(rho * self.area, L, phi) + _plane_rotary_mass(
            rho * self.second_moment, L, phi
        )
        m = _T_XZ.T @ mp @ _T_XZ + _T_YZ.T @ mp @ _T_YZ
        consistent_bar = np.array([[2.0, 1.0], [1.0, 2.0]]) / 6.0
        m[np.ix_(_AXIAL, _AXIAL)] += rho * self.area * L * consistent_bar
        m[np.ix_(_TORSION, _TORSION)] += rho * self.polar_moment * L * consistent_bar
        return m

    def gyroscopic_matrix(self, temperature_c: float) -> np.ndarray:
        """Element gyroscopic matrix G^e per rad/s of spin about +z (Eq 36), 12x12, skew-symmetric.

        ``G = 2 (T_xz^T R T_yz - T_yz^T R T_xz)`` with R the planar rotary-inertia matrix (rho I);
        the factor 2 is I_p / I of a circular section.
        """
        r = _plane_rotary_mass(
            self.material.density * self.second_moment, self.length, self.phi(temperature_c)
        )
        return 2.0 * (_T_XZ.T @ r @ _T_YZ - _T_YZ.T @ r @ _T_XZ)

    def thermal_node_load(self, temperature_c: float, reference_temperature_c: float) -> np.ndarray:
        """Thermal node load F_T of the element (Eqs 9-11), 12-vector in the DOF order of Eq 35.

        Uniform steady temperature ``temperature_c`` over the element, unstressed at
        ``reference_temperature_c``; dT = temperature_c - reference_temperature_c.

        * Axial (Eq 9 with B = d/dz of the linear axial shape functions, D = E*):
          ``F_T = E* A a dT * [-1 at z_i, +1 at z_j]``, i.e. ``f_T A / I_ps`` of Eqs 10-11. It is the
          equivalent load of an initial strain: applied to the free element it produces exactly the
          free expansion ``a dT l`` and zero stress.
        * Lateral forces and bending moments: zero. Eq 9 projects the thermal strain through the
          bending part of B, ``-y d(theta)/dz`` type terms, and integrates over the section; for a
          temperature uniform over the section ``int y dA = int x dA = 0``, so they vanish. Lateral
          thermal loads arise only from a temperature gradient across the section, which the paper's
          steady uniform field does not have. The printed Eq 10 (7 columns in 2 rows for 12 DOFs) is
          garbled; only its axial column ``-/+ A/I_ps`` is consistent with Eq 9, and it is the only one
          the paper validates (Table 2). See docs/thermal_node_load.md.
        * Torsion: zero (thermal strain has no shear part, Eq 2).

        E* is taken at the element's temperature (Eq 11), which reproduces Table 2 within 0.016 %.

        References
        ----------
        Sun et al. (2021), Eqs 2, 9, 10, 11, Table 2.
        """
        dt = float(temperature_c) - float(reference_temperature_c)
        f = np.zeros(12)
        if dt == 0.0:
            return f
        e = self.material.youngs_modulus(temperature_c)
        axial = e * self.area * self.material.expansion_coefficient * dt  # f_T A / I_ps, Eq 11
        f[_AXIAL[0]] = -axial
        f[_AXIAL[1]] = axial
        return f
