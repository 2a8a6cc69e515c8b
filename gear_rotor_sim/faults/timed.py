"""Time-dependent faults: the library effect switched on at the onset, its severity following growth.

:class:`TimedEffect` wraps the library effect built at a reference severity ``S`` (the largest
severity the fault reaches) by :data:`~gear_rotor_sim.faults.library.EFFECT_TYPES`; per integration
step it scales the effect's contribution by ``s(t) / S`` (``s`` from
:meth:`FaultSpec.severity_at <gear_rotor_sim.faults.spec.FaultSpec.severity_at>`):

* forces ``a(t) -> (s/S) a(t)`` and transmission error ``e(t) -> (s/S) e(t)``, exact because the
  severities that may grow enter linearly (amplitude parameters);
* mesh stiffness factor ``f(t) -> 1 + (s/S) (f(t) - 1)``, exact for tooth damage
  (``f = 1 - depth share``, affine in the depth).

Where ``s = S`` the effect's own arrays are returned unchanged, and where ``s = 0`` the neutral
values: a fault at constant severity gives bit for bit the signal of the same effect passed to the
simulator directly (the calibration's path).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from gear_rotor_sim.faults.base import Effect
from gear_rotor_sim.faults.spec import FaultSpec


class TimedEffect:
    """A library effect active from ``spec.onset_s`` with the severity law of ``spec``.

    Parameters
    ----------
    spec : FaultSpec
        Validated fault (see :mod:`gear_rotor_sim.faults.spec`).
    """

    def __init__(self, spec: FaultSpec) -> None:
        self.spec = spec
        s0, s1 = spec.initial_severity, spec.final_severity
        self.reference = s1 if abs(s1) >= abs(s0) else s0
        self.effect: Effect = spec.effect(self.reference)
        self.name = self.effect.name

    def __repr__(self) -> str:
        return f"TimedEffect({self.spec!r})"

    def scale(self, t: np.ndarray) -> np.ndarray:
        """``s(t) / S`` at the step times."""
        if self.reference == 0.0:
            return np.zeros(np.shape(t))
        return self.spec.severity_at(t) / self.reference

    def at_reference(self, t: np.ndarray) -> bool:
        """Whether ``s(t) = S`` at every time of ``t`` (a fault without growth, past its onset): then
        the effect's own arrays apply unchanged (what the ``np.where`` below gives, without its passes
        over the chunk)."""
        spec = self.spec
        t = np.asarray(t)
        return (
            spec.growth is None
            and t.size > 0
            and self.reference != 0.0
            and spec.initial_severity == self.reference
            and float(t.min()) >= spec.onset_s
        )

    # Effect protocol -----------------------------------------------------------------------
    def mesh_stiffness_factor(self, ctx: Any) -> np.ndarray | None:
        f = self.effect.mesh_stiffness_factor(ctx)
        if f is None:
            return None
        f = np.asarray(f, float)
        if self.at_reference(ctx.t):
            return f
        r = self.scale(ctx.t).reshape((-1,) + (1,) * (f.ndim - 1))
        return np.where(r == 1.0, f, np.where(r == 0.0, 1.0, 1.0 + r * (f - 1.0)))

    def transmission_error(self, ctx: Any) -> np.ndarray | None:
        e = self.effect.transmission_error(ctx)
        if e is None:
            return None
        e = np.asarray(e, float)
        if self.at_reference(ctx.t):
            return e
        r = self.scale(ctx.t).reshape((-1,) + (1,) * (e.ndim - 1))
        return np.where(r == 1.0, e, r * e)

    def external_forces(self, system: Any) -> np.ndarray | None:
        return self.effect.external_forces(system)

    def force_amplitudes(self, ctx: Any) -> np.ndarray | None:
        a = self.effect.force_amplitudes(ctx)
        if a is None:
            return None
        a = np.asarray(a, float)
        if self.at_reference(ctx.t):
            return a
        r = self.scale(ctx.t).reshape((-1,) + (1,) * (a.ndim - 1))
        return np.where(r == 1.0, a, r * a)

    def modify_config(self, cfg: Any) -> Any:
        # applies when the fault list is applied (spec validation forbids growth for these)
        return self.effect.modify_config(cfg)


def timed_effects(faults: Sequence[FaultSpec]) -> tuple[TimedEffect, ...]:
    """Simulator effects of a fault list."""
    return tuple(TimedEffect(f) for f in faults)
