"""Sideband energy ratios against depth and mesh stiffness scale on the FE model
(docs/history/calibration_sessions.md 8.10).

For a damaged tooth (gear tooth 5 or pinion tooth 5) at 3000 rpm / 25 C, data are made by the FE
model with the mesh stiffness scaled by 1.0 and 1.34 (the ratio of the ISO 6336 and potential-energy
mesh stiffnesses of the paper's pair, docs/calibration.md Sec. 8.1) at depths 0.2 / 0.4 / 0.6, with 3 %
noise. Each is read against the NOMINAL model (scale 1.0) twice: from the sideband energy ratios
``SER_m`` (``features_sidebands.py``) and, for contrast, from the absolute sideband energies
``sqrt(sum_k |c_{mz+-k}|^2)`` (what a fit on absolute amplitudes sees). A scale-free feature reads the
same depth at both scales.

Usage::

    python benchmarks/sideband_depth_scale.py [--wheel gear|pinion]
"""

from __future__ import annotations

import argparse
import itertools
import time

import numpy as np

from gear_rotor_sim.calibration import features_sidebands as fsb
from gear_rotor_sim.calibration.residual import cached_system
from gear_rotor_sim.config import load_config
from gear_rotor_sim.faults import MeshStiffnessDamping, ToothDamage
from gear_rotor_sim.simulator import Simulator

CHANNELS = ["dte", "bearing2_fx", "bearing2_fy", "node5_ax", "node5_ay"]
FS = 20000.0
SPEED_RPM = 3000.0
WARMUP_S = 0.15
WINDOW_S = 0.98  # one hunting period at 3000 rpm (29 x 49 mesh cycles): the other shaft cancels


def run(cfg, effects) -> np.ndarray:
    sim = Simulator(
        cfg, SPEED_RPM, 25.0, FS, CHANNELS, 32, effects=tuple(effects), system_builder=cached_system
    )
    block = sim.advance(WARMUP_S + WINDOW_S + 1e-3)
    i0 = round(WARMUP_S * FS)
    return block.data[i0 : i0 + round(WINDOW_S * FS)]


def shaft(wheel: str) -> tuple[float, int]:
    f_in = SPEED_RPM / 60.0
    return (f_in, 29) if wheel == "pinion" else (f_in * 29 / 49, 49)


def sideband_energy(x: np.ndarray, f: float, z: int) -> np.ndarray:
    """Absolute sideband energies (the ratio's numerator) per channel and harmonic, via the ratio
    times the carrier of the same synchronous average."""
    ser, _ = fsb.sideband_energy_ratios(x, FS, f, z, debias=False)
    car = np.array([[_carrier(x[:, c], f, z, m) for m in (1, 2, 3)] for c in range(x.shape[1])])
    return ser * car


def _carrier(x: np.ndarray, f: float, z: int, m: int) -> float:
    from gear_rotor_sim.calibration.residual import order_coefficients

    c, _, _ = order_coefficients(x, FS, f, np.array([m * z]), 0.0)
    return float(np.abs(c[0]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--wheel", choices=["gear", "pinion"], default="gear")
    args = ap.parse_args()
    t0 = time.perf_counter()
    cfg = load_config("paper_sun2021")
    f, z = shaft(args.wheel)

    def tooth(d: float) -> list:
        return [ToothDamage(tooth=5, depth=d, wheel=args.wheel)] if d > 0 else []

    runs = {d: run(cfg, tooth(d)) for d in fsb.DEPTH_GRID}
    ratio_grid = {d: fsb.sideband_energy_ratios(x, FS, f, z, debias=False)[0] for d, x in runs.items()}
    abs_grid = {d: sideband_energy(x, f, z) for d, x in runs.items()}
    members = [
        fsb.sideband_energy_ratios(run(cfg, [e, *tooth(0.4)]), FS, f, z, debias=False)[0]
        for e in fsb.CONTACT_ENSEMBLE
    ]
    mf = fsb.ensemble_log_spread(ratio_grid[0.4], members)
    rng = np.random.default_rng(1)
    rel_mf = fsb.ensemble_depth_spread(members, 0.4, ratio_grid, mf)
    print(f"{args.wheel} tooth 5, 3000 rpm, 25 C, 3 % noise; read against the nominal model (x1.0)\n")
    print(
        "| mesh scale of the data | true depth | depth from SER (rel.) | +- (statistical, model-form) "
        "| depth from absolute sideband energy (rel.) |"
    )
    print("|---|---|---|---|---|")
    for s, d in itertools.product([1.0, 1.34], [0.2, 0.4, 0.6]):
        eff = ([MeshStiffnessDamping(stiffness_scale=s)] if s != 1.0 else []) + tooth(d)
        x = run(cfg, eff)
        x = x + 0.03 * x.std(axis=0) * rng.standard_normal(x.shape)
        ser, se = fsb.sideband_energy_ratios(x, FS, f, z)
        r = fsb.fit_depth_from_ratios(ser, se, ratio_grid, mf)
        a = sideband_energy(x, f, z)
        ra = fsb.fit_depth_from_ratios(a, 0.05 * a, abs_grid, None)
        sd = float(np.hypot(r.sigma, rel_mf * r.depth))
        print(
            f"| x{s:g} | {d:g} | {r.depth:.3f} ({(r.depth - d) / d:+.0%}) | {sd:.3f} ({r.sigma:.3f}, "
            f"{rel_mf * r.depth:.3f}) | "
            f"{ra.depth:.3f} ({(ra.depth - d) / d:+.0%}) |"
        )
    print(f"\n{time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
