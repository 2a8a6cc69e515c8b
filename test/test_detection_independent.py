"""The monitor on data the FE model did not make (docs/detection.md, "On data the model did not make").

Records of ``lumped_gearbox`` (independent simulator, housing path) and the CWRU recordings; the
thresholds are learnt on healthy records of the same machine with ``gear-rotor-sim thresholds learn``
and applied with ``gear-rotor-sim thresholds check`` (the monitor node's computation,
:meth:`gear_rotor_sim.alarms.FaultAlarms.check`).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from gear_rotor_sim.cli import main as cli

ROOT = Path(__file__).resolve().parents[1]
DURATION_S = 1.5  # 4 windows of 0.25 s from 0.5 s


def _record(folder: Path, name: str, speed_rpm: float, seed: int, faults: tuple[str, ...] = ()) -> str:
    from lumped_gearbox import make_record, write_record

    r = make_record(speed_rpm, 25.0, list(faults), duration_s=DURATION_S, seed=seed, housing=True)
    return str(write_record(folder / name, r))


def _check(capsys: pytest.CaptureFixture[str], record: str, thresholds: str) -> list[dict]:
    capsys.readouterr()
    assert cli(["thresholds", "check", record, "--thresholds", thresholds, "--json"]) == 0
    return [json.loads(line) for line in capsys.readouterr().out.splitlines()]


def test_tooth_damage_on_the_independent_machine_with_its_own_thresholds(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Thresholds learnt on 4 healthy lumped records (3000 rpm +-1 %, 25 C; 16 windows) flag gear
    tooth 5 at depth 0.4 in every window (tooth-damage group) while a held-out healthy record of the
    same machine at another speed offset and noise seed raises no alarm of any group."""
    train = [
        _record(tmp_path, f"h{i}", 3000.0 * (1 + d), 10 + i)
        for i, d in enumerate((-0.01, -0.004, 0.004, 0.01))
    ]
    held = _record(tmp_path, "held", 3000.0 * 1.002, 20)
    damaged = _record(tmp_path, "damaged", 3000.0, 21, ("tooth_damage:wheel=gear,tooth=5,depth=0.4",))
    th = str(tmp_path / "my_thresholds.json")
    assert (
        cli(
            [
                "thresholds",
                "learn",
                *train,
                "--out",
                th,
                "--k",
                "6",
                "--speeds",
                "3000",
                "--temperatures",
                "25",
            ]
        )
        == 0
    )
    data = json.loads(Path(th).read_text(encoding="utf-8"))
    assert data["config"] == "paper_sun2021" and len(data["classes"]) == 1
    assert len(data["names"]) == 24  # 12 indicators x bearing2_housing_ax/ay
    held_w = _check(capsys, held, th)
    dam_w = _check(capsys, damaged, th)
    assert len(held_w) == len(dam_w) == 4
    assert all(w["alarms"] == {} for w in held_w), held_w
    assert all("tooth_damage" in w["alarms"] for w in dam_w), dam_w


def test_shipped_fe_thresholds_do_not_fit_the_independent_machine(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The FE-learnt config/fault_thresholds.json on a healthy lumped record: the housing channels of
    another machine sit outside the FE model's healthy band, so the shipped thresholds alarm on a
    healthy record (docs/detection.md: 'what transfers and what does not')."""
    healthy = _record(tmp_path, "healthy", 3000.0, 30)
    wins = _check(capsys, healthy, str(ROOT / "config" / "fault_thresholds.json"))
    assert len(wins) == 4
    assert all(w["alarms"] for w in wins), wins


def test_cwru_inner_race_with_thresholds_learnt_on_the_normal_file() -> None:
    """CWRU drive end: bearing indicators (6205 geometry, no mesh) learnt on the first half of
    normal_0's windows at k = 6: the envelope line at BPFI is above its threshold in every window of
    IR007, the one at BPFO in every window of OR007, and the held-out half of normal_0 raises no
    alarm. The data folder: ``GEAR_ROTOR_CWRU_DIR`` or ../shared/data/cwru."""
    import importlib.util
    import os
    import sys

    from gear_rotor_sim.calibration.cwru import cwru_data_dir

    folder = Path(os.environ.get("GEAR_ROTOR_CWRU_DIR") or cwru_data_dir(ROOT))
    if not (folder / "IR007_0.mat").exists():
        pytest.skip(f"CWRU data not found in {folder}")
    spec = importlib.util.spec_from_file_location(
        "detection_independent", ROOT / "benchmarks" / "detection_independent.py"
    )
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # its dataclasses look their module up
    spec.loader.exec_module(mod)
    res = mod.score_cwru(mod.cwru_windows(folder), (6.0,))["k6"]
    assert res["false_alarm_any"] == 0.0
    # the envelope line at the 6205's BPFI itself (not only the kurtosis every bearing group shares)
    assert res["IR007_0.mat"]["indicators"]["env_bpfi"] == 1.0
    assert res["IR007_0.mat"]["own_group"] == 1.0
    assert res["OR007_at6_0.mat"]["indicators"]["env_bpfo"] == 1.0
