"""Transfer from a lateral force at the pinion to the six channels: the FE model against the generator.

Both models linearised where the teeth stay in contact (the mean mesh stiffness along the line of action),
at the operating speed's gyroscopic matrix; the force is the crack's: internal to the input shaft, so in the
FE model the self-equilibrated pair ``P^T n`` of ``faults/crack.py`` (the node less the bearing line's
weights) and in the generator the wheel's force less its share in bearing 2's channel
(``lumped_gearbox/simulate.py``). Printed: |H| of every channel per newton, along the line of action
(``a``) and across it (``c``), at 1x, 2x, 3x of the input shaft and at the mesh frequency, for the models
as built and for the FE model with one change at a time (``--variant``): the generator's reading of each
difference tried on the FE side.

Run: ``python benchmarks/crack_transfer.py --speed-rpm 3000``.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

CHANNELS = ("dte", "bearing2_fx", "bearing2_fy", "bearing2_fz", "node5_ax", "node5_ay")


def fe_transfer(
    freqs_hz: np.ndarray, speed_rpm: float, config: str = "config/paper_sun2021.yaml", variant: str = "fe"
) -> dict[str, np.ndarray]:
    """FE |H| (channel, frequency, direction a/c) per newton of the crack pair at node 5."""
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.faults.crack import deflection_map
    from gear_rotor_sim.solver.channels import parse_channels
    from gear_rotor_sim.solver.linear_model import LinearModel
    from gear_rotor_sim.system import GearRotorSystem

    system = GearRotorSystem.from_config(load_config(config), 25.0)
    lin = LinearModel(system)
    n = lin.nfree
    M, K, C = lin.M.copy(), lin.K.copy(), lin.C.copy()
    mesh = system.meshes[0]
    v = lin.V[0]
    if variant == "no_tilt_damping":  # the bearings' tilt damping (Table 5's c_theta) removed
        for b in system.bearings:
            for d in (3, 4):
                p = lin.pos[6 * b.node0 + d]
                if p >= 0:
                    C[p, p] -= b.damping[d, d]
    omega = speed_rpm * 2 * math.pi / 60
    D = C + omega * lin.G
    lin.C = C  # the bearing channels' damping rows below read system.bearings, not C
    P = deflection_map(system, mesh.pinion_node0)[:, lin.free]  # (2, n)
    # the line of action's direction in the pinion's x-y plane
    ix = lin.pos[6 * mesh.pinion_node0]
    iy = lin.pos[6 * mesh.pinion_node0 + 1]
    u = np.array([v[ix], v[iy]])
    u = u / np.linalg.norm(u)
    w = np.array([-u[1], u[0]])
    specs = parse_channels(system, CHANNELS)
    cx, _ = lin.output_rows(specs, omega)
    out = {c: np.zeros((freqs_hz.size, 2)) for c in CHANNELS}
    for k, f in enumerate(freqs_hz):
        om = 2 * math.pi * f
        A = K - om**2 * M + 1j * om * D
        for j, dvec in enumerate((u, w)):
            q = np.linalg.solve(A, P.T @ dvec)
            state = np.concatenate([q, 1j * om * q])
            o = 0
            for sp in specs:
                if sp.kind == "row" and sp.order == 2:
                    val = -(om**2) * q[lin.pos[sp.dof]]
                elif sp.kind == "row":
                    val = cx[o] @ state
                elif sp.kind == "dte":
                    val = lin.V[sp.mesh] @ q
                else:
                    val = np.nan
                if sp.kind == "row":
                    o += 1
                out[sp.name][k, j] = abs(val)
    _ = (n, mesh)
    return out


def lumped_transfer(freqs_hz: np.ndarray, speed_rpm: float, variant: str = "gen") -> dict[str, np.ndarray]:
    """Generator |H| (channel, frequency, direction a/c) per newton of the crack force on the pinion."""
    from lumped_gearbox import model as mdl
    from lumped_gearbox.params import Gearbox
    from lumped_gearbox.simulate import build

    s = build(Gearbox(), speed_rpm, 25.0)
    g, kk, cc, ms = s.geo, s.kk, s.cc, s.mass
    sa, ca = g[mdl.G_SA], g[mdl.G_CA]
    V = np.array([sa, ca, 0, g[mdl.G_RB1], -sa, -ca, 0, g[mdl.G_RB2]])
    M = np.diag([ms[mdl.M_M1]] * 3 + [ms[mdl.M_J1]] + [ms[mdl.M_M2]] * 3 + [ms[mdl.M_J2]])
    K = np.diag([kk[mdl.K_L1]] * 2 + [kk[mdl.K_Z1], kk[mdl.K_T1]] + [kk[mdl.K_L2]] * 2 + [kk[mdl.K_Z2], 0.0])
    C = np.diag([cc[mdl.C_L1]] * 2 + [cc[mdl.C_Z1], cc[mdl.C_T1]] + [cc[mdl.C_L2]] * 2 + [cc[mdl.C_Z2], 0.0])
    K = K + s.mesh_mean * np.outer(V, V)
    C = C + cc[mdl.C_M] * np.outer(V, V)
    if variant == "gear_held":  # the gear's rotation held (a rigid load): what the FE mesh does if so
        K[7, 7] += 1e12
    u = np.array([sa, ca])
    w = np.array([-ca, sa])
    out = {c: np.zeros((freqs_hz.size, 2)) for c in CHANNELS}
    for k, f in enumerate(freqs_hz):
        om = 2 * math.pi * f
        A = K - om**2 * M + 1j * om * C
        for j, dvec in enumerate((u, w)):
            F = np.zeros(8)
            F[0:2] = dvec
            q = np.linalg.solve(A, F)
            vel = 1j * om * q
            out["dte"][k, j] = abs(V @ q)
            out["bearing2_fx"][k, j] = abs(0.5 * (kk[mdl.K_L1] * q[0] - F[0] + cc[mdl.C_L1] * vel[0]))
            out["bearing2_fy"][k, j] = abs(0.5 * (kk[mdl.K_L1] * q[1] - F[1] + cc[mdl.C_L1] * vel[1]))
            out["bearing2_fz"][k, j] = abs(s.axial_half * q[2])
            out["node5_ax"][k, j] = abs(om**2 * q[0])
            out["node5_ay"][k, j] = abs(om**2 * q[1])
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--speed-rpm", type=float, default=3000.0)
    p.add_argument("--config", default="config/paper_sun2021.yaml")
    args = p.parse_args(argv)
    f1 = args.speed_rpm / 60
    freqs = np.array([1e-3, f1, 2 * f1, 3 * f1, 29 * f1])
    labels = ["static", "1x", "2x", "3x", "mesh"]
    fe = fe_transfer(freqs, args.speed_rpm, args.config)
    fe0 = fe_transfer(freqs, args.speed_rpm, args.config, "no_tilt_damping")
    gen = lumped_transfer(freqs, args.speed_rpm)
    print(
        f"|H| per N of the crack's force at the pinion, {args.speed_rpm:g} rpm, along (a) and across (c) the "
        "line of action; FE0: the FE model without the bearings' tilt damping; gen/FE, gen/FE0: ratios"
    )
    print(
        f"{'channel':12s} {'f':>6s}  {'FE a':>9s} {'FE0 a':>9s} {'gen a':>9s} {'gen/FE':>6s} {'gen/FE0':>7s}"
        f"  {'FE c':>9s} {'FE0 c':>9s} {'gen c':>9s} {'gen/FE':>6s} {'gen/FE0':>7s}"
    )
    for c in CHANNELS:
        if c == "bearing2_fz":
            continue  # no lateral force reaches it in either linearisation
        for k, lab in enumerate(labels):
            row = f"{c:12s} {lab:>6s}"
            for j in (0, 1):
                a, a0, b = fe[c][k][j], fe0[c][k][j], gen[c][k][j]
                r = b / a if a > 0 else float("nan")
                r0 = b / a0 if a0 > 0 else float("nan")
                row += f"  {a:9.3e} {a0:9.3e} {b:9.3e} {r:6.2f} {r0:7.2f}"
            print(row)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
