"""Dataset generation: many recorded simulation runs from one sweep description.

A sweep file (YAML, safe loader, strictly validated) describes the runs::

    name: bearing_study          # optional
    base:                        # defaults for every run (any run key below)
      duration_s: 2.0
      sample_rate_hz: 20000
      streams: [dte, bearing_forces]
    grid:                        # cartesian product; each key a list of values
      speed_rpm: [1000, 3000, 6000]
      temperature_c: [25, 125]
      bearing_type: ["A#", "B#"]
      faults:                    # a grid axis of fault lists (docs/faults.md); [] is the healthy run
        - []
        - [{type: tooth_damage, wheel: gear, tooth: 5, depth: 0.3}]
        - [{type: outer_race_defect, bearing: 2, force_n: 500}]
    runs:                        # explicit runs (base values overridden), added after the grid
      - {speed_rpm: 3000, temperature_c: 25, schedule: [{at_s: 1.0, speed_rpm: 6000}]}
      - speed_rpm: 3000          # a fault appearing at 0.5 s and growing (run to failure)
        temperature_c: 25
        faults: [{type: tooth_damage, tooth: 3, depth: 0.1, onset_s: 0.5,
                  growth: {law: exponential, final: 0.8, duration_s: 1.0}}]
    recording: {qos: sensor_data, flush_period_s: 1.0, compression: none}

Run keys: ``speed_rpm``, ``temperature_c``, ``duration_s``, ``config``, ``bearing_type``,
``sample_rate_hz``, ``streams``, ``displacement_nodes``, ``acceleration_nodes``, ``schedule``,
``block_s``, ``faults``. Each run's MCAP carries its ground truth (topic ``/gear_rotor/faults``
and the metadata record ``gear_rotor_sim.faults``); the manifest lists each run's ``faults``.

Output folder: one MCAP file per run (``run_<index>_<id>.mcap``, ``id`` = first 12 hex digits of
the SHA-256 of the run's parameters) and ``manifest.json``. Each run is written to
``<file>.part`` and renamed when complete; the manifest is rewritten atomically (temporary file,
fsync, ``os.replace``) after every finished run, so an interruption at any moment leaves a valid
manifest that lists only complete, checksummed files. Generating again into the same folder
skips every run whose file is present with the recorded SHA-256 and redoes the others.

Runs execute in parallel in local processes (``concurrent.futures.ProcessPoolExecutor``) or on a
Dask cluster (``dask.distributed.Client(address)``); Dask workers must see the output folder
under the same path (shared file system).
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import itertools
import json
import os
import time
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any

import yaml

from gear_rotor_sim.recording.record_cli import (
    STREAM_NAMES,
    InputError,
    RunParameters,
    ScheduleStep,
    check_number,
    load_rig,
    parse_schedule,
    record_run,
    validate_run,
)

MANIFEST = "manifest.json"
MANIFEST_FORMAT = "gear_rotor_sim.dataset/1"
RUN_KEYS = (
    "speed_rpm",
    "temperature_c",
    "duration_s",
    "config",
    "bearing_type",
    "sample_rate_hz",
    "streams",
    "displacement_nodes",
    "acceleration_nodes",
    "schedule",
    "block_s",
    "faults",
)
TOP_KEYS = ("name", "base", "grid", "runs", "recording")
RECORDING_KEYS = ("qos", "flush_period_s", "compression")
DEFAULT_RECORDING = {"qos": "sensor_data", "flush_period_s": 1.0, "compression": "none"}
MAX_RUNS = 100_000


class DatasetError(RuntimeError):
    """Dataset generation could not proceed (bad output folder, failed run, foreign manifest)."""


@dataclasses.dataclass(frozen=True)
class PlannedRun:
    """One run of a sweep: its position, identity, file name and parameters."""

    index: int
    run_id: str
    file: str
    params: RunParameters


@dataclasses.dataclass(frozen=True)
class Sweep:
    """A validated sweep: the runs and the recording settings."""

    name: str
    runs: tuple[PlannedRun, ...]
    recording: dict
    definition: dict
    sha256: str


# ---------------------------------------------------------------------------------------------
# sweep parsing
# ---------------------------------------------------------------------------------------------
def _unknown(d: Mapping, allowed: Iterable[str], path: str) -> None:
    extra = sorted(str(k) for k in d if k not in allowed)
    if extra:
        where = f"{path}: " if path else ""
        raise InputError(f"{where}unknown key(s) {extra}; allowed: {', '.join(allowed)}")


def _string_list(value: Any, key: str) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise InputError(f"{key}: expected a list of names (allowed: {list(STREAM_NAMES)})")
    return tuple(value)


def _node_list(value: Any, key: str) -> tuple[int, ...]:
    if not isinstance(value, list) or not all(isinstance(v, int) and not isinstance(v, bool) for v in value):
        raise InputError(f"{key}: expected a list of 1-based node numbers")
    return tuple(value)


def _run_parameters(values: Mapping, path: str) -> RunParameters:
    """Build ``RunParameters`` from a merged run mapping (types checked, ranges checked later)."""
    _unknown(values, RUN_KEYS, path)
    for required in ("speed_rpm", "temperature_c", "duration_s"):
        if required not in values:
            raise InputError(f"{path}.{required}: missing (set it in base, grid or the run)")
    duration = check_number(values["duration_s"], f"{path}.duration_s", 0.0, 86400.0, lo_open=True)
    kwargs: dict[str, Any] = {
        "speed_rpm": values["speed_rpm"],
        "temperature_c": values["temperature_c"],
        "duration_s": duration,
    }
    for key in ("sample_rate_hz", "block_s"):
        if key in values:
            kwargs[key] = values[key]
    for key in ("config", "bearing_type"):
        if key in values and values[key] is not None:
            if not isinstance(values[key], str):
                raise InputError(f"{path}.{key}: {values[key]!r} must be a string")
            kwargs[key] = values[key]
    if "streams" in values:
        kwargs["streams"] = _string_list(values["streams"], f"{path}.streams")
    for key in ("displacement_nodes", "acceleration_nodes"):
        if key in values:
            kwargs[key] = _node_list(values[key], f"{path}.{key}")
    if "schedule" in values:
        kwargs["schedule"] = parse_schedule(values["schedule"], duration, f"{path}.schedule")
    if values.get("faults") is not None:
        from gear_rotor_sim.faults.spec import FaultError, parse_faults

        try:
            faults = parse_faults(values["faults"], key=f"{path}.faults")
        except FaultError as exc:
            raise InputError(str(exc)) from None
        kwargs["faults"] = tuple(f.as_dict() for f in faults)
    return RunParameters(**kwargs)


def run_id(params: RunParameters, recording: Mapping) -> str:
    """Stable identity of a run: SHA-256 of its parameters and recording settings (12 hex digits)."""
    text = json.dumps({"parameters": params.as_dict(), "recording": dict(recording)}, sort_keys=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:12]


def parse_sweep(raw: Any) -> Sweep:
    """Validate a sweep mapping; InputError naming the key and the allowed values otherwise."""
    if not isinstance(raw, Mapping):
        raise InputError("sweep: the file must hold a mapping with base, grid and/or runs")
    _unknown(raw, TOP_KEYS, "")
    name = raw.get("name", "dataset")
    if not isinstance(name, str):
        raise InputError(f"name: {name!r} must be a string")
    base = raw.get("base") or {}
    if not isinstance(base, Mapping):
        raise InputError("base: expected a mapping of run keys")
    _unknown(base, RUN_KEYS, "base")
    grid = raw.get("grid") or {}
    if not isinstance(grid, Mapping):
        raise InputError("grid: expected a mapping from run keys to lists of values")
    _unknown(grid, RUN_KEYS, "grid")
    for key, values in grid.items():
        if not isinstance(values, list) or not values:
            raise InputError(f"grid.{key}: expected a non-empty list of values")
    explicit = raw.get("runs") or []
    if not isinstance(explicit, list):
        raise InputError("runs: expected a list of run mappings")
    if not grid and not explicit:
        raise InputError("sweep: give a grid and/or a list of runs")
    recording = dict(DEFAULT_RECORDING)
    rec_raw = raw.get("recording") or {}
    if not isinstance(rec_raw, Mapping):
        raise InputError("recording: expected a mapping")
    _unknown(rec_raw, RECORDING_KEYS, "recording")
    recording.update(rec_raw)
    if recording["qos"] not in ("sensor_data", "reliable"):
        raise InputError(f"recording.qos: {recording['qos']!r} is not one of ['reliable', 'sensor_data']")
    recording["flush_period_s"] = check_number(
        recording["flush_period_s"], "recording.flush_period_s", 0.0, 60.0, True
    )
    if recording["compression"] not in ("none", "zstd", "lz4"):
        raise InputError(f"recording.compression: {recording['compression']!r} is not one of none, zstd, lz4")

    n_grid = 1
    for values in grid.values():
        n_grid *= len(values)
    total = (n_grid if grid else 0) + len(explicit)
    if total > MAX_RUNS:
        raise InputError(f"sweep: {total} runs requested (allowed at most {MAX_RUNS})")

    rigs: dict[tuple, Any] = {}

    def check(params: RunParameters, path: str) -> None:
        key = (params.config, params.bearing_type)
        try:
            if key not in rigs:
                rigs[key] = load_rig(params)
            validate_run(params, rigs[key])
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None
        except ValueError as exc:  # ConfigError: unknown config or bearing type
            raise InputError(f"{path}: {exc}") from None

    merged_runs: list[tuple[str, RunParameters]] = []
    if grid:
        keys = list(grid)
        for combo in itertools.product(*(grid[k] for k in keys)):
            values = dict(zip(keys, combo, strict=True))
            path = "grid(" + ", ".join(f"{k}={v}" for k, v in values.items()) + ")"
            params = _run_parameters({**base, **values}, path)
            check(params, path)
            merged_runs.append((path, params))
    for i, item in enumerate(explicit):
        path = f"runs[{i}]"
        if not isinstance(item, Mapping):
            raise InputError(f"{path}: expected a mapping of run keys")
        _unknown(item, RUN_KEYS, path)
        params = _run_parameters({**base, **item}, path)
        check(params, path)
        merged_runs.append((path, params))

    planned: list[PlannedRun] = []
    seen: dict[str, str] = {}
    for index, (path, params) in enumerate(merged_runs):
        rid = run_id(params, recording)
        if rid in seen:
            raise InputError(f"{path}: same parameters as {seen[rid]} (each run must differ)")
        seen[rid] = path
        planned.append(PlannedRun(index, rid, f"run_{index:04d}_{rid}.mcap", params))
    definition = {
        "name": name,
        "recording": recording,
        "runs": [{"id": p.run_id, "parameters": p.params.as_dict()} for p in planned],
    }
    digest = hashlib.sha256(json.dumps(definition, sort_keys=True).encode("utf-8")).hexdigest()
    return Sweep(name, tuple(planned), recording, definition, digest)


def load_sweep(path: str | os.PathLike) -> Sweep:
    """Read and validate a sweep YAML file (safe loader)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"sweep file {p}: {exc.strerror or exc}") from None
    try:
        raw = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise InputError(f"sweep file {p}: not valid YAML ({exc})") from None
    return parse_sweep(raw)


# ---------------------------------------------------------------------------------------------
# files
# ---------------------------------------------------------------------------------------------
def sha256_file(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def write_json_atomic(path: Path, data: Any) -> None:
    """Write JSON to ``path`` via a temporary file, fsync and ``os.replace`` (never half-written)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(data, f, indent=2, sort_keys=False)
            f.write("\n")
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    with contextlib.suppress(OSError):
        fd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())


# ---------------------------------------------------------------------------------------------
# one run (executed in a worker)
# ---------------------------------------------------------------------------------------------
def _params_from_dict(d: Mapping) -> RunParameters:
    d = dict(d)
    d["streams"] = tuple(d["streams"])
    d["displacement_nodes"] = tuple(d["displacement_nodes"])
    d["acceleration_nodes"] = tuple(d["acceleration_nodes"])
    d["schedule"] = tuple(ScheduleStep(**s) for s in d["schedule"])
    d["faults"] = tuple(dict(f) for f in d.get("faults", ()))
    return RunParameters(**d)


def execute_run(params: dict, recording: dict, out_dir: str, file: str, run_id_: str) -> dict:
    """Record one run into ``out_dir/file`` (atomically) and return its manifest entry.

    Top-level and picklable: executed by process-pool and Dask workers.
    """
    p = _params_from_dict(params)
    out = Path(out_dir) / file
    t0 = time.perf_counter()
    result = record_run(
        p,
        out,
        atomic=True,
        qos=recording["qos"],
        flush_period_s=recording["flush_period_s"],
        compression=recording["compression"],
        custom_data={"dataset_run_id": run_id_},
    )
    return {
        "id": run_id_,
        "file": file,
        "parameters": params,
        "faults": list(params.get("faults", [])),
        "duration_s": result.duration_s,
        "sha256": sha256_file(out),
        "bytes": result.bytes,
        "messages": result.messages,
        "sample_counts": result.samples_per_topic,
        "wall_time_s": round(time.perf_counter() - t0, 3),
        "finished": _now(),
    }


# ---------------------------------------------------------------------------------------------
# generation
# ---------------------------------------------------------------------------------------------
@dataclasses.dataclass
class GenerationReport:
    """Outcome of :func:`generate`."""

    total: int
    done: list[str]
    skipped: list[str]
    redone: list[str]
    manifest: Path


class _Manifest:
    """The output folder's manifest, kept in memory and rewritten atomically on every change."""

    def __init__(self, out_dir: Path, sweep: Sweep) -> None:
        self.path = out_dir / MANIFEST
        self.sweep = sweep
        self.entries: dict[str, dict] = {}
        self.created = _now()
        if self.path.exists():
            try:
                old = json.loads(self.path.read_text(encoding="utf-8"))
            except (OSError, ValueError) as exc:
                raise DatasetError(f"{self.path}: cannot read the existing manifest ({exc})") from None
            if not isinstance(old, dict) or old.get("format") != MANIFEST_FORMAT:
                raise DatasetError(
                    f"{self.path}: not a gear_rotor_sim dataset manifest; choose another --out"
                )
            if old.get("sweep_sha256") != sweep.sha256:
                raise DatasetError(
                    f"{out_dir} holds a dataset of a different sweep (manifest sweep_sha256 "
                    f"{str(old.get('sweep_sha256'))[:12]}..., this sweep {sweep.sha256[:12]}...); "
                    "use a new --out folder to generate this sweep"
                )
            self.created = old.get("created", self.created)
            self.entries = {e["id"]: e for e in old.get("runs", []) if isinstance(e, dict) and "id" in e}

    def save(self) -> None:
        order = {r.run_id: r.index for r in self.sweep.runs}
        runs = sorted(self.entries.values(), key=lambda e: order.get(e["id"], 1 << 30))
        write_json_atomic(
            self.path,
            {
                "format": MANIFEST_FORMAT,
                "name": self.sweep.name,
                "sweep_sha256": self.sweep.sha256,
                "sweep": self.sweep.definition,
                "created": self.created,
                "updated": _now(),
                "runs_total": len(self.sweep.runs),
                "runs_finished": len(runs),
                "runs": runs,
            },
        )


def _prepare_out_dir(out_dir: Path) -> None:
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DatasetError(f"cannot create output folder {out_dir}: {exc.strerror or exc}") from None
    if not os.access(out_dir, os.W_OK | os.X_OK):
        raise DatasetError(f"output folder {out_dir} is not writable")
    probe = out_dir / f".write-probe-{os.getpid()}"
    try:
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise DatasetError(f"output folder {out_dir} is not writable: {exc.strerror or exc}") from None


def generate(
    sweep: Sweep,
    out_dir: str | os.PathLike,
    workers: int | None = None,
    scheduler: str | None = None,
    log: Callable[[str], None] | None = None,
    scheduler_timeout_s: float = 10.0,
) -> GenerationReport:
    """Generate (or resume) the dataset of ``sweep`` in ``out_dir``.

    Parameters
    ----------
    sweep : Sweep
        From :func:`load_sweep` / :func:`parse_sweep`.
    out_dir : path
        Output folder (created if needed).
    workers : int, optional
        Local worker processes (default: CPU count); 1 runs in this process.
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:8786``); runs are submitted to its workers.
    log : callable, optional
        Receives one line per event.
    scheduler_timeout_s : float
        How long to try to connect to the Dask scheduler.

    Raises
    ------
    DatasetError
        The folder is unusable, holds a different sweep, or a run failed (the runs finished before
        the failure stay in the manifest).
    """
    say = log or (lambda _msg: None)
    out = Path(out_dir)
    _prepare_out_dir(out)
    manifest = _Manifest(out, sweep)
    skipped: list[str] = []
    redone: list[str] = []
    todo: list[PlannedRun] = []
    for run in sweep.runs:
        entry = manifest.entries.get(run.run_id)
        path = out / run.file
        if entry is not None:
            if path.is_file() and sha256_file(path) == entry.get("sha256"):
                skipped.append(run.run_id)
                continue
            why = "missing" if not path.is_file() else "checksum mismatch"
            say(f"run {run.index} ({run.file}): {why}; regenerating")
            del manifest.entries[run.run_id]
            redone.append(run.run_id)
        todo.append(run)
    for stale in out.glob("*.mcap.part"):
        with contextlib.suppress(OSError):
            stale.unlink()
    manifest.save()
    say(f"{len(sweep.runs)} runs: {len(skipped)} already complete, {len(todo)} to generate")
    done: list[str] = []

    def finished(entry: dict) -> None:
        manifest.entries[entry["id"]] = entry
        manifest.save()
        done.append(entry["id"])
        say(f"finished {entry['file']} ({entry['duration_s']:g} s, {entry['bytes'] / 1e6:.2f} MB)")

    args = [(r.params.as_dict(), sweep.recording, str(out), r.file, r.run_id) for r in todo]
    n_workers = max(1, int(workers or os.cpu_count() or 1))
    if scheduler:
        _run_dask(args, scheduler, finished, scheduler_timeout_s)
    elif n_workers == 1 or len(args) <= 1:
        for a in args:
            try:
                finished(execute_run(*a))
            except Exception as exc:
                raise DatasetError(f"run {a[3]} failed: {exc}") from exc
    else:
        _run_pool(args, n_workers, finished)
    return GenerationReport(len(sweep.runs), done, skipped, redone, manifest.path)


def _run_pool(args: list[tuple], n_workers: int, finished: Callable[[dict], None]) -> None:
    pending: dict[Future, tuple] = {}
    queue = list(args)
    failure: tuple[str, BaseException] | None = None
    with ProcessPoolExecutor(max_workers=n_workers) as pool:
        try:
            while queue or pending:
                while queue and failure is None and len(pending) < n_workers:
                    a = queue.pop(0)
                    pending[pool.submit(execute_run, *a)] = a
                if not pending:
                    break
                ready, _ = wait(list(pending), return_when=FIRST_COMPLETED)
                for fut in ready:
                    a = pending.pop(fut)
                    exc = fut.exception()
                    if exc is None:
                        finished(fut.result())
                    elif failure is None:
                        failure = (a[3], exc)
                if failure is not None:
                    queue.clear()
        except BaseException:
            for fut in pending:
                fut.cancel()
            raise
    if failure is not None:
        raise DatasetError(f"run {failure[0]} failed: {failure[1]}") from failure[1]


def _run_dask(args: list[tuple], scheduler: str, finished: Callable[[dict], None], timeout_s: float) -> None:
    try:
        from dask.distributed import Client, as_completed
    except ImportError as exc:  # pragma: no cover - dask is a declared dependency of this command
        raise DatasetError(f"--scheduler needs dask.distributed: {exc}") from None
    try:
        client = Client(scheduler, timeout=f"{timeout_s}s")
    except OSError as exc:
        raise DatasetError(f"cannot connect to the Dask scheduler at {scheduler}: {exc}") from None
    failure: tuple[str, BaseException] | None = None
    try:
        futures = {client.submit(execute_run, *a, pure=False, key=f"gear-rotor-run-{a[4]}"): a for a in args}
        for fut in as_completed(list(futures)):
            a = futures[fut]
            if fut.status == "finished":
                finished(fut.result())
            elif fut.status == "error" and failure is None:
                failure = (a[3], fut.exception())
                for other in futures:
                    if not other.done():
                        other.cancel()
    finally:
        client.close()
    if failure is not None:
        raise DatasetError(f"run {failure[0]} failed: {failure[1]}") from failure[1]
