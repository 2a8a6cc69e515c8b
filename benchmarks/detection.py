"""Detection benchmark: the monitor's indicators over a labelled fault dataset, healthy-learnt alarms.

Generate the dataset (resumable) and the table in docs/detection.md with one command::

    bash benchmarks/detection.sh            # dataset into ./detection_ds, then this script

or, on an existing dataset::

    python benchmarks/detection.py DIR --markdown docs/detection.md

The alarms are :class:`gear_rotor_sim.alarms.FaultAlarms`'s computation (the monitor node's with
``fault_thresholds_file``): indicators of the window, thresholds of its operating class, groups.

Method: windows of ``--window-s`` from ``--skip-s`` on (gear_rotor_sim.datasets.load); features of the
housing accelerometers (gear_rotor_sim.fault_indicators.window_features); healthy runs split by
manifest order into training (even) and held-out (odd) halves; thresholds ``mean + k std`` per
feature and operating class learnt on the training half (gear_rotor_sim.alarms). Each fault type
is watched by its indicator group (``gear_rotor_sim.alarms.FAULT_GROUPS``) on all housing channels;
detection rate = fraction of that type's windows in which its group alarms; false alarms = fraction
of held-out healthy windows in which the group alarms. Printed and written for every ``k`` of ``--k``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from gear_rotor_sim import datasets
from gear_rotor_sim.alarms import FAULT_GROUPS, Thresholds, group_alarms, operating_class, save_thresholds
from gear_rotor_sim.fault_indicators import window_features

GROUPS = FAULT_GROUPS


def _run_features(args: tuple[str, float, float]) -> list[dict]:
    path, window_s, skip_s = args
    out = []
    for w in datasets.read_run(path).windows(window_s, skip_s):
        lab = [x for x in w.labels if x["active"]]
        out.append(
            {
                "run": w.run,
                "t0": w.t0,
                "speed_rpm": w.speed_rpm,
                "temperature_c": w.temperature_c,
                "type": lab[0]["type"] if lab else "healthy",
                "severity": lab[0]["severity"] if lab else 0.0,
                "severity_name": lab[0]["severity_name"] if lab else "",
                "features": window_features(w),
            }
        )
    return out


def features(directory: Path, window_s: float, skip_s: float, workers: int) -> list[dict]:
    files = [str(p) for p in datasets.run_files(directory)]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        per_run = list(pool.map(_run_features, [(f, window_s, skip_s) for f in files]))
    return [w for run in per_run for w in run]


def _group_alarm(th: Thresholds, feats: dict, cls: tuple, fault_type: str) -> bool:
    return fault_type in group_alarms(th.exceeded(feats, cls))


def evaluate(windows: list[dict], k: float) -> dict:
    healthy_runs = sorted({w["run"] for w in windows if w["type"] == "healthy"})
    train_runs = set(healthy_runs[0::2])
    train = [w for w in windows if w["run"] in train_runs]
    held = [w for w in windows if w["type"] == "healthy" and w["run"] not in train_runs]
    speeds = sorted({round(w["speed_rpm"]) for w in windows if w["type"] != "healthy"})
    temps = sorted({round(w["temperature_c"]) for w in windows if w["type"] != "healthy"})

    def cls(w: dict) -> tuple[float, float]:
        return operating_class(w["speed_rpm"], w["temperature_c"], speeds, temps)

    th = Thresholds.fit([w["features"] for w in train], [cls(w) for w in train], k)
    det: dict[str, dict[float, list[bool]]] = defaultdict(lambda: defaultdict(list))
    fa: dict[str, list[bool]] = defaultdict(list)
    any_fa = []
    for w in held:
        ex = th.exceeded(w["features"], cls(w))
        any_fa.append(bool(ex))
        hit = group_alarms(ex)
        for t in GROUPS:
            fa[t].append(t in hit)
    names = {}
    for w in windows:
        if w["type"] in GROUPS:
            det[w["type"]][w["severity"]].append(_group_alarm(th, w["features"], cls(w), w["type"]))
            names[w["type"]] = w["severity_name"]
    return {
        "k": k,
        "thresholds": th,
        "train_windows": len(train),
        "held_out_windows": len(held),
        "false_alarm_any": float(np.mean(any_fa)) if any_fa else float("nan"),
        "types": {
            t: {
                "severity_name": names.get(t, ""),
                "detection": {s: float(np.mean(v)) for s, v in sorted(det[t].items())},
                "windows": {s: len(v) for s, v in sorted(det[t].items())},
                "false_alarm": float(np.mean(fa[t])) if fa[t] else float("nan"),
            }
            for t in GROUPS
            if t in det
        },
    }


def table(res: dict) -> str:
    lines = [
        f"k = {res['k']:g}: {res['train_windows']} healthy training windows, {res['held_out_windows']} "
        f"held-out healthy windows; held-out windows with any alarm: {100 * res['false_alarm_any']:.1f} %",
        "",
        "| fault type | severity parameter | detection rate (severity) | false alarms (held-out healthy) |",
        "|---|---|---|---|",
    ]
    for t, r in res["types"].items():
        det = " / ".join(f"{100 * v:.0f} % ({s:g})" for s, v in r["detection"].items())
        lines.append(f"| {t} | {r['severity_name']} | {det} | {100 * r['false_alarm']:.1f} % |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("directory", type=Path, help="dataset folder (gear-rotor-sim dataset output)")
    ap.add_argument("--window-s", type=float, default=0.25)
    ap.add_argument("--skip-s", type=float, default=0.5, help="start-up transient skipped, s")
    ap.add_argument("--k", type=float, nargs="+", default=[3.0, 4.0, 5.0, 6.0])
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--markdown", type=Path, help="write the tables into this Markdown file's results block")
    ap.add_argument("--json", type=Path, help="write the results as JSON")
    ap.add_argument(
        "--save-thresholds",
        type=Path,
        help="write the thresholds learnt at --alarm-k (the monitor node's fault_thresholds_file)",
    )
    ap.add_argument("--alarm-k", type=float, default=6.0, help="k of the saved thresholds (default 6)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    windows = features(args.directory, args.window_s, args.skip_s, args.workers)
    wall = time.perf_counter() - t0
    ks = sorted(set(args.k) | ({args.alarm_k} if args.save_thresholds else set()))
    results = [evaluate(windows, k) for k in ks]
    if args.save_thresholds:
        th = next(r["thresholds"] for r in results if r["k"] == args.alarm_k)
        save_thresholds(
            th, str(args.save_thresholds), note=f"learnt by benchmarks/detection.py on {args.directory}"
        )
        print(f"wrote {args.save_thresholds}")
    results = [r for r in results if r["k"] in args.k]
    for r in results:
        del r["thresholds"]
    n_runs = len({w["run"] for w in windows})
    head = (
        f"{n_runs} runs, {len(windows)} windows of {args.window_s:g} s from {args.skip_s:g} s; "
        f"features computed in {wall:.1f} s wall"
    )
    text = head + "\n\n" + "\n\n".join(table(r) for r in results)
    print(text)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1), encoding="utf-8")
    return write_block(args.markdown, text, "results") if args.markdown else 0


def write_block(path: Path, text: str, name: str) -> int:
    """Replace what stands between ``<!-- NAME: begin -->`` and ``<!-- NAME: end -->`` in a Markdown
    file by ``text``; 0, or 2 when the file has no such block."""
    md = path.read_text(encoding="utf-8")
    begin, end = f"<!-- {name}: begin -->", f"<!-- {name}: end -->"
    if begin not in md or end not in md:
        print(f"{path}: no '{begin}' ... '{end}' block", file=sys.stderr)
        return 2
    md = md[: md.index(begin) + len(begin)] + "\n" + text + "\n" + md[md.index(end) :]
    path.write_text(md, encoding="utf-8")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
