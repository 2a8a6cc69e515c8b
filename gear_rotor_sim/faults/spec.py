"""One fault description for the node, ``record``, ``dataset`` and the calibration.

A fault list is YAML (or the same structure in Python)::

    faults:
      - {type: tooth_damage, wheel: gear, tooth: 5, depth: 0.3}
      - type: outer_race_defect
        bearing: 2
        force_n: 200
        onset_s: 1.0
        growth: {law: exponential, final: 2000, duration_s: 4}

Each entry is flat: ``type`` (a library name of :data:`~gear_rotor_sim.faults.library.EFFECT_TYPES`),
the location keys of that effect (``wheel`` + ``tooth``, ``mesh``, ``bearing``, ``node``), its
parameters (``depth``, ``force_n``, ``eccentricity_m``, ...; those not given keep the effect's
default), ``onset_s`` (simulated time at which the fault appears; 0 by default) and an optional
``growth``. The *severity* of a fault is its effect's main parameter (the first fitted parameter:
``depth`` of tooth damage, ``force_n`` of a bearing defect, ...); the value given is the severity at
onset. ``growth`` moves it toward ``final`` over ``duration_s`` after the onset:

* ``linear``: ``s(tau) = s0 + (final - s0) min(tau / duration_s, 1)``;
* ``exponential``: ``s(tau) = s0 (final / s0) ** min(tau / duration_s, 1)`` (needs ``s0 > 0``),

with ``tau = t - onset_s``; before the onset the severity is 0 (the healthy machine). Every error
names the field and the allowed values (``faults[0].tooth: 40 is out of range (allowed 1..36)``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from gear_rotor_sim.faults.base import Effect
from gear_rotor_sim.faults.library import EFFECT_TYPES

#: Location keys (integers are 1-based, as everywhere a user sees).
LOCATION_KEYS = ("wheel", "tooth", "mesh", "bearing", "node")
#: Keys of an entry that are not effect fields.
CONTROL_KEYS = ("type", "onset_s", "growth")
GROWTH_LAWS = ("linear", "exponential")
#: Operating-point discrepancies are set through speed_rpm / temperature_c, not injected.
NOT_INJECTABLE = {"temperature_offset": "set temperature_c instead (it is an operating-point offset)"}
#: Effect fields that are objects, not YAML values.
_INTERNAL_FIELDS = ("geometry", "_cache")


class FaultError(ValueError):
    """A fault description is invalid; the message names the field and the allowed values."""


def fault_types() -> tuple[str, ...]:
    """Library names that can be injected (``EFFECT_TYPES`` minus operating-point offsets)."""
    return tuple(n for n in EFFECT_TYPES if n not in NOT_INJECTABLE)


@dataclass(frozen=True)
class Growth:
    """Severity progression after the onset toward ``final`` over ``duration_s``."""

    law: str
    final: float
    duration_s: float

    def as_dict(self) -> dict[str, Any]:
        return {"law": self.law, "final": self.final, "duration_s": self.duration_s}


@dataclass(frozen=True)
class FaultSpec:
    """One fault: library ``type``, location, parameters, onset and growth (user units, 1-based).

    Attributes
    ----------
    type : str
        Library name (``tooth_damage``, ``outer_race_defect``, ...).
    location : dict
        Location keys of the effect (``wheel``, ``tooth``, ``mesh``, ``bearing``, ``node``).
    parameters : dict
        The other effect fields given (severity included).
    onset_s : float
        Simulated time at which the fault appears, s.
    growth : Growth or None
    """

    type: str
    location: dict[str, Any] = field(default_factory=dict)
    parameters: dict[str, Any] = field(default_factory=dict)
    onset_s: float = 0.0
    growth: Growth | None = None

    # ------------------------------------------------------------------------------ effect view
    @property
    def effect_class(self) -> type[Effect]:
        ctor = EFFECT_TYPES[self.type]
        return getattr(ctor, "func", ctor)

    @property
    def severity_name(self) -> str:
        """The severity parameter: the effect's main (first fitted) parameter."""
        return self.effect_class.specs[0].name

    @property
    def initial_severity(self) -> float:
        """Severity at the onset (the value given, else the effect's default)."""
        v = self.parameters.get(self.severity_name)
        if v is None:
            v = getattr(self.effect(), self.severity_name)
        return float(v)

    @property
    def final_severity(self) -> float:
        return self.growth.final if self.growth is not None else self.initial_severity

    def effect(self, severity: float | None = None) -> Effect:
        """The library effect at ``severity`` (default the severity at onset): one implementation."""
        kw: dict[str, Any] = {**self.location, **self.parameters}
        if severity is not None:
            kw[self.severity_name] = severity
        return EFFECT_TYPES[self.type](**kw)

    def severity_at(self, t: Any) -> Any:
        """Severity at simulated time(s) ``t`` (0 before the onset; see the module docstring)."""
        import numpy as np

        t = np.asarray(t, dtype=float)
        s0 = self.initial_severity
        tau = t - self.onset_s
        if self.growth is None:
            s = np.full(t.shape, s0)
        else:
            x = np.clip(tau / self.growth.duration_s, 0.0, 1.0)
            if self.growth.law == "linear":
                s = s0 + (self.growth.final - s0) * x
            else:
                s = s0 * (self.growth.final / s0) ** x
        return np.where(tau >= 0.0, s, 0.0)

    def changes_config(self) -> bool:
        """Whether the effect modifies the assembled system (``modify_config``, e.g. tooth wear's
        backlash): such a fault applies when the fault list is applied and cannot grow."""
        return type(self.effect()).modify_config is not Effect.modify_config

    def as_dict(self) -> dict[str, Any]:
        """Flat form (the YAML entry)."""
        d: dict[str, Any] = {"type": self.type, **self.location, **self.parameters}
        d["onset_s"] = self.onset_s
        if self.growth is not None:
            d["growth"] = self.growth.as_dict()
        return d


# -------------------------------------------------------------------------------------- parsing
def _number(value: Any, path: str, lo: float, hi: float, lo_open: bool = False) -> float:
    rng = f"{lo:g} {'<' if lo_open else '<='} value <= {hi:g}"
    if isinstance(value, str):  # YAML 1.1 reads 1e-5 (no dot) as a string
        try:
            value = float(value)
        except ValueError:
            pass
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise FaultError(f"{path}: {value!r} is not a number (allowed {rng})")
    v = float(value)
    if not math.isfinite(v) or v < lo or v > hi or (lo_open and v == lo):
        raise FaultError(f"{path}: {value!r} is out of range (allowed {rng})")
    return v


def _integer(value: Any, path: str, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        if not (isinstance(value, float) and value.is_integer()):
            raise FaultError(f"{path}: {value!r} is not an integer (allowed {lo}..{hi})")
    v = int(value)
    if not lo <= v <= hi:
        raise FaultError(f"{path}: {value!r} is out of range (allowed {lo}..{hi})")
    return v


def _fields(cls: type[Effect]) -> dict[str, dataclasses.Field]:
    return {f.name: f for f in dataclasses.fields(cls) if f.name not in _INTERNAL_FIELDS and f.init}


def parse_fault(raw: Any, path: str = "faults[0]", cfg: Any = None) -> FaultSpec:
    """Validate one flat fault entry; ``cfg`` (a RigConfig) also checks the location exists."""
    if not isinstance(raw, Mapping):
        raise FaultError(f"{path}: expected a mapping such as {{type: tooth_damage, tooth: 5, depth: 0.3}}")
    types = fault_types()
    if "type" not in raw:
        raise FaultError(f"{path}.type: missing (allowed: {', '.join(types)})")
    ftype = raw["type"]
    if ftype in NOT_INJECTABLE:
        raise FaultError(
            f"{path}.type: {ftype!r} is not injectable: {NOT_INJECTABLE[ftype]} (allowed: {', '.join(types)})"
        )
    if ftype not in types:
        raise FaultError(f"{path}.type: {ftype!r} is not known (allowed: {', '.join(types)})")
    ctor = EFFECT_TYPES[ftype]
    cls = getattr(ctor, "func", ctor)
    fixed = set(getattr(ctor, "keywords", {}) or {})  # e.g. member=pinion, kind=outer
    fields = {k: f for k, f in _fields(cls).items() if k not in fixed}
    allowed = sorted(set(fields) | set(CONTROL_KEYS))
    unknown = [str(k) for k in raw if k not in fields and k not in CONTROL_KEYS]
    if unknown:
        raise FaultError(f"{path}: unknown key(s) {unknown} for {ftype} (allowed: {', '.join(allowed)})")
    specs = {s.name: s for s in cls.specs}
    location: dict[str, Any] = {}
    params: dict[str, Any] = {}
    for key, value in raw.items():
        if key in CONTROL_KEYS:
            continue
        kpath = f"{path}.{key}"
        default = fields[key].default
        if key == "wheel":
            if value not in ("pinion", "gear"):
                raise FaultError(f"{kpath}: {value!r} is not a wheel (allowed: pinion, gear)")
            location[key] = value
        elif key in LOCATION_KEYS:
            location[key] = _integer(value, kpath, 1, 10_000)
        elif key in specs and specs[key].role == "index":
            params[key] = _integer(value, kpath, int(specs[key].lower), int(specs[key].upper))
        elif key in specs:
            params[key] = _number(value, kpath, specs[key].lower, specs[key].upper)
        elif isinstance(default, bool):
            if not isinstance(value, bool):
                raise FaultError(f"{kpath}: {value!r} is not a boolean (allowed: true, false)")
            params[key] = value
        elif isinstance(default, int):
            params[key] = _integer(value, kpath, 0, 2**31 - 1)
        elif isinstance(default, float):
            params[key] = _number(value, kpath, -1e12, 1e12)
        else:
            params[key] = value
    for key in ("tooth",):  # location keys that are fitted indices in the library
        if key in params:
            location[key] = params.pop(key)
    onset = _number(raw.get("onset_s", 0.0), f"{path}.onset_s", 0.0, 1.0e7)
    spec = FaultSpec(ftype, location, params, onset, None)
    try:
        spec.effect()
    except (TypeError, ValueError) as exc:
        raise FaultError(f"{path}: {exc}") from None
    if onset > 0.0 and spec.changes_config():
        raise FaultError(
            f"{path}.onset_s: {onset:g}: {ftype} changes the assembled system (modify_config) and "
            "applies when the fault list is applied (allowed: 0)"
        )
    growth = raw.get("growth")
    if growth is not None:
        spec = dataclasses.replace(spec, growth=_parse_growth(growth, f"{path}.growth", spec, specs))
    if cfg is not None:
        check_location(spec, cfg, path)
    return spec


def _parse_growth(raw: Any, path: str, spec: FaultSpec, specs: Mapping) -> Growth:
    if not isinstance(raw, Mapping):
        raise FaultError(f"{path}: expected {{law: linear|exponential, final, duration_s}}")
    unknown = [str(k) for k in raw if k not in ("law", "final", "duration_s")]
    if unknown:
        raise FaultError(f"{path}: unknown key(s) {unknown} (allowed: law, final, duration_s)")
    for key in ("law", "final", "duration_s"):
        if key not in raw:
            raise FaultError(f"{path}.{key}: missing")
    law = raw["law"]
    if law not in GROWTH_LAWS:
        raise FaultError(f"{path}.law: {law!r} is not a growth law (allowed: {', '.join(GROWTH_LAWS)})")
    if spec.changes_config():
        raise FaultError(
            f"{path}: {spec.type} cannot grow: it changes the assembled system (modify_config), "
            "which applies when the fault list is applied"
        )
    sev = specs[spec.severity_name]
    if sev.role not in ("amplitude",) and spec.type != "tooth_damage":
        raise FaultError(
            f"{path}: {spec.type} cannot grow: its severity {spec.severity_name} does not enter linearly"
        )
    final = _number(raw["final"], f"{path}.final", sev.lower, sev.upper)
    duration = _number(raw["duration_s"], f"{path}.duration_s", 0.0, 1.0e7, lo_open=True)
    if law == "exponential" and not (spec.initial_severity > 0 and final > 0):
        raise FaultError(
            f"{path}.law: exponential growth needs {spec.severity_name} > 0 at onset and final > 0 "
            f"(got {spec.initial_severity:g} -> {final:g}); allowed from 0: linear"
        )
    return Growth(law, final, duration)


def check_location(spec: FaultSpec, cfg: Any, path: str = "faults[0]") -> None:
    """The location exists on the rig (tooth of the wheel, bearing, node, mesh): FaultError if not."""
    loc = spec.location
    nm = len(cfg.meshes)
    mesh = loc.get("mesh", 1)
    kind = spec.effect_class.__name__
    if kind in ("GearEccentricity", "ToothDamage", "ToothWear") or "mesh" in loc:
        if nm == 0:
            raise FaultError(f"{path}.type: {spec.type} needs a gear mesh; the rig has none")
        _integer(mesh, f"{path}.mesh", 1, nm)
    if "tooth" in loc or kind == "ToothDamage":
        m = cfg.meshes[mesh - 1]
        wheel = loc.get("wheel", "pinion")
        z = m.pinion_teeth if wheel == "pinion" else m.gear_teeth
        _integer(loc.get("tooth", 1), f"{path}.tooth", 1, int(z))
    if "bearing" in loc:
        _integer(loc["bearing"], f"{path}.bearing", 1, len(cfg.bearings))
    if "node" in loc:
        _integer(loc["node"], f"{path}.node", 1, cfg.n_nodes)


def parse_faults(raw: Any, cfg: Any = None, key: str = "faults") -> tuple[FaultSpec, ...]:
    """A fault list: ``{faults: [...]}``, a list of entries, or None (no faults)."""
    if raw is None:
        return ()
    if isinstance(raw, Mapping):
        extra = [str(k) for k in raw if k != "faults"]
        if extra:
            raise FaultError(f"{key}: unknown key(s) {extra} (expected a mapping with only 'faults')")
        raw = raw.get("faults")
        if raw is None:
            return ()
    if not isinstance(raw, list):
        raise FaultError(
            f"{key}: expected a list of faults such as [{{type: tooth_damage, tooth: 5, depth: 0.3}}]"
        )
    return tuple(parse_fault(item, f"{key}[{i}]", cfg) for i, item in enumerate(raw))


def load_faults(source: Any, cfg: Any = None) -> tuple[FaultSpec, ...]:
    """Faults from a YAML file path, YAML text, or the parsed structure (list or ``{faults: [...]}``)."""
    if isinstance(source, (str, Path)):
        text = str(source)
        path = Path(text)
        if not text.lstrip().startswith(("[", "{")) and "\n" not in text and path.is_file():
            text = path.read_text(encoding="utf-8")
        elif isinstance(source, Path) or (
            not text.lstrip().startswith(("[", "{", "faults")) and "\n" not in text
        ):
            raise FaultError(f"faults: {text!r} is neither a file nor a YAML fault list")
        try:
            source = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise FaultError(f"faults: not valid YAML ({exc})") from None
    return parse_faults(source, cfg)
