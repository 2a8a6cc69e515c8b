"""Loaders of the recorded formats: MCAP recordings of the project's own streams and MATLAB
``.mat`` files through a mapping (the CWRU bearing data)
(moved from ``measurement.py`` in session 16, unchanged).
"""

from __future__ import annotations

import fnmatch
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from gear_rotor_sim.calibration.measurement_checks import _finish, _si
from gear_rotor_sim.calibration.measurement_contract import (
    ChannelSpec,
    Measurement,
    MeasurementError,
    OperatingPoint,
    _check_top,
    _err,
    _positive,
    _read_yaml,
    parse_channel,
    parse_operating_point,
    sidecar_path,
    spec_from_model_channel,
)


def load_mcap(
    path: str | Path,
    sidecar: str | Path | Mapping[str, Any] | None = None,
    nan_policy: str = "error",
    topics: list[str] | None = None,
) -> Measurement:
    """Load a recording of the project's own streams (``/gear_rotor/<stream>``, VibrationChunk).

    Channels of all vibration topics sharing the first topic's sample rate are joined over their
    common sample-index range. A lost chunk (jump in ``first_sample_index``) is reported as a gap.
    The operating point is the median of the messages' ``speed_rpm`` / ``temperature_c``; the gearbox
    comes from an optional sidecar (``gearbox:``; its ``operating_point`` overrides the messages),
    otherwise ``paper_sun2021`` is assumed and reported in :attr:`Measurement.issues`.
    """
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    path = Path(path)
    src = str(path)
    if not path.exists():
        raise _err(src, "file not found")
    chunks: dict[str, list[tuple[int, float, float, float, list[str], list[str], np.ndarray]]] = {}
    try:
        with open(path, "rb") as fh:
            reader = make_reader(fh, decoder_factories=[DecoderFactory()])
            for schema, channel, _message, msg in reader.iter_decoded_messages():
                if schema is None or not schema.name.endswith("VibrationChunk"):
                    continue
                if not channel.topic.startswith("/gear_rotor/"):
                    continue
                if topics is not None and channel.topic not in topics:
                    continue
                names = list(msg.channel_names)
                arr = np.asarray(msg.data, dtype=float).reshape(-1, len(names)) if names else np.zeros((0, 0))
                chunks.setdefault(channel.topic, []).append(
                    (
                        int(msg.first_sample_index),
                        float(msg.sample_rate_hz),
                        float(msg.speed_rpm),
                        float(msg.temperature_c),
                        names,
                        list(msg.units),
                        arr,
                    )
                )
            recorded = _recorded_rig(reader)
            steps = _recorded_steps(reader)
    except Exception as exc:  # mcap raises several unrelated types for damaged files
        if isinstance(exc, MeasurementError):
            raise
        raise _err(src, f"cannot read MCAP: {exc}") from None
    if not chunks:
        raise _err(src, "no gear_rotor_msgs/msg/VibrationChunk messages on /gear_rotor/* topics")
    issues: list[str] = []
    fs = None
    streams = []
    for topic in sorted(chunks):
        cs = sorted(chunks[topic], key=lambda c: c[0])
        if fs is None:
            fs = cs[0][1]
        if abs(cs[0][1] - fs) > 1e-9 * fs:
            issues.append(f"topic {topic}: sample rate {cs[0][1]} Hz differs from {fs} Hz; not used")
            continue
        names, units = cs[0][4], cs[0][5]
        start = cs[0][0]
        stop = cs[-1][0] + cs[-1][6].shape[0]
        arr = np.full((stop - start, len(names)), np.nan)
        covered = np.zeros(stop - start, dtype=bool)
        for c in cs:
            if c[4] != names:
                raise _err(src, f"topic {topic}: channel names change between chunks")
            i = c[0] - start
            arr[i : i + c[6].shape[0]] = c[6]
            covered[i : i + c[6].shape[0]] = True
        speeds = np.array([c[2] for c in cs])
        temps = np.array([c[3] for c in cs])
        streams.append((topic, start, names, units, arr, covered, speeds, temps))
    assert fs is not None
    lo = max(s[1] for s in streams)
    hi = min(s[1] + s[4].shape[0] for s in streams)
    if hi - lo < 2:
        raise _err(src, "the vibration topics share fewer than 2 samples")
    specs: list[ChannelSpec] = []
    cols: list[np.ndarray] = []
    covered = np.ones(hi - lo, dtype=bool)
    for topic, start, names, units, arr, cov, _, _ in streams:
        for k, (name, unit) in enumerate(zip(names, units, strict=True)):
            if any(s.column == name for s in specs):
                continue
            try:
                spec = spec_from_model_channel(name, unit)
                entry: dict[str, Any] = {"column": name, "quantity": spec.quantity, "unit": unit}
                if spec.bearing is not None or spec.node is not None:
                    entry.update(bearing=spec.bearing, node=spec.node, direction=spec.direction)
                if spec.mesh is not None:
                    entry["mesh"] = spec.mesh
                parse_channel(entry, src, f"{topic}.{name}")
            except MeasurementError as exc:
                issues.append(f"topic {topic}: channel {name!r} skipped ({exc})")
                continue
            specs.append(spec)
            cols.append(arr[lo - start : hi - start, k])
        covered &= cov[lo - start : hi - start]
    if not specs:
        raise _err(src, "no usable channels")
    speeds = np.concatenate([s[6] for s in streams])
    temps = np.concatenate([s[7] for s in streams])
    if np.ptp(speeds) > 1e-3 * max(np.median(speeds), 1.0):
        issues.append(
            f"speed varies in the recording ({speeds.min():.1f}..{speeds.max():.1f} rpm); median used"
        )
    op = OperatingPoint(float(np.median(speeds)), float(np.median(temps)), None)
    gearbox, bearing_type = recorded if recorded is not None else ("paper_sun2021", None)
    meta: dict[str, Any] | None = None
    if isinstance(sidecar, Mapping):
        meta = dict(sidecar)
    else:
        sc = Path(sidecar) if sidecar is not None else sidecar_path(path)
        if sc.exists():
            meta = _read_yaml(sc)
        elif sidecar is not None:
            raise _err(src, f"sidecar {sc} not found")
    if meta is not None:
        _check_top(meta, src, ())
        if "gearbox" in meta:
            gearbox, bearing_type = str(meta["gearbox"]), None
        if "operating_point" in meta:
            op = parse_operating_point(meta["operating_point"], src)
    elif recorded is not None:
        bt = f", bearing type {bearing_type} on all bearings" if bearing_type else ""
        issues.append(f"no sidecar: gearbox {gearbox!r}{bt} from the recording's metadata")
    else:
        issues.append("no sidecar: gearbox 'paper_sun2021' assumed")
    if op.speed_rpm <= 0:
        raise _err(src, "speed_rpm in the messages is not positive; give operating_point in a sidecar")
    data = np.column_stack(cols)
    breaks = []
    if not covered.all():
        d = np.diff(np.concatenate([[1], covered.astype(np.int8)]))
        breaks = [int(i) for i in np.flatnonzero(d == -1)]
        data[~covered] = np.nan
    out = _finish(src, None, lo / fs, fs, data, tuple(specs), op, gearbox, nan_policy, issues, breaks)
    out.bearing_type = bearing_type
    out.recorded_steps_per_mesh = steps
    return out


#: MCAP metadata record written by ``gear-rotor-sim record``, ``dataset`` and the node's recorder.
RECORDING_METADATA = "gear_rotor_sim.recording"


#: ``custom_data.generator`` of a recording made by :func:`~gear_rotor_sim.recording.record_cli.record_run`
SIMULATOR_GENERATOR = "gear-rotor-sim record"


def _recorded_steps(reader: Any) -> int | None:
    """Steps per mesh period of the simulator that made the recording: the dt rule's default
    (``solver.dt_rule.DEFAULT_STEPS_PER_MESH``, the only setting ``record_run`` uses) where the
    ``gear_rotor_sim.recording`` metadata names the generator ``gear-rotor-sim record``; None otherwise."""
    from gear_rotor_sim.solver.dt_rule import DEFAULT_STEPS_PER_MESH

    try:
        records = list(reader.iter_metadata())
    except Exception:  # no metadata index (a cut recording)
        return None
    for rec in records:
        if rec.name != RECORDING_METADATA:
            continue
        simulated = rec.metadata.get("custom_data.generator") == SIMULATOR_GENERATOR
        return DEFAULT_STEPS_PER_MESH if simulated else None
    return None


def _recorded_rig(reader: Any) -> tuple[str, str | None] | None:
    """``(config, bearing_type)`` of the rig a recording was made with, from its
    ``gear_rotor_sim.recording`` metadata (``custom_data.config``, ``custom_data.bearing_type``,
    YAML scalars); None when the recording does not name it."""
    try:
        records = list(reader.iter_metadata())
    except Exception:  # a recording without a summary section (cut by a crash): no metadata index
        return None
    for rec in records:
        if rec.name != RECORDING_METADATA:
            continue
        config = rec.metadata.get("custom_data.config")
        if not config:
            return None
        try:
            name = yaml.safe_load(config)
            bt = yaml.safe_load(rec.metadata.get("custom_data.bearing_type", "null"))
        except yaml.YAMLError:
            return None
        if not isinstance(name, str) or not name:
            return None
        return name, (str(bt) if bt else None)
    return None


def load_mat(
    path: str | Path, mapping: str | Path | Mapping[str, Any] | None = None, nan_policy: str = "error"
) -> Measurement:
    """Load a MATLAB v5 file through a mapping (sidecar shape, ``key`` globs instead of columns).

    A mapping may hold ``files: {<file name>: {sample_rate_hz: ...}}`` overrides, so one mapping
    describes a set of files recorded at different rates (the CWRU subset: 12 and 48 kHz).
    """
    from scipy.io import loadmat

    path = Path(path)
    src = str(path)
    if not path.exists():
        raise _err(src, "file not found")
    if mapping is None:
        mapping = sidecar_path(path)
        if not Path(mapping).exists():
            raise _err(src, f"no mapping given and no sidecar {mapping} (a .mat file needs a mapping)")
    if isinstance(mapping, Mapping):
        meta, msrc = dict(mapping), f"{src} (mapping)"
    else:
        meta, msrc = _read_yaml(Path(mapping)), str(mapping)
    _check_top(meta, msrc, ("operating_point", "gearbox", "channels"))
    files = meta.get("files") or {}
    if not isinstance(files, Mapping):
        raise _err(msrc, "files: expected a mapping of file name -> overrides")
    over = files.get(path.name, {})
    if not isinstance(over, Mapping) or set(over) - {"sample_rate_hz", "operating_point"}:
        raise _err(msrc, f"files.{path.name}: only sample_rate_hz and operating_point may be overridden")
    meta = {**meta, **over}
    if "sample_rate_hz" not in meta:
        raise _err(msrc, "sample_rate_hz: missing (a .mat file stores no rate; give it here or under files:)")
    fs = _positive(meta["sample_rate_hz"], msrc, "sample_rate_hz")
    try:
        mat = loadmat(str(path))
    except Exception as exc:
        raise _err(src, f"cannot read MATLAB file: {exc}") from None
    variables = {k: np.asarray(v) for k, v in mat.items() if not k.startswith("__")}
    scalars = {
        k: float(v.ravel()[0])
        for k, v in variables.items()
        if v.size == 1 and np.issubdtype(v.dtype, np.number)
    }
    op = parse_operating_point(meta["operating_point"], msrc, scalars)
    if not isinstance(meta["channels"], list) or not meta["channels"]:
        raise _err(msrc, "channels: expected a non-empty list")
    specs = []
    cols = []
    for i, c in enumerate(meta["channels"]):
        spec = parse_channel(c, msrc, f"channels[{i}]", column_key="key")
        matches = sorted(k for k in variables if fnmatch.fnmatchcase(k, spec.column))
        if len(matches) != 1:
            raise _err(src, f"channels[{i}].key: {spec.column!r} matches {matches} among {sorted(variables)}")
        arr = variables[matches[0]].astype(float).ravel()
        specs.append(
            ChannelSpec(matches[0], spec.quantity, spec.unit, spec.bearing, spec.node, spec.direction)
        )
        cols.append(arr)
    n = min(c.size for c in cols)
    issues = []
    if any(c.size != n for c in cols):
        issues.append(f"variables have different lengths; the first {n} samples used")
    chans = tuple(specs)
    data = _si(np.column_stack([c[:n] for c in cols]), chans)
    return _finish(src, None, 0.0, fs, data, chans, op, str(meta["gearbox"]), nan_policy, issues)
