"""Which effects the periodic replay may serve, and the shafts whose revolution sets their period
(``Simulator(periodic_replay=True)``; docs/solver.md, "Periodic replay at steady state", "Effects").

An effect locked to a shaft's angle (a damaged tooth, an eccentric wheel, a mass unbalance, a
parallel shaft misalignment) adds a forcing that repeats after one revolution of that shaft, at a
constant speed and as long as its severity does not change: its inputs to the kernel (the mesh
stiffness factor, the transmission error, the force amplitudes; solver/excitation.py) are functions
of the shaft angles and speeds only. The stream then repeats after a whole number of mesh cycles of
every mesh *and* whole revolutions of those shafts (for a gear-shaft effect on the paper gearbox the
hunting period of the 29/49 mesh, 1421 mesh cycles). Everything else (a bearing defect, whose ball-pass
orders are not whole shaft orders; tooth wear; the tilted gear misalignment, whose mesh-force orders
follow the stream; any effect not listed here) keeps the replay off.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from gear_rotor_sim.faults.base import shaft_index
from gear_rotor_sim.faults.gear import GearEccentricity, ToothDamage
from gear_rotor_sim.faults.shaft import MassUnbalance, ShaftMisalignment
from gear_rotor_sim.faults.timed import TimedEffect


def _constant_from(effect: TimedEffect) -> float:
    """Simulated time from which a timed fault's severity no longer changes (its onset, or the end
    of its growth)."""
    spec = effect.spec
    grow = spec.growth.duration_s if spec.growth is not None else 0.0
    return float(spec.onset_s) + float(grow)


def effect_shafts(effect: Any, system: Any, t_first: float) -> tuple[int, ...] | None:
    """The shafts whose angle ``effect`` follows, or None when its forcing is not periodic in shaft
    angles from ``t_first`` on (the earliest time the next chunk's effect inputs read).

    Parameters
    ----------
    effect : Effect or TimedEffect
        One of the Simulator's effects.
    system : AssembledSystem
        The system it acts on (its meshes' shafts).
    t_first : float
        Simulated time, s.
    """
    if isinstance(effect, TimedEffect):
        if t_first < _constant_from(effect):
            return None  # before the onset or while it grows: the severity changes with time
        effect = effect.effect
    if isinstance(effect, ToothDamage):
        m = system.meshes[effect.mesh - 1]
        return (int(m.pinion_shaft if effect.wheel == "pinion" else m.gear_shaft),)
    if isinstance(effect, GearEccentricity):
        return (int(effect._gear(system)[1]),)
    if isinstance(effect, MassUnbalance | ShaftMisalignment):
        return (shaft_index(system, effect.node - 1),)
    return None


def periodic_effect_shafts(effects: Sequence[Any], system: Any, t_first: float) -> tuple[int, ...] | None:
    """The sorted shafts of every effect (:func:`effect_shafts`); None if any effect is not periodic
    in shaft angles; ``()`` without effects."""
    shafts: set[int] = set()
    for e in effects:
        s = effect_shafts(e, system, t_first)
        if s is None:
            return None
        shafts.update(s)
    return tuple(sorted(shafts))
