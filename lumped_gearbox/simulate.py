"""Set up the lumped model at an operating point, integrate it, and return the output channels."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from lumped_gearbox import model as mdl
from lumped_gearbox.bearing import defect_forces
from lumped_gearbox.faults import (
    BearingDefect,
    BearingStiffness,
    CardanMisalignment,
    Eccentricity,
    Fault,
    GearMisalignment,
    LooseHousing,
    MassUnbalance,
    ShaftCrack,
    TemperatureOffset,
    ToothDamage,
    ToothWear,
)
from lumped_gearbox.load_profile import N_LOAD_PROFILE
from lumped_gearbox.loose_housing import bearing_relief, fault_terms
from lumped_gearbox.mesh import RELIEF_CYCLES, pair_amplitude
from lumped_gearbox.params import Gearbox, springs, thermal_axial_load, thermal_half_backlash
from lumped_gearbox.speed_profile import N_PROFILE

CHANNELS = ("dte", "bearing2_fx", "bearing2_fy", "bearing2_fz", "node5_ax", "node5_ay")
UNITS = {"dte": "m", "bearing2_fx": "N", "bearing2_fy": "N", "bearing2_fz": "N"}


@dataclass
class Setup:
    """Parameter vectors of the kernel (see ``model.py``) and what they were built from."""

    geo: np.ndarray
    mass: np.ndarray
    kk: np.ndarray
    cc: np.ndarray
    load: np.ndarray
    fault: np.ndarray
    tooth_p: np.ndarray
    tooth_g: np.ndarray
    temperature_c: float  # actual (declared + offset)
    thermal_axial_n: float
    mesh_mean: float
    axial_half: float
    speed_rpm: float = 0.0
    bearing_defects: tuple[BearingDefect, ...] = ()
    #: input speed profile vector (``speed_profile.SpeedProfile.vector``); zeros: constant speed
    profile: np.ndarray = field(default_factory=lambda: np.zeros(N_PROFILE))
    #: flank position errors of every tooth (``pitch.PitchErrors.vector``); empty: none
    pitch: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def static_state(self) -> np.ndarray:
        """Static equilibrium at the mean mesh stiffness without STE (q, 8 entries)."""
        g, kk = self.geo, self.kk
        f = self.load[mdl.L_T2] / g[mdl.G_RB2]
        sa, ca = g[mdl.G_SA], g[mdl.G_CA]
        q = np.zeros(8)
        q[0], q[1] = -f * sa / kk[mdl.K_L1], -f * ca / kk[mdl.K_L1]
        q[3] = -f * g[mdl.G_RB1] / kk[mdl.K_T1]
        q[4], q[5] = f * sa / kk[mdl.K_L2], f * ca / kk[mdl.K_L2]
        delta = self.load[mdl.L_B] + f / self.mesh_mean
        rest = sa * (q[0] - q[4]) + ca * (q[1] - q[5]) + g[mdl.G_RB1] * q[3]
        q[7] = (delta - rest) / g[mdl.G_RB2]
        return q


def build(
    gb: Gearbox,
    speed_rpm: float,
    temperature_c: float,
    faults: Sequence[Fault] = (),
    ste: bool = True,
) -> Setup:
    """Kernel parameters at a declared operating point with faults applied.

    Raises
    ------
    ValueError
        Naming the field: speed not positive/finite, temperature outside Table 1.
    """
    if not (math.isfinite(speed_rpm) and 0.0 < speed_rpm <= 30000.0):
        raise ValueError(f"speed_rpm: {speed_rpm!r} outside (0, 30000]")
    offset = sum(f.offset_c for f in faults if isinstance(f, TemperatureOffset))
    temp = temperature_c + offset
    wear = sum(f.wear_depth_m for f in faults if isinstance(f, ToothWear))
    bscale = math.prod(f.scale for f in faults if isinstance(f, BearingStiffness))
    if bscale != 1.0:
        gb = gb.replace(k_radial=gb.k_radial * bscale, k_axial=gb.k_axial * bscale)
    sp = springs(gb, temp)
    m1, j1, m2, j2 = gb.masses()
    mb1, _ = gb.disc(gb.pitch_radii[0])
    mb2, _ = gb.disc(gb.pitch_radii[1])
    rb1, rb2 = gb.base_radii
    eps = gb.contact_ratio
    w1 = speed_rpm * 2.0 * math.pi / 60.0
    geo = np.array(
        [
            gb.z1,
            gb.z2,
            eps,
            rb1,
            rb2,
            math.sin(gb.pressure_angle_rad),
            math.cos(gb.pressure_angle_rad),
            w1,
            w1 * gb.z1 / gb.z2,
            gb.pitch_point_fraction,
            gb.face_width_m,
            RELIEF_CYCLES,
        ]
    )
    mass = np.array([m1, j1, m2, j2, mb1, mb2])
    kk = np.array([sp.lateral, sp.lateral, 2 * sp.axial_half, 2 * sp.axial_half, sp.torsion_input, 0.0])
    kk[mdl.K_PAIR] = pair_amplitude(sp.mesh_mean, eps)
    m_e = 1.0 / (rb1**2 / j1 + rb2**2 / j2)
    cc = np.array(
        [
            2 * gb.c_radial,
            2 * gb.c_radial,
            2 * gb.c_axial,
            2 * gb.c_axial,
            2 * gb.torsion_damping_ratio * math.sqrt(sp.torsion_input * j1),
            2 * gb.mesh_damping_ratio * math.sqrt(sp.mesh_mean * m_e),
        ]
    )
    # [T0, b, e0, phase, then the load-torque profile (load_profile.py; zeros: constant torque)]
    load = np.zeros(mdl.L_TA + N_LOAD_PROFILE)
    load[: mdl.L_TA] = [
        gb.output_torque_nm,
        thermal_half_backlash(gb, temp, wear),
        gb.ste_amplitude_m if ste else 0.0,
        0.0,
    ]
    fault = np.zeros(mdl.N_FAULT)
    fault[mdl.F_WEAR] = wear
    tooth_p = np.ones(gb.z1)
    tooth_g = np.ones(gb.z2)
    for f in faults:
        if isinstance(f, ToothDamage):
            arr = tooth_p if f.wheel == "pinion" else tooth_g
            arr[int(f.tooth) - 1] *= 1.0 - f.depth
        elif isinstance(f, Eccentricity):
            i = mdl.F_ECC_P if f.member == "pinion" else mdl.F_ECC_G
            fault[i], fault[i + 1] = f.eccentricity_m, f.phase_rad
        elif isinstance(f, MassUnbalance):
            i = mdl.F_UNB_P if int(f.node) == 5 else mdl.F_UNB_G
            fault[i], fault[i + 1] = f.unbalance_kg_m, f.phase_rad
        elif isinstance(f, GearMisalignment):
            fault[mdl.F_MIS], fault[mdl.F_MIS_PH] = f.angle_rad, f.phase_rad
            fault[mdl.F_MIS_GEAR] = 1.0 if f.member == "gear" else 0.0
        elif isinstance(f, ShaftCrack):
            fault[mdl.F_CRACK], fault[mdl.F_CRACK_PH] = f.stiffness_loss, f.phase_rad
            fault[mdl.F_CRACK_GEAR] = 1.0 if f.shaft == "gear" else 0.0
        elif isinstance(f, CardanMisalignment):
            fault[mdl.F_CARDAN], fault[mdl.F_CARDAN_PH] = f.angle_rad, f.phase_rad
    for f in faults:
        if isinstance(f, LooseHousing):  # loose_housing.py; its driving unbalance adds to node 5's
            fault[mdl.F_LOOSE : mdl.F_LOOSE_SHARE + 1] = fault_terms(
                f.stiffness_loss,
                f.clearance_m,
                f.preload_n,
                f.direction_rad,
                sp.lateral_bending,
                gb.k_radial,
                geo[mdl.G_SA],
                geo[mdl.G_CA],
            )
            if f.unbalance_kg_m > 0.0:
                u = fault[mdl.F_UNB_P] * np.exp(1j * fault[mdl.F_UNB_P_PH]) + f.unbalance_kg_m * np.exp(
                    1j * f.phase_rad
                )
                fault[mdl.F_UNB_P], fault[mdl.F_UNB_P_PH] = abs(u), float(np.angle(u))
    return Setup(
        geo,
        mass,
        kk,
        cc,
        load,
        fault,
        tooth_p,
        tooth_g,
        temp,
        thermal_axial_load(gb, temp),
        sp.mesh_mean,
        sp.axial_half,
        speed_rpm,
        tuple(f for f in faults if isinstance(f, BearingDefect)),
    )


def integrate_from_rest(
    setup: Setup, t0: float, dt: float, substeps: int, n_out: int, n_skip: int
) -> np.ndarray:
    """RK4 from static equilibrium at ``t0``: ``n_skip`` stored instants discarded, then ``n_out`` kept,
    one every ``substeps`` steps of ``dt`` (rows: q, v, a (8 each), mesh force, mesh stiffness)."""
    out = mdl.integrate(
        t0,
        dt,
        substeps,
        n_out,
        setup.static_state(),
        np.zeros(8),
        setup.geo,
        setup.mass,
        setup.kk,
        setup.cc,
        setup.load,
        setup.fault,
        setup.tooth_p,
        setup.tooth_g,
        n_skip,
        setup.profile,
        setup.pitch,
    )
    if out.shape[0] != n_out:
        raise RuntimeError("lumped model diverged (non-finite state); reduce the time step (substeps)")
    return out


def run(
    setup: Setup,
    duration_s: float,
    sample_rate_hz: float = 20000.0,
    substeps: int = 8,
    preroll_s: float = 0.3,
) -> dict[str, np.ndarray]:
    """Integrate from static equilibrium at ``t = -preroll_s`` and return the clean channels.

    Returns
    -------
    dict
        ``time_s`` (0 at input-shaft angle 0), the six :data:`CHANNELS` and, for tests,
        ``mesh_force``, ``mesh_stiffness``, ``q`` (n, 8), ``v`` (n, 8), ``a`` (n, 8).
    """
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration_s: {duration_s!r} must be positive")
    if not (math.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        raise ValueError(f"sample_rate_hz: {sample_rate_hz!r} must be positive")
    n_out = round(duration_s * sample_rate_hz)
    n_skip = round(preroll_s * sample_rate_hz)
    dt = 1.0 / (sample_rate_hz * substeps)
    out = integrate_from_rest(setup, -n_skip / sample_rate_hz, dt, substeps, n_out, n_skip)
    return channels(setup, out, np.arange(n_out) / sample_rate_hz)


def channels(setup: Setup, out: np.ndarray, t: np.ndarray) -> dict[str, np.ndarray]:
    """The output channels from the stored states ``out`` of :func:`model.integrate` at times ``t``.

    The bearing-defect pulses are averaged over each interval of ``t``'s grid (``bearing.py``), so
    they follow the grid the states were stored on: the record's samples (:func:`run`) or every
    integration step (the data-acquisition chain, ``daq.py``).
    """
    q, v, a = out[:, 0:8], out[:, 8:16], out[:, 16:24]
    g, kk, cc = setup.geo, setup.kk, setup.cc
    sa, ca = g[mdl.G_SA], g[mdl.G_CA]
    pulses = np.zeros((t.size, 2))
    load_angle = math.atan2(-ca, -sa)  # direction of bearing 2's static load on the housing
    for i, d in enumerate(setup.bearing_defects):
        pulses += defect_forces(
            d.kind,
            d.force_n,
            d.defect_angle_rad,
            setup.speed_rpm,
            t,
            load_angle,
            seed=i,
            profile=setup.profile,
        )
    crack = np.zeros((t.size, 2))  # a cracked pinion shaft's extra restoring force (shaft_faults.py)
    if setup.fault[mdl.F_CRACK] > 0.0 and setup.fault[mdl.F_CRACK_GEAR] < 0.5:
        loss_k = setup.fault[mdl.F_CRACK] * kk[mdl.K_L1]
        psi = g[mdl.G_W1] * t + setup.fault[mdl.F_CRACK_PH]
        n = np.column_stack([np.cos(psi), np.sin(psi)])  # crack_force, vectorised
        crack = loss_k * np.maximum(np.sum(n * q[:, 0:2], axis=1), 0.0)[:, None] * n
    if setup.fault[mdl.F_LOOSE] > 0.0:  # bearing 2's changed load path (loose_housing.py)
        f = setup.fault
        nvec = np.array([f[mdl.F_LOOSE_NX], f[mdl.F_LOOSE_NY]])
        relief = bearing_relief(
            q[:, 0:2] @ nvec, f[mdl.F_LOOSE_LIFT], f[mdl.F_LOOSE_GAP], kk[mdl.K_L1], f[mdl.F_LOOSE_SHARE]
        )
        crack = crack + 2.0 * relief[:, None] * nvec  # the channels take half of ``crack``
    dte = (
        sa * (q[:, 0] - q[:, 4]) + ca * (q[:, 1] - q[:, 5]) + g[mdl.G_RB1] * q[:, 3] + g[mdl.G_RB2] * q[:, 7]
    )
    return {
        "time_s": t,
        "dte": dte,
        # force transmitted to the housing by bearing 2 (input shaft, node 9): half the shaft's force
        # plus the pulses of bearing defects (between race and housing)
        "bearing2_fx": 0.5 * (kk[mdl.K_L1] * q[:, 0] - crack[:, 0] + cc[mdl.C_L1] * v[:, 0]) + pulses[:, 0],
        "bearing2_fy": 0.5 * (kk[mdl.K_L1] * q[:, 1] - crack[:, 1] + cc[mdl.C_L1] * v[:, 1]) + pulses[:, 1],
        "bearing2_fz": setup.thermal_axial_n + setup.axial_half * q[:, 2] + 0.5 * cc[mdl.C_Z1] * v[:, 2],
        "node5_ax": a[:, 0],
        "node5_ay": a[:, 1],
        "mesh_force": out[:, 24],
        "mesh_stiffness": out[:, 25],
        "q": q,
        "v": v,
        "a": a,
    }
