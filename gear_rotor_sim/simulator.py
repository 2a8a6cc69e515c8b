"""Streaming simulator: ``advance(duration) -> SampleBlock`` with speed/temperature ramps and effects.

Orchestration only; the per-step work is the compiled exact Newmark map of
:mod:`gear_rotor_sim.solver`. See docs/solver.md for the method, the dt rule and the decimation.

Time grids
----------
Output sample ``i`` is at ``t = i / output_rate_hz``. The integration step is
``dt = 1 / (k * output_rate_hz)`` with the integer ``k`` the smallest for which
``dt <= T_mesh / steps_per_mesh`` at the highest speed of the coming chunk (speed floor
``DT_RULE_SPEED_FLOOR_RPM``) and, while the teeth separate, ``dt <= 1 / contact_loss_rate_hz`` with
the mesh events located (the default dt rule, docs/solver.md). ``k`` is raised as soon as needed and
lowered only when 25 % too large (hysteresis); it changes only on output-grid instants. The
anti-aliasing FIR is centred (zero phase), so the integration runs its group delay (about 25 output
periods) ahead of the last emitted sample; new set-points apply from the integration time.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from gear_rotor_sim.blocks import SampleBlock
from gear_rotor_sim.faults.misalignment_stream import MisalignmentStream
from gear_rotor_sim.solver.basis_cache import cached_eigen_basis
from gear_rotor_sim.solver.decimate import DeferredDecimator
from gear_rotor_sim.solver.dt_rule import (
    CONTACT_LOSS_RATE_HZ,
    check_contact_loss_rate,
    light_mesh_modes,
    resonance_rate_hz,
    rule_locate_events,
)
from gear_rotor_sim.solver.newmark import (
    MAX_STEPS_PER_MESH,
    MIN_STEPS_PER_MESH,
    SPEED_QUANTUM_REL,
    ChunkBuffers,
    NewmarkStepper,
    SimulationDiverged,
    SolverState,
    StepContext,
    _effect_arrays,
    available_channels,
    check_steps_per_mesh,
    mesh_frequencies_hz,
    mesh_frequency_hz,
    parse_channels,
    quantize_speed_rpm,
    static_equilibrium,
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

__all__ = ["Effect", "SimulationDiverged", "Simulator", "StepContext"]

#: Temperature quantum of the system cache, C (a ramp rebuilds the system at these steps).
TEMPERATURE_QUANTUM_C = 0.5
#: Modal reduction (``modal_cutoff_hz="auto"``): the modes above the larger of this many output rates
#: and ``MODAL_CUTOFF_MESH_HARMONICS`` harmonics of the highest mesh frequency are carried by their
#: static response (residual flexibility); docs/solver.md, "Modal reduction".
MODAL_CUTOFF_OUTPUT_FACTOR = 2.0
#: While a speed / temperature ramp runs, the gyroscopic basis and the system are re-built on these
#: coarser grids (docs/solver.md, "Ramps"); at a constant set-point the fine quanta above apply.
RAMP_SPEED_QUANTUM_REL = 0.25
RAMP_TEMPERATURE_QUANTUM_C = 5.0
#: While the temperature ramps, exact systems are assembled on this grid (and at the ramp's ends); the
#: basis-grid nodes between are interpolated (solver/rebase.py).
RAMP_ASSEMBLY_QUANTUM_C = 25.0
MODAL_CUTOFF_MESH_HARMONICS = 4.0


def auto_modal_cutoff_hz(f_mesh_hz: float, output_rate_hz: float) -> float:
    """The ``modal_cutoff_hz="auto"`` cut-off: the larger of ``MODAL_CUTOFF_OUTPUT_FACTOR`` output
    rates and ``MODAL_CUTOFF_MESH_HARMONICS`` harmonics of the (highest) mesh frequency, Hz."""
    return max(MODAL_CUTOFF_OUTPUT_FACTOR * output_rate_hz, MODAL_CUTOFF_MESH_HARMONICS * f_mesh_hz)


#: The dt rule uses at least this speed (dt at standstill stays bounded).
DT_RULE_SPEED_FLOOR_RPM = 60.0
#: Highest accepted integration rate; an output rate above it is refused.
MAX_INTEGRATION_RATE_HZ = 2.0e7
MAX_SPEED_RPM = 1.0e5
_MAX_CHUNK_STEPS = 65536
#: The dt rule decides on fixed instants of this spacing (whatever the chunking, so that the stream
#: stays independent of how ``advance`` is called): contact-loss setting on if the teeth separated in
#: the window just ended, off after a whole window in continuous contact, s.
DT_RULE_WINDOW_S = 0.1


class Effect(Protocol):
    """Calibration effect hook (docs/design.md); any method may return None."""

    name: str

    def mesh_stiffness_factor(self, ctx: StepContext) -> np.ndarray | None: ...

    def transmission_error(self, ctx: StepContext) -> np.ndarray | None: ...

    def external_forces(self, system: AssembledSystem) -> np.ndarray | None: ...

    def force_amplitudes(self, ctx: StepContext) -> np.ndarray | None: ...

    def modify_config(self, cfg: Any) -> Any: ...


@dataclass
class _Ramp:
    """value(t) moves from ``v0`` at ``t0`` toward ``target`` at ``rate`` per second."""

    t0: float
    v0: float
    target: float
    rate: float

    def value(self, t: np.ndarray | float) -> np.ndarray:
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


def _default_builder(cfg: Any, temperature_c: float) -> AssembledSystem:
    from gear_rotor_sim.system import GearRotorSystem  # assembly module (physics core)

    return GearRotorSystem.from_config(cfg, temperature_c)


class PendingBlock:
    """A block integrated by :meth:`Simulator.advance_deferred` whose samples are not filtered yet.

    ``first_index``, ``n_samples`` and ``t0`` are known at once; :meth:`result` runs the decimation
    (once; later calls return the same block).
    """

    __slots__ = ("_block", "_sim", "first_index", "n_samples", "t0")

    def __init__(self, sim: Simulator, first_index: int, n_samples: int) -> None:
        self._sim: Simulator | None = sim
        self.first_index = first_index
        self.n_samples = n_samples
        self.t0 = first_index / sim.output_rate_hz
        self._block: SampleBlock | None = None

    def result(self) -> SampleBlock:
        """The :class:`SampleBlock` (what :meth:`Simulator.advance` returns)."""
        if self._block is None:
            assert self._sim is not None
            self._block = self._sim._output_block(self.first_index, self.n_samples)
            self._sim = None
        return self._block


class Simulator:
    """Streaming nonlinear simulator of the gear-rotor-bearing system (Eq 39).

    Parameters
    ----------
    cfg : RigConfig
        The rig (effects' ``modify_config`` are applied to it first).
    speed_rpm, temperature_c : float
        Initial operating point (also the initial targets); the state starts at static equilibrium.
    output_rate_hz : float
        Sample rate of the returned blocks.
    channels : sequence of str, optional
        Channel names (``Simulator.available_channels(cfg)``); None: ``dte``, ``mesh_force``, all
        bearing forces and the pinion-node accelerations x, y.
    steps_per_mesh : int
        Minimum integration steps per mesh period (8..4096); default 32 (docs/solver.md).
    contact_loss_rate_hz : float or None
        The default dt rule: while the teeth separate (free flight or back-side contact in the last
        window of ``DT_RULE_WINDOW_S``) the integration rate is at least this and the mesh events are
        located; it returns to ``steps_per_mesh`` after a window in continuous contact. None:
        ``steps_per_mesh`` throughout.
    speed_ramp_rpm_per_s, temperature_ramp_c_per_s : float
        Ramp rates toward new targets (> 0; ``inf`` jumps).
    ramp_speed_quantum_rel, ramp_temperature_quantum_c : float
        Grids of the eigenbasis while a speed ramp (relative speed step, default 25 %) or a
        temperature ramp (default 5 C; exact assembly per ``RAMP_ASSEMBLY_QUANTUM_C``, the static
        load, mesh tables and backlash still per 0.5 C, solver/rebase.py) runs; at a constant
        set-point the fine quanta (1 %, 0.5 C) apply. Chunks still end at every fine quantum (the dt
        rule decides there). ``SPEED_QUANTUM_REL`` / ``TEMPERATURE_QUANTUM_C`` give the per-quantum
        rebuild (an exact assembly and eigendecomposition per quantum). Eigenbases are cached on
        disk across runs (solver/basis_cache.py).
    modal_cutoff_hz : "auto", float or None
        Modal reduction with static correction: the modes above the cut-off follow the excitation
        quasi-statically (residual flexibility) and only the retained ones are integrated by the exact
        map (docs/solver.md, "Modal reduction"). "auto" (default): the larger of 2 output rates and 4
        harmonics of the highest mesh frequency (40 kHz at 20 kHz output up to 10 kHz mesh
        frequency). None: full model. A number: that cut-off (Hz).
    effects : sequence of Effect
    locate_events : bool, optional
        Split integration steps at the mesh-table jumps and contact changes inside them (second-order
        accurate at those events, docs/solver.md); False takes them at the step instants (faster).
        Default: the dt rule (``rule_locate_events``): on while the teeth separate, and from
        ``LOCATE_EVENTS_FROM_STEPS`` steps per mesh period.
    exact_modal_map : bool, optional
        The exact modal propagator instead of Newmark's map (no period error at any mode;
        docs/solver.md, "Exact modal map"). Default (None): the dt rule's choice, the exact map where
        the rule's resonance part (a lightly damped mode near a low mesh harmonic) would raise the
        integration rate, Newmark's map elsewhere. True / False: always / never (False gives the
        resonance part's higher rate instead).
    one_setting : bool
        The dt rule's contact-loss setting (rate >= ``contact_loss_rate_hz``, events located) in
        continuous contact too, so that the rule has one setting and the stream cannot depend on
        whether the teeth once separated (e.g. in a start-up transient). The contact setting (32 steps
        per mesh period, not located) keeps the RMS DTE within 0.3 % but not the waveform: at 3000 rpm
        the bearing forces differ from 1024 located steps per mesh period by 5-11 % of their
        fluctuating RMS, the contact-loss setting by 0.2-0.8 % (docs/solver.md, "Session 8"), and a
        switch between the two leaves a transient of that size. Default False (the two-setting
        rule: at 3000 rpm 5.3x fewer steps in contact and 5.2x the real-time factor).
    event_average : bool
        On a step holding a located event (a table jump or contact change), give the channels the
        end value shifted by what the events change in the step's mean, ``x_n + A_n - (x_{n-1} +
        x_n) / 2`` (``A_n`` the average over the step's sub-steps), instead of the end value, so that
        the events' times inside the step reach the output. Point samples of signals with jumps
        (the mesh force; with the reduced basis every channel) fold their high harmonics into the
        output band: at 20000 rpm a 1000 Hz line in the mesh force as large as the mesh line
        (docs/solver.md, "Session 10"). Regular steps are unchanged. Default True (the streams a
        user sees); the calibration's model runs pass False, the setting its tables were measured
        with. The gear kernel only (the dense fallback ignores it).
    average_table_jumps : bool
        With located events, a step whose only events are table jumps (at most one per mesh) is taken
        whole with the tables' average over the step instead of as sub-steps split at the jumps
        (docs/solver.md, "Session 11": 1.14x / 1.20x DTE-only CPU RTF at 20000 / 15000 rpm, RMS DTE
        within 0.5 % of the converged model; at 20000 rpm the fluctuating part's error doubles).
        Default False. The gear kernel only.
    streamed_misalignment : bool
        A tilted ``GearMisalignment`` given without ``mesh_force_orders`` takes them from a running
        synchronous average of the stream's own mesh force (faults/misalignment_stream.py; docs/
        faults.md): its axial force follows the instantaneous mesh force. Default True (the node,
        ``record``, ``dataset``); False: such an effect keeps the static mesh force ``F0`` (the
        calibration's model runs, which supply the orders from their own fixed-point pass).
    system_builder : callable, optional
        ``(cfg, temperature_c) -> AssembledSystem``; default ``GearRotorSystem.from_config``.
    """

    def __init__(
        self,
        cfg: Any,
        speed_rpm: float = 3000.0,
        temperature_c: float = 25.0,
        output_rate_hz: float = 20000.0,
        channels: Sequence[str] | None = None,
        steps_per_mesh: int = 32,
        speed_ramp_rpm_per_s: float = 2000.0,
        temperature_ramp_c_per_s: float = 20.0,
        effects: Sequence[Effect] = (),
        *,
        system_builder: Callable[[Any, float], AssembledSystem] | None = None,
        force_dense: bool = False,
        locate_events: bool | None = None,
        contact_loss_rate_hz: float | None = CONTACT_LOSS_RATE_HZ,
        modal_cutoff_hz: float | str | None = "auto",
        exact_modal_map: bool | None = None,
        ramp_speed_quantum_rel: float = RAMP_SPEED_QUANTUM_REL,
        ramp_temperature_quantum_c: float = RAMP_TEMPERATURE_QUANTUM_C,
        one_setting: bool = False,
        event_average: bool = True,
        average_table_jumps: bool = False,
        streamed_misalignment: bool = True,
    ) -> None:
        _check_speed(speed_rpm)
        cut_ok = modal_cutoff_hz is None or modal_cutoff_hz == "auto"
        if not cut_ok and isinstance(modal_cutoff_hz, int | float):
            cut_ok = bool(np.isfinite(modal_cutoff_hz) and modal_cutoff_hz > 0)
        if not cut_ok:
            raise ValueError(
                f"modal_cutoff_hz: {modal_cutoff_hz!r} must be 'auto', None (full model) or a "
                "frequency > 0 Hz"
            )
        self.modal_cutoff_hz = modal_cutoff_hz
        if exact_modal_map is not None and not isinstance(exact_modal_map, bool | np.bool_):
            raise ValueError(
                f"exact_modal_map: {exact_modal_map!r} must be True, False or None (the dt rule)"
            )
        self._exact_opt = exact_modal_map
        self._exact = bool(exact_modal_map)  # the map in use (the dt rule's choice with None)
        for name, q, lo, hi in (
            ("ramp_speed_quantum_rel", ramp_speed_quantum_rel, SPEED_QUANTUM_REL, 1.0),
            ("ramp_temperature_quantum_c", ramp_temperature_quantum_c, TEMPERATURE_QUANTUM_C, 25.0),
        ):
            if not (isinstance(q, int | float) and lo <= q <= hi):  # also rejects NaN
                raise ValueError(f"{name}: {q!r} must be in [{lo:g}, {hi:g}]")
        self.ramp_speed_quantum_rel = float(ramp_speed_quantum_rel)
        self.ramp_temperature_quantum_c = float(ramp_temperature_quantum_c)
        _check_temperature(temperature_c)
        if not (np.isfinite(output_rate_hz) and 0 < output_rate_hz <= MAX_INTEGRATION_RATE_HZ):
            raise ValueError(
                f"output_rate_hz: {output_rate_hz!r} must be in (0, {MAX_INTEGRATION_RATE_HZ:g}] "
                "(it cannot exceed the highest integration rate)"
            )
        check_steps_per_mesh(steps_per_mesh)
        check_contact_loss_rate(contact_loss_rate_hz, MAX_INTEGRATION_RATE_HZ)
        for name, rate in (
            ("speed_ramp_rpm_per_s", speed_ramp_rpm_per_s),
            ("temperature_ramp_c_per_s", temperature_ramp_c_per_s),
        ):
            if not rate > 0:  # also rejects NaN
                raise ValueError(f"{name}: {rate!r} must be > 0 (inf for a jump)")
        self.effects = tuple(effects)
        if not isinstance(streamed_misalignment, bool | np.bool_):
            raise ValueError(f"streamed_misalignment: {streamed_misalignment!r} must be True or False")
        # tilted wheels' axial force from the stream's own mesh force (faults/misalignment_stream.py)
        self._mis = MisalignmentStream(bool(streamed_misalignment))
        self._run_effects = self.effects  # the effects the steppers run (with the streamed ones)
        self.base_cfg = cfg
        cfg = _modified_config(cfg, self.effects)
        self.cfg = cfg
        self._builder = system_builder or _default_builder
        self.output_rate_hz = float(output_rate_hz)
        self.steps_per_mesh = int(steps_per_mesh)
        self.speed_ramp = float(speed_ramp_rpm_per_s)
        self.temperature_ramp = float(temperature_ramp_c_per_s)
        self._force_dense = force_dense
        self._chunk_buffers = ChunkBuffers()  # per-chunk work arrays kept across chunks
        self.contact_loss_rate_hz = None if contact_loss_rate_hz is None else float(contact_loss_rate_hz)
        self._locate_opt = None if locate_events is None else bool(locate_events)
        if not isinstance(one_setting, bool | np.bool_):
            raise ValueError(f"one_setting: {one_setting!r} must be True or False")
        if not isinstance(event_average, bool | np.bool_):
            raise ValueError(f"event_average: {event_average!r} must be True or False")
        self.event_average = bool(event_average)
        if not isinstance(average_table_jumps, bool | np.bool_):
            raise ValueError(f"average_table_jumps: {average_table_jumps!r} must be True or False")
        self.average_table_jumps = bool(average_table_jumps)
        self.one_setting = bool(one_setting) and contact_loss_rate_hz is not None
        self._loss_mode = self.one_setting  # the dt rule's contact-loss setting is active
        self._separated = False  # the teeth separated in the current dt-rule window
        self._rule_window = max(1, round(DT_RULE_WINDOW_S * self.output_rate_hz))  # output samples
        self._seg_out0 = 0  # output index of raw index 0 of the current raw segment
        self.locate_events = False  # set from the dt rule once k is known (below)
        self._systems: OrderedDict[float, tuple[AssembledSystem, NewmarkStepper]] = OrderedDict()
        # ramp systems at the fine quanta between the grid nodes (solver/rebase.py), LRU
        self._spans: OrderedDict[float, RampSpan] = OrderedDict()  # per basis-grid node
        self._thermal: ThermalLoad | None = None
        self._nodes: OrderedDict[float, tuple[AssembledSystem, NewmarkStepper]] = OrderedDict()
        tq = self._tq(temperature_c)
        system = self._build(tq)
        names = list(channels) if channels is not None else self.default_channels(system)
        self.specs = parse_channels(system, names)
        self._run_effects = self._mis.set_effects(self.effects, system)
        self._systems[tq] = (
            system,
            self._stepper_for(system),
        )
        self.channels = tuple(names)
        self.units = tuple(s.unit for s in self.specs)
        system, stepper = self._system(tq)
        self._state: SolverState = static_equilibrium(system, self._run_effects)
        self._speed = _Ramp(0.0, float(speed_rpm), float(speed_rpm), self.speed_ramp)
        self._angle0 = 0.0  # input-shaft angle at the start of the current speed ramp, rad
        self._temp = _Ramp(0.0, float(temperature_c), float(temperature_c), self.temperature_ramp)
        self._tq_cur = tq
        self._sys_key = (tq, False)  # (fine quantum, ramp system) of the stepper in use
        self._stepper = stepper
        self._k = self._k_required(speed_rpm, speed_rpm, system)
        self._seg_t0 = 0.0  # time of raw index 0 of the current raw segment
        self._raw = 0  # raw steps done in the segment
        self.locate_events = self._locate_now()
        self._omega_q = -1.0
        self._activate(stepper, self._state, speed_rpm)
        init = np.concatenate([stepper.initial_outputs(self._state), [speed_rpm, temperature_c]])
        self._dec = DeferredDecimator(self._k, init, n_main=len(self.specs))
        self._n_out = 0
        self.last_chunk_stats: dict[str, float] = {}

    # ----------------------------------------------------------------------------------- helpers
    @staticmethod
    def default_channels(system: AssembledSystem) -> list[str]:
        names: list[str] = []
        if len(system.meshes) == 1:
            names += ["dte", "mesh_force"]
        else:  # one DTE and force channel per mesh, 1-based in the order of ``meshes:``
            for k in range(1, len(system.meshes) + 1):
                names += [f"mesh{k}_dte", f"mesh{k}_force"]
        for b in system.bearings:
            names += [f"bearing{b.number}_f{c}" for c in "xyz"]
        if system.meshes:
            node = system.meshes[0].pinion_node0 + 1
            names += [f"node{node}_ax", f"node{node}_ay"]
        return names

    @staticmethod
    def available_channels(
        cfg: Any,
        system_builder: Callable[[Any, float], AssembledSystem] | None = None,
        temperature_c: float | None = None,
    ) -> list[tuple[str, str]]:
        """All channel names with units for a rig."""
        builder = system_builder or _default_builder
        t = getattr(cfg, "reference_temperature_c", 25.0) if temperature_c is None else temperature_c
        return available_channels(builder(cfg, float(t)))

    @staticmethod
    def _tq(temperature_c: float) -> float:
        return float(np.round(temperature_c / TEMPERATURE_QUANTUM_C) * TEMPERATURE_QUANTUM_C)

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
        hit = self._nodes.get(tq)
        if hit is None:
            system = interpolated_system(self._system(a)[0], self._system(b)[0], tq, self._thermal_load(tq))
            hit = (system, self._stepper_for(system))
            self._nodes[tq] = hit
            if len(self._nodes) > 4:
                self._nodes.popitem(last=False)
        else:
            self._nodes.move_to_end(tq)
        return hit

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
        hit = self._systems.get(tq)
        if hit is None:
            system = self._build(tq)
            hit = (
                system,
                self._stepper_for(system),
            )
            self._systems[tq] = hit
            if len(self._systems) > 8:
                self._systems.popitem(last=False)
        else:
            self._systems.move_to_end(tq)
        return hit

    def _locate_now(self) -> bool:
        if self._locate_opt is not None:
            return self._locate_opt
        return rule_locate_events(self._spm_now, self._loss_mode)

    def _k_required(self, s0: float, s1: float, system: AssembledSystem) -> int:
        f = mesh_frequency_hz(system, max(s0, s1, DT_RULE_SPEED_FLOOR_RPM))
        if f <= 0:  # no mesh: resolve the first torsional/bending modes instead, at least 4x
            return 4
        rate = self.steps_per_mesh * f
        if self.contact_loss_rate_hz is not None:  # the dt rule's contact-loss and resonance parts
            if self._loss_mode:
                rate = max(rate, self.contact_loss_rate_hz)
            res = 0.0
            if self._exact_opt is not True:
                stepper = self._stepper
                light = light_mesh_modes(stepper.lin, stepper.basis(self._sq(s0) * 2.0 * np.pi / 60.0))
                for sp in (s0, s1):  # every mesh's harmonics (a light mode near any of them)
                    for fm in mesh_frequencies_hz(system, max(sp, DT_RULE_SPEED_FLOOR_RPM)):
                        res = max(res, resonance_rate_hz(fm, light))
            if self._exact_opt is None:  # the exact map instead of resolving the light mode
                self._exact = res > rate
            if not self._exact:
                rate = max(rate, res)
            rate = min(rate, MAX_STEPS_PER_MESH * f)
        return max(1, int(np.ceil(rate / self.output_rate_hz * (1 - 1e-12))))

    @property
    def _spm_now(self) -> float:
        """Integration steps per mesh period at the current speed."""
        system = self._stepper.system
        f = mesh_frequency_hz(system, max(self.speed_rpm, DT_RULE_SPEED_FLOOR_RPM))
        return self._k * self.output_rate_hz / f if f > 0 else float("inf")

    @property
    def dt(self) -> float:
        return 1.0 / (self._k * self.output_rate_hz)

    def _cutoff_hz(self, system: AssembledSystem, speed_rpm: float) -> float | None:
        """Modal cut-off of the reduced model at a speed (None: full model).

        ``"auto"``: the larger of ``MODAL_CUTOFF_OUTPUT_FACTOR`` output rates and
        ``MODAL_CUTOFF_MESH_HARMONICS`` harmonics of the highest mesh frequency at the quantised speed
        (docs/solver.md, "Modal reduction": the RMS DTE within 0.005 % of the full model on the paper
        gearbox). A number: that cut-off.
        """
        cut = self.modal_cutoff_hz
        if cut is None:
            return None
        if cut != "auto":
            return float(cut)
        f_mesh = mesh_frequency_hz(system, max(self._sq(speed_rpm), DT_RULE_SPEED_FLOOR_RPM))
        return auto_modal_cutoff_hz(f_mesh, self.output_rate_hz)

    def _activate(self, stepper: NewmarkStepper, st: SolverState, speed_rpm: float) -> None:
        self._stepper = stepper
        stepper.modal_cutoff_hz = self._cutoff_hz(stepper.system, speed_rpm)
        stepper.exact_map = self._exact
        self._omega_q = self._sq(speed_rpm) * 2.0 * np.pi / 60.0
        stepper.set_operating_point(self._omega_q, self.dt, st)

    # ------------------------------------------------------------------------------- public API
    @property
    def time_s(self) -> float:
        """Time of the next output sample, s (the end of the stream so far)."""
        return self._n_out / self.output_rate_hz

    @property
    def _raw_time(self) -> float:
        return self._seg_t0 + self._raw * self.dt

    @property
    def speed_rpm(self) -> float:
        return float(self._speed.value(self._raw_time))

    @property
    def temperature_c(self) -> float:
        return float(self._temp.value(self._raw_time))

    @property
    def target_speed_rpm(self) -> float:
        return self._speed.target

    @property
    def target_temperature_c(self) -> float:
        return self._temp.target

    @property
    def targets(self) -> tuple[float, float]:
        return self._speed.target, self._temp.target

    @property
    def state(self) -> SolverState:
        return self._state.copy()

    def set_targets(self, speed_rpm: float | None = None, temperature_c: float | None = None) -> None:
        """New set-points, approached at the ramp rates from the current integration time."""
        t = self._raw_time
        if speed_rpm is not None:
            _check_speed(speed_rpm)
            self._angle0 += float(self._speed.integral(t)) * (2.0 * np.pi / 60.0)
            self._speed = _Ramp(t, float(self._speed.value(t)), float(speed_rpm), self.speed_ramp)
        if temperature_c is not None:
            _check_temperature(temperature_c)
            self._system(self._tq(temperature_c))  # material policy check now, not mid-stream
            self._spans.clear()  # their grid nodes belong to the previous ramp
            self._nodes.clear()
            self._temp = _Ramp(t, float(self._temp.value(t)), float(temperature_c), self.temperature_ramp)

    def set_effects(self, effects: Sequence[Effect]) -> None:
        """Replace the effects from the current integration time on; the state is carried.

        The systems are rebuilt with the effects' ``modify_config`` applied to the rig given at
        construction (``base_cfg``), and the carried effect force amplitudes are those of the new
        effects at the current step, so that a fault already active continues without a jump. The
        integration runs the decimation filter's group delay (about 25 output samples) ahead of the
        last emitted sample: the change shows from there.
        """
        effects = tuple(effects)
        cfg = _modified_config(self.base_cfg, effects)
        self.effects = effects
        self._run_effects = self._mis.set_effects(effects, self._stepper.system)
        effects = self._run_effects
        self.cfg = cfg
        self._systems.clear()
        self._spans.clear()
        self._nodes.clear()
        self._thermal = None  # modify_config may change the materials
        _, stepper = self._system(self._tq_cur)
        self._sys_key = (self._tq_cur, False)
        t = self._raw_time
        dt = self.dt
        tt = np.array([t - dt, t, t + dt])
        angle = self._angle0 + self._speed.integral(tt) * (2.0 * np.pi / 60.0)
        speed = self._speed.value(tt) * (2.0 * np.pi / 60.0)
        st = self._state
        if stepper.lin.ne:
            _, _, _, _, ampl = _effect_arrays(stepper.lin, tt, angle, speed, effects)
            st.ampl = ampl[-1].copy()
        else:
            st.ampl = np.zeros(0)
        self._activate(stepper, st, float(self._speed.value(t)))

    def advance(self, duration: float) -> SampleBlock:
        """Integrate and return the output samples with times in [time_s, time_s + duration)."""
        return self.advance_deferred(duration).result()

    def advance_deferred(self, duration: float) -> PendingBlock:
        """:meth:`advance` with the output filtering left to whoever calls ``result()``.

        Integrates now (the simulator is at ``time_s + duration`` on return) and returns a
        :class:`PendingBlock` that knows the block's first sample index and length; its ``result()``
        runs the anti-aliasing decimation of the raw samples and returns the :class:`SampleBlock`
        that :meth:`advance` would have returned, bit for bit. Pending blocks must be resolved in the
        order they were made (a ValueError otherwise); ``result()`` may run in another thread,
        concurrently with the next ``advance_deferred`` (the simulator node does so: the FIR then runs
        on the other core while the next chunk is integrated). ``last_chunk_stats["wall_s"]`` counts
        the integration only.
        """
        if not (np.isfinite(duration) and duration >= 0):
            raise ValueError(f"duration: {duration!r} must be finite and >= 0")
        wall0 = time.perf_counter()
        n_target = int(np.ceil((self.time_s + duration) * self.output_rate_hz - 1e-9))
        n_emit = n_target - self._n_out
        got = 0
        steps = n_loss = n_back = 0
        try:
            while got < n_emit:
                need_raw = (n_target - 1) * 1.0 / self.output_rate_hz  # last output time
                dt = self.dt
                t_raw = self._raw_time
                n_steps = int(np.ceil((need_raw - t_raw) / dt - 1e-9)) + self._dec.delay
                n_steps = max(n_steps, 1)
                n_steps = self._limit_chunk(n_steps, t_raw, dt)
                n_y, loss, back = self._run_steps(n_steps)
                steps += n_steps
                n_loss += loss
                n_back += back
                if n_y:
                    take = min(n_y, n_emit - got)
                    got += take
                    self._pending_n = n_y - take
                self._maybe_regrid()
        except BaseException:
            self._pending_n += got  # completed outputs stay queued for the next block, in order
            raise
        first = self._n_out
        self._n_out += got
        self.last_chunk_stats = {
            "contact_loss_fraction": n_loss / max(steps, 1),
            "back_contact_fraction": n_back / max(steps, 1),
            "steps": float(steps),
            "wall_s": time.perf_counter() - wall0,
            "dt_s": self.dt,
            "decimation": float(self._k),
            "located": float(self.locate_events),
            "exact_modal_map": float(self._exact),
            "contact_loss_rule": float(self._loss_mode),
            "mesh_solve_failures": float(self._stepper.n_mesh_fail),
        }
        return PendingBlock(self, first, got)

    def _output_block(self, first: int, n: int) -> SampleBlock:
        """The decimated samples ``first .. first + n - 1`` as a block (see :class:`PendingBlock`)."""
        data = self._dec.take(n, first)
        nch = len(self.channels)
        return SampleBlock(
            first / self.output_rate_hz,
            self.output_rate_hz,
            self.channels,
            self.units,
            np.ascontiguousarray(data[:, :nch]),
            first,
            data[:, nch].copy(),
            data[:, nch + 1].copy(),
        )

    # ------------------------------------------------------------------------------- internals
    _pending_n: int = 0  # outputs completed by the last raw chunk beyond what its block took

    def _limit_chunk(self, n_steps: int, t_raw: float, dt: float) -> int:
        n = min(n_steps, _MAX_CHUNK_STEPS)
        # stop at the next quantum change of speed (gyroscopic basis) or temperature (system rebuild)
        s_now = float(self._speed.value(t_raw))
        if s_now != self._speed.target:
            # chunks end at every fine quantum (the dt rule decides there, as without the ramp grid);
            # the basis changes only where the ramp grid's value does (_run_steps)
            sq = quantize_speed_rpm(s_now)
            up = self._speed.target > s_now
            step = np.sqrt(1.0 + SPEED_QUANTUM_REL)  # half a quantum on the log grid
            level = (sq * step if up else sq / step) if sq > 0 else (0.5 if up else -1.0)
            # the ramp's end is a crossing too (the fine grid takes over there)
            level = min(level, self._speed.target) if up else max(level, self._speed.target)
            tt = self._speed.time_to_reach(level) + self._speed.t0 - t_raw
            if np.isfinite(tt):
                n = min(n, max(1, int(np.ceil(tt / dt))))
        tc = float(self._temp.value(t_raw))
        if tc != self._temp.target:
            up = self._temp.target > tc
            level = self._tq(tc) + (0.5 if up else -0.5) * TEMPERATURE_QUANTUM_C
            # the ramp's end is a crossing too (the fine grid takes over there)
            level = min(level, self._temp.target) if up else max(level, self._temp.target)
            tt = self._temp.time_to_reach(level) + self._temp.t0 - t_raw
            if np.isfinite(tt):
                n = min(n, max(1, int(np.ceil(tt / dt))))
        # chunks end on the output grid so that the decimation factor can change there
        k = self._k
        end = self._raw + n
        end = -(-end // k) * k
        if self.contact_loss_rate_hz is not None or self._mis.active:  # and at the next decision instant
            w = self._rule_window
            nxt = ((self._seg_out0 + self._raw // k) // w + 1) * w
            end = min(end, (nxt - self._seg_out0) * k)
        return end - self._raw

    def _run_steps(self, n: int) -> tuple[int, int, int]:
        """Integrate ``n`` raw steps; return the outputs now complete (with those left over from the
        previous call), the steps with contact loss and those with back-side contact."""
        t_raw = self._raw_time
        # operating point at the chunk start (quantised)
        s_now = float(self._speed.value(t_raw))
        temp_now = float(self._temp.value(t_raw))
        tq = self._tq(temp_now)
        key = (tq, temp_now != self._temp.target)
        if key != self._sys_key:
            stepper, carry = self._system_at(*key, s_now)
            self._tq_cur = tq
            self._sys_key = key
            if not carry:
                self._activate(stepper, self._state, s_now)
        else:
            oq = self._sq(s_now) * 2.0 * np.pi / 60.0
            if (
                oq != self._omega_q
                or self._stepper.map is None
                or self._stepper.map.dt != self.dt
                or self._stepper.exact_map != self._exact
            ):
                self._activate(self._stepper, self._state, s_now)
        dt = self.dt
        # new steps are raw+1 .. raw+n (raw is the carried state), plus one neighbour on each side
        j = np.arange(self._raw, self._raw + n + 2, dtype=float)
        t = self._seg_t0 + j * dt
        speed = self._speed.value(t) * (2.0 * np.pi / 60.0)
        # angle anchored at the ramp start: the same values whatever the chunking
        angle = self._angle0 + self._speed.integral(t) * (2.0 * np.pi / 60.0)
        self.locate_events = self._locate_now()
        self._stepper.locate_events = self.locate_events
        ch, _, _, fm, states, _ = self._stepper.run(t, angle, speed, self._state)
        if self._mis.active:
            self._mis.push(angle[1:-1], fm)
        self._raw += n
        self._update_dt_rule(states)
        self._update_misalignment()
        # the channels, speed and temperature go side by side straight into the decimator's store; a
        # set-point held over the whole chunk as one value (the decimator returns it exactly where it
        # fills an output's window, without filtering it)
        sp = self._speed
        speed_col = sp.target if float(sp.value(t[1])) == sp.target else speed[1:-1] * 60.0 / (2.0 * np.pi)
        tr = self._temp
        temp_col = tr.target if float(tr.value(t[1])) == tr.target else tr.value(t[1:-1])
        n_y = self._dec.push(ch, speed_col, temp_col) + self._pending_n
        self._pending_n = 0
        loss = back = 0
        if states.shape[1]:
            loss = int(np.count_nonzero((states == 0).any(axis=1)))  # any mesh
            back = int(np.count_nonzero((states < 0).any(axis=1)))
        return n_y, loss, back

    def _update_dt_rule(self, states: np.ndarray) -> None:
        """Contact-loss setting at the window ends: on after a separation, off after none."""
        if self.contact_loss_rate_hz is None or not states.shape[1]:
            return
        if not self._separated and states.shape[0] and states.min() < 2:  # any mesh: free flight, back side
            self._separated = True  # or pinned at +-b*
        if self._raw % self._k or (self._seg_out0 + self._raw // self._k) % self._rule_window:
            return
        self._loss_mode = self._separated or self.one_setting
        self._separated = False
        self.locate_events = self._locate_now()

    def _update_misalignment(self) -> None:
        """At the fixed update instants (every ``DT_RULE_WINDOW_S`` on the output grid), the tilted
        wheels' mesh-force orders from the running synchronous average of the stream's mesh force
        (faults/misalignment_stream.py)."""
        if not self._mis.active:
            return
        if self._raw % self._k or (self._seg_out0 + self._raw // self._k) % self._rule_window:
            return
        self._mis.update(self.speed_rpm, self.output_rate_hz, self._rule_window / self.output_rate_hz)

    @property
    def mesh_force_orders(self) -> dict[str, tuple[complex, ...]]:
        """Order coefficients of the mesh force (N) each tilted gear misalignment of the effects uses
        now, by the effect's label: the running synchronous average of the stream's own mesh force
        over the tilted wheel's revolution (faults/misalignment_stream.py); empty: the static mesh
        force ``F0`` (before the first update, 0.1 s). Effects given with ``mesh_force_orders`` keep
        theirs and are not listed."""
        return self._mis.orders()

    def _maybe_regrid(self) -> None:
        if self._raw % self._k:
            return
        t = self._raw_time
        system = self._stepper.system
        s_now = float(self._speed.value(t))
        s_end = float(self._speed.value(t + 0.05))
        k_req = self._k_required(s_now, s_end, system)
        if k_req > self._k or k_req <= 0.75 * self._k:
            self._dec.regrid(k_req, self._raw)
            self._seg_out0 += self._raw // self._k
            self._seg_t0 = t
            self._raw = 0
            self._k = k_req
            self._activate(self._stepper, self._state, s_now)
        elif self._raw > 1 << 40:
            self._dec.rebase(self._raw)
            self._seg_out0 += self._raw // self._k
            self._seg_t0 = t
            self._raw = 0


def _modified_config(cfg: Any, effects: Sequence[Effect]) -> Any:
    for eff in effects:
        fn = getattr(eff, "modify_config", None)
        if fn is not None:
            cfg = fn(cfg)
    return cfg


def _check_speed(speed_rpm: float) -> None:
    if not (np.isfinite(speed_rpm) and 0.0 <= speed_rpm <= MAX_SPEED_RPM):
        raise ValueError(f"speed_rpm: {speed_rpm!r} must be finite and in 0..{MAX_SPEED_RPM:g}")


def _check_temperature(temperature_c: float) -> None:
    if not np.isfinite(temperature_c):
        raise ValueError(f"temperature_c: {temperature_c!r} must be finite (material range per policy)")


_ = (MIN_STEPS_PER_MESH, MAX_STEPS_PER_MESH)
