"""Measured data for calibration: the CSV + YAML sidecar contract, MCAP recordings and MATLAB files.

The contract (``docs/calibration.md``)::

    run.csv    first column ``time_s``, one column per channel (header row with the column names)
    run.yaml   sample_rate_hz: 20000
               operating_point: {speed_rpm: 3000, temperature_c: 25, output_torque_nm: 200}
               gearbox: paper_sun2021            # a config name or path
               channels:
                 - {column: dte, quantity: dynamic_transmission_error, unit: m}
                 - {column: bearing2_fx, quantity: bearing_force, bearing: 2, direction: x, unit: N}
                 - {column: gear1_ay, quantity: acceleration, node: 5, direction: y, unit: m/s^2}

MCAP recordings of the project's own streams (topics ``/gear_rotor/<stream>``, messages
``gear_rotor_msgs/msg/VibrationChunk``) carry channel names, units, sample rate and operating point
themselves; an optional sidecar of the same stem may name the gearbox. MATLAB ``.mat`` files (the
CWRU bearing data) are read through a mapping of the same shape as the sidecar in which ``key``
(a glob over the variable names) replaces ``column`` and ``speed_rpm`` may be ``{key: "X*RPM"}``.

Validation raises :class:`MeasurementError` with a message naming the file, the field and what is
allowed. Gaps in the time column and NaN runs are never interpolated: they are either an error
(``nan_policy="error"``) or reported in :attr:`Measurement.issues` while the longest clean
contiguous segment is kept (``nan_policy="longest_segment"``).

Modules (split in session 16, docs/history/calibration_sessions.md Sec. 8.40): this one keeps the CSV loader
and writer and :func:`load_measurement`; the contract's types and field parsing are in
``measurement_contract.py``, the checks on the data (time axis, gaps, NaN runs, magnitudes, spikes, SI) in
``measurement_checks.py``, the MCAP and MATLAB loaders in ``measurement_files.py``. The names are importable
from here as before.
"""

from __future__ import annotations

import csv
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from gear_rotor_sim.blocks import SampleBlock
from gear_rotor_sim.calibration.measurement_checks import (
    GLITCH_SCALES,
    PHYSICAL_LIMITS,
    SPIKE_MAX_SAMPLES,
    SPIKE_SCALES,
    _check_magnitudes,
    _dimension,
    _finish,
    _replace_spikes,
    _si,
    nan_runs,
    robust_scale,
)
from gear_rotor_sim.calibration.measurement_contract import (
    _CHANNEL_KEYS,
    _NAME_RE,
    _OP_KEYS,
    _SIDECAR_KEYS,
    CSV_FORM,
    G_STANDARD,
    MESH_QUANTITIES,
    QUANTITIES,
    ROTATIONS,
    SI_UNIT,
    SIDECAR_FORM,
    TRANSLATIONS,
    UNITS,
    ChannelSpec,
    Measurement,
    MeasurementError,
    OperatingPoint,
    _check_top,
    _err,
    _finite,
    _positive,
    _read_yaml,
    _require_text,
    parse_channel,
    parse_operating_point,
    sidecar_path,
    spec_from_model_channel,
    unit_factor,
)
from gear_rotor_sim.calibration.measurement_files import (
    RECORDING_METADATA,
    _recorded_rig,
    load_mat,
    load_mcap,
)

#: the names other modules, tests and benchmarks import from here (moved in session 16)
__all__ = [
    "CSV_FORM",
    "GLITCH_SCALES",
    "G_STANDARD",
    "MESH_QUANTITIES",
    "PHYSICAL_LIMITS",
    "QUANTITIES",
    "RECORDING_METADATA",
    "ROTATIONS",
    "SIDECAR_FORM",
    "SI_UNIT",
    "SPIKE_MAX_SAMPLES",
    "SPIKE_SCALES",
    "TRANSLATIONS",
    "UNITS",
    "_CHANNEL_KEYS",
    "_NAME_RE",
    "_OP_KEYS",
    "_SIDECAR_KEYS",
    "ChannelSpec",
    "Measurement",
    "MeasurementError",
    "OperatingPoint",
    "_check_magnitudes",
    "_check_top",
    "_dimension",
    "_err",
    "_finish",
    "_finite",
    "_positive",
    "_read_yaml",
    "_recorded_rig",
    "_replace_spikes",
    "_require_text",
    "_si",
    "load_csv",
    "load_mat",
    "load_mcap",
    "load_measurement",
    "nan_runs",
    "parse_channel",
    "parse_operating_point",
    "robust_scale",
    "sidecar_path",
    "spec_from_model_channel",
    "unit_factor",
    "write_csv",
]


def load_csv(
    path: str | Path, sidecar: str | Path | Mapping[str, Any] | None = None, nan_policy: str = "error"
) -> Measurement:
    """Load a CSV measurement with its YAML sidecar (see the module docstring).

    Parameters
    ----------
    path : str or Path
        CSV file; first column ``time_s``.
    sidecar : path, mapping or None
        The description; default the ``.yaml`` of the same stem.
    nan_policy : str
        ``"error"`` (default) or ``"longest_segment"``.
    """
    path = Path(path)
    src = str(path)
    if not path.exists():
        raise _err(src, "file not found")
    _require_text(path, CSV_FORM)
    if isinstance(sidecar, Mapping):
        meta, msrc = dict(sidecar), f"{src} (sidecar)"
    else:
        sc = Path(sidecar) if sidecar is not None else sidecar_path(path)
        if not sc.exists():
            raise _err(src, f"sidecar {sc} not found (a YAML file of the same stem describes the columns)")
        meta, msrc = _read_yaml(sc), str(sc)
    _check_top(meta, msrc, ("sample_rate_hz", "operating_point", "gearbox", "channels"))
    fs = _positive(meta["sample_rate_hz"], msrc, "sample_rate_hz")
    op = parse_operating_point(meta["operating_point"], msrc)
    if not isinstance(meta["channels"], list) or not meta["channels"]:
        raise _err(msrc, "channels: expected a non-empty list")
    chans = tuple(parse_channel(c, msrc, f"channels[{i}]") for i, c in enumerate(meta["channels"]))
    with open(path, newline="", encoding="utf-8") as fh:
        header = [h.strip() for h in next(csv.reader(fh), [])]
    if not header or header[0] != "time_s":
        raise _err(src, f"first column must be 'time_s', header is {header[:5]}")
    dup = sorted({h for h in header if header.count(h) > 1})
    if dup:
        raise _err(src, f"duplicate column(s) {dup}")
    idx = []
    for i, c in enumerate(chans):
        if c.column not in header:
            raise _err(src, f"channels[{i}].column: {c.column!r} missing from the CSV header {header}")
        idx.append(header.index(c.column))
    raw = _read_numbers(path, src)
    if raw.shape[1] != len(header):
        raise _err(src, f"rows have {raw.shape[1]} fields, header has {len(header)}")
    data = _si(raw[:, idx], chans)
    return _finish(src, raw[:, 0], 0.0, fs, data, chans, op, str(meta["gearbox"]), nan_policy, [])


def _read_numbers(path: Path, src: str) -> np.ndarray:
    """The CSV's data rows as floats: 'nan'/'inf' and empty fields (missing, NaN) are numbers, any
    other text is an error naming its row and column."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # numpy's "empty input" warning
            raw = np.loadtxt(path, delimiter=",", skiprows=1, dtype=float, ndmin=2)
    except ValueError as exc:
        if "could not convert string '' " not in str(exc):
            raise _err(src, f"malformed row: {exc}") from None
        try:  # empty fields: missing samples (NaN), reported by the NaN-run checks
            raw = np.atleast_2d(
                np.genfromtxt(path, delimiter=",", skip_header=1, dtype=float, invalid_raise=True)
            )
        except ValueError as exc2:
            raise _err(src, f"malformed row: {exc2}") from None
    if raw.size == 0:
        raise _err(src, "no data rows after the header (at least 2 samples are required)")
    return raw


def write_csv(
    path: str | Path,
    block: SampleBlock,
    operating_point: OperatingPoint,
    gearbox: str,
    channels: list[ChannelSpec] | None = None,
) -> Path:
    """Write a :class:`SampleBlock` as CSV + sidecar following the contract (for tests and examples).

    Parameters
    ----------
    channels : list of ChannelSpec, optional
        Descriptions; default derived from the block's model channel names (SI units).
    """
    path = Path(path)
    specs = (
        channels
        if channels is not None
        else [spec_from_model_channel(c, u) for c, u in zip(block.channels, block.units, strict=True)]
    )
    cols = ["time_s", *[s.column for s in specs]]
    arr = np.column_stack([block.time, block.data])
    np.savetxt(path, arr, delimiter=",", header=",".join(cols), comments="", fmt="%.10g")
    op = {"speed_rpm": operating_point.speed_rpm, "temperature_c": operating_point.temperature_c}
    if operating_point.output_torque_nm is not None:
        op["output_torque_nm"] = operating_point.output_torque_nm
    meta = {
        "sample_rate_hz": float(block.sample_rate_hz),
        "operating_point": op,
        "gearbox": gearbox,
        "channels": [
            {
                k: v
                for k, v in (
                    ("column", s.column),
                    ("quantity", s.quantity),
                    ("bearing", s.bearing),
                    ("node", s.node),
                    ("direction", s.direction),
                    ("mesh", s.mesh),
                    ("unit", s.unit),
                )
                if v is not None
            }
            for s in specs
        ],
    }
    with open(path.with_suffix(".yaml"), "w", encoding="utf-8") as fh:
        yaml.safe_dump(meta, fh, sort_keys=False)
    return path


def load_measurement(
    path: str | Path, description: str | Path | Mapping[str, Any] | None = None, nan_policy: str = "error"
) -> Measurement:
    """Load a measurement by file type: ``.csv`` (sidecar), ``.mcap``, ``.mat`` (mapping).

    Parameters
    ----------
    path : str or Path
        The data file.
    description : path, mapping or None
        Sidecar (CSV, MCAP) or mapping (.mat); default the ``.yaml`` of the same stem.
    nan_policy : str
        ``"error"`` or ``"longest_segment"``.
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".csv":
        return load_csv(path, description, nan_policy)
    if suffix == ".mcap":
        return load_mcap(path, description, nan_policy)
    if suffix == ".mat":
        return load_mat(path, description, nan_policy)
    raise MeasurementError(
        f"{path}: unsupported file type {suffix!r}; supported: .csv (+ .yaml), .mcap, .mat"
    )
