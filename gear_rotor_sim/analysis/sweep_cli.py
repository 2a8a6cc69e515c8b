"""``gear-rotor-sim sweep``: speed x temperature x backlash x bearing-type sweeps saved to ``.npz``.

Examples
--------
``gear-rotor-sim sweep --speeds 500:20000:79 --temperatures 25,125,225 --out sweep.npz``
``gear-rotor-sim sweep --speeds 19000 --temperatures 25,125,225 --bearings A#,B#,C# --out s19k.npz``
``gear-rotor-sim sweep ... --scheduler tcp://10.0.0.5:8786`` (run the segments on a Dask cluster)
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from gear_rotor_sim.analysis.bifurcation import RunSettings


def parse_speeds(text: str) -> np.ndarray:
    """``"a:b:n"`` (n speeds from a to b inclusive) or a comma list, rpm."""
    text = text.strip()
    try:
        if ":" in text:
            a, b, n = text.split(":")
            speeds = np.linspace(float(a), float(b), int(n))
        else:
            speeds = np.array([float(s) for s in text.split(",") if s.strip()])
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"speeds: {text!r} is not 'start:stop:count' or 'v1,v2,...'"
        ) from None
    if speeds.size == 0 or np.any(~np.isfinite(speeds)) or np.any(speeds <= 0):
        raise argparse.ArgumentTypeError(f"speeds: {text!r} must give positive, finite speeds")
    return speeds


def parse_floats(text: str) -> list[float]:
    try:
        return [float(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of numbers") from None


def parse_backlash(text: str) -> list[bool]:
    out = []
    for s in text.split(","):
        s = s.strip()
        if s not in ("thermal", "fixed"):
            raise argparse.ArgumentTypeError(f"backlash: {s!r} is not 'thermal' or 'fixed'")
        out.append(s == "thermal")
    return out


def add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """Integration window and execution options shared by ``sweep`` and ``figures``."""
    d = RunSettings()
    parser.add_argument("--periods", type=int, default=d.n_periods, help="sampled mesh periods per speed")
    parser.add_argument("--transient", type=int, default=d.n_transient_periods, help="transient mesh periods")
    parser.add_argument(
        "--steps-per-mesh", type=int, default=d.steps_per_mesh, help="Newmark steps per mesh period"
    )
    parser.add_argument(
        "--workers", type=int, default=None, help="local worker processes (default: all cores)"
    )
    parser.add_argument(
        "--scheduler", default=None, help="Dask scheduler address (runs the sweep on that cluster)"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress line on stderr")


def settings_from(args: argparse.Namespace) -> RunSettings:
    d = RunSettings()
    return RunSettings(args.transient, args.periods, args.steps_per_mesh, d.first_transient_factor)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--speeds", type=parse_speeds, default=parse_speeds("500:20000:79"), help="a:b:n or list, rpm"
    )
    parser.add_argument(
        "--temperatures", type=parse_floats, default=[25.0, 125.0, 225.0], help="C, comma list"
    )
    parser.add_argument("--bearings", default="A#", help="bearing types, comma list of A#,B#,C#")
    parser.add_argument("--backlash", type=parse_backlash, default=[True], help="thermal,fixed")
    parser.add_argument("--orbit-nodes", default="9", help="1-based nodes whose x-y orbit is kept")
    parser.add_argument("--out", required=True, help="output .npz")
    add_run_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from gear_rotor_sim.analysis.sweep import grid_cases, run_sweep

    bearings = [b.strip() for b in args.bearings.split(",") if b.strip()]
    cases = grid_cases(args.temperatures, bearings, args.backlash)
    res = run_sweep(
        cases,
        args.speeds,
        settings_from(args),
        orbit_nodes=tuple(int(n) for n in args.orbit_nodes.split(",")),
        workers=args.workers,
        scheduler=args.scheduler,
        progress=not args.no_progress,
    )
    path = res.save(args.out)
    print(f"{len(cases)} case(s) x {res.speeds_rpm.size} speed(s) in {res.wall_time_s:.1f} s -> {path}")
    for i, c in enumerate(cases):
        f2 = res.data["bearing_total_rms"][i, :, 1]
        k = int(np.argmax(f2))
        peak = res.speeds_rpm[k]
        print(f"  {c.label()}: bearing 2 RMS force {f2.min():.0f}..{f2.max():.0f} N (max at {peak:g} rpm)")
    sys.stdout.flush()
    return 0
