"""The statistic of the cross-talk rule on saved records (history Sec. 8.58): for each axial
bearing-force channel and each other bearing-force channel, the leak ``c``
(``gear_rotor_sim.calibration.channel_leak``), its size in standard errors (20 needed), the band readings'
``chi2 / dof`` about one real constant (3 at most), the bands that read it alone, the share of the axial
channel's fluctuating power it holds (0.5 needed), and whether it fires.

No calibration and no model run: each record is loaded as the CLI loads it (CWRU ``.mat`` files through their
mapping); the rule reads the record alone.

Usage::

    python benchmarks/sensor_leak_stats.py RECORD.csv [RECORD.csv | FILE.mat ...] [--summary]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any


def readings(path: Path) -> tuple[Any, list[Any]]:
    """The loaded measurement and its :func:`channel_leak.leak_readings`."""
    from gear_rotor_sim.calibration.channel_leak import leak_readings

    if path.suffix == ".mat":
        from gear_rotor_sim.calibration.cwru import load_cwru

        m = load_cwru(path, duration_s=None)
    else:
        from gear_rotor_sim.calibration.measurement import load_measurement

        m = load_measurement(path)
    q = [c.quantity for c in m.channels]
    d = [c.direction for c in m.channels]
    return m, leak_readings(m.data, q, d, m.sample_rate_hz)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("records", nargs="+", help="CSV records (with their sidecars) or CWRU .mat files")
    ap.add_argument("--summary", action="store_true", help="only the largest z, share and the firings")
    args = ap.parse_args(argv)
    if not args.summary:
        head = "| record | axial channel | source | c | z = abs(c) / se | chi2 / dof | bands alone | share |"
        print(head + " fires |")
        print("|---|---|---|---|---|---|---|---|---|")
    worst_z = worst_share = (0.0, "-")
    fired = []
    for p in map(Path, args.records):
        m, rs = readings(p)
        cols = [c.column for c in m.channels]
        if not rs and not args.summary:
            print(f"| {p.stem} | no axial force channel with a force source |" + " - |" * 6 + " no |")
        for r in rs:
            worst_z = max(worst_z, (r.z, f"{p.stem} {cols[r.source]}"))
            worst_share = max(worst_share, (r.share, f"{p.stem} {cols[r.source]}"))
            if r.is_leak:
                fired.append(f"{p.stem} {cols[r.target]} <- {cols[r.source]} {r.c:+.4g}")
            if not args.summary:
                print(
                    f"| {p.stem} | {cols[r.target]} | {cols[r.source]} | {r.c:+.4g} | {r.z:.3g} | "
                    f"{r.chi2_dof:.3g} | {r.bands_significant} | {r.share:.3f} | "
                    f"{'yes' if r.is_leak else 'no'} |",
                    flush=True,
                )
    print(
        f"\n{len(args.records)} records; largest z {worst_z[0]:.3g} ({worst_z[1]}), largest share "
        f"{worst_share[0]:.3g} ({worst_share[1]}); fires on {len(fired)}: {', '.join(fired) or 'none'}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
