"""Modules split into modules of one role each: newmark.py's set-up (session 12, docs/design.md), the
gear kernel and the Simulator (session 17, docs/solver.md "Module layout"). Every name the split
module had stays importable from it and is the very object of its new module (a memo or a
work-array holder re-exported as a copy would silently split the state; a second numba dispatcher
would compile a second copy)."""

from __future__ import annotations

import importlib

import pytest

from gear_rotor_sim.solver import newmark

MOVED = {
    "arrays": ["ChunkBuffers", "aligned", "aligned_zeros"],
    "channels": ["ChannelSpec", "available_channels", "parse_channels"],
    "linear_model": ["LinearModel"],
    "modal_basis": ["COND_LIMIT", "Basis", "eigen_basis", "state_blocks", "_BASIS_MEMO", "_eigen_basis"],
    "modal_map": ["EXACT_MAP_MU_MAX", "StepMap", "step_map", "reduce_basis", "residual_flexibility"],
    "gear_arrays": ["OUTPUT_BLOCK_STEPS", "GearMap", "gear_map", "split_table_jumps", "_jump_intervals"],
    "excitation": [
        "StepContext",
        "effect_columns",
        "excitation",
        "make_context",
        "mesh_phases",
        "_effect_arrays",
    ],
    "state": ["SolverState", "mesh_law", "static_equilibrium"],
}


def test_every_exported_name_exists_and_the_stepper_stays() -> None:
    missing = [n for n in newmark.__all__ if not hasattr(newmark, n)]
    assert not missing, missing
    moved = {n for names in MOVED.values() for n in names}
    public_moved = {n for n in moved if not n.startswith("_")}
    assert public_moved <= set(newmark.__all__), public_moved - set(newmark.__all__)
    assert newmark.NewmarkStepper.__module__ == "gear_rotor_sim.solver.newmark"


#: gear_kernel.py split by role (session 17, docs/solver.md "Module layout"): module -> names that
#: ``gear_kernel`` had and re-exports (the very numba dispatchers: a second one would compile a second
#: copy, and a replaced ``gear_kernel.run_chunk_gear`` must stay the one ``newmark`` calls).
GEAR_KERNEL_PARTS = {
    "gear_tables": ["TE_ANCHOR_STEPS", "_lerp", "_tables_at", "_te_sin_cos"],
    "gear_mesh_solve": [
        "_affine_forces",
        "_mesh_solve_one",
        "_mesh_solve_two",
        "_row_two",
        "_set_columns",
        "_solve_meshes",
        "_state_force",
    ],
    "gear_events": ["_EVENT_SNAP", "_MAX_PIECES", "_event_step", "_locate_crossing"],
    "gear_jumps": ["_jump_average_end", "_jump_average_start"],
    "gear_output": ["_copy_int", "_emit_block"],
    "gear_loop": ["_run_loop"],
}


def test_gear_kernel_exports() -> None:
    from gear_rotor_sim.solver import gear_kernel

    parts = [n for names in GEAR_KERNEL_PARTS.values() for n in names]
    assert sorted(gear_kernel.__all__) == sorted(["run_chunk_gear", *parts])


def test_newmark_calls_the_gear_kernel_through_its_module(monkeypatch: pytest.MonkeyPatch) -> None:
    """Benchmarks replace ``gear_kernel.run_chunk_gear`` (bench_kernel_copy.py, bench_solver.py): the
    stepper must look it up there at each chunk."""
    from gear_rotor_sim.examples import paper_gearbox
    from gear_rotor_sim.simulator import Simulator
    from gear_rotor_sim.solver import gear_kernel

    calls = []
    orig = gear_kernel.run_chunk_gear

    def spy(*a: object, **k: object) -> object:
        calls.append(1)
        return orig(*a, **k)

    sim = Simulator(paper_gearbox(), 3000.0, 25.0, 20000.0, channels=["dte"])
    monkeypatch.setattr(gear_kernel, "run_chunk_gear", spy)
    sim.advance(0.002)
    assert calls


#: simulator.py split by concern (session 17): module -> names importable from ``simulator``.
SIMULATOR_PARTS = {
    "simulator_systems": [
        "TEMPERATURE_QUANTUM_C",
        "RAMP_SPEED_QUANTUM_REL",
        "RAMP_TEMPERATURE_QUANTUM_C",
        "RAMP_ASSEMBLY_QUANTUM_C",
        "SystemCache",
        "_Ramp",
        "_default_builder",
    ],
    "simulator_stepping": [
        "MODAL_CUTOFF_OUTPUT_FACTOR",
        "MODAL_CUTOFF_MESH_HARMONICS",
        "DT_RULE_SPEED_FLOOR_RPM",
        "DT_RULE_WINDOW_S",
        "Stepping",
        "auto_modal_cutoff_hz",
    ],
    "simulator_stream": ["PendingBlock", "Stream"],
}

#: Simulator's public API before the split (methods, properties, static methods).
SIMULATOR_API = [
    "advance",
    "advance_deferred",
    "available_channels",
    "default_channels",
    "dt",
    "mesh_force_orders",
    "set_effects",
    "set_targets",
    "speed_rpm",
    "state",
    "target_speed_rpm",
    "target_temperature_c",
    "targets",
    "temperature_c",
    "time_s",
]


def test_simulator_api_and_bases() -> None:
    from gear_rotor_sim import simulator

    sim_cls = simulator.Simulator
    assert sim_cls.__module__ == "gear_rotor_sim.simulator"
    assert [b.__name__ for b in sim_cls.__mro__[1:4]] == ["SystemCache", "Stepping", "Stream"]
    missing = [n for n in SIMULATOR_API if not hasattr(sim_cls, n)]
    assert not missing, missing
    # the bases hold no state of their own: every attribute lives on the Simulator instance
    for base in sim_cls.__mro__[1:4]:
        assert "__init__" not in vars(base), base
    assert all(hasattr(simulator, n) for n in simulator.__all__)


#: (module that re-exports, module of one role) -> the names moved there.
_SOLVER = "gear_rotor_sim.solver"
SPLITS = {
    **{(f"{_SOLVER}.newmark", f"{_SOLVER}.{m}"): v for m, v in MOVED.items()},
    **{(f"{_SOLVER}.gear_kernel", f"{_SOLVER}.{m}"): v for m, v in GEAR_KERNEL_PARTS.items()},
    **{("gear_rotor_sim.simulator", f"gear_rotor_sim.{m}"): v for m, v in SIMULATOR_PARTS.items()},
}


@pytest.mark.parametrize(("facade", "module"), sorted(SPLITS))
def test_moved_names_are_the_role_modules_objects(facade: str, module: str) -> None:
    old = importlib.import_module(facade)
    mod = importlib.import_module(module)
    for name in SPLITS[facade, module]:
        assert getattr(old, name) is getattr(mod, name), f"{facade}.{name} is not {module}.{name}"
