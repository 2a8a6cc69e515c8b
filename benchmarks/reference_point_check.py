"""The record's error on a held reference's machine and on the nominal machine, and their ratio, which
``calibration/reference_point.py`` reads (docs/history/calibration_sessions.md Sec. 8.77).

Usage::

    python benchmarks/reference_point_check.py REFERENCE.reference.json RECORD.csv [RECORD.csv ...]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(argv: list[str] | None = None) -> int:
    from crack_baseline_trace import prepared

    from gear_rotor_sim.calibration.baseline import load_reference
    from gear_rotor_sim.calibration.reference_point import reference_point

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("reference", help="a saved reference baseline (*.reference.json)")
    ap.add_argument("records", nargs="+", help="records (CSV with their YAML sidecars)")
    args = ap.parse_args(argv)
    ref = load_reference(args.reference)
    for rec in args.records:
        t0 = time.process_time()
        cal = prepared(rec, list(ref.effects), ref.carrier_tolerance)
        cal.baseline_reference = ref.as_dict()
        # as ``Calibrator.run`` scores the record first: the settings' carrier tolerance, not the reference's
        cal.cmp.set_carrier_tolerance(cal.settings.tolerance)
        chk = reference_point(cal, cal.cmp.score(cal._features(cal.base_raw)))
        print(
            f"{Path(rec).stem}: {chk.speed_rpm:.0f} rpm, reference {chk.reference_speed_rpm:.0f} rpm: held "
            f"{chk.error_held:.4g}, nominal {chk.error_nominal:.4g}, ratio {chk.ratio:.3g} "
            f"({'describes' if chk.describes() else 'set aside'}); {time.process_time() - t0:.0f} s CPU",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
