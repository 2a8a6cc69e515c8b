"""The measured-data contract (``measurement.py``'s docstring, docs/calibration.md): units and
quantities, the channel and operating-point descriptions, the :class:`Measurement` itself, and
the parsing of a sidecar's fields, each error naming the file and the field
(moved from ``measurement.py`` in session 16, unchanged).
"""

from __future__ import annotations

import fnmatch
import re
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
    speed_change : numpy.ndarray or None
        Relative speed change per sample of a record resampled to uniform shaft angle (order tracking).
    recorded_steps_per_mesh : int or None
        Integration steps per mesh period (the dt rule's setting) of the simulator that made the record,
        where the record names it (``gear-rotor-sim record`` MCAP metadata); None for measured records.
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
    #: relative speed change ``w / w_mean - 1`` per sample where order tracking resampled the record to
    #: uniform shaft angle (``order_tracking.py``, ``speed_modulation.py``); None at a constant speed
    speed_change: np.ndarray | None = None
    #: the dt rule's steps per mesh period of the simulator that made the record (its MCAP metadata names
    #: the generator ``gear-rotor-sim record``); the calibration's model runs then take the record's own
    #: numerics (``model_steps.recorded_steps``); None for measured records
    recorded_steps_per_mesh: int | None = None

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
            recorded_steps_per_mesh=self.recorded_steps_per_mesh,
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


def sidecar_path(path: str | Path) -> Path:
    """The YAML sidecar of a data file: same stem, ``.yaml`` (or ``.yml``)."""
    p = Path(path)
    for ext in (".yaml", ".yml"):
        if p.with_suffix(ext).exists():
            return p.with_suffix(ext)
    return p.with_suffix(".yaml")


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
