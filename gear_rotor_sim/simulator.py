"""Streaming simulator: ``advance(duration) -> SampleBlock`` with speed/temperature ramps and effects.

Orchestration only; the per-step work is the compiled exact Newmark map of
:mod:`gear_rotor_sim.solver`. See docs/solver.md for the method, the dt rule and the decimation.

Module layout (docs/solver.md, "Module layout"): :class:`Simulator` (this module: its parameters,
construction, set-points, effects) is made of three bases, each in its own module and holding no
state of its own: :class:`~gear_rotor_sim.simulator_systems.SystemCache` (systems and steppers per
temperature quantum, the ramps), :class:`~gear_rotor_sim.simulator_stepping.Stepping` (the dt
rule, the chunks, the raw steps) and :class:`~gear_rotor_sim.simulator_stream.Stream`
(``advance``, ``advance_deferred``, the decimated blocks).

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

from collections import OrderedDict
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np

from gear_rotor_sim.faults.misalignment_stream import MisalignmentStream
from gear_rotor_sim.simulator_replay import PeriodicReplay
from gear_rotor_sim.simulator_stepping import (
    DT_RULE_SPEED_FLOOR_RPM,
    DT_RULE_WINDOW_S,
    MODAL_CUTOFF_MESH_HARMONICS,
    MODAL_CUTOFF_OUTPUT_FACTOR,
    Stepping,
    auto_modal_cutoff_hz,
)
from gear_rotor_sim.simulator_stream import PendingBlock, Stream
from gear_rotor_sim.simulator_systems import (
    RAMP_ASSEMBLY_QUANTUM_C,
    RAMP_SPEED_QUANTUM_REL,
    RAMP_TEMPERATURE_QUANTUM_C,
    TEMPERATURE_QUANTUM_C,
    SystemCache,
    _default_builder,
    _Ramp,
)
from gear_rotor_sim.solver.decimate import DeferredDecimator
from gear_rotor_sim.solver.dt_rule import (
    CONTACT_LOSS_RATE_HZ,
    check_contact_loss_rate,
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
    parse_channels,
    static_equilibrium,
)
from gear_rotor_sim.solver.rebase import RampSpan, ThermalLoad
from gear_rotor_sim.system_data import AssembledSystem

# the public names, also those of the bases' modules (their import paths from here are kept)
__all__ = [
    "DT_RULE_SPEED_FLOOR_RPM",
    "DT_RULE_WINDOW_S",
    "MAX_INTEGRATION_RATE_HZ",
    "MAX_SPEED_RPM",
    "MODAL_CUTOFF_MESH_HARMONICS",
    "MODAL_CUTOFF_OUTPUT_FACTOR",
    "RAMP_ASSEMBLY_QUANTUM_C",
    "RAMP_SPEED_QUANTUM_REL",
    "RAMP_TEMPERATURE_QUANTUM_C",
    "TEMPERATURE_QUANTUM_C",
    "Effect",
    "PendingBlock",
    "SimulationDiverged",
    "Simulator",
    "StepContext",
    "auto_modal_cutoff_hz",
]

#: Highest accepted integration rate; an output rate above it is refused.
MAX_INTEGRATION_RATE_HZ = 2.0e7
MAX_SPEED_RPM = 1.0e5


class Effect(Protocol):
    """Calibration effect hook (docs/design.md); any method may return None."""

    name: str

    def mesh_stiffness_factor(self, ctx: StepContext) -> np.ndarray | None: ...

    def transmission_error(self, ctx: StepContext) -> np.ndarray | None: ...

    def external_forces(self, system: AssembledSystem) -> np.ndarray | None: ...

    def force_amplitudes(self, ctx: StepContext) -> np.ndarray | None: ...

    def modify_config(self, cfg: Any) -> Any: ...


class Simulator(SystemCache, Stepping, Stream):
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
    periodic_replay : bool or "faults"
        At a constant set point without effects, once the state at the end of a chunk equals the state
        a whole number of forcing periods earlier (each part within ``REPLAY_TOLERANCE`` = 1e-10 of its
        norm), serve the following steps' channel rows from that period through the same decimation
        instead of integrating, until the set point, the effects or the dt rule's setting changes;
        integration then resumes from the state integration would hold (docs/solver.md, "Periodic
        replay at steady state"; simulator_replay.py). Chaotic or quasi-periodic motion never engages
        it. The angles are taken modulo the forcing period, which moves the stream by the integration's
        sensitivity to round-off. ``"faults"`` also admits effects locked to a shaft's angle at a
        constant severity (a damaged tooth, an eccentric wheel, an unbalance, a shaft misalignment):
        the faulted stream then differs from the plain integration's by that sensitivity, up to 0.15 of
        its peak at 3000 rpm (docs/solver.md). Default False (the calibration, the sweeps, ``record``);
        the ROS node turns it on (parameters ``periodic_replay``, ``periodic_replay_faults``).
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
        periodic_replay: bool | str = False,
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
        if not (isinstance(periodic_replay, bool | np.bool_) or periodic_replay == "faults"):
            raise ValueError(f"periodic_replay: {periodic_replay!r} must be True, False or 'faults'")
        rep = PeriodicReplay(faults=periodic_replay == "faults") if periodic_replay else None
        self._replay = rep
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

    # ------------------------------------------------------------------------------- public API
    @property
    def time_s(self) -> float:
        """Time of the next output sample, s (the end of the stream so far)."""
        return self._n_out / self.output_rate_hz

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
        self._replay_sync()
        return self._state.copy()

    @property
    def replay(self) -> PeriodicReplay | None:
        """The periodic replay's status (``active``, ``period_steps``, ``engaged_at_s``, ...); None
        without ``periodic_replay``."""
        return self._replay

    def _replay_sync(self) -> None:
        """While the stream is replayed, make the carried state the one integration would hold now."""
        if self._replay is not None:
            self._replay.sync(self)

    def set_targets(self, speed_rpm: float | None = None, temperature_c: float | None = None) -> None:
        """New set-points, approached at the ramp rates from the current integration time."""
        self._replay_sync()  # the state the new ramp starts from
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
        if self._replay is not None:
            self._replay.stop(self)  # the state the new effects start from
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

    @property
    def mesh_force_orders(self) -> dict[str, tuple[complex, ...]]:
        """Order coefficients of the mesh force (N) each tilted gear misalignment of the effects uses
        now, by the effect's label: the running synchronous average of the stream's own mesh force
        over the tilted wheel's revolution (faults/misalignment_stream.py); empty: the static mesh
        force ``F0`` (before the first update, 0.1 s). Effects given with ``mesh_force_orders`` keep
        theirs and are not listed."""
        return self._mis.orders()


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
