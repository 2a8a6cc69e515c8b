"""The CWRU bearing rig: model, .mat mapping, and calibration against the real recordings.

The Case Western Reserve University Bearing Data Center rig (``../shared/data/cwru/README.md``): a
2 hp induction motor whose shaft runs in an SKF 6205-2RS JEM deep-groove ball bearing at the drive
end (DE; seeded faults) and a 6203 at the fan end; accelerometers on the motor housing. The model is
``config/cwru_rig.yaml`` (a shaft on two bearings, the rotor as a disc, no gear). The DE accelerometer
is a ``housing_acceleration`` channel of bearing 1: the DE bearing force drives a single-DOF housing
mode (:class:`~gear_rotor_sim.calibration.residual.HousingSensor`) whose frequency is set from the
measured impulsive band. Only the envelope family is compared: the files carry one nominal speed
(motor slip makes the true speed differ by a few rpm), so phase-locked order features are not used.

References
----------
Smith, W. A., Randall, R. B. (2015). Rolling element bearing diagnostics using the Case Western
Reserve University data: a benchmark study. Mech. Syst. Signal Process. 64-65, 100-131.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from gear_rotor_sim.calibration.fit import CalibrationResult, Calibrator, FitSettings
from gear_rotor_sim.calibration.measurement import Measurement, load_mat
from gear_rotor_sim.calibration.residual import HousingSensor, ResidualSettings
from gear_rotor_sim.faults import BEARING_6205, candidate_effects

#: The subset in ../shared/data/cwru: file -> (condition, expected library effect or None).
CWRU_FILES: dict[str, tuple[str, str | None]] = {
    "normal_0.mat": ("healthy baseline", None),
    "IR007_0.mat": ("inner-race defect 0.007 in", "inner_race_defect"),
    "OR007_at6_0.mat": ("outer-race defect 0.007 in at 6 o'clock", "outer_race_defect"),
    "B007_0.mat": ("rolling-element defect 0.007 in", "ball_defect"),
}

#: Mapping of the CWRU .mat files onto the measurement contract (sidecar shape, ``key`` globs).
CWRU_MAPPING: dict[str, Any] = {
    "description": "CWRU bearing data, drive-end accelerometer, motor load 0 hp",
    "sample_rate_hz": 12000,
    "operating_point": {"speed_rpm": {"key": "X*RPM"}, "temperature_c": 25.0},
    "gearbox": "cwru_rig",
    "channels": [
        {
            "key": "X*_DE_time",
            "quantity": "housing_acceleration",
            "bearing": 1,
            "direction": "y",
            "unit": "g",
        },
    ],
    "files": {"normal_0.mat": {"sample_rate_hz": 48000}},
}

#: Comparison settings for the rig: envelope features up to 3.3 BPFI, 1 s Welch segments.
CWRU_SETTINGS = ResidualSettings(
    families=("envelope",), fit_gain=False, envelope_segment_s=1.0, envelope_min_hz=5.0
)


def cwru_data_dir(repo: str | Path | None = None) -> Path:
    """``<repo>/../shared/data/cwru`` (default: relative to this package's repository)."""
    root = Path(repo) if repo is not None else Path(__file__).resolve().parents[2]
    return (root / ".." / "shared" / "data" / "cwru").resolve()


def is_cwru_file(path: str | Path) -> bool:
    return Path(path).name in CWRU_FILES


def decimate_to(m: Measurement, rate_hz: float) -> Measurement:
    """Integer-factor decimation (zero-phase FIR anti-alias filter) to ``rate_hz``; recorded as an issue."""
    from scipy.signal import decimate

    q = round(m.sample_rate_hz / rate_hz)
    if q <= 1 or abs(m.sample_rate_hz / q - rate_hz) > 1e-6 * rate_hz:
        return m
    data = decimate(m.data, q, ftype="fir", axis=0, zero_phase=True)
    return Measurement(
        m.source,
        m.sample_rate_hz / q,
        m.t0,
        data,
        m.channels,
        m.operating_point,
        m.gearbox,
        [
            *m.issues,
            f"decimated from {m.sample_rate_hz:g} Hz to {m.sample_rate_hz / q:g} Hz "
            "(FIR anti-alias filter, zero phase) so that all CWRU files are analysed alike",
        ],
    )


def load_cwru(
    path: str | Path, duration_s: float | None = 3.0, rate_hz: float | None = 12000.0
) -> Measurement:
    """Load a CWRU file through :data:`CWRU_MAPPING`, at ``rate_hz`` (the 48 kHz baseline is
    decimated), keeping the first ``duration_s`` seconds."""
    m = load_mat(path, CWRU_MAPPING)
    if rate_hz is not None:
        m = decimate_to(m, rate_hz)
    return m.segment(0.0, duration_s) if duration_s is not None else m


def cwru_calibrator(measurement: Measurement, log: Any = None) -> Calibrator:
    """A :class:`Calibrator` for the rig: DE-bearing defects (6205), unbalance, misalignment."""
    from gear_rotor_sim.config import load_config

    cfg = load_config("cwru_rig")
    # the CWRU results (docs/calibration_cwru.md) were calibrated with a fixed 0.1 ms impact; their
    # forces are relative to the 1 kg housing model, so the duration is kept
    candidates = candidate_effects(cfg, BEARING_6205, bearings=(1,), bearing_pulse_s=1.0e-4)
    sensors = {
        c: HousingSensor(frequency_hz=3000.0, damping_ratio=0.05, mass_kg=1.0)
        for c in measurement.model_channels
        if "_housing_a" in c
    }
    return Calibrator(
        measurement,
        cfg,
        candidates,
        settings=CWRU_SETTINGS,
        fit_settings=FitSettings(),
        sensors=sensors,
        bearing_geometry=BEARING_6205,
        warmup_s=0.2,
        log=log,
        # envelope features only: they carry no information on the stiffness/damping scales
        baseline_sets=(),
    )


def calibrate_cwru(path: str | Path, duration_s: float | None = 3.0, log: Any = None) -> CalibrationResult:
    """Calibrate the rig model against one CWRU file."""
    return cwru_calibrator(load_cwru(path, duration_s), log).run()
