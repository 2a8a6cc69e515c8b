"""newmark.py's set-up split into modules of one role each (session 12, docs/design.md): every name
``gear_rotor_sim.solver.newmark`` had stays importable from it and is the very object of its new
module (a memo or a work-array holder re-exported as a copy would silently split the state)."""

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


@pytest.mark.parametrize("module", sorted(MOVED))
def test_moved_names_are_the_role_modules_objects(module: str) -> None:
    mod = importlib.import_module(f"gear_rotor_sim.solver.{module}")
    for name in MOVED[module]:
        assert getattr(newmark, name) is getattr(mod, name), f"newmark.{name} is not {module}.{name}"


def test_every_exported_name_exists_and_the_stepper_stays() -> None:
    missing = [n for n in newmark.__all__ if not hasattr(newmark, n)]
    assert not missing, missing
    moved = {n for names in MOVED.values() for n in names}
    public_moved = {n for n in moved if not n.startswith("_")}
    assert public_moved <= set(newmark.__all__), public_moved - set(newmark.__all__)
    assert newmark.NewmarkStepper.__module__ == "gear_rotor_sim.solver.newmark"
