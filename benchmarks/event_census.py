"""What the integrated 20000 rpm step spends its events on, and the most a table-jump lever can give.

Issue 13 (docs/solver.md, "Performance"; docs/history/solver_sessions.md, "Session 21").

``census``: a ``Simulator`` (paper gearbox, 25 C, DTE only, default model and dt rule) after
``--settle`` s; over the next ``--seconds`` the kernel's calls are watched (the mesh phase of every
step from its angle, the contact state at every step end, the sub-steps): steps per mesh period,
table jumps per period by jump phase, contact changes, steps holding an event, sub-steps, the phase
window of free flight and how many jumps fall in it (a jump where the teeth are apart on both sides
changes no force: such a step would need no sub-steps).

``ceiling PATH``: the chunk captured by ``profile_event_steps.py capture`` run by the kernel three
ways, alternated, CPU medians per step: events located (the default), the steps whose only events are
table jumps taken whole (``average_jumps``: the cost of a lever that made every table-jump step a
regular step, plus the averaging), and nothing located; then two ``Simulator`` objects, the default and
``average_table_jumps=True``, alternated in 0.1 s chunks (CPU). A lever on the table jumps alone
(their instants known per period, their sub-step maps precomputed) still integrates the jump steps
as sub-steps, so it cannot beat the second figure.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/event_census.py census [--rpm 20000]``;
``... ceiling /tmp/c20k.pkl`` (capture first).
"""

from __future__ import annotations

import argparse
import copy
import pickle
import time

import numpy as np


def _watch(rpm: float, settle_s: float, seconds: float) -> tuple[object, list[tuple]]:
    """A DTE-only Simulator advanced ``settle_s``, then ``seconds`` with its stepper's calls recorded
    as (angles, contact state before, contact states, sub-steps)."""
    from gear_rotor_sim.examples import paper_gearbox
    from gear_rotor_sim.simulator import Simulator

    sim = Simulator(paper_gearbox(), rpm, 25.0, 20000.0, channels=["dte"])
    sim.advance(settle_s)
    stepper = sim._stepper
    orig = stepper.run
    calls: list[tuple] = []

    def run(t: np.ndarray, angle: np.ndarray, speed: np.ndarray, st: object, *a: object) -> tuple:
        s0 = stepper.contact.copy()
        n0 = stepper.n_substeps
        r = orig(t, angle, speed, st, *a)
        calls.append((angle.copy(), s0, r[4].copy(), stepper.n_substeps - n0))
        return r

    stepper.run = run
    try:
        sim.advance(seconds)
    finally:
        del stepper.run
    return stepper, calls


def census(rpm: float, settle_s: float, seconds: float) -> dict:
    """Events of the first mesh per mesh period (see the module docstring); printed and returned."""
    stepper, calls = _watch(rpm, settle_s, seconds)
    gm = stepper.gear
    jp = np.asarray(gm.tables[5][0, : int(gm.tables[8][0])], float)
    teeth = stepper.system.meshes[0].pinion_teeth
    ratio = abs(float(stepper.system.shaft_speed_ratios[stepper.system.meshes[0].pinion_shaft]))
    cyc = teeth * ratio / (2.0 * np.pi)
    n = cc = ev = sub = 0
    per_jump = np.zeros(jp.size, int)
    dead_jump = np.zeros(jp.size, int)
    phases, states = [], []
    for angle, s0, st, nsub in calls:
        m = angle.size - 2
        ph = angle[: m + 1] * cyc  # mesh cycles at the step starts and ends
        s = np.concatenate([[s0[0]], st[:, 0]])
        has = np.zeros(m, bool)
        for q, p in enumerate(jp):
            inside = (np.floor(ph[1:] - p) - np.floor(ph[:-1] - p)) > 0
            per_jump[q] += int(inside.sum())
            dead_jump[q] += int((inside & (s[:-1] == 0) & (s[1:] == 0)).sum())
            has |= inside
        change = s[:-1] != s[1:]
        n += m
        cc += int(change.sum())
        ev += int((has | change).sum())
        sub += int(nsub)
        phases.append(ph[1:] % 1.0)
        states.append(st[:, 0])
    periods = seconds * rpm / 60.0 * teeth * ratio
    ph_all = np.concatenate(phases)
    free = np.concatenate(states) == 0
    res = {
        "rpm": rpm,
        "steps_per_mesh_period": n / periods,
        "jump_phases": jp.tolist(),
        "jumps_per_period": (per_jump / periods).tolist(),
        "jumps_with_both_ends_in_free_flight": dead_jump.tolist(),
        "contact_changes_per_period": cc / periods,
        "event_steps_per_period": ev / periods,
        "substeps_per_period": sub / periods,
        "substeps_per_event_step": sub / ev if ev else 0.0,
        "free_flight_fraction": float(free.mean()),
        "free_flight_phase": [float(ph_all[free].min()), float(ph_all[free].max())] if free.any() else None,
    }
    print(
        f"{rpm:.0f} rpm, {seconds:g} s after {settle_s:g} s: {res['steps_per_mesh_period']:.2f} steps "
        f"per mesh period; per period {res['event_steps_per_period']:.2f} steps with an event "
        f"({100 * ev / n:.1f} % of the steps), {res['substeps_per_period']:.2f} sub-steps "
        f"({res['substeps_per_event_step']:.2f} per event step), {res['contact_changes_per_period']:.2f} "
        f"contact changes; free flight {100 * res['free_flight_fraction']:.1f} % of the steps"
    )
    if free.any():
        print(
            f"  free flight at mesh phase {res['free_flight_phase'][0]:.3f}-{res['free_flight_phase'][1]:.3f}"
        )
    for q, p in enumerate(jp):
        print(
            f"  table jump at phase {p:.4f}: {per_jump[q] / periods:.3f} per period, {dead_jump[q]} of "
            f"{per_jump[q]} with the teeth apart at both ends of the step"
        )
    return res


def ceiling(path: str, reps: int, sim_chunks: int) -> dict:
    """Kernel per-step CPU: located, table-jump steps taken whole, not located (alternated), and the
    Simulator default against ``average_table_jumps=True`` (alternated 0.1 s chunks)."""
    from gear_rotor_sim.examples import paper_gearbox
    from gear_rotor_sim.simulator import Simulator
    from gear_rotor_sim.solver import gear_kernel

    with open(path, "rb") as fh:
        a0 = list(pickle.load(fh))
    n = a0[4][0].shape[0] - 1
    ways = {"located": (True, False), "jump steps whole": (True, True), "not located": (False, False)}
    cpu: dict[str, list[float]] = {k: [] for k in ways}
    nsub: dict[str, int] = {}
    for _ in range(reps + 1):
        for name, (loc, avg) in ways.items():
            b = copy.deepcopy(a0)
            b[8] = loc
            b[14] = avg  # run_chunk_gear's average_jumps (the captured call passes all 15 arguments)
            c0 = time.process_time()
            out = gear_kernel.run_chunk_gear(*b)
            cpu[name].append(time.process_time() - c0)
            nsub[name] = int(out[3])
    res: dict = {"kernel_us_per_step": {}, "substeps_per_step": {}}
    for name in ways:
        us = 1e6 * float(np.median(cpu[name][1:])) / n
        res["kernel_us_per_step"][name] = us
        res["substeps_per_step"][name] = nsub[name] / n
    k = res["kernel_us_per_step"]
    ns = res["substeps_per_step"]
    print(
        f"kernel on {path} ({n} steps), CPU median of {reps}: located {k['located']:.3f}, jump steps whole "
        f"{k['jump steps whole']:.3f}, not located {k['not located']:.3f} us per step (sub-steps per step "
        f"{ns['located']:.3f} / {ns['jump steps whole']:.3f} / 0); "
        f"located / jump steps whole = {k['located'] / k['jump steps whole']:.3f}"
    )
    sims = {
        "default": Simulator(paper_gearbox(), 20000.0, 25.0, 20000.0, channels=["dte"]),
        "average_table_jumps": Simulator(
            paper_gearbox(), 20000.0, 25.0, 20000.0, channels=["dte"], average_table_jumps=True
        ),
    }
    for s in sims.values():
        s.advance(0.3)
    t_sim: dict[str, list[float]] = {k: [] for k in sims}
    for _ in range(sim_chunks):
        for name, s in sims.items():
            c0 = time.process_time()
            s.advance(0.1)
            t_sim[name].append(time.process_time() - c0)
    rtf = {name: 0.1 / float(np.median(v)) for name, v in t_sim.items()}
    res["simulator_cpu_rtf"] = rtf
    print(
        f"Simulator at 20000 rpm, DTE only, 0.1 s chunks alternated x{sim_chunks}: CPU RTF default "
        f"{rtf['default']:.2f}, average_table_jumps {rtf['average_table_jumps']:.2f} "
        f"(x{rtf['average_table_jumps'] / rtf['default']:.3f})"
    )
    return res


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("census")
    c.add_argument("--rpm", type=float, default=20000.0)
    c.add_argument("--settle", type=float, default=0.3)
    c.add_argument("--seconds", type=float, default=0.1)
    g = sub.add_parser("ceiling")
    g.add_argument("path")
    g.add_argument("--reps", type=int, default=9)
    g.add_argument("--chunks", type=int, default=9)
    a = ap.parse_args()
    if a.cmd == "census":
        census(a.rpm, a.settle, a.seconds)
    else:
        ceiling(a.path, a.reps, a.chunks)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
