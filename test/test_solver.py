"""Solver tests against independent truth: frequency-domain solves, energy, the mesh law, statics."""

from __future__ import annotations

import numpy as np
import pytest

from gear_rotor_sim.solver import (
    NewmarkStepper,
    SimulationDiverged,
    mesh_law,
    parse_channels,
    quantize_speed_rpm,
    simulate_steady,
    static_equilibrium,
)
from gear_rotor_sim.solver.newmark import LinearModel, eigen_basis
from gear_rotor_sim.system_data import AssembledSystem, BearingSite, MeshCoupling

ALPHA = np.deg2rad(20.0)


def _chain(n_nodes: int, node0: int, ndof: int, k_t: float, k_r: float, k: np.ndarray) -> None:
    for a in range(node0, node0 + n_nodes - 1):
        for d in range(6):
            kd = k_t if d < 3 else k_r
            i, j = 6 * a + d, 6 * (a + 1) + d
            k[i, i] += kd
            k[j, j] += kd
            k[i, j] -= kd
            k[j, i] -= kd


def make_system(
    with_mesh: bool = True,
    stiffness_amp: float = 0.3,
    half_backlash: float = 5e-6,
    te_amplitude: float = 2e-6,
    mesh_damping: float = 300.0,
    damping: float = 1.0,
    gyro: float = 1.0,
    load_torque: float = 50.0,
    friction: float = 0.0,
    temperature_c: float = 25.0,
    tables: bool = True,
) -> AssembledSystem:
    """Two 3-node shafts (pinion node 2, gear node 5; 1-based), bearings at both shaft ends.

    Node-lumped masses/inertias, springs between adjacent nodes, a spur mesh on Eq 22 geometry.
    ``damping`` scales a stiffness-proportional damping; ``gyro`` scales the polar inertias in G.
    ``tables``: the mesh carries uniform tables (the compiled single-mesh fast path runs) and its
    callables interpolate them; False: analytic callables only (the general kernel runs).
    """
    n_nodes, ndof = 6, 36
    m, jd, jp = 2.0, 4e-3, 8e-3
    M = np.zeros((ndof, ndof))
    for node in range(n_nodes):
        M[6 * node : 6 * node + 6, 6 * node : 6 * node + 6] = np.diag([m, m, m, jd, jd, jp])
    K = np.zeros((ndof, ndof))
    _chain(3, 0, ndof, 2e8, 2e5, K)
    _chain(3, 3, ndof, 2e8, 2e5, K)
    zp, zg = 20, 30
    ratios = np.array([1.0, -zp / zg])
    bearings = []
    kb = np.diag([1e8, 1e8, 5e7, 1e4, 1e4, 0.0])
    cb = np.diag([200.0, 200.0, 100.0, 0.1, 0.1, 0.0])
    for number, node in enumerate((0, 2, 3, 5), start=1):
        sl = slice(6 * node, 6 * node + 6)
        K[sl, sl] += kb
        bearings.append(BearingSite(number, node, kb, cb, "test"))
    C = damping * 2e-6 * K
    for b in bearings:
        sl = slice(6 * b.node0, 6 * b.node0 + 6)
        C[sl, sl] += b.damping
    G = np.zeros((ndof, ndof))
    for node in range(n_nodes):
        r = ratios[0 if node < 3 else 1]
        i = 6 * node
        G[i + 3, i + 4] += gyro * jp * r
        G[i + 4, i + 3] -= gyro * jp * r
    static = np.zeros(ndof)
    static[6 * 5 + 5] = load_torque
    free = np.array([d for d in range(ndof) if d != 5])
    meshes: tuple[MeshCoupling, ...] = ()
    if with_mesh:
        rbp, rbg = 0.03, 0.045
        v = np.zeros(ndof)
        v[6 * 1 : 6 * 1 + 6] = [np.sin(ALPHA), np.cos(ALPHA), 0, 0, 0, rbp]
        v[6 * 4 : 6 * 4 + 6] = [-np.sin(ALPHA), -np.cos(ALPHA), 0, 0, 0, rbg]
        basis = [-v]
        if friction:
            vf = np.zeros(ndof)
            vf[6 * 1 + 0], vf[6 * 4 + 0] = np.cos(ALPHA), -np.cos(ALPHA)
            vf[6 * 1 + 5], vf[6 * 4 + 5] = 0.01, -0.01
            basis.append(vf)
        km = 2e8

        def stiff(phase: np.ndarray) -> np.ndarray:
            return km * (1.0 + stiffness_amp * np.sign(np.sin(2 * np.pi * np.asarray(phase)) + 1e-300) * 0.5)

        def coefs(phase: np.ndarray) -> np.ndarray:
            ph = np.asarray(phase, float)
            cols = [np.ones_like(ph)]
            if friction:
                cols.append(friction * np.cos(2 * np.pi * ph))
            return np.stack(cols, axis=-1)

        tab_k = tab_c = None
        if tables:
            grid = np.arange(512) / 512.0
            tab_k, tab_c = stiff(grid), coefs(grid)
            stiff_tab, coefs_tab = tab_k.copy(), tab_c.copy()

            def stiff(phase: np.ndarray) -> np.ndarray:
                return np.interp(np.asarray(phase, float), grid, stiff_tab, period=1.0)

            def coefs(phase: np.ndarray) -> np.ndarray:
                ph = np.atleast_1d(np.asarray(phase, float))
                return np.column_stack([np.interp(ph, grid, c, period=1.0) for c in coefs_tab.T])

        meshes = (
            MeshCoupling(
                1,
                4,
                0,
                1,
                zp,
                zg,
                v,
                np.column_stack(basis),
                coefs,
                stiff,
                km,
                mesh_damping,
                half_backlash,
                te_amplitude,
                0.3,
                rbp,
                rbg,
                1.6,
                tab_k,
                tab_c,
            ),
        )
    return AssembledSystem(
        temperature_c,
        M,
        K,
        C,
        G,
        static,
        free,
        meshes,
        tuple(bearings),
        np.array([0, 0, 0, 1, 1, 1]),
        ratios,
        np.array([0.0, 0.1, 0.2, 0.0, 0.1, 0.2]),
    )


def harmonic_dte(system: AssembledSystem, omega_in: float, w: float, e0: float, phase: float) -> complex:
    """Exact steady DTE amplitude of the linear (constant k, b*=0) system: (K - w^2 M + i w D) X = F."""
    lin = LinearModel(system)
    mc = system.meshes[0]
    d = lin.C + omega_in * lin.G
    h = lin.K - w**2 * lin.M + 1j * w * d
    # mesh force -V (k (V q - e) + c (V q' - e')) : the k V^T V, c V^T V parts are in K_lin, D; the rest
    # is V^T (k + i w c) e with e = Im(e0 exp(i (w t + phase)))
    rhs = lin.V[0] * (mc.mean_stiffness + 1j * w * mc.damping) * e0 * np.exp(1j * phase)
    x = np.linalg.solve(h, rhs)
    return complex(lin.V[0] @ x)


@pytest.mark.parametrize("tables", [True, False], ids=["fast-kernel", "general-kernel"])
def test_linear_harmonic_response_matches_frequency_domain(tables: bool) -> None:
    sys_ = make_system(
        stiffness_amp=0.0, half_backlash=0.0, te_amplitude=5e-6, load_torque=0.0, damping=5.0, tables=tables
    )
    speed_rpm = 3000.0
    res, _ = simulate_steady(sys_, speed_rpm, 300, 40, steps_per_mesh=64, channels=("dte",), sample="step")
    omega_in = quantize_speed_rpm(speed_rpm) * 2 * np.pi / 60
    mc = sys_.meshes[0]
    w = mc.pinion_teeth * speed_rpm * 2 * np.pi / 60
    amp = harmonic_dte(sys_, omega_in, w, mc.te_amplitude, mc.te_phase)
    t = res.t
    exact = (amp * np.exp(1j * w * t)).imag
    sim = res.channel("dte")
    # amplitude of the fundamental by projection over whole periods
    a_sim = 2 * np.mean(sim * np.exp(-1j * w * t))
    a_ex = 2 * np.mean(exact * np.exp(-1j * w * t))
    assert abs(abs(a_sim) - abs(a_ex)) / abs(a_ex) < 5e-3
    assert np.sqrt(np.mean((sim - exact) ** 2)) / np.sqrt(np.mean(exact**2)) < 5e-3


def test_dense_fallback_matches_frequency_domain() -> None:
    sys_ = make_system(stiffness_amp=0.0, half_backlash=0.0, te_amplitude=5e-6, load_torque=0.0, damping=5.0)
    specs = parse_channels(sys_, ["dte"])
    st = static_equilibrium(sys_)
    stepper = NewmarkStepper(sys_, specs, force_dense=True)
    speed_rpm = 3000.0
    omega = quantize_speed_rpm(speed_rpm) * 2 * np.pi / 60
    w = 20 * speed_rpm * 2 * np.pi / 60
    dt = 2 * np.pi / w / 64
    stepper.set_operating_point(omega, dt, st)
    assert stepper.map is not None and stepper.map.dense
    j = np.arange(-1, 64 * 340 + 1, dtype=float)
    w_in = speed_rpm * 2 * np.pi / 60  # the mesh phase follows the exact speed; G uses the quantised one
    ch, *_ = stepper.run(j * dt, w_in * j * dt, np.full(j.size, w_in), st)
    t = j[1:-1][-64 * 40 :] * dt
    sim = ch[-64 * 40 :, 0]
    amp = harmonic_dte(sys_, omega, w, 5e-6, 0.3)
    exact = (amp * np.exp(1j * w * t)).imag
    assert np.sqrt(np.mean((sim - exact) ** 2)) / np.sqrt(np.mean(exact**2)) < 5e-3


def _energy(sys_: AssembledSystem, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    lin = LinearModel(sys_)
    return 0.5 * np.einsum("ni,ij,nj->n", v, lin.M, v) + 0.5 * np.einsum("ni,ij,nj->n", q, lin.K, q)


def test_undamped_linear_run_conserves_energy() -> None:
    # no damping anywhere, gyroscopic coupling on (it does no work), constant mesh stiffness, no backlash
    sys_ = make_system(
        stiffness_amp=0.0, half_backlash=0.0, te_amplitude=0.0, load_torque=0.0, damping=0.0, mesh_damping=0.0
    )
    sys_ = AssembledSystem(
        **{
            **sys_.__dict__,
            "bearings": tuple(
                BearingSite(b.number, b.node0, b.stiffness, 0 * b.damping) for b in sys_.bearings
            ),
        }
    )
    sys_ = AssembledSystem(**{**sys_.__dict__, "C": np.zeros_like(sys_.C)})
    lin = LinearModel(sys_)
    names = [f"node{n}_{d}" for n in range(1, 7) for d in ("x", "y", "z", "theta_x", "theta_y", "theta_z")]
    names += [f"node{n}_v{d}" for n in range(1, 7) for d in ("x", "y", "z", "theta_x", "theta_y", "theta_z")]
    specs = parse_channels(sys_, names)
    st = static_equilibrium(sys_)
    rng = np.random.default_rng(1)
    st.x = rng.standard_normal(2 * lin.nfree) * np.concatenate(
        [np.full(lin.nfree, 1e-6), np.full(lin.nfree, 1e-3)]
    )
    stepper = NewmarkStepper(sys_, specs)
    omega = 500.0
    dt = 2e-5
    stepper.set_operating_point(omega, dt, st)
    j = np.arange(-1, 3001, dtype=float)
    ch, *_ = stepper.run(j * dt, omega * j * dt, np.full(j.size, omega), st)
    free = sys_.free_dofs
    q = ch[:, :36][:, free]
    v = ch[:, 36:][:, free]
    e = _energy(sys_, q, v)
    e0 = _energy(sys_, st.x[None, : lin.nfree] * 0 + np.asarray(q[:1]), np.asarray(v[:1]))[0]
    assert np.max(np.abs(e - e0)) / e0 < 1e-9
    # and it must fail if there is damping: the same run with bearing damping loses energy
    sys_d = make_system(stiffness_amp=0.0, half_backlash=0.0, te_amplitude=0.0, load_torque=0.0)
    stepper_d = NewmarkStepper(sys_d, specs)
    stepper_d.set_operating_point(omega, dt, st)
    ch_d, *_ = stepper_d.run(j * dt, omega * j * dt, np.full(j.size, omega), st)
    e_d = _energy(sys_d, ch_d[:, :36][:, free], ch_d[:, 36:][:, free])
    assert e_d[-1] < 0.99 * e_d[0]


def _nonlinear_run(friction: float = 0.0, tables: bool = True) -> tuple:
    sys_ = make_system(
        half_backlash=3e-6,
        te_amplitude=2.5e-5,
        load_torque=20.0,
        stiffness_amp=0.4,
        friction=friction,
        tables=tables,
    )
    names = [
        "dte",
        "mesh_force",
        "node2_x",
        "node2_y",
        "node2_theta_z",
        "node5_x",
        "node5_y",
        "node5_theta_z",
    ]
    specs = parse_channels(sys_, names)
    st = static_equilibrium(sys_)
    stepper = NewmarkStepper(sys_, specs)
    omega = 4000 * 2 * np.pi / 60
    dt = 2 * np.pi / (20 * omega) / 32
    stepper.set_operating_point(omega, dt, st)
    assert (stepper.gear is not None) == tables  # the path under test is the one intended
    j = np.arange(-1, 32 * 300 + 1, dtype=float)
    return sys_, stepper.run(j * dt, omega * j * dt, np.full(j.size, omega), st)


@pytest.mark.parametrize("tables", [True, False], ids=["fast-kernel", "general-kernel"])
@pytest.mark.parametrize("friction", [0.0, 0.05])
def test_mesh_law_holds_exactly_every_step(friction: float, tables: bool) -> None:
    sys_, (ch, dte, dted, fm, states, exc) = _nonlinear_run(friction, tables)
    kt, et, edt, _, _ = exc
    mc = sys_.meshes[0]
    b = mc.half_backlash
    d, dd, f, s = dte[:, 0], dted[:, 0], fm[:, 0], states[:, 0]
    k, e, ed = kt[:, 0], et[:, 0], edt[:, 0]
    dm, dmd = d - e, dd - ed
    # all contact regimes occur
    assert np.mean(s == 0) > 0.01 and np.mean(s < 0) > 0.01 and np.mean(s == 2) > 0.1
    fscale = np.max(np.abs(f))
    law = mesh_law(d, dd, k, mc.damping, e, ed, b)
    contact = np.abs(s) == 2
    assert np.max(np.abs(f - law)[contact]) < 1e-10 * fscale
    assert np.all(np.abs(dm[contact]) > b * (1 - 1e-9))
    dead = s == 0
    assert np.all(f[dead] == 0.0) and np.all(np.abs(dm[dead]) <= b * (1 + 1e-9))
    pinned = np.abs(s) == 1
    assert np.all(np.abs(np.abs(dm[pinned]) - b) < 1e-12 * b)
    hull = mc.damping * dmd[pinned]
    assert np.all(
        (f[pinned] >= np.minimum(0, hull) - 1e-9 * fscale)
        & (f[pinned] <= np.maximum(0, hull) + 1e-9 * fscale)
    )
    # delta reported by the solve equals V q from the independently output node displacements (Eq 21)
    a = np.sin(ALPHA)
    vq = (
        a * ch[:, 2]
        + np.cos(ALPHA) * ch[:, 3]
        + 0.03 * ch[:, 4]
        - a * ch[:, 5]
        - np.cos(ALPHA) * ch[:, 6]
        + 0.045 * ch[:, 7]
    )
    assert np.max(np.abs(vq - d)) < 1e-9 * np.max(np.abs(d))


def test_quasi_static_limit_matches_static_solve() -> None:
    # at 6 rpm the mesh frequency (2 Hz) is far below the first mode (> 100 Hz): response = statics
    sys_ = make_system(stiffness_amp=0.0, half_backlash=4e-6, te_amplitude=3e-6, load_torque=30.0)
    res, _ = simulate_steady(sys_, 6.0, 0, 2, steps_per_mesh=64, channels=("dte",), sample="step")
    mc = sys_.meshes[0]
    free = sys_.free_dofs
    v = mc.line_of_action[free]
    kk = sys_.K[np.ix_(free, free)] + mc.mean_stiffness * np.outer(v, v)
    phase = 20 * 6.0 / 60 * res.t
    e = mc.te_amplitude * np.sin(2 * np.pi * phase + mc.te_phase)
    # drive-side contact: F = k (V q - e - b), generalised force -V F
    rhs = sys_.static_load[free][:, None] + mc.mean_stiffness * np.outer(v, e + mc.half_backlash)
    dte_static = v @ np.linalg.solve(kk, rhs)
    # residual: the step of e(0) at the start rings in modes not resolved by dt (trapezoid keeps them)
    assert np.max(np.abs(res.channel("dte") - dte_static)) < 5e-3 * np.max(np.abs(dte_static))


def test_divergence_raises_naming_time_speed_temperature() -> None:
    sys_ = make_system()
    specs = parse_channels(sys_, ["dte"])
    st = static_equilibrium(sys_)
    stepper = NewmarkStepper(sys_, specs)
    stepper.set_operating_point(300.0, 1e-5, st)
    j = np.arange(-1, 101, dtype=float)
    with pytest.raises(SimulationDiverged, match=r"t = .* s, speed = .* rpm, temperature = 25 C"):
        stepper.run(j * 1e-5, 300 * j * 1e-5, np.full(j.size, 300.0), st, bound=1e-9)
    bad = make_system()
    mc = bad.meshes[0]
    poisoned = np.where(np.arange(512) / 512 > 0.5, np.nan, 2e8)  # for the table-driven fast kernel
    nan_mesh = MeshCoupling(
        **{
            **mc.__dict__,
            "stiffness": lambda ph: np.where(np.asarray(ph) > 0.5, np.nan, 2e8),
            "table_stiffness": poisoned,
        }
    )
    bad = AssembledSystem(**{**bad.__dict__, "meshes": (nan_mesh,)})
    stepper = NewmarkStepper(bad, specs)
    stepper.set_operating_point(300.0, 1e-5, static_equilibrium(bad))
    j = np.arange(-1, 2001, dtype=float)
    with pytest.raises(SimulationDiverged, match="non-finite"):
        stepper.run(j * 1e-5, 300 * j * 1e-5, np.full(j.size, 300.0), static_equilibrium(bad))


def test_bad_input_to_steady_runner() -> None:
    sys_ = make_system()
    with pytest.raises(ValueError, match="speed_rpm"):
        simulate_steady(sys_, float("nan"), 1, 1)
    with pytest.raises(ValueError, match="speed_rpm"):
        simulate_steady(sys_, -5.0, 1, 1)
    with pytest.raises(ValueError, match="steps_per_mesh"):
        simulate_steady(sys_, 3000.0, 1, 1, steps_per_mesh=4)
    with pytest.raises(ValueError, match="channels"):
        simulate_steady(sys_, 3000.0, 1, 1, channels=("bearing9_fx",))


def test_eigenbasis_is_well_conditioned_and_exact() -> None:
    sys_ = make_system()
    lin = LinearModel(sys_)
    b = eigen_basis(lin, 400.0)
    assert not b.dense and b.cond < 1e8
    # the kept half reproduces A exactly: A Phi = Phi Lambda on the kept modes
    a = lin.state_matrix(400.0)
    assert np.max(np.abs(a @ b.phi - b.phi * b.lam)) < 1e-8 * np.max(np.abs(b.lam)) * np.max(np.abs(b.phi))
