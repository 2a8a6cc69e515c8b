"""Memory of a long streaming run (prints; not a test). Run with OPENBLAS_NUM_THREADS=1.

``Simulator.advance(0.1)`` on the paper gearbox at 3000 rpm, 25 C, 20 kHz output, default channels
(the caller drops each block, as a streaming consumer does), for as many chunks as fit in the wall
budget (default 180 s) or until the simulated target (default 600 s) is reached. The resident set
size (``VmRSS`` of ``/proc/self/status``) is sampled after every chunk; printed: RSS after the
warm-up chunk, at the middle and at the end, the peak (``ru_maxrss``), and the least-squares slope
of RSS against simulated time over the second half of the run. If the run is shorter than the
target, the RSS at the target is extrapolated linearly from that slope (labelled as such).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_memory.py [--wall 180] [--target 600]
[--speed RPM]``.
"""

from __future__ import annotations

import argparse
import os
import resource
import time

import numpy as np

from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.simulator import Simulator

CHUNK_S = 0.1


def rss_mb() -> float:
    """Current resident set size, MB (VmRSS)."""
    with open("/proc/self/status", encoding="ascii") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def run(wall_budget_s: float = 180.0, target_s: float = 600.0, speed_rpm: float = 3000.0) -> dict:
    la0 = os.getloadavg()
    sim = Simulator(paper_gearbox(), speed_rpm, 25.0, 20000.0)
    sim.advance(CHUNK_S)  # warm-up: kernels loaded, basis and filter built
    t_sim = [sim.time_s]
    rss = [rss_mb()]
    w0, c0 = time.perf_counter(), time.process_time()
    n_samples = 0
    while time.perf_counter() - w0 < wall_budget_s and sim.time_s < target_s - 1e-9:
        blk = sim.advance(CHUNK_S)
        n_samples += blk.data.shape[0]
        del blk
        t_sim.append(sim.time_s)
        rss.append(rss_mb())
    wall = time.perf_counter() - w0
    cpu = time.process_time() - c0
    t = np.asarray(t_sim)
    r = np.asarray(rss)
    half = t.size // 2
    slope = float(np.polyfit(t[half:], r[half:], 1)[0]) if t.size - half >= 2 else float("nan")
    return {
        "speed_rpm": speed_rpm,
        "channels": len(sim.channels),
        "chunks": t.size - 1,
        "simulated_s": float(t[-1] - t[0]),
        "wall_s": wall,
        "cpu_s": cpu,
        "rtf": float(t[-1] - t[0]) / wall,
        "samples": n_samples,
        "rss_start_mb": float(r[0]),
        "rss_mid_mb": float(r[half]),
        "rss_end_mb": float(r[-1]),
        "rss_min_mb": float(r.min()),
        "rss_max_mb": float(r.max()),
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "slope_mb_per_sim_min": slope * 60.0,
        "t_end_s": float(t[-1]),
        "target_s": target_s,
        "extrapolated_rss_at_target_mb": float(r[-1] + slope * (target_s - t[-1])),
        "load": (la0, os.getloadavg()),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description="RSS of a long streaming run")
    ap.add_argument("--wall", type=float, default=180.0, help="wall-time budget, s")
    ap.add_argument("--target", type=float, default=600.0, help="simulated duration of interest, s")
    ap.add_argument(
        "--speed",
        type=float,
        default=3000.0,
        help="input speed, rpm (7000: the dt rule's contact-loss setting)",
    )
    args = ap.parse_args()
    res = run(args.wall, args.target, args.speed)
    print(
        f"Simulator.advance({CHUNK_S}) x {res['chunks']} at {res['speed_rpm']:.0f} rpm, 25 C, 20 kHz, "
        f"{res['channels']} channels: {res['simulated_s']:.1f} s simulated in {res['wall_s']:.1f} s wall "
        f"({res['cpu_s']:.1f} s CPU; RTF {res['rtf']:.1f}); load average {res['load'][0][0]:.2f} -> "
        f"{res['load'][1][0]:.2f}"
    )
    print(
        f"RSS (VmRSS) after warm-up {res['rss_start_mb']:.1f} MB, middle {res['rss_mid_mb']:.1f} MB, "
        f"end {res['rss_end_mb']:.1f} MB (min {res['rss_min_mb']:.1f}, max {res['rss_max_mb']:.1f}); "
        f"peak ru_maxrss {res['peak_mb']:.1f} MB"
    )
    print(f"slope over the second half: {res['slope_mb_per_sim_min']:+.3f} MB per simulated minute")
    if res["t_end_s"] < res["target_s"] - 1e-6:
        print(
            f"EXTRAPOLATED (linear, from that slope) RSS at {res['target_s'] / 60:.0f} simulated minutes: "
            f"{res['extrapolated_rss_at_target_mb']:.1f} MB"
        )
    else:
        print(f"measured through {res['t_end_s'] / 60:.1f} simulated minutes (no extrapolation)")


if __name__ == "__main__":
    main()
