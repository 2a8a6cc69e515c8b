"""The declared speed checked against the record's own mesh lines, corrected where it is not the true
one (issue 11: effects nobody declared; docs/calibration.md Sec. 2 "Speed check").

:func:`check_operating_speed` reads the input-shaft speed from the record
(:func:`~gear_rotor_sim.calibration.speed_estimate.estimate_speed`) and compares it with the declared
``operating_point.speed_rpm``:

* **agreement** (``|measured - declared| <= max(K_SIGMA sigma, tolerance)``): the measurement is
  returned unchanged (the same object): nothing else in the calibration changes;
* **a correction** (beyond that, up to ``PLAUSIBLE`` of the declared speed: an induction motor's
  slip, a tachometer's error, a sample clock off by a percent, which the mesh lines cannot tell from a
  speed error and the issue names as the other reading, ``sample_clock.py``): the measurement is
  returned with the measured speed, so that the model runs and every synchronous feature (orders,
  combs, synchronous average, the non-synchronous envelope, the hunting-period window) use it; a line
  in the record's ``issues`` names the declared and measured speeds, and the calibration reports an
  ``operating_speed`` entry in ``baseline_updates`` with the healthy model's error at the declared
  and at the measured speed (:func:`speed_entry`): an operating-point correction, never a fault;
* **beyond** ``PLAUSIBLE``: a :class:`MeasurementError` naming ``operating_point.speed_rpm`` (a wrong
  sidecar or gearbox, not a slip).

Before that, a speed that varies within the record is tracked and the record resampled to uniform
shaft angle at its mean speed (``order_tracking.py``); the mean is then checked as above.

The tolerance is the speed error that changes no synchronous feature by more than 0.1 %: over the
record's ``n_rev`` input revolutions the highest order feature ``K = 3 z + 6`` (``residual.py``) drifts
in phase by ``2 pi K eps n_rev`` at a relative error ``eps``, and its synchronous average keeps
``sinc(pi K eps n_rev) ~ 1 - (pi K eps n_rev)^2 / 6`` of its amplitude; ``1e-3`` of loss gives
``eps = sqrt(6e-3) / (pi K n_rev)`` (3000 rpm, 2 s: 2.6e-6, 0.008 rpm). On the benchmark's 2 s records
the estimate's ``K_SIGMA`` sigma is 2e-4 to 5e-4 rpm, well inside that tolerance, so in practice the
tolerance decides: an error the record resolves but that moves no synchronous feature by 0.1 % is left
alone, and every larger one is corrected.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from gear_rotor_sim.calibration.measurement import Measurement, MeasurementError
from gear_rotor_sim.calibration.order_tracking import SpeedVariation, check_speed_variation
from gear_rotor_sim.calibration.sample_clock import clock_alternative
from gear_rotor_sim.calibration.speed_estimate import (
    SpeedEstimate,
    estimate_speed,
    mesh_orders_per_input,
    slowest_shaft_ratio,
)

#: a difference within this many sigma of the estimate is agreement
K_SIGMA = 5.0
#: largest relative speed error read as an operating-point error (slip, tachometer, clock); beyond it
#: the declared speed is refused
PLAUSIBLE = 0.10
#: relative loss of the highest synchronous order's amplitude that the tolerance allows
FEATURE_LOSS = 1e-3
#: orders beyond the last mesh harmonic in the order features (``m z +- 6``)
ORDER_MARGIN = 6


@dataclass
class SpeedCheck:
    """Outcome of :func:`check_operating_speed`.

    Attributes
    ----------
    estimate : SpeedEstimate
    tolerance_rpm : float
        Feature tolerance (module docstring).
    corrected : bool
        Whether the calibration runs at the measured speed.
    declared : Measurement
        The measurement as loaded (declared speed; in the angle domain when its speed varies).
    variation : SpeedVariation or None
        The varying-speed check run first (``order_tracking.py``).
    """

    estimate: SpeedEstimate
    tolerance_rpm: float
    corrected: bool
    declared: Measurement
    variation: SpeedVariation | None = None

    @property
    def limit_rpm(self) -> float:
        """Largest difference read as agreement."""
        return max(K_SIGMA * self.estimate.sigma_rpm, self.tolerance_rpm)

    def describe(self) -> str:
        """One line naming the declared and measured speeds."""
        e = self.estimate
        rel = 100.0 * (e.measured_rpm - e.declared_rpm) / e.declared_rpm
        return (
            f"operating_point.speed_rpm: declared {e.declared_rpm:.6g} rpm, the record's mesh lines give "
            f"{e.measured_rpm:.8g} +- {e.sigma_rpm:.2g} rpm ({rel:+.3g} %, {e.n_lines} lines)"
        )


def feature_tolerance_rpm(cfg: Any, speed_rpm: float, duration_s: float) -> float:
    """Speed error (rpm) that keeps the highest synchronous order within ``FEATURE_LOSS`` of its
    amplitude over a record of ``duration_s`` (module docstring)."""
    z = max((m.pinion_teeth for m in getattr(cfg, "meshes", ())), default=0)
    k_max = 3 * z + ORDER_MARGIN
    n_rev = speed_rpm / 60.0 * duration_s
    if not (k_max > 0 and n_rev > 0):
        return math.inf
    return speed_rpm * math.sqrt(6.0 * FEATURE_LOSS) / (math.pi * k_max * n_rev)


def check_operating_speed(measurement: Measurement, cfg: Any) -> tuple[Measurement, SpeedCheck | None]:
    """The measurement to calibrate: at the measured speed where it disagrees with the declared one.

    Parameters
    ----------
    measurement : Measurement
        As loaded.
    cfg : RigConfig
        The rig's model (its meshes give the lines).

    Returns
    -------
    (Measurement, SpeedCheck or None)
        ``measurement`` itself and None for a rig without a mesh (CWRU: nothing is estimated);
        otherwise the check, and the measurement at the measured speed if it is corrected.

    Raises
    ------
    MeasurementError
        The measured speed differs from the declared one by more than ``PLAUSIBLE``.
    """
    orders = mesh_orders_per_input(cfg)
    if not orders:
        return measurement, None
    # a speed varying within the record: read in the angle domain at its mean speed first
    measurement, variation = check_speed_variation(measurement, cfg)
    declared = measurement.operating_point.speed_rpm
    est = estimate_speed(
        measurement.data, measurement.sample_rate_hz, declared, orders, slowest_shaft_ratio(cfg)
    )
    tol = feature_tolerance_rpm(cfg, declared, measurement.duration_s)
    check = SpeedCheck(est, tol, False, measurement, variation)
    if est.measured_rpm is None:
        measurement.issues.append(
            f"operating_point.speed_rpm: not checked against the record ({est.reason}); the declared "
            f"{declared:g} rpm is used"
        )
        return measurement, check
    diff = est.measured_rpm - declared
    if abs(diff) <= check.limit_rpm:
        return measurement, check
    if abs(diff) > PLAUSIBLE * declared:
        raise MeasurementError(
            f"{measurement.source}: {check.describe()}: beyond the {100 * PLAUSIBLE:g} % of a motor's "
            "slip or a tachometer's error; check operating_point.speed_rpm and the gearbox"
        )
    check.corrected = True
    issue = (
        f"{check.describe()}; the model and the synchronous features use the measured speed; "
        + clock_alternative(declared, est.measured_rpm, measurement.sample_rate_hz)
    )
    if abs(est.drift_z) > K_SIGMA and est.halves_rpm is not None:
        issue += (
            f"; the speed is not constant over the record (halves {est.halves_rpm[0]:.8g} and "
            f"{est.halves_rpm[1]:.8g} rpm): their mean is used"
        )
    op = dataclasses.replace(measurement.operating_point, speed_rpm=float(est.measured_rpm))
    return dataclasses.replace(measurement, operating_point=op, issues=[*measurement.issues, issue]), check


def _nominal_error(cal: Any) -> float:
    """Error of a set-up calibrator's healthy (baseline-held) model, its transfer slopes fitted on it;
    the slopes are left unheld again (as ``Calibrator.run`` finds them)."""
    feats = cal._features(cal.base_raw)
    cal._refit_transfer(feats)
    err = float(cal.cmp.score(feats).error)
    cal.cmp.fix_transfer(None)
    return err


def correction_errors(cal: Any) -> tuple[float, float] | None:
    """The healthy (baseline-held) model's error at the declared and at the measured speed, scored
    alike (transfer slopes fitted, before the rattle rules and the static screen) on a calibrator
    ``cal`` set up at the measured speed; None unless ``cal``'s speed was corrected. The line naming
    both speeds and errors goes into ``cal.notes``."""
    check = getattr(cal, "speed", None)
    if check is None or not check.corrected:
        return None
    from gear_rotor_sim.calibration.fit import Calibrator

    c = Calibrator(
        check.declared,
        cfg=cal.runner.cfg,
        settings=dataclasses.replace(cal.settings),
        sensors=dict(cal.runner.sensors or {}),
        warmup_s=cal.runner.warmup_s,
        steps_per_mesh=cal.runner.steps_per_mesh,
        baseline=None if cal.fit_baseline else list(cal.baseline),
        reference_numerics=cal.reference_numerics,
        rattle_rules=cal.rattle_rules,
        speed_check=False,
    )
    c._setup()
    before, after = _nominal_error(c), _nominal_error(cal)
    cal.notes.append(
        f"operating_speed: {check.describe()}; the healthy model's error {before:.4g} at the declared "
        f"speed, {after:.4g} at the measured speed (an operating-point correction, not an effect)"
    )
    cal.log(cal.notes[-1])
    return before, after


def speed_entry(check: SpeedCheck, error_declared: float, error_measured: float) -> Any:
    """The ``operating_speed`` entry of ``baseline_updates`` (an operating-point correction, never an
    effect): the declared and measured speeds, the estimate's sigma, and the healthy model's error at
    the declared (``error_before``) and at the measured speed (``error_after``)."""
    from gear_rotor_sim.calibration.fit_types import FoundEffect

    e = check.estimate
    return FoundEffect(
        "operating_speed",
        "operating_speed",
        {"speed_rpm": e.measured_rpm, "declared_speed_rpm": e.declared_rpm},
        {"speed_rpm": e.sigma_rpm},
        1.0,
        math.nan,
        math.nan,
        float(error_declared),
        float(error_measured),
        None,
        "baseline",
    )
