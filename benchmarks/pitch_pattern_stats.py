"""The pitch-pattern rule's statistics on saved records (issue 11; calibration_sessions.md Sec. 8.68).

For every record (CSV + YAML sidecar with a ``dte`` column, constant speed, the paper gearbox) each wheel's
pattern is read from the record's DTE alone (``calibration/pitch_pattern.py``: the healthy model's DTE has
no content at a wheel's non-carrier orders, so on a record where no effect is found this is the statistic
the calibration's rule sees, ``calibration/pitch_baseline.py``): its significance (rule >= 20), its spread
round the wheel (rule >= 0.4) and its high-harmonic share (rule >= 0.3), and whether all hold. Prints one
line per record and wheel and the largest significance where the other two rules hold.

Usage::

    python benchmarks/pitch_pattern_stats.py DIR [DIR ...]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import yaml

from gear_rotor_sim.calibration import pitch_pattern as pp
from gear_rotor_sim.calibration.pitch_baseline import MIN_HIGH_SHARE, MIN_SIGNIFICANCE, MIN_SPREAD
from gear_rotor_sim.calibration.residual import cached_system
from gear_rotor_sim.config import load_config

#: the paper pair's teeth (pinion, gear)
TEETH = (29, 49)


def record_stats(csv: Path) -> list[tuple[str, float, float, float]]:
    """(wheel, significance, spread, high-harmonic share) of the record's DTE, or [] without a DTE column."""
    side = yaml.safe_load(csv.with_suffix(".yaml").read_text())
    cols = [c["column"] for c in side["channels"] if c.get("quantity") == "dynamic_transmission_error"]
    if not cols:
        return []
    data = np.genfromtxt(csv, delimiter=",", names=True)
    fs = float(side["sample_rate_hz"])
    op = side["operating_point"]
    f1 = float(op["speed_rpm"]) / 60.0
    eps = float(
        cached_system(load_config("paper_sun2021"), float(op["temperature_c"])).meshes[0].contact_ratio
    )
    t0 = float(side.get("t0", 0.0) or 0.0)
    out = []
    for wheel, z, f in (("pinion", TEETH[0], f1), ("gear", TEETH[1], f1 * TEETH[0] / TEETH[1])):
        orders = pp.pattern_orders(z)
        coef, var = pp.wheel_orders(data[cols[0]], fs, f, t0, orders)
        w = pp.fit_wheel_pattern(coef, var, z, eps)
        out.append((wheel, w.significance, pp.spread(w.positions_m), pp.high_harmonic_share(w.positions_m)))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+", help="directories of records (CSV + YAML)")
    args = ap.parse_args(argv)
    worst = (0.0, "")
    for d in args.dirs:
        for csv in sorted(Path(d).glob("*.csv")):
            for wheel, sig, spr, high in record_stats(csv):
                fires = sig >= MIN_SIGNIFICANCE and spr >= MIN_SPREAD and high >= MIN_HIGH_SHARE
                print(
                    f"{csv.name} {wheel}: significance {sig:.3g}, spread {spr:.2f}, high harmonics {high:.2f}"
                    f"{' FIRES' if fires else ''}"
                )
                if spr >= MIN_SPREAD and high >= MIN_HIGH_SHARE and sig > worst[0]:
                    worst = (sig, f"{csv.name} {wheel}")
    print(f"largest significance where the spread and harmonic rules hold: {worst[0]:.3g} ({worst[1]})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
