"""Whether a held reference's machine describes the record's operating point (``calibrate --baseline``;
issue 11: the baseline's plausibility; docs/calibration.md Sec. 8.1; history Sec. 8.77).

Physics. A reference fit carries its mesh and bearing stiffness and damping scales to every other speed as
properties of the machine (Eqs 13-15, 37: they do not depend on the speed). That holds only where the fit
identified them as such. Where a mesh harmonic of the reference record lies near the FE model's mesh mode, the
chi^2 over the mesh scale is bimodal: the scale moves the mode to either side of the harmonic, and on the
blind set's references at 5851-6109 rpm (second harmonic 5656-5905 Hz, the FE model's mode 5180 Hz at the
nominal mesh, the generator's 6420 Hz) the lower basin wins: x0.36-0.60, the FE mode put at 1.2-1.5 times
the mesh frequency, between the first two harmonics, where the generator's is at 2.2-2.3 times
(``benchmarks/reference_mesh_scan.py``). Such a scale fits the reference's resonance and nothing else: on a
healthy record of the same machine at 2970 rpm the chi^2 falls monotonically from x0.36 (order family
4792 per feature) to x2 (266), the nominal x1 at 488. Carried there, the machine is worse than the nominal one
and a fault is judged against it (blind10: a pinion misalignment that passes without a reference, 44.1 ->
15.4 with nothing named).

Rule (:func:`reference_point`). Before the diagnosis the record is scored on the held machine and on the
nominal machine (one run, the sensor gains and slopes refitted on each, the same comparison): if the held
machine's error exceeds :data:`HELD_OVER_NOMINAL` times the nominal machine's, the reference's sets do not
describe this operating point, and the record is diagnosed as without a reference (its own baseline fitted),
the report saying why (:func:`rerun_off_point`: an ``issues`` entry and ``baseline.reference.set_aside``).
A fault is missing from both models alike, so the ratio reads the machine, not the fault.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.calibration.fit_types import CalibrationResult
    from gear_rotor_sim.calibration.residual import Score

#: the held machine may score the record at most this many times the nominal machine's error
HELD_OVER_NOMINAL = 1.5


@dataclass(frozen=True)
class ReferencePoint:
    """The record's error on the held reference machine and on the nominal machine (same comparison)."""

    error_held: float
    error_nominal: float
    speed_rpm: float
    reference_speed_rpm: float

    @property
    def ratio(self) -> float:
        """Held over nominal error."""
        return self.error_held / self.error_nominal if self.error_nominal > 0 else float("inf")

    def describes(self) -> bool:
        """Whether the held machine describes the record's point (ratio at most :data:`HELD_OVER_NOMINAL`)."""
        return self.ratio <= HELD_OVER_NOMINAL

    def note(self) -> str:
        """The report's sentence where the reference is set aside."""
        return (
            f"reference baseline set aside: its machine (fitted at {self.reference_speed_rpm:.0f} rpm) "
            f"scores this record at {self.speed_rpm:.0f} rpm {self.error_held:.3g} against the nominal "
            f"machine's {self.error_nominal:.3g} ({self.ratio:.3g} x > {HELD_OVER_NOMINAL:g} x): its "
            "stiffness scales fit the reference's own speed (a mesh mode placed against a harmonic there), "
            "not the machine; the record is diagnosed with its own baseline, as without a reference"
        )

    def as_dict(self) -> dict[str, float]:
        """JSON-ready (the report's ``baseline.reference_check``)."""
        return {
            "error_held": self.error_held,
            "error_nominal": self.error_nominal,
            "ratio": self.ratio,
            "limit": HELD_OVER_NOMINAL,
        }


def reference_point(cal: Calibrator, score_held: Score) -> ReferencePoint:
    """The record scored on the nominal machine beside ``score_held``, its score on the held machine.

    Parameters
    ----------
    cal : Calibrator
        Set up against a held reference (``cal.baseline`` the reference's sets), the transfer slopes fitted
        on the held machine.
    score_held : Score
        The record's score on the held machine.

    Returns
    -------
    ReferencePoint
        The calibrator's state (baseline, base run, caches, slopes) is left as it was.
    """
    from gear_rotor_sim.calibration.confirm_updated import _trial

    with _trial(cal):
        cal.baseline = []
        cal._sig_cache.clear()
        cal._sig_checked.clear()
        cal.base_raw = cal._raw(())
        feats = cal._features(cal.base_raw)
        cal._refit_transfer(feats)
        nominal = cal.cmp.score(feats)
    ref_speed = (cal.baseline_reference.get("operating_point") or {}).get("speed_rpm", float("nan"))
    return ReferencePoint(
        float(score_held.error),
        float(nominal.error),
        float(cal.m.operating_point.speed_rpm),
        float(ref_speed),
    )


def rerun_off_point(cal: Calibrator, score_held: Score) -> CalibrationResult | None:
    """The hook at the start of ``Calibrator.run`` against a held reference: None where the held machine
    describes the record's point (or the check is off), else the result of the same calibration without the
    reference, its ``issues`` naming why and its ``baseline.reference`` the reference set aside with the
    check's numbers."""
    from gear_rotor_sim.calibration.mains_repair import copy_measurement

    if cal.fit_baseline or not cal.baseline or not cal.fit.reference_point_check:
        return None
    if not hasattr(cal, "_init_args"):
        return None
    check = reference_point(cal, score_held)
    if check.describes():
        return None
    note = check.note()
    cal.log(note)
    kw = dict(cal._init_args)
    m = copy_measurement(kw.pop("measurement"))
    m.issues.append(note)
    kw.update(baseline=None, baseline_source=None, carrier_tolerance=None, baseline_reference=None)
    kw["fit_settings"] = cal.fit
    result = type(cal)(m, **kw).run()
    result.baseline_reference = {**cal.baseline_reference, "set_aside": check.as_dict()}
    return result
