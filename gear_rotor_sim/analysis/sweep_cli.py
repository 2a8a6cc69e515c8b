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
from collections.abc import Callable
from pathlib import Path

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
        "--steps-per-mesh",
        type=int,
        default=d.steps_per_mesh,
        help="Newmark steps per mesh period in continuous contact (the default dt rule refines it where "
        "the teeth separate or a mesh harmonic meets a lightly damped mode; docs/solver.md)",
    )
    parser.add_argument(
        "--fixed-steps",
        action="store_true",
        help="keep --steps-per-mesh throughout (no dt rule: faster, up to 8 %% RMS error where the "
        "teeth separate)",
    )
    parser.add_argument(
        "--workers", type=int, default=None, help="local worker processes (default: all cores)"
    )
    parser.add_argument(
        "--scheduler", default=None, help="Dask scheduler address (runs the sweep on that cluster)"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress line on stderr")


BEARING_TYPES = ("A#", "B#", "C#")
N_NODES = 18
#: Fewest sampled mesh periods the motion classification accepts (2 x max period 8 + 2).
MIN_CLASSIFY_PERIODS = 18


class InputError(ValueError):
    """A bad command-line value, reported as ``gear-rotor-sim COMMAND: error: ...`` (exit code 2)."""


def check_run_arguments(args: argparse.Namespace, min_periods: int = 1) -> None:
    """Validate the shared integration/execution options before anything is simulated.

    Raises
    ------
    InputError
        Naming the option, the value and what is allowed.
    """
    if not 8 <= args.steps_per_mesh <= 4096:
        raise InputError(f"--steps-per-mesh: {args.steps_per_mesh} must be in 8..4096")
    if args.periods < min_periods:
        raise InputError(f"--periods: {args.periods} must be >= {min_periods}")
    if args.transient < 0:
        raise InputError(f"--transient: {args.transient} must be >= 0")
    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers: {args.workers} must be >= 1")


def parse_bearings(text: str) -> list[str]:
    """Comma list of bearing types; each one of ``A#``, ``B#``, ``C#``."""
    out = [b.strip() for b in text.split(",") if b.strip()]
    bad = [b for b in out if b not in BEARING_TYPES]
    if not out or bad:
        raise InputError(f"bearings: {text!r} must be a comma list of {', '.join(BEARING_TYPES)}")
    return out


def parse_nodes(text: str) -> tuple[int, ...]:
    """Comma list of 1-based node numbers (1..18)."""
    try:
        nodes = tuple(int(n) for n in text.split(",") if n.strip())
    except ValueError:
        raise InputError(f"--orbit-nodes: {text!r} is not a comma list of node numbers") from None
    if not nodes or any(not 1 <= n <= N_NODES for n in nodes):
        raise InputError(f"--orbit-nodes: {text!r}: nodes must be in 1..{N_NODES}")
    return nodes


def check_source(path: str | None) -> None:
    """``--from``: the file must exist."""
    if path is not None and not Path(path).is_file():
        raise InputError(f"--from: {path!r} does not exist (give a .npz written by --cache or 'sweep --out')")


def load_result(path: str, loader: Callable[[str], object], what: str) -> object:
    """Load a saved result; a wrong or unreadable file becomes an :class:`InputError`."""
    check_source(path)
    import zipfile

    if not zipfile.is_zipfile(path):
        raise InputError(f"--from: {path!r} is not a .npz archive (expected a saved {what})")
    try:
        return loader(path)
    except (ValueError, KeyError, OSError) as exc:
        raise InputError(f"--from: {path!r} is not a saved {what} ({exc})") from None


def run_reporting_errors(command: str, body: Callable[[], int]) -> int:
    """Run ``body`` and report bad input on one line instead of a traceback.

    ValueError (including configuration and material-range errors), KeyError (a case missing from a
    saved sweep) and OSError (a missing or unwritable file) are printed as
    ``gear-rotor-sim COMMAND: error: ...``; the exit code is then 2.
    """
    try:
        return body()
    except (ValueError, OSError, KeyError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"gear-rotor-sim {command}: error: {msg}", file=sys.stderr)
        return 2


def settings_from(args: argparse.Namespace) -> RunSettings:
    d = RunSettings()
    rate = None if args.fixed_steps else d.contact_loss_rate_hz
    return RunSettings(args.transient, args.periods, args.steps_per_mesh, d.first_transient_factor, rate)


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
    return run_reporting_errors("sweep", lambda: _run(args))


def _run(args: argparse.Namespace) -> int:
    from gear_rotor_sim.analysis.sweep import grid_cases, run_sweep

    check_run_arguments(args)
    bearings = parse_bearings(args.bearings)
    orbit_nodes = parse_nodes(args.orbit_nodes)
    if not args.temperatures:
        raise InputError("--temperatures: give at least one temperature")
    cases = grid_cases(args.temperatures, bearings, args.backlash)
    res = run_sweep(
        cases,
        args.speeds,
        settings_from(args),
        orbit_nodes=orbit_nodes,
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
