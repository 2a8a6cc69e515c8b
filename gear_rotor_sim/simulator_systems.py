"""The Simulator's systems and steppers: the per-temperature cache, the set-point ramps and the ramp
systems between the basis-grid nodes.

Part of :class:`gear_rotor_sim.simulator.Simulator` (docs/solver.md, "Module layout", "Speed,
temperature, ramps"): :class:`SystemCache` is one of its bases and holds no state of its own; the
attributes it reads and writes are the Simulator's (set in ``Simulator.__init__``).
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import numpy as np

from gear_rotor_sim.solver.basis_cache import cached_eigen_basis
from gear_rotor_sim.solver.newmark import (
    SPEED_QUANTUM_REL,
    ChunkBuffers,
    NewmarkStepper,
    quantize_speed_rpm,
)
from gear_rotor_sim.solver.rebase import (
    RampSpan,
    ThermalLoad,
    interpolated_system,
    ramp_linear_model,
    ramp_nodes,
    ramp_system,
)
from gear_rotor_sim.system_data import AssembledSystem

#: Temperature quantum of the system cache, C (a ramp rebuilds the system at these steps).
TEMPERATURE_QUANTUM_C = 0.5
#: While a speed / temperature ramp runs, the gyroscopic basis and the system are re-built on these
#: coarser grids (docs/solver.md, "Ramps"); at a constant set-point the fine quanta above apply.
RAMP_SPEED_QUANTUM_REL = 0.25
RAMP_TEMPERATURE_QUANTUM_C = 5.0
#: While the temperature ramps, exact systems are assembled on this grid (and at the ramp's ends); the
#: basis-grid nodes between are interpolated (solver/rebase.py).
RAMP_ASSEMBLY_QUANTUM_C = 25.0


@dataclass
class _Ramp:
    """value(t) moves from ``v0`` at ``t0`` toward ``target`` at ``rate`` per second."""

    t0: float
    v0: float
    target: float
    rate: float

    def value(self, t: np.ndarray | float) -> np.ndarray:
        if isinstance(t, float):  # a scalar time (a few thousand calls a ramp): the same float
            # operations in the same order as the array path below, without its array calls
            ds, d = t - self.t0, self.target - self.v0
            if d == 0.0 or self.rate == np.inf or ds >= abs(d) / self.rate:
                return np.asarray(self.target)
            return np.asarray(self.v0 + (1.0 if d > 0.0 else -1.0) * self.rate * ds)
        dt = np.asarray(t, float) - self.t0
        d = self.target - self.v0
        if d == 0.0 or self.rate == np.inf:
            return np.full(np.shape(dt), self.target) if np.ndim(dt) else np.asarray(self.target)
        tr = abs(d) / self.rate
        return np.where(dt >= tr, self.target, self.v0 + np.sign(d) * self.rate * dt)

    def integral(self, t: np.ndarray) -> np.ndarray:
        """Integral of value from t0 to t."""
        dt = np.asarray(t, float) - self.t0
        d = self.target - self.v0
        if d == 0.0 or self.rate == np.inf:
            return self.target * dt
        tr = abs(d) / self.rate
        a = np.sign(d) * self.rate
        ramp = self.v0 * np.minimum(dt, tr) + 0.5 * a * np.minimum(dt, tr) ** 2
        return ramp + self.target * np.maximum(dt - tr, 0.0)

    def time_to_reach(self, level: float) -> float:
        """Time after t0 at which the value crosses ``level`` (inf if never)."""
        d = self.target - self.v0
        if d == 0.0 or self.rate == np.inf:
            return np.inf
        x = (level - self.v0) / (np.sign(d) * self.rate)
        if x < 0 or (level - self.v0) * (self.target - level) < 0:
            return np.inf
        return float(x)


def _lru(
    cache: OrderedDict, key: float, build: Any, stepper_for: Any, size: int
) -> tuple[AssembledSystem, NewmarkStepper]:
    """``cache[key]`` (system, stepper), built by ``build()`` and ``stepper_for(system)`` when absent;
    least recently used first out beyond ``size`` entries."""
    hit = cache.get(key)
    if hit is None:
        system = build()
        hit = (system, stepper_for(system))
        cache[key] = hit
        if len(cache) > size:
            cache.popitem(last=False)
    else:
        cache.move_to_end(key)
    return hit


def _default_builder(cfg: Any, temperature_c: float) -> AssembledSystem:
    from gear_rotor_sim.system import GearRotorSystem  # assembly module (physics core)

    return GearRotorSystem.from_config(cfg, temperature_c)


class SystemCache:
    """Systems and steppers of a :class:`~gear_rotor_sim.simulator.Simulator` by temperature quantum,
    and the ramp systems while the temperature ramps (solver/rebase.py)."""

    cfg: Any
    _builder: Any
    _systems: OrderedDict[float, tuple[AssembledSystem, NewmarkStepper]]
    _spans: OrderedDict[float, RampSpan]
    _nodes: OrderedDict[float, tuple[AssembledSystem, NewmarkStepper]]
    _thermal: ThermalLoad | None
    _chunk_buffers: ChunkBuffers

    @staticmethod
    def _tq(temperature_c: float) -> float:
        # Python's round of a float is numpy's (half to even), without the array call (4000 calls a ramp)
        return float(round(temperature_c / TEMPERATURE_QUANTUM_C) * TEMPERATURE_QUANTUM_C)

    def _thermal_load_model(self) -> ThermalLoad | None:
        """The thermal node load of the default assembly (None for a custom builder)."""
        if self._builder is not _default_builder:
            return None
        if self._thermal is None:
            self._thermal = ThermalLoad(self.cfg)
        return self._thermal

    def _thermal_load(self, tq: float) -> np.ndarray | None:
        """Exact thermal node load for the default assembly (None: interpolated, custom builders)."""
        model = self._thermal_load_model()
        return None if model is None else model(tq)

    def _ramp_range(self) -> tuple[float, float]:
        return tuple(sorted((self._tq(self._temp.v0), self._tq(self._temp.target))))  # type: ignore[return-value]

    def _node(self, tq: float) -> tuple[AssembledSystem, NewmarkStepper]:
        """Node of the ramp's basis grid: exact on the assembly grid and at the ramp's ends, else
        interpolated between them (solver/rebase.py); its own eigenbases."""
        lo, hi = self._ramp_range()
        a, b = (self._tq(v) for v in ramp_nodes(tq, RAMP_ASSEMBLY_QUANTUM_C, lo, hi))
        if tq in (a, b):
            return self._system(tq)
        return _lru(
            self._nodes,
            tq,
            lambda: interpolated_system(self._system(a)[0], self._system(b)[0], tq, self._thermal_load(tq)),
            self._stepper_for,
            4,
        )

    def _system_at(self, tq: float, ramping: bool, speed_rpm: float) -> tuple[NewmarkStepper, bool]:
        """Stepper at the fine quantum ``tq`` and whether its modal state carries on (else the state is
        loaded into it): the exact assembly at a constant set-point; while the temperature ramps, ramp
        systems on the nearest basis-grid node's linear part and eigenbases (solver/rebase.py): with
        the default assembly one :class:`RampSpan` per node whose kernel arrays are corrected in place
        per quantum, else one new stepper per quantum."""
        q = self.ramp_temperature_quantum_c
        if not ramping or q <= TEMPERATURE_QUANTUM_C:
            return self._system(tq)[1], False
        lo, hi = self._ramp_range()
        a, b = (self._tq(v) for v in ramp_nodes(tq, q, lo, hi))
        near_t = a if tq - a <= b - tq else b
        near_sys, near = self._node(near_t)
        sys_a, sys_b = self._node(a)[0], self._node(b)[0]
        system = ramp_system(near_sys, sys_a, sys_b, tq, self._thermal_load(tq))
        thermal = self._thermal_load_model()
        if thermal is None or thermal.units is None:  # one stepper per quantum
            if tq == near_t:
                return near, False
            stepper = self._stepper_for(system, ramp_linear_model(near.lin, system, self._run_effects))
            stepper.basis_source = near.basis  # the same state matrix: the node's bases (and its cache)
            return stepper, False
        span = self._spans.get(near_t)
        if span is None:
            below, above = (
                ramp_nodes(near_t - 0.5 * q, q, lo, hi)[0],
                ramp_nodes(near_t + 0.5 * q, q, lo, hi)[1],
            )
            lower = self._node(self._tq(below))[0] if self._tq(below) < near_t else None
            upper = self._node(self._tq(above))[0] if self._tq(above) > near_t else None
            span = RampSpan((near_sys, near), lower, upper, thermal, self._stepper_for, self._run_effects)
            self._spans[near_t] = span
            if len(self._spans) > 4:
                self._spans.popitem(last=False)
        omega = self._sq(speed_rpm) * 2.0 * np.pi / 60.0
        stepper, carry = span.retarget(
            system, omega, self.dt, self._cutoff_hz(near_sys, speed_rpm), self._state, self._exact
        )
        return stepper, carry and stepper is self._stepper

    def _stepper_for(self, system: AssembledSystem, lin: Any = None) -> NewmarkStepper:
        """A stepper whose eigenbases come from the disk cache (solver/basis_cache.py)."""
        stepper = NewmarkStepper(
            system,
            self.specs,
            self._run_effects,
            self._force_dense,
            locate_events=self.locate_events,
            lin=lin,
        )
        dense = self._force_dense
        stepper.basis_source = lambda omega: cached_eigen_basis(stepper.lin, omega, dense)
        stepper.chunk_buffers = self._chunk_buffers  # one set for all steppers: one runs at a time
        stepper.event_average = self.event_average
        stepper.average_jumps = self.average_table_jumps
        return stepper

    def _speed_quantum(self, speed_rpm: float) -> float:
        """Relative speed quantum of the basis in use: coarse while the speed ramps."""
        return SPEED_QUANTUM_REL if speed_rpm == self._speed.target else self.ramp_speed_quantum_rel

    def _sq(self, speed_rpm: float) -> float:
        return quantize_speed_rpm(speed_rpm, self._speed_quantum(speed_rpm))

    def _build(self, tq: float) -> AssembledSystem:
        try:
            return self._builder(self.cfg, tq)
        except ValueError as exc:
            msg = str(exc)
            raise ValueError(
                msg if msg.startswith("temperature_c") else f"temperature_c: {tq}: {msg}"
            ) from exc

    def _system(self, tq: float) -> tuple[AssembledSystem, NewmarkStepper]:
        return _lru(self._systems, tq, lambda: self._build(tq), self._stepper_for, 8)
