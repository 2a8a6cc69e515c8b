"""Tooth wear from the DTE mean without a reference, on the record's own baseline-updated model
(``calibration/candidates_wear_contact.py``, docs/history/calibration_sessions.md Sec. 8.32).

The record comes from the independent ``lumped_gearbox`` (its own mesh model and wear profile: uniform
removal plus a stiffness-weighted sliding-wear profile with tip relief, docs/independent_data.md), 32 um
of wear at 3000 rpm where the teeth stay in contact. Measured on this 1 s record (seed 41): with the rule,
``tooth_wear`` 30.2 um (-6 %) named first, error 8.98 -> 3.61; with the rule switched off
(``screen_wear_after_baseline_update`` returning None) nothing is claimed, error 8.98 -> 5.49 (the
ranking's full-profile wear is not confirmed by its full simulation).
"""

from __future__ import annotations

import types
from pathlib import Path

import pytest

from gear_rotor_sim.calibration.candidates_wear_contact import screen_wear_after_baseline_update
from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.fit_types import FitSettings
from gear_rotor_sim.calibration.measurement import load_measurement

TRUTH_M = 32e-6

# one calibration of a 1 s record: 20 s CPU
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def worn_record(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from lumped_gearbox import make_record, write_record

    rec = make_record(3000.0, 25.0, [f"tooth_wear:wear_depth_m={TRUTH_M:g}"], duration_s=1.0, seed=41)
    return write_record(tmp_path_factory.mktemp("wear_contact") / "worn.csv", rec)


@pytest.mark.acceptance
def test_contact_wear_is_read_from_the_dte_mean_after_the_baseline_update(worn_record: Path) -> None:
    # the first effect is what is asserted: the search stops there (Sec. 8.74)
    r = Calibrator(load_measurement(worn_record), fit_settings=FitSettings(max_effects=1)).run()
    found = [(e.label, e.parameters) for e in r.effects]
    assert r.effects and r.effects[0].name == "tooth_wear", found
    depth = r.effects[0].parameters["wear_depth_m"]
    assert abs(depth - TRUTH_M) <= 0.25 * TRUTH_M, found
    assert r.error_after <= 0.5 * r.error_before, (r.error_before, r.error_after)
    # the reading ran on the record's own baseline: a set was updated before it
    assert any(b.name == "bearing_stiffness_damping" for b in r.baseline_updates), r.baseline_updates


def test_the_reading_after_a_baseline_update_is_not_run_against_a_held_reference() -> None:
    # with a reference the DTE-mean reading runs once, before the rounds (candidates_wear_reference.py)
    held = types.SimpleNamespace(fit_baseline=False)
    assert screen_wear_after_baseline_update(held, None) is None  # type: ignore[arg-type]
