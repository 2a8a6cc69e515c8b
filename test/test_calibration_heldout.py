"""Held-out independent records (issue 11, docs/history/calibration_sessions.md Sec. 8.22).

The 27-row table holds the gear eccentricity at 20 um only, where it read +24 %: every sensor gain sat
at its 0.8 bound, set by the mesh carriers' model-form misfit, and an order-1 effect seen through that
gain reads ``1 / 0.8`` too large. At 32 um (x1.6, another phase and seed, a record the table does not
hold) it read +30 % (2 s) and +26 % (0.6 s). The low shaft orders now take the sensor's own gain (the
equilibrium-load ratio of a radial bearing force, else the nominal 1): checked here against the
generator's truth, its injected eccentricity and its sensor gains.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from gear_rotor_sim.calibration.fit import Calibrator
from gear_rotor_sim.calibration.fit_types import FitSettings
from gear_rotor_sim.calibration.measurement import load_measurement

#: the held-out benchmark's x1.6 gear-eccentricity row (benchmarks/calibration_heldout.py), 0.6 s
FAULT = "gear_eccentricity:eccentricity_m=32e-6,phase_rad=3.0"
TRUTH_M = 32e-6
SEED = 112


@pytest.fixture(scope="module")
def diagnosis(tmp_path_factory: pytest.TempPathFactory):
    from lumped_gearbox import make_record, write_record

    rec = make_record(3000.0, 25.0, [FAULT], duration_s=0.6, seed=SEED)
    path = write_record(Path(tmp_path_factory.mktemp("heldout")) / "gear_ecc_x1.6.csv", rec)
    # both tests read the first effect and the baseline: the search stops there (Sec. 8.74)
    return rec, Calibrator(load_measurement(path), fit_settings=FitSettings(max_effects=1)).run()


@pytest.mark.acceptance
def test_gear_eccentricity_off_the_table_severity_is_read_without_the_carrier_gain(diagnosis) -> None:
    """Named first, the error at least halved, and the eccentricity within 12.5 %: half the 25 %
    that the carriers' gain at its 0.8 bound put on it (measured before: 40.4 um, +26 %; after:
    32.4 um, +1 %)."""
    _, r = diagnosis
    assert r.effects, r.conclusion
    first = r.effects[0]
    assert first.name == "gear_eccentricity", [(e.label, e.parameters) for e in r.effects]
    rel = (first.parameters["eccentricity_m"] - TRUTH_M) / TRUTH_M
    assert abs(rel) <= 0.125, first.parameters
    assert r.error_after <= 0.5 * r.error_before, (r.error_before, r.error_after)


@pytest.mark.acceptance
def test_shaft_order_gains_are_the_generators_sensor_gains(diagnosis) -> None:
    """The gain the low shaft orders take: the generator's gain (its truth) at the radial bearing
    forces, read from their equilibrium means within 3 % (the generator's gain spread; measured
    -1.4 % and the carriers' gain 0.8, -21 %); the nominal 1 at the DTE and the accelerometers,
    whatever gain the carriers were given."""
    rec, r = diagnosis
    sensor = next(b for b in r.baseline_updates if b.name == "sensor_transfer").parameters
    for ch in ("bearing2_fx", "bearing2_fy"):
        assert sensor[f"shaft_order_gain_{ch}"] == pytest.approx(rec.gain[ch], rel=0.03), (ch, sensor)
    for ch in ("dte", "node5_ax", "node5_ay"):
        assert sensor[f"shaft_order_gain_{ch}"] == 1.0, (ch, sensor)


def _heldout_bench():
    import importlib.util
    import sys

    path = Path(__file__).resolve().parents[1] / "benchmarks" / "calibration_heldout.py"
    spec = importlib.util.spec_from_file_location("calib_heldout", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules["calib_heldout"] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


def test_heldout_verdicts_for_two_faults_locations_and_an_unobservable_fault() -> None:
    """The benchmark's verdicts on constructed results: a pair is judged on both effects (any order
    among the first two, each within 25 %), the unbalance on its node, an unobservable fault as a
    healthy record."""
    bench = _heldout_bench()
    ecc, outer = bench.TWO_FAULTS[0]
    pair = bench.Held("pair", 3000.0, 25.0, (ecc, outer), 1)
    effects = [
        {
            "name": "outer_race_defect",
            "label": "outer_race_defect@bearing2",
            "parameters": {"force_n": 280.0},
        },
        {"name": "gear_eccentricity", "label": "gear_eccentricity", "parameters": {"eccentricity_m": 21e-6}},
    ]
    res = {"effects": effects, "error_before": 10.0, "error_after": 2.0}
    assert bench.judge(pair, res)["verdict"] == "PASS"
    effects[0]["parameters"]["force_n"] = 220.0  # -27 %
    assert bench.judge(pair, res)["checks"] == {
        "named first": True,
        "param within 25 %": False,
        "error halved": True,
    }
    node14 = bench.Held("u", 3000.0, 25.0, ("mass_unbalance:node=5,unbalance_kg_m=3e-4",), 1)
    wrong = {
        "name": "mass_unbalance",
        "label": "mass_unbalance@node14",
        "parameters": {"unbalance_kg_m": 3e-4},
    }
    row = bench.judge(node14, {"effects": [wrong], "error_before": 10.0, "error_after": 2.0})
    assert row["verdict"] == "FAIL" and not row["checks"]["named first"]
    hidden = bench.Held("h", 3000.0, 25.0, bench.UNOBSERVABLE, 1)
    assert bench.judge(hidden, {"effects": [], "error_before": 5.0, "error_after": 5.0})["verdict"] == "PASS"
    assert (
        bench.judge(hidden, {"effects": [wrong], "error_before": 5.0, "error_after": 2.0})["verdict"]
        == "FAIL"
    )
