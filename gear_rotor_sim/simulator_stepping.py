"""The Simulator's stepping: the dt rule, the chunks, the stepper's operating point and the raw steps.

Part of :class:`gear_rotor_sim.simulator.Simulator` (docs/solver.md, "Module layout", "dt rule and
decimation"): :class:`Stepping` is one of its bases and holds no state of its own; the attributes it
reads and writes are the Simulator's (set in ``Simulator.__init__``).
"""

from __future__ import annotations

import numpy as np

from gear_rotor_sim.simulator_replay import PeriodicReplay
from gear_rotor_sim.simulator_systems import TEMPERATURE_QUANTUM_C
from gear_rotor_sim.solver.dt_rule import (
    light_mesh_modes,
    resonance_rate_hz,
    rule_locate_events,
)
from gear_rotor_sim.solver.newmark import (
    MAX_STEPS_PER_MESH,
    SPEED_QUANTUM_REL,
    NewmarkStepper,
    SolverState,
    mesh_frequencies_hz,
    mesh_frequency_hz,
    quantize_speed_rpm,
)
from gear_rotor_sim.system_data import AssembledSystem

#: Modal reduction (``modal_cutoff_hz="auto"``): the modes above the larger of this many output rates
#: and ``MODAL_CUTOFF_MESH_HARMONICS`` harmonics of the highest mesh frequency are carried by their
#: static response (residual flexibility); docs/solver.md, "Modal reduction".
MODAL_CUTOFF_OUTPUT_FACTOR = 2.0
MODAL_CUTOFF_MESH_HARMONICS = 4.0


def auto_modal_cutoff_hz(f_mesh_hz: float, output_rate_hz: float) -> float:
    """The ``modal_cutoff_hz="auto"`` cut-off: the larger of ``MODAL_CUTOFF_OUTPUT_FACTOR`` output
    rates and ``MODAL_CUTOFF_MESH_HARMONICS`` harmonics of the (highest) mesh frequency, Hz."""
    return max(MODAL_CUTOFF_OUTPUT_FACTOR * output_rate_hz, MODAL_CUTOFF_MESH_HARMONICS * f_mesh_hz)


#: The dt rule uses at least this speed (dt at standstill stays bounded).
DT_RULE_SPEED_FLOOR_RPM = 60.0
_MAX_CHUNK_STEPS = 65536
#: The dt rule decides on fixed instants of this spacing (whatever the chunking, so that the stream
#: stays independent of how ``advance`` is called): contact-loss setting on if the teeth separated in
#: the window just ended, off after a whole window in continuous contact, s.
DT_RULE_WINDOW_S = 0.1


class Stepping:
    """Raw integration steps of a :class:`~gear_rotor_sim.simulator.Simulator`: the dt rule (decimation
    factor ``k``, events located, exact map), chunks ending at the quanta and decision instants,
    and the stepper's operating point."""

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

    @property
    def _raw_time(self) -> float:
        return self._seg_t0 + self._raw * self.dt

    _pending_n: int = 0  # outputs completed by the last raw chunk beyond what its block took
    _replay: PeriodicReplay | None = None  # Simulator(periodic_replay=True): simulator_replay.py

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
        previous call), the steps with contact loss and those with back-side contact.

        With ``periodic_replay`` the steps come from the stored period while the stream repeats
        (simulator_replay.py; docs/solver.md, "Periodic replay at steady state")."""
        rep = self._replay
        if rep is not None and rep.active:
            served = rep.serve(self, n)
            if served is not None:
                self.locate_events = self._locate_now()
                j = np.arange(self._raw, self._raw + n + 2, dtype=float)
                t = self._seg_t0 + j * self.dt
                return self._emit_steps(n, served[0], served[1], t, None)
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
        key = None
        if rep is not None:
            key = rep.key_of(self)
            angle = rep.begin(self, key, angle)
        ch, _, _, fm, states, _ = self._stepper.run(t, angle, speed, self._state, excitation_rows=False)
        if self._mis.active:
            self._mis.push(angle[1:-1], fm)
        if rep is not None:
            rep.observe(self, key, self._raw, ch, states)
        return self._emit_steps(n, ch, states, t, speed)

    def _emit_steps(
        self, n: int, ch: np.ndarray, states: np.ndarray, t: np.ndarray, speed: np.ndarray | None
    ) -> tuple[int, int, int]:
        """Advance the raw index over ``n`` steps whose channel rows and contact states are ``ch``,
        ``states`` (times ``t`` with a neighbour on each side, input speed ``speed`` in rad/s, None
        when held at the target): the dt rule, the decimator's store and the chunk's counts."""
        self._raw += n
        self._update_dt_rule(states)
        self._update_misalignment()
        # the channels, speed and temperature go side by side straight into the decimator's store; a
        # set-point held over the whole chunk as one value (the decimator returns it exactly where it
        # fills an output's window, without filtering it)
        sp = self._speed
        held = speed is None or float(sp.value(t[1])) == sp.target
        speed_col = sp.target if held else speed[1:-1] * 60.0 / (2.0 * np.pi)
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

    def _maybe_regrid(self) -> None:
        if self._raw % self._k:
            return
        t = self._raw_time
        system = self._stepper.system
        s_now = float(self._speed.value(t))
        s_end = float(self._speed.value(t + 0.05))
        k_req = self._k_required(s_now, s_end, system)
        regrid = k_req > self._k or k_req <= 0.75 * self._k
        if self._replay is not None and (regrid or self._raw > 1 << 40):
            self._replay.stop(self)  # the raw grid changes: the state made current first
        if regrid:
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
