"""Multi-mesh model and kernel (config/two_stage_example.yaml) against independent truth.

Statics against the lever rule through both stages, the linear response of both meshes against a
frequency-domain solve, and the compiled multi-mesh kernel against the general kernel and against the
single-mesh fast kernel on the paper gearbox.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gear_rotor_sim.config import DiscConfig, load_config
from gear_rotor_sim.faults.library import EFFECT_TYPES
from gear_rotor_sim.simulator import Simulator
from gear_rotor_sim.solver import NewmarkStepper, parse_channels, quantize_speed_rpm, static_equilibrium
from gear_rotor_sim.solver.newmark import LinearModel
from gear_rotor_sim.system import GearRotorSystem
from gear_rotor_sim.system_data import AssembledSystem

SPEED_RPM = 3000.0


def _two_stage(friction: float | None = None) -> AssembledSystem:
    cfg = load_config("two_stage_example")
    if friction is not None:
        cfg = cfg.replace(
            meshes=tuple(dataclasses.replace(m, friction_coefficient=friction) for m in cfg.meshes)
        )
    return GearRotorSystem.from_config(cfg, 25.0)


def _with_meshes(system: AssembledSystem, **changes: object) -> AssembledSystem:
    return dataclasses.replace(system, meshes=tuple(dataclasses.replace(m, **changes) for m in system.meshes))


def _run(
    system: AssembledSystem,
    names: list[str],
    n: int,
    steps_per_mesh: int,
    fuse: bool = True,
    effects: tuple = (),
    exact: bool = False,
    **kw: object,
) -> tuple:
    """``n`` steps at constant speed from static equilibrium; (stepper, channels, dte, times)."""
    specs = parse_channels(system, names)
    stepper = NewmarkStepper(system, specs, effects, **kw)
    stepper.fuse_meshes = fuse
    stepper.exact_map = exact
    st = static_equilibrium(system, effects)
    omega = quantize_speed_rpm(SPEED_RPM) * 2 * np.pi / 60
    f_mesh = system.meshes[0].pinion_teeth * SPEED_RPM / 60
    dt = 1.0 / (steps_per_mesh * f_mesh)
    stepper.set_operating_point(omega, dt, st)  # the gyroscopic term at the quantised speed
    j = np.arange(-1, n + 1, dtype=float)
    w_in = SPEED_RPM * 2 * np.pi / 60  # the mesh phases follow the exact speed
    ch, dte, *_ = stepper.run(j * dt, w_in * j * dt, np.full(j.size, w_in), st)
    return stepper, ch, dte, j[1:-1] * dt


def test_static_load_sharing_and_torque_balance() -> None:
    """Frictionless statics: the lever rule through both stages (F2 r_bg2 = T_load, F1 r_bg1 = F2 r_bp2)."""
    system = _two_stage(friction=0.0)
    st = static_equilibrium(system)
    m1, m2 = system.meshes
    load = 400.0
    assert np.all(st.contact == 2)  # both stages on their drive flanks
    assert np.all(st.delta > np.array([m.half_backlash for m in system.meshes]))
    assert st.force[1] * m2.base_radius_gear == pytest.approx(load, rel=1e-9)
    assert st.force[0] * m1.base_radius_gear == pytest.approx(st.force[1] * m2.base_radius_pinion, rel=1e-9)
    # the input torque (reaction at the drive) through the overall ratio
    z = (m1.gear_teeth / m1.pinion_teeth) * (m2.gear_teeth / m2.pinion_teeth)
    assert st.force[0] * m1.base_radius_pinion == pytest.approx(load / z, rel=1e-9)
    # speed ratios of the three shafts (signed: external pairs reverse the spin)
    r = system.shaft_speed_ratios
    assert r[1] == pytest.approx(-29 / 49, rel=1e-12)
    assert r[2] == pytest.approx(29 / 49 * 25 / 60, rel=1e-12)


def _harmonic_dte(system: AssembledSystem, omega_in: float, mesh: int, w: float, e0: float) -> np.ndarray:
    """Complex DTE amplitudes of all meshes to TE ``e0 sin(w t)`` on one mesh, linear model (Eq 39)."""
    lin = LinearModel(system)
    mc = system.meshes[mesh]
    h = lin.K - w**2 * lin.M + 1j * w * (lin.C + omega_in * lin.G)
    rhs = lin.V[mesh] * (mc.mean_stiffness + 1j * w * mc.damping) * e0
    return lin.V @ np.linalg.solve(h, rhs)


@pytest.mark.parametrize("exact", [False, True], ids=["newmark-map", "exact-map"])
def test_linear_response_of_both_meshes_matches_frequency_domain(exact: bool) -> None:
    """Constant mesh stiffness, no backlash, no friction: the DTE of both meshes to both meshes' TE
    (two frequencies, superposed) against the steady frequency-domain solution, with Newmark's map
    and with the exact modal propagator (``step_map(exact=True)``). The exact map's two-point force
    quadrature scales a harmonic load by cos(w h / 2) (0.48 % at 32 steps per mesh period; measured
    0.56 / 0.16 % RMS error at 32, 0.16 / 0.04 % at 64, second order), so it runs at 64."""
    base = _two_stage(friction=0.0)
    e0 = 1e-6
    system = _with_meshes(base, half_backlash=0.0, te_amplitude=e0, te_phase=0.0, table_jumps=None)
    system = dataclasses.replace(
        system,
        meshes=tuple(
            dataclasses.replace(
                m,
                table_stiffness=np.full(m.table_stiffness.size, m.mean_stiffness),
                stiffness=lambda ph, k=m.mean_stiffness: np.full(np.shape(ph), k),
            )
            for m in system.meshes
        ),
    )
    spm = 64 if exact else 32
    f1 = system.meshes[0].pinion_teeth * SPEED_RPM / 60
    n_tr = int(0.5 * f1) * spm  # 0.5 s: > 19 time constants of the slowest mode
    n_win = 100 * spm  # 100 periods of mesh 1 (51 of mesh 2)
    stepper, ch, _, t = _run(system, ["mesh1_dte", "mesh2_dte"], n_tr + n_win, spm, exact=exact)
    assert stepper.gear is not None and stepper.map.exact == exact  # general kernel: equal (below)
    st = static_equilibrium(system)
    omega_in = quantize_speed_rpm(SPEED_RPM) * 2 * np.pi / 60
    w_in = SPEED_RPM * 2 * np.pi / 60
    tw = t[n_tr:]
    exact = np.tile(st.delta, (tw.size, 1))
    for k, m in enumerate(system.meshes):
        w = m.pinion_teeth * abs(system.shaft_speed_ratios[m.pinion_shaft]) * w_in
        amp = _harmonic_dte(system, omega_in, k, w, e0)
        exact += (amp[None, :] * np.exp(1j * w * tw)[:, None]).imag
    sim = ch[n_tr:]
    fluct = exact - exact.mean(axis=0)
    for k in range(2):
        err = np.sqrt(np.mean((sim[:, k] - exact[:, k]) ** 2)) / np.sqrt(np.mean(fluct[:, k] ** 2))
        assert err < 5e-3, (k, err)


def _effects() -> tuple:
    """Effects of every kind the kernels take: stiffness factor and TE on mesh 2 (tooth damage on the
    output gear, gear eccentricity) and a force column (mass unbalance on the output shaft)."""
    return (
        EFFECT_TYPES["tooth_damage"](tooth=7, depth=0.3, wheel="gear", mesh=2),
        EFFECT_TYPES["gear_eccentricity"](eccentricity_m=5e-6, mesh=2),
        EFFECT_TYPES["mass_unbalance"](node=23, unbalance_kg_m=2e-4),
    )


@pytest.mark.parametrize("fuse", [True, False], ids=["fused-pass", "pass-per-mesh"])
def test_multi_mesh_kernel_equals_general_kernel_two_stage(fuse: bool) -> None:
    """The same map and mesh law (friction, backlash, varying stiffness, effects on the second mesh):
    the compiled gear kernel (both update paths) and the general kernel agree to round-off (tables
    without jumps: both interpolate them; events at the step instants in both)."""
    system = _with_meshes(_two_stage(), table_jumps=None)
    names = ["mesh1_dte", "mesh1_force", "mesh2_dte", "mesh2_force", "bearing5_fy", "node23_ay"]
    s_fast, fast, _, _ = _run(system, names, 3000, 40, fuse=fuse, effects=_effects())
    s_gen, gen, _, _ = _run(system, names, 3000, 40, effects=_effects(), disable_fast=True)
    assert s_fast.gear is not None and s_gen.gear is None
    scale = np.abs(gen).max(axis=0)
    assert np.all(np.abs(fast - gen).max(axis=0) <= 1e-8 * scale)


def test_gear_kernel_equals_general_kernel_on_paper_gearbox() -> None:
    """On one mesh (the scalar mesh solve and the one-mesh update pass) the gear kernel reproduces the
    general kernel (events not located), with effects of every kind."""
    system = GearRotorSystem.from_config(load_config("paper_sun2021"), 25.0)
    names = ["dte", "mesh_force", "bearing1_fx", "node5_ay"]
    eff = (
        EFFECT_TYPES["tooth_damage"](tooth=3, depth=0.3, wheel="pinion", mesh=1),
        EFFECT_TYPES["gear_eccentricity"](eccentricity_m=5e-6, mesh=1),
        EFFECT_TYPES["mass_unbalance"](node=14, unbalance_kg_m=2e-4),
    )
    system = _with_meshes(system, table_jumps=None)
    s_one, one, _, _ = _run(system, names, 6000, 40, effects=eff)
    s_gen, gen, _, _ = _run(system, names, 6000, 40, effects=eff, disable_fast=True)
    assert s_one.gear is not None and s_gen.gear is None
    scale = np.abs(gen).max(axis=0)
    assert np.all(np.abs(one - gen).max(axis=0) <= 1e-8 * scale)


def test_two_stage_simulator_per_mesh_channels() -> None:
    """The interface of issue 15: per-mesh channels; both mesh lines in their own channel."""
    sim = Simulator(
        load_config("two_stage_example"),
        speed_rpm=SPEED_RPM,
        temperature_c=25.0,
        output_rate_hz=20000.0,
        channels=["mesh1_dte", "mesh2_dte"],
    )
    sim.advance(0.3)
    block = sim.advance(0.2)
    assert block.channels == ("mesh1_dte", "mesh2_dte")
    y = np.asarray(block.data)
    f = np.fft.rfftfreq(y.shape[0], 1 / 20000.0)
    for k, f_mesh in enumerate((1450.0, 1450.0 * 25 / 49)):
        spec = np.abs(np.fft.rfft(y[:, k] - y[:, k].mean()))
        assert abs(f[np.argmax(spec)] - f_mesh) <= 2 * (f[1] - f[0])
    assert np.all(y > 0)  # both stages loaded on their drive flanks
    with pytest.raises(ValueError, match="channels: 'mesh3_dte'"):
        Simulator(load_config("two_stage_example"), speed_rpm=SPEED_RPM, channels=["mesh3_dte"])


@pytest.mark.parametrize("exact", [False, True], ids=["newmark-map", "exact-map"])
def test_modal_reduction_keeps_the_static_solution(exact: bool) -> None:
    """With the residual flexibility of the dropped modes the static response is exact: a reduced run
    (20 kHz cut-off: 53 of 164 modes) started at static equilibrium with constant mesh stiffness and
    no transmission error stays there to round-off (Newmark's map and the exact propagator, whose
    force weights give the exact static response too)."""
    system = _with_meshes(_two_stage(friction=0.0), te_amplitude=0.0, table_jumps=None)
    system = dataclasses.replace(
        system,
        meshes=tuple(
            dataclasses.replace(m, table_stiffness=np.full(m.table_stiffness.size, m.mean_stiffness))
            for m in system.meshes
        ),
    )
    specs = parse_channels(system, ["mesh1_dte", "mesh2_dte", "bearing5_fy"])
    stepper = NewmarkStepper(system, specs)
    stepper.modal_cutoff_hz = 20e3
    stepper.exact_map = exact
    st = static_equilibrium(system)
    omega = quantize_speed_rpm(SPEED_RPM) * 2 * np.pi / 60
    dt = 1.0 / (32 * 1450.0)
    stepper.set_operating_point(omega, dt, st)
    assert stepper.map.resid is not None and stepper.map.basis.lam.size < 60
    j = np.arange(-1, 2001, dtype=float)
    ch, *_ = stepper.run(j * dt, omega * j * dt, np.full(j.size, omega), st)
    x0 = static_equilibrium(system)
    assert np.all(np.abs(ch[:, :2] - x0.delta) <= 1e-9 * x0.delta)
    lin = LinearModel(system)
    q = x0.q_full(system.ndof)
    site = system.bearings[4]
    f_static = site.stiffness[1] @ q[6 * site.node0 : 6 * site.node0 + 6]
    assert np.all(np.abs(ch[:, 2] - f_static) <= 1e-8 * abs(f_static))
    assert lin.nm == 2


@pytest.mark.parametrize("rpm", [3000.0, 12000.0])
def test_modal_reduction_matches_full_model(rpm: float) -> None:
    """The default reduced model ("auto" cut-off) of the two-stage rig against the full model: the
    RMS DTE of both meshes within 0.5 % (measured 0.00 % at 3000 rpm, 0.01 % at 12000 rpm with
    41 % contact loss)."""
    out = {}
    for cut in (None, "auto"):
        sim = Simulator(
            load_config("two_stage_example"),
            speed_rpm=rpm,
            output_rate_hz=20000.0,
            channels=["mesh1_dte", "mesh2_dte"],
            modal_cutoff_hz=cut,
        )
        sim.advance(0.1)
        out[cut] = np.asarray(sim.advance(0.05).data)
        assert (sim._stepper.map.resid is None) == (cut is None)
    rms_full = np.sqrt(np.mean(out[None] ** 2, axis=0))
    rms_red = np.sqrt(np.mean(out["auto"] ** 2, axis=0))
    assert np.all(np.abs(rms_red - rms_full) <= 5e-3 * rms_full)


def test_streams_and_recording_metadata_name_every_mesh_and_shaft() -> None:
    """Multi-stage rigs: the DTE stream carries every mesh's channels; the recordings' metadata holds
    the per-shaft speed ratios and the mesh orders (mesh frequency per input revolution)."""
    from gear_rotor_sim.streams import default_streams
    from gear_rotor_sim.system import drivetrain_metadata

    cfg = load_config("two_stage_example")
    dte = default_streams(len(cfg.bearings), n_meshes=len(cfg.meshes))[0]
    assert dte.channels == ("mesh1_dte", "mesh1_force", "mesh2_dte", "mesh2_force")
    available = {name for name, _ in Simulator.available_channels(cfg)}
    assert set(dte.channels) <= available
    meta = drivetrain_metadata(cfg)
    ratios = dict(kv.split("=") for kv in meta["shaft_speed_ratios"].split(", "))
    assert float(ratios["intermediate"]) == pytest.approx(-29 / 49, rel=1e-11)
    assert float(ratios["output"]) == pytest.approx(29 / 49 * 25 / 60, rel=1e-11)
    orders = dict(kv.split("=") for kv in meta["mesh_orders"].split(", "))
    # mesh frequencies at 3000 rpm: 1450 Hz and 1450 * 25 / 49 Hz
    assert float(orders["mesh1"]) * 3000 / 60 == pytest.approx(1450.0, rel=1e-11)
    assert float(orders["mesh2"]) * 3000 / 60 == pytest.approx(1450.0 * 25 / 49, rel=1e-11)


def test_physical_state_round_trip_through_the_modal_basis() -> None:
    """``physical_x`` (compiled loops, no BLAS) inverts ``load_state`` on the full basis: a perturbed
    static state of the two-stage rig comes back to round-off of its own norm."""
    system = _two_stage()
    stepper = NewmarkStepper(system, parse_channels(system, ["mesh1_dte"]))
    st = static_equilibrium(system)
    rng = np.random.default_rng(3)
    st.x = st.x * (1.0 + 0.1 * rng.standard_normal(st.x.size))
    stepper.set_operating_point(quantize_speed_rpm(SPEED_RPM) * 2 * np.pi / 60, 1.0 / (32 * 1450.0), st)
    assert stepper.map.resid is None
    x = stepper.physical_x()
    assert np.linalg.norm(x - st.x) <= 1e-9 * np.linalg.norm(st.x)


def test_rigid_second_stage_limit_is_the_constrained_train() -> None:
    """A second stage made rigid (mesh 2 stiffness x 1e2, 1e4, 1e6; Eq 30's k V^T V term) tends to the
    train with mesh 2's line-of-action displacement held at zero (V_2 q = 0, imposed exactly on the
    other matrices by a null-space basis): the lowest 12 natural frequencies converge as 1/scale, and the
    stiffest agrees to 1e-6. The constrained train is built without mesh 2's stiffness at all, so it is
    an independent limit, not the model compared with itself."""
    import scipy.linalg as sla

    base = _two_stage(friction=0.0)
    lin0 = LinearModel(base)
    v2 = lin0.V[1]
    k_other = lin0.K - base.meshes[1].mean_stiffness * np.outer(v2, v2)  # the train without mesh 2
    z = sla.null_space(v2[None, :])
    exact = np.sqrt(np.abs(sla.eigh(z.T @ k_other @ z, z.T @ lin0.M @ z, eigvals_only=True)[:12]))
    errs = []
    for scale in (1e2, 1e4, 1e6):
        m2 = dataclasses.replace(base.meshes[1], mean_stiffness=base.meshes[1].mean_stiffness * scale)
        lin = LinearModel(dataclasses.replace(base, meshes=(base.meshes[0], m2)))
        assert np.allclose(lin.K, lin.K.T, rtol=0, atol=1e-12 * np.abs(lin.K).max())
        w = np.sqrt(np.abs(sla.eigh(lin.K, lin.M, eigvals_only=True)[:12]))
        errs.append(np.max(np.abs(w - exact) / exact))
    assert errs[2] <= 1e-6
    assert errs[1] <= 2e-2 * errs[0] and errs[2] <= 2e-2 * errs[1]  # 1/scale convergence (1e-2 steps)


def test_exact_map_replaces_the_resonance_rate_two_stage() -> None:
    """The two-stage rig at 3000 rpm has a light mode (1489 Hz, zeta 0.016) near the first mesh line
    (1450 Hz): the dt rule with Newmark's map raises the rate to about 94 steps per mesh period; the
    exact modal propagator at the base 32 steps (the Simulator's default there) keeps the RMS DTE of
    both meshes within 0.5 % of a reference converged independently of the map (Newmark, 512 located
    steps per mesh period; measured against 1024: -0.18 / -0.02 %), while Newmark's map at 32 steps
    misses the fluctuating part by more (0.9 / 0.6 % against 1024)."""
    from gear_rotor_sim.solver.steady import simulate_steady

    system = _two_stage()
    names = ("mesh1_dte", "mesh2_dte")
    kw = {"locate_events": True, "contact_loss_rate_hz": None}
    _, st0 = simulate_steady(system, SPEED_RPM, 0, 290, 512, names, **kw)  # 0.2 s from static
    ref, _ = simulate_steady(system, SPEED_RPM, 0, 100, 512, names, st0, "step", **kw)
    exact, _ = simulate_steady(system, SPEED_RPM, 30, 100, 32, names, st0, "step", exact_modal_map=None)
    newmark, _ = simulate_steady(system, SPEED_RPM, 30, 100, 32, names, st0, "step", exact_modal_map=False)
    assert exact.steps_per_mesh == 32 and newmark.steps_per_mesh > 64  # the rule's two choices
    rms = {k: np.sqrt(np.mean(r.data**2, axis=0)) for k, r in (("ref", ref), ("exact", exact))}
    assert np.all(np.abs(rms["exact"] / rms["ref"] - 1.0) < 5e-3)
    sd_ref = ref.data.std(axis=0)
    assert np.all(np.abs(exact.data.std(axis=0) / sd_ref - 1.0) < 1e-2)


# ---------------------------------------------------------------------------------------------------
# Rigid second stage against the single-stage model (the paper gearbox built from its own config)
# ---------------------------------------------------------------------------------------------------
def _stiff_output_side(scale: float) -> AssembledSystem:
    """The two-stage example with its output side made rigid by ``scale``: the third shaft's Young's
    modulus, its two bearings' stiffnesses and mesh 2's mean stiffness times ``scale``. Mesh 2 without
    friction and static TE (in the rigid limit a TE of the second stage would drive the output inertia:
    an excitation the single-stage model does not have)."""
    cfg = load_config("two_stage_example")
    steel = cfg.materials["carbon_steel"]
    stiff = dataclasses.replace(
        steel, name="stiff", youngs_moduli=tuple(e * scale for e in steel.youngs_moduli)
    )
    out = cfg.shafts[2]
    shafts = (
        *cfg.shafts[:2],
        dataclasses.replace(
            out,
            material="stiff",
            elements=tuple(dataclasses.replace(e, material="stiff") for e in out.elements),
        ),
    )
    out_nodes = set(range(cfg.node_offsets[2], cfg.node_offsets[2] + out.n_nodes))
    bearings = tuple(
        dataclasses.replace(
            b,
            properties=dataclasses.replace(
                b.properties,
                k_radial=b.properties.k_radial * scale,
                k_axial=b.properties.k_axial * scale,
                k_tilt=b.properties.k_tilt * scale,
            ),
        )
        if b.node0 in out_nodes
        else b
        for b in cfg.bearings
    )
    meshes = (
        cfg.meshes[0],
        dataclasses.replace(cfg.meshes[1], friction_coefficient=0.0, transmission_error_amplitude_m=0.0),
    )
    cfg = cfg.replace(
        materials={**cfg.materials, "stiff": stiff}, shafts=shafts, bearings=bearings, meshes=meshes
    )
    system = GearRotorSystem.from_config(cfg, 25.0)
    m2 = dataclasses.replace(system.meshes[1], mean_stiffness=system.meshes[1].mean_stiffness * scale)
    return dataclasses.replace(system, meshes=(system.meshes[0], m2))


def _single_stage_reduced(with_output_inertia: bool = True) -> tuple[AssembledSystem, float]:
    """The paper's single-stage gearbox (config/paper_sun2021.yaml: the same two shafts, bearings and
    first stage) with the second stage's pinion as a plain disc at node 16 (pitch diameter, bore, face
    width), carrying there what a rigid second stage transmits, derived by hand:

    - mesh 2's line of action at its pinion (Eq 22, ``n = (sin a, cos a)``, mirrored in y and theta_z
      because pinion 2 turns negative): ``w = (sin a, -cos a, -r_bp2)`` on (x, y, theta_z) of node 16,
      ``r_bg2`` on theta_z of the output shaft;
    - statics: the output side has no torsional support but the load, so mesh 2 carries
      ``F2 = T / r_bg2`` and node 16 gets ``-F2 w`` (Eq 26); no other load;
    - dynamics: the rigid output side (rigid shaft on rigid bearings, node 23 fixed laterally) turns
      with ``r_bg2 theta_out = -w . q16`` (mesh 2's constraint), so its polar inertia ``J_out`` adds the
      kinetic energy ``J_out (w . dq16)^2 / (2 r_bg2^2)``: a rank-one mass ``J_out w w^T / r_bg2^2`` at
      node 16 (torsion, the lateral line-of-action coupling and their cross terms). ``J_out`` is the
      shaft's ``rho pi d^4 L / 32`` plus the gear disc's ``m (D^2 + d^2) / 8`` from the config's
      dimensions.

    Returns the system and F2.
    """
    two = load_config("two_stage_example")
    m2 = two.meshes[1]
    gear2 = two.gear(m2.gear)
    steel = two.materials["carbon_steel"]
    alpha = m2.pressure_angle_rad
    r_bp2 = 0.5 * m2.module_m * m2.pinion_teeth * np.cos(alpha)
    r_bg2 = 0.5 * m2.module_m * m2.gear_teeth * np.cos(alpha)
    torque = two.load.torque_nm
    f2 = torque / r_bg2
    out = two.shafts[2]
    j_shaft = sum(
        steel.density * np.pi * (e.outer_diameter_m**4 - e.inner_diameter_m**4) / 32.0 * e.length_m
        for e in out.elements
    )
    pitch, bore = gear2.module_m * gear2.teeth, gear2.bore_diameter_m
    m_disc = steel.density * np.pi / 4.0 * (pitch**2 - bore**2) * gear2.face_width_m
    j_out = j_shaft + m_disc * (pitch**2 + bore**2) / 8.0

    # the second stage's pinion stays on the intermediate shaft: a plain disc of its dimensions
    pinion2 = two.gear(m2.pinion)
    node16 = 15
    disc = DiscConfig(
        node16,
        pinion2.module_m * pinion2.teeth,
        pinion2.bore_diameter_m,
        pinion2.face_width_m,
        "carbon_steel",
    )
    cfg = load_config("paper_sun2021").replace(load=None, discs=(disc,))
    system = GearRotorSystem.from_config(cfg, 25.0)
    dofs = 6 * node16 + np.array([0, 1, 5])
    w = np.array([np.sin(alpha), -np.cos(alpha), -r_bp2])
    load = np.zeros(system.ndof)
    load[dofs] = -f2 * w
    M = np.array(system.M, float)
    if with_output_inertia:
        M[np.ix_(dofs, dofs)] += j_out / r_bg2**2 * np.outer(w, w)
    return dataclasses.replace(system, M=M, static_load=np.asarray(system.static_load) + load), f2


def test_two_stage_statics_equal_the_single_stage_model_loaded_by_the_second_stage() -> None:
    """Statics need no limit: the output shaft has no torsional support but the load, so mesh 2
    transmits exactly ``T / r_bg2`` whatever its stiffness, and the first two shafts of the two-stage
    example (as configured, and with the output side stiffened 1e4 times) sit exactly where the
    single-stage model puts them under ``-F2 w`` at node 16: every displacement of nodes 1-18 and the
    first-stage mesh force to round-off of their own magnitude."""
    from gear_rotor_sim.system import mesh_forces, static_solution

    reduced, f2 = _single_stage_reduced()
    q_ref = static_solution(reduced)
    f_ref = mesh_forces(reduced, q_ref)
    n = reduced.ndof
    for system in (_two_stage(), _stiff_output_side(1e4)):
        q = static_solution(system)
        f = mesh_forces(system, q)
        assert f[1] == pytest.approx(f2, rel=1e-9)
        assert f[0] == pytest.approx(f_ref[0], rel=1e-9)
        assert np.max(np.abs(q[:n] - q_ref)) <= 1e-9 * np.max(np.abs(q_ref))


def _mesh1_receptance(system: AssembledSystem, freqs_hz: np.ndarray) -> np.ndarray:
    """Mesh-1 DTE per unit mesh-1 TE (complex, linear model with the mean stiffness, Eq 39) at the
    running speed (gyroscopic terms of every shaft at its own speed)."""
    omega_in = SPEED_RPM * 2 * np.pi / 60
    out = np.empty(freqs_hz.size, complex)
    for i, f in enumerate(freqs_hz):
        out[i] = _harmonic_dte(system, omega_in, 0, 2 * np.pi * f, 1.0)[0]
    return out


def test_rigid_second_stage_limit_is_the_single_stage_model() -> None:
    """The second stage and the output side made rigid (x1e2, 1e4, 1e6) tend to the single-stage
    paper gearbox carrying the output inertia referred through mesh 2's line of action (see
    _single_stage_reduced): the first-stage receptance (mesh-1 DTE per unit mesh-1 TE, 50 Hz-8 kHz,
    through the mesh resonances) and the 10 lowest natural frequencies converge as 1/scale, and at
    1e6 agree to 1e-5. Torsion alone (the inertia referred by the ratio squared, no lateral coupling)
    misses by orders of magnitude more: the lateral coupling is part of the limit."""
    import scipy.linalg as sla

    freqs = np.geomspace(50.0, 8000.0, 60)
    reduced, _ = _single_stage_reduced()
    ref = _mesh1_receptance(reduced, freqs)
    lin_ref = LinearModel(reduced)
    w_ref = np.sqrt(np.abs(sla.eigh(lin_ref.K, lin_ref.M, eigvals_only=True)[:10]))
    frf_err, eig_err = [], []
    for scale in (1e2, 1e4, 1e6):
        system = _stiff_output_side(scale)
        frf_err.append(np.max(np.abs(_mesh1_receptance(system, freqs) - ref)) / np.max(np.abs(ref)))
        lin = LinearModel(system)
        w = np.sqrt(np.abs(sla.eigh(lin.K, lin.M, eigvals_only=True)[:10]))
        eig_err.append(np.max(np.abs(w - w_ref) / w_ref))
    assert frf_err[2] <= 1e-5 and eig_err[2] <= 1e-5, (frf_err, eig_err)
    for errs in (frf_err, eig_err):
        assert errs[1] <= 3e-2 * errs[0] and errs[2] <= 3e-2 * errs[1], (frf_err, eig_err)
    # the referred inertia on torsion only (J_out (r_bp2 / r_bg2)^2 on theta_z of node 16) is not the limit
    torsion_only, _ = _single_stage_reduced(with_output_inertia=False)
    M = np.array(torsion_only.M, float)
    jz = reduced.M[6 * 15 + 5, 6 * 15 + 5] - torsion_only.M[6 * 15 + 5, 6 * 15 + 5]
    M[6 * 15 + 5, 6 * 15 + 5] += jz
    torsion_only = dataclasses.replace(torsion_only, M=M)
    err_torsion = np.max(np.abs(_mesh1_receptance(torsion_only, freqs) - ref)) / np.max(np.abs(ref))
    assert err_torsion >= 1e3 * frf_err[2], (err_torsion, frf_err)
