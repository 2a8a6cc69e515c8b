"""Exceptions that cross a process pool must survive pickling (sweeps run points in worker processes)."""

from __future__ import annotations

import pickle
from concurrent.futures import ProcessPoolExecutor

import pytest

from gear_rotor_sim.solver.newmark import SimulationDiverged


def _diverge(speed_rpm: float) -> None:
    raise SimulationDiverged(0.125, speed_rpm, 25.0, "|DTE| above the bound")


def test_simulation_diverged_pickle_round_trip() -> None:
    exc = SimulationDiverged(0.125, 14000.0, 225.0, "non-finite state")
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is SimulationDiverged
    assert (back.time_s, back.speed_rpm, back.temperature_c, back.reason) == (
        0.125,
        14000.0,
        225.0,
        "non-finite state",
    )
    assert str(back) == str(exc)


def test_simulation_diverged_crosses_a_process_pool() -> None:
    # before the fix the pool died with BrokenProcessPool when a worker raised this exception
    with ProcessPoolExecutor(max_workers=1) as pool:
        fut = pool.submit(_diverge, 19000.0)
        with pytest.raises(SimulationDiverged, match="19000 rpm") as info:
            fut.result(timeout=120)
    assert info.value.speed_rpm == 19000.0
