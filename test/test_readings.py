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
    from gear_rotor_sim.analysis.report_published import write_readings

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
    write_readings(
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
    from gear_rotor_sim.analysis.report_published import edge_verdict

    jump = [{"speed_rpm": 100.0, "label": "period-2", "k": float("nan"), "section_spread": 0.4},
            {"speed_rpm": 200.0, "label": "chaotic", "k": 0.99, "section_spread": 0.7}]  # fmt: skip
    weak = [{**jump[0]}, {**jump[1], "k": 0.6}]
    assert "fully developed chaos (K 0.99 at 200 rpm)" in edge_verdict(jump)
    assert "weak chaos (K 0.60 at 200 rpm)" in edge_verdict(weak)


def test_new_readings_change_only_what_they_name() -> None:
    base = build_config(reading_case(_reading("as_published"), "25C"))
    nodamp = build_config(reading_case(_reading("no_shaft_damping"), "25C"))
    assert nodamp.rayleigh_damping.stiffness_s == 0.0 and base.rayleigh_damping.stiffness_s > 0.0
    assert nodamp.replace(rayleigh_damping=base.rayleigh_damping) == base
    fresh = _reading("fresh_start")
    assert fresh.fresh and not fresh.overrides and not fresh.downward
    assert build_config(reading_case(fresh, "25C")) == base
    # the transmission-error phase is an override of the mesh (the edge-sensitivity table varies it)
    from gear_rotor_sim.analysis.bifurcation import Case

    phased = build_config(Case(25.0, overrides=(("transmission_error_phase_rad", 1.25),)))
    assert phased.meshes[0].transmission_error_phase_rad == 1.25


def test_fresh_sweep_starts_every_speed_cold() -> None:
    """Without continuation each speed equals a cold run started at that speed alone, whatever came
    before it; with continuation the second speed starts from the first one's final state."""
    settings = RunSettings(10, 20, 16, 2.0)
    case = reading_case(_reading("as_published"), "25C")
    speeds = np.array([3000.0, 3500.0])
    fresh = sweep(case, speeds, settings, fresh=True)
    cont = sweep(case, speeds, settings)
    cold = sweep(case, speeds[1:], settings)
    assert np.array_equal(fresh.speeds_rpm, speeds) and fresh.meta["fresh"]
    np.testing.assert_array_equal(fresh.section[1], cold.section[0])
    np.testing.assert_array_equal(fresh.section[0], cont.section[0])
    assert not np.array_equal(cont.section[1], cold.section[0])


def test_edge_sensitivity_reports_divergence_and_renders(monkeypatch) -> None:
    """A variation whose run leaves the physical range is a row with the speed where it did (not
    dropped, not an exception); the report lists the bands and says which variations moved the edge."""
    from gear_rotor_sim.analysis import readings
    from gear_rotor_sim.analysis.report_published import write_edge_sensitivity
    from gear_rotor_sim.solver.newmark import SimulationDiverged

    bands = {"reference": (12775.0, 14700.0), "a": (13125.0, 14775.0), "b": None, "c": (12775.0, 14675.0)}

    def fake_sweep(case, speeds, settings, downward=False, fresh=False):
        key = dict(case.overrides).get("damping_ratio", 0.0)
        name = {0.0: "reference", 0.05: "a", 0.03: "b"}.get(key, "c")
        if bands[name] is None:
            raise SimulationDiverged(1.0, 15500.0, 25.0, "|DTE| above 0.01 m")
        return bands[name]

    monkeypatch.setattr(readings, "sweep", fake_sweep)
    monkeypatch.setattr(readings, "main_band_of", lambda res, gap: res)
    var = (
        readings.Variation("reference", "ref"),
        readings.Variation("a", "zeta 0.05", (("damping_ratio", 0.05),)),
        readings.Variation("b", "zeta 0.03", (("damping_ratio", 0.03),)),
        readings.Variation("c", "transient x 2", transient_factor=2.0),
    )
    es = readings.edge_sensitivity(RunSettings(10, 20, 16, 2.0), variations=var)
    rows = {r["key"]: r for r in es["rows"]}
    assert rows["b"]["diverged_rpm"] == 15500.0 and rows["a"]["diverged_rpm"] is None
    assert rows["a"]["edge_errors_rpm"] == [13125.0 - 13500.0, 14775.0 - 14700.0]
    lines: list[str] = []
    write_edge_sensitivity(lines.append, es)
    text = "\n".join(lines)
    assert "| zeta 0.03 | run diverged at 15500 rpm | - | - |" in text
    assert "| zeta 0.05 | 13125-14775 | -375 / +75 | yes |" in text
    assert "| ref | 12775-14700 | -725 / +0 | no |" in text
    assert "zeta 0.05 (+350 rpm)" in text and "unchanged (same grid speed) with: transient x 2." in text


def test_readings_study_keeps_a_diverged_panel(monkeypatch) -> None:
    """A panel whose sweep leaves the physical range is reported with the speed, the other panels
    and the report carry on."""
    from gear_rotor_sim.analysis import readings
    from gear_rotor_sim.analysis.report_published import write_readings
    from gear_rotor_sim.solver.newmark import SimulationDiverged

    real = readings.sweep

    def fake(case, speeds, settings, downward=False, fresh=False):
        if case.temperature_c == 225.0 and case.thermal_backlash:
            raise SimulationDiverged(1.0, 13275.0, 225.0, "non-finite state")
        return real(case, speeds[:2], settings, downward, fresh)

    monkeypatch.setattr(readings, "sweep", fake)
    st = readings.readings_study(
        RunSettings(10, 20, 16, 2.0), np.array([3000.0, 3500.0]), readings=READINGS[:1]
    )
    row = st["readings"][0]
    assert row["diverged_rpm"] == {"225C": 13275.0}
    assert np.isnan(row["bands_rpm"]["225C"][0]) and row["sequence_25c"]
    lines: list[str] = []
    write_readings(lines.append, st)
    assert "run diverged at 13275 rpm" in "\n".join(lines)


def test_summary_states_the_band_and_the_readings_range() -> None:
    from gear_rotor_sim.analysis.report_published import readings_summary

    def row(title: str, a: list[float], b: list[float]) -> dict:
        return {
            "title": title,
            "bands_rpm": {"25C": a, "225C": b},
            "edge_errors_rpm": {"25C": [a[0] - 13500, a[1] - 14700], "225C": [b[0] - 13000, b[1] - 14200]},
        }

    rd = {
        "paper_rpm": {"25C": [13500.0, 14700.0], "225C": [13000.0, 14200.0]},
        "readings": [
            row("as published", [12775.0, 14700.0], [12600.0, 14150.0]),
            row("total backlash", [14125.0, 14875.0], [15500.0, 15550.0]),
        ],
    }
    text = readings_summary(rd, [12792.0, 14642.0])
    assert "12792-14642 rpm, edge errors -708 / -58 rpm" in text and "(not within +-700 rpm)" in text
    assert "between 12775 and 14125 rpm" in text
    assert "within +-700 rpm: total backlash; none puts all three panels there" in text
    assert "(within +-700 rpm)." in readings_summary(rd, [12800.0, 14642.0])


def test_config_overrides_change_only_their_field() -> None:
    import dataclasses

    import pytest

    from gear_rotor_sim.analysis.bifurcation import Case
    from gear_rotor_sim.system import mesh_forces, static_solution

    base_case = reading_case(_reading("as_published"), "25C")
    base = build_config(base_case)

    def with_(*ov: tuple[str, float]):
        return build_config(dataclasses.replace(base_case, overrides=ov))

    assert with_(("reference_temperature_c", 20.0)).replace(reference_temperature_c=25.0) == base
    assert with_(("shear_coefficient", 1.0)).shear_coefficient == 1.0
    moved = with_(("load_node", 14.0))
    assert moved.load.node0 == 13 and moved.load.torque_nm == base.load.torque_nm
    assert moved.replace(load=base.load) == base
    tilt = with_(("bearing_tilt_stiffness_scale", 2.0), ("bearing_tilt_damping", 0.0))
    for a, b in zip(tilt.bearings, base.bearings, strict=True):
        assert a.properties.k_tilt == 2.0 * b.properties.k_tilt and a.properties.c_tilt == 0.0
        assert (
            dataclasses.replace(a.properties, k_tilt=b.properties.k_tilt, c_tilt=b.properties.c_tilt)
            == b.properties
        )
    # the output torque reaches the mesh through the output shaft either way: the static mesh force
    # is T2 / r_bg whether the torque acts on the shaft end (node 18) or on the gear (node 14)
    s18 = build_system(base_case)
    s14 = build_system(dataclasses.replace(base_case, overrides=(("load_node", 14.0),)))
    f18 = mesh_forces(s18, static_solution(s18))[0]
    f14 = mesh_forces(s14, static_solution(s14))[0]
    assert abs(f14 / f18 - 1.0) <= 1e-9
    for ov, msg in (
        (("load_node", 19.0), r"load_node: 19.0 must be a node number 1..18"),
        (("shear_coefficient", 0.0), r"shear_coefficient: 0.0 must be within \(0, 2\]"),
        (("bearing_tilt_stiffness_scale", -1.0), r"bearing_tilt_stiffness_scale: -1.0 must be finite"),
        (("bearing_tilt_damping", -1.0), r"bearing_tilt_damping: -1.0 must be finite and >= 0"),
    ):
        with pytest.raises(ValueError, match=msg):
            build_config(Case(25.0, overrides=(ov,)))


def test_nonlinear_hertz_scale() -> None:
    """The same Eq 13-14 combination with the linear k_h reproduces the model's table (built by another
    path, SpurGearPair.mesh_stiffness_at); in single contact the pair carries T2 / r_bg and the
    non-linear stiffness is the table's with the Hertz compliance swapped, in closed form."""
    from gear_rotor_sim.analysis.readings import (
        hertz_variation,
        nonlinear_hertz_scale,
        nonlinear_hertz_stiffness,
    )
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.gears import paper_gear_pair

    k_lin, table = nonlinear_hertz_stiffness(linear=True)
    assert np.max(np.abs(k_lin / table - 1.0)) <= 1e-12
    k_nl, table = nonlinear_hertz_stiffness()
    pair = paper_gear_pair(load_config(PUBLISHED).materials["carbon_steel"])
    single = pair.mesh_stiffness_table(25.0).n_pairs == 1
    force = 200.0 / pair.base_radius(False)
    kh_nl = 207e9**0.9 * 0.02**0.8 * force**0.1 / 1.275  # 1.16e9 N/m
    expected = 1.0 / (1.0 / table + 1.0 / kh_nl - 1.0 / pair.hertz_stiffness(25.0))
    assert single.any() and np.max(np.abs(k_nl[single] / expected[single] - 1.0)) <= 1e-12
    assert np.all(k_nl < table)  # a softer contact everywhere (1.16e9 and less, against 3.55e9)
    scale = nonlinear_hertz_scale()
    assert abs(scale - k_nl.mean() / table.mean()) <= 1e-15
    v = hertz_variation()
    assert v.overrides == (("mesh_stiffness_scale", scale),) and "proxy" in v.title
