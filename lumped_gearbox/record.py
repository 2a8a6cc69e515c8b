"""Measurement-like records: sensor noise, gain errors, and the CSV + YAML sidecar + truth files.

The files follow the measured-data contract of ``docs/calibration.md`` (issue 6): ``<stem>.csv``
(``time_s`` then one column per channel), ``<stem>.yaml`` (rate, declared operating point, gearbox,
channels with quantity/location/unit) and, for benchmarks, ``<stem>.truth.json`` (the faults that
were injected, the actual temperature, noise levels and gains).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from lumped_gearbox.daq import DAQ_SUBSTEPS, HOUSING_CHANNELS, acquire
from lumped_gearbox.faults import Fault, fault_truth, parse_fault
from lumped_gearbox.housing import housing_acceleration
from lumped_gearbox.load_profile import LoadProfile
from lumped_gearbox.model import L_TA
from lumped_gearbox.params import Gearbox
from lumped_gearbox.pitch import PitchErrors
from lumped_gearbox.sensors import SensorFilter, apply_chain, sensor_chains
from lumped_gearbox.simulate import CHANNELS, build, run
from lumped_gearbox.speed_profile import SpeedProfile

SIDECAR_CHANNELS = [
    {"column": "dte", "quantity": "dynamic_transmission_error", "unit": "m"},
    {"column": "bearing2_fx", "quantity": "bearing_force", "bearing": 2, "direction": "x", "unit": "N"},
    {"column": "bearing2_fy", "quantity": "bearing_force", "bearing": 2, "direction": "y", "unit": "N"},
    {"column": "bearing2_fz", "quantity": "bearing_force", "bearing": 2, "direction": "z", "unit": "N"},
    {"column": "node5_ax", "quantity": "acceleration", "node": 5, "direction": "x", "unit": "m/s^2"},
    {"column": "node5_ay", "quantity": "acceleration", "node": 5, "direction": "y", "unit": "m/s^2"},
]
SIDECAR_HOUSING = [
    {"column": c, "quantity": "housing_acceleration", "bearing": 2, "direction": c[-1], "unit": "m/s^2"}
    for c in HOUSING_CHANNELS
]

#: the two documented operating points (docs/independent_data.md): teeth in contact / rattling
CONTACT_RPM = 3000.0
RATTLE_RPM = 8000.0
#: how a record is sampled: "daq" (converged step, anti-aliasing low-pass, then sampling; the default
#: since session 13) or "point" (RK4 at 8 substeps, every 8th state, no low-pass: sessions 1-12)
SAMPLINGS = ("daq", "point")
POINT_SUBSTEPS = 8


@dataclass
class Record:
    """A noisy record and its ground truth."""

    time_s: np.ndarray
    data: dict[str, np.ndarray]
    speed_rpm: float
    temperature_c: float  # declared
    faults: list[Fault]
    noise_fraction: dict[str, float]
    gain: dict[str, float]
    seed: int
    clean: dict[str, np.ndarray] = field(repr=False, default_factory=dict)
    actual_temperature_c: float = 0.0
    contact_loss_fraction: float = 0.0
    sampling: str = "daq"
    substeps: int = DAQ_SUBSTEPS
    #: the input speed's drift and fluctuation about the declared (mean) speed; None: constant
    speed_profile: SpeedProfile | None = None
    #: the output torque's fluctuation about its mean (load_profile.py); None: constant
    load_profile: LoadProfile | None = None
    #: manufacturing pitch errors of the wheels (pitch.py); None: exact teeth
    pitch_errors: PitchErrors | None = None
    #: the sensors' own filters per column (sensors.py); empty: flat sensors
    sensors: dict[str, tuple[SensorFilter, ...]] = field(default_factory=dict)
    #: the wheels' tooth counts (for the pitch errors' truth)
    teeth: tuple[int, int] = (29, 49)

    def truth(self) -> dict[str, Any]:
        out = {
            "generator": "lumped_gearbox",
            "speed_rpm": self.speed_rpm,
            "declared_temperature_c": self.temperature_c,
            "actual_temperature_c": self.actual_temperature_c,
            "faults": [fault_truth(f) for f in self.faults],
            "noise_fraction": self.noise_fraction,
            "gain": self.gain,
            "seed": self.seed,
            "contact_loss_fraction": self.contact_loss_fraction,
            "sampling": self.sampling,
            "substeps": self.substeps,
        }
        if self.speed_profile is not None:
            out["speed_profile"] = self.speed_profile.truth()
        if self.load_profile is not None:
            out["load_profile"] = self.load_profile.truth()
        if self.pitch_errors is not None:
            out["pitch_errors"] = self.pitch_errors.truth(*self.teeth)
        if self.sensors:
            out["sensors"] = {c: [f.truth() for f in chain] for c, chain in self.sensors.items()}
        return out


def make_record(
    speed_rpm: float = CONTACT_RPM,
    temperature_c: float = 25.0,
    faults: Sequence[Fault | str] = (),
    duration_s: float = 2.0,
    sample_rate_hz: float = 20000.0,
    noise: tuple[float, float] = (0.02, 0.05),
    gain_error: float = 0.03,
    seed: int = 0,
    gearbox: Gearbox | None = None,
    housing: bool = False,
    sampling: str = "daq",
    substeps: int | None = None,
    speed_profile: SpeedProfile | dict[str, float] | None = None,
    load_profile: LoadProfile | dict[str, float] | None = None,
    pitch_errors: PitchErrors | dict[str, Any] | None = None,
    sensors: Mapping[str, SensorFilter | Sequence[SensorFilter]] | None = None,
) -> Record:
    """Simulate the lumped gearbox and add sensor noise and gain errors.

    Parameters
    ----------
    speed_rpm, temperature_c : float
        Declared input speed and steady temperature (a ``temperature_offset`` fault makes the actual
        temperature differ).
    faults : sequence of Fault or str
        Fault objects or CLI strings (``"tooth_damage:wheel=gear,tooth=5,depth=0.3"``).
    noise : (float, float)
        Range of the white-noise standard deviation per channel, as a fraction of the channel's RMS
        about its mean (at least a tenth of the largest RMS among the channels of the same
        quantity); each channel draws its own fraction.
    gain_error : float
        Each channel is multiplied by a gain drawn uniformly in ``1 +- gain_error``.
    seed : int
        Seed of the noise and gain draws.
    housing : bool
        Also record the housing accelerations at bearing 2 (``bearing2_housing_ax/ay``,
        :mod:`lumped_gearbox.housing`).
    sampling : {"daq", "point"}
        ``"daq"`` (default): the data-acquisition chain of :mod:`lumped_gearbox.daq`, RK4 at
        ``substeps`` (default 32) steps per sample, every channel low-passed (linear-phase FIR,
        passband to 0.4 fs, >= 80 dB from 0.5 fs) before sampling. ``"point"``: the chain of
        sessions 1-12, RK4 at ``substeps`` (default 8) and every ``substeps``-th state kept without
        a low-pass (content above ``fs / 2`` folds into the record).
    substeps : int, optional
        RK4 steps per output sample (default: 32 for ``"daq"``, 8 for ``"point"``).
    speed_profile : SpeedProfile or dict, optional
        An input speed that varies within the record (:mod:`lumped_gearbox.speed_profile`):
        ``drift_pct`` (-10 .. 10, the change over the record, centred), ``fluctuation_pct`` (0 .. 5)
        at ``fluctuation_hz`` (0 .. 400), ``fluctuation_phase_rad``; ``speed_rpm`` is the mean. The
        sidecar still declares ``speed_rpm``; the truth file holds the profile. None (default): the
        constant speed of every earlier record (bit for bit).
    load_profile : LoadProfile or dict, optional
        An output torque that fluctuates about the gearbox's ``output_torque_nm`` (its mean, the torque
        the sidecar declares; :mod:`lumped_gearbox.load_profile`): ``amplitude_pct`` (0 .. 50) at
        ``frequency_hz`` (0 .. 200) or locked to the gear at ``gear_order`` (0 .. 10), ``phase_rad``. The
        truth file holds the profile. None (default): the constant torque of every earlier record (bit
        for bit).
    pitch_errors : PitchErrors or dict, optional
        Manufacturing pitch errors on every tooth (:mod:`lumped_gearbox.pitch`): ``f_pt_um`` (RMS single
        pitch deviation, 0 .. 30 um), ``runout_um`` (once-per-turn part, 0 .. 50 um), ``seed``, ``wheels``.
        The truth file holds the drawn flank positions. None (default) or all-zero errors: exact teeth, the
        records of every earlier table bit for bit.
    sensors : mapping, optional
        Column -> a sensor's own filter or filters (:mod:`lumped_gearbox.sensors`: an AC-coupled force
        sensor's high-pass, an accelerometer's low-pass), applied before the anti-aliasing low-pass (``daq``)
        or on the samples (``point``). The sidecar does not say it; the truth file does.

    Raises
    ------
    ValueError
        Naming the field: ``sampling`` not one of :data:`SAMPLINGS`, ``substeps`` below 1, a
        ``speed_profile`` or ``load_profile`` field outside its range, and the operating point and fault
        checks of :func:`simulate.build`.
    """
    if sampling not in SAMPLINGS:
        raise ValueError(f"sampling: {sampling!r} not one of {', '.join(SAMPLINGS)}")
    if substeps is None:
        substeps = DAQ_SUBSTEPS if sampling == "daq" else POINT_SUBSTEPS
    if not (isinstance(substeps, int) and substeps >= 1):
        raise ValueError(f"substeps: {substeps!r} must be an integer >= 1")
    gb = gearbox or Gearbox()
    fl = [parse_fault(f) if isinstance(f, str) else f for f in faults]
    setup = build(gb, speed_rpm, temperature_c, fl)
    if isinstance(speed_profile, dict):
        speed_profile = SpeedProfile(**speed_profile)
    if speed_profile is not None:
        setup.profile = speed_profile.vector(duration_s)
    if isinstance(load_profile, dict):
        load_profile = LoadProfile(**load_profile)
    if load_profile is not None:
        setup.load[L_TA:] = load_profile.vector()
    if isinstance(pitch_errors, dict):
        pitch_errors = PitchErrors(**pitch_errors)
    if pitch_errors is not None:
        e = pitch_errors.vector(gb.z1, gb.z2, gb.pressure_angle_rad)
        setup.pitch = e if np.any(e != 0.0) else setup.pitch
    channels = CHANNELS + HOUSING_CHANNELS if housing else CHANNELS
    chains = sensor_chains(sensors, channels)
    if sampling == "daq":
        clean = acquire(setup, duration_s, sample_rate_hz, substeps, housing=housing, sensors=chains)
    else:
        clean = run(setup, duration_s, sample_rate_hz, substeps)
        if housing:
            for c in HOUSING_CHANNELS:
                clean[c] = housing_acceleration(clean[f"bearing2_f{c[-1]}"], sample_rate_hz)
        for c, chain in chains.items():
            clean[c] = apply_chain(clean[c], sample_rate_hz, chain)
    rng = np.random.default_rng(seed)
    data: dict[str, np.ndarray] = {}
    nf: dict[str, float] = {}
    gains: dict[str, float] = {}
    for ch in channels:
        x = clean[ch]
        frac = float(rng.uniform(*noise))
        g = float(rng.uniform(1.0 - gain_error, 1.0 + gain_error))
        # noise floor: a tenth of the largest RMS among the channels of the same quantity, so that a
        # channel without dynamic content (the axial force of an aligned gearbox) is not noise-free
        same = [c for c in channels if c[:-1] == ch[:-1]]
        floor = 0.1 * max(float(np.std(clean[c])) for c in same)
        sigma = frac * max(float(np.std(x)), floor)
        data[ch] = g * x + rng.normal(0.0, sigma, x.size)
        nf[ch], gains[ch] = frac, g
    fm = clean["mesh_force"]
    loss = float(np.mean(np.abs(fm) <= 1e-9 * max(1.0, float(np.max(np.abs(fm))))))
    return Record(
        clean["time_s"],
        data,
        speed_rpm,
        temperature_c,
        fl,
        nf,
        gains,
        seed,
        clean,
        setup.temperature_c,
        loss,
        sampling,
        substeps,
        speed_profile,
        load_profile,
        pitch_errors,
        chains,
        (gb.z1, gb.z2),
    )


def write_record(path: str | Path, record: Record | None = None, **kwargs: Any) -> Path:
    """Write ``<path>.csv``, the ``.yaml`` sidecar and ``.truth.json``; returns the CSV path.

    Either pass a :class:`Record` or the keyword arguments of :func:`make_record`.
    """
    rec = record if record is not None else make_record(**kwargs)
    path = Path(path).with_suffix(".csv")
    path.parent.mkdir(parents=True, exist_ok=True)
    names = [c for c in (*CHANNELS, *HOUSING_CHANNELS) if c in rec.data]
    cols = [rec.time_s] + [rec.data[c] for c in names]
    np.savetxt(
        path,
        np.column_stack(cols),
        delimiter=",",
        header=",".join(("time_s", *names)),
        comments="",
        fmt="%.9g",
    )
    fs = 1.0 / float(rec.time_s[1] - rec.time_s[0])
    sidecar = {
        "sample_rate_hz": round(fs, 6),
        "operating_point": {
            "speed_rpm": float(rec.speed_rpm),
            "temperature_c": float(rec.temperature_c),
            "output_torque_nm": 200.0,
        },
        "gearbox": "paper_sun2021",
        "description": (
            f"lumped_gearbox (independent lumped-parameter model, {rec.sampling} sampling), "
            "docs/independent_data.md"
        ),
        "channels": SIDECAR_CHANNELS + [c for c in SIDECAR_HOUSING if c["column"] in rec.data],
    }
    with open(path.with_suffix(".yaml"), "w", encoding="utf-8") as fh:
        yaml.safe_dump(sidecar, fh, sort_keys=False)
    with open(path.with_suffix(".truth.json"), "w", encoding="utf-8") as fh:
        json.dump(rec.truth(), fh, indent=2)
    return path
