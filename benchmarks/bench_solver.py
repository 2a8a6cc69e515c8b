"""Solver benchmark on the paper gearbox (prints; not a test). Run with OPENBLAS_NUM_THREADS=1.

Steps/s of the full model (108 DOF, 107 free) with DTE only and with the default channels, real-time
factor at 3000 and 20000 rpm (default dt rule, 32 steps per mesh), eigendecomposition time per speed,
RSS over a long streaming run. Median of 5 runs.
"""

from __future__ import annotations

import resource
import time

import numpy as np

from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.simulator import Simulator
from gear_rotor_sim.solver.newmark import LinearModel, eigen_basis, simulate_steady
from gear_rotor_sim.system import GearRotorSystem


def main() -> None:
    cfg = paper_gearbox()
    system = GearRotorSystem.from_config(cfg, 25.0)
    lin = LinearModel(system)
    te = []
    for i in range(5):
        t0 = time.perf_counter()
        b = eigen_basis(lin, 100.0 + i)
        te.append(time.perf_counter() - t0)
    print(
        f"eigendecomposition per speed: {np.median(te) * 1e3:.1f} ms "
        f"(cond(Phi) {b.cond:.3g}, dense={b.dense})"
    )
    for chans in (("dte",), tuple(Simulator.default_channels(system))):
        for rpm in (3000.0, 20000.0):
            _, st = simulate_steady(system, rpm, 10, 10, 32, chans, sample="step")
            ws = []
            for _ in range(5):
                t0 = time.perf_counter()
                simulate_steady(system, rpm, 0, 4000, 32, chans, initial_state=st, sample="mesh")
                ws.append(time.perf_counter() - t0)
            sps = 4000 * 32 / np.median(ws)
            f_mesh = 29 * rpm / 60.0
            print(
                f"{len(chans):2d} channels, {rpm:7.0f} rpm: {sps / 1e6:.3f} M steps/s, "
                f"RTF {sps / (32 * f_mesh):.2f}"
            )
    for rpm in (3000.0, 20000.0):
        sim = Simulator(cfg, rpm, 25.0, 20000.0)
        sim.advance(0.02)
        t0 = time.perf_counter()
        sim.advance(0.2)
        w = time.perf_counter() - t0
        print(f"Simulator.advance, default channels at 20 kHz, {rpm:.0f} rpm: RTF {0.2 / w:.2f}")
    sim = Simulator(cfg, 3000.0, 25.0, 1000.0, channels=["dte"])
    rss = []
    for _ in range(20):
        sim.advance(1.0)
        rss.append(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
    print(
        f"streaming 20 s simulated at 3000 rpm: max RSS (MB) after 1 s {rss[0]:.1f}, after 20 s {rss[-1]:.1f}"
    )


if __name__ == "__main__":
    main()
