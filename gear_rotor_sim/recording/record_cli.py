"""``gear-rotor-sim record``: run the streaming simulator without ROS and record an MCAP file.

Example::

    gear-rotor-sim record --speed-rpm 3000 --temperature-c 125 --duration-s 2 --out run.mcap
    gear-rotor-sim record --duration-s 4 --out ramp.mcap \\
        --schedule "[{at_s: 1, speed_rpm: 6000}, {at_s: 2.5, temperature_c: 150}]"
    gear-rotor-sim record --speed-rpm 3000 --temperature-c 25 --duration-s 2 \\
        --faults FAULTS.yaml --out run.mcap      # injected faults, ground truth on /gear_rotor/faults

:func:`record_run` is the shared core: the dataset generator records each run with it.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import yaml

from gear_rotor_sim.streams import StreamSpec, default_streams

STREAM_NAMES = ("dte", "bearing_forces", "displacements", "accelerations", "housing_accelerations")
#: Topic name (under /gear_rotor) of the housing accelerometers (gear_rotor_sim.sensors.housing).
HOUSING_STREAM = "housing_accelerations"
SAMPLE_RATE_RANGE_HZ = (1.0, 1.0e6)
DURATION_RANGE_S = (0.0, 86400.0)


class InputError(ValueError):
    """A user-supplied value is invalid; the message names the key and the allowed values."""


@dataclass(frozen=True)
class ScheduleStep:
    """A setpoint change at simulated time ``at_s`` (None keeps the current target)."""

    at_s: float
    speed_rpm: float | None = None
    temperature_c: float | None = None


@dataclass(frozen=True)
class RunParameters:
    """Everything that defines one recorded simulation run (user-facing units)."""

    speed_rpm: float
    temperature_c: float
    duration_s: float
    config: str = "paper_sun2021"
    bearing_type: str | None = None
    sample_rate_hz: float = 20000.0
    streams: tuple[str, ...] = ("dte", "bearing_forces")
    displacement_nodes: tuple[int, ...] = ()
    acceleration_nodes: tuple[int, ...] = ()
    schedule: tuple[ScheduleStep, ...] = ()
    block_s: float = 0.1
    #: Injected faults: flat entries of the fault description (gear_rotor_sim.faults.spec).
    faults: tuple[dict, ...] = ()

    def as_dict(self) -> dict[str, Any]:
        """Plain (JSON/YAML-friendly) form."""
        d = asdict(self)
        d["faults"] = [dict(f) for f in self.faults]
        if not self.faults:  # healthy runs keep the identity (run_id) they had before faults existed
            del d["faults"]
        d["streams"] = list(self.streams)
        d["displacement_nodes"] = list(self.displacement_nodes)
        d["acceleration_nodes"] = list(self.acceleration_nodes)
        d["schedule"] = [{k: v for k, v in asdict(s).items() if v is not None} for s in self.schedule]
        return d


@dataclass
class RunResult:
    """What :func:`record_run` wrote and how long it took."""

    file: str
    duration_s: float
    messages: int
    bytes: int
    samples_per_topic: dict[str, int] = field(default_factory=dict)
    simulate_wall_s: float = 0.0
    record_wall_s: float = 0.0

    @property
    def overhead(self) -> float:
        """Recording wall time relative to simulation wall time."""
        return self.record_wall_s / self.simulate_wall_s if self.simulate_wall_s > 0 else 0.0


# ---------------------------------------------------------------------------------------------
# validation
# ---------------------------------------------------------------------------------------------
def speed_range_rpm() -> tuple[float, float]:
    """Speeds the simulator accepts, rpm."""
    from gear_rotor_sim.simulator import MAX_SPEED_RPM

    return 0.0, float(MAX_SPEED_RPM)


def check_number(value: Any, key: str, lo: float, hi: float, lo_open: bool = False) -> float:
    """A finite number within ``[lo, hi]`` (``(lo, hi]`` if ``lo_open``); InputError otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{key}: {value!r} is not a number (allowed {_range_text(lo, hi, lo_open)})")
    v = float(value)
    if not math.isfinite(v) or v > hi or v < lo or (lo_open and v == lo):
        raise InputError(f"{key}: {value!r} is out of range (allowed {_range_text(lo, hi, lo_open)})")
    return v


def _range_text(lo: float, hi: float, lo_open: bool) -> str:
    return f"{lo:g} {'<' if lo_open else '<='} value <= {hi:g}"


def parse_schedule(raw: Any, duration_s: float, key: str = "schedule") -> tuple[ScheduleStep, ...]:
    """Validate a schedule: a list of ``{at_s, speed_rpm, temperature_c}`` mappings.

    ``at_s`` is required and non-decreasing within ``[0, duration_s]``; each step needs
    ``speed_rpm`` and/or ``temperature_c``. Unknown keys are errors.
    """
    if raw is None:
        return ()
    if not isinstance(raw, list):
        raise InputError(f"{key}: expected a list of {{at_s, speed_rpm, temperature_c}} steps")
    steps: list[ScheduleStep] = []
    last = 0.0
    for i, item in enumerate(raw):
        path = f"{key}[{i}]"
        if not isinstance(item, Mapping):
            raise InputError(f"{path}: expected a mapping with at_s and speed_rpm and/or temperature_c")
        unknown = set(item) - {"at_s", "speed_rpm", "temperature_c"}
        if unknown:
            raise InputError(
                f"{path}: unknown key(s) {sorted(map(str, unknown))}; allowed: at_s, speed_rpm, temperature_c"
            )
        if "at_s" not in item:
            raise InputError(f"{path}.at_s: missing (time of the step, s)")
        at = check_number(item["at_s"], f"{path}.at_s", 0.0, duration_s)
        if at < last:
            raise InputError(
                f"{path}.at_s: {at:g} is earlier than the previous step ({last:g}); keep steps in order"
            )
        last = at
        if "speed_rpm" not in item and "temperature_c" not in item:
            raise InputError(f"{path}: give speed_rpm and/or temperature_c")
        speed = item.get("speed_rpm")
        temp = item.get("temperature_c")
        steps.append(
            ScheduleStep(
                at,
                None if speed is None else check_number(speed, f"{path}.speed_rpm", *speed_range_rpm()),
                None if temp is None else check_number(temp, f"{path}.temperature_c", -273.15, 1.0e4, True),
            )
        )
    return tuple(steps)


def load_schedule(text: str, duration_s: float) -> tuple[ScheduleStep, ...]:
    """``--schedule``: a YAML file path, or an inline YAML/JSON list (safe loader)."""
    path = Path(text)
    source = text
    if not text.lstrip().startswith("[") and path.is_file():
        source = path.read_text(encoding="utf-8")
    try:
        raw = yaml.safe_load(source)
    except yaml.YAMLError as exc:
        raise InputError(f"schedule: not valid YAML ({exc})") from None
    if isinstance(raw, str):
        raise InputError(f"schedule: {text!r} is neither a file nor an inline list")
    return parse_schedule(raw, duration_s)


def load_rig(params: RunParameters):
    """The validated rig configuration of a run (bearing type applied)."""
    from gear_rotor_sim.config import load_config

    cfg = load_config(params.config)
    if params.bearing_type is not None:
        cfg = cfg.with_bearing_type(params.bearing_type)
    return cfg


def temperature_range_c(cfg) -> tuple[float, float]:
    """Temperatures every material of ``cfg`` accepts (the intersection of the strict ranges)."""
    lo, hi = -273.15, 1.0e4
    for mat in cfg.materials.values():
        if getattr(mat, "out_of_range", "error") == "error":
            a, b = mat.temperature_range_c
            lo, hi = max(lo, a), min(hi, b)
    return lo, hi


def select_streams(cfg, params: RunParameters) -> list[StreamSpec]:
    """The requested subset of the standard streams for ``cfg``."""
    unknown = [s for s in params.streams if s not in STREAM_NAMES]
    if unknown:
        raise InputError(f"streams: {unknown} not known; allowed: {list(STREAM_NAMES)}")
    for key, nodes in (
        ("displacement_nodes", params.displacement_nodes),
        ("acceleration_nodes", params.acceleration_nodes),
    ):
        for n in nodes:
            if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= cfg.n_nodes:
                raise InputError(f"{key}: node {n!r} does not exist (allowed 1..{cfg.n_nodes})")
    specs = default_streams(
        len(cfg.bearings),
        displacement_nodes=tuple(params.displacement_nodes),
        acceleration_nodes=tuple(params.acceleration_nodes),
        has_mesh=bool(cfg.meshes),
        n_meshes=len(cfg.meshes),
    )
    if HOUSING_STREAM in params.streams and cfg.bearings:
        from gear_rotor_sim.sensors.housing import housing_channels

        chans = housing_channels(range(1, len(cfg.bearings) + 1))
        specs.append(StreamSpec(HOUSING_STREAM, chans, "gearbox_housing"))
    chosen = [s for s in specs if s.name in params.streams]
    missing = [s for s in params.streams if s not in {c.name for c in chosen}]
    if missing:
        hint = " (displacements/accelerations need --displacement-nodes/--acceleration-nodes)"
        raise InputError(f"streams: {missing} cannot be produced for this rig{hint}")
    return chosen


def validate_run(params: RunParameters, cfg=None) -> tuple[Any, list[StreamSpec]]:
    """Check a run's values against the rig; returns ``(cfg, streams)``. InputError on bad values."""
    check_number(params.duration_s, "duration_s", *DURATION_RANGE_S, lo_open=True)
    check_number(params.speed_rpm, "speed_rpm", *speed_range_rpm())
    check_number(params.sample_rate_hz, "sample_rate_hz", *SAMPLE_RATE_RANGE_HZ)
    check_number(params.block_s, "block_s", 0.0, 10.0, lo_open=True)
    if cfg is None:
        try:
            cfg = load_rig(params)
        except ValueError as exc:  # ConfigError is a ValueError
            raise InputError(str(exc)) from None
    lo, hi = temperature_range_c(cfg)
    check_number(params.temperature_c, "temperature_c", lo, hi)
    fault_specs(params, cfg)
    for i, step in enumerate(params.schedule):
        if step.temperature_c is not None:
            check_number(step.temperature_c, f"schedule[{i}].temperature_c", lo, hi)
        if step.at_s > params.duration_s:
            raise InputError(f"schedule[{i}].at_s: {step.at_s:g} is after the end ({params.duration_s:g} s)")
    return cfg, select_streams(cfg, params)


def fault_specs(params: RunParameters, cfg) -> tuple:
    """The run's validated faults (``FaultSpec``); InputError naming the field otherwise."""
    from gear_rotor_sim.faults.spec import FaultError, parse_faults

    try:
        return parse_faults(list(params.faults), cfg)
    except FaultError as exc:
        raise InputError(str(exc)) from None


def load_fault_file(text: str) -> tuple[dict, ...]:
    """``--faults``: a YAML file (``faults: [...]``) or an inline YAML list; flat validated entries."""
    from gear_rotor_sim.faults.spec import FaultError, load_faults

    try:
        return tuple(f.as_dict() for f in load_faults(text))
    except FaultError as exc:
        raise InputError(str(exc)) from None


#: Topic of the fault ground truth (the node publishes it latched; recordings carry it).
FAULTS_TOPIC = "/gear_rotor/faults"
#: MCAP metadata record holding the requested faults as JSON.
FAULTS_METADATA = "gear_rotor_sim.faults"


def latched_qos() -> dict:
    """Offered QoS of the fault topic: reliable, transient local, keep last 1."""
    from gear_rotor_sim.recording.writer import qos_profile

    return {**qos_profile("reliable"), "depth": 1, "durability": "transient_local"}


def write_fault_state(rec, faults: Sequence, t: float, sequence: int) -> None:
    """Write the ground truth at simulated time ``t`` on :data:`FAULTS_TOPIC`."""
    from gear_rotor_sim.faults.truth import fault_state_fields
    from gear_rotor_sim.recording import schemas
    from gear_rotor_sim.recording.cdr import serialize_fault_state

    fields = fault_state_fields(faults, t)
    stamp = fields["stamp_sec"] * 1_000_000_000 + fields["stamp_nanosec"]
    rec.write_serialized(
        FAULTS_TOPIC, schemas.FAULT_STATE, serialize_fault_state(fields), stamp, sequence=sequence
    )


# ---------------------------------------------------------------------------------------------
# the run
# ---------------------------------------------------------------------------------------------
def record_run(
    params: RunParameters,
    out: str | Path,
    *,
    atomic: bool = False,
    qos: str = "sensor_data",
    flush_period_s: float = 1.0,
    compression: str = "none",
    custom_data: Mapping[str, str] | None = None,
    progress: Callable[[float], None] | None = None,
) -> RunResult:
    """Simulate ``params`` with the streaming simulator and record every stream to ``out``.

    Parameters
    ----------
    params : RunParameters
    out : path
        MCAP file to write.
    atomic : bool
        Write ``out.part`` and rename on success (``out`` never names a partial file).
    progress : callable, optional
        Called with the simulated time (s) after each block has been written.

    Returns
    -------
    RunResult

    Raises
    ------
    InputError
        Invalid parameters (before anything is written).
    RecordingError
        The file could not be written (unwritable folder, full disk).
    """
    from gear_rotor_sim.faults.timed import timed_effects
    from gear_rotor_sim.faults.truth import truth, truth_json
    from gear_rotor_sim.recording import schemas
    from gear_rotor_sim.recording.writer import McapRecorder
    from gear_rotor_sim.sensors.housing import append_housing
    from gear_rotor_sim.simulator import Simulator
    from gear_rotor_sim.system import drivetrain_metadata

    cfg, specs = validate_run(params)
    faults = fault_specs(params, cfg)
    housing = _housing(specs, params)
    channels = list(
        dict.fromkeys(
            [c for s in specs if s.name != HOUSING_STREAM for c in s.channels]
            + (list(housing.sources) if housing else [])
        )
    )
    sim = Simulator(
        cfg,
        speed_rpm=params.speed_rpm,
        temperature_c=params.temperature_c,
        output_rate_hz=params.sample_rate_hz,
        channels=channels,
        **({"effects": timed_effects(faults)} if faults else {}),
    )
    meta = {"generator": "gear-rotor-sim record", **{k: _text(v) for k, v in params.as_dict().items()}}
    meta["faults"] = truth_json(faults)
    meta.update(drivetrain_metadata(cfg))  # per-shaft speed ratios, mesh orders
    meta.update(custom_data or {})
    steps = list(params.schedule)
    samples = {s.topic: 0 for s in specs}
    seq = 0
    t_sim = t_rec = 0.0
    end = params.duration_s
    half_sample = 0.5 / params.sample_rate_hz
    with McapRecorder(
        out,
        specs,
        qos=qos,
        flush_period_s=flush_period_s,
        compression=compression,
        atomic=atomic,
        custom_data=meta,
    ) as rec:
        rec.add_topic(FAULTS_TOPIC, schemas.FAULT_STATE, qos=latched_qos())
        rec.add_metadata(
            FAULTS_METADATA, {"faults": truth_json(faults), "format": "flat fault entries, JSON"}
        )
        write_fault_state(rec, faults, 0.0, 0)
        n_truth = 1
        last_truth = truth(faults, 0.0)
        while sim.time_s < end - half_sample:
            while steps and steps[0].at_s <= sim.time_s + half_sample:
                _apply(sim, steps.pop(0))
            stop = min(sim.time_s + params.block_s, end)
            if steps:
                stop = min(stop, steps[0].at_s)
            t0 = time.perf_counter()
            block = sim.advance(stop - sim.time_s)
            t1 = time.perf_counter()
            t_sim += t1 - t0
            if block.n_samples:
                if housing is not None:
                    block = append_housing(block, housing)
                for spec in specs:
                    rec.write_block(block, spec, seq)
                    samples[spec.topic] += block.n_samples
                seq += 1
            now = truth(faults, sim.time_s)
            if now != last_truth:  # onset passed or severity grew: the state at the block end
                write_fault_state(rec, faults, sim.time_s, n_truth)
                n_truth += 1
                last_truth = now
            t_rec += time.perf_counter() - t1
            if progress is not None:
                progress(sim.time_s)
        t1 = time.perf_counter()
    t_rec += time.perf_counter() - t1
    return RunResult(
        file=str(out),
        duration_s=float(sim.time_s),
        messages=rec.message_count,
        bytes=Path(out).stat().st_size,
        samples_per_topic=samples,
        simulate_wall_s=t_sim,
        record_wall_s=t_rec,
    )


def _housing(specs: Sequence[StreamSpec], params: RunParameters):
    """Streaming housing accelerometers of the run (default housing model and noise), or None.

    The noise is seeded from the run's parameters: the same run gives the same file.
    """
    spec = next((s for s in specs if s.name == HOUSING_STREAM), None)
    if spec is None:
        return None
    import json
    import zlib

    from gear_rotor_sim.sensors.housing import HousingAccelerometers
    from gear_rotor_sim.sensors.noise import SensorNoise

    seed = zlib.crc32(json.dumps(params.as_dict(), sort_keys=True).encode("utf-8"))
    return HousingAccelerometers(spec.channels, params.sample_rate_hz, noise=SensorNoise(seed=seed))


def _apply(sim, step: ScheduleStep) -> None:
    targets = {}
    if step.speed_rpm is not None:
        targets["speed_rpm"] = step.speed_rpm
    if step.temperature_c is not None:
        targets["temperature_c"] = step.temperature_c
    sim.set_targets(**targets)


def _text(value: Any) -> str:
    if isinstance(value, str):
        return value
    return yaml.safe_dump(value, default_flow_style=True, width=1 << 16).strip()


# ---------------------------------------------------------------------------------------------
# command line
# ---------------------------------------------------------------------------------------------
def _int_list(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of node numbers") from None


def _name_list(text: str) -> tuple[str, ...]:
    return tuple(x.strip() for x in text.split(",") if x.strip())


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the ``record`` options."""
    parser.add_argument("--out", required=True, help="MCAP file to write")
    parser.add_argument("--duration-s", type=float, required=True, help="simulated duration, s")
    parser.add_argument("--speed-rpm", type=float, default=3000.0, help="input-shaft speed (default 3000)")
    parser.add_argument("--temperature-c", type=float, default=25.0, help="temperature, C (default 25)")
    parser.add_argument(
        "--schedule",
        help="setpoint steps: a YAML file or an inline list such as "
        "'[{at_s: 1, speed_rpm: 5000}, {at_s: 2, temperature_c: 125}]'",
    )
    parser.add_argument(
        "--faults",
        help="faults to inject: a YAML file holding 'faults: [...]' or an inline list such as "
        "'[{type: tooth_damage, wheel: gear, tooth: 5, depth: 0.3}]' (docs/faults.md)",
    )
    parser.add_argument("--config", default="paper_sun2021", help="rig config name or YAML path")
    parser.add_argument("--bearing-type", help="bearing type for all bearings (e.g. A#, B#, C#)")
    parser.add_argument(
        "--streams",
        type=_name_list,
        default=("dte", "bearing_forces"),
        help=f"comma-separated streams out of {','.join(STREAM_NAMES)} (default dte,bearing_forces)",
    )
    parser.add_argument("--displacement-nodes", type=_int_list, default=(), help="e.g. 5,6")
    parser.add_argument("--acceleration-nodes", type=_int_list, default=(), help="e.g. 5")
    parser.add_argument("--sample-rate-hz", type=float, default=20000.0, help="output rate (default 20000)")
    parser.add_argument("--block-s", type=float, default=0.1, help="simulated time per message (default 0.1)")
    parser.add_argument("--qos", choices=("sensor_data", "reliable"), default="sensor_data")
    parser.add_argument("--flush-period-s", type=float, default=1.0, help="chunk flush period (default 1)")
    parser.add_argument("--compression", choices=("none", "zstd", "lz4"), default="none")
    parser.add_argument("--progress", action="store_true", help="print the simulated time after each block")


def params_from_args(args: argparse.Namespace) -> RunParameters:
    """Build and validate run parameters from parsed arguments."""
    schedule = load_schedule(args.schedule, args.duration_s) if args.schedule else ()
    return RunParameters(
        speed_rpm=args.speed_rpm,
        temperature_c=args.temperature_c,
        duration_s=args.duration_s,
        config=args.config,
        bearing_type=args.bearing_type,
        sample_rate_hz=args.sample_rate_hz,
        streams=tuple(args.streams),
        displacement_nodes=tuple(args.displacement_nodes),
        acceleration_nodes=tuple(args.acceleration_nodes),
        schedule=schedule,
        block_s=args.block_s,
        faults=load_fault_file(args.faults) if args.faults else (),
    )


def run(args: argparse.Namespace) -> int:
    """Execute ``gear-rotor-sim record``; returns the exit status."""
    from gear_rotor_sim.recording.writer import RecordingError

    try:
        params = params_from_args(args)
        validate_run(params)
    except InputError as exc:
        print(f"gear-rotor-sim record: error: {exc}", file=sys.stderr)
        return 2

    def show(t: float) -> None:
        print(f"t={t:.6f}", flush=True)

    try:
        result = record_run(
            params,
            args.out,
            qos=args.qos,
            flush_period_s=args.flush_period_s,
            compression=args.compression,
            progress=show if args.progress else None,
        )
    except InputError as exc:
        print(f"gear-rotor-sim record: error: {exc}", file=sys.stderr)
        return 2
    except (RecordingError, ValueError) as exc:
        print(f"gear-rotor-sim record: error: {exc}", file=sys.stderr)
        return 1
    total = sum(result.samples_per_topic.values())
    print(
        f"wrote {result.file}: {result.messages} messages, {result.bytes / 1e6:.2f} MB, "
        f"{result.duration_s:g} s simulated, {total} samples over {len(result.samples_per_topic)} topics; "
        f"simulation {result.simulate_wall_s:.2f} s wall, recording {result.record_wall_s:.3f} s wall "
        f"({100 * result.overhead:.1f} % overhead)"
    )
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Stand-alone entry point (same as ``gear-rotor-sim record``)."""
    parser = argparse.ArgumentParser(prog="gear-rotor-sim record")
    add_arguments(parser)
    return run(parser.parse_args(argv))
