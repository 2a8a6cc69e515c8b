"""A DTE zero offset against tooth wear read from the DTE mean (issue 11: effects nobody declared;
docs/calibration.md Sec. 1, "Sensor conventions and faults nobody declared"; history Sec. 8.58).

In contact the DTE mean is ``b + F / k + 1.40 h`` (``candidates_wear_reference.py``; ``h`` the wear depth),
and the calibration reads the wear depth from it (with a reference, and without one after a baseline update,
``candidates_wear_contact.py``). A DTE is the difference of two encoder angles times a base radius; its zero
is where the two angles were referenced, and an offset ``z`` there (an encoder's index, the acquisition's
zero) adds ``z`` to the mean and nothing else: it reads as a wear of ``z / 1.40`` (session 17, history Sec.
8.43: +-5 um on the 20 um record read 20.1 and 13.0 um where the undisturbed record reads 16.5 um). What the
mean cannot say, the dynamic features might: wear changes the tooth profile, hence the mesh harmonics, while a
zero changes no dynamics. So where a wear claimed from the DTE mean is in the result, its reading is stated
with both interpretations (:func:`wear_zero_issue`), and whether the dynamic features alone support the wear:
the balanced chi^2 of the order and envelope families (the static one left out) before minus after the wear,
less the BIC penalty of its two parameters (depth and profile scale), must exceed the BIC threshold.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from gear_rotor_sim.calibration.residual import Score

#: DTE mean per wear depth in contact for the paper pair (``faults.gear.ToothWear``, Sec. 8.8)
MEAN_PER_DEPTH = 1.40
#: a claimed depth this close (relative) to the mean's reading is that reading (a later refinement moves it)
DEPTH_MATCH = 0.05


@dataclass(frozen=True)
class WearMeanReading:
    """What a wear depth read from the DTE mean rests on."""

    depth_m: float
    mean_excess_m: float  # the DTE mean above the model before the wear, at unit gain
    mean_sigma_m: float  # its standard deviation (the static feature's)
    dynamic_dbic: float  # the dynamic families' gain from the wear, less the BIC penalty of 2 parameters
    profile_scale: float
    column: str

    @property
    def dynamic_support(self) -> bool:
        """Whether the dynamic features alone support the wear beyond the BIC threshold (10)."""
        return self.dynamic_dbic > 10.0


def dynamic_dbic(before: Score, after: Score, k: int = 2) -> float:
    """Balanced chi^2 gain of the order and envelope families alone (the static family left out), less
    ``k ln N`` (``Score.balanced_chi2``)."""

    def dyn(s: Score) -> float:
        return s.balanced_chi2 - float(s.chi2.get("static", 0.0))

    return dyn(before) - dyn(after) - k * math.log(max(before.n_total, 2))


def wear_reading(
    eff: Any, before: Score, after: Score, r0_m: float, s0_m: float, column: str
) -> WearMeanReading:
    """The :class:`WearMeanReading` of a wear ``eff`` read from the DTE mean of ``column``, ``r0_m +- s0_m``
    above the model."""
    return WearMeanReading(
        float(eff.wear_depth_m),
        float(r0_m),
        float(s0_m),
        dynamic_dbic(before, after),
        float(eff.profile_scale),
        column,
    )


def wear_zero_issue(reading: WearMeanReading) -> str:
    """The ``issues`` entry of a claimed wear read from the DTE mean: both readings of the mean."""
    um, column = 1e6, reading.column
    both = (
        f"{MEAN_PER_DEPTH:g} h + z = {um * reading.mean_excess_m:+.3g} um for a wear h and a zero z: "
        f"tooth wear of {um * reading.depth_m:.3g} um and no zero, or no wear and a zero offset of "
        f"{um * reading.mean_excess_m:+.3g} um on {column!r}, or any split between"
    )
    if reading.dynamic_support:
        tail = (
            f"the dynamic features alone support a wear (dBIC {reading.dynamic_dbic:.3g} without the "
            "channel means; a zero changes no dynamics), so the wear is preferred, but how the mean splits "
            "between wear and a zero is not read: the depth assumes no zero"
        )
    else:
        tail = (
            f"the dynamic features do not tell them apart (dBIC {reading.dynamic_dbic:.3g} without the "
            f"channel means, profile scale {reading.profile_scale:.2g}): both readings fit the record; check "
            "the DTE's zero (the encoders' reference) to decide"
        )
    return (
        f"column {column!r}: the wear depth is read from the DTE mean, {um * reading.mean_excess_m:+.3g} +- "
        f"{um * reading.mean_sigma_m:.2g} um above the model ({MEAN_PER_DEPTH:g} um of mean per um of "
        "depth); "
        f"a DTE zero offset adds the same to the mean: {both}; {tail}"
    )


def dte_zero_issues(cal: Any, effects: list[Any]) -> list[str]:
    """``issues`` entries for a claimed ``tooth_wear`` whose depth came from the DTE mean (the last reading
    kept on ``cal.wear_mean_reading`` by ``candidates_wear_reference.dte_mean_wear``; the claimed depth within
    :data:`DEPTH_MATCH` of it)."""
    reading = getattr(cal, "wear_mean_reading", None)
    if reading is None:
        return []
    for e in effects:
        depth = (e.parameters or {}).get("wear_depth_m") if e.name == "tooth_wear" else None
        if depth is not None and abs(float(depth) - reading.depth_m) <= DEPTH_MATCH * reading.depth_m:
            return [wear_zero_issue(reading)]
    return []
