"""Simulator(periodic_replay="faults") with effects locked to a shaft's angle (docs/solver.md, "Periodic
replay at steady state", "Faults"; gear_rotor_sim/simulator_replay_effects.py): their forcing period,
and the replayed stream against the same option's integration (the same periodic angles). With
``periodic_replay=True`` a set point with effects is integrated (test_replay_switches.py)."""

from __future__ import annotations

import numpy as np
import pytest
from test_periodic_replay import _rel_diff, _settle

from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.faults import (
    BearingDefect,
    GearEccentricity,
    MassUnbalance,
    ShaftMisalignment,
    ToothDamage,
)
from gear_rotor_sim.faults.spec import parse_fault
from gear_rotor_sim.faults.timed import TimedEffect
from gear_rotor_sim.simulator import Simulator
from gear_rotor_sim.simulator_replay import forcing_period_outputs
from gear_rotor_sim.simulator_replay_effects import effect_shafts, periodic_effect_shafts
from gear_rotor_sim.system import GearRotorSystem

CHANNELS = ["dte", "mesh_force", "bearing2_fx", "bearing2_fy", "node5_ay"]

_PINION_TOOTH = ToothDamage(tooth=3, depth=0.3, wheel="pinion")
#: At 20000 rpm a 0.3-deep pinion tooth leaves the motion non-periodic (the state one or more pinion
#: revolutions apart differs by 1e-4 to 8e-2 of its norm over 4 s: no replay); 0.1 settles.
_PINION_TOOTH_20K = ToothDamage(tooth=3, depth=0.1, wheel="pinion")
_GEAR_TOOTH = ToothDamage(tooth=7, depth=0.1, wheel="gear")


def _system() -> GearRotorSystem:
    return GearRotorSystem.from_config(paper_gearbox(bearing_type="A#"), 25.0)


def _pair(rpm: float, effects: tuple, mode: bool | str = "faults") -> tuple[Simulator, Simulator]:
    """The replaying Simulator and its integrated reference (the same option, serving off: the same
    angles, every step integrated)."""
    cfg = paper_gearbox(bearing_type="A#")
    kw = dict(channels=CHANNELS, periodic_replay=mode, effects=effects)
    on = Simulator(cfg, rpm, 25.0, 20000.0, **kw)
    off = Simulator(cfg, rpm, 25.0, 20000.0, **kw)
    assert off.replay is not None
    off.replay.serving = False
    return on, off


def test_effect_shafts_and_forcing_periods() -> None:
    """A pinion-tooth fault repeats with the pinion (60 samples at 20000 rpm, the healthy period: 29 mesh
    cycles are one pinion revolution); a gear-tooth fault only after the hunting period of the 29/49
    mesh (1421 mesh cycles, 49 pinion revolutions: 2940 samples at 20000 rpm); a bearing defect's
    ball-pass orders are not shaft orders (no replay)."""
    system = _system()
    pin = system.meshes[0].pinion_shaft
    gear = system.meshes[0].gear_shaft
    assert pin != gear
    assert effect_shafts(_PINION_TOOTH, system, 0.0) == (pin,)
    assert effect_shafts(_GEAR_TOOTH, system, 0.0) == (gear,)
    assert effect_shafts(GearEccentricity(member="gear", eccentricity_m=2e-5), system, 0.0) == (gear,)
    assert effect_shafts(MassUnbalance(node=5, unbalance_kg_m=1e-4), system, 0.0) is not None
    assert effect_shafts(ShaftMisalignment(node=1, offset_m=1e-4), system, 0.0) is not None
    assert effect_shafts(BearingDefect(kind="outer", bearing=2, force_n=200.0), system, 0.0) is None
    both = periodic_effect_shafts((_PINION_TOOTH, _GEAR_TOOTH), system, 0.0)
    assert both == tuple(sorted({pin, gear}))
    assert (
        periodic_effect_shafts((_PINION_TOOTH, BearingDefect(kind="outer", bearing=2)), system, 0.0) is None
    )
    assert forcing_period_outputs(system, 20000.0, 20000.0, (pin,)) == 60
    assert forcing_period_outputs(system, 20000.0, 20000.0, (gear,)) == 2940
    assert forcing_period_outputs(system, 3000.0, 20000.0, (gear,)) == 19600


def test_timed_faults_are_periodic_only_at_a_constant_severity() -> None:
    """Before the onset and while the severity grows the forcing is not periodic; from the onset (no
    growth) or the end of the growth on it is."""
    system = _system()
    fault = {"type": "tooth_damage", "wheel": "pinion", "tooth": 3, "depth": 0.3, "onset_s": 0.5}
    plain = TimedEffect(parse_fault(fault))
    assert effect_shafts(plain, system, 0.49) is None
    assert effect_shafts(plain, system, 0.5) == (system.meshes[0].pinion_shaft,)
    growth = {"law": "linear", "final": 0.3, "duration_s": 1.0}
    grow = TimedEffect(parse_fault({**fault, "depth": 0.1, "growth": growth}))
    assert effect_shafts(grow, system, 1.2) is None
    assert effect_shafts(grow, system, 1.5) == (system.meshes[0].pinion_shaft,)


@pytest.mark.parametrize(
    ("rpm", "effects", "mode"),
    [
        (20000.0, (_PINION_TOOTH_20K,), "faults"),
        (3000.0, (_PINION_TOOTH, MassUnbalance(node=5, unbalance_kg_m=1e-4, phase_rad=0.3)), "faults"),
        (7000.0, (GearEccentricity(member="pinion", eccentricity_m=2e-5, phase_rad=0.4),), "faults"),
    ],
)
def test_replayed_stream_with_a_shaft_locked_fault(rpm: float, effects: tuple, mode: bool | str) -> None:
    """A pinion-tooth fault (depth 0.1) at 20000 rpm (contact loss), a pinion tooth (0.3) and an
    unbalance at 3000 rpm, an eccentric pinion at 7000 rpm: bit for bit the integrated stream until
    the replay engages, then within 1e-6 of each channel's fluctuating RMS over 0.4 s."""
    on, off = _pair(rpm, effects, mode)
    a, b = _settle(on, off, 0.1)
    assert np.array_equal(np.concatenate(a[:-1]), np.concatenate(b[:-1]))
    assert on.replay is not None and on.replay.mismatch <= 1e-10
    x = np.concatenate([a[-1]] + [on.advance(0.1).data for _ in range(3)])
    y = np.concatenate([b[-1]] + [off.advance(0.1).data for _ in range(3)])
    assert on.replay.active
    err = _rel_diff(x, y)
    assert np.all(err < 1e-6), err
    assert np.all(np.std(y, axis=0) > 0)


def test_gear_tooth_fault_is_replayed_over_the_hunting_period() -> None:
    """A gear-tooth fault at 20000 rpm, advanced in chunks of its forcing period (2940 samples, 0.147 s:
    the hunting period): the stored period is a whole number of hunting periods and the replayed stream
    follows the integrated one (1e-6 of each channel's fluctuating RMS over 3 hunting periods); one
    pinion revolution apart it differs (the damaged gear tooth meets another pinion tooth)."""
    on, off = _pair(20000.0, (_GEAR_TOOTH,))
    chunk = 2940 / 20000.0
    a, b = _settle(on, off, chunk)
    assert on.replay is not None
    assert on.replay.period_steps % (2940 * on._k) == 0
    assert np.array_equal(np.concatenate(a[:-1]), np.concatenate(b[:-1]))
    x = np.concatenate([a[-1]] + [on.advance(chunk).data for _ in range(3)])
    y = np.concatenate([b[-1]] + [off.advance(chunk).data for _ in range(3)])
    assert on.replay.active
    err = _rel_diff(x, y)
    assert np.all(err < 1e-6), err
    f = y[:, 2]  # bearing2_fx
    assert np.sqrt(np.mean((f[60:] - f[:-60]) ** 2)) > 1e-3 * np.std(f)
