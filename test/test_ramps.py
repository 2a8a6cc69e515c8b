"""Ramps on coarse basis grids (25 % of speed, 5 C; ramp systems between) against the per-quantum rebuild."""

from __future__ import annotations

import numpy as np
import pytest

from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.simulator import TEMPERATURE_QUANTUM_C, Simulator
from gear_rotor_sim.solver.newmark import SPEED_QUANTUM_REL

CHANNELS = ["dte", "mesh_force", "bearing1_fx", "node5_ay"]


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
