"""Simulator(periodic_replay=True): the replayed stream against the integrated one (docs/solver.md,
"Periodic replay at steady state"; gear_rotor_sim/simulator_replay.py)."""

from __future__ import annotations

import numpy as np
import pytest

from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.simulator import Simulator
from gear_rotor_sim.simulator_replay import forcing_period_outputs, state_mismatch

CHANNELS = ["dte", "mesh_force", "bearing2_fx", "bearing2_fy", "node5_ay"]
CHUNK_S = 0.1
MAX_SETTLE_S = 4.0


def _pair(rpm: float, channels: list[str] = CHANNELS) -> tuple[Simulator, Simulator]:
    """The replaying Simulator and its integrated reference: the same option with serving off (the
    same periodic angles, every step integrated)."""
    cfg = paper_gearbox(bearing_type="A#")
    on = Simulator(cfg, rpm, 25.0, 20000.0, channels=channels, periodic_replay=True)
    off = Simulator(cfg, rpm, 25.0, 20000.0, channels=channels, periodic_replay=True)
    assert off.replay is not None
    off.replay.serving = False
    return on, off


def _settle(
    on: Simulator, off: Simulator, chunk_s: float = CHUNK_S
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Advance both in the same chunks until the replay engages (at most MAX_SETTLE_S)."""
    a: list[np.ndarray] = []
    b: list[np.ndarray] = []
    while on.time_s < MAX_SETTLE_S:
        a.append(on.advance(chunk_s).data)
        b.append(off.advance(chunk_s).data)
        assert on.replay is not None
        if on.replay.active:
            return a, b
    pytest.fail(f"replay did not engage within {MAX_SETTLE_S} s")


def _rel_diff(x: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """RMS of the difference per channel over the fluctuating RMS of the integrated stream."""
    return np.sqrt(np.mean((x - ref) ** 2, axis=0)) / np.std(ref, axis=0)


def test_forcing_period_on_the_output_grid() -> None:
    """Whole pinion revolutions of the 29-tooth pinion at 20 kHz: 60 samples at 20000 rpm (1 rev), 400 at
    3000 (1 rev), 1200 at 7000 (7 revs), 250 at 14400 (3 revs); none at standstill."""
    from gear_rotor_sim.system import GearRotorSystem

    system = GearRotorSystem.from_config(paper_gearbox(bearing_type="A#"), 25.0)
    got = {rpm: forcing_period_outputs(system, rpm, 20000.0) for rpm in (20000.0, 3000.0, 7000.0, 14400.0)}
    assert got == {20000.0: 60, 3000.0: 400, 7000.0: 1200, 14400.0: 250}
    assert forcing_period_outputs(system, 0.0, 20000.0) is None


@pytest.mark.parametrize("rpm", [3000.0, 7000.0, 12000.0, 20000.0])
def test_replayed_stream_equals_the_integrated_one(rpm: float) -> None:
    """Period-1 (3000 rpm; 7000 and 20000 rpm with contact loss) and period-2 (12000 rpm): until the
    replay engages the stream is bit for bit the integrated one; over the 0.4 s from the chunk in which
    it engaged the difference is below 1e-6 of each channel's fluctuating RMS."""
    on, off = _pair(rpm)
    a, b = _settle(on, off)
    # engaged inside the last chunk (its last outputs read served steps through the FIR)
    assert np.array_equal(np.concatenate(a[:-1]), np.concatenate(b[:-1]))
    assert on.replay is not None and on.replay.mismatch <= 1e-10
    x = np.concatenate([a[-1]] + [on.advance(CHUNK_S).data for _ in range(3)])
    y = np.concatenate([b[-1]] + [off.advance(CHUNK_S).data for _ in range(3)])
    assert on.replay.active
    err = _rel_diff(x, y)
    assert np.all(err < 1e-6), err
    assert np.all(np.std(y, axis=0) > 0)


def test_period_two_is_replayed_as_period_two() -> None:
    """12000 rpm, 25 C is period-2 (docs/solver.md, "Modal reduction"): the forcing repeats after one
    pinion revolution (100 samples, 29 mesh periods), the response only after two; the replayed stream
    keeps that: one revolution apart it differs by more than 1e-3 of its RMS, two apart by less than
    1e-9."""
    on, off = _pair(12000.0, ["dte"])
    _settle(on, off)
    assert on.replay is not None
    g_raw = 100 * on._k
    assert on.replay.period_steps % (2 * g_raw) == 0
    x = on.advance(0.2).data[:, 0]
    assert on.replay.active
    rms = np.std(x)
    assert np.sqrt(np.mean((x[100:] - x[:-100]) ** 2)) > 1e-3 * rms
    assert np.sqrt(np.mean((x[200:] - x[:-200]) ** 2)) < 1e-9 * rms


def test_set_point_change_during_replay_continues_as_integration() -> None:
    """A speed change in the middle of a stored period (3000 -> 3300 rpm): the state made current equals
    the integrated one, and the stream after the change follows the integrated one."""
    on, off = _pair(3000.0)
    _settle(on, off)
    on.advance(0.0123)  # not a whole number of periods
    off.advance(0.0123)
    on.set_targets(speed_rpm=3300.0)
    off.set_targets(speed_rpm=3300.0)
    assert on.replay is not None
    sa, sb = on.state, off.state
    assert np.linalg.norm(sa.x - sb.x) <= 1e-8 * np.linalg.norm(sb.x)
    assert sa.time == sb.time and abs(sa.angle - sb.angle) <= 1e-9 * abs(sb.angle)
    x = np.concatenate([on.advance(CHUNK_S).data for _ in range(3)])
    y = np.concatenate([off.advance(CHUNK_S).data for _ in range(3)])
    assert not on.replay.active  # the ramp runs
    err = _rel_diff(x, y)
    assert np.all(err < 1e-6), err


def test_chaotic_motion_is_not_replayed() -> None:
    """19000 rpm, 25 C (inside the model's chaotic band, docs/REPRODUCTION.md): integrated throughout,
    the stream bit for bit the integrated reference's."""
    on, off = _pair(19000.0, ["dte"])
    x = np.concatenate([on.advance(CHUNK_S).data for _ in range(15)])
    y = np.concatenate([off.advance(CHUNK_S).data for _ in range(15)])
    assert on.replay is not None and not on.replay.active and on.replay.n_engaged == 0
    assert np.array_equal(x, y)


def test_state_mismatch_scales_with_each_part() -> None:
    """The match is relative to each part's own norm and needs equal contact states."""
    on, _ = _pair(3000.0, ["dte"])
    on.advance(0.05)
    from gear_rotor_sim.simulator_replay import _snapshot

    a = _snapshot(on._stepper, on._state)
    b = _snapshot(on._stepper, on._state)
    assert state_mismatch(a, b) == 0.0
    b["zr"] = b["zr"] * (1 + 1e-9)
    b["zi"] = b["zi"] * (1 + 1e-9)
    assert 0.5e-9 < state_mismatch(a, b) < 2e-9
    b = _snapshot(on._stepper, on._state)
    b["state"].contact = b["state"].contact - 1
    assert state_mismatch(a, b) == float("inf")


def test_replay_off_by_default_and_checked() -> None:
    cfg = paper_gearbox(bearing_type="A#")
    assert Simulator(cfg, 3000.0, 25.0, 20000.0, channels=["dte"]).replay is None
    with pytest.raises(ValueError, match="periodic_replay"):
        Simulator(cfg, 3000.0, 25.0, 20000.0, channels=["dte"], periodic_replay=1)  # type: ignore[arg-type]
