"""A gear misalignment's record scored at fixed effects: angle, tilted-contact width, baseline sets.

Traces what sets a misalignment's angle and error in contact (docs/history/calibration_sessions.md Sec. 8.37):
the record (CSV, as ``gear-rotor-sim calibrate`` reads it, the start transient skipped) is scored against
the FE model with the given baseline sets (and a held reference's, ``--baseline REF.json``) plus a gear
misalignment at fixed angle and phase, for each ``rho`` scale (``face_width_m`` times the scale:
the edge-loaded mesh part only) and each angle factor. Prints the error, the balanced chi^2, the axial
channels' order chi^2 (the refinement's objective, ``candidates_misalignment.axial_chi2``) and the per-family
chi^2 / N.

Usage::

    python benchmarks/misalignment_width_trace.py RECORD.csv --angle 1.03e-3 --phase 3.14 \\
        [--member gear] [--baseline REF.json] [--mesh 1.80,0.777] [--bearing 0.5,1.2] \\
        [--scales 1 1.25 1.5 1.75 2] [--angle-factors 0.9 1.1 1.3]
"""

from __future__ import annotations

import argparse
import dataclasses
import time

from gear_rotor_sim.calibration.baseline import load_reference
from gear_rotor_sim.calibration.calibrate_cli import skip_start_transient
from gear_rotor_sim.calibration.candidates_misalignment import axial_chi2
from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.faults import BearingStiffnessDamping, Effect, GearMisalignment, MeshStiffnessDamping


def _pair(text: str) -> tuple[float, float]:
    k, c = (float(x) for x in text.split(","))
    return k, c


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("record")
    ap.add_argument("--angle", type=float, required=True, help="tilt, rad")
    ap.add_argument("--phase", type=float, required=True, help="phase, rad")
    ap.add_argument("--member", default="gear")
    ap.add_argument("--baseline", default=None, help="a held reference (JSON of --save-baseline)")
    ap.add_argument("--mesh", type=_pair, default=None, help="mesh set stiffness,damping scales")
    ap.add_argument("--bearing", type=_pair, default=None, help="bearing set stiffness,damping scales")
    ap.add_argument("--scales", type=float, nargs="*", default=[1.0, 1.25, 1.5, 1.75, 2.0, 3.0])
    ap.add_argument("--angle-factors", type=float, nargs="*", default=[0.9, 1.1, 1.3])
    args = ap.parse_args()

    m = load_measurement(args.record)
    start = skip_start_transient(m, None)
    if start:
        m = m.segment(start, None)
    kw = load_reference(args.baseline).calibrator_kwargs() if args.baseline else {}
    cal = Calibrator(m, **kw)
    cal._setup()
    cal._refit_transfer(cal._features(cal.base_raw))
    cal.n_total = cal.cmp.score(cal._features(cal.base_raw)).n_total
    sets: list[Effect] = []
    if args.mesh:
        sets.append(MeshStiffnessDamping(stiffness_scale=args.mesh[0], damping_scale=args.mesh[1]))
    if args.bearing:
        sets.append(BearingStiffnessDamping(stiffness_scale=args.bearing[0], damping_scale=args.bearing[1]))
    print(f"held baseline: {cal.baseline}; sets: {sets}")

    def score(effects: list[Effect], label: str) -> None:
        t = time.process_time()
        f = cal._features(cal._raw(tuple(effects)))
        s = cal.cmp.score(f)
        fam = {k: round(v / max(s.n[k], 1), 2) for k, v in s.chi2.items()}
        print(
            f"{label:32s} error {s.error:8.3f}  balanced chi2 {s.balanced_chi2:.4g}  axial chi2 "
            f"{axial_chi2(cal, f):.4g}  chi2/N {fam}  ({time.process_time() - t:.1f} s CPU)",
            flush=True,
        )

    mis = GearMisalignment(member=args.member, angle_rad=args.angle, phase_rad=args.phase)
    score(sets, "no misalignment")
    for s in args.scales:
        score([*sets, dataclasses.replace(mis, face_width_m=s * mis.face_width_m)], f"angle x1, rho x{s:g}")
    for a in args.angle_factors:
        score([*sets, dataclasses.replace(mis, angle_rad=a * args.angle)], f"angle x{a:g}, rho x1")


if __name__ == "__main__":
    main()
