"""Periodic replay of a settled stream: ``Simulator(periodic_replay=True)`` (docs/solver.md, "Periodic
replay at steady state").

At a constant set point the forcing of Eq 39 (mesh stiffness, friction, static transmission error)
is periodic in the input-shaft angle: every mesh's phase returns after a whole number of its mesh
periods; an effect locked to a shaft's angle at a constant severity (a damaged tooth, an eccentric
wheel, an unbalance, a shaft misalignment; simulator_replay_effects.py) repeats after whole
revolutions of its shaft, so the forcing period holds those too. Once the solver's state at the end
of an integrated chunk equals its state at the end of an earlier chunk a whole number of forcing
periods before (each part of the state within ``REPLAY_TOLERANCE`` of its own norm, the contact
states equal), every later step repeats the steps in between: their channel rows (what the kernel
gave, before the decimation) are fed to the same decimator instead of integrating, until the set
point, the effects or the dt rule's setting changes. The state at the current instant is then
restored from the stored one (the stepper's modal state included) and integrated forward over the
part of the period already served, so integration resumes exactly as it would from that state.
Chaotic and quasi-periodic motion never matches and is integrated as without the option (the chunks
are not changed: only the ends the caller and the dt rule make are compared). The angles are taken
modulo the forcing period (:meth:`PeriodicReplay.begin`), which moves the stream by the integration's
sensitivity to round-off. Effects are admitted only under ``faults`` (``Simulator(periodic_replay=
"faults")``): the node's faulted stream is held to the plain integration, which the calibration
simulates, and that is not periodic to round-off where a step lands exactly on a mesh-table jump
(docs/solver.md, "Periodic replay at steady state", "Faults").

:class:`PeriodicReplay` holds the history and the stored period; :class:`~gear_rotor_sim.simulator.
Simulator` calls it from ``Stepping._run_steps`` (part of its bases, holding no state of its own).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from gear_rotor_sim.simulator_replay_effects import periodic_effect_shafts

if TYPE_CHECKING:
    from gear_rotor_sim.simulator import Simulator
    from gear_rotor_sim.solver.newmark import NewmarkStepper
    from gear_rotor_sim.solver.state import SolverState
    from gear_rotor_sim.system_data import AssembledSystem

#: Relative tolerance of the state match: each part of the state (modal amplitudes, carried column
#: amplitudes, predictions, mesh deflection, rate and force) within this fraction of its own norm.
REPLAY_TOLERANCE = 1e-10
#: Longest lag compared (and stream kept for it), s of simulated time.
REPLAY_MAX_LAG_S = 0.5
#: The forcing period may be at most this many output samples (longer: no replay).
REPLAY_MAX_FORCING_OUTPUTS = 100_000
#: A mesh phase that drifts by at most this many cycles per forcing period counts as periodic.
_PHASE_TOL_CYCLES = 1e-9

#: The stepper's carried arrays (besides the SolverState) that the next chunk reads.
_STEPPER_ARRAYS = ("zr", "zi", "beta_prev", "beta_act", "ypred", "contact")


def forcing_period_outputs(
    system: AssembledSystem, speed_rpm: float, output_rate_hz: float, shafts: tuple[int, ...] = ()
) -> int | None:
    """Smallest number of output samples after which every mesh's phase has advanced by whole mesh
    cycles at a constant ``speed_rpm`` (the period of the healthy forcing on the output grid) and every
    shaft of ``shafts`` by whole revolutions (the effects locked to those shafts' angles,
    simulator_replay_effects.py).

    Returns None without a mesh, at standstill, or when no such number up to
    ``REPLAY_MAX_FORCING_OUTPUTS`` exists (within ``_PHASE_TOL_CYCLES`` per period).
    """
    if not system.meshes or not (speed_rpm > 0 and output_rate_hz > 0):
        return None
    ratios = np.asarray(system.shaft_speed_ratios, dtype=float)
    cyc = np.array(
        [m.pinion_teeth * abs(float(ratios[m.pinion_shaft])) for m in system.meshes]
        + [abs(float(ratios[s])) for s in shafts]
    )
    per_out = cyc * (speed_rpm / 60.0) / output_rate_hz  # mesh cycles per output sample
    g = np.arange(1, REPLAY_MAX_FORCING_OUTPUTS + 1, dtype=float)[:, None]
    x = g * per_out[None, :]
    ok = np.all(np.abs(x - np.rint(x)) <= _PHASE_TOL_CYCLES, axis=1)
    hit = np.flatnonzero(ok)
    return int(hit[0]) + 1 if hit.size else None


def _snapshot(stepper: NewmarkStepper, st: SolverState) -> dict[str, Any]:
    snap: dict[str, Any] = {"state": st.copy()}
    for name in _STEPPER_ARRAYS:
        a = getattr(stepper, name, None)
        if a is not None:
            snap[name] = np.array(a, copy=True)
    return snap


def _restore(stepper: NewmarkStepper, snap: dict[str, Any]) -> SolverState:
    """Put the stepper's carried arrays back to ``snap`` (in place, keeping their alignment) and return
    a copy of its SolverState."""
    for name in _STEPPER_ARRAYS:
        if name in snap:
            a = getattr(stepper, name)
            if a.shape == snap[name].shape:
                np.copyto(a, snap[name])
            else:  # not expected (same stepper and map): a fresh array
                setattr(stepper, name, snap[name].copy())
    return snap["state"].copy()


def _parts(snap: dict[str, Any]) -> list[np.ndarray]:
    st = snap["state"]
    z = np.concatenate([snap.get("zr", np.zeros(0)), snap.get("zi", np.zeros(0))])
    parts = [z, st.delta, st.delta_dot, st.force, st.ampl]
    parts += [np.asarray(snap[n], float) for n in ("beta_prev", "beta_act", "ypred") if n in snap]
    return parts


def state_mismatch(a: dict[str, Any], b: dict[str, Any]) -> float:
    """Largest relative difference between two snapshots, part by part (each against its own norm);
    ``inf`` when the contact states differ."""
    if not np.array_equal(a["state"].contact, b["state"].contact):
        return float("inf")
    if "contact" in a and not np.array_equal(a["contact"], b["contact"]):
        return float("inf")
    worst = 0.0
    for pa, pb in zip(_parts(a), _parts(b), strict=True):
        if pa.size == 0:
            continue
        scale = max(float(np.linalg.norm(pa)), float(np.linalg.norm(pb)))
        diff = float(np.linalg.norm(pa - pb))
        if diff == 0.0:
            continue
        worst = max(worst, diff / scale if scale > 0 else float("inf"))
    return worst


class PeriodicReplay:
    """History of a Simulator's chunk ends at a constant set point and, once two of them a whole
    number of forcing periods apart match, the stored period (see the module docstring).

    Attributes (read by benchmarks and tests)
    ----------
    active : bool
        The stream is served from the stored period.
    period_steps : int
        Raw steps of the stored period (0 before it engaged).
    engaged_at_s : float or None
        Integration time at which it last engaged; ``constant_since_s`` when the set point became
        eligible (the history's start).
    faults : bool
        Whether effects locked to a shaft's angle are admitted (``Simulator(periodic_replay="faults")``);
        by default a set point with effects is integrated.
    mismatch : float
        The state mismatch of the two chunk ends that engaged it.
    """

    def __init__(self, tolerance: float = REPLAY_TOLERANCE, faults: bool = False) -> None:
        self.tolerance = float(tolerance)
        self.faults = bool(faults)
        self.active = False
        self.period_steps = 0
        self.engaged_at_s: float | None = None
        self.constant_since_s: float | None = None
        self.mismatch = float("inf")
        self.n_engaged = 0
        #: False: never serve (the angles stay periodic): the integrated reference of the replay
        self.serving = True
        self._period_at: tuple = (None,) * 5  # (system, speed, rate, effect shafts, forcing period)
        self._reset()

    def _reset(self) -> None:
        self._key: tuple | None = None
        self._effects: Any = None  # the effects the key names (held: their ids stay theirs)
        self._stepper: Any = None
        self._g_raw = 0
        self._max_raw = 0
        self._ends: list[tuple[int, dict[str, Any]]] = []  # (raw index, snapshot) of chunk ends
        self._chunks: list[tuple[int, np.ndarray, np.ndarray]] = []  # (first raw step, rows, states)
        self._rows = np.zeros((0, 0))
        self._states = np.zeros((0, 0), dtype=np.int8)
        self._base = 0  # raw index of the stored state (a period boundary)
        self._snap: dict[str, Any] = {}
        self._synced = -1  # raw index at which the Simulator's state was last made current
        self._anchor = (0, 0.0)  # (raw index, angle) the periodic angles count from

    # ------------------------------------------------------------------------------------ queries
    def key_of(self, sim: Simulator) -> tuple | None:
        """What must stay the same for the stream to repeat (None: not eligible now).

        Eligible: speed and temperature at their targets (no ramp running), no effects or, under
        ``faults``, only effects locked to shaft angles at a constant severity
        (:func:`periodic_effect_shafts`: a damaged tooth, an eccentric wheel, a mass unbalance, a shaft
        misalignment, past their onset and growth; not the streamed gear misalignment), a forcing
        period on the output grid (whole mesh cycles and whole revolutions of those effects' shafts).
        The key holds the forcing period, the dt rule's setting (decimation factor, events located,
        exact map), the quantised speed, the segment of the raw grid, the effects' shafts and the
        effects themselves (by identity: a new list, even an equal one, starts a new history).
        """
        if sim._mis.active:
            return None
        t = sim._raw_time
        if float(sim._speed.value(t)) != sim._speed.target or float(sim._temp.value(t)) != sim._temp.target:
            return None
        system = sim._stepper.system
        shafts: tuple[int, ...] | None = ()
        if sim._run_effects:
            if not self.faults:
                return None
            # the chunk's effect inputs start one step before its first new step
            shafts = periodic_effect_shafts(sim._run_effects, system, t - sim.dt)
            if shafts is None:
                return None
        at = (system, sim._speed.target, sim.output_rate_hz, shafts)
        if self._period_at[0] is not system or self._period_at[1:4] != at[1:]:
            self._period_at = (*at, forcing_period_outputs(*at))
        g = self._period_at[4]
        if g is None:
            return None
        return (
            g,
            sim._k,
            bool(sim._locate_now()),
            bool(sim._exact),
            sim._omega_q,
            sim._seg_t0,
            sim._seg_out0,
            sim._sys_key,
            sim._speed.target,
            sim._temp.target,
            shafts,
            tuple(id(e) for e in sim._run_effects),
        )

    # ------------------------------------------------------------------------------ integration
    def begin(self, sim: Simulator, key: tuple | None, angle: np.ndarray) -> np.ndarray:
        """Before a chunk is integrated (raw steps ``sim._raw + 1 ..``; ``angle`` the input-shaft angles
        of ``_run_steps``, a neighbour on each side): start a new history when the key changed, and
        return the angles the stepper gets.

        At an eligible set point the angle is taken from the raw index modulo the forcing period,
        ``angle_a + omega dt ((j - j_a) mod P)`` (``j_a`` the first step of the history), so that the
        mesh phases, and every decision the kernel takes on them (a table jump at a step instant or
        just after it), repeat bit for bit from one forcing period to the next. Without it the phase's
        round-off grows with the angle and flips such decisions now and then: at 20000 rpm a kick of
        1e-4 to 2e-3 of the state every few forcing periods (docs/solver.md, "Periodic replay at
        steady state"), and the state never repeats to 1e-10. With faults the same flips move the
        plain integration even at 3000 rpm (a step of the step grid exactly on the mesh table's jump at
        phase 0 every 29 mesh periods: 1e-2 to 0.1 of the peak, or another orbit;
        benchmarks/replay_switches.py), which is why faults are admitted only under ``faults``.
        """
        if key is None or key != self._key or sim._stepper is not self._stepper:
            self._reset()
            if key is None:
                self.constant_since_s = None
                return angle
            self._key = key
            self._effects = sim._run_effects
            self._stepper = sim._stepper
            self._g_raw = key[0] * sim._k
            self._max_raw = int(REPLAY_MAX_LAG_S * sim.output_rate_hz) * sim._k
            self.constant_since_s = sim._raw_time
            self._anchor = (sim._raw, float(angle[0]))
        return self.periodic_angle(sim, sim._raw, angle.size)

    def periodic_angle(self, sim: Simulator, raw0: int, n: int) -> np.ndarray:
        """Angles of raw indices ``raw0 .. raw0 + n - 1`` from their index modulo the forcing period."""
        j0, a0 = self._anchor
        m = (np.arange(raw0, raw0 + n, dtype=np.int64) - j0) % self._g_raw
        return a0 + (sim._speed.target * (2.0 * np.pi / 60.0) * sim.dt) * m

    def observe(
        self, sim: Simulator, key: tuple | None, raw0: int, ch: np.ndarray, states: np.ndarray
    ) -> None:
        """Record an integrated chunk (raw steps ``raw0 + 1 ..``, the Simulator's state at its end) and
        engage when its end state matches an earlier end a whole number of forcing periods before."""
        if key is None or not self.serving:  # serving off: the periodic angles only (a reference)
            return
        end = raw0 + ch.shape[0]
        self._chunks.append((raw0 + 1, ch, states.copy()))
        snap = _snapshot(sim._stepper, sim._state)
        for m, old in reversed(self._ends):  # the shortest lag first
            lag = end - m
            if lag % self._g_raw or lag > self._max_raw:
                continue
            mis = state_mismatch(snap, old)
            if mis <= self.tolerance:
                self._engage(sim, m, end, snap, mis)
                return
        self._ends.append((end, snap))
        lo = end - self._max_raw
        self._ends = [(m, s) for m, s in self._ends if m >= lo]
        while self._chunks and self._chunks[0][0] + self._chunks[0][1].shape[0] - 1 <= lo:
            self._chunks.pop(0)

    def _engage(self, sim: Simulator, m: int, end: int, snap: dict[str, Any], mis: float) -> None:
        keep = [c for c in self._chunks if c[0] > m]
        rows = np.concatenate([c[1] for c in keep], axis=0)
        states = np.concatenate([c[2] for c in keep], axis=0)
        assert rows.shape[0] == end - m and keep[0][0] == m + 1
        self._rows, self._states = rows, states
        self._ends, self._chunks = [], []
        self._base = end
        self._snap = snap
        self._synced = end
        self.period_steps = end - m
        self.mismatch = mis
        self.engaged_at_s = sim._seg_t0 + end * sim.dt
        self.active = True
        self.n_engaged += 1

    # ----------------------------------------------------------------------------------- replay
    def serve(self, sim: Simulator, n: int) -> tuple[np.ndarray, np.ndarray] | None:
        """The channel rows and contact states of the next ``n`` raw steps from the stored period, or
        None (after making the Simulator's state current) when the stream no longer repeats."""
        if not self.active:
            return None
        if self.key_of(sim) != self._key or sim._stepper is not self._stepper:
            self.stop(sim)
            return None
        L = self.period_steps
        p0 = (sim._raw - self._base) % L
        idx = (p0 + np.arange(n)) % L
        return self._rows[idx], self._states[idx]

    def sync(self, sim: Simulator) -> None:
        """Make the Simulator's state (and its stepper's carried arrays) those integration would hold at
        the current raw index: the stored state at the period boundary, integrated over the steps of
        the period already served."""
        if not self.active or self._synced == sim._raw:
            return
        stepper = self._stepper
        assert stepper is sim._stepper, "replay state restored into another stepper"
        st = _restore(stepper, self._snap)
        off = (sim._raw - self._base) % self.period_steps
        raw0 = sim._raw - off
        j = np.arange(raw0, sim._raw + 2, dtype=float)
        t = sim._seg_t0 + j * sim.dt
        angle = self.periodic_angle(sim, raw0, j.size)
        if off:
            speed = sim._speed.value(t) * (2.0 * np.pi / 60.0)
            stepper.locate_events = self._key[2]
            stepper.run(t, angle, speed, st, excitation_rows=False)
        else:  # the boundary itself: the stored state, at this instant's angle and time
            st.angle = float(angle[0])
            st.time = float(t[0])
        sim._state = st
        self._synced = sim._raw

    def stop(self, sim: Simulator) -> None:
        """Leave the replay with the Simulator's state current; the history starts again."""
        if self.active:
            self.sync(sim)
        self.active = False
        self._reset()
