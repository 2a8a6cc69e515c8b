"""Time-step convergence study of the Newmark solver on the paper gearbox (issue 3; docs/solver.md).

For each temperature and input speed the same simulated history (static equilibrium, a transient of
``TRANSIENT_S`` seconds, then a recorded window of whole mesh periods) is integrated with
``steps_per_mesh`` = 8, 16, ..., 256 and a reference with 512 (one halving beyond the table). Reported
per run, against the reference:

* ``e_ac``: relative error of the RMS of the fluctuating DTE (standard deviation over the window),
* ``e_tot``: relative error of the RMS of the DTE itself (mean included, as ``dte_rms`` of the sweeps),
* ``e_pc``: largest error of the Poincare samples (DTE at mesh phase 0, a common instant of every
  grid) over the window, relative to the reference standard deviation (pointwise, periodic only),
* the observed order ``p = log2(|R_h - R_h/2| / |R_h/2 - R_h/4|)`` from successive RMS values
  (reference free) and ``log2(e_pc(h) / e_pc(h/2))``.

The RMS is taken over the step samples of each grid (what the solver delivers at that dt).
A response that is not periodic (quasi-periodic or chaotic by the classifier of
:mod:`gear_rotor_sim.analysis.classify`) cannot converge pointwise; for it the window is long
(``LONG_PERIODS`` mesh periods) and the statistical standard error of the RMS (batch means over
20 blocks) is printed next to the error, which is meaningful only where it exceeds that noise.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/convergence_study.py [--quick] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time

import numpy as np

from gear_rotor_sim.analysis.classify import classify_motion
from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.solver.newmark import mesh_frequency_hz
from gear_rotor_sim.solver.steady import simulate_steady
from gear_rotor_sim.system import GearRotorSystem

TEMPERATURES_C = (25.0, 225.0)
SPEEDS_RPM = (1000.0, 3000.0, 7000.0, 12000.0, 14000.0, 17500.0, 19000.0)
#: Steps per mesh period of a periodic response: the halving ladder 8..256 plus the values between
#: (the Simulator's dt rule gives any value >= its minimum, and the error is not monotone), then
#: 512 and 1024 against the reference 2048 (the 512-point stiffness table is resolved from 512 on).
STEPS_PERIODIC = (8, 12, 16, 20, 24, 28, 32, 40, 48, 56, 64, 80, 96, 112, 128, 160, 192, 224, 256, 512, 1024)
REFERENCE_PERIODIC = 2048
#: Non-periodic responses: the halving ladder only, reference 512, long window.
STEPS_NONPERIODIC = (8, 16, 32, 64, 128, 256)
REFERENCE_NONPERIODIC = 512
#: Transient before recording, s: > 22 time constants of the slowest decaying mode (26 ms at 225 C).
TRANSIENT_S = 0.6
#: Recorded mesh periods of a periodic response and of a non-periodic one.
SHORT_PERIODS = 400
LONG_PERIODS = 30000
#: Mesh periods per call of simulate_steady (bounds the per-step arrays held at once).
PIECE_PERIODS = 1000
TOLERANCE = 0.005


def run_window(system: object, rpm: float, spm: int, n_transient: int, n_rec: int) -> dict:
    """Streaming statistics of the DTE over ``n_rec`` mesh periods after ``n_transient``."""
    _, st = simulate_steady(system, rpm, 0, n_transient, spm, ("dte",), sample="mesh")
    s1 = s2 = 0.0
    n = 0
    blocks: list[tuple[float, float, int]] = []
    sections: list[np.ndarray] = []
    loss = 0.0
    lo, hi = math.inf, -math.inf
    done = 0
    while done < n_rec:
        k = min(PIECE_PERIODS, n_rec - done)
        res, st = simulate_steady(system, rpm, 0, k, spm, ("dte",), initial_state=st, sample="step")
        x = res.channel("dte")
        sections.append(x[spm - 1 :: spm].copy())  # end of each mesh period = phase 0
        lo, hi = min(lo, float(x.min())), max(hi, float(x.max()))
        s1 += float(x.sum())
        s2 += float(np.dot(x, x))
        n += x.size
        loss += res.contact_loss_fraction * k
        blocks.append((float(x.sum()), float(np.dot(x, x)), x.size))
        done += k
    mean = s1 / n
    tot = math.sqrt(s2 / n)
    ac = math.sqrt(max(s2 / n - mean * mean, 0.0))
    return {
        "rms_total": tot,
        "rms_ac": ac,
        "mean": mean,
        "range": hi - lo,
        "section": np.concatenate(sections),
        "contact_loss_fraction": loss / n_rec,
        "blocks": blocks,
    }


def batch_se(blocks: list[tuple[float, float, int]], n_batches: int = 20) -> float:
    """Relative standard error of the AC RMS by batch means over the step samples."""
    # regroup the pieces' sums into n_batches consecutive batches of (almost) equal size
    s1 = np.array([b[0] for b in blocks])
    s2 = np.array([b[1] for b in blocks])
    cnt = np.array([b[2] for b in blocks])
    n_batches = min(n_batches, len(blocks))
    if n_batches < 5:
        return float("nan")
    groups = np.array_split(np.arange(len(blocks)), n_batches)
    vals = []
    for g in groups:
        m = s1[g].sum() / cnt[g].sum()
        vals.append(math.sqrt(max(s2[g].sum() / cnt[g].sum() - m * m, 0.0)))
    v = np.array(vals)
    return float(v.std(ddof=1) / math.sqrt(n_batches) / v.mean())


def study_point(system: object, rpm: float, long_periods: int, quick: bool = False) -> dict:
    f_mesh = mesh_frequency_hz(system, rpm)  # type: ignore[arg-type]
    n_tr = math.ceil(TRANSIENT_S * f_mesh)
    # classify on the periodic reference grid (short window first; lengthen if not periodic)
    ref = REFERENCE_PERIODIC
    r_ref = run_window(system, rpm, ref, n_tr, SHORT_PERIODS)
    sec = r_ref["section"]
    motion = classify_motion(sec, scale=r_ref["range"])  # tolerance relative to the DTE range
    periodic = motion.period > 0
    n_rec = SHORT_PERIODS
    steps = STEPS_PERIODIC
    if not periodic:
        n_rec = long_periods
        ref = REFERENCE_NONPERIODIC
        steps = STEPS_NONPERIODIC
        r_ref = run_window(system, rpm, ref, n_tr, n_rec)
    if quick:
        steps = STEPS_NONPERIODIC
    runs = {}
    for spm in steps:
        runs[spm] = run_window(system, rpm, spm, n_tr, n_rec)
    rows = []
    for spm in steps:
        r = runs[spm]
        e_ac = abs(r["rms_ac"] - r_ref["rms_ac"]) / r_ref["rms_ac"]
        e_tot = abs(r["rms_total"] - r_ref["rms_total"]) / r_ref["rms_total"]
        e_pc = float(np.max(np.abs(r["section"] - r_ref["section"]))) / r_ref["rms_ac"]
        rows.append(
            {
                "steps_per_mesh": spm,
                "rms_ac_m": r["rms_ac"],
                "rms_total_m": r["rms_total"],
                "e_ac": e_ac,
                "e_tot": e_tot,
                "e_pc": e_pc,
                "contact_loss_fraction": r["contact_loss_fraction"],
                "se_ac": batch_se(r["blocks"]) if not periodic else 0.0,
            }
        )
    # observed order over each halving h -> h/2 -> h/4 from successive RMS values (reference free)
    # and over h -> h/2 from the Poincare errors against the reference
    rms = {s: runs[s]["rms_ac"] for s in steps}
    rms[ref] = r_ref["rms_ac"]
    epc = {r["steps_per_mesh"]: r["e_pc"] for r in rows}
    for row in rows:
        s = row["steps_per_mesh"]
        row["p_rms"] = row["p_pc"] = float("nan")
        if 2 * s in rms and 4 * s in rms:
            d1, d2 = abs(rms[s] - rms[2 * s]), abs(rms[2 * s] - rms[4 * s])
            if d1 > 0 and d2 > 0:
                row["p_rms"] = math.log2(d1 / d2)
        if 2 * s in epc and epc[2 * s] > 0 and row["e_pc"] > 0:
            row["p_pc"] = math.log2(row["e_pc"] / epc[2 * s])
    return {
        "speed_rpm": rpm,
        "mesh_frequency_hz": f_mesh,
        "transient_periods": n_tr,
        "recorded_periods": n_rec,
        "motion": motion.label,
        "periodic": periodic,
        "reference_steps": ref,
        "reference_rms_ac_m": r_ref["rms_ac"],
        "reference_rms_total_m": r_ref["rms_total"],
        "reference_se_ac": batch_se(r_ref["blocks"]) if not periodic else 0.0,
        "contact_loss_fraction": r_ref["contact_loss_fraction"],
        "rows": rows,
    }


def _threshold(rows: list[dict], key: str) -> int | str:
    """Smallest steps/mesh s0 such that every tested s >= s0 meets the tolerance."""
    best: int | str = "none"
    for r in sorted(rows, key=lambda r: -r["steps_per_mesh"]):
        if r[key] > TOLERANCE:
            break
        best = r["steps_per_mesh"]
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="two speeds at 25 C, shorter windows")
    ap.add_argument("--json", default="", help="write the results to this JSON file")
    ap.add_argument("--speeds", type=float, nargs="*", help="input speeds, rpm (default: the study's)")
    ap.add_argument("--temperatures", type=float, nargs="*", help="temperatures, C (default 25 and 225)")
    args = ap.parse_args()
    temps = TEMPERATURES_C[:1] if args.quick else TEMPERATURES_C
    speeds = (3000.0, 14000.0) if args.quick else SPEEDS_RPM
    temps = tuple(args.temperatures) if args.temperatures else temps
    speeds = tuple(args.speeds) if args.speeds else speeds
    long_periods = 4000 if args.quick else LONG_PERIODS
    cfg = paper_gearbox()
    t_start = time.perf_counter()
    print(f"load average at start: {os.getloadavg()}")
    out = []
    for temp in temps:
        system = GearRotorSystem.from_config(cfg, temp)
        for rpm in speeds:
            t0 = time.perf_counter()
            pt = study_point(system, rpm, long_periods, args.quick)
            pt["temperature_c"] = temp
            out.append(pt)
            se = f", RMS standard error {pt['reference_se_ac'] * 100:.2f} %" if not pt["periodic"] else ""
            print(
                f"\n{temp:5.0f} C {rpm:7.0f} rpm ({pt['motion']}, contact loss "
                f"{pt['contact_loss_fraction'] * 100:.0f} % of steps, {pt['recorded_periods']} periods "
                f"after {pt['transient_periods']}{se}); reference {pt['reference_steps']} steps/mesh: "
                f"RMS(DTE - mean) {pt['reference_rms_ac_m'] * 1e6:.4f} um, RMS(DTE) "
                f"{pt['reference_rms_total_m'] * 1e6:.4f} um   [{time.perf_counter() - t0:.0f} s]"
            )
            print("  steps/mesh   e_ac(%)    e_tot(%)   e_pc(%)   p_rms  p_pc")
            for r in pt["rows"]:
                print(
                    f"  {r['steps_per_mesh']:9d} {r['e_ac'] * 100:10.4f} {r['e_tot'] * 100:10.4f} "
                    f"{r['e_pc'] * 100:10.4f} {r['p_rms']:6.2f} {r['p_pc']:5.2f}"
                )
    # dt rule: smallest steps per mesh meeting the tolerance at every periodic point
    print("\nsmallest tested steps/mesh from which every larger tested value has e <= 0.5 % (e_ac, e_tot):")
    for pt in out:
        print(
            f"  {pt['temperature_c']:5.0f} C {pt['speed_rpm']:7.0f} rpm {pt['motion']:>15s}: "
            f"{_threshold(pt['rows'], 'e_ac')}, {_threshold(pt['rows'], 'e_tot')}"
        )
    print(f"\ntotal wall {time.perf_counter() - t_start:.0f} s; load average at end: {os.getloadavg()}")
    if args.json:
        for pt in out:
            pt.pop("section", None)
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
