"""Ramps on coarse basis grids (25 % of speed, 5 C; ramp systems between) against the per-quantum rebuild."""

from __future__ import annotations

import dataclasses
import pickle
from pathlib import Path

import numpy as np
import pytest

from gear_rotor_sim.config import load_config
from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.simulator import TEMPERATURE_QUANTUM_C, Simulator
from gear_rotor_sim.solver import basis_cache
from gear_rotor_sim.solver.basis_cache import basis_key, cache_dir, cached_eigen_basis
from gear_rotor_sim.solver.newmark import SPEED_QUANTUM_REL, LinearModel, NewmarkStepper
from gear_rotor_sim.solver.rebase import ThermalLoad, interpolated_system
from gear_rotor_sim.system import GearRotorSystem

CHANNELS = ["dte", "mesh_force", "bearing1_fx", "bearing1_fz", "node5_ay"]


def _ramp(target: dict, duration_s: float, **grids: float) -> tuple[np.ndarray, Simulator]:
    sim = Simulator(paper_gearbox(), speed_rpm=3000.0, temperature_c=25.0, channels=CHANNELS, **grids)
    sim.advance(0.1)
    sim.set_targets(**target)
    return np.asarray(sim.advance(duration_s).data), sim


@pytest.mark.parametrize(
    ("target", "duration_s"),
    [({"speed_rpm": 3600.0}, 0.35), ({"temperature_c": 35.0}, 0.55)],
    ids=["speed-3000-3600rpm", "temperature-25-35C"],
)
def test_ramp_on_coarse_grids_equals_per_quantum_rebuild(target: dict, duration_s: float) -> None:
    """The stream through a ramp at the default rates (2000 rpm/s, 20 C/s) on the ramp grids equals
    the per-quantum rebuild (1 % of speed, 0.5 C) within 0.5 % RMS on every channel."""
    ref, _ = _ramp(
        target,
        duration_s,
        ramp_speed_quantum_rel=SPEED_QUANTUM_REL,
        ramp_temperature_quantum_c=TEMPERATURE_QUANTUM_C,
    )
    new, sim = _ramp(target, duration_s)
    assert sim.speed_rpm == target.get("speed_rpm", 3000.0)
    assert sim.temperature_c == target.get("temperature_c", 25.0)
    rms = np.sqrt(np.mean(ref**2, axis=0))
    diff = np.sqrt(np.mean((new - ref) ** 2, axis=0))
    assert np.all(diff <= 5e-3 * rms), diff / rms


def test_ramp_grids_are_validated() -> None:
    with pytest.raises(ValueError, match="ramp_speed_quantum_rel"):
        Simulator(paper_gearbox(), ramp_speed_quantum_rel=0.001)
    with pytest.raises(ValueError, match="ramp_temperature_quantum_c"):
        Simulator(paper_gearbox(), ramp_temperature_quantum_c=float("nan"))


def test_ramp_with_custom_builder_equals_per_quantum_rebuild() -> None:
    """A custom ``system_builder`` takes the path without RampSpan (a stepper per quantum, the thermal
    load interpolated between the nodes): 25 -> 35 C within 0.5 % RMS of the per-quantum rebuild."""

    def builder(cfg: object, t: float) -> object:
        return GearRotorSystem.from_config(cfg, t)

    def run(**grids: float) -> np.ndarray:
        sim = Simulator(paper_gearbox(), channels=CHANNELS, system_builder=builder, **grids)
        sim.advance(0.1)
        sim.set_targets(temperature_c=35.0)
        return np.asarray(sim.advance(0.55).data)

    ref = run(ramp_temperature_quantum_c=TEMPERATURE_QUANTUM_C)
    new = run()
    rms = np.sqrt(np.mean(ref**2, axis=0))
    assert np.all(np.sqrt(np.mean((new - ref) ** 2, axis=0)) <= 5e-3 * rms)


def _flat(x: object, name: str = "") -> dict[str, np.ndarray]:
    if isinstance(x, np.ndarray):
        return {name: x}
    if isinstance(x, tuple):
        return {k: v for i, e in enumerate(x) for k, v in _flat(e, f"{name}[{i}]").items()}
    if dataclasses.is_dataclass(x):
        out: dict[str, np.ndarray] = {}
        for f in dataclasses.fields(x):
            if f.name not in ("basis", "xrec"):
                out.update(_flat(getattr(x, f.name), f"{name}.{f.name}"))
        return out
    return {}


@pytest.mark.parametrize("rig", ["paper", "two_stage_example"])
def test_ramp_span_arrays_equal_a_rebuild(rig: str) -> None:
    """The kernel arrays a RampSpan sets per quantum (affine corrections of its node's) equal those
    built from scratch for the same ramp system, to 1e-9 of each array's largest entry (reduced basis
    with residual flexibility, the default on every rig; the two-stage rig: two meshes and the exact
    modal map the dt rule takes there)."""
    cfg = paper_gearbox() if rig == "paper" else load_config(rig)
    sim = Simulator(cfg, speed_rpm=3000.0, temperature_c=25.0)
    sim.advance(0.1)
    sim.set_targets(temperature_c=45.0)
    seen = []
    # at about 31 C, then 0.5 C on: two quanta between the basis nodes 30 and 35 on node 30's span (the
    # span refills its arrays in place at each quantum)
    for step_s in (0.3, 0.025):
        sim.advance(step_s)
        st = sim._stepper
        assert st.system.temperature_c not in (30.0, 35.0) and 30.0 in sim._spans
        seen.append(st.system.temperature_c)
        fresh = NewmarkStepper(st.system, sim.specs, sim.effects, locate_events=sim.locate_events)
        fresh.modal_cutoff_hz = st.modal_cutoff_hz
        fresh.exact_map = st.exact_map
        assert st.modal_cutoff_hz is not None and st.exact_map == (rig != "paper")
        fresh.set_operating_point(st.map.basis.omega, st.map.dt, sim.state)
        for obj, ref in ((st.map, fresh.map), (st.gear, fresh.gear)):
            a, b = _flat(obj), _flat(ref)
            assert a.keys() == b.keys()
            for k in b:
                scale = np.max(np.abs(b[k])) if b[k].size else 0.0
                assert np.max(np.abs(a[k] - b[k]), initial=0.0) <= 1e-9 * scale, k
    assert seen[1] == seen[0] + TEMPERATURE_QUANTUM_C  # two quanta of the same span


def test_thermal_load_per_material_equals_assembly() -> None:
    """ThermalLoad (one modulus evaluation per material, memoised per temperature) equals the element
    loop of the assembly, on a second call and after a pickle round trip (the memo is keyed by id())."""
    cfg = paper_gearbox()
    model = ThermalLoad(cfg)
    assert model.units is not None
    for t in (25.0, 87.3, 125.0):
        ref = GearRotorSystem.from_config(cfg, t).thermal_load
        for m in (model, model, pickle.loads(pickle.dumps(model))):
            assert np.linalg.norm(m(t) - ref) <= 1e-12 * max(np.linalg.norm(ref), 1.0)


def test_interpolated_node_system_against_assembly() -> None:
    """A node system interpolated over 25 C (25 -> 50 C) against the exact assembly at 37.5 C: b* and the
    thermal load exact (Eq 27 is linear in T), K, M and the mesh tables within 1e-3 (the quadratic
    E*(T) fit of Table 1 bends by about 1.5e-4 over 25 C)."""
    cfg = paper_gearbox()
    lo, hi, mid = (GearRotorSystem.from_config(cfg, t) for t in (25.0, 50.0, 37.5))
    sys = interpolated_system(lo, hi, 37.5, ThermalLoad(cfg)(37.5))
    m, r = sys.meshes[0], mid.meshes[0]
    assert m.half_backlash == pytest.approx(r.half_backlash, rel=1e-12)
    assert np.linalg.norm(sys.static_load - mid.static_load) <= 1e-12 * np.linalg.norm(mid.static_load)
    for a, b in ((sys.K, mid.K), (sys.M, mid.M)):
        assert np.linalg.norm(a - b) <= 1e-3 * np.linalg.norm(b)
    assert np.max(np.abs(m.table_stiffness - r.table_stiffness)) <= 1e-3 * np.max(r.table_stiffness)
    assert m.mean_stiffness == pytest.approx(r.mean_stiffness, rel=1e-3)
    change = np.max(np.abs(lo.meshes[0].table_stiffness - hi.meshes[0].table_stiffness))
    assert change > 10 * np.max(np.abs(m.table_stiffness - r.table_stiffness))  # the check can fail


def test_basis_cache_round_trip(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A basis written to the disk cache reads back equal; a damaged file is recomputed."""
    monkeypatch.setenv("GEAR_ROTOR_SIM_BASIS_CACHE", str(tmp_path))
    lin = LinearModel(GearRotorSystem.from_config(paper_gearbox(), 41.0))
    omega = 3217.0 * 2.0 * np.pi / 60.0
    b1 = cached_eigen_basis(lin, omega)
    files = list(tmp_path.glob("*.npz"))
    assert len(files) == 1 and files[0].stem == basis_key(lin, omega)
    basis_cache._RECENT.clear()  # read from the disk, as a later run would
    b2 = cached_eigen_basis(lin, omega)
    for name in ("lam", "phi", "kept"):
        assert np.array_equal(getattr(b1, name), getattr(b2, name))
    assert np.array_equal(b1.lu[0], b2.lu[0]) and (b1.scale, b1.n_forced) == (b2.scale, b2.n_forced)
    good = files[0].read_bytes()
    for damaged in (b"not a basis", good[: len(good) // 2]):  # not an npz; a truncated one
        files[0].write_bytes(damaged)
        basis_cache._RECENT.clear()
        b3 = cached_eigen_basis(lin, omega)
        assert np.array_equal(b3.lam, b1.lam)
    monkeypatch.setenv("GEAR_ROTOR_SIM_BASIS_CACHE", "off")
    assert cache_dir() is None
