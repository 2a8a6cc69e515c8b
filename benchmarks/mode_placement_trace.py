"""The mesh mode against a held reference: what the record says about the gear pair's inertia
(docs/history/calibration_sessions.md Sec. 8.71).

A reference record at a low speed fixes the static mesh compliance ``F / k`` (its mesh harmonics lie far
below the mesh mode) and nothing of the mode. This script brings a calibration against a saved reference to
its first round (the reference's sets held, the transfer slopes fitted) and scores the model on the record
with the gear discs' inertia times ``s`` (``faults.mesh_inertia.GearInertia``: the mode moves as
``1 / sqrt(s)``, ``F / k`` stays the reference's) for each ``s`` of ``--scales``, optionally with a damaged
tooth: the whole record's balanced chi^2, the error, chi^2 / n per family and the FE model's first mesh mode
at the reference's mesh stiffness and that inertia (``gear_rotor_sim.calibration.mesh_mode``).

Usage::

    python benchmarks/mode_placement_trace.py RECORD.csv --reference REF.reference.json \
        --scales 1,0.8,0.7,0.6,0.5 [--tooth pinion:7:0.4]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))


def prepared(record: str, reference: str) -> Any:
    """A calibrator against the saved reference brought to its first round (as ``crack_baseline_trace``)."""
    from crack_baseline_trace import prepared as _prepared

    from gear_rotor_sim.calibration.baseline import load_reference

    ref = load_reference(reference)
    return _prepared(record, list(ref.effects), ref.carrier_tolerance)


def main(argv: list[str] | None = None) -> int:
    from gear_rotor_sim.calibration.mesh_mode import mesh_mode_hz
    from gear_rotor_sim.faults import ToothDamage
    from gear_rotor_sim.faults.mesh_inertia import GearInertia

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("record")
    ap.add_argument("--reference", required=True, help="a saved reference baseline (*.reference.json)")
    ap.add_argument("--scales", default="1,0.8,0.7,0.6,0.5", help="gear inertia scales, comma-separated")
    ap.add_argument("--tooth", default=None, help="WHEEL:TOOTH:DEPTH of a damaged tooth added to every run")
    args = ap.parse_args(argv)
    t0 = time.process_time()
    cal = prepared(args.record, args.reference)
    temp = cal.m.operating_point.temperature_c
    extra: tuple = ()
    if args.tooth:
        w, t, d = args.tooth.split(":")
        extra = (ToothDamage(tooth=int(t), depth=float(d), wheel=w),)
    print(
        f"{Path(args.record).stem}: {cal.m.operating_point.speed_rpm:g} rpm, {temp:g} C; held: "
        + ", ".join(f"{b.label} {b.parameters()}" for b in cal.baseline)
        + (f"; with {extra[0].label} depth {extra[0].depth:g}" if extra else "")
    )
    for s in (float(v) for v in args.scales.split(",")):
        pre = (GearInertia(inertia_scale=s),) if s != 1.0 else ()
        feats = cal._features(cal._raw((*pre, *extra)))
        cal._refit_transfer(feats)
        sc = cal.cmp.score(feats)
        fam = ", ".join(f"{f} {sc.chi2[f] / max(sc.n[f], 1):.4g}" for f in sc.chi2 if sc.n[f])
        f_mode = mesh_mode_hz(cal.runner.cfg, temp, [*cal.baseline, *pre])
        print(
            f"  gear inertia x{s:g}: FE mesh mode {f_mode:.0f} Hz; balanced chi2 {sc.balanced_chi2:.6g}, "
            f"error {sc.error:.4g} (chi2/n: {fam})"
        )
    print(f"  CPU {time.process_time() - t0:.0f} s, {cal.runner.n_runs} runs")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
