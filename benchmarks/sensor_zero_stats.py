"""The statistics of session 20's two sensor-zero rules on saved records (history Sec. 8.53): a channel's
drifting mean (``gear_rotor_sim.calibration.channel_drift``: the largest ``|t|`` of a DC-coupled
channel's trend over the record, 10 needed) and an axial force's zero offset
(``gear_rotor_sim.calibration.axial_zero``: each axial bearing-force channel's static residual at the
declared temperature in static sigmas, 5 needed, and where it stands out the temperature offset it reads
and whether that is claimable).

No calibration: each record is loaded as the CLI loads it (CWRU ``.mat`` files through their mapping, 3 s
at 12 kHz as their reports), its calibrator made and, for the axial rule, set up (the healthy model's first
run at the declared operating point). The gain-modulation and sign checks that run before the axial rule in
``check_conventions`` are skipped (they fire on none of the benchmark records).

Usage::

    python benchmarks/sensor_zero_stats.py RECORD.csv [RECORD.csv | FILE.mat ...]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def row(path: Path) -> str:
    """One Markdown row: record, the largest drift ``|t|``, the axial channels' ``z``, the implied temperature
    offset, the claimable interval, whether either rule fires."""
    from gear_rotor_sim.calibration.axial_zero import K_SIGMA, axial_readings
    from gear_rotor_sim.calibration.channel_conventions import DYNAMIC_ONLY
    from gear_rotor_sim.calibration.channel_drift import T_MIN, trend
    from gear_rotor_sim.system import shaft_rates_hz

    if path.suffix == ".mat":
        from gear_rotor_sim.calibration.cwru import cwru_calibrator, load_cwru

        cal = cwru_calibrator(load_cwru(path))
    else:
        from gear_rotor_sim.calibration.fit import Calibrator
        from gear_rotor_sim.calibration.measurement import load_measurement

        cal = Calibrator(load_measurement(path))
    m = cal.m
    f_slow = min(shaft_rates_hz(cal.runner.cfg, m.operating_point.speed_rpm))
    dc = [(k, c.column) for k, c in enumerate(m.channels) if c.quantity not in DYNAMIC_ONLY]
    trends = [(trend(m.data[:, k], m.sample_rate_hz, f_slow), c) for k, c in dc]
    t_max, col = max(((abs(tr.t), c) for tr, c in trends if tr is not None), default=(float("nan"), "-"))
    fires = "yes" if t_max >= T_MIN else "no"
    drift = f"{t_max:.3g} ({col}) | {fires}" if dc else "no DC-coupled channel | no"
    if not any(c.quantity == "bearing_force" and c.direction == "z" for c in m.channels):
        return f"| {path.stem} | {drift} | no axial force channel | - | - | no |"
    cal._setup()
    r = axial_readings(cal)
    if r is None:
        return f"| {path.stem} | {drift} | no axial channel in the static family | - | - | no |"
    zs = ", ".join(f"{r.columns[k]} {r.z[k]:+.3g}" for k in r.axial)
    if r.sensitivity_n_per_c is None:
        return f"| {path.stem} | {drift} | {zs} | - (within {K_SIGMA:g}) | - | no |"
    implied = ", ".join(f"{r.residual_n[k] / r.sensitivity_n_per_c[k]:+.4g} C" for k in r.axial)
    lo, hi = r.claimable_c
    fires = "yes" if r.offsets() else "no"
    return f"| {path.stem} | {drift} | {zs} | {implied} | {lo:+.3g} to {hi:+.3g} C | {fires} |"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("records", nargs="+", help="CSV records (with their sidecars) or CWRU .mat files")
    args = ap.parse_args(argv)
    print(
        "| record | drift: largest abs(t) (channel) | drift fires | axial z (sigma) | implied temperature "
        "offset | claimable | axial zero fires |"
    )
    print("|---|---|---|---|---|---|---|")
    for p in args.records:
        print(row(Path(p)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
