"""The node's fault switches offline, with and without the periodic replay, against the plain integration.

Issue 13 (docs/solver.md, "Periodic replay at steady state"; docs/history/solver_sessions.md,
"Session 22"). ``test/test_faults_node.py::test_node_signal_equals_library_effects_in_the_simulator``
compares the node (``periodic_replay`` on, faults given as ``timed_effects``, 0.1 s chunks through
``advance_deferred``, each new fault list applied by ``set_effects`` at a chunk start) with a
``Simulator`` *without* the option, given the library effects, at 1e-9 of each channel's peak.
:func:`node_like_run` does the same offline, so that a change of the replay can be checked against
that bound in seconds, without ROS.

``switches``: a plan of fault lists, each held for a number of 0.1 s chunks (``NAME:CHUNKS,...``, names
from :data:`FAULTS`, ``healthy`` for none; ``--node-sequence N``: the node test's order, N chunks each);
prints per chunk the largest difference over the channels
(of each channel's peak over the run), whether the replay serves, and how often it engaged.

``jump``: where two plain integrations whose start angles differ by ``--perturb`` rad (round-off)
first part: the step, its mesh phase (cycles) and both mesh-force rows, and the difference per 0.1 s
chunk (of the peak). At 3000 rpm with an eccentric gear the 29-tooth pinion's step grid meets the
mesh phase 0 (a table jump) exactly on a step instant every 29 mesh periods, and the angle's round-off
decides on which side of the jump that step lies.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/replay_switches.py switches
[--plan mass_unbalance:9,shaft_misalignment:9] [--rpm 3000] [--faults] [--node-sequence N] [--plain-angles]``;
``... jump
[--fault gear_eccentricity]``.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

import numpy as np

#: Fault lists by name (the node test's requests of these types; ``healthy``: none).
FAULTS: dict[str, list[dict[str, Any]]] = {
    "healthy": [],
    "tooth_damage": [{"type": "tooth_damage", "wheel": "pinion", "tooth": 3, "depth": 0.3}],
    "gear_tooth": [{"type": "tooth_damage", "wheel": "gear", "tooth": 5, "depth": 0.3}],
    "pinion_eccentricity": [{"type": "pinion_eccentricity", "eccentricity_m": 2.0e-5}],
    "gear_eccentricity": [{"type": "gear_eccentricity", "eccentricity_m": 3.0e-5, "phase_rad": 0.5}],
    "mass_unbalance": [{"type": "mass_unbalance", "node": 5, "unbalance_kg_m": 2.0e-4}],
    "shaft_misalignment": [{"type": "shaft_misalignment", "node": 1, "offset_m": 1.0e-4}],
    "outer_race_defect": [{"type": "outer_race_defect", "bearing": 2, "force_n": 800.0}],
    "tooth_wear": [{"type": "tooth_wear", "wear_depth_m": 1.0e-5}],
    "inner_race_defect": [{"type": "inner_race_defect", "bearing": 3, "force_n": 800.0}],
    "ball_defect": [{"type": "ball_defect", "bearing": 1, "force_n": 800.0}],
    "gear_misalignment": [
        {"type": "gear_misalignment", "member": "pinion", "angle_rad": 1.0e-3, "phase_rad": 0.3}
    ],
    "mesh_stiffness_damping": [
        {"type": "mesh_stiffness_damping", "stiffness_scale": 1.3, "damping_scale": 0.7}
    ],
    "bearing_stiffness_damping": [
        {"type": "bearing_stiffness_damping", "stiffness_scale": 0.6, "damping_scale": 1.5}
    ],
}
#: The order of test_faults_node.py's requests (its first fault, the gear tooth, then one of each type).
NODE_SEQUENCE = [
    "gear_tooth", "pinion_eccentricity", "mass_unbalance", "tooth_wear", "outer_race_defect",
    "gear_eccentricity", "shaft_misalignment", "inner_race_defect", "ball_defect", "gear_misalignment",
    "mesh_stiffness_damping", "bearing_stiffness_damping",
]  # fmt: skip
#: The node's channels of /gear_rotor/dte and two bearings of /gear_rotor/bearing_forces.
CHANNELS = ["dte", "mesh_force", "bearing1_fx", "bearing1_fy", "bearing2_fx", "bearing2_fy"]
CHUNK_S = 0.1


def library_effects(specs: Sequence[dict[str, Any]]) -> list[Any]:
    """The library effects of ``specs`` as the node test's reference builds them: the effect itself for a
    fault without onset or growth, ``timed_effects`` otherwise."""
    from gear_rotor_sim.faults.library import EFFECT_TYPES
    from gear_rotor_sim.faults.spec import parse_faults
    from gear_rotor_sim.faults.timed import timed_effects

    faults = parse_faults(list(specs))
    if any(f.growth is not None or f.onset_s for f in faults):
        return list(timed_effects(faults))
    fields = [{k: v for k, v in s.items() if k not in ("type", "onset_s")} for s in specs]
    return [EFFECT_TYPES[s["type"]](**f) for s, f in zip(specs, fields, strict=True)]


def node_like_run(
    plan: Sequence[tuple[Sequence[dict[str, Any]], int]],
    rpm: float = 3000.0,
    channels: Sequence[str] = CHANNELS,
    replay: bool | str = True,
    model: str = "paper_sun2021",
    same_reference: bool = False,
) -> tuple[np.ndarray, np.ndarray, list[tuple[float, bool, int]]]:
    """The node's stream and the plain integration's through ``plan``.

    Parameters
    ----------
    plan : sequence of (fault specs, chunks)
        Each fault list (docs/faults.md entries) is applied at a chunk start, as the node's stepping
        thread does (``set_effects(timed_effects(...))``), and held for that many 0.1 s chunks.
    rpm : float
        Constant input speed.
    channels : sequence of str
        Output channels (20 kHz).
    replay : bool or str
        The node-like ``Simulator``'s ``periodic_replay`` (``"faults"``: faults replayed too).
    model : str
        Config name.
    same_reference : bool
        The reference is the same option's integration (serving off: the same periodic angles, given
        the same ``timed_effects``) instead of the plain ``Simulator`` with the library effects.

    Returns
    -------
    node, plain : ndarray
        The two streams (the node's and the reference's), samples x channels.
    info : list of (float, bool, int)
        Per chunk: the end time, whether the replay served at its end, how often it engaged so far.
    """
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.faults.spec import parse_faults
    from gear_rotor_sim.faults.timed import timed_effects
    from gear_rotor_sim.simulator import Simulator

    cfg = load_config(model)
    kw: dict[str, Any] = {"channels": list(channels)}
    first = plan[0][0]
    timed = timed_effects(parse_faults(list(first)))
    node = Simulator(cfg, rpm, 25.0, 20000.0, periodic_replay=replay, effects=timed, **kw)
    if same_reference:
        plain = Simulator(cfg, rpm, 25.0, 20000.0, periodic_replay=replay, effects=timed, **kw)
        assert plain.replay is not None
        plain.replay.serving = False
    else:
        plain = Simulator(cfg, rpm, 25.0, 20000.0, effects=library_effects(first), **kw)
    a: list[np.ndarray] = []
    b: list[np.ndarray] = []
    info: list[tuple[float, bool, int]] = []
    for i, (specs, chunks) in enumerate(plan):
        if i:
            node.set_effects(timed_effects(parse_faults(list(specs))))
            ref = timed_effects(parse_faults(list(specs))) if same_reference else library_effects(specs)
            plain.set_effects(ref)
        for _ in range(chunks):
            a.append(node.advance_deferred(CHUNK_S).result().data)
            b.append(plain.advance(CHUNK_S).data)
            rep = node.replay
            info.append((node.time_s, bool(rep and rep.active), rep.n_engaged if rep else 0))
    return np.vstack(a), np.vstack(b), info


def chunk_errors(node: np.ndarray, plain: np.ndarray, n_chunk: int) -> np.ndarray:
    """Per chunk of ``n_chunk`` samples, the largest |node - plain| over its samples and the channels,
    each channel's taken of its peak |plain| over the whole run (the node test's measure)."""
    scale = np.maximum(np.abs(plain).max(axis=0), 1e-300)
    err = (np.abs(node - plain) / scale).max(axis=1)
    n = err.size // n_chunk
    return err[: n * n_chunk].reshape(n, n_chunk).max(axis=1)


def _parse_plan(text: str) -> list[tuple[list[dict[str, Any]], int]]:
    out = []
    for part in text.split(","):
        name, chunks = part.split(":")
        out.append((FAULTS[name], int(chunks)))
    return out


def node_sequence_plan(hold: int) -> str:
    """The plan text of :data:`NODE_SEQUENCE`, each fault held ``hold`` chunks."""
    return ",".join(f"{name}:{hold}" for name in NODE_SEQUENCE)


def switches(plan_text: str, rpm: float, plain_angles: bool, mode: bool | str = True) -> np.ndarray:
    """Print and return the per-chunk errors of :func:`node_like_run` (``plain_angles``: the replay's
    angles replaced by the plain integration's also without faults, a diagnosis of the option's
    arithmetic; ``mode``: ``periodic_replay``)."""
    import gear_rotor_sim.simulator_replay as sr

    plan = _parse_plan(plan_text)
    names = [n.split(":")[0] for n in plan_text.split(",") for _ in range(int(n.split(":")[1]))]
    orig = sr.PeriodicReplay.begin
    if plain_angles:
        sr.PeriodicReplay.begin = lambda self, sim, key, angle: (orig(self, sim, key, angle), angle)[1]
    try:
        x, y, info = node_like_run(plan, rpm, replay=mode)
    finally:
        sr.PeriodicReplay.begin = orig
    err = chunk_errors(x, y, int(CHUNK_S * 20000))
    for name, e, (t, active, n_eng) in zip(names, err, info, strict=True):
        print(f"t={t:5.2f} s {name:20s} |node - plain| / peak {e:8.1e} serving={active!s:5s} engaged {n_eng}")
    print(f"largest {err.max():.2e} (the node test's bound: 1e-9)")
    return err


def jump(rpm: float, fault: str, perturb: float, chunks: int) -> None:
    """Print where two plain integrations with start angles ``perturb`` rad apart first differ."""
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.simulator import Simulator
    from gear_rotor_sim.solver.newmark import NewmarkStepper

    calls: dict[int, list[tuple]] = {0: [], 1: []}
    which = [0]
    orig = NewmarkStepper.run

    def run(self: Any, t: np.ndarray, angle: np.ndarray, *a: Any, **k: Any) -> Any:
        r = orig(self, t, angle, *a, **k)
        cyc = self.system.meshes[0].pinion_teeth / (2.0 * np.pi)
        calls[which[0]].append((t[1:-1].copy(), (angle[1:-1] * cyc) % 1.0, r[0].copy()))
        return r

    cfg = load_config("paper_sun2021")
    streams = []
    NewmarkStepper.run = run
    try:
        for w, d in enumerate((0.0, perturb)):
            which[0] = w
            eff = library_effects(FAULTS[fault])
            sim = Simulator(cfg, rpm, 25.0, 20000.0, channels=["dte", "mesh_force"], effects=eff)
            sim._angle0 += d
            streams.append(np.vstack([sim.advance(CHUNK_S).data for _ in range(chunks)]))
    finally:
        NewmarkStepper.run = orig
    err = chunk_errors(streams[1], streams[0], int(CHUNK_S * 20000))
    print(f"{fault} at {rpm:g} rpm, start angles {perturb:g} rad apart; per 0.1 s, of the peak:")
    print("  " + " ".join(f"{e:.1e}" for e in err))
    for (t, ph, r0), (_, _, r1) in zip(calls[0], calls[1], strict=False):
        if r0.shape != r1.shape:
            print("  the chunks differ (dt rule)")
            return
        d = np.abs(r1 - r0).max(axis=1) / np.abs(r0).max()
        hit = np.flatnonzero(d > 1e-9)
        if hit.size:
            j = hit[0]
            print(f"  first step differing by > 1e-9 of the peak: t = {t[j]:.9f} s, mesh phase {ph[j]:.12f}")
            for q in range(max(0, j - 2), min(j + 2, r0.shape[0])):
                f0, f1 = r0[q, 1], r1[q, 1]
                print(f"    t = {t[q]:.9f}  phase {ph[q]:.9f}  mesh force {f0:10.3f} / {f1:10.3f} N")
            return
    print("  no step differs by more than 1e-9")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("switches")
    s.add_argument("--plan", default="mass_unbalance:9,shaft_misalignment:9,healthy:9,gear_eccentricity:4")
    s.add_argument("--rpm", type=float, default=3000.0)
    s.add_argument("--plain-angles", action="store_true", help="the replay with the plain angles")
    s.add_argument("--faults", action="store_true", help='periodic_replay="faults" (faults replayed)')
    s.add_argument(
        "--node-sequence", type=int, default=0, help="test_faults_node's order, held N chunks each"
    )
    j = sub.add_parser("jump")
    j.add_argument("--rpm", type=float, default=3000.0)
    j.add_argument("--fault", default="gear_eccentricity", choices=sorted(FAULTS))
    j.add_argument("--perturb", type=float, default=1e-13)
    j.add_argument("--chunks", type=int, default=6)
    args = ap.parse_args()
    if args.cmd == "switches":
        plan = node_sequence_plan(args.node_sequence) if args.node_sequence else args.plan
        switches(plan, args.rpm, args.plain_angles, "faults" if args.faults else True)
    else:
        jump(args.rpm, args.fault, args.perturb, args.chunks)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
