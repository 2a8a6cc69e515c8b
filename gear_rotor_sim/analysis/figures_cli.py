"""``gear-rotor-sim figures KIND``: one command per figure kind, PNG output.

Kinds
-----
``bifurcation``   Fig 6 panel: DTE Poincare samples vs speed (``--from`` a saved result or simulate,
                  ``--cache`` saves the result).
``phase``         phase portrait of the DTE at one speed.
``poincare``      Poincare map of the DTE at one speed.
``spectrum``      amplitude spectrum (or ``--order`` order spectrum) of any channel at one speed.
``bearing-force`` Fig 7: RMS total force of a bearing vs speed per temperature.
``displacement``  Fig 8: displacement amplitude per node at one speed, per bearing type.
``force-share``   Fig 9: share of the bearing force per direction.
``orbit``         Fig 10: axis orbit of bearing 2.

The sweep-based kinds take ``--from sweep.npz`` (``gear-rotor-sim sweep``) or simulate the grid
they need and optionally ``--cache`` it.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from gear_rotor_sim.analysis.sweep_cli import (
    BEARING_TYPES,
    MIN_CLASSIFY_PERIODS,
    InputError,
    add_run_arguments,
    check_run_arguments,
    load_result,
    parse_bearings,
    parse_floats,
    parse_speeds,
    run_reporting_errors,
    settings_from,
)

KINDS = (
    "bifurcation",
    "phase",
    "poincare",
    "spectrum",
    "bearing-force",
    "displacement",
    "force-share",
    "orbit",
)


def _case_arguments(p: argparse.ArgumentParser, temperature: bool = True) -> None:
    if temperature:
        p.add_argument("--temperature", type=float, default=25.0, help="uniform temperature, C")
    p.add_argument("--bearing", default="A#", help="bearing type A#, B# or C#")
    p.add_argument("--no-thermal-backlash", action="store_true", help="backlash independent of temperature")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="kind", metavar="KIND", required=True)
    p = sub.add_parser("bifurcation", help="Fig 6: DTE bifurcation diagram over speed")
    _case_arguments(p)
    p.add_argument("--speeds", type=parse_speeds, default=parse_speeds("500:20000:400"), help="a:b:n or list")
    p.add_argument("--from", dest="source", help="saved BifurcationResult .npz (no simulation)")
    p.add_argument("--cache", help="save the simulated result to this .npz")
    p.add_argument("--out", required=True, help="output PNG")
    add_run_arguments(p)
    for kind, helptext in (
        ("phase", "phase portrait of the DTE at one speed"),
        ("poincare", "Poincare map of the DTE at one speed"),
        ("spectrum", "amplitude or order spectrum of a channel at one speed"),
    ):
        p = sub.add_parser(kind, help=helptext)
        _case_arguments(p)
        p.add_argument("--speed", type=float, required=True, help="input speed, rpm")
        p.add_argument("--channel", default="dte", help="channel name (spectrum only; e.g. bearing2_fz)")
        p.add_argument("--order", action="store_true", help="order spectrum (orders of the input shaft)")
        p.add_argument("--max", type=float, default=None, help="largest frequency (Hz) or order shown")
        p.add_argument("--out", required=True, help="output PNG")
        add_run_arguments(p)
    for kind, helptext in (
        ("bearing-force", "Fig 7: RMS total bearing force vs speed per temperature"),
        ("displacement", "Fig 8: displacement amplitude per node"),
        ("force-share", "Fig 9: share of bearing force per direction"),
        ("orbit", "Fig 10: axis orbit of bearing 2"),
    ):
        p = sub.add_parser(kind, help=helptext)
        p.add_argument("--from", dest="source", help="saved SweepResult .npz (no simulation)")
        p.add_argument("--cache", help="save the simulated sweep to this .npz")
        p.add_argument("--temperatures", type=parse_floats, default=[25.0, 125.0, 225.0], help="C")
        if kind == "bearing-force":
            p.add_argument("--speeds", type=parse_speeds, default=parse_speeds("500:20000:79"), help="rpm")
            p.add_argument("--bearing", type=int, default=2, help="1-based bearing number")
        else:
            p.add_argument("--speed", type=float, default=19000.0, help="input speed, rpm")
            p.add_argument("--bearings", default="A#,B#,C#", help="bearing types")
        p.add_argument("--out", required=True, help="output PNG")
        add_run_arguments(p)


def _case(args: argparse.Namespace):  # type: ignore[no-untyped-def]
    from gear_rotor_sim.analysis.bifurcation import Case

    return Case(float(args.temperature), args.bearing, not args.no_thermal_backlash)


def _single_speed(args: argparse.Namespace, channels: tuple[str, ...]) -> tuple[np.ndarray, float, int]:
    from gear_rotor_sim.analysis.bifurcation import build_system, mesh_period_s, steady_run

    system = build_system(_case(args))
    settings = settings_from(args)
    data, _, used = steady_run(system, args.speed, settings, channels, None, first=True)
    return data, mesh_period_s(system, args.speed) / used.steps_per_mesh, used.steps_per_mesh


def _channel_unit(args: argparse.Namespace, name: str) -> str:
    from gear_rotor_sim.analysis.bifurcation import build_system
    from gear_rotor_sim.solver.newmark import available_channels

    return dict(available_channels(build_system(_case(args)))).get(name, "")


def _sweep(args: argparse.Namespace, speeds: np.ndarray, bearings: list[str]):  # type: ignore[no-untyped-def]
    from gear_rotor_sim.analysis.sweep import SweepResult, grid_cases, run_sweep

    if args.source:
        return load_result(args.source, SweepResult.load, "sweep result ('gear-rotor-sim sweep --out')")
    res = run_sweep(
        grid_cases(args.temperatures, bearings),
        speeds,
        settings_from(args),
        workers=args.workers,
        scheduler=args.scheduler,
        progress=not args.no_progress,
    )
    if args.cache:
        res.save(args.cache)
    return res


def check_arguments(args: argparse.Namespace) -> None:
    """Validate the options of ``figures KIND`` before anything is simulated (:class:`InputError`)."""
    if Path(args.out).suffix.lower() != ".png":
        raise InputError(f"--out: {args.out!r} must be a .png file")
    needs_classes = args.kind in ("bifurcation", "phase", "poincare")
    check_run_arguments(args, MIN_CLASSIFY_PERIODS if needs_classes else 1)
    if hasattr(args, "bearing") and isinstance(args.bearing, str) and args.bearing not in BEARING_TYPES:
        raise InputError(f"--bearing: {args.bearing!r} must be one of {', '.join(BEARING_TYPES)}")
    if args.kind == "bearing-force" and not 1 <= args.bearing <= 4:
        raise InputError(f"--bearing: {args.bearing} must be a bearing number in 1..4")
    if hasattr(args, "bearings"):
        parse_bearings(args.bearings)
    if hasattr(args, "speed") and not (np.isfinite(args.speed) and args.speed > 0):
        raise InputError(f"--speed: {args.speed!r} must be finite and > 0 rpm")
    if hasattr(args, "temperatures") and not args.temperatures:
        raise InputError("--temperatures: give at least one temperature")
    if args.kind == "spectrum":
        from gear_rotor_sim.analysis.bifurcation import build_system
        from gear_rotor_sim.solver.newmark import parse_channels

        try:
            parse_channels(build_system(_case(args)), [args.channel])
        except ValueError as exc:
            raise InputError(f"--channel: {exc}") from None


def run(args: argparse.Namespace) -> int:
    return run_reporting_errors("figures", lambda: _run(args))


def _run(args: argparse.Namespace) -> int:
    from gear_rotor_sim.analysis import figures

    check_arguments(args)
    out = Path(args.out)
    if args.kind == "bifurcation":
        from gear_rotor_sim.analysis.bifurcation import BifurcationResult, run_bifurcation

        if args.source:
            res = load_result(args.source, BifurcationResult.load, "bifurcation result (--cache FILE.npz)")
        else:
            res = run_bifurcation(
                _case(args),
                args.speeds,
                settings_from(args),
                workers=args.workers,
                scheduler=args.scheduler,
                progress=not args.no_progress,
            )
            if args.cache:
                res.save(args.cache)
        figures.plot_bifurcation([res], out)
        for label, lo, hi in res.windows():
            print(f"  {lo:8.0f} - {hi:8.0f} rpm  {label}")
    elif args.kind in ("phase", "poincare"):
        from gear_rotor_sim.analysis.classify import classify_motion
        from gear_rotor_sim.analysis.poincare import phase_portrait

        data, dt, spm = _single_speed(args, ("dte",))
        pp = phase_portrait(data[:, 0], 1.0 / dt, spm, offset=spm - 1)
        m = classify_motion(np.column_stack([pp.px, pp.pv]), [np.ptp(pp.x), np.ptp(pp.v)])
        title = f"{_case(args).label()}, {args.speed:g} rpm: {m.label}"
        if args.kind == "phase":
            figures.plot_phase_portrait(pp, out, title)
        else:
            figures.plot_poincare(pp.px, pp.pv, out, title)
        print(f"{args.speed:g} rpm: {m.label} ({m.n_distinct} distinct Poincare points, K={m.k:.2f})")
    elif args.kind == "spectrum":
        from gear_rotor_sim.analysis.signals import amplitude_spectrum, order_spectrum

        data, dt, _ = _single_speed(args, (args.channel,))
        x = data[:, 0]
        if args.order:
            spec = order_spectrum(x, 1.0 / dt, args.speed, samples_per_rev=4 * 29 * 8)
        else:
            spec = amplitude_spectrum(x, 1.0 / dt)
        unit = _channel_unit(args, args.channel)
        figures.plot_spectrum(
            spec, out, f"{args.channel}, {_case(args).label()}, {args.speed:g} rpm", unit, args.max
        )
    elif args.kind == "bearing-force":
        res = _sweep(args, args.speeds, ["A#"])
        figures.plot_bearing_force(res, out, args.temperatures, bearing=args.bearing)
    else:
        bearings = parse_bearings(args.bearings)
        res = _sweep(args, np.array([args.speed]), bearings)
        if args.kind == "displacement":
            figures.plot_displacement(res, out, args.speed, args.temperatures, bearings)
        elif args.kind == "force-share":
            figures.plot_force_share(res, out, args.speed, args.temperatures, bearings)
        else:
            figures.plot_orbit(res, out, args.speed, args.temperatures, bearings)
    print(f"wrote {out}")
    return 0
