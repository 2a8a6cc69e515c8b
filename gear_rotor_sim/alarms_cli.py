"""``gear-rotor-sim thresholds``: fault-alarm thresholds learnt from healthy records of your machine.

::

    gear-rotor-sim thresholds learn healthy_*.csv --out my_thresholds.json --k 6
    gear-rotor-sim thresholds check record.csv --thresholds my_thresholds.json

``learn`` cuts each healthy record into the monitor's windows (0.25 s from 0.5 s by default), computes
the monitor's features on its housing-acceleration channels and writes ``mean + k std`` per feature
and operating class (the file the monitor node's ``fault_thresholds_file`` reads). ``check`` applies
a thresholds file to the windows of records exactly as the monitor node does
(:meth:`gear_rotor_sim.alarms.FaultAlarms.check`) and prints the fault types that alarm per window.
docs/detection.md, "Thresholds for your own machine".
"""

from __future__ import annotations

import argparse
import json
import sys

from gear_rotor_sim.alarms_learn import SKIP_S, WINDOW_S


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", required=True)
    lrn = sub.add_parser("learn", help="learn thresholds from healthy records of one machine")
    lrn.add_argument(
        "records", nargs="+", help="healthy measurement files (.csv + .yaml sidecar, .mcap, CWRU .mat)"
    )
    lrn.add_argument("--out", required=True, help="thresholds JSON to write (fault_thresholds_file)")
    lrn.add_argument("--k", type=float, default=6.0, help="threshold = mean + k std (default 6)")
    lrn.add_argument(
        "--speeds",
        type=float,
        nargs="+",
        help="nominal speeds of the operating classes, rpm (default: declared)",
    )
    lrn.add_argument(
        "--temperatures",
        type=float,
        nargs="+",
        help="nominal temperatures of the classes, C (default: declared)",
    )
    chk = sub.add_parser(
        "check", help="fault alarms of each window of records, as the monitor node raises them"
    )
    chk.add_argument("records", nargs="+", help="measurement files to check")
    chk.add_argument(
        "--thresholds", required=True, help="thresholds JSON (thresholds learn, or the shipped one)"
    )
    chk.add_argument("--json", action="store_true", help="print one JSON object per window")
    for p in (lrn, chk):
        p.add_argument(
            "--window-s", type=float, default=WINDOW_S, help=f"window length, s (default {WINDOW_S:g})"
        )
        p.add_argument(
            "--skip-s", type=float, default=SKIP_S, help=f"start of the first window, s (default {SKIP_S:g})"
        )
        p.add_argument("--duration-s", type=float, help="use only this much of each record after --skip-s, s")


def _learn(args: argparse.Namespace) -> int:
    from gear_rotor_sim.alarms import save_thresholds
    from gear_rotor_sim.alarms_learn import features_of, learn, measurement_windows

    feats, points, configs = [], [], set()
    for path in args.records:
        wins, gearbox = measurement_windows(path, args.window_s, args.skip_s, args.duration_s)
        configs.add(gearbox)
        feats += features_of(wins, gearbox)
        points += [(w.speed_rpm, w.temperature_c) for w in wins]
    if len(configs) != 1:
        raise ValueError(f"the records declare different gearboxes: {sorted(configs)}")
    th = learn(feats, points, args.k, args.speeds, args.temperatures)
    note = f"learnt by gear-rotor-sim thresholds learn from {len(args.records)} healthy records"
    save_thresholds(th, args.out, config=configs.pop(), note=note)
    classes = "; ".join(f"{c[0]:g} rpm, {c[1]:g} C" for c in sorted(th.mean))
    print(f"operating classes: {classes}")
    print(f"wrote {args.out}: {len(th.names)} features, {len(feats)} healthy windows, k = {args.k:g}")
    return 0


def _check(args: argparse.Namespace) -> int:
    from gear_rotor_sim.alarms import FaultAlarms
    from gear_rotor_sim.alarms_learn import measurement_windows

    alarms = FaultAlarms(args.thresholds)
    n_win = n_alarm = 0
    for path in args.records:
        wins, _ = measurement_windows(path, args.window_s, args.skip_s, args.duration_s)
        for w in wins:
            hit, cls = alarms.check(w)
            n_win += 1
            n_alarm += bool(hit)
            if args.json:
                print(json.dumps({"record": path, "t0_s": w.t0, "operating_class": cls, "alarms": hit}))
            else:
                text = ", ".join(sorted(hit)) if hit else "no fault alarm"
                print(f"{path} t0 {w.t0:.3f} s ({cls[0]:g} rpm, {cls[1]:g} C): {text}")
    if not args.json:
        print(f"{n_alarm} of {n_win} windows with a fault alarm")
    return 0


def run(args: argparse.Namespace) -> int:
    try:
        return _learn(args) if args.action == "learn" else _check(args)
    except (OSError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
