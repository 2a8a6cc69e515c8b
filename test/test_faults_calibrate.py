"""The loop closes on our own fault data (issue 12, last interface line): a recording made with
``record --faults`` is traced by ``calibrate --json`` back to the injected tooth damage."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

FAULTS_YAML = "faults: [{type: tooth_damage, wheel: gear, tooth: 5, depth: 0.3}]\n"


@pytest.mark.acceptance
def test_calibrate_names_the_injected_tooth_damage(tmp_path: Path) -> None:
    faults = tmp_path / "FAULTS.yaml"
    faults.write_text(FAULTS_YAML, encoding="utf-8")
    run = tmp_path / "run.mcap"
    cli = [sys.executable, "-m", "gear_rotor_sim.cli"]
    subprocess.run(
        [*cli, "record", "--speed-rpm", "3000", "--temperature-c", "25", "--duration-s", "2",
         "--faults", str(faults), "--out", str(run)],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    # the first effect is what is asserted: the search stops there (--max-effects 1; Sec. 8.74)
    cmd = [*cli, "calibrate", str(run), "--json", "--max-effects", "1"]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True)
    effects = json.loads(out.stdout)["effects"]
    assert effects, "no effect named"
    first = effects[0]
    assert first["name"] == "tooth_damage", first
    assert first["parameters"].get("wheel") == "gear" and int(first["parameters"]["tooth"]) == 5, first
