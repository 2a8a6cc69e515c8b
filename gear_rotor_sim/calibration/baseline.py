"""The baseline of a machine from a healthy reference record (``calibrate --baseline HEALTHY``).

A healthy record of the same machine, at any operating point, fixes what is a property of the
machine and of the model's fidelity to it; the record under diagnosis is then compared with that
updated model (``docs/calibration.md`` Sec. 8.1). What carries over from the reference to another
operating point, and why:

* **carried**: the baseline parameter sets fitted on the reference, i.e. the mesh stiffness and
  damping scales and the bearing (radial and tilt) stiffness and damping scales
  (``faults/baseline.py``; the axial bearing terms stay nominal, as they set the thermal axial load
  the static screening reads the temperature from). They scale
  the tooth-pair and bearing stiffnesses of Eq 13-15 and Eq 37, which do not depend on the speed;
  the temperature dependence stays in the model (E(T), thermal preload), so they also hold at
  another temperature;
* consequence of the carried mesh scale: the static transmission error ``b + F/k`` of the healthy
  machine is known at the record's operating point, so a DTE mean above it reads as flank wear
  (``candidates_wear_reference.py``; the wear is found before the ranking, like a screened
  temperature);
* where the teeth separate at the record's operating point, the carried scales are the centre of the
  rattle rules' sensitivity ensemble (``features_rattle.py``: the spread of the impact response over
  stiffness and damping around them is each order's model-form variance), and a mesh fault's path to
  the bearing channels stays a fitted nuisance (``fault_path.py``): the scales fix the linear lateral
  path, not the impact response. Measured at 8000 rpm with the 2000 rpm reference (mesh x1.31 / x1.7):
  a damaged tooth's response is five times smaller in power per unit depth than the nominal model's,
  so a tooth is claimed there only if the channels at the mesh see it
  (``docs/history/calibration_sessions.md`` Sec. 8.17);
* **carried**: the model-form tolerance of the mesh carriers (the median relative misfit of the
  carriers after the baseline update, ``carrier_tolerance``). It is dimensionless (a fraction of the
  carrier amplitude), so it applies unchanged to the carriers of another speed, whose absolute
  amplitudes differ;
* **not carried**: the sensor gain and transfer slope of each channel. The slope is fitted over the
  mesh-carrier band of a record (``f_mesh`` to ``3 f_mesh``), which moves with the speed (967-2900 Hz
  at 2000 rpm, 1450-4350 Hz at 3000 rpm for the paper's 29 teeth), so it is re-fitted on the record
  under diagnosis, as a nuisance, on the baseline-updated healthy model;
* **not carried**: the noise level (each record's own scatter between revolutions), the envelope
  bands (chosen on each record's own residual) and any temperature offset the static screening
  finds on the reference (an operating condition of that record, not of the machine).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gear_rotor_sim.calibration.measurement import Measurement
from gear_rotor_sim.calibration.residual import REFERENCE_STEPS_PER_MESH, ResidualSettings
from gear_rotor_sim.faults import BASELINE_TYPES, Effect


@dataclass(frozen=True)
class ReferenceBaseline:
    """What a healthy reference record fixes for the diagnosis of other records of the machine.

    Attributes
    ----------
    effects : tuple of Effect
        Baseline parameter sets fitted on the reference (mesh and bearing stiffness/damping scales).
    carrier_tolerance : float
        Relative model-form misfit of the mesh carriers after the baseline update (5-50 %).
    source : str
        The reference file (reported as ``baseline.source``).
    speed_rpm, temperature_c : float
        Declared operating point of the reference.
    error_before, error_after : float
        Main metric of the reference before and after the baseline update.
    notes : tuple of str
        Why the reference needs care (e.g. a temperature offset found on it, not carried).
    rattle_amplitude : dict, optional
        Where the reference's healthy model's teeth separate: the DTE amplitude at the first mesh order
        of the reference record (``record_m``) and of the reference-updated model (``model_m``), the
        record's noise (``noise_m``) and the model amplitude's spread over the baseline ensemble
        (``spread_m``), m. Their ratio is the machine's rattle amplitude scale against the model's,
        which the wear rule at rattle uses (``candidates_wear_rattle.rattle_scale``; Sec. 8.26).
    """

    effects: tuple[Effect, ...]
    carrier_tolerance: float
    source: str
    speed_rpm: float
    temperature_c: float
    error_before: float
    error_after: float
    notes: tuple[str, ...] = field(default_factory=tuple)
    rattle_amplitude: dict[str, float] | None = None

    def calibrator_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :class:`~gear_rotor_sim.calibration.fit.Calibrator` that hold it."""
        return {
            "baseline": list(self.effects),
            "baseline_source": self.source,
            "carrier_tolerance": self.carrier_tolerance,
            "baseline_reference": self.as_dict(),
        }

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary (``baseline.reference`` of the diagnosis)."""
        return {
            "source": self.source,
            "operating_point": {"speed_rpm": self.speed_rpm, "temperature_c": self.temperature_c},
            "updates": [
                {"name": e.name, "label": e.label, "parameters": e.parameters()} for e in self.effects
            ],
            "carrier_tolerance": self.carrier_tolerance,
            "error_before": self.error_before,
            "error_after": self.error_after,
            "carried": ["baseline parameter sets", "carrier_tolerance"],
            "refitted_per_record": ["sensor gains", "transfer slopes", "noise", "envelope bands"],
            "notes": list(self.notes),
            **({"rattle_amplitude": dict(self.rattle_amplitude)} if self.rattle_amplitude else {}),
        }

    def save(self, path: str | Path) -> Path:
        """Write the reference as JSON (``calibrate --save-baseline``; read by :func:`load_reference`)."""
        p = Path(path)
        p.write_text(json.dumps({"format": REFERENCE_FORMAT, **self.as_dict()}, indent=1))
        return p


#: ``format`` tag of a saved reference baseline
REFERENCE_FORMAT = "gear_rotor_sim.reference_baseline/1"
#: fields of ``rattle_amplitude`` (optional; a reference where the teeth separate, Sec. 8.26)
RATTLE_AMPLITUDE_KEYS = ("record_m", "model_m", "noise_m", "spread_m")


def load_reference(path: str | Path) -> ReferenceBaseline:
    """Read a reference baseline written by :meth:`ReferenceBaseline.save`.

    Raises
    ------
    ValueError
        Naming the file and the field when the file is not such a reference or a value is out of range.
    """
    p = Path(path)
    try:
        d = json.loads(p.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{p}: not a readable JSON reference baseline ({exc})") from exc
    if not isinstance(d, dict) or d.get("format") != REFERENCE_FORMAT:
        raise ValueError(f"{p}: field 'format' must be {REFERENCE_FORMAT!r} (written by --save-baseline)")
    by_name = {t.name: t for t in BASELINE_TYPES}
    effects: list[Effect] = []
    for i, u in enumerate(d.get("updates") or []):
        where = f"{p}: updates[{i}]"
        if not isinstance(u, dict) or u.get("name") not in by_name:
            raise ValueError(f"{where}.name must be one of {sorted(by_name)}")
        cls = by_name[u["name"]]
        params = u.get("parameters") or {}
        kw: dict[str, float] = {}
        for spec in cls.specs:
            v = params.get(spec.name)
            if not isinstance(v, int | float) or not (spec.lower <= float(v) <= spec.upper):
                raise ValueError(
                    f"{where}.parameters.{spec.name} = {v!r}: must be a number in "
                    f"[{spec.lower}, {spec.upper}]"
                )
            kw[spec.name] = float(v)
        effects.append(cls(**kw))
    ct = d.get("carrier_tolerance")
    if not isinstance(ct, int | float) or not (0.0 < float(ct) <= 1.0):
        raise ValueError(f"{p}: field 'carrier_tolerance' = {ct!r}: must be a number in (0, 1]")
    op = d.get("operating_point") or {}
    ra = d.get("rattle_amplitude")
    if ra is not None:
        if not isinstance(ra, dict):
            raise ValueError(f"{p}: field 'rattle_amplitude' must be an object")
        for k in RATTLE_AMPLITUDE_KEYS:
            v = ra.get(k)
            lo_ok = v is not None and isinstance(v, int | float) and math.isfinite(v)
            if not lo_ok or not (v > 0 if k in ("record_m", "model_m") else v >= 0):
                raise ValueError(
                    f"{p}: field 'rattle_amplitude.{k}' = {v!r}: must be a finite number "
                    + ("> 0" if k in ("record_m", "model_m") else ">= 0")
                    + " (m)"
                )
        ra = {k: float(ra[k]) for k in RATTLE_AMPLITUDE_KEYS}

    def num(x: Any) -> float:
        return float(x) if isinstance(x, int | float) else math.nan

    return ReferenceBaseline(
        effects=tuple(effects),
        carrier_tolerance=float(ct),
        source=str(d.get("source", p)),
        speed_rpm=num(op.get("speed_rpm")),
        temperature_c=num(op.get("temperature_c")),
        error_before=num(d.get("error_before")),
        error_after=num(d.get("error_after")),
        notes=tuple(str(n) for n in d.get("notes") or []),
        rattle_amplitude=ra,
    )


def fit_reference_baseline(
    reference: Measurement,
    *,
    source: str | None = None,
    settings: ResidualSettings | None = None,
    steps_per_mesh: int = REFERENCE_STEPS_PER_MESH,
    log: Callable[[str], None] | None = None,
    **calibrator_kw: Any,
) -> ReferenceBaseline:
    """Fit the baseline parameter sets alone on a healthy reference record.

    Parameters
    ----------
    reference : Measurement
        Healthy record of the machine (any operating point).
    source : str, optional
        Name reported as the baseline source (default ``reference.source``).
    settings : ResidualSettings, optional
        Feature settings (a copy is used).
    steps_per_mesh : int
        Integration steps per mesh period of the model runs.
    log : callable, optional
        Progress messages.
    **calibrator_kw
        Passed to :class:`~gear_rotor_sim.calibration.fit.Calibrator` (e.g. ``cfg``).

    Returns
    -------
    ReferenceBaseline
    """
    from gear_rotor_sim.calibration.candidates_wear_rattle import rattle_reference_amplitude
    from gear_rotor_sim.calibration.fit import Calibrator, FitSettings

    st = ResidualSettings(**vars(settings)) if settings is not None else ResidualSettings()
    cal = Calibrator(
        reference,
        settings=st,
        fit_settings=FitSettings(max_effects=0),
        steps_per_mesh=steps_per_mesh,
        reference_numerics=True,
        log=log,
        **calibrator_kw,
    )
    r = cal.run()
    notes = []
    if r.effects:
        found = ", ".join(f"{e.label} {e.parameters}" for e in r.effects)
        notes.append(
            f"the reference record itself shows {found}: not carried (an operating condition of that "
            "record); its baseline was fitted with it"
        )
    # its sets at the bounds of their plausible range (baseline_bounds.py): carried, and said so
    notes += [n for n in r.notes if n.startswith("at bound: baseline ")]
    op = cal.m.operating_point  # the measured speed where the declared one was corrected (speed_check.py)
    notes += [
        i
        for i in cal.m.issues
        if i.startswith(("operating_point.speed_rpm", "operating_point.output_torque_nm"))
    ]
    return ReferenceBaseline(
        effects=tuple(e for e in r.baseline_effects if isinstance(e, BASELINE_TYPES)),
        carrier_tolerance=float(r.model_form.get("carrier_tolerance", st.tolerance)),
        source=str(source if source is not None else reference.source),
        speed_rpm=float(op.speed_rpm),
        temperature_c=float(op.temperature_c),
        error_before=float(r.error_before),
        error_after=float(r.error_after),
        notes=tuple(notes),
        rattle_amplitude=rattle_reference_amplitude(cal),
    )
