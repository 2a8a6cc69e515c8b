"""The speed read from every benchmark record's mesh lines, against its declared (true) speed: no
calibration, only the check that ``Calibrator`` runs first (``calibration/speed_check.py``).

Records: the 28 rows of the issue-11 table and its two reference records
(``calibration_independent.py``), the 41 held-out records (``calibration_heldout.py``), made by
``lumped_gearbox`` at their declared speed (a record already in ``--out`` is reused). For each: the
declared and measured speed, the sigma, ``z = (measured - declared) / sigma``, the lines used, the
Birge ratio, the halves' drift in sigma, the varying-speed statistic (``calibration/order_tracking.py``:
the tracked angle's rms off uniform rotation, its limit ``max(5 sigma, tolerance)`` and their ratio,
which must stay below 1) and whether the record is passed on as loaded (every one must be).

Usage::

    python benchmarks/speed_estimate_records.py [--out DIR] [--cases SUBSTR ...]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import calibration_heldout as ho
import calibration_independent as ci


def _records(out: Path, only: list[str] | None) -> list[tuple[str, Path]]:
    todo: list[tuple[str, object, object]] = [("table", c, ci.make) for c in ci.cases(False)]
    todo += [
        ("reference", ci.Case(f"baseline_{sp:.0f}rpm_{tc:.0f}C", sp, tc, None, 999), ci.make)
        for sp, tc in (ci.BASELINE, ci.BASELINE_ALT)
    ]
    todo += [("held-out", c, ho.make) for c in ho.cases()]
    recs = []
    for kind, case, make in todo:
        if only and not any(s in case.tag for s in only):
            continue
        csv = out / f"{case.tag}.csv"
        if not csv.exists():
            make(case, out, 2.0)
        recs.append((kind, csv))
    return recs


def main(argv: list[str] | None = None) -> int:
    from gear_rotor_sim.calibration.measurement import load_measurement
    from gear_rotor_sim.calibration.speed_check import check_operating_speed
    from gear_rotor_sim.config import load_config

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/speed_estimate_records", help="records directory")
    ap.add_argument("--cases", nargs="*", default=None, help="only records whose tag contains one of these")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    cfg = load_config("paper_sun2021")
    print(
        "| set | record | declared rpm | measured rpm | sigma (rpm) | z | lines | Birge "
        "| halves drift (sigma) | angle off uniform (rad rms) | its sigma | / limit | kept |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    )
    n_kept = n = 0
    cpu = 0.0
    worst = 0.0
    for kind, csv in _records(out, args.cases):
        m = load_measurement(csv)
        c0 = time.process_time()
        m2, chk = check_operating_speed(m, cfg)
        cpu += time.process_time() - c0
        e = chk.estimate
        kept = m2 is m
        n += 1
        n_kept += kept
        meas = "-" if e.measured_rpm is None else f"{e.measured_rpm:.6f}"
        v = chk.variation
        sig = v.track.sigma_angle_rad if v is not None and v.track is not None else math.nan
        ratio = v.rms_deviation_rad / v.limit_rad if v is not None else math.nan
        worst = max(worst, ratio) if math.isfinite(ratio) else worst
        print(
            f"| {kind} | {csv.stem} | {e.declared_rpm:g} | {meas} | {e.sigma_rpm:.2g} | {e.z_score:+.2f} | "
            f"{e.n_lines} | {e.birge_ratio:.2f} | {e.drift_z:+.2f} | {v.rms_deviation_rad:.2g} | {sig:.2g} | "
            f"{ratio:.3f} | {'yes' if kept else 'NO'} |",
            flush=True,
        )
    print(
        f"\n{n_kept} of {n} records keep the declared speed; largest varying-speed statistic {worst:.3f} "
        f"of its limit; check CPU {cpu:.1f} s in all; "
        f"load average {os.getloadavg()[0]:.1f}; total {time.perf_counter() - t0:.0f} s (with record making)."
    )
    return 0 if n_kept == n else 1


if __name__ == "__main__":
    sys.exit(main())
