"""The simulator node's shared state and diagnostics without a running node (ros/node_runtime.py,
ros/node_diagnostics.py): the achieved real-time factor against rates worked out by hand, the chunk
bookkeeping, and the diagnostic levels of docs/ros.md."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticStatus

from gear_rotor_sim.ros.node_diagnostics import diagnostic_statuses
from gear_rotor_sim.ros.node_runtime import SharedState, achieved_rtf, chunk_stat


def test_achieved_rtf_over_the_last_three_seconds() -> None:
    assert achieved_rtf([]) == 0.0 and achieved_rtf([(1.0, 2.0)]) == 0.0
    # chunks every 0.5 s of wall time; simulated time runs at 2x until wall 8 s, then at 1x
    walls = np.arange(0.5, 10.01, 0.5)
    sims = np.where(walls <= 8.0, 2.0 * walls, 16.0 + (walls - 8.0))
    window = list(zip(walls.tolist(), sims.tolist(), strict=True))
    # last 3 s: wall 7 -> 10, simulated 14 -> 18
    assert achieved_rtf(window) == pytest.approx(4.0 / 3.0, rel=1e-12)
    assert achieved_rtf(window[:12]) == pytest.approx(2.0, rel=1e-12)  # wall up to 6 s: 2x throughout
    # two chunks further apart than 3 s: their own rate
    assert achieved_rtf([(0.0, 0.0), (5.0, 2.5)]) == pytest.approx(0.5, rel=1e-12)


def test_record_chunk_counts_samples_and_reads_either_stats_form() -> None:
    st = SharedState()
    sim = SimpleNamespace(speed_rpm=3000.0, temperature_c=25.0, last_chunk_stats=None)
    sim.last_chunk_stats = {"contact_loss_fraction": 0.25, "steps": 640, "wall_time_s": 0.02}
    st.record_chunk(sim, 2000, 0.1, late=False)
    sim.last_chunk_stats = SimpleNamespace(back_contact_fraction=0.1, steps=700, wall_s=0.03)
    st.record_chunk(sim, 2000, 0.2, late=True)
    assert (st.chunks, st.samples, st.late_chunks, st.sim_time) == (2, 4000, 1, 0.2)
    # the second chunk's statistics (a dataclass-like object), missing fields 0
    assert (st.contact_loss, st.back_side_contact, st.solver_steps, st.chunk_wall_s) == (0.0, 0.1, 700, 0.03)
    assert [s for _, s in st.achieved_rtf_window] == [0.1, 0.2]
    assert chunk_stat(None, "steps", default=-1.0) == -1.0


def _state(chunks: int, health: bytes = DiagnosticStatus.OK, refused: int = 0) -> SharedState:
    st = SharedState(chunks=chunks, health_level=health, refused=refused, refused_since_diag=refused)
    st.last_refusal = "speed_rpm: -5 is below 0" if refused else ""
    return st


@pytest.mark.parametrize(
    ("chunks", "rtf", "level", "start"),
    [
        (10, 0.85, DiagnosticStatus.WARN, "cannot keep real_time_factor 1"),  # below 90 % of 1.0
        (10, 0.95, DiagnosticStatus.OK, "running"),
        (1, 0.10, DiagnosticStatus.OK, "running"),  # one chunk: no rate yet
    ],
)
def test_simulation_status_warns_below_ninety_percent_of_the_requested_factor(
    chunks: int, rtf: float, level: bytes, start: str
) -> None:
    sim, _ = diagnostic_statuses("n", _state(chunks), rtf, 1.0, "off")
    assert sim.level == level and sim.message.startswith(start), sim.message
    assert sim.name == "n: simulation"
    assert {kv.key: kv.value for kv in sim.values}["recording"] == "off"


def test_an_error_stays_an_error_and_refusals_are_reported_once() -> None:
    st = _state(10, DiagnosticStatus.ERROR, refused=3)
    st.health_message = "SimulationDiverged: ..."
    sim, sp = diagnostic_statuses("n", st, 0.1, 1.0, "off")
    assert sim.level == DiagnosticStatus.ERROR and sim.message == "SimulationDiverged: ..."
    assert sp.level == DiagnosticStatus.WARN and sp.message.startswith("3 setpoint(s) refused")
    _, sp = diagnostic_statuses("n", st, 0.1, 1.0, "off")  # the next report: none since
    assert sp.level == DiagnosticStatus.OK and sp.message == "ok"
    assert {kv.key: kv.value for kv in sp.values}["refused_total"] == "3"
