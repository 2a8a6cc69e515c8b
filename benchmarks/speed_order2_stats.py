"""The angle modulation at a shaft's order 2 read from the mesh lines, record by record: what separates a
speed ripple at order 2 (a Cardan joint) from a misaligned wheel's own 2x (issue 11; docs/history/
calibration_sessions.md Sec. 8.60).

For each record (``RECORD.csv`` with its ``.yaml``; directories are searched for ``*.csv``) the speed check's
first track is made as ``order_tracking.check_speed_variation`` makes it (``track_speed`` then
``track_faster``) and, along it, for orders 1-3 of the pinion and the gear:

- the combined reading of ``speed_order_locked.angle_modulation`` (amplitude ``2 |d|`` in rad of the input,
  z, chi2 per line);
- the same per mesh harmonic ``m`` (every channel's line ``m z`` combined): ``2 |d_m|`` and ``arg d_m``;
- the relative amplitude modulation ``|a| / (K |d|)`` (median over lines);
- the axial channels' line at order 1 of the misaligned wheel (a misalignment's axial force), over its noise.

Usage::

    python benchmarks/speed_order2_stats.py PATH [PATH ...] [--cases SUBSTR ...] [--orders 2]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from speed_track_error import first_tracks


def _truth(csv: Path) -> str:
    p = csv.with_suffix(".truth.json")
    if not p.exists():
        return "-"
    t = json.loads(p.read_text())
    prof = t.get("speed_profile") or {}
    faults = ",".join(str(f.get("type", f)) if isinstance(f, dict) else str(f) for f in t.get("faults", []))
    sp = f" {prof.get('fluctuation_pct', 0)}%@{prof.get('fluctuation_hz', 0):.4g}Hz" if prof else ""
    return (faults or "healthy") + sp


def _per_harmonic(rd, z: int) -> str:
    from gear_rotor_sim.calibration.speed_order_locked import combine

    cells = []
    for m in (1, 2, 3):
        keep = np.isclose(rd.harmonic, m * z)
        mod = combine(rd, 0.0, 0, keep)
        cells.append("-" if mod is None else f"{mod.amplitude_rad:.2g}/{mod.phase_rad:+.2f}")
    return " ".join(cells)


def main(argv: list[str] | None = None) -> int:
    from gear_rotor_sim.calibration.speed_estimate import mesh_orders_per_input, slowest_shaft_ratio
    from gear_rotor_sim.calibration.speed_order_locked import combine, line_readings
    from gear_rotor_sim.calibration.speed_tracking import _line_orders
    from gear_rotor_sim.config import load_config

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("paths", nargs="+", help="record CSVs or directories of them")
    ap.add_argument("--cases", nargs="*", default=None, help="only records whose name contains one of these")
    ap.add_argument("--orders", nargs="*", type=int, default=[2], help="shaft orders shown (default 2)")
    args = ap.parse_args(argv)
    cfg = load_config("paper_sun2021")
    orders, ratio = mesh_orders_per_input(cfg), slowest_shaft_ratio(cfg)
    z = cfg.meshes[0].pinion_teeth
    print(
        "| record | truth | shaft order | 2|d| (rad) | z | chi2/line | per harmonic m=1,2,3: 2|d_m| / arg | "
        "|a|/(K|d|) | DTE per harmonic | CPU (s) |\n|---|---|---|---|---|---|---|---|---|---|"
    )
    t_start = time.perf_counter()
    for csv, m, tr, cpu in first_tracks(args.paths, args.cases, orders, ratio):
        c0 = time.process_time() - cpu
        if tr is None or tr.n_lines == 0:
            print(f"| {csv.stem} | {_truth(csv)} | not tracked |")
            continue
        lines = _line_orders(orders, tr.mean_rpm / 60.0, m.sample_rate_hz)
        dte = [i for i, c in enumerate(m.channels) if c.quantity == "dynamic_transmission_error"]
        for name, r in (("pinion", 1.0), ("gear", ratio)):
            for j in args.orders:
                rd = line_readings(m.data, tr.angle_rad, lines, r, j)
                mod = combine(rd, r, j)
                if mod is None:
                    continue
                kd = rd.harmonic * np.abs(rd.d)
                am = float(np.median(np.abs(rd.a) / np.maximum(kd, 1e-300)))
                on_dte = np.isin(rd.channel, dte)
                dcell = "-"
                if np.any(on_dte):
                    fields = ("harmonic", "channel", "d", "a", "weight")
                    sub = type(rd)(*(getattr(rd, f)[on_dte] for f in fields))
                    dcell = _per_harmonic(sub, z)
                print(
                    f"| {csv.stem} | {_truth(csv)} | {name} {j}x | {mod.amplitude_rad:.3g} | {mod.z:.0f} | "
                    f"{mod.chi2_per_line:.3g} | {_per_harmonic(rd, z)} | {am:.3g} | {dcell} | "
                    f"{time.process_time() - c0:.1f} |",
                    flush=True,
                )
    print(f"\nload average {os.getloadavg()[0]:.1f}; total {time.perf_counter() - t_start:.0f} s.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
