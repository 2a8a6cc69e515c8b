"""Calibration against real data: the CWRU bearing files in ../shared/data/cwru (see its README).

Truth is the seeded fault of each file (README): the inner- and outer-race files must be traced to
that defect type with the envelope error reduced; the healthy baseline must report no bearing
defect. For the ball file the README notes that no clear 2 x BSF line exists; the test only requires
that the tool does not claim a ball defect it cannot see and that the report says what was found.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from gear_rotor_sim.calibration.cwru import CWRU_FILES, calibrate_cwru, load_cwru

REPO = Path(__file__).resolve().parents[1]
DATA = (REPO / ".." / "shared" / "data" / "cwru").resolve()

pytestmark = pytest.mark.skipif(
    not all((DATA / f).exists() for f in CWRU_FILES),
    reason=f"CWRU data not found at {DATA} (expected ../shared/data/cwru relative to the repository)",
)

BEARING_DEFECTS = {"outer_race_defect", "inner_race_defect", "ball_defect"}


def _env_error(result, which: str) -> float:
    score = result.score_before if which == "before" else result.score_after
    return math.sqrt(score.chi2["envelope"] / score.n["envelope"])


def test_mapping_reads_rate_speed_and_units() -> None:
    m = load_cwru(DATA / "IR007_0.mat", duration_s=None)
    assert m.sample_rate_hz == 12000.0 and m.operating_point.speed_rpm == 1797.0
    assert m.model_channels == ["bearing1_housing_ay"] and m.channels[0].column == "X105_DE_time"
    assert 10.0 < m.duration_s < 10.2  # 121265 samples at 12 kHz
    n = load_cwru(DATA / "normal_0.mat", duration_s=1.0, rate_hz=None)
    assert n.sample_rate_hz == 48000.0 and n.n_samples == 48000 and n.operating_point.speed_rpm == 1796.0
    d = load_cwru(DATA / "normal_0.mat", duration_s=1.0)
    assert d.sample_rate_hz == 12000.0 and d.n_samples == 12000 and any("decimated" in s for s in d.issues)


@pytest.mark.parametrize(
    ("name", "expected"), [("IR007_0.mat", "inner_race_defect"), ("OR007_at6_0.mat", "outer_race_defect")]
)
def test_faulty_files_traced_to_the_seeded_defect(name: str, expected: str) -> None:
    r = calibrate_cwru(DATA / name)
    assert r.effects, r.conclusion
    first = r.effects[0]
    assert first.name == expected and first.label == f"{expected}@bearing1"
    assert first.confidence > 0.9
    # the envelope-spectrum error drops by at least a factor of 5 (measured: about 16 and 22)
    assert _env_error(r, "after") < 0.2 * _env_error(r, "before")
    assert r.error_after < 0.2 * r.error_before
    # no second, different bearing defect claimed on top of the seeded one
    assert not any(
        e.name in BEARING_DEFECTS and e.name != expected for e in r.effects[1:] if e.confidence > 0.5
    )


def test_healthy_file_reports_no_bearing_defect() -> None:
    r = calibrate_cwru(DATA / "normal_0.mat")
    assert not any(e.name in BEARING_DEFECTS for e in r.effects), [e.label for e in r.effects]


def test_ball_file_is_reported_honestly() -> None:
    r = calibrate_cwru(DATA / "B007_0.mat")
    # README: no clear peak at 2 x BSF in this file: a ball defect must not be claimed from it
    assert not any(e.name == "ball_defect" for e in r.effects)
    assert r.conclusion


@pytest.mark.acceptance
def test_cli_json_contract(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from gear_rotor_sim.cli import main

    rc = main(
        [
            "calibrate",
            str(DATA / "OR007_at6_0.mat"),
            "--json",
            "--duration",
            "3",
            "--report",
            str(tmp_path / "rep"),
        ]
    )
    assert rc == 0
    out = capsys.readouterr().out.strip()
    obj = json.loads(out)  # exactly one JSON object on stdout
    assert set(obj) >= {"effects", "error_before", "error_after", "per_channel_before", "per_channel_after"}
    assert obj["effects"][0]["name"] == "outer_race_defect"
    assert set(obj["effects"][0]) >= {"name", "parameters", "confidence"}
    assert obj["error_after"] < obj["error_before"]
    assert "bearing1_housing_ay" in obj["per_channel_before"]
    md = (tmp_path / "rep" / "OR007_at6_0.md").read_text()
    assert "outer_race_defect@bearing1" in md
    assert (tmp_path / "rep" / "OR007_at6_0_envelope_spectra.png").stat().st_size > 10_000


def test_cli_rejects_invalid_measurement(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from gear_rotor_sim.cli import main

    (tmp_path / "bad.csv").write_text("time_s,x\n0,1\n0.001,2\n")
    (tmp_path / "bad.yaml").write_text(
        "sample_rate_hz: 1000\noperating_point: {speed_rpm: 3000, temperature_c: 25}\n"
        "gearbox: paper_sun2021\nchannels:\n  - {column: x, quantity: strain, unit: m}\n"
    )
    assert main(["calibrate", str(tmp_path / "bad.csv")]) == 2
    assert "unknown quantity" in capsys.readouterr().err
