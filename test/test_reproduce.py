"""``gear-rotor-sim reproduce`` on a tiny configuration: JSON keys, and physics against closed forms.

Independent truths used here (hand formulas from the paper's tables, not the model's code):
* the static mesh load T2 / r_b2 (200 N m on the 49-tooth gear's base radius) shared equally by the two
  bearings of the input shaft (pinion mid-span) sets the 25 C bearing-2 force at low speed;
* a shaft heated by dT and held axially by two bearing springs k_b carries
  ``F = k_s a dT L / (1 + 2 k_s / k_b)`` with ``k_s = E(T) A / L``; its ends move ``F / k_b``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from gear_rotor_sim import cli

L_SHAFT = 0.140  # m, Table 4 (6 x 20 mm + 2 x 10 mm)
AREA = math.pi / 4 * 0.030**2  # m^2, 30 mm solid shaft
ALPHA = 1.17e-5  # 1/C
E_GPA = {125.0: 200.0, 225.0: 189.0}  # Table 1
K_AXIAL_A = 2.28e7  # N/m, Table 5 A#


def _axial(t: float) -> tuple[float, float]:
    k_s = E_GPA[t] * 1e9 * AREA / L_SHAFT
    force = k_s * ALPHA * (t - 25.0) * L_SHAFT / (1.0 + 2.0 * k_s / K_AXIAL_A)
    return force, force / K_AXIAL_A * 1e6


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path]:
    out = tmp_path_factory.mktemp("repro")
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = cli.main(["reproduce", "--level", "tiny", "--json", "--workers", "1", "--out", str(out)])
    assert rc == 0
    return json.loads(buf.getvalue()), out


def test_json_keys_and_paper_values(tiny: tuple[dict, Path]) -> None:
    r, out = tiny
    assert [row["temperature_c"] for row in r["fig7_1000rpm"]] == [25.0, 125.0, 225.0]
    assert [row["paper_n"] for row in r["fig7_1000rpm"]] == [1088.0, 1855.0, 3434.0]
    assert [row["paper_um"] for row in r["fig8_19000rpm_node9"]] == [9.8, 81.5, 172.7]
    assert all(row["model_n"] > 0 for row in r["fig7_1000rpm"])
    assert set(r["benchmark"]) >= {"steps_per_s", "rtf_3000rpm", "rtf_20000rpm"}
    assert r["benchmark"]["steps_per_s"] > 0
    # issue 13: the default model (reduced modal basis, default dt rule) against the full one at 1024
    # located steps per mesh period (measured -0.25 % at the tiny level's point, the dt rule's error)
    b = r["benchmark"]
    assert b["default_model"] == "reduced"
    assert math.isfinite(b["speedup_vs_full"]) and b["speedup_vs_full"] > 0  # timing: no tight bound
    assert math.isfinite(b["max_rms_dte_error_pct"]) and 0.0 <= b["max_rms_dte_error_pct"] < 0.5
    assert (out / "REPRODUCTION.md").is_file()
    for name in (
        "fig6_bifurcation",
        "fig7_bearing_force",
        "fig8_displacement",
        "fig9_force_share",
        "fig10_orbit",
    ):
        png = out / "figures" / f"{name}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name


def test_cold_bearing_force_is_the_static_mesh_load_share(tiny: tuple[dict, Path]) -> None:
    r, _ = tiny
    r_b2 = 49 * 3e-3 / 2 * math.cos(math.radians(20.0))
    share = 200.0 / r_b2 / 2.0
    f25 = next(row["model_n"] for row in r["fig7_1000rpm"] if row["temperature_c"] == 25.0)
    assert f25 == pytest.approx(share, rel=0.08)


@pytest.mark.parametrize("t", [125.0, 225.0])
def test_hot_node9_displacement_is_the_thermal_axial_growth(tiny: tuple[dict, Path], t: float) -> None:
    r, _ = tiny
    force, u_um = _axial(t)
    model = next(row["model_um"] for row in r["fig8_19000rpm_node9"] if row["temperature_c"] == t)
    assert model == pytest.approx(u_um, rel=0.1)
    f = next(row["model_n"] for row in r["fig7_1000rpm"] if row["temperature_c"] == t)
    assert f > force  # the axial part alone is below the total


def test_benchmark_uses_the_scripts_measure_when_present(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from gear_rotor_sim.analysis import reproduce_bench

    script = tmp_path / "bench_solver.py"
    script.write_text(
        "def measure(quick: bool) -> dict:\n"
        "    return {'steps_per_s': 1.5e6, 'rtf_3000rpm': 40.0, 'rtf_20000rpm': 6.0, 'quick': quick,\n"
        "            'speedup_vs_full': 1.0, 'max_rms_dte_error_pct': 0.3}\n",
        encoding="utf-8",
    )
    monkeypatch.setattr(reproduce_bench, "BENCH_SOLVER", script)
    got = reproduce_bench.benchmark(0.001, quick=True)
    assert got["steps_per_s"] == 1.5e6 and got["quick"] is True
    assert got["max_rms_dte_error_pct"] == 0.3  # the script's own figures are kept
    assert got["source"] == "benchmarks/bench_solver.py"
    script.write_text("def main() -> None:\n    pass\n", encoding="utf-8")
    assert reproduce_bench._bench_solver_measure() is None
