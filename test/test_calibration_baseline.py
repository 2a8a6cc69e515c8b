"""A saved reference baseline (``calibrate --baseline HEALTHY --save-baseline FILE``) and its validation.

No simulation: the reference is written and read back, and every malformed field is refused with an
error naming the file and the field. The physics of the baseline is tested on independent records in
``test_calibration_independent_diagnosis.py``.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from gear_rotor_sim.calibration.baseline import REFERENCE_FORMAT, ReferenceBaseline, load_reference
from gear_rotor_sim.faults import BearingStiffnessDamping, MeshStiffnessDamping


def _reference() -> ReferenceBaseline:
    return ReferenceBaseline(
        effects=(MeshStiffnessDamping(1.306, 1.7), BearingStiffnessDamping(0.523, 1.324)),
        carrier_tolerance=0.5,
        source="out/healthy_2000.csv",
        speed_rpm=2000.0,
        temperature_c=25.0,
        error_before=47.4,
        error_after=4.12,
    )


def test_saved_reference_reads_back_and_holds_the_same_baseline(tmp_path: Path) -> None:
    ref = _reference()
    back = load_reference(ref.save(tmp_path / "machine.json"))
    assert back == ref
    kw = back.calibrator_kwargs()
    assert kw["baseline"] == list(ref.effects) and kw["carrier_tolerance"] == 0.5
    assert kw["baseline_source"] == "out/healthy_2000.csv"
    assert kw["baseline_reference"]["operating_point"] == {"speed_rpm": 2000.0, "temperature_c": 25.0}


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"format": "something else"}, "'format'"),
        ({"carrier_tolerance": 0.0}, "'carrier_tolerance'"),
        ({"carrier_tolerance": "half"}, "'carrier_tolerance'"),
        ({"updates": [{"name": "tooth_wear", "parameters": {}}]}, "updates[0].name"),
        (
            {"updates": [{"name": "mesh_stiffness_damping", "parameters": {"stiffness_scale": 5.0}}]},
            "updates[0].parameters.stiffness_scale",
        ),
    ],
)
def test_malformed_reference_is_refused_naming_the_field(tmp_path: Path, change: dict, field: str) -> None:
    path = _reference().save(tmp_path / "machine.json")
    d = json.loads(path.read_text())
    d.update(change)
    path.write_text(json.dumps(d))
    with pytest.raises(ValueError) as exc:
        load_reference(path)
    assert str(path) in str(exc.value) and field in str(exc.value), str(exc.value)


def test_not_json_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "machine.json"
    path.write_bytes(b"\x00\x01binary")
    with pytest.raises(ValueError, match="not a readable JSON reference baseline"):
        load_reference(path)


def test_cli_refuses_save_baseline_without_a_healthy_record(tmp_path: Path) -> None:
    """Exit status 2 with one line naming the option (nothing is simulated)."""
    from lumped_gearbox import make_record, write_record

    csv = write_record(tmp_path / "rec.csv", make_record(3000.0, 25.0, [], duration_s=0.05, seed=1))
    p = subprocess.run(
        [sys.executable, "-m", "gear_rotor_sim.cli", "calibrate", str(csv), "--save-baseline", "x.json"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert p.returncode == 2, p.stderr
    assert "--save-baseline" in p.stderr and "--baseline HEALTHY" in p.stderr
    assert REFERENCE_FORMAT.startswith("gear_rotor_sim.reference_baseline/")
