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
"""

from __future__ import annotations

import csv
import fnmatch
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from gear_rotor_sim.blocks import SampleBlock

G_STANDARD = 9.80665  # m/s^2 per g (ISO 80000-3)

# unit text -> (dimension, factor to SI)
UNITS: dict[str, tuple[str, float]] = {
    "m": ("length", 1.0),
    "mm": ("length", 1e-3),
    "um": ("length", 1e-6),
    "µm": ("length", 1e-6),
    "μm": ("length", 1e-6),
    "micron": ("length", 1e-6),
    "nm": ("length", 1e-9),
    "N": ("force", 1.0),
    "kN": ("force", 1e3),
    "mN": ("force", 1e-3),
    "m/s": ("velocity", 1.0),
    "mm/s": ("velocity", 1e-3),
    "um/s": ("velocity", 1e-6),
    "in/s": ("velocity", 0.0254),
    "m/s^2": ("acceleration", 1.0),
    "m/s2": ("acceleration", 1.0),
    "m s^-2": ("acceleration", 1.0),
    "mm/s^2": ("acceleration", 1e-3),
    "g": ("acceleration", G_STANDARD),
    "rad": ("angle", 1.0),
    "mrad": ("angle", 1e-3),
    "urad": ("angle", 1e-6),
    "µrad": ("angle", 1e-6),
    "deg": ("angle", np.pi / 180.0),
    "rad/s": ("angular_velocity", 1.0),
    "deg/s": ("angular_velocity", np.pi / 180.0),
    "rad/s^2": ("angular_acceleration", 1.0),
    "rad/s2": ("angular_acceleration", 1.0),
}
SI_UNIT = {
    "length": "m",
    "force": "N",
    "velocity": "m/s",
    "acceleration": "m/s^2",
    "angle": "rad",
    "angular_velocity": "rad/s",
    "angular_acceleration": "rad/s^2",
}

# quantity -> (required location key or None, dimension for translations, dimension for rotations)
QUANTITIES: dict[str, tuple[str | None, str, str | None]] = {
    "dynamic_transmission_error": (None, "length", None),
    "mesh_force": (None, "force", None),
    "bearing_force": ("bearing", "force", None),
    "displacement": ("node", "length", "angle"),
    "velocity": ("node", "velocity", "angular_velocity"),
    "acceleration": ("node", "acceleration", "angular_acceleration"),
    # accelerometer on the housing of a bearing: the model's housing/sensor mode driven by that
    # bearing's force (calibration.residual.HousingSensor)
    "housing_acceleration": ("bearing", "acceleration", None),
}
TRANSLATIONS = ("x", "y", "z")
ROTATIONS = ("theta_x", "theta_y", "theta_z")
_SIDECAR_KEYS = {"sample_rate_hz", "operating_point", "gearbox", "channels", "description", "files", "format"}
_OP_KEYS = {"speed_rpm", "temperature_c", "output_torque_nm"}
_CHANNEL_KEYS = {"column", "key", "quantity", "unit", "bearing", "node", "direction", "name", "mesh"}
#: Quantities of one gear mesh: an optional ``mesh`` key (1-based, order of ``meshes:`` in the rig)
#: selects the mesh of a multi-stage rig (model channels ``mesh{k}_dte``, ``mesh{k}_force``); without
#: it they are the first mesh's (``dte``, ``mesh_force``).
MESH_QUANTITIES = ("dynamic_transmission_error", "mesh_force")


#: Largest magnitude of a measured sample per dimension (SI), beyond any vibration sensor's range:
#: a sample beyond it is refused (a sensor glitch, a wrong unit). 1 m of DTE or displacement,
#: 1e9 N, 1e4 m/s, 1e7 m/s^2 (~1e6 g, ten times a shock accelerometer's range), 1e6 rad,
#: 1e6 rad/s, 1e9 rad/s^2.
PHYSICAL_LIMITS: dict[str, float] = {
    "length": 1.0,
    "force": 1e9,
    "velocity": 1e4,
    "acceleration": 1e7,
    "angle": 1e6,
    "angular_velocity": 1e6,
    "angular_acceleration": 1e9,
}
#: A finite sample more than this many robust scales (1.4826 x MAD) from the channel's median is
#: refused as non-physical (no sensor has a dynamic range of 10^6 over its noise-plus-signal level).
GLITCH_SCALES = 1e6
#: Isolated spikes: runs of at most SPIKE_MAX_SAMPLES samples more than SPIKE_SCALES robust scales
#: from the median, with normal samples on both sides, are replaced by linear interpolation and
#: reported in ``Measurement.issues`` (a Gaussian signal exceeds 100 scales with probability ~0; the
#: impacts of a bearing defect ring over many samples and stay far below it in the CWRU records).
SPIKE_SCALES = 100.0
SPIKE_MAX_SAMPLES = 2


class MeasurementError(ValueError):
    """Invalid measured data or description; the message names the file and field."""


@dataclass(frozen=True)
class ChannelSpec:
    """One measured channel: where it is in the file and which model output it corresponds to.

    Attributes
    ----------
    column : str
        CSV column, MCAP channel name or .mat variable name.
    quantity : str
        One of :data:`QUANTITIES`.
    unit : str
        Unit as written in the file (converted to SI on loading).
    bearing, node : int or None
        1-based bearing (paper numbering) or node (Fig 5 numbering).
    direction : str or None
        ``x``, ``y``, ``z`` (or ``theta_x`` ... for node quantities).
    mesh : int or None
        1-based mesh of a mesh quantity (:data:`MESH_QUANTITIES`) on a multi-stage rig; None: the
        first mesh under the single-mesh names ``dte`` / ``mesh_force``.
    """

    column: str
    quantity: str
    unit: str
    bearing: int | None = None
    node: int | None = None
    direction: str | None = None
    mesh: int | None = None

    @property
    def model_channel(self) -> str:
        """Name of the simulator channel this measurement corresponds to (``docs/design.md``)."""
        if self.quantity == "dynamic_transmission_error":
            return "dte" if self.mesh is None else f"mesh{self.mesh}_dte"
        if self.quantity == "mesh_force":
            return "mesh_force" if self.mesh is None else f"mesh{self.mesh}_force"
        if self.quantity == "bearing_force":
            return f"bearing{self.bearing}_f{self.direction}"
        if self.quantity == "housing_acceleration":
            return f"bearing{self.bearing}_housing_a{self.direction}"
        prefix = {"displacement": "", "velocity": "v", "acceleration": "a"}[self.quantity]
        return f"node{self.node}_{prefix}{self.direction}"

    @property
    def si_unit(self) -> str:
        _, trans, rot = QUANTITIES[self.quantity]
        return SI_UNIT[rot if self.direction in ROTATIONS and rot else trans]


@dataclass(frozen=True)
class OperatingPoint:
    """Declared operating point: input-shaft speed, uniform steady temperature, output torque."""

    speed_rpm: float
    temperature_c: float
    output_torque_nm: float | None = None


@dataclass
class Measurement:
    """Validated measured channels in SI, uniformly sampled and gap-free.

    Attributes
    ----------
    source : str
        File the data came from.
    sample_rate_hz : float
        Sampling rate, Hz.
    t0 : float
        Time of the first kept sample, s (the file's time axis).
    data : numpy.ndarray
        ``(n_samples, n_channels)`` float64 in SI units.
    channels : tuple of ChannelSpec
        One per data column.
    operating_point : OperatingPoint
        As declared (sidecar, mapping or MCAP messages).
    gearbox : str
        Config name or path of the model of the measured machine.
    issues : list of str
        Gaps, NaN runs and other findings reported while loading (never silently repaired).
    bearing_type : str or None
        Bearing type on every bearing of ``gearbox`` (recordings made with ``--bearing-type``).
    """

    source: str
    sample_rate_hz: float
    t0: float
    data: np.ndarray
    channels: tuple[ChannelSpec, ...]
    operating_point: OperatingPoint
    gearbox: str
    issues: list[str] = field(default_factory=list)
    #: bearing type put on every bearing of ``gearbox`` (a recording made with ``--bearing-type``)
    bearing_type: str | None = None

    @property
    def n_samples(self) -> int:
        return int(self.data.shape[0])

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.sample_rate_hz

    @property
    def model_channels(self) -> list[str]:
        return [c.model_channel for c in self.channels]

    def channel(self, name: str) -> np.ndarray:
        """Samples of a channel by column name or model channel name."""
        for i, c in enumerate(self.channels):
            if name in (c.column, c.model_channel):
                return self.data[:, i]
        raise KeyError(
            f"channel {name!r} not in {self.source}; available: {[c.column for c in self.channels]}"
        )

    def segment(self, start_s: float = 0.0, duration_s: float | None = None) -> Measurement:
        """A contiguous part of the record (times relative to the first kept sample)."""
        i0 = round(start_s * self.sample_rate_hz)
        i1 = (
            self.n_samples
            if duration_s is None
            else min(self.n_samples, i0 + round(duration_s * self.sample_rate_hz))
        )
        if not 0 <= i0 < i1:
            raise ValueError(
                f"segment: [{start_s}, +{duration_s}] s is outside the {self.duration_s:.4g} s record"
            )
        return Measurement(
            self.source,
            self.sample_rate_hz,
            self.t0 + i0 / self.sample_rate_hz,
            self.data[i0:i1].copy(),
            self.channels,
            self.operating_point,
            self.gearbox,
            [*self.issues, f"analysed samples {i0}..{i1 - 1}"],
            self.bearing_type,
        )

    def as_block(self) -> SampleBlock:
        """The data as a :class:`SampleBlock` with model channel names and SI units."""
        n = self.n_samples
        return SampleBlock(
            self.t0,
            self.sample_rate_hz,
            tuple(self.model_channels),
            tuple(c.si_unit for c in self.channels),
            np.ascontiguousarray(self.data, dtype=np.float64),
            0,
            np.full(n, self.operating_point.speed_rpm),
            np.full(n, self.operating_point.temperature_c),
        )


# ---------------------------------------------------------------------------------------------------
# Field validation
# ---------------------------------------------------------------------------------------------------
def _err(src: str, msg: str) -> MeasurementError:
    return MeasurementError(f"{src}: {msg}")


def _positive(value: Any, src: str, path: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise _err(src, f"{path}: expected a number, got {value!r}") from None
    if not np.isfinite(v) or v <= 0:
        raise _err(src, f"{path}: must be positive and finite, got {value!r}")
    return v


def _finite(value: Any, src: str, path: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise _err(src, f"{path}: expected a number, got {value!r}") from None
    if not np.isfinite(v):
        raise _err(src, f"{path}: must be finite, got {value!r}")
    return v


def unit_factor(unit: str, dimension: str, src: str = "", path: str = "unit") -> float:
    """Factor converting ``unit`` to SI; :class:`MeasurementError` if not understood or wrong kind."""
    u = str(unit).strip()
    if u not in UNITS:
        raise _err(src, f"{path}: unit {unit!r} is not understood; known units: {sorted(UNITS)}")
    dim, factor = UNITS[u]
    if dim != dimension:
        allowed = sorted(k for k, (d, _) in UNITS.items() if d == dimension)
        raise _err(src, f"{path}: unit {unit!r} is a {dim} unit, this channel needs {dimension}: {allowed}")
    return factor


def parse_channel(d: Any, src: str, path: str, column_key: str = "column") -> ChannelSpec:
    """Validate one channel entry of a sidecar or mapping."""
    if not isinstance(d, Mapping):
        raise _err(src, f"{path}: expected a mapping like {{column: dte, quantity: ..., unit: m}}")
    unknown = set(d) - _CHANNEL_KEYS
    if unknown:
        raise _err(src, f"{path}: unknown key(s) {sorted(unknown)}; allowed: {sorted(_CHANNEL_KEYS)}")
    if column_key not in d:
        raise _err(src, f"{path}.{column_key}: missing")
    quantity = d.get("quantity")
    if quantity not in QUANTITIES:
        raise _err(src, f"{path}.quantity: unknown quantity {quantity!r}; allowed: {sorted(QUANTITIES)}")
    if "unit" not in d:
        raise _err(src, f"{path}.unit: missing")
    where, trans_dim, rot_dim = QUANTITIES[quantity]
    bearing = node = direction = None
    if where is not None:
        if where not in d:
            raise _err(src, f"{path}.{where}: required for quantity {quantity!r} (1-based)")
        v = d[where]
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            raise _err(src, f"{path}.{where}: must be a 1-based integer, got {v!r}")
        if where == "bearing":
            bearing = v
        else:
            node = v
        direction = d.get("direction")
        allowed = TRANSLATIONS + (ROTATIONS if rot_dim else ())
        if direction not in allowed:
            raise _err(src, f"{path}.direction: {direction!r} is not one of {list(allowed)}")
    mesh = None
    if d.get("mesh") is not None:
        if quantity not in MESH_QUANTITIES:
            raise _err(src, f"{path}.mesh: only for the quantities {list(MESH_QUANTITIES)}, not {quantity!r}")
        mesh = d["mesh"]
        if isinstance(mesh, bool) or not isinstance(mesh, int) or mesh < 1:
            raise _err(src, f"{path}.mesh: must be a 1-based integer (order of meshes), got {mesh!r}")
    dim = rot_dim if direction in ROTATIONS and rot_dim else trans_dim
    unit_factor(d["unit"], dim, src, f"{path}.unit")
    return ChannelSpec(str(d[column_key]), quantity, str(d["unit"]).strip(), bearing, node, direction, mesh)


def parse_operating_point(d: Any, src: str, file_values: Mapping[str, float] | None = None) -> OperatingPoint:
    """Validate ``operating_point``; ``{key: ...}`` entries are looked up in ``file_values``."""
    if not isinstance(d, Mapping):
        raise _err(src, "operating_point: expected {speed_rpm: ..., temperature_c: ...}")
    unknown = set(d) - _OP_KEYS
    if unknown:
        raise _err(src, f"operating_point: unknown key(s) {sorted(unknown)}; allowed: {sorted(_OP_KEYS)}")
    vals: dict[str, float | None] = {}
    for k in ("speed_rpm", "temperature_c", "output_torque_nm"):
        v = d.get(k)
        if isinstance(v, Mapping):
            if file_values is None or "key" not in v:
                raise _err(src, f"operating_point.{k}: {{key: ...}} is only allowed for .mat files")
            matches = [n for n in file_values if fnmatch.fnmatchcase(n, str(v["key"]))]
            if len(matches) != 1:
                raise _err(src, f"operating_point.{k}.key: {v['key']!r} matches {matches} in the file")
            v = file_values[matches[0]]
        if v is None:
            if k == "output_torque_nm":
                vals[k] = None
                continue
            raise _err(src, f"operating_point.{k}: missing")
        vals[k] = (
            _positive(v, src, f"operating_point.{k}")
            if k == "speed_rpm"
            else _finite(v, src, f"operating_point.{k}")
        )
    return OperatingPoint(float(vals["speed_rpm"]), float(vals["temperature_c"]), vals["output_torque_nm"])


def _require_text(path: Path, expected: str) -> None:
    """MeasurementError naming the file and ``expected`` when it is not UTF-8 text (binary data)."""
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
    except OSError as exc:
        raise _err(str(path), f"cannot read: {exc.strerror}") from None
    nul = raw.find(b"\x00")
    bad = nul
    if bad < 0:
        try:
            raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            bad = exc.start
    if bad >= 0:
        raise _err(str(path), f"not a text file (byte 0x{raw[bad]:02x} at offset {bad}); expected {expected}")


CSV_FORM = "a UTF-8 CSV file (header row 'time_s,<column>,...') with a YAML sidecar of the same stem"
SIDECAR_FORM = "a UTF-8 YAML sidecar (sample_rate_hz, operating_point, gearbox, channels)"


def _read_yaml(path: Path) -> dict[str, Any]:
    _require_text(path, SIDECAR_FORM)
    try:
        with open(path, encoding="utf-8") as fh:
            d = yaml.safe_load(fh)
    except yaml.YAMLError as exc:
        raise _err(str(path), f"not valid YAML: {' '.join(str(exc).split())}") from None
    if not isinstance(d, dict):
        raise _err(str(path), "expected a mapping at the top level")
    return d


def _check_top(d: Mapping[str, Any], src: str, required: tuple[str, ...]) -> None:
    unknown = set(d) - _SIDECAR_KEYS
    if unknown:
        raise _err(src, f"unknown key(s) {sorted(unknown)}; allowed: {sorted(_SIDECAR_KEYS)}")
    for k in required:
        if k not in d:
            raise _err(src, f"{k}: missing (required: {list(required)})")


# ---------------------------------------------------------------------------------------------------
# Gaps and NaN runs
# ---------------------------------------------------------------------------------------------------
def nan_runs(x: np.ndarray) -> list[tuple[int, int]]:
    """Runs of non-finite samples as ``(start, length)``."""
    bad = ~np.isfinite(x)
    if not bad.any():
        return []
    d = np.diff(np.concatenate([[0], bad.astype(np.int8), [0]]))
    starts = np.flatnonzero(d == 1)
    ends = np.flatnonzero(d == -1)
    return [(int(s), int(e - s)) for s, e in zip(starts, ends, strict=True)]


def _finish(
    src: str,
    time: np.ndarray | None,
    t0: float,
    fs: float,
    data: np.ndarray,
    channels: tuple[ChannelSpec, ...],
    op: OperatingPoint,
    gearbox: str,
    nan_policy: str,
    issues: list[str],
    breaks: list[int] | None = None,
) -> Measurement:
    """Convert, check the time axis, report gaps/NaN runs, apply the NaN policy."""
    if nan_policy not in ("error", "longest_segment"):
        raise ValueError(f"nan_policy: {nan_policy!r} is not one of ['error', 'longest_segment']")
    n = data.shape[0]
    if n < 2:
        raise _err(src, f"only {n} sample(s); at least 2 are required")
    cut = np.zeros(n + 1, dtype=bool)  # cut[i]: a segment boundary before sample i
    problems: list[str] = []
    if time is not None:
        if not np.all(np.isfinite(time)):
            i = int(np.flatnonzero(~np.isfinite(time))[0])
            raise _err(src, f"time_s: non-finite value at row {i + 2}")
        dt = np.diff(time)
        if np.any(dt <= 0):
            i = int(np.flatnonzero(dt <= 0)[0])
            raise _err(
                src,
                f"time_s: not strictly increasing at row {i + 3} "
                f"({float(time[i])!r} -> {float(time[i + 1])!r})",
            )
        nominal = 1.0 / fs
        med = float(np.median(dt))
        if abs(med - nominal) > 1e-3 * nominal:
            raise _err(
                src, f"time_s: median step {med:.6g} s disagrees with sample_rate_hz {fs} ({nominal:.6g} s)"
            )
        jumps = np.flatnonzero(dt > 1.5 * nominal)
        for j in jumps:
            problems.append(f"gap in time_s of {dt[j]:.6g} s after t = {time[j]:.6g} s")
            cut[j + 1] = True
        irregular = np.flatnonzero((dt < 0.5 * nominal) | ((dt > 1.01 * nominal) & (dt <= 1.5 * nominal)))
        if irregular.size:
            raise _err(
                src, f"time_s: {irregular.size} irregular step(s), first after t = {time[irregular[0]]:.6g} s"
            )
        t0 = float(time[0])
    for b in breaks or []:
        problems.append(f"discontinuity (lost chunk) before sample {b}")
        cut[b] = True
    _check_magnitudes(src, data, channels, time if time is not None else t0 + np.arange(n) / fs)
    bad = np.zeros(n, dtype=bool)
    for k, c in enumerate(channels):
        runs = nan_runs(data[:, k])
        if runs:
            longest = max(r[1] for r in runs)
            first = runs[0][0]
            kind = "NaN/inf" if np.isinf(data[:, k]).any() else "NaN"
            problems.append(
                f"column {c.column!r}: {len(runs)} {kind} run(s), {sum(r[1] for r in runs)} samples, "
                f"longest {longest}, first at t = {t0 + first / fs:.6g} s"
            )
            bad |= ~np.isfinite(data[:, k])
    if problems and nan_policy == "error":
        raise _err(
            src,
            "; ".join(problems) + " (gaps and NaNs are not interpolated; use nan_policy="
            "'longest_segment' / --allow-gaps to analyse the longest clean segment)",
        )
    if problems:
        # longest run of good samples that crosses no cut
        good = ~bad
        best = (0, 0)
        start = None
        for i in range(n + 1):
            end_here = i == n or not good[i] or (cut[i] and i > 0)
            if start is not None and end_here:
                if i - start > best[1] - best[0]:
                    best = (start, i)
                start = None
            if i < n and good[i] and start is None:
                start = i
        if best[1] - best[0] < 2:
            raise _err(src, "no clean segment of at least 2 samples: " + "; ".join(problems))
        issues.extend(problems)
        issues.append(
            f"kept the longest clean segment: samples {best[0]}..{best[1] - 1} "
            f"({(best[1] - best[0]) / fs:.4g} s of {n / fs:.4g} s)"
        )
        data = data[best[0] : best[1]]
        t0 = float(time[best[0]]) if time is not None else t0 + best[0] / fs
    data = _replace_spikes(data, channels, t0, fs, issues)
    return Measurement(src, fs, float(t0), np.ascontiguousarray(data, float), channels, op, gearbox, issues)


def _dimension(c: ChannelSpec) -> str:
    _, trans, rot = QUANTITIES[c.quantity]
    return rot if c.direction in ROTATIONS and rot else trans


def robust_scale(x: np.ndarray) -> tuple[float, float]:
    """Median and robust standard deviation (1.4826 x median absolute deviation) of the finite samples."""
    f = x[np.isfinite(x)]
    if f.size == 0:
        return 0.0, 0.0
    med = float(np.median(f))
    return med, 1.4826 * float(np.median(np.abs(f - med)))


def _check_magnitudes(src: str, data: np.ndarray, channels: tuple[ChannelSpec, ...], t: np.ndarray) -> None:
    """Refuse samples beyond :data:`PHYSICAL_LIMITS` or :data:`GLITCH_SCALES` robust scales (SI data)."""
    for k, c in enumerate(channels):
        x = data[:, k]
        finite = np.isfinite(x)
        dim = _dimension(c)
        limit = PHYSICAL_LIMITS[dim]
        over = np.flatnonzero(finite & (np.abs(x) > limit))
        what = f"beyond the physical limit {limit:g} {SI_UNIT[dim]} of a {dim} channel"
        if over.size == 0:
            med, scale = robust_scale(x)
            if scale > 0:
                over = np.flatnonzero(finite & (np.abs(x - med) > GLITCH_SCALES * scale))
                what = (
                    f"more than {GLITCH_SCALES:g} robust scales ({scale:.3g} {SI_UNIT[dim]}, "
                    f"1.4826 x MAD) from the median {med:.3g} {SI_UNIT[dim]}"
                )
        if over.size:
            i = int(over[0])
            raise _err(
                src,
                f"column {c.column!r}: {over.size} non-physical sample(s), first {x[i]:.6g} {SI_UNIT[dim]} "
                f"at t = {t[i]:.6g} s (sample {i}), {what}; a sensor glitch? remove or repair those samples",
            )


def _replace_spikes(
    data: np.ndarray, channels: tuple[ChannelSpec, ...], t0: float, fs: float, issues: list[str]
) -> np.ndarray:
    """Isolated spikes (runs of at most :data:`SPIKE_MAX_SAMPLES` samples more than
    :data:`SPIKE_SCALES` robust scales from the median) replaced by linear interpolation between
    their neighbours and reported in ``issues``; longer excursions are kept and reported."""
    out = data
    for k, c in enumerate(channels):
        x = data[:, k]
        med, scale = robust_scale(x)
        if scale <= 0:
            continue
        far = np.abs(x - med) > SPIKE_SCALES * scale
        if not far.any():
            continue
        d = np.diff(np.concatenate([[0], far.astype(np.int8), [0]]))
        starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
        spikes = [
            (s, e)
            for s, e in zip(starts, ends, strict=True)
            if e - s <= SPIKE_MAX_SAMPLES and s > 0 and e < x.size
        ]
        kept = len(starts) - len(spikes)
        if spikes:
            if out is data:
                out = data.copy()
            for s, e in spikes:
                out[s:e, k] = np.interp(np.arange(s, e), [s - 1, e], [x[s - 1], x[e]])
            times = ", ".join(f"{t0 + s / fs:.6g}" for s, _ in spikes[:5])
            times += ", ..." if len(spikes) > 5 else ""
            issues.append(
                f"column {c.column!r}: {len(spikes)} isolated spike(s) (<= {SPIKE_MAX_SAMPLES} samples, "
                f"> {SPIKE_SCALES:g} robust scales from the median) replaced by linear interpolation "
                f"at t = {times} s"
            )
        if kept:
            issues.append(
                f"column {c.column!r}: {kept} excursion(s) beyond {SPIKE_SCALES:g} robust scales kept "
                f"(longer than {SPIKE_MAX_SAMPLES} samples or at an end of the record)"
            )
    return out


def _si(data: np.ndarray, channels: tuple[ChannelSpec, ...]) -> np.ndarray:
    out = np.array(data, dtype=float, copy=True)
    for k, c in enumerate(channels):
        _, trans, rot = QUANTITIES[c.quantity]
        dim = rot if c.direction in ROTATIONS and rot else trans
        out[:, k] *= unit_factor(c.unit, dim)
    return out


# ---------------------------------------------------------------------------------------------------
# Loaders
# ---------------------------------------------------------------------------------------------------
def sidecar_path(path: str | Path) -> Path:
    """The YAML sidecar of a data file: same stem, ``.yaml`` (or ``.yml``)."""
    p = Path(path)
    for ext in (".yaml", ".yml"):
        if p.with_suffix(ext).exists():
            return p.with_suffix(ext)
    return p.with_suffix(".yaml")


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


_NAME_RE = re.compile(
    r"^(?:(?P<dte>dte)|(?P<mf>mesh_force)|mesh(?P<mk>\d+)_(?P<mq>dte|force)|bearing(?P<b>\d+)_f(?P<bd>[xyz])|"
    r"node(?P<n>\d+)_(?P<kind>[va]?)(?P<nd>x|y|z|theta_x|theta_y|theta_z))$"
)


def spec_from_model_channel(name: str, unit: str) -> ChannelSpec:
    """The :class:`ChannelSpec` of a simulator channel name (``dte``, ``bearing2_fx``, ``node5_ay``)."""
    m = _NAME_RE.match(name)
    if m is None:
        raise MeasurementError(
            f"channel {name!r}: not a model channel name (dte, mesh_force, mesh<k>_dte, mesh<k>_force, "
            "bearing<k>_f<x|y|z>, "
            "node<n>_<x|y|z|theta_*>, node<n>_v<...>, node<n>_a<...>)"
        )
    if m["dte"]:
        return ChannelSpec(name, "dynamic_transmission_error", unit)
    if m["mf"]:
        return ChannelSpec(name, "mesh_force", unit)
    if m["mk"]:
        quantity = "dynamic_transmission_error" if m["mq"] == "dte" else "mesh_force"
        return ChannelSpec(name, quantity, unit, mesh=int(m["mk"]))
    if m["b"]:
        return ChannelSpec(name, "bearing_force", unit, bearing=int(m["b"]), direction=m["bd"])
    quantity = {"": "displacement", "v": "velocity", "a": "acceleration"}[m["kind"]]
    return ChannelSpec(name, quantity, unit, node=int(m["n"]), direction=m["nd"])


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
    return out


#: MCAP metadata record written by ``gear-rotor-sim record``, ``dataset`` and the node's recorder.
RECORDING_METADATA = "gear_rotor_sim.recording"


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
