"""Parameters of the lumped gearbox: the paper's numbers typed in, and the equivalent springs.

Everything here is derived from the text of Sun et al. (2021) (Tables 1, 3, 4, 5; Sec 2.1, 4.1) and
textbook formulas; nothing is imported from ``gear_rotor_sim``.

Layout (Fig 5 of the paper): two equal shafts (140 mm, 30 mm diameter), each on two bearings at its
ends (input: bearings 1 and 2, output: bearings 3 and 4), pinion (29 teeth) and gear (49 teeth) at
mid-span (nodes 5 and 14), driven at constant speed at the input end (node 1), loaded by the output
torque T2 = 200 N m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

# Table 1 (carbon steel): temperature (C) -> Young's modulus (Pa), Poisson's ratio
TABLE1_T_C = np.array([25.0, 125.0, 225.0, 325.0])
TABLE1_E_PA = np.array([207.0e9, 200.0e9, 189.0e9, 174.0e9])
TABLE1_NU = np.array([0.290, 0.294, 0.298, 0.302])
EXPANSION_PER_C = 1.17e-5  # Sec 2.1
DENSITY = 7860.0  # Table 3
ISO_STEEL_E = 206.0e9  # reference modulus of the ISO 6336-1 tooth stiffness


def youngs_modulus(temperature_c: float) -> float:
    """Young's modulus E(T), Pa: piecewise-linear through Table 1 (25-325 C).

    Raises
    ------
    ValueError
        If ``temperature_c`` lies outside Table 1 (25-325 C).
    """
    _check_temperature(temperature_c)
    return float(np.interp(temperature_c, TABLE1_T_C, TABLE1_E_PA))


def shear_modulus(temperature_c: float) -> float:
    """Shear modulus ``G = E / (2 (1 + nu))`` at ``temperature_c``, Pa."""
    nu = float(np.interp(temperature_c, TABLE1_T_C, TABLE1_NU))
    return youngs_modulus(temperature_c) / (2.0 * (1.0 + nu))


def _check_temperature(temperature_c: float) -> None:
    if not (np.isfinite(temperature_c) and TABLE1_T_C[0] <= temperature_c <= TABLE1_T_C[-1]):
        raise ValueError(
            f"temperature_c: {temperature_c!r} is outside the material table (Table 1): "
            f"allowed {TABLE1_T_C[0]:g} to {TABLE1_T_C[-1]:g} C"
        )


@dataclass(frozen=True)
class Gearbox:
    """Geometry, material and supports of the paper's gearbox (SI units).

    Attributes
    ----------
    z1, z2 : int
        Pinion and gear teeth (Table 3).
    module_m, pressure_angle_rad, face_width_m : float
        Table 3.
    addendum_coef : float
        h_a* (Table 3).
    shaft_length_m, shaft_diameter_m : float
        Each shaft: Table 4 (8 elements, 140 mm, 30 mm); the gears sit at mid-span.
    k_radial, k_axial, c_radial, c_axial : float
        Bearing A# (Table 5), N/m and N s/m.
    half_backlash_m : float
        b = 35 um (Sec 4.2).
    ste_amplitude_m : float
        e0 = 20 um (Sec 4.2), static transmission error amplitude at the mesh frequency.
    output_torque_nm : float
        T2 (Table 3).
    reference_temperature_c : float
        Temperature of the as-built, unstressed state (the paper's Table 2 starts at 25 C).
    housing_expansion_per_c : float
        Expansion coefficient of the housing (grey cast iron, 1.05e-5 /C; an assumption of this model,
        the paper gives none): sets how the centre distance follows the temperature.
    mesh_damping_ratio, torsion_damping_ratio : float
        Modal damping of the mesh and of the drive-shaft torsion (not in the paper; chosen here).
    """

    z1: int = 29
    z2: int = 49
    module_m: float = 3.0e-3
    pressure_angle_rad: float = math.radians(20.0)
    face_width_m: float = 20.0e-3
    addendum_coef: float = 1.0
    shaft_length_m: float = 0.140
    shaft_diameter_m: float = 0.030
    k_radial: float = 1.15e8
    k_axial: float = 2.28e7
    c_radial: float = 1.0e3
    c_axial: float = 1.0e3
    half_backlash_m: float = 35.0e-6
    ste_amplitude_m: float = 20.0e-6
    output_torque_nm: float = 200.0
    reference_temperature_c: float = 25.0
    housing_expansion_per_c: float = 1.05e-5
    mesh_damping_ratio: float = 0.05
    torsion_damping_ratio: float = 0.02

    def replace(self, **changes: float) -> Gearbox:
        return replace(self, **changes)

    # ---- gear geometry ----------------------------------------------------------------------------
    @property
    def pitch_radii(self) -> tuple[float, float]:
        return 0.5 * self.module_m * self.z1, 0.5 * self.module_m * self.z2

    @property
    def base_radii(self) -> tuple[float, float]:
        c = math.cos(self.pressure_angle_rad)
        r1, r2 = self.pitch_radii
        return r1 * c, r2 * c

    @property
    def centre_distance(self) -> float:
        return sum(self.pitch_radii)

    @property
    def base_pitch(self) -> float:
        return math.pi * self.module_m * math.cos(self.pressure_angle_rad)

    def path_of_contact(self) -> tuple[float, float]:
        """Lengths of approach and recess along the line of action, m (pinion driving)."""
        r1, r2 = self.pitch_radii
        b1, b2 = self.base_radii
        ha = self.addendum_coef * self.module_m
        s = math.sin(self.pressure_angle_rad)
        approach = math.sqrt((r2 + ha) ** 2 - b2**2) - r2 * s  # gear tip to the pitch point
        recess = math.sqrt((r1 + ha) ** 2 - b1**2) - r1 * s  # pitch point to the pinion tip
        return approach, recess

    @property
    def contact_ratio(self) -> float:
        """Transverse contact ratio: path of contact / base pitch."""
        return sum(self.path_of_contact()) / self.base_pitch

    @property
    def pitch_point_fraction(self) -> float:
        """Position of the pitch point along one pair's path, as a fraction of the path."""
        a, r = self.path_of_contact()
        return a / (a + r)

    # ---- inertias: solid discs at the pitch circle, bored for the shaft, plus a third of the shaft --
    def disc(self, radius: float) -> tuple[float, float]:
        """Mass and polar inertia of a bored disc of ``radius`` and the face width."""
        rb = 0.5 * self.shaft_diameter_m
        m = DENSITY * math.pi * (radius**2 - rb**2) * self.face_width_m
        j = 0.5 * m * (radius**2 + rb**2)
        return m, j

    @property
    def shaft_mass(self) -> float:
        return DENSITY * math.pi * (0.5 * self.shaft_diameter_m) ** 2 * self.shaft_length_m

    def masses(self) -> tuple[float, float, float, float]:
        """Pinion mass, pinion polar inertia, gear mass, gear polar inertia (kg, kg m^2).

        Rigid discs of pitch radius and face width with the shaft bore, plus the participating part of
        the massless-spring shaft: 17/35 of its mass for the lateral mid-span mode of a pinned beam
        (Rayleigh), a third of its polar inertia for torsion.
        """
        r1, r2 = self.pitch_radii
        m1, j1 = self.disc(r1)
        m2, j2 = self.disc(r2)
        ms = self.shaft_mass
        js = 0.5 * ms * (0.5 * self.shaft_diameter_m) ** 2
        lat = 17.0 / 35.0 * ms
        return m1 + lat, j1 + js / 3.0, m2 + lat, j2 + js / 3.0


@dataclass(frozen=True)
class Springs:
    """Equivalent springs of the lumped model at one temperature (N/m, N m/rad, N s/m)."""

    lateral: float  # shaft bending at mid-span in series with the two bearings
    lateral_bending: float
    axial_half: float  # one half shaft in series with its bearing (axial)
    torsion_input: float  # drive end (node 1) to the pinion (node 5)
    shaft_axial: float  # whole shaft, E A / L
    mesh_mean: float  # ISO mean mesh stiffness c_gamma_alpha * b at E(T)
    mesh_single_pair: float  # ISO single-pair stiffness c' * b at E(T)


def springs(gb: Gearbox, temperature_c: float) -> Springs:
    """The equivalent springs at a uniform temperature.

    - Lateral: a pinned-pinned Euler-Bernoulli beam loaded at mid-span, ``L^3 / (48 E I)``, in series
      with the two bearings in parallel (each carries half the load), ``1 / (2 k_b)``. The bearings'
      tilt stiffness is neglected (pinned ends).
    - Axial: each half shaft ``E A / (L/2)`` in series with its bearing; the pinion sees both halves.
    - Torsion: ``G J / (L/2)`` from the driven end to the pinion.
    - Mesh: ISO 6336-1 (method B) single-pair stiffness ``c' = C_M / q'`` with
      ``q' = 0.04723 + 0.15551/z1 + 0.25791/z2`` mm um/N (unshifted teeth), ``C_M = 0.8``, and mean
      mesh stiffness ``c_gamma = c' (0.75 eps + 0.25)``, both per mm face width, scaled by
      ``E(T) / 206 GPa``.
    """
    e = youngs_modulus(temperature_c)
    g = shear_modulus(temperature_c)
    d, length = gb.shaft_diameter_m, gb.shaft_length_m
    area = math.pi * d**2 / 4.0
    inertia = math.pi * d**4 / 64.0
    polar = math.pi * d**4 / 32.0
    bending = 48.0 * e * inertia / length**3
    lateral = 1.0 / (1.0 / bending + 1.0 / (2.0 * gb.k_radial))
    half = e * area / (0.5 * length)
    axial_half = 1.0 / (1.0 / half + 1.0 / gb.k_axial)
    torsion = g * polar / (0.5 * length)
    q = 0.04723 + 0.15551 / gb.z1 + 0.25791 / gb.z2  # mm um / N
    # c' in N/(mm um) times the face width in mm gives N/um; times 1e6 gives N/m.
    width_mm = gb.face_width_m * 1.0e3
    c_single = (0.8 / q) * width_mm * 1.0e6
    scale = e / ISO_STEEL_E
    mean = c_single * (0.75 * gb.contact_ratio + 0.25)
    return Springs(lateral, bending, axial_half, torsion, e * area / length, mean * scale, c_single * scale)


def thermal_axial_load(gb: Gearbox, temperature_c: float) -> float:
    """Axial force of a shaft held by its two bearings at a uniform temperature rise, N.

    The free elongation ``a dT L`` is shared between the shaft (``k_s = E A / L``) and the two
    axial bearing springs in series (``k_b / 2``), so the force is
    ``a dT L / (1/k_s + 2/k_b) = k_s a dT L / (1 + 2 k_s / k_b)``. Positive = compression of the
    shaft, pushing bearing 2 (at the far end) outwards.
    """
    dt = temperature_c - gb.reference_temperature_c
    k_s = youngs_modulus(temperature_c) * math.pi * gb.shaft_diameter_m**2 / 4.0 / gb.shaft_length_m
    return EXPANSION_PER_C * dt * gb.shaft_length_m * k_s / (1.0 + 2.0 * k_s / gb.k_axial)


def thermal_half_backlash(gb: Gearbox, temperature_c: float, extra_m: float = 0.0) -> float:
    """Half backlash along the line of action at a uniform temperature, m.

    A uniform temperature rise scales both (steel) gears by ``1 + a dT``; a scaled pair is conjugate at
    the scaled centre distance. The housing (cast iron) moves the bearings apart by only
    ``a_h dT a``, so the pair sits ``(a - a_h) dT a`` too close; pulling a pair together by ``da``
    removes ``da sin(alpha)`` of normal clearance on each flank side. The backlash itself scales too.
    ``extra_m`` (tooth wear) is added before the thermal change. Never below zero.
    """
    dt = temperature_c - gb.reference_temperature_c
    b = (gb.half_backlash_m + extra_m) * (1.0 + EXPANSION_PER_C * dt)
    closer = (EXPANSION_PER_C - gb.housing_expansion_per_c) * dt * gb.centre_distance
    return max(0.0, b - closer * math.sin(gb.pressure_angle_rad))
