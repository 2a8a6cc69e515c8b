"""Calibration self-test (issue 6 acceptance): data from our simulator with one undeclared effect.

For every effect of the library, at two operating points, the measurement (CSV + sidecar, the user
contract) holds the injected effect, 3 % RMS noise, a 3 % sensor-gain error per channel and mesh
damping +20 % (a nuisance mismatch); nothing of this is declared. The tool must name the injected
effect first, fit its main parameter within 25 % of the truth, and at least halve the error; the
healthy controls (same nuisances, no effect) must claim nothing.

The test runs each effect at one of the two points (:data:`TESTED_CASES`): where both points hold the
same effect at the same location, the second checks the same path again (the same candidate and rules
at another speed), so eight such cases run only in ``benchmarks/calibration_selftest.py``, which prints
all of :data:`CASES` (docs/history/calibration_sessions.md Sec. 8.72). The mass unbalance (nodes 3 and
8) and the inner-race defect (bearings 3 and 2) stay at both points: different locations.

The model is a compact version of the paper's gearbox (Sun et al. 2021, Fig 5: the same shafts,
gears, bearings and mesh, four elements per shaft instead of eight) so that the whole matrix runs in
about two minutes; signatures are simulated once per operating point and reused (cached runs).
"""

from __future__ import annotations

import zlib
from pathlib import Path

import pytest
import yaml

from gear_rotor_sim.calibration.fit import Calibrator, synthetic_measurement
from gear_rotor_sim.calibration.measurement import load_measurement
from gear_rotor_sim.faults import (
    BearingDefect,
    Effect,
    GearEccentricity,
    MassUnbalance,
    MeshStiffnessDamping,
    ShaftMisalignment,
    TemperatureOffset,
    ToothDamage,
    ToothWear,
    effect_name,
)

REPO = Path(__file__).resolve().parents[1]
CHANNELS = ["dte", "bearing2_fy", "bearing3_fy", "node3_ay"]
OPS = {"A": (3000.0, 25.0), "B": (3500.0, 50.0)}
STEPS_PER_MESH = 32  # the streaming default; identical for data and model

# (operating point, injected effect, main parameter)
CASES: list[tuple[str, Effect, str]] = [
    ("A", GearEccentricity(member="pinion", eccentricity_m=10e-6, phase_rad=0.5), "eccentricity_m"),
    ("A", GearEccentricity(member="gear", eccentricity_m=10e-6, phase_rad=-1.0), "eccentricity_m"),
    ("A", MassUnbalance(node=3, unbalance_kg_m=4e-4, phase_rad=1.0), "unbalance_kg_m"),
    ("A", ShaftMisalignment(node=1, offset_m=1e-4, phase_rad=0.3), "offset_m"),
    ("A", ToothDamage(tooth=7, depth=0.5), "depth"),
    ("A", ToothWear(wear_depth_m=30e-6), "wear_depth_m"),
    ("A", TemperatureOffset(offset_c=250.0), "offset_c"),
    ("A", BearingDefect(kind="outer", bearing=2, force_n=3000.0, seed=5), "force_n"),
    ("A", BearingDefect(kind="inner", bearing=3, force_n=6000.0, seed=6), "force_n"),
    ("A", BearingDefect(kind="ball", bearing=2, force_n=5000.0, seed=7), "force_n"),
    ("B", GearEccentricity(member="pinion", eccentricity_m=8e-6, phase_rad=2.0), "eccentricity_m"),
    ("B", GearEccentricity(member="gear", eccentricity_m=8e-6, phase_rad=1.5), "eccentricity_m"),
    ("B", MassUnbalance(node=8, unbalance_kg_m=6e-4, phase_rad=-2.0), "unbalance_kg_m"),
    ("B", ShaftMisalignment(node=1, offset_m=1.2e-4, phase_rad=-1.2), "offset_m"),
    ("B", ToothDamage(tooth=20, depth=0.4), "depth"),
    ("A", ToothDamage(wheel="gear", tooth=11, depth=0.5), "depth"),
    ("B", ToothWear(wear_depth_m=30e-6), "wear_depth_m"),
    ("B", TemperatureOffset(offset_c=200.0), "offset_c"),  # 250 would be the material-range bound
    ("B", BearingDefect(kind="outer", bearing=2, force_n=4000.0, seed=15), "force_n"),
    ("B", BearingDefect(kind="inner", bearing=2, force_n=6000.0, seed=16), "force_n"),
    ("B", BearingDefect(kind="ball", bearing=2, force_n=6000.0, seed=17), "force_n"),
]

#: the cases the benchmark alone runs; the same effect at the same location stays tested at the other
#: point: pinion and gear eccentricity at A; shaft misalignment (node 1), pinion tooth damage, tooth wear,
#: temperature offset, outer-race and ball defects (bearing 2) at B
BENCHMARK_ONLY = {
    "A-shaft_misalignment@node1",
    "A-tooth_damage@pinion",
    "A-tooth_wear",
    "A-temperature_offset",
    "A-outer_race_defect@bearing2",
    "A-ball_defect@bearing2",
    "B-pinion_eccentricity",
    "B-gear_eccentricity",
}
TESTED_CASES = [c for c in CASES if f"{c[0]}-{c[1].label}" not in BENCHMARK_ONLY]


def compact_gearbox_dict() -> dict:
    """The paper's gearbox with pairs of shaft elements merged (nodes 1-5 and 6-10)."""
    d = yaml.safe_load((REPO / "config" / "paper_sun2021.yaml").read_text())
    for sh in d["shafts"]:
        e = sh["elements"]
        sh["elements"] = [
            {
                "length_mm": e[i]["length_mm"] + e[i + 1]["length_mm"],
                "outer_diameter_mm": e[i]["outer_diameter_mm"],
            }
            for i in range(0, 8, 2)
        ]
    d["bearings"] = [{"node": n, "type": "A#"} for n in (1, 5, 6, 10)]
    d["gears"][0]["node"], d["gears"][1]["node"] = 3, 8
    d["drive"]["node"], d["load"]["node"] = 1, 10
    d["name"] = "paper_sun2021_compact"
    return d


@pytest.fixture(scope="module")
def rig(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    from gear_rotor_sim.config import load_config

    root = tmp_path_factory.mktemp("selftest")
    path = root / "paper_sun2021_compact.yaml"
    path.write_text(yaml.safe_dump(compact_gearbox_dict()))
    return root, load_config(path)


def _run(rig: tuple[Path, object], op: str, effects: list[Effect], seed: int, tag: str):
    root, cfg = rig
    speed, temp = OPS[op]
    csv = synthetic_measurement(
        cfg,
        effects,
        speed,
        temp,
        CHANNELS,
        root / f"{tag}.csv",
        str(root / "paper_sun2021_compact.yaml"),
        seed=seed,
        output_torque_nm=200.0,
        steps_per_mesh=STEPS_PER_MESH,
    )
    m = load_measurement(csv)  # through the user contract: nothing about the effect is declared
    assert "effect" not in (root / f"{tag}.yaml").read_text()
    return Calibrator(m, cfg, steps_per_mesh=STEPS_PER_MESH).run()


@pytest.mark.acceptance
@pytest.mark.parametrize("op", ["A", "B"])
def test_healthy_control_claims_nothing(rig, op: str) -> None:
    r = _run(rig, op, [], seed=100, tag=f"healthy_{op}")
    assert r.effects == [], [(e.label, e.parameters) for e in r.effects]
    assert r.error_before < 1.5  # at the noise level despite gain error, noise and damping +20 %


#: Known misses, each with its measured value.
KNOWN_MISSES: dict[str, str] = {}


@pytest.mark.acceptance
@pytest.mark.parametrize(
    ("op", "effect", "param"),
    [
        pytest.param(
            *case,
            id=f"{case[0]}-{case[1].label}",
            marks=[pytest.mark.xfail(reason=KNOWN_MISSES[f"{case[0]}-{case[1].label}"])]
            if f"{case[0]}-{case[1].label}" in KNOWN_MISSES
            else [],
        )
        for case in TESTED_CASES
    ],
)
def test_injected_effect_is_found(rig, op: str, effect: Effect, param: str) -> None:
    r = _run(
        rig,
        op,
        [effect],
        seed=zlib.crc32(effect.label.encode()) % 1000,
        tag=f"{op}_{effect.label.replace('@', '_')}",
    )
    assert r.effects, f"nothing found; error {r.error_before:.3g}; {r.conclusion}; {r.rounds[:1]}"
    first = r.effects[0]
    assert first.name == effect_name(effect) and first.label == effect.label
    truth = float(getattr(effect, param))
    fitted = first.parameters[param]
    assert abs(fitted - truth) <= 0.25 * abs(truth), f"{param}: fitted {fitted:.4g}, truth {truth:.4g}"
    if isinstance(effect, ToothDamage):
        assert first.parameters["tooth"] == effect.tooth
    assert r.error_after <= 0.5 * r.error_before, (r.error_before, r.error_after)
    assert first.confidence > 0.9


@pytest.mark.acceptance
@pytest.mark.parametrize(("op", "scale"), [("A", 0.6), ("B", 1.5)])
def test_mesh_stiffness_is_a_baseline_update_not_an_effect(rig, op: str, scale: float) -> None:
    """A mesh stiffness off by -40 % / +50 % is an uncertain nominal value: it is fitted as the
    baseline (``baseline_updates``), never reported in ``effects``."""
    r = _run(rig, op, [MeshStiffnessDamping(stiffness_scale=scale)], seed=7, tag=f"{op}_mesh_stiffness")
    assert r.effects == [], [(e.label, e.parameters) for e in r.effects]
    upd = {b.name: b.parameters for b in r.baseline_updates}
    assert "mesh_stiffness_damping" in upd, upd
    assert abs(upd["mesh_stiffness_damping"]["stiffness_scale"] - scale) <= 0.25 * scale
    assert r.error_after <= 0.5 * r.error_before


def test_every_effect_of_the_table_stays_tested() -> None:
    """The cases left to the benchmark exist, and every effect (name and location) of :data:`CASES` is
    still run by :func:`test_injected_effect_is_found` at one point at least."""
    ids = {f"{op}-{e.label}" for op, e, _ in CASES}
    assert BENCHMARK_ONLY <= ids, BENCHMARK_ONLY - ids
    assert {e.label for _, e, _ in TESTED_CASES} == {e.label for _, e, _ in CASES}
    assert len(TESTED_CASES) == len(CASES) - len(BENCHMARK_ONLY) == 13
