"""``gear-rotor-sim calibrate MEASUREMENT [--report DIR] [--json]``.

Loads the measurement (CSV + sidecar, MCAP, or .mat with a mapping; the CWRU files use the built-in
mapping), runs the model at the declared operating point, traces the residual to the effect library,
and prints a summary, the JSON object (``--json``: one object with ``effects`` in the order found,
``error_before``, ``error_after`` and per-channel detail) and/or writes a report directory.

Exit status: 0 calibrated; 2 the measurement or an argument was refused (one line on stderr naming
the file, column or field, time and the allowed range); 3 the calibration produced a non-finite
error (reported on stderr, the JSON still printed with ``--json``: never a silent null result).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from gear_rotor_sim.calibration.measurement import Measurement, MeasurementError, load_measurement

EXIT_INVALID = 2
EXIT_NON_FINITE = 3


def _fmt(v: object) -> str:
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "measurement",
        metavar="MEASUREMENT",
        help="data file: .csv (with a .yaml sidecar), .mcap, or .mat (with a mapping)",
    )
    parser.add_argument("--report", metavar="DIR", help="write Markdown, PNG figures and JSON into DIR")
    parser.add_argument("--json", action="store_true", help="print one JSON object on stdout (nothing else)")
    parser.add_argument(
        "--sidecar",
        "--mapping",
        dest="description",
        metavar="YAML",
        help="sidecar/mapping file (default: same stem .yaml); 'cwru' for the CWRU .mat mapping",
    )
    parser.add_argument("--gearbox", help="override the sidecar's gearbox (config name or path)")
    parser.add_argument(
        "--baseline",
        metavar="HEALTHY",
        help="healthy record of the same machine (any operating point), or a reference saved by "
        "--save-baseline (.json): its baseline (mesh and bearing stiffness/damping scales, carrier "
        "model-form tolerance) is calibrated first and MEASUREMENT is diagnosed against the updated model",
    )
    parser.add_argument(
        "--save-baseline",
        metavar="FILE",
        help="write the reference baseline fitted from --baseline HEALTHY to FILE (JSON), for reuse",
    )
    parser.add_argument(
        "--allow-gaps",
        action="store_true",
        help="analyse the longest clean segment instead of refusing data with gaps/NaN runs",
    )
    parser.add_argument(
        "--duration",
        type=float,
        default=None,
        metavar="S",
        help="analyse only the first S seconds (default: all; CWRU files: 3 s)",
    )
    parser.add_argument(
        "--start",
        type=float,
        default=None,
        metavar="S",
        help="analyse from S seconds into the record (default: a leading start-up transient, as in a "
        "recording that starts from rest or static equilibrium, is detected and skipped; 0 keeps it)",
    )
    parser.add_argument(
        "--tolerance",
        type=float,
        default=None,
        help="relative model-form tolerance of the features (default 0.05)",
    )
    parser.add_argument("--max-effects", type=int, default=None, help="most effects added (default 3)")
    parser.add_argument(
        "--no-speed-check",
        action="store_true",
        help="use the declared speed as is (default: it is checked against the record's mesh lines and the "
        "measured one is used where they disagree, reported as operating_speed; docs/calibration.md Sec. 2)",
    )
    parser.add_argument(
        "--no-load-check",
        action="store_true",
        help="use the declared output torque as is (default: it is checked against the radial bearing-force "
        "means and the measured one is used where they disagree, reported as operating_torque; "
        "docs/calibration.md Sec. 2)",
    )
    parser.add_argument(
        "--steps-per-mesh",
        type=int,
        default=None,
        help="integration steps per mesh period of the model runs (default: the diagnosis takes the "
        "coarsest count from 32, 64 with --baseline, whose healthy model agrees with twice the steps "
        "within the noise, docs/history/calibration_sessions.md Sec. 8.24; the --baseline reference is "
        "fitted at 64: from 48 on the mesh events are located, Sec. 8.18); a given count is used as is",
    )


def skip_start_transient(m: Measurement, gearbox: str | None = None) -> float:
    """Start of the analysed part: after a leading start-up transient of ``m`` (0 if none or if the
    rig's shaft rates are unknown); a skip is listed in ``m.issues``."""
    from gear_rotor_sim.calibration.features_orders import leading_transient_s
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.system import shaft_speed_ratios

    try:
        cfg = load_config(gearbox or m.gearbox)
    except (ValueError, OSError, TypeError, KeyError):
        return 0.0
    f_in = m.operating_point.speed_rpm / 60.0
    shafts = [abs(float(r)) * f_in for r in shaft_speed_ratios(cfg)]
    start = leading_transient_s(m.data, m.sample_rate_hz, shafts)
    if start > 0.0:
        m.issues.append(
            f"start-up transient: the first {start:.3g} s hold non-synchronous content above 3x its "
            "level in the rest of the record (free vibration decaying); analysed from there (--start 0 "
            "keeps it)"
        )
    return start


def run(args: argparse.Namespace) -> int:
    from gear_rotor_sim.calibration import cwru
    from gear_rotor_sim.calibration.baseline import fit_reference_baseline, load_reference
    from gear_rotor_sim.calibration.fit import Calibrator, FitSettings
    from gear_rotor_sim.calibration.report import result_json, write_report
    from gear_rotor_sim.calibration.residual import REFERENCE_STEPS_PER_MESH, ResidualSettings

    def log(msg: str) -> None:
        if not args.json:
            print(msg, file=sys.stderr)

    path = Path(args.measurement)
    nan_policy = "longest_segment" if args.allow_gaps else "error"
    use_cwru = args.description == "cwru" or (
        path.suffix.lower() == ".mat"
        and args.description is None
        and cwru.is_cwru_file(path)
        and not path.with_suffix(".yaml").exists()
    )
    if args.start is not None and not (math.isfinite(args.start) and args.start >= 0.0):
        print(f"gear-rotor-sim calibrate: --start: {args.start} is not a time >= 0 s", file=sys.stderr)
        return EXIT_INVALID
    try:
        if use_cwru:
            from gear_rotor_sim.calibration.measurement import load_mat

            m = cwru.decimate_to(load_mat(path, cwru.CWRU_MAPPING, nan_policy), 12000.0)
            duration = 3.0 if args.duration is None else args.duration
        else:
            m = load_measurement(path, args.description, nan_policy)
            duration = args.duration
        start = args.start
        if start is None:
            start = 0.0 if use_cwru else skip_start_transient(m, args.gearbox)
        if duration is not None or start:
            m = m.segment(start, duration)
    except (MeasurementError, ValueError) as exc:
        print(f"gear-rotor-sim calibrate: {exc}", file=sys.stderr)
        return EXIT_INVALID
    if args.gearbox:
        m.gearbox, m.bearing_type = args.gearbox, None
    for issue in m.issues:
        log(f"note: {issue}")
    try:
        if use_cwru:
            cal = cwru.cwru_calibrator(m, log)
        else:
            settings = ResidualSettings()
            if args.tolerance is not None:
                settings.tolerance = args.tolerance
            ref: dict = {}
            if args.save_baseline and (not args.baseline or Path(args.baseline).suffix.lower() == ".json"):
                raise ValueError("--save-baseline FILE needs --baseline HEALTHY, a record to fit it on")
            if args.baseline and Path(args.baseline).suffix.lower() == ".json":
                rb = load_reference(args.baseline)
                log(f"baseline: {args.baseline} (fitted on {rb.source})")
                ref = rb.calibrator_kwargs()
            elif args.baseline:
                href = load_measurement(Path(args.baseline), None, nan_policy)
                href_start = args.start
                if href_start is None:
                    href_start = skip_start_transient(href, args.gearbox)
                if args.duration is not None or href_start:
                    href = href.segment(href_start, args.duration)
                if args.gearbox:
                    href.gearbox, href.bearing_type = args.gearbox, None
                log(f"baseline: calibrating on {args.baseline}")
                rb = fit_reference_baseline(
                    href,
                    source=str(args.baseline),
                    settings=settings,
                    steps_per_mesh=REFERENCE_STEPS_PER_MESH
                    if args.steps_per_mesh is None
                    else args.steps_per_mesh,
                    log=log,
                    speed_check=not args.no_speed_check,
                    load_check=not args.no_load_check,
                )
                for note in rb.notes:
                    log(f"baseline: {note}")
                if args.save_baseline:
                    log(f"baseline: saved to {rb.save(args.save_baseline)}")
                ref = rb.calibrator_kwargs()
            cal = Calibrator(
                m,
                settings=settings,
                steps_per_mesh=args.steps_per_mesh,
                log=log,
                speed_check=not args.no_speed_check,
                load_check=not args.no_load_check,
                **ref,
            )
        if args.tolerance is not None:
            cal.settings.tolerance = args.tolerance
        if args.max_effects is not None:
            cal.fit = FitSettings(max_effects=args.max_effects)
        result = cal.run()
    except (MeasurementError, ValueError, KeyError) as exc:
        print(f"gear-rotor-sim calibrate: {exc}", file=sys.stderr)
        return EXIT_INVALID
    if not (math.isfinite(result.error_before) and math.isfinite(result.error_after)):
        print(
            f"gear-rotor-sim calibrate: {path}: non-finite error (before {result.error_before}, "
            f"after {result.error_after}); the measurement or the model overflowed; data issues: "
            f"{m.issues or 'none'}",
            file=sys.stderr,
        )
        if args.json:
            print(json.dumps(result_json(result)))
        return EXIT_NON_FINITE
    if args.report:
        paths = write_report(result, args.report)
        log(f"report: {paths['markdown']}")
    if args.json:
        print(json.dumps(result_json(result)))
    else:
        print(f"{path.name}: {result.conclusion}")
        print(f"baseline ({result.baseline_source}):")
        for b in result.baseline_updates:
            if b.effect is not None or b.name in ("operating_speed", "operating_torque"):
                ps = ", ".join(f"{k}={_fmt(v)}" for k, v in b.parameters.items())
                print(f"  {b.label}: {ps}")
        print(
            "error (normalised RMS residual, 1 = noise level): "
            f"{result.error_before:.4g} -> {result.error_after:.4g}"
        )
        for e in result.effects:
            ps = ", ".join(f"{k}={_fmt(v)}" for k, v in e.parameters.items())
            print(f"  {e.label}: {ps} (confidence {e.confidence:.3f})")
    return 0
