"""The misaligned gear's axial force from the instantaneous mesh force in a stream (the Simulator).

A tilted wheel's axial mesh force is ``F(t) gamma(t)`` with ``F`` the instantaneous normal tooth force
(``faults/misalignment_force.py``, docs/history/calibration_sessions.md Sec. 8.19). An effect's force
amplitudes are set from the kinematics before each chunk, so ``F`` enters as the order coefficients of
the mesh force over one revolution of the tilted wheel (``GearMisalignment.mesh_force_orders``). The
calibration gets them from a first run (``with_mesh_force``). A stream cannot run twice;
the :class:`Simulator` keeps a running synchronous average of its own mesh force instead:

* every integration step's mesh force is binned by the tilted wheel's angle (``STREAM_BINS`` bins
  over a revolution, each step shared linearly between its two neighbouring bin centres; compiled,
  ``solver/sync_average.py``);
* at fixed instants of the output grid (every ``DT_RULE_WINDOW_S``, 0.1 s, whatever the chunking:
  the steps are binned one at a time in their order, so the stream does not depend on how
  ``advance`` is called) the bin means give the orders ``0 .. K`` (a real FFT, the binning's
  ``sinc^2`` transfer divided out; ``K`` the orders inside the output's passband,
  ``misalignment_force.max_wheel_order``, at most ``STREAM_BINS / 8``), which replace the effect's
  orders from that instant; then the bins are scaled by ``exp(-interval / STREAM_MEMORY_S)``: an
  exponentially weighted average with memory ``STREAM_MEMORY_S``.

The fixed point is reached in one pass, as in the calibration: the axial force acts on the wheels'
axial degrees of freedom, which the spur mesh does not see, so the mesh force being averaged does not
depend on the estimate. Start-up: until the first update the effect uses the static mesh force ``F0``
(its law without orders); the start-up transient then weighs in the average with
``exp(-t / STREAM_MEMORY_S)``. Speed and temperature ramps, set-point jumps: the estimate follows the
mesh force with the memory's lag (``STREAM_MEMORY_S``, plus up to one update interval); in a ramp the
order ``K`` follows the speed at each update. A new fault list (``Simulator.set_effects``) keeps the
running average of a wheel that stays tilted (it is the run's mesh force, not the effect's). Parts of
``F`` not synchronous with the tilted wheel (the other wheel's own orders, the non-periodic part at
rattle) average out as the memory's length allows (the calibration's pass drops them exactly over
whole hunting periods): a line between the wheel's orders leaks into an order ``df`` away by about
``1 / (2 pi df STREAM_MEMORY_S)`` of its amplitude. ``Simulator(streamed_misalignment=False)`` runs
the effects as given (the calibration's model runs: ``F0``, or the orders of their own pass).

Measured (``test/test_misalignment_stream.py``; paper gearbox, 3000 rpm, 1 mrad on the gear): after
1 s the orders equal the calibration pass's within 0.02 % at the mesh harmonics and 0.1 % of ``F0``
at any order; the axial bearing reactions' sidebands equal those of a run with the pass's orders
within 0.02 %, and at 8000 rpm (rattle) within 0.04 % (sidebands 11 % of the order-1 line there).
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from gear_rotor_sim.faults.gear import GearMisalignment
from gear_rotor_sim.faults.misalignment_force import PASSBAND_FRACTION
from gear_rotor_sim.faults.timed import TimedEffect
from gear_rotor_sim.solver.sync_average import bin_linear

#: bins of the synchronous average over one revolution of the tilted wheel
STREAM_BINS = 4096
#: highest order carried (the binning's transfer at it, ``sinc^2(1/8) = 0.95``, is divided out)
STREAM_MAX_ORDER = STREAM_BINS // 8
#: memory of the running average, s (the weights of past intervals fall as ``exp(-age / memory)``)
STREAM_MEMORY_S = 0.3


def needs_stream(effect: object) -> bool:
    """Whether ``effect`` is a tilted gear misalignment whose mesh force the stream must supply (no
    ``mesh_force_orders`` given: given orders are used as they are, the calibration's path)."""
    return isinstance(effect, GearMisalignment) and effect.angle_rad > 0 and not effect.mesh_force_orders


class StreamedMisalignment:
    """A :class:`GearMisalignment` whose ``mesh_force_orders`` the simulator updates as it runs.

    Every steppers of the simulator holds this one object; :meth:`set_orders` swaps the effect it
    delegates to (``current``), so the next chunk of any of them uses the new orders.
    """

    def __init__(self, base: GearMisalignment) -> None:
        self.base = base
        self.current = base
        self.name = base.name

    def __repr__(self) -> str:
        return f"StreamedMisalignment({self.base!r})"

    def __getattr__(self, name: str) -> Any:  # label, member, mesh, angle_rad, applicable, ...
        if name in ("base", "current"):
            raise AttributeError(name)
        return getattr(self.current, name)

    @property
    def key(self) -> tuple[int, str]:
        """The tilted wheel: (1-based mesh, member)."""
        return self.base.mesh, self.base.member

    def set_orders(self, coef: np.ndarray | None) -> None:
        """Use the order coefficients ``coef`` (N) from now on; None: the static force ``F0``."""
        if coef is None:
            self.current = self.base
        else:
            self.current = dataclasses.replace(self.base, mesh_force_orders=tuple(complex(c) for c in coef))

    # Effect protocol (explicit: the simulator looks these up with getattr)
    def mesh_stiffness_factor(self, ctx: Any) -> np.ndarray | None:
        return self.current.mesh_stiffness_factor(ctx)

    def transmission_error(self, ctx: Any) -> np.ndarray | None:
        return self.current.transmission_error(ctx)

    def external_forces(self, system: Any) -> np.ndarray | None:
        return self.current.external_forces(system)

    def force_amplitudes(self, ctx: Any) -> np.ndarray | None:
        return self.current.force_amplitudes(ctx)

    def modify_config(self, cfg: Any) -> Any:
        return self.current.modify_config(cfg)


def streamed_effects(effects: Sequence[object]) -> tuple[tuple[object, ...], list[StreamedMisalignment]]:
    """The effects with every tilted misalignment without orders (bare, or inside a
    :class:`TimedEffect`: a copy of it is made) behind a :class:`StreamedMisalignment`, and those."""
    out: list[object] = []
    proxies: list[StreamedMisalignment] = []
    for e in effects:
        if needs_stream(e):
            assert isinstance(e, GearMisalignment)
            p = StreamedMisalignment(e)
            out.append(p)
            proxies.append(p)
        elif isinstance(e, TimedEffect) and needs_stream(e.effect):
            assert isinstance(e.effect, GearMisalignment)
            p = StreamedMisalignment(e.effect)
            timed = copy.copy(e)
            timed.effect = p  # type: ignore[assignment]
            out.append(timed)
            proxies.append(p)
        else:
            out.append(e)
    return tuple(out), proxies


class SynchronousMeshForce:
    """Running synchronous average of one mesh's force over the revolution of one wheel.

    Parameters
    ----------
    mesh : int
        0-based mesh (column of the stepper's mesh force).
    shaft : int
        Shaft of the wheel (column of ``system.shaft_speed_ratios``).
    ratio : float
        Signed speed ratio of that shaft to the input shaft.
    """

    def __init__(self, mesh: int, shaft: int, ratio: float) -> None:
        self.mesh = mesh
        self.shaft = shaft
        self.ratio = float(ratio)
        self.sums = np.zeros(STREAM_BINS)
        self.weights = np.zeros(STREAM_BINS)
        self._win_sums = np.zeros(STREAM_BINS)  # the steps since the last update
        self._win_weights = np.zeros(STREAM_BINS)
        self._win_steps = 0
        self.orders: np.ndarray | None = None  # the last update's coefficients

    def push(self, input_angle: np.ndarray, mesh_force: np.ndarray) -> None:
        """Bin a chunk's steps: input-shaft angles (rad, n) and mesh forces (N, (n, n_meshes)),
        into the current update interval's bins (``solver/sync_average.py``)."""
        angle = np.ascontiguousarray(input_angle, dtype=float)
        force = np.ascontiguousarray(mesh_force, dtype=float)
        scale = self.ratio * STREAM_BINS / (2.0 * np.pi)
        bin_linear(angle, force, self.mesh, scale, self._win_sums, self._win_weights)
        self._win_steps += angle.size

    def update(self, wheel_hz: float, output_rate_hz: float, interval_s: float) -> np.ndarray | None:
        """Add the interval's bins to the running average, return its orders ``0 .. K`` (None while
        no step was binned) and age the bins by ``interval_s``.

        ``K``: the orders of a shaft at ``|wheel_hz|`` below ``PASSBAND_FRACTION`` of the output rate
        (all ``STREAM_MAX_ORDER`` at standstill), at most ``STREAM_MAX_ORDER``.
        """
        if self._win_steps:
            self.sums += self._win_sums
            self.weights += self._win_weights
            self._win_sums[:] = 0.0
            self._win_weights[:] = 0.0
            self._win_steps = 0
        filled = self.weights > 0
        if not filled.any():
            return None
        centres = np.arange(STREAM_BINS, dtype=float)
        means = np.empty(STREAM_BINS)
        means[filled] = self.sums[filled] / self.weights[filled]
        if not filled.all():  # bins not reached yet: linear between the nearest reached (periodic)
            means[~filled] = np.interp(centres[~filled], centres[filled], means[filled], period=STREAM_BINS)
        if abs(wheel_hz) * STREAM_MAX_ORDER <= PASSBAND_FRACTION * output_rate_hz:
            kmax = STREAM_MAX_ORDER
        else:
            kmax = math.floor(PASSBAND_FRACTION * output_rate_hz / abs(wheel_hz))
        k = np.arange(kmax + 1)
        # the bins' kernel (a triangle of two bins, centred on the bin) has the transfer sinc^2(k / bins)
        coef = np.fft.rfft(means)[: kmax + 1] / STREAM_BINS / np.sinc(k / STREAM_BINS) ** 2
        coef[0] = coef[0].real
        self.orders = coef
        lam = math.exp(-interval_s / STREAM_MEMORY_S)
        self.sums *= lam
        self.weights *= lam
        return coef


class MisalignmentStream:
    """The simulator's side: the proxies of its effects and one running average per tilted wheel."""

    def __init__(self, enabled: bool = True) -> None:
        self.enabled = enabled  # False: the effects run as given (Simulator(streamed_misalignment=False))
        self.proxies: list[StreamedMisalignment] = []
        self.averages: dict[tuple[int, str], SynchronousMeshForce] = {}

    def set_effects(self, effects: Sequence[object], system: Any) -> tuple[object, ...]:
        """The effects to run (see :func:`streamed_effects`); the running averages of wheels still
        tilted are kept and their last orders apply at once, the others dropped."""
        if not self.enabled:
            return tuple(effects)
        run, proxies = streamed_effects(effects)
        self.proxies = proxies
        keep: dict[tuple[int, str], SynchronousMeshForce] = {}
        ratios = np.asarray(system.shaft_speed_ratios, dtype=float)
        for p in proxies:
            avg = self.averages.get(p.key) or keep.get(p.key)
            if avg is None:
                m = system.meshes[p.base.mesh - 1]
                shaft = m.pinion_shaft if p.base.member == "pinion" else m.gear_shaft
                avg = SynchronousMeshForce(p.base.mesh - 1, int(shaft), float(ratios[shaft]))
            keep[p.key] = avg
            p.set_orders(avg.orders)
        self.averages = keep
        return run

    @property
    def active(self) -> bool:
        return bool(self.proxies)

    def push(self, input_angle: np.ndarray, mesh_force: np.ndarray) -> None:
        for avg in self.averages.values():
            avg.push(input_angle, mesh_force)

    def update(self, speed_rpm: float, output_rate_hz: float, interval_s: float) -> None:
        """Update every average (:meth:`SynchronousMeshForce.update`) and hand the orders over."""
        for avg in self.averages.values():
            avg.update(avg.ratio * speed_rpm / 60.0, output_rate_hz, interval_s)
        for p in self.proxies:
            p.set_orders(self.averages[p.key].orders)

    def orders(self) -> dict[str, tuple[complex, ...]]:
        """The orders in use per tilted wheel's label (empty tuple: ``F0``, before the first update)."""
        return {p.label: tuple(p.current.mesh_force_orders) for p in self.proxies}
