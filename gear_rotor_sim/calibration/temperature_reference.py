"""A screened temperature offset against a held reference: judged on the record's own baseline
(``calibrate --baseline``; issue 11: "a temperature offset must agree with the static axial bearing force";
docs/calibration.md Sec. 8.3; history Sec. 8.79).

Physics. A held reference fixes the mesh and bearing stiffness and damping scales of the machine at the
reference's own operating point, its actual temperature the declared one (``baseline.py``). A temperature
offset is a condition of the record, not of the machine, so the reference does not absorb it: the static
screen reads it from the axial bearing-force mean (``k_s a dT L / (1 + 2 k_s / k_b)``, Sun et al. 2021,
Eqs 9-11), which no baseline set moves. Its whole-feature confirmation (``confirm_updated``) then judges it
on the held machine, whose scales carried from another speed can misfit the record's order carriers by far
more than the temperature's own dynamic signature (E(T) and the thermal backlash over a few tens of
degrees). Measured on blind2_03 of the blind set's second draw (4504 rpm, declared 108 C, actual +50.6 C;
reference at 6339 rpm, mesh x0.915, bearing x0.765): the screen's +52.3 C brings the axial mean from 6.35
to 0.02 sigma, while on the held machine the order family's chi^2 stands at 8181 for 1080 features and the
offset moves it to 9135 (the held mesh scale x0.915 against x1.40 read on this record, order chi^2 1754):
Delta BIC -562, refused, nothing claimed, 12.2 -> 2.68.

Rule (:func:`judge_on_own_baseline`). Against a held reference, where the screened offset brings every
channel mean within 3 sigma and the held machine refuses it, the offset is judged as without a reference:
the baseline sets fitted on this record with and without it from the nominal machine, both scored with
the carrier floor of the record's own updated model, the same Delta BIC and 25 % share rules
(``confirm_updated.confirm_screened_offset``). Confirmed, the offset joins the held machine and the rounds
go on against it; nothing of the trial fits is kept. It runs only where the held machine has refused an
offset that matches the means, so a record whose means agree with the declared temperature, or whose
offset the held machine confirms, keeps its path.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

from gear_rotor_sim.calibration.confirm_updated import UpdatedConfirmation, confirm_screened_offset

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.fit import Calibrator
    from gear_rotor_sim.faults import Effect


def applies(cal: Calibrator) -> bool:
    """Whether the calibrator holds a reference's baseline and the rule is on (``FitSettings``)."""
    return bool(not cal.fit_baseline and cal.fit.offset_on_own_baseline)


@contextmanager
def _own_baseline(cal: Calibrator) -> Iterator[None]:
    """The calibrator as without a reference (baseline fitted on the record, no held sets, the carrier
    tolerance re-estimated), restored afterwards."""
    saved = (cal.fit_baseline, list(cal.baseline), cal.fixed_carrier_tolerance)
    try:
        cal.fit_baseline, cal.baseline, cal.fixed_carrier_tolerance = True, [], None
        yield
    finally:
        cal.fit_baseline, cal.baseline, cal.fixed_carrier_tolerance = saved


def judge_on_own_baseline(cal: Calibrator, offset: Effect) -> UpdatedConfirmation:
    """The screened ``offset`` judged with the baseline sets fitted on this record (module docstring).

    Parameters
    ----------
    cal : Calibrator
        Against a held reference, before the rounds (its ``pre_effects`` the effects screened so far).
    offset : Effect
        The temperature offset that brought every channel mean within 3 sigma.

    Returns
    -------
    UpdatedConfirmation
        As :func:`~gear_rotor_sim.calibration.confirm_updated.confirm_screened_offset` without a reference.
        The calibrator's held baseline, base run and caches are left as they were.
    """
    with _own_baseline(cal):
        return confirm_screened_offset(cal, offset)


def note(offset: Effect, conf: UpdatedConfirmation, ok: bool) -> str:
    """The report's sentence on the judgement."""
    return (
        f"static screening against the held reference: {offset.label} {offset.parameters()} judged on "
        f"this record's own baseline (the held sets set aside; carrier tolerance "
        f"{conf.carrier_tolerance:.3g}; without it {conf.baseline_without}, with it {conf.baseline_with}): "
        f"dBIC {conf.delta_bic:.4g}, "
        f"{conf.explained:.2f} of the excess ({conf.static_explained:.2f} of the channel means'), error "
        f"{conf.error_without:.3g} -> {conf.error_with:.3g}: "
        + ("confirmed, taken into the held machine" if ok else "not confirmed")
        + " (temperature_reference.py, Sec. 8.79)"
    )
