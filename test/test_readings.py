"""Readings of the paper tried against Fig 6 (issue 13): the cases are the readings they name, the
downward sweep runs the speeds from the top, and the report states which readings fall inside."""

from __future__ import annotations

import numpy as np

from gear_rotor_sim.analysis.bifurcation import RunSettings, build_config, build_system
from gear_rotor_sim.analysis.readings import PUBLISHED, READINGS, reading_case, sweep


def _reading(key: str):
    return next(r for r in READINGS if r.key == key)


def test_reading_cases_change_only_what_they_name() -> None:
    base = build_config(reading_case(_reading("as_published"), "25C"))
    assert base.name == PUBLISHED and base.load.torque_nm == 200.0
    assert base.meshes[0].half_backlash_m == 35e-6
    assert all(m.gear_mass_in_mesh_matrix for m in base.meshes)
    backlash = build_config(reading_case(_reading("total_backlash"), "25C"))
    assert backlash.meshes[0].half_backlash_m == 17.5e-6
    assert backlash.replace(meshes=base.meshes) == base
    torque = build_config(reading_case(_reading("torque_150"), "25C"))
    assert torque.load.torque_nm == 150.0 and torque.load.node0 == base.load.node0
    assert torque.replace(load=base.load) == base
    # the static mesh force follows the torque: T2 / r_bg (lever rule, frictionless statics)
    from gear_rotor_sim.system import mesh_forces, static_solution

    s150 = build_system(reading_case(_reading("torque_150"), "25C"))
    s200 = build_system(reading_case(_reading("as_published"), "25C"))
    f150 = mesh_forces(s150, static_solution(s150))[0]
    f200 = mesh_forces(s200, static_solution(s200))[0]
    assert abs(f150 / f200 - 0.75) <= 1e-9
    assert _reading("sweep_down").downward and not _reading("sweep_down").overrides


def test_downward_sweep_continues_from_the_top_speed() -> None:
    """The downward sweep starts cold at the highest speed (longer first transient) and returns the
    speeds in increasing order; its top speed equals a cold upward run started there."""
    settings = RunSettings(10, 20, 16, 2.0)
    case = reading_case(_reading("as_published"), "25C")
    speeds = np.array([3000.0, 3500.0, 4000.0])
    down = sweep(case, speeds, settings, downward=True)
    assert np.array_equal(down.speeds_rpm, speeds)
    cold_top = sweep(case, speeds[-1:], settings)
    np.testing.assert_array_equal(down.section[-1], cold_top.section[0])


def test_report_names_the_readings_inside_the_band() -> None:
    from gear_rotor_sim.analysis.reproduction_report import _write_readings

    rows = []
    for key, e25 in (("a", [-725.0, 100.0]), ("b", [625.0, 75.0])):
        rows.append(
            {
                "key": key,
                "title": f"reading {key}",
                "text": "quote",
                "bands_rpm": {"25C": [13500.0 + e25[0], 14700.0 + e25[1]]},
                "edge_errors_rpm": {"25C": e25},
                "windows_rpm": {"25C": []},
                "sequence_25c": [["period-1", 500.0, 20000.0]],
            }
        )
    lines: list[str] = []
    _write_readings(
        lines.append,
        {
            "readings": rows,
            "step_rpm": 25.0,
            "gap_rpm": 250.0,
            "fine_windows_rpm": {"25C": [12000.0, 15800.0]},
            "paper_rpm": {"25C": [13500.0, 14700.0]},
            "wall_time_s": 1.0,
        },
    )
    text = "\n".join(lines)
    assert "Fig 6a main band within +-700 rpm of the paper's at both edges: reading b." in text
    assert "12775-14800 (-725 / +100)" in text


def test_lower_edge_detail_reports_the_jump_into_chaos() -> None:
    """Two period-1 speeds (constant section) then three with an uncorrelated section (chaos by the
    0-1 test): the detail lists them with K and the section spread around the edge."""
    from gear_rotor_sim.analysis.bifurcation import BifurcationResult
    from gear_rotor_sim.analysis.readings import lower_edge_detail

    rng = np.random.default_rng(1)
    n, m = 5, 200
    section = np.zeros((n, m))
    section[2:] = rng.uniform(-1e-5, 1e-5, (3, m))
    res = BifurcationResult(
        case=reading_case(_reading("as_published"), "25C"),
        speeds_rpm=np.array([100.0, 200.0, 300.0, 400.0, 500.0]),
        section=section,
        section_v=np.zeros((n, m)),
        dte_min=np.full(n, -1e-5),
        dte_max=np.full(n, 1e-5),
        dte_rms=np.full(n, 5e-6),
        dte_v_range=np.ones(n),
        settings=RunSettings(10, m, 16, 2.0),
        wall_time_s=0.0,
    )
    d = lower_edge_detail(res, 300.0)
    assert [e["speed_rpm"] for e in d] == [100.0, 200.0, 300.0, 400.0, 500.0]
    assert [e["label"] for e in d] == ["period-1", "period-1", "chaotic", "chaotic", "chaotic"]
    assert all(e["k"] > 0.8 for e in d[2:]) and all(e["section_spread"] == 0.0 for e in d[:2])


def test_edge_verdict_tells_a_jump_from_weak_chaos() -> None:
    from gear_rotor_sim.analysis.reproduction_report import _edge_verdict

    jump = [{"speed_rpm": 100.0, "label": "period-2", "k": float("nan"), "section_spread": 0.4},
            {"speed_rpm": 200.0, "label": "chaotic", "k": 0.99, "section_spread": 0.7}]  # fmt: skip
    weak = [{**jump[0]}, {**jump[1], "k": 0.6}]
    assert "fully developed chaos (K 0.99 at 200 rpm)" in _edge_verdict(jump)
    assert "weak chaos (K 0.60 at 200 rpm)" in _edge_verdict(weak)
