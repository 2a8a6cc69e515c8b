"""The tracked input-shaft angle against the generator's true one, record by record (issue 11;
docs/history/calibration_sessions.md Sec. 8.55).

For each ``lumped_gearbox`` record (``RECORD.csv`` with its ``.yaml`` and ``.truth.json``) given or
found in the directories given, the speed check's tracker (``calibration/speed_tracking.py``) is run as
``order_tracking.check_speed_variation`` runs it, and the script prints:

- the decision statistic: the tracked angle's rms about its straight line, its limit
  ``max(5 sigma, tolerance)`` and their ratio (the record is resampled when it exceeds 1);
- the fast-fluctuation pass (``speed_fast.py``): whether it replaced the first track, and the
  coherent mesh-line power of both tracks (their ratio);
- the angle modulation at orders 1-3 of each shaft read from the mesh lines' sidebands
  (``speed_order_locked.py``): the largest, its z, and its ratio to the largest of the same shaft's other
  two orders (a fluctuation at a shaft's rate stands at one order, a damaged tooth's local event is flat),
  "(read)" where it is read as a speed fluctuation and added to the angle (as the calibration does);
- where the truth holds a speed profile: the true angle ``w0 (t + angle_extra(t))``
  (``lumped_gearbox/speed_profile.py``) and the tracked one (the decision's track and, where the record
  is resampled, the refined one), both less their straight line: the true deviation's rms, the error's
  rms and largest, two kernel widths from each end left out.

Usage::

    python benchmarks/speed_track_error.py PATH [PATH ...] [--cases SUBSTR ...]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np


def _records(paths: list[str], only: list[str] | None) -> list[Path]:
    out: list[Path] = []
    for p in map(Path, paths):
        out += sorted(p.glob("*.csv")) if p.is_dir() else [p]
    return [r for r in out if not only or any(s in r.stem for s in only)]


def first_tracks(
    paths: list[str], only: list[str] | None, orders: list[float], ratio: float
) -> Iterator[tuple[Path, Any, Any, float]]:
    """Each record of ``paths`` with the speed check's first track (``track_speed`` then ``track_faster``, as
    ``order_tracking.check_speed_variation`` makes it) and the CPU time it took: ``(csv, measurement, track,
    cpu_s)``. Shared with speed_order2_stats.py."""
    from gear_rotor_sim.calibration.measurement import load_measurement
    from gear_rotor_sim.calibration.speed_fast import track_faster
    from gear_rotor_sim.calibration.speed_tracking import track_speed

    for csv in _records(paths, only):
        m = load_measurement(csv)
        rpm = m.operating_point.speed_rpm
        c0 = time.process_time()
        tr = track_speed(m.data, m.sample_rate_hz, rpm, orders, ratio)
        tr = track_faster(m.data, m.sample_rate_hz, rpm, orders, ratio, tr)
        yield csv, m, tr, time.process_time() - c0


def _true_angle(csv: Path, t: np.ndarray, rpm: float) -> np.ndarray | None:
    """The generator's input angle at ``t`` from the truth's speed profile (None: constant speed)."""
    from lumped_gearbox.speed_profile import SpeedProfile, angle_extra

    truth = csv.with_suffix(".truth.json")
    if not truth.exists():
        return None
    prof = json.loads(truth.read_text()).get("speed_profile")
    if not prof:
        return None
    sp = SpeedProfile(**prof)
    if sp.constant:
        return None
    p = sp.vector(float(t[-1] + t[1] - t[0]))
    return rpm * math.pi / 30.0 * (t + angle_extra(p, t))


def _error(t: np.ndarray, tracked: np.ndarray, true: np.ndarray, kernel_s: float) -> tuple[float, float]:
    """Rms and largest of (tracked - true), both less their straight line, inside two kernel widths."""
    inner = (t >= 2 * kernel_s) & (t <= t[-1] - 2 * kernel_s)
    err = tracked - true
    err = err - np.polyval(np.polyfit(t[inner], err[inner], 1), t)
    return float(np.sqrt(np.mean(err[inner] ** 2))), float(np.max(np.abs(err[inner])))


def _order_locked(data: np.ndarray, theta: np.ndarray, lines: list[float], ratio: float) -> str:
    """The largest angle modulation at orders 1-3 of the gear and the pinion, with its dominance."""
    from gear_rotor_sim.calibration.speed_order_locked import angle_modulation

    best = ""
    top = 0.0
    for name, r in (("gear", ratio), ("pinion", 1.0)):
        mods = [angle_modulation(data, theta, lines, r, j) for j in (1, 2, 3)]
        amps = [m.amplitude_rad if m is not None else 0.0 for m in mods]
        j = int(np.argmax(amps))
        if amps[j] > top and mods[j] is not None:
            top = amps[j]
            other = max(a for i, a in enumerate(amps) if i != j)
            best = (
                f"{amps[j]:.2g} at {name} {j + 1}x (z {mods[j].z:.0f}), x{amps[j] / max(other, 1e-300):.3g}"
            )
    return best or "-"


def main(argv: list[str] | None = None) -> int:
    from gear_rotor_sim.calibration.order_tracking import (
        SpeedVariation,
        _interior,
        angle_tolerance_rad,
    )
    from gear_rotor_sim.calibration.speed_estimate import mesh_orders_per_input, slowest_shaft_ratio
    from gear_rotor_sim.calibration.speed_order_locked import order_locked_fluctuation, with_angle_modulation
    from gear_rotor_sim.calibration.speed_tracking import _line_orders, refine_track
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.system import shaft_speed_ratios

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("paths", nargs="+", help="record CSVs or directories of them")
    ap.add_argument("--cases", nargs="*", default=None, help="only records whose name contains one of these")
    args = ap.parse_args(argv)
    cfg = load_config("paper_sun2021")
    orders, ratio, tol = mesh_orders_per_input(cfg), slowest_shaft_ratio(cfg), angle_tolerance_rad(cfg)
    ratios = [float(r) for r in shaft_speed_ratios(cfg)]
    print(
        "| record | angle off uniform (rad rms) | limit | / limit | fast pass | power gain | order-locked "
        "(rad, / other orders) | true deviation (rad rms) | error, decision's track (rms / max) | error, "
        "refined (rms / max) | CPU (s) |\n|---|---|---|---|---|---|---|---|---|---|---|"
    )
    worst_const = 0.0
    t_start = time.perf_counter()
    for csv, m, tr, cpu in first_tracks(args.paths, args.cases, orders, ratio):
        rpm = m.operating_point.speed_rpm
        c0 = time.process_time()
        first = tr
        if tr is not None and tr.n_lines > 0:
            mod = order_locked_fluctuation(m.data, m.sample_rate_hz, tr, orders, ratios, tol)
            tr = with_angle_modulation(tr, mod) if mod is not None else tr
        cpu += time.process_time() - c0
        if tr is None or tr.n_lines == 0:
            print(f"| {csv.stem} | not tracked | | | | | | | | | {cpu:.1f} |")
            continue
        inner = _interior(tr)
        rms = float(np.sqrt(np.mean(tr.deviation_rad()[inner] ** 2)))
        var = SpeedVariation(tr, rms, tol)
        ratio_lim = rms / var.limit_rad
        fast = "yes" if tr.fast_pass else "no"
        gain = f"{tr.fast_power_gain:.3g}" if math.isfinite(tr.fast_power_gain) else "-"
        t = tr.t
        lines = _line_orders(orders, tr.mean_rpm / 60.0, m.sample_rate_hz)
        locked = _order_locked(m.data, first.angle_rad, lines, ratio)
        locked += " (read)" if tr.order_locked is not None else ""
        true = _true_angle(csv, t, rpm)
        dev = e1 = e2 = "-"
        if true is None:
            worst_const = max(worst_const, ratio_lim)
        else:
            td = true - np.polyval(np.polyfit(t, true, 1), t)
            dev = f"{math.sqrt(float(np.mean(td[inner] ** 2))):.3g}"
            e1 = "{:.2g} / {:.2g}".format(*_error(t, tr.angle_rad, true, tr.kernel_s))
            if ratio_lim > 1.0:
                c1 = time.process_time()
                # as the calibration refines: from the angle with its order-locked part
                ref = refine_track(m.data, m.sample_rate_hz, tr, orders)
                cpu += time.process_time() - c1
                e2 = "{:.2g} / {:.2g}".format(*_error(t, ref.angle_rad, true, ref.kernel_s))
        print(
            f"| {csv.stem} | {rms:.3g} | {var.limit_rad:.2g} | {ratio_lim:.3g} | {fast} | {gain} | "
            f"{locked} | {dev} | {e1} | {e2} | {cpu:.1f} |",
            flush=True,
        )
    print(
        f"\nlargest statistic of a constant-speed record: {worst_const:.3f} of its limit; load average "
        f"{os.getloadavg()[0]:.1f}; total {time.perf_counter() - t_start:.0f} s."
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
