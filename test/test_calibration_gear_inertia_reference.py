"""The gear pair's inertia against a held reference (docs/history/calibration_sessions.md Sec. 8.71;
``calibration/baseline_gear_inertia.py``): the held-out 4500 rpm / 75 C gear tooth on a short
``lumped_gearbox`` record, calibrated against the 2000 rpm reference. The truth is the generator's
(tooth 5, depth 0.4), which shares no code with the FE model."""

from __future__ import annotations

import math

import pytest

from gear_rotor_sim.calibration.baseline_gear_inertia import scale_at_minimum

#: the held-out record's fault and operating point (benchmarks/calibration_heldout.py, 4500 rpm / 75 C)
FAULT = "tooth_damage:wheel=gear,tooth=5,depth=0.4"


def test_scale_at_minimum_is_the_parabola_vertex_in_log_scale() -> None:
    # chi2 = (ln s - ln 0.7)^2 sampled at four scales: the vertex is 0.7 exactly
    pts = [(s, (math.log(s) - math.log(0.7)) ** 2) for s in (1.0, 0.8, 0.65, 0.5)]
    assert scale_at_minimum(pts, 0.5, 2.0) == pytest.approx(0.7, rel=1e-9)
    # no curvature among the three best: the best point; the bounds clip
    assert scale_at_minimum([(1.0, 3.0), (0.8, 2.0), (0.65, 1.0)], 0.5, 2.0) == pytest.approx(0.65)
    assert scale_at_minimum([(1.0, 3.0), (0.8, 2.0), (0.65, 1.0)], 0.7, 2.0) == pytest.approx(0.7)


def _calibrate(path, reference, on: bool):
    from gear_rotor_sim.calibration.fit import Calibrator, FitSettings
    from gear_rotor_sim.calibration.measurement import load_measurement

    fs = FitSettings(gear_inertia_with_reference=on)
    return Calibrator(load_measurement(path), fit_settings=fs, **reference.calibrator_kwargs()).run()


@pytest.mark.slow
def test_gear_tooth_at_4500rpm_against_the_reference(tmp_path, reference_2000) -> None:
    from lumped_gearbox import make_record, write_record

    path = write_record(tmp_path / "gear5.csv", make_record(4500.0, 75.0, [FAULT], duration_s=0.6, seed=128))
    r = _calibrate(path, reference_2000, True)
    assert r.effects, "no effect claimed"
    first = r.effects[0]
    assert first.label == "tooth_damage@gear" and int(first.parameters["tooth"]) == 5
    assert abs(first.parameters["depth"] - 0.4) <= 0.25 * 0.4
    assert r.error_after <= 0.5 * r.error_before
    inertia = [b for b in r.baseline_effects if b.name == "gear_inertia"]
    assert len(inertia) == 1 and inertia[0].inertia_scale < 1.0  # the mode above the reference's
    # without the rule the tooth is refused by its ranking share (0.13 on the 2 s record, Sec. 8.71)
    r0 = _calibrate(path, reference_2000, False)
    named = bool(r0.effects) and r0.effects[0].label == "tooth_damage@gear"
    ok0 = (
        named
        and abs(r0.effects[0].parameters["depth"] - 0.4) <= 0.1
        and r0.error_after <= 0.5 * r0.error_before
    )
    assert not ok0, "the reference's machine alone passes: the test cannot fail without the rule"
