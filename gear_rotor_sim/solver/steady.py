"""Constant-speed runs for the analyses: ``simulate_steady`` (Poincare-ready dt, the default dt rule)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from gear_rotor_sim.solver.dt_rule import (
    CONTACT_LOSS_RATE_HZ,
    DEFAULT_STEPS_PER_MESH,
    check_contact_loss_rate,
    light_mesh_modes,
    resonance_rate_hz,
    rule_locate_events,
    rule_steps_per_mesh,
)
from gear_rotor_sim.solver.newmark import (
    NewmarkStepper,
    SolverState,
    check_steps_per_mesh,
    mesh_frequencies_hz,
    mesh_frequency_hz,
    parse_channels,
    quantize_speed_rpm,
    static_equilibrium,
)
from gear_rotor_sim.system_data import AssembledSystem

#: Mesh periods of the first chunk (doubling after each) until the teeth first separate.
RULE_PROBE_PERIODS = 64


@dataclass
class SteadyResult:
    """Raw samples of a constant-speed run: every step or once per mesh period."""

    t: np.ndarray
    channels: tuple[str, ...]
    data: np.ndarray  # (n, nch)
    dt: float
    mesh_period: float
    speed_rpm: float
    contact_loss_fraction: float
    back_contact_fraction: float
    steps_per_mesh: int = 0  # of the recorded part (the dt rule may raise it during the run)
    located: bool = False

    def channel(self, name: str) -> np.ndarray:
        return self.data[:, self.channels.index(name)]


def simulate_steady(
    system: AssembledSystem,
    speed_rpm: float,
    n_transient_periods: int,
    n_periods: int,
    steps_per_mesh: int = DEFAULT_STEPS_PER_MESH,
    channels: Sequence[str] = ("dte",),
    initial_state: SolverState | None = None,
    sample: str = "mesh",
    effects: Sequence[object] = (),
    chunk_steps: int = 65536,
    locate_events: bool | None = None,
    contact_loss_rate_hz: float | None = CONTACT_LOSS_RATE_HZ,
    modal_cutoff_hz: float | None = None,
    exact_modal_map: bool | None = False,
) -> tuple[SteadyResult, SolverState]:
    """Constant-speed run with ``dt = T_mesh / N`` exactly (Poincare-ready), N by the dt rule.

    Parameters
    ----------
    system : AssembledSystem
        Must have at least one mesh (the mesh period sets dt).
    speed_rpm : float
        Input-shaft speed, > 0.
    n_transient_periods, n_periods : int
        Mesh periods discarded, then recorded.
    steps_per_mesh : int
        Steps per mesh period (8..4096) while the teeth stay in contact (the minimum otherwise).
    channels : sequence of str
    initial_state : SolverState, optional
        Continue from a previous run (e.g. the previous speed of a bifurcation sweep); default the
        static equilibrium.
    sample : {"mesh", "step"}
        ``"mesh"``: one sample per mesh period, at the end of each period (phase 0 of the first
        mesh when starting from phase 0); ``"step"``: every step.
    locate_events : bool, optional
        Split steps at the mesh events inside them (see :class:`NewmarkStepper`); default: the dt
        rule (:func:`rule_locate_events`).
    contact_loss_rate_hz : float or None
        The dt rule (:func:`rule_steps_per_mesh`): once the teeth separate, the run switches to at
        least this many steps per second with events located, for the rest of the call; the recording
        restarts if it had begun, so the recorded part has one dt. None: ``steps_per_mesh`` throughout.
    modal_cutoff_hz : float or None
        Modal reduction with static correction above this frequency (Hz; docs/solver.md, "Modal
        reduction"); None: the full model.
    exact_modal_map : bool or None
        The exact modal propagator instead of Newmark's map (``newmark.step_map(exact=True)``; it has
        no period error, so the dt rule's resonance part is not applied). None: only where that
        resonance part would raise the rate (as the Simulator's default). Default False: Newmark.

    Returns
    -------
    (SteadyResult, SolverState)
    """
    if not np.isfinite(speed_rpm) or speed_rpm <= 0:
        raise ValueError(f"speed_rpm: {speed_rpm!r} must be finite and > 0 for a steady run")
    check_steps_per_mesh(steps_per_mesh)
    if sample not in ("mesh", "step"):
        raise ValueError(f"sample: {sample!r} must be 'mesh' or 'step'")
    f_mesh = mesh_frequency_hz(system, speed_rpm)
    if f_mesh <= 0:
        raise ValueError("system: a steady run needs at least one mesh")
    specs = parse_channels(system, list(channels))
    check_contact_loss_rate(contact_loss_rate_hz)
    adaptive = contact_loss_rate_hz is not None

    def located(n: int, contact_loss: bool) -> bool:
        return rule_locate_events(n, contact_loss) if locate_events is None else bool(locate_events)

    stepper = NewmarkStepper(system, specs, effects)
    stepper.modal_cutoff_hz = None if modal_cutoff_hz is None else float(modal_cutoff_hz)
    st = static_equilibrium(system, effects) if initial_state is None else initial_state.copy()
    period = 1.0 / f_mesh
    omega = speed_rpm * 2.0 * np.pi / 60.0
    omega_q = quantize_speed_rpm(speed_rpm) * 2.0 * np.pi / 60.0
    res_rate = 0.0
    if adaptive:  # a light mode near a low harmonic of any mesh
        light = light_mesh_modes(stepper.lin, stepper.basis(omega_q))
        res_rate = max(resonance_rate_hz(f, light) for f in mesh_frequencies_hz(system, speed_rpm))
    if exact_modal_map is None:  # the exact map instead of resolving a light mode near a mesh line
        exact_modal_map = res_rate > 0.0 and rule_steps_per_mesh(
            f_mesh, False, int(steps_per_mesh), contact_loss_rate_hz, res_rate
        ) > rule_steps_per_mesh(f_mesh, False, int(steps_per_mesh), contact_loss_rate_hz, 0.0)
    if exact_modal_map:
        res_rate = 0.0
    stepper.exact_map = bool(exact_modal_map)
    spm = rule_steps_per_mesh(f_mesh, False, int(steps_per_mesh), contact_loss_rate_hz, res_rate)
    stepper.locate_events = located(spm, False)
    dt = period / spm
    stepper.set_operating_point(omega_q, dt, st)
    left_tr, left_rec = int(n_transient_periods), int(n_periods)
    outs: list[np.ndarray] = []
    times: list[np.ndarray] = []
    n_loss = n_back = n_rec = 0
    switched = False
    seg_t0, seg_a0, seg_j = st.time, st.angle, 0  # segment of constant dt: exact grid t0 + j dt
    probe = RULE_PROBE_PERIODS
    while left_tr + left_rec > 0:
        per_chunk = max(1, chunk_steps // spm)
        if adaptive and not switched:  # short chunks (doubling) until the teeth separate, if ever
            per_chunk = min(per_chunk, probe)
            probe *= 2
        m = min(per_chunk, left_tr + left_rec)
        m_tr = min(m, left_tr)
        nstep = m * spm
        j = np.arange(seg_j, seg_j + nstep + 2, dtype=float)  # carried step, new steps, one after
        t = seg_t0 + j * dt
        angle = seg_a0 + omega * j * dt
        speed = np.full(j.size, omega)
        ch, _, _, _, states, _ = stepper.run(t, angle, speed, st, excitation_rows=False)
        seg_j += nstep
        idx = np.arange(1, nstep + 1)
        rec = idx > m_tr * spm
        lost = bool(states.shape[1]) and bool(states.shape[0]) and int(states.min()) < 2
        if adaptive and not switched and lost:
            switched = True
            spm = rule_steps_per_mesh(f_mesh, True, int(steps_per_mesh), contact_loss_rate_hz, res_rate)
            stepper.locate_events = located(spm, True)
            dt = period / spm
            stepper.set_operating_point(omega_q, dt, st)
            seg_t0, seg_a0, seg_j = st.time, st.angle, 0
            left_tr = max(left_tr - m, 0)
            if left_tr == 0:  # the recording had begun at the old dt: record n_periods from here
                left_rec = int(n_periods)
                outs, times = [], []
                n_loss = n_back = n_rec = 0
            continue
        left_tr -= m_tr
        left_rec -= m - m_tr
        sel = rec.copy()
        if sample == "mesh":
            sel &= (idx % spm) == 0
        if np.any(sel):
            outs.append(ch[sel])
            times.append(t[1:-1][sel])
        if states.shape[1]:
            s0 = states[rec]  # a step counts when any mesh is out of drive-flank contact
            n_loss += int(np.count_nonzero((s0 == 0).any(axis=1)))
            n_back += int(np.count_nonzero((s0 < 0).any(axis=1)))
        n_rec += int(np.count_nonzero(rec))
    data = np.concatenate(outs) if outs else np.zeros((0, len(specs)))
    tt = np.concatenate(times) if times else np.zeros(0)
    res = SteadyResult(
        tt,
        tuple(channels),
        data,
        dt,
        period,
        float(speed_rpm),
        n_loss / max(n_rec, 1),
        n_back / max(n_rec, 1),
        spm,
        stepper.locate_events,
    )
    return res, st
