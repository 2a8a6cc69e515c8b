"""``gear-rotor-sim dataset``: generate (or resume) a dataset of recorded runs from a sweep file.

Example::

    gear-rotor-sim dataset sweep.yaml --out data/bearing_study --workers 2
    gear-rotor-sim dataset sweep.yaml --out /shared/study --scheduler tcp://10.0.0.5:8786

The sweep format is described in :mod:`gear_rotor_sim.recording.dataset`.
"""

from __future__ import annotations

import argparse
import sys


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the ``dataset`` options."""
    parser.add_argument("sweep", help="sweep description (YAML)")
    parser.add_argument("--out", required=True, help="output folder (MCAP files and manifest.json)")
    parser.add_argument(
        "--workers", type=int, default=None, help="local worker processes (default: CPU count; 1: in-process)"
    )
    parser.add_argument(
        "--scheduler", help="Dask scheduler address, e.g. tcp://host:8786 (shared file system)"
    )
    parser.add_argument("--dry-run", action="store_true", help="validate the sweep and list the runs only")


def run(args: argparse.Namespace) -> int:
    """Execute ``gear-rotor-sim dataset``; returns the exit status."""
    from gear_rotor_sim.recording.dataset import DatasetError, generate, load_sweep
    from gear_rotor_sim.recording.record_cli import InputError

    if args.workers is not None and args.workers < 1:
        print(f"gear-rotor-sim dataset: error: --workers: {args.workers} (allowed >= 1)", file=sys.stderr)
        return 2
    try:
        sweep = load_sweep(args.sweep)
    except InputError as exc:
        print(f"gear-rotor-sim dataset: error: {args.sweep}: {exc}", file=sys.stderr)
        return 2
    if args.dry_run:
        for r in sweep.runs:
            p = r.params
            print(
                f"{r.file}: {p.speed_rpm:g} rpm, {p.temperature_c:g} C, {p.duration_s:g} s, "
                f"bearing {p.bearing_type or 'default'}"
            )
        return 0

    def say(line: str) -> None:
        print(line, flush=True)

    try:
        report = generate(sweep, args.out, workers=args.workers, scheduler=args.scheduler, log=say)
    except DatasetError as exc:
        print(f"gear-rotor-sim dataset: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("gear-rotor-sim dataset: interrupted; run the same command again to resume", file=sys.stderr)
        return 130
    print(
        f"dataset {sweep.name}: {report.total} runs ({len(report.done)} generated, "
        f"{len(report.skipped)} already complete); manifest {report.manifest}"
    )
    return 0
