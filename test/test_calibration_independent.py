"""benchmarks/calibration_independent.py: verdicts per criterion and the record/table pipeline."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location(
    "calib_indep", REPO / "benchmarks" / "calibration_independent.py"
)
assert spec is not None and spec.loader is not None
bench = importlib.util.module_from_spec(spec)
sys.modules["calib_indep"] = bench  # dataclasses look their module up
spec.loader.exec_module(bench)


def _case(fault):
    return bench.Case("t", 3000.0, 25.0, fault, 1)


def _res(effects, before=100.0, after=40.0):
    return {"effects": effects, "error_before": before, "error_after": after, "wall_s": 1.0}


def test_fault_record_passes_only_when_named_first_close_and_halved():
    gear = "tooth_damage:wheel=gear,tooth=5,depth=0.4"
    hit = {"name": "tooth_damage", "label": "tooth_damage@gear", "parameters": {"depth": 0.45, "tooth": 5}}
    row = bench.judge(_case(gear), _res([hit]))
    assert row["verdict"] == "PASS" and row["rel_error"] == pytest.approx(0.125)
    wrong_wheel = {**hit, "label": "tooth_damage@pinion"}
    assert bench.judge(_case(gear), _res([wrong_wheel]))["checks"]["named first"] is False
    wrong_tooth = {**hit, "parameters": {"depth": 0.45, "tooth": 6}}
    assert bench.judge(_case(gear), _res([wrong_tooth]))["checks"]["named first"] is False
    far = {**hit, "parameters": {"depth": 0.55, "tooth": 5}}  # +37.5 %
    assert bench.judge(_case(gear), _res([far]))["checks"] == {
        "named first": True,
        "param within 25 %": False,
        "error halved": True,
    }
    assert bench.judge(_case(gear), _res([hit], 100.0, 60.0))["checks"]["error halved"] is False
    second = [{"name": "mesh_stiffness_damping", "label": "mesh_stiffness_damping", "parameters": {}}, hit]
    row = bench.judge(_case(gear), _res(second))
    assert row["verdict"] == "FAIL" and math.isnan(row["fitted"])


def test_healthy_record_fails_on_any_effect_but_not_on_baseline_updates():
    upd = {"name": "mesh_stiffness_damping", "label": "mesh_stiffness_damping", "parameters": {}}
    ok = {**_res([]), "baseline_updates": [upd]}
    assert bench.judge(_case(None), ok)["verdict"] == "PASS"
    assert bench.judge(_case(None), _res([upd]))["verdict"] == "FAIL"
    failed = bench.judge(_case(None), {"failed": True, "stderr": "boom", "wall_s": 1.0})
    assert failed["verdict"].startswith("FAIL")


def test_case_list_covers_both_operating_points_and_healthy_grid():
    full = bench.cases(quick=False)
    tags = [c.tag for c in full]
    assert len(set(tags)) == len(tags)
    for op, (speed, _) in bench.OPS.items():
        # every shared fault and the shaft crack (an EXTRA row since session 23) once at each operating point
        faults = [c.fault for c in full if c.tag.startswith(op) and c.speed_rpm == speed]
        assert sorted(faults) == sorted([*bench.FAULTS, bench.CRACK])
    assert [c.tag for c in full[-len(bench.EXTRA) :]] == [e[0] for e in bench.EXTRA]
    healthy = [(c.speed_rpm, c.temperature_c) for c in full if c.fault is None]
    assert len({s for s, _ in healthy}) >= 3 and len({t for _, t in healthy}) >= 3


def test_table_from_a_real_record(tmp_path):
    """A short record is written and loads; the table renders its row (no calibration run here)."""
    from gear_rotor_sim.calibration.measurement import load_measurement

    case = bench.Case("contact_tooth_wear", 3000.0, 25.0, "tooth_wear:wear_depth_m=20e-6", 3)
    csv = bench.make(case, tmp_path, 0.2)
    assert load_measurement(csv).n_samples == 4000
    row = bench.judge(
        case, _res([{"name": "tooth_wear", "label": "tooth_wear", "parameters": {"wear_depth_m": 2.2e-5}}])
    )
    text = bench.table([row])
    assert "| contact_tooth_wear | `tooth_wear:wear_depth_m=20e-6` | tooth_wear |" in text
    assert "(+10%)" in text and "PASS" in text


def test_rerender_from_saved_results(tmp_path, capsys):
    """--from-results judges saved calibration JSON and marks the missing records 'not run'."""
    import json

    (tmp_path / "healthy_3000rpm_25C.calibration.json").write_text(
        json.dumps({"effects": [], "error_before": 3.0, "error_after": 3.0, "wall_s": 60.0})
    )
    argv = [
        "--from-results",
        str(tmp_path),
        "--out",
        str(tmp_path / "r"),
        "--no-baseline",
        "--cases",
        "healthy",
    ]
    assert bench.main(argv) == 0
    text = (tmp_path / "r" / "table.md").read_text()
    assert "| healthy_3000rpm_25C | `healthy` | none | - | 3 | 3 | 1.00 | yes | - | - | PASS | 60 |" in text
    assert "| healthy_2000rpm_25C | `healthy` | - |" in text and "not run" in text
    assert "1 of 1 calibrations run pass all their criteria (4 not run)" in text
