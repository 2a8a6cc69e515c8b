"""Manufacturing pitch errors nobody declared (docs/history/calibration_sessions.md Sec. 8.65): the
features that read a damaged tooth and a bearing keep out what the other teeth's pitch errors make.

Truth is the independent generator's (``lumped_gearbox``, which shares no code with the FE model): the
same machine and fault with exact teeth, against a record with every flank drawn at ISO quality 5 or 7
(``lumped_gearbox/pitch.py``).
"""

from __future__ import annotations

import numpy as np
import pytest

from gear_rotor_sim.calibration.envelope_hunting import MIN_SHARE, hunting_part, hunting_share
from gear_rotor_sim.calibration.features_dte_depth import dte_tooth_signature
from gear_rotor_sim.calibration.features_orders import remove_synchronous
from gear_rotor_sim.calibration.features_tooth_window import MIN_OUTSIDE_SHARE, named_tooth_window
from lumped_gearbox import make_record
from lumped_gearbox.pitch import PitchErrors

FS = 20000.0
RPM = 3000.0
Z1, Z2 = 29, 49
TOOTH = "tooth_damage:wheel=pinion,tooth=7,depth=0.4"


def _dte(faults: list[str], f_pt_um: float, seed: int) -> np.ndarray:
    pe = PitchErrors(f_pt_um=f_pt_um, seed=7) if f_pt_um else None
    return make_record(RPM, 25.0, faults, duration_s=0.6, seed=seed, pitch_errors=pe).data["dte"]


@pytest.fixture(scope="module")
def dte_records() -> dict[str, np.ndarray]:
    """0.6 s (30 pinion revolutions) at 3000 rpm: tooth 7 at depth 0.4 with exact teeth and with pitch
    errors of quality 5 (3 um), and the exact healthy machine."""
    return {
        "tooth": _dte([TOOTH], 0.0, 11),
        "tooth_q5": _dte([TOOTH], 3.0, 11),
        "healthy": _dte([], 0.0, 34),
    }


def test_the_tooth_window_reads_the_damaged_tooth_not_the_other_teeths_pitch_errors(dte_records):
    """Over the whole revolution the quality-5 pitch errors of the other teeth raise the DTE comb's
    families to 1.5 times and more the damaged tooth's own (the depth read 0.588 for 0.4, Sec. 8.62);
    within the window round the tooth the families are the exact-teeth record's within 30 % (what stays:
    the tooth's own and its neighbours' pitch deviations). The window sits on tooth 7 of the generator
    (angle 7 / 29 of a revolution, within one mesh period), and the rule fires on the record with pitch
    errors only."""
    f1 = RPM / 60.0
    # the "model" of the named tooth: the exact-teeth records (the generator's own signature)
    center, share = named_tooth_window(
        dte_records["tooth_q5"], dte_records["tooth"], dte_records["healthy"], FS, f1, Z1
    )
    assert center is not None and share >= MIN_OUTSIDE_SHARE
    assert abs((center - 7 / Z1 + 0.5) % 1.0 - 0.5) * Z1 < 1.0
    c_exact, share_exact = named_tooth_window(
        dte_records["tooth"], dte_records["tooth"], dte_records["healthy"], FS, f1, Z1
    )
    assert c_exact is None and share_exact < 0.2
    whole = dte_tooth_signature(dte_records["tooth_q5"], FS, f1, Z1)[0]
    whole_truth = dte_tooth_signature(dte_records["tooth"], FS, f1, Z1)[0]
    assert np.median(whole / whole_truth) > 1.5
    win = dte_tooth_signature(dte_records["tooth_q5"], FS, f1, Z1, center_rev=center)[0]
    win_truth = dte_tooth_signature(dte_records["tooth"], FS, f1, Z1, center_rev=center)[0]
    assert abs(np.median(win / win_truth) - 1.0) < 0.3


def test_content_periodic_in_the_hunting_period_is_taken_from_the_envelope_input():
    """At a single pitch deviation of 6 um (quality 7) the pairs leaving contact alone make content
    periodic in the hunting period (49 pinion revolutions, 0.98 s at 3000 rpm): more than MIN_SHARE of
    ``bearing2_fx``'s non-synchronous power. Removed, the non-synchronous RMS comes within 30 % of the
    exact-teeth record's (twice it before); on the exact-teeth record the share stays under a tenth of
    MIN_SHARE and the rule does not fire."""
    f1 = RPM / 60.0
    shafts = [f1, f1 * Z1 / Z2]
    hunting_hz = f1 / Z2
    out = {}
    for f_pt in (0.0, 6.0):
        pe = PitchErrors(f_pt_um=f_pt, seed=7) if f_pt else None
        r = make_record(RPM, 25.0, [], duration_s=2.05, seed=34, pitch_errors=pe, sampling="point")
        x = remove_synchronous(r.data["bearing2_fx"], FS, shafts)
        part = hunting_part(x, FS, hunting_hz)
        out[f_pt] = (np.std(x), np.std(x - part), hunting_share(x, part))
    exact, pitch = out[0.0], out[6.0]
    assert exact[2] < 0.1 * MIN_SHARE
    assert pitch[2] >= MIN_SHARE
    assert pitch[0] > 1.5 * exact[0]
    assert pitch[1] < 1.3 * exact[1]
    # one hunting period is too short to average over: nothing is taken
    short = make_record(RPM, 25.0, [], duration_s=0.9, seed=34, pitch_errors=PitchErrors(f_pt_um=6.0, seed=7))
    assert not np.any(hunting_part(short.data["bearing2_fx"], FS, hunting_hz))
