"""Each channel's delay against the model and the other channels on saved records (issue 11, history
Sec. 8.57): the statistic of ``calibration/channel_skew.py`` printed per record and channel, so that its
thresholds can be checked on records without a skew (the 71 benchmark records: no channel may read as
skewed) and on records with one.

Usage::

    python benchmarks/channel_skew_stats.py RECORD.csv [RECORD.csv ...] [--out FILE.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np


def stats(path: Path) -> dict:
    """The calibrator set up on one record (speed check included), each channel's reading, the fix."""
    from gear_rotor_sim.calibration.channel_skew import read_delays, skew_fix
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.measurement import load_measurement

    t0 = time.process_time()
    if path.suffix.lower() == ".mat":  # the CWRU bearing rig, as the CLI loads it
        from gear_rotor_sim.calibration import cwru
        from gear_rotor_sim.calibration.measurement import load_mat

        m = cwru.decimate_to(load_mat(path, cwru.CWRU_MAPPING, "error"), 12000.0).segment(0.0, 3.0)
        cal = cwru.cwru_calibrator(m, lambda s: None)
    else:
        cal = Calibrator(load_measurement(path))
    cal._setup()
    cols = [c.column for c in cal.m.channels]
    ds = read_delays(cal, at_rattle=True)  # empty without order features (a rig without a mesh: CWRU)
    # where the teeth separate the rule reads nothing (read_delays): the readings are shown, never fixed
    fix = skew_fix(read_delays(cal), cols, cal.m.sample_rate_hz)
    if not ds:
        return {"record": path.stem, "channels": {}, "fix": [], "cpu_s": time.process_time() - t0}
    return {
        "record": path.stem,
        "channels": {
            c: {
                "delay": d.delay_samples,
                "skew": d.skew_samples,
                "gain": d.gain,
                "coherence": d.coherence,
                "n_lines": d.n_lines,
                "others_spread": d.others_spread,
            }
            for c, d in zip(cols, ds, strict=True)
        },
        "fix": [cols[c] for c in fix.channels],
        "rattle": not read_delays(cal) and bool(ds),
        "cpu_s": time.process_time() - t0,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("records", nargs="+", help="CSV records with their YAML sidecars, or CWRU .mat files")
    ap.add_argument("--out", help="write the readings as JSON")
    args = ap.parse_args(argv)
    rows = []
    for p in args.records:
        try:
            r = stats(Path(p))
        except Exception as exc:  # a record the calibrator refuses: say so and go on
            print(f"{Path(p).stem}: not read ({exc})", flush=True)
            continue
        rows.append(r)
        cells = " ".join(
            f"{c} {v['skew']:+.2f}/{v['gain']:.2f}/{v['coherence']:.2f}"
            if np.isfinite(v["skew"])
            else f"{c} -"
            for c, v in r["channels"].items()
        )
        cells = cells or "no order features (no mesh): nothing read"
        tail = " (teeth separating: not read)" if r.get("rattle") else ""
        print(f"{r['record']}: {cells} -> fix {r['fix'] or '-'}{tail} ({r['cpu_s']:.1f} s)", flush=True)
    if args.out:
        Path(args.out).write_text(json.dumps(rows, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
