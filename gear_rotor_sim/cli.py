"""The ``gear-rotor-sim`` command. Each subcommand lives with the code it drives.

A subcommand module provides ``add_arguments(parser)`` and ``run(args) -> int``; it is imported
only when its subcommand is used, so ``gear-rotor-sim validate`` never imports ROS or Dask.
"""

from __future__ import annotations

import argparse
import importlib
import sys

SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "validate": ("gear_rotor_sim.validation", "Table 2 and mesh-stiffness checks of the model"),
    "reproduce": ("gear_rotor_sim.analysis.reproduce", "reproduce the paper's figures and numbers"),
    "figures": ("gear_rotor_sim.analysis.figures_cli", "bifurcation, phase, Poincare, spectra, orbits"),
    "sweep": ("gear_rotor_sim.analysis.sweep_cli", "parallel sweeps over speed/temperature/..."),
    "record": ("gear_rotor_sim.recording.record_cli", "simulate and record an MCAP file (no ROS)"),
    "recover": ("gear_rotor_sim.recording.recover_cli", "complete an MCAP file cut by a crash"),
    "dataset": ("gear_rotor_sim.recording.dataset_cli", "generate a dataset of MCAP runs"),
    "calibrate": ("gear_rotor_sim.calibration.calibrate_cli", "fit the model to a measurement"),
    "thresholds": (
        "gear_rotor_sim.alarms_cli",
        "learn fault-alarm thresholds from healthy records, check records",
    ),
    "serve": ("gear_rotor_sim.live.serve", "stream live to Foxglove over WebSocket (no ROS)"),
}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gear-rotor-sim",
        description="Gear-rotor-bearing digital twin with steady-state temperature effects.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (module, helptext) in SUBCOMMANDS.items():
        p = sub.add_parser(name, help=helptext, description=helptext)
        if name == command:
            importlib.import_module(module).add_arguments(p)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    command = next((a for a in argv if not a.startswith("-")), None)
    if command not in SUBCOMMANDS:
        command = None
    args = build_parser(command).parse_args(argv)
    module = importlib.import_module(SUBCOMMANDS[args.command][0])
    return int(module.run(args) or 0)


if __name__ == "__main__":
    raise SystemExit(main())
