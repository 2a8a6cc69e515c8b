"""CPU and wall time of ``gear-rotor-sim calibrate`` per record (issue 11: under 2 minutes per record).

The records are the issue-11 table's (``calibration_independent.py``) and the held-out set's
(``calibration_heldout.py``), made by ``lumped_gearbox`` with the same seeds into ``--out`` when they
are not there yet. Each record is calibrated ``--runs`` times in a subprocess
(``python -m gear_rotor_sim.cli calibrate RECORD.csv --json [--baseline REF]``); the CPU time is the
child's ``ru_utime + ru_stime`` (on a shared machine the wall time mostly measures the other jobs).
Prints one Markdown row per record and variant with the median and the range over the runs.

With ``--compare DIR`` every JSON report is compared field by field, to the last digit, with the report
of the same record and variant in DIR (``<tag>[.baseline].calibration.json``, as written by this script
with ``--save`` or by the two table benchmarks): a change that is meant to make the calibration faster
must leave them identical (docs/history/calibration_sessions.md Sec. 8.39).

Usage::

    python benchmarks/calibration_timing.py --table healthy_2000 contact_tooth_damage_gear \\
        --heldout healthy_1500 [--baseline] [--runs 3] [--out DIR] [--save DIR] [--compare DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import calibration_heldout as ho
import calibration_independent as ci

#: report fields that measure the run, not the result (none of the calibrate report's own fields today;
#: the table benchmarks add ``wall_s`` / ``cpu_s`` to the files they save)
TIMING_FIELDS = ("wall_s", "cpu_s")


def records(table: list[str], heldout: list[str], out: Path, duration_s: float) -> list[tuple[str, Path]]:
    """(tag, csv) of the table's and the held-out set's cases whose tag contains one of the substrings."""
    found: list[tuple[str, Path]] = []
    for subs, all_cases, make in ((table, ci.cases(False), ci.make), (heldout, ho.cases(), ho.make)):
        for c in all_cases:
            if subs and any(s in c.tag for s in subs):
                csv = out / f"{c.tag}.csv"
                if not csv.exists():
                    make(c, out, duration_s)
                found.append((c.tag, csv))
    return found


def reference(out: Path, duration_s: float) -> Path:
    """The benchmarks' healthy 2000 rpm reference, fitted once and saved (as ``--baseline`` takes it)."""
    ref = ci.Case(f"baseline_{ci.BASELINE[0]:.0f}rpm_{ci.BASELINE[1]:.0f}C", *ci.BASELINE, None, 999)
    saved = out / f"{ref.tag}.reference.json"
    return saved if saved.exists() else Path(ci._reference((ref, str(out), duration_s)))


def run_once(csv: Path, baseline: Path | None) -> tuple[float, float, str]:
    """CPU (s), wall (s) and the JSON report of one ``calibrate --json`` subprocess
    (``calibration_independent.calibrate``, which adds ``wall_s`` / ``cpu_s`` to the report)."""
    d = ci.calibrate(csv, baseline)
    if d.get("failed"):
        raise RuntimeError(f"calibrate {csv} failed: {d['stderr']}")
    return d["cpu_s"], d["wall_s"], json.dumps(d, indent=1)


def differences(a: Any, b: Any, path: str = "") -> list[str]:
    """Every leaf where two JSON documents differ (floats compared exactly, as their JSON text)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            if k in TIMING_FIELDS and not path:
                continue
            if k not in a or k not in b:
                out.append(f"{path}/{k}: only in {'new' if k in a else 'reference'}")
            else:
                out += differences(a[k], b[k], f"{path}/{k}")
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: length {len(a)} != {len(b)}"]
        pairs = enumerate(zip(a, b, strict=True))
        return [d for i, (x, y) in pairs for d in differences(x, y, f"{path}[{i}]")]
    same = json.dumps(a) == json.dumps(b)  # NaN == NaN, 0.1 != 0.10000000000000002
    return [] if same else [f"{path}: {json.dumps(a)[:80]} != {json.dumps(b)[:80]}"]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--table", nargs="*", default=[], help="table cases whose tag contains one of these")
    ap.add_argument("--heldout", nargs="*", default=[], help="held-out cases whose tag contains one of these")
    ap.add_argument("--baseline", action="store_true", help="also --baseline (the 2000 rpm reference)")
    ap.add_argument("--only-baseline", action="store_true", help="only the --baseline variant")
    ap.add_argument("--runs", type=int, default=1, help="calibrations per record and variant (median)")
    ap.add_argument("--out", default="out/calibration_timing", help="records directory")
    ap.add_argument("--duration-s", type=float, default=2.0, help="record length, s (default 2)")
    ap.add_argument("--save", default=None, help="write each JSON report (the last run's) into this dir")
    ap.add_argument("--compare", default=None, help="compare each JSON report with the one in this directory")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    todo = records(args.table, args.heldout, out, args.duration_s)
    if not todo:
        print("no case matches --table / --heldout", file=sys.stderr)
        return 2
    variants: list[Path | None] = [] if args.only_baseline else [None]
    if args.baseline or args.only_baseline:
        variants.append(reference(out, args.duration_s))
    print(
        f"{len(todo)} record(s), {args.runs} run(s) each, "
        f"load average {os.getloadavg()[0]:.1f} at the start\n\n"
        "| record | variant | CPU median (s) | CPU min-max (s) | wall median (s) | wall min-max (s) "
        "| report |\n|---|---|---|---|---|---|---|"
    )
    status = 0
    for tag, csv in todo:
        for base in variants:
            name = f"{tag}{'.baseline' if base else ''}.calibration.json"
            cpu, wall, text = [], [], ""
            for _ in range(args.runs):
                c, w, text = run_once(csv, base)
                cpu.append(c)
                wall.append(w)
            verdict = "-"
            if args.save:
                Path(args.save).mkdir(parents=True, exist_ok=True)
                (Path(args.save) / name).write_text(text)
            if args.compare:
                ref = Path(args.compare) / name
                if not ref.exists():
                    verdict = "no reference report"
                else:
                    diff = differences(json.loads(text), json.loads(ref.read_text()))
                    verdict = "identical" if not diff else f"{len(diff)} differences: {'; '.join(diff[:3])}"
                    status |= bool(diff)
            print(
                f"| {tag} | {'--baseline' if base else 'no reference'} | {statistics.median(cpu):.1f} | "
                f"{min(cpu):.1f}-{max(cpu):.1f} | {statistics.median(wall):.1f} | "
                f"{min(wall):.1f}-{max(wall):.1f} | {verdict} |",
                flush=True,
            )
    print(f"\nload average {os.getloadavg()[0]:.1f} at the end")
    return status


if __name__ == "__main__":
    sys.exit(main())
