"""``gear-rotor-sim recover``: turn an MCAP file cut by a crash into a complete one.

Example::

    gear-rotor-sim recover run.mcap --out run.recovered.mcap
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the ``recover`` options."""
    parser.add_argument("src", help="the unfinished (or damaged) MCAP file; it is not modified")
    parser.add_argument("--out", help="recovered file (default: SRC with .recovered.mcap)")


def default_output(src: Path) -> Path:
    """``run.mcap`` -> ``run.recovered.mcap``."""
    stem = src.name[: -len(".mcap")] if src.name.endswith(".mcap") else src.name
    return src.with_name(stem + ".recovered.mcap")


def run(args: argparse.Namespace) -> int:
    """Execute ``gear-rotor-sim recover``; returns the exit status."""
    from gear_rotor_sim.recording.recover import recover
    from gear_rotor_sim.recording.writer import RecordingError

    src = Path(args.src)
    dst = Path(args.out) if args.out else default_output(src)
    try:
        report = recover(src, dst)
    except (FileNotFoundError, ValueError, RecordingError) as exc:
        print(f"gear-rotor-sim recover: error: {exc}", file=sys.stderr)
        return 1
    print(report.summary())
    print(f"wrote {dst}")
    return 0
