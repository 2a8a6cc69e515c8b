"""The on-order mains rule's statistic on saved calibration reports: it must fire on none (issue 11).

``calibration/mains_repair.py`` and ``mains_pattern.py`` act only where ``mains_check.on_order_lines`` finds a
shaft order at a mains harmonic whose components the fitted model lacks (record >= 3 x model, >= 10 sigma)
hold at least ``mains_check.MIN_SHARE`` of the final error together. This script reads each report's
``residual_trace`` (``calibrate --json``), computes that summed share for every such order with the threshold
at 0, and prints per report the largest, its order and channels, and whether it reaches ``MIN_SHARE`` (the
rule fires: the record is diagnosed again). Reports without a residual trace (before session 18) are
skipped; the operating point's speed and the paper gearbox's ratio give the shafts. Docs:
docs/history/calibration_sessions.md Secs. 8.54, 8.59.

Usage::

    python benchmarks/mains_onorder_stats.py DIR [DIR ...] [--top N]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from gear_rotor_sim.calibration import mains_check as mc

#: the paper gearbox's output / input speed ratio (29 / 49 teeth)
RATIO = 29.0 / 49.0


def largest(report: dict[str, Any], big_t: float = 2.0) -> tuple[float, str]:
    """The largest summed share of a mains-harmonic shaft order that the model lacks, and where."""
    sp = float(report["operating_point"]["speed_rpm"]) / 60.0
    shafts = [("input", sp), ("output", sp * RATIO)]
    old = mc.MIN_SHARE
    mc.MIN_SHARE = 0.0
    try:
        groups = mc.on_order_lines(report["residual_trace"], shafts, big_t)
    finally:
        mc.MIN_SHARE = old
    if not groups:
        return 0.0, "-"
    g = groups[0]
    return float(g["share"]), f"{g['shaft']} order {g['order']}: " + ", ".join(
        c["channel"] for c in g["channels"]
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+", help="directories of *.calibration.json")
    ap.add_argument("--top", type=int, default=5, help="rows printed, largest first (default 5)")
    args = ap.parse_args(argv)
    rows = []
    for d in args.dirs:
        for f in sorted(Path(d).glob("*calibration.json")):
            rep = json.loads(f.read_text())
            if rep.get("residual_trace"):
                share, where = largest(rep)
                rows.append((share, f"{Path(d).name}/{f.name}", where))
    rows.sort(key=lambda r: -r[0])
    fired = sum(r[0] >= mc.MIN_SHARE for r in rows)
    print(f"{len(rows)} reports with a residual trace; the rule fires (share >= {mc.MIN_SHARE}) on {fired}")
    print("| report | largest summed share | order: channels |\n|---|---|---|")
    for share, name, where in rows[: args.top]:
        print(f"| {name} | {share:.3f} | {where} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
