"""``gear-rotor-sim validate``: Table 2 within 0.1 % of the paper and the mesh-stiffness summary keys."""

from __future__ import annotations

import json

import pytest

from gear_rotor_sim.cli import main

# Sun et al. (2021) Table 2, "Numerical calculation" row (x1e5 N), temperature rise from 25 C.
PAPER_TABLE2 = {
    50.0: 0.84346e5,
    100.0: 1.6538e5,
    150.0: 2.4187e5,
    200.0: 3.1257e5,
    250.0: 3.7624e5,
    300.0: 4.3164e5,
}


@pytest.fixture(scope="module")
def report() -> dict:
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(["validate", "--json"])
    assert rc == 0
    text = buf.getvalue().strip()
    assert text.count("\n") == 0  # one JSON object on one line
    return json.loads(text)


def test_table2_within_0_1_percent(report: dict) -> None:
    rows = report["table2"]
    assert [r["temperature_rise_c"] for r in rows] == sorted(PAPER_TABLE2)
    for r in rows:
        assert set(r) >= {"temperature_rise_c", "paper_n", "model_n", "rel_error"}
        paper = PAPER_TABLE2[r["temperature_rise_c"]]
        assert r["paper_n"] == pytest.approx(paper, rel=1e-12)
        assert abs(r["model_n"] / paper - 1.0) < 1e-3
        assert r["rel_error"] == pytest.approx(r["model_n"] / paper - 1.0, abs=1e-12)


def test_mesh_stiffness_summary(report: dict) -> None:
    rows = report["mesh_stiffness"]
    assert [r["temperature_c"] for r in rows] == [25.0, 125.0, 225.0]
    keys = {"temperature_c", "mean_n_per_m", "min_n_per_m", "max_n_per_m", "contact_ratio", "iso_ratio"}
    for r in rows:
        assert set(r) >= keys
        assert r["min_n_per_m"] < r["mean_n_per_m"] < r["max_n_per_m"]
        assert r["contact_ratio"] == pytest.approx(1.6985, abs=1e-4)  # 29/49, m 3, 20 deg closed form
        assert 0.70 <= r["iso_ratio"] <= 1.30
    # Stiffness falls with temperature as E(T) does (Table 1: 207 -> 200 -> 189 GPa), within 1 %.
    assert rows[1]["mean_n_per_m"] / rows[0]["mean_n_per_m"] == pytest.approx(200 / 207, rel=0.01)
    assert rows[2]["mean_n_per_m"] / rows[0]["mean_n_per_m"] == pytest.approx(189 / 207, rel=0.01)


def test_text_output(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["validate"]) == 0
    out = capsys.readouterr().out
    assert "Table 2" in out and "ISO ratio" in out
    assert "84346.0" in out
