"""Command line: ``python -m lumped_gearbox record --speed-rpm 3000 ... --out X.csv``."""

from __future__ import annotations

import argparse
import sys
import time

from lumped_gearbox.faults import FAULT_NAMES, parse_fault
from lumped_gearbox.load_profile import LoadProfile
from lumped_gearbox.pitch import PitchErrors
from lumped_gearbox.record import make_record, write_record
from lumped_gearbox.sensors import parse_sensor
from lumped_gearbox.speed_profile import SpeedProfile


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m lumped_gearbox",
        description="Independent lumped-parameter simulator of the Sun et al. (2021) gearbox: test records.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    rec = sub.add_parser("record", help="write <out>.csv, <out>.yaml (sidecar) and <out>.truth.json")
    rec.add_argument("--speed-rpm", type=float, default=3000.0, help="input speed, rpm (default 3000)")
    rec.add_argument("--temperature-c", type=float, default=25.0, help="declared temperature, C (25-325)")
    rec.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="NAME:K=V,...",
        help=f"fault to inject (repeatable); names: {', '.join(FAULT_NAMES)}",
    )
    rec.add_argument("--duration-s", type=float, default=2.0, help="recorded duration, s (default 2)")
    rec.add_argument("--sample-rate-hz", type=float, default=20000.0, help="sample rate, Hz (default 20000)")
    rec.add_argument("--seed", type=int, default=0, help="seed of noise and gains (default 0)")
    rec.add_argument(
        "--housing", action="store_true", help="also record bearing2_housing_ax/ay (housing transfer path)"
    )
    rec.add_argument(
        "--sampling",
        choices=("daq", "point"),
        default="daq",
        help="daq (default): converged RK4 step, anti-aliasing low-pass, then sampling; "
        "point: every 8th RK4 state without a low-pass (the records of sessions 1-12)",
    )
    rec.add_argument(
        "--speed-drift-pct",
        type=float,
        default=0.0,
        help="speed_profile.drift_pct: change of the input speed over the record, %% of --speed-rpm "
        "(-10 .. 10, centred: --speed-rpm is the mean; default 0)",
    )
    rec.add_argument(
        "--speed-fluctuation-pct",
        type=float,
        default=0.0,
        help="speed_profile.fluctuation_pct: amplitude of a sinusoidal fluctuation, %% (0 .. 5; default 0)",
    )
    rec.add_argument(
        "--speed-fluctuation-hz",
        type=float,
        default=0.0,
        help="speed_profile.fluctuation_hz: its frequency, Hz (0 .. 400)",
    )
    rec.add_argument(
        "--load-fluctuation-pct",
        type=float,
        default=0.0,
        help="load_profile.amplitude_pct: amplitude of the output torque's fluctuation, %% of its mean "
        "(0 .. 50; default 0: constant torque)",
    )
    rec.add_argument(
        "--load-fluctuation-hz",
        type=float,
        default=0.0,
        help="load_profile.frequency_hz: its fixed frequency, Hz (0 .. 200)",
    )
    rec.add_argument(
        "--load-fluctuation-gear-order",
        type=float,
        default=0.0,
        help="load_profile.gear_order: locked to the gear's angle at this order of the gear shaft (0 .. 10; "
        "instead of --load-fluctuation-hz)",
    )
    rec.add_argument(
        "--pitch-fpt-um",
        type=float,
        default=0.0,
        help="pitch_errors.f_pt_um: RMS single pitch deviation of every tooth of both wheels, um "
        "(0 .. 30; default 0: exact teeth)",
    )
    rec.add_argument(
        "--pitch-runout-um",
        type=float,
        default=0.0,
        help="pitch_errors.runout_um: once-per-turn part of the cumulative pitch deviation, um (0 .. 50)",
    )
    rec.add_argument("--pitch-seed", type=int, default=0, help="pitch_errors.seed: seed of the flank draw")
    rec.add_argument(
        "--sensor",
        action="append",
        default=[],
        metavar="COLUMN:KIND:HZ[:ORDER]",
        help="a sensor's own filter on one column (repeatable): highpass (AC coupling, order 1) or lowpass "
        "(order 2), -3 dB at HZ; e.g. bearing2_fx:highpass:0.5, node5_ax:lowpass:3000",
    )
    rec.add_argument("--out", required=True, help="output CSV path")
    args = parser.parse_args(argv)
    try:
        faults = [parse_fault(f) for f in args.fault]
        profile = None
        if args.speed_drift_pct or args.speed_fluctuation_pct:
            profile = SpeedProfile(
                args.speed_drift_pct, args.speed_fluctuation_pct, args.speed_fluctuation_hz
            )
        load = None
        if args.load_fluctuation_pct:
            load = LoadProfile(
                args.load_fluctuation_pct, args.load_fluctuation_hz, args.load_fluctuation_gear_order
            )
        pitch = None
        if args.pitch_fpt_um or args.pitch_runout_um:
            pitch = PitchErrors(args.pitch_fpt_um, args.pitch_runout_um, args.pitch_seed)
        sensors: dict[str, list] = {}
        for text in args.sensor:
            col, filt = parse_sensor(text)
            sensors.setdefault(col, []).append(filt)
        t0 = time.perf_counter()
        r = make_record(
            args.speed_rpm,
            args.temperature_c,
            faults,
            duration_s=args.duration_s,
            sample_rate_hz=args.sample_rate_hz,
            seed=args.seed,
            housing=args.housing,
            sampling=args.sampling,
            speed_profile=profile,
            load_profile=load,
            pitch_errors=pitch,
            sensors=sensors,
        )
        path = write_record(args.out, r)
    except (ValueError, RuntimeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(
        f"wrote {path} (+ .yaml, .truth.json): {args.duration_s:g} s at {args.sample_rate_hz:g} Hz, "
        f"{args.sampling} sampling, contact-loss fraction {r.contact_loss_fraction:.3f}, "
        f"{time.perf_counter() - t0:.1f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
