"""Calibration on a multi-stage rig (issue 15): per-mesh channels in, effects on every mesh out.

The end-to-end case is the acceptance item "calibration on the two-stage example: tooth damage on the
second-stage gear named first with its wheel and tooth": a ``gear-rotor-sim record`` of
``config/two_stage_example.yaml`` with a damaged tooth on mesh 2's gear is traced back by
``gear-rotor-sim calibrate --json``. It is a self-consistency test of the multi-mesh plumbing (loader,
candidates, tooth search on the second stage), the data being made by this model; the physics of the
two-stage model is tested against independent truth in test_multi_mesh.py.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from gear_rotor_sim.calibration.measurement import MeasurementError, load_csv, load_measurement
from gear_rotor_sim.calibration.residual import Comparison, shaft_orders
from gear_rotor_sim.config import load_config
from gear_rotor_sim.faults import GearMisalignment, candidate_effects
from gear_rotor_sim.system import GearRotorSystem, mesh_forces, static_solution

TWO_STAGE = "two_stage_example"


def _csv(tmp: Path, channels: list[dict], n: int = 40) -> Path:
    t = np.arange(n) / 1000.0
    rows = np.column_stack([t] + [np.full(n, 1.0 + k) for k in range(len(channels))])
    path = tmp / "run.csv"
    header = ",".join(["time_s", *[c["column"] for c in channels]])
    np.savetxt(path, rows, delimiter=",", header=header, comments="")
    sidecar = {
        "sample_rate_hz": 1000,
        "operating_point": {"speed_rpm": 3000, "temperature_c": 25},
        "gearbox": TWO_STAGE,
        "channels": channels,
    }
    (tmp / "run.yaml").write_text(yaml.safe_dump(sidecar))
    return path


def test_sidecar_mesh_key_selects_the_stage(tmp_path: Path) -> None:
    m = load_csv(
        _csv(
            tmp_path,
            [
                {"column": "te1", "quantity": "dynamic_transmission_error", "unit": "um"},
                {"column": "te2", "quantity": "dynamic_transmission_error", "mesh": 2, "unit": "um"},
                {"column": "f2", "quantity": "mesh_force", "mesh": 2, "unit": "kN"},
            ],
        )
    )
    assert m.model_channels == ["dte", "mesh2_dte", "mesh2_force"]
    np.testing.assert_allclose(m.channel("mesh2_force"), 3000.0)  # 3 kN -> N
    np.testing.assert_allclose(m.channel("te2"), 2e-6)  # 2 um -> m


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ({"column": "b", "quantity": "bearing_force", "bearing": 2, "direction": "x", "mesh": 2, "unit": "N"},
         "mesh: only for"),
        ({"column": "b", "quantity": "mesh_force", "mesh": 0, "unit": "N"}, "mesh: must be a 1-based"),
        ({"column": "b", "quantity": "mesh_force", "mesh": "2", "unit": "N"}, "mesh: must be a 1-based"),
    ],
)  # fmt: skip
def test_sidecar_mesh_key_errors_name_the_field(tmp_path: Path, entry: dict, message: str) -> None:
    with pytest.raises(MeasurementError, match=message):
        load_csv(_csv(tmp_path, [entry]))


def test_a_mesh_the_rig_lacks_is_refused_naming_the_column(tmp_path: Path) -> None:
    from gear_rotor_sim.calibration.fit import Calibrator

    m = load_csv(
        _csv(tmp_path, [{"column": "te3", "quantity": "dynamic_transmission_error", "mesh": 3, "unit": "m"}])
    )
    with pytest.raises(MeasurementError, match=r"'te3' \(mesh3_dte\).*mesh: 1\.\.2"):
        Calibrator(m)


def test_recording_names_its_rig_and_per_mesh_channels(tmp_path: Path) -> None:
    from gear_rotor_sim.recording.record_cli import RunParameters, record_run

    out = tmp_path / "r.mcap"
    record_run(
        RunParameters(speed_rpm=3000.0, temperature_c=25.0, duration_s=0.02, config=TWO_STAGE,
                      bearing_type="B#", streams=("dte",)),
        out,
    )  # fmt: skip
    m = load_measurement(out)
    assert m.gearbox == TWO_STAGE and m.bearing_type == "B#"
    assert m.model_channels == ["mesh1_dte", "mesh1_force", "mesh2_dte", "mesh2_force"]
    assert not any("skipped" in s for s in m.issues), m.issues
    assert any("from the recording's metadata" in s for s in m.issues), m.issues


def test_dataset_runs_on_the_two_stage_rig_load_with_their_rig(tmp_path: Path) -> None:
    """``dataset`` on the two-stage example with a fault on mesh 2 as a grid axis: every run's file
    loads with its rig and all four mesh channels, and its ground truth names mesh 2."""
    from gear_rotor_sim.recording.dataset import generate, parse_sweep

    sweep = parse_sweep(
        {
            "base": {"duration_s": 0.02, "config": TWO_STAGE, "streams": ["dte"]},
            "grid": {
                "speed_rpm": [3000],
                "temperature_c": [25],
                "faults": [
                    [],
                    [{"type": "tooth_damage", "mesh": 2, "wheel": "gear", "tooth": 5, "depth": 0.3}],
                ],
            },
        }
    )
    generate(sweep, tmp_path, workers=1)
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert len(manifest["runs"]) == 2
    for entry in manifest["runs"]:
        m = load_measurement(tmp_path / entry["file"])
        assert m.gearbox == TWO_STAGE
        assert m.model_channels == ["mesh1_dte", "mesh1_force", "mesh2_dte", "mesh2_force"]
    assert [f.get("mesh") for e in manifest["runs"] for f in e["faults"]] == [2]


def test_candidates_cover_every_mesh_and_wheel() -> None:
    labels = {e.label for e in candidate_effects(load_config(TWO_STAGE))}
    for suffix in ("", "@mesh2"):
        assert {
            f"tooth_damage@pinion{suffix}",
            f"tooth_damage@gear{suffix}",
            f"pinion_eccentricity{suffix}",
            f"gear_eccentricity{suffix}",
            f"tooth_wear{suffix}",
            f"pinion_misalignment{suffix}",
            f"gear_misalignment{suffix}",
        } <= labels
    single = [e.label for e in candidate_effects(load_config("paper_sun2021"))]
    assert not any("@mesh" in s for s in single) and "tooth_damage@gear" in single


def test_carriers_of_both_stages_on_the_intermediate_shaft() -> None:
    """The intermediate shaft carries the 49-tooth gear of stage 1 and the 25-tooth pinion of stage
    2: the multiples of both are mesh carriers (not order comb)."""
    cfg = load_config(TWO_STAGE)
    shafts = shaft_orders(cfg, 3000.0, 20000.0)
    inter = next(s for s in shafts if s.name == "intermediate")
    assert set(inter.carrier_teeth) == {49, 25}
    mask = Comparison.carriers(SimpleNamespace(shafts=shafts), shafts.index(inter))
    carriers = set(inter.orders[mask].tolist())
    assert {25, 49, 50, 75, 98} <= carriers and not ({24, 26, 48, 51} & carriers)


def test_gear_misalignment_static_force_per_stage_equals_the_static_solution() -> None:
    """The misalignment's static mesh force of each stage (load torque referred through the speed
    ratios, over the base radius) against the mesh forces of the FE static equilibrium."""
    cfg = load_config(TWO_STAGE)
    system = GearRotorSystem.from_config(cfg, 25.0)
    fe = mesh_forces(system, static_solution(system))
    ours = np.array([GearMisalignment(mesh=k)._static_force(system) for k in (1, 2)])
    np.testing.assert_allclose(ours, fe, rtol=1e-9)
    assert fe[1] / fe[0] > 1.9  # the stages carry different forces: a shared value would be wrong


@pytest.mark.acceptance
def test_calibrate_names_the_damaged_tooth_on_the_second_stage_gear(tmp_path: Path) -> None:
    """record (two-stage example, damaged tooth 5 of mesh 2's gear) -> calibrate --json: first
    effect tooth_damage on mesh 2, wheel gear, tooth 5, depth within 25 %."""
    run = tmp_path / "two_stage_gear2_tooth5.mcap"
    cli = [sys.executable, "-m", "gear_rotor_sim.cli"]
    faults = "[{type: tooth_damage, mesh: 2, wheel: gear, tooth: 5, depth: 0.4}]"
    subprocess.run(
        [*cli, "record", "--config", TWO_STAGE, "--speed-rpm", "3000", "--duration-s", "0.65",
         "--streams", "dte", "--faults", faults, "--out", str(run)],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    # --start 0.2: the recording starts from static equilibrium; its start-up transient is skipped
    out = subprocess.run(
        [*cli, "calibrate", str(run), "--start", "0.2", "--json"], check=True, capture_output=True, text=True
    )
    result = json.loads(out.stdout)
    effects = result["effects"]
    assert effects, result["notes"]
    first = effects[0]
    assert first["name"] == "tooth_damage", first
    p = first["parameters"]
    assert (p["mesh"], p["wheel"], p["tooth"]) == (2, "gear", 5), first
    assert abs(p["depth"] - 0.4) <= 0.25 * 0.4, first
    assert result["error_after"] <= 0.5 * result["error_before"]
