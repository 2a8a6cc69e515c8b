"""Solver benchmark on the paper gearbox (prints figures; not a test). Run with OPENBLAS_NUM_THREADS=1.

Parts (a) and (c) run the full model (108 DOF, 107 free, no modal truncation); the Simulator parts run
the default model (modal reduction with static correction, ``modal_cutoff_hz="auto"``) unless they
compare it with the full one ((f), (g), (h)). One process (one core), 25 C. Every figure is
the median of ``repeats`` (>= 5) timed runs, as wall time (``time.perf_counter``) and CPU time of
the process (``time.process_time``); the load average (``os.getloadavg``) is printed with each part
because the machine is shared.

(a) steps/s: ``NewmarkStepper.run`` on 65,536-step chunks (the kernel with its per-chunk Python
    wrapper, as ``simulate_steady`` calls it) and ``simulate_steady(..., sample="mesh")`` over a
    long run including its per-call set-up (eigendecomposition, static state); DTE only and the
    16 default Simulator channels; 3000 and 20000 rpm (43 % contact loss at 20000 rpm).
    The same with the default dt rule (DTE only): at 20000 rpm the teeth separate, so the rule
    integrates at >= 320 kHz (34 steps/mesh) with the mesh events located.
(b) real-time factor of ``Simulator.advance`` (default dt rule: >= 32 steps per mesh period, >= 320 kHz
    and events located while the teeth separate; output 20 kHz, anti-aliasing decimation included),
    channels ``["dte"]`` and the default set.
(c) set-up per temperature (system assembly, linear model) and per speed (eigendecomposition of the
    state matrix; step map per dt).
(d) bifurcation sweep (``run_bifurcation``, default RunSettings: 300 transient + 200 sampled mesh
    periods, the default dt rule, continuation) over 500-20000 rpm: 40 speeds on one worker, extrapolated
    to 400 (labelled), and the full 400 speeds on the default (2) workers, set-up included.

(f) the two-stage example, full against reduced model (``modal_cutoff_hz="auto"``, the default) at
    3000 / 7000 / 12000 / 20000 rpm, interleaved: RTF, retained modes, speed-up and
    the RMS DTE difference of the last chunk (same dt rule, sample by sample).
(e) the two-stage example (``config/two_stage_example.yaml``, three shafts, two meshes, the
    multi-mesh kernel) next to the paper gearbox: ``Simulator.advance`` RTF with the DTE channels only
    (``mesh1_dte``, ``mesh2_dte`` against ``dte``) at 3000 rpm input, the two simulators advanced
    alternately (interleaved chunks, so both see the same machine phase), and the ratio; plus the
    integration steps per second of each.

(g) the default model against the full model on the paper gearbox (``reproduce.default_against_full``:
    the ``speedup_vs_full`` and ``max_rms_dte_error_pct`` keys of ``reproduce --json``): accuracy of
    the default (reduced, dt rule) and of the full model with the same rule against the full model at
    1024 located steps per mesh period.
(h) the paper gearbox, full against reduced (default) model side by side, interleaved, DTE only, at
    3000 / 7000 / 12000 / 20000 rpm: RTF, integration steps per second, retained modes, speed-up and
    the RMS DTE difference of the last chunk.
(i) ramps (this script only, not ``reproduce``): ``Simulator.advance`` with the 16 default channels from
    steady 3000 rpm / 25 C through 3000 -> 6000 rpm at 2000 rpm/s (1.5 s) and 25 -> 125 C at 20 C/s
    (5 s), each next to the steady RTF measured just before it in the same simulator; with an empty
    eigenbasis disk cache ("cold", a first run) and again with the cache it filled ("warm", a later
    run; the in-process basis memo cleared). Without ``--quick`` also the per-quantum rebuild
    (``ramp_speed_quantum_rel=SPEED_QUANTUM_REL``, ``ramp_temperature_quantum_c=TEMPERATURE_QUANTUM_C``)
    and the largest RMS difference of the default stream from it over the channels, % of the channel's
    RMS.

(k) the gear kernel alone (this script only): ``gear_kernel.run_chunk_gear`` on chunks captured from
    ``Simulator.advance`` (DTE channels) of the paper gearbox at 3000 and 20000 rpm and the two-stage
    example at 3000 rpm, each with the default (reduced) and the full basis, all in one run: CPU us
    per step with the events located as the rule has it and with location off on the same chunk,
    sub-steps per step, the located part per sub-step, forced modes and active columns, and the
    regular step's cost per forced mode and per (forced mode x column). The per-step profile of the
    default against the full model and of the two-stage rig against the paper gearbox. Last,
    ``Simulator.advance`` at 20000 rpm (DTE only) split into the kernel's CPU and the rest, with the
    minor page faults and system CPU per simulated second (newmark.ChunkBuffers).

(r) periodic replay at steady state (``Simulator(periodic_replay=True)``, benchmarks/bench_replay.py):
    the time until it engages and the RTF with it against integration, interleaved, 3000 / 7000 /
    12000 / 20000 rpm DTE only and 3000 / 20000 rpm with the 16 default channels. Every other part
    integrates (the option is off by default; the default / full ratio is measured with it off).

``measure(quick)`` returns ``steps_per_s`` (simulate_steady, DTE only, 32 steps/mesh, the smaller of
3000 and 20000 rpm), ``rtf_3000rpm`` and ``rtf_20000rpm`` (Simulator.advance, DTE only) plus the detail; the
reproduce command imports it (``quick=True`` takes well under a minute).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_solver.py [--quick] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import time
from collections.abc import Callable, Sequence

import numpy as np

from gear_rotor_sim.analysis.reproduce import default_against_full
from gear_rotor_sim.config import load_config
from gear_rotor_sim.examples import paper_gearbox
from gear_rotor_sim.simulator import Simulator
from gear_rotor_sim.solver.newmark import (
    LinearModel,
    NewmarkStepper,
    eigen_basis,
    gear_map,
    mesh_frequency_hz,
    parse_channels,
    quantize_speed_rpm,
    step_map,
)
from gear_rotor_sim.solver.steady import simulate_steady
from gear_rotor_sim.system import GearRotorSystem

SPEEDS_RPM = (3000.0, 20000.0)
STEPS_PER_MESH = 32
OUTPUT_RATE_HZ = 20000.0
CHUNK_STEPS = 65536


def _load() -> float:
    return float(os.getloadavg()[0])


def timed(fn: Callable[[], object], repeats: int) -> dict:
    """Median wall and CPU seconds of ``repeats`` calls (and the 1-min load average before/after)."""
    walls, cpus = [], []
    la0 = _load()
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    return {
        "wall_s": float(np.median(walls)),
        "cpu_s": float(np.median(cpus)),
        "walls_s": walls,
        "load": (la0, _load()),
    }


def kernel_steps_per_s(system: object, rpm: float, channels: Sequence[str], repeats: int) -> dict:
    """``NewmarkStepper.run`` on CHUNK_STEPS-step chunks at constant speed (steady state first)."""
    _, st = simulate_steady(system, rpm, 400, 1, STEPS_PER_MESH, tuple(channels))  # type: ignore[arg-type]
    stepper = NewmarkStepper(system, parse_channels(system, list(channels)))  # type: ignore[arg-type]
    dt = 1.0 / (mesh_frequency_hz(system, rpm) * STEPS_PER_MESH)  # type: ignore[arg-type]
    omega = rpm * 2.0 * np.pi / 60.0
    stepper.set_operating_point(quantize_speed_rpm(rpm) * 2.0 * np.pi / 60.0, dt, st)
    j = np.arange(CHUNK_STEPS + 2, dtype=float)
    state = {"k": 0}

    def run() -> None:
        k = state["k"]
        t = st.time + (j + k) * dt
        stepper.run(t, omega * t, np.full(j.size, omega), st)
        state["k"] = k + CHUNK_STEPS

    run()  # warm (compilation is cached on disk; first call loads it)
    r = timed(run, repeats)
    r["steps_per_s"] = CHUNK_STEPS / r["wall_s"]
    r["steps_per_cpu_s"] = CHUNK_STEPS / r["cpu_s"]
    return r


def steady_steps_per_s(
    system: object, rpm: float, channels: Sequence[str], n_periods: int, repeats: int, rule: bool = False
) -> dict:
    """``simulate_steady(sample="mesh")`` over ``n_periods`` mesh periods, per-call set-up included.

    ``rule=False``: 32 steps per mesh period throughout, events not located (the cost of a step);
    True: the default dt rule (steps counted as run: the rule may raise the resolution and locate).
    """
    kw = {} if rule else {"contact_loss_rate_hz": None}
    _, st = simulate_steady(system, rpm, 400, 1, STEPS_PER_MESH, tuple(channels), **kw)  # type: ignore[arg-type]
    used = {}

    def run() -> None:
        res, _ = simulate_steady(
            system,  # type: ignore[arg-type]
            rpm,
            0,
            n_periods,
            STEPS_PER_MESH,
            tuple(channels),
            initial_state=st,
            sample="mesh",
            **kw,  # type: ignore[arg-type]
        )
        used["spm"], used["located"] = res.steps_per_mesh, res.located

    r = timed(run, repeats)
    n = n_periods * used["spm"]
    r["steps_per_mesh"] = used["spm"]
    r["located"] = used["located"]
    r["steps"] = n
    r["steps_per_s"] = n / r["wall_s"]
    r["steps_per_cpu_s"] = n / r["cpu_s"]
    return r


def simulator_rtf(
    cfg: object, rpm: float, channels: Sequence[str] | None, chunk_s: float, repeats: int
) -> dict:
    """Real-time factor of consecutive ``Simulator.advance(chunk_s)`` calls after a warm-up."""
    sim = Simulator(cfg, rpm, 25.0, OUTPUT_RATE_HZ, channels=channels)
    sim.advance(0.05)  # warm-up: kernels loaded, basis built, transient start
    r = timed(lambda: sim.advance(chunk_s), repeats)
    r["rtf"] = chunk_s / r["wall_s"]
    r["rtf_cpu"] = chunk_s / r["cpu_s"]
    r["steps_per_mesh"] = sim.last_chunk_stats["steps"] / (
        chunk_s * mesh_frequency_hz(sim._stepper.system, rpm)
    )
    r["dt_s"] = sim.dt
    r["n_channels"] = len(sim.channels)
    return r


def interleaved_rtf(cases: dict[str, tuple], rpm: float, chunk_s: float, repeats: int) -> dict:
    """RTF of several simulators advanced alternately (chunk by chunk) after a warm-up; medians.

    ``cases``: name -> (config, channels[, Simulator keyword arguments]). Each case's last block is kept
    (``"last"``): the simulators advance in lockstep, so blocks of equal cases compare sample by sample.
    """
    sims = {
        k: Simulator(c[0], rpm, 25.0, OUTPUT_RATE_HZ, channels=c[1], **(c[2] if len(c) > 2 else {}))
        for k, c in cases.items()
    }
    last: dict[str, np.ndarray] = {}
    for sim in sims.values():
        sim.advance(0.1)  # warm-up: kernels loaded, basis built, transient start
    wall: dict[str, list[float]] = {k: [] for k in sims}
    cpu: dict[str, list[float]] = {k: [] for k in sims}
    steps: dict[str, float] = {}
    load0 = os.getloadavg()[0]
    for _ in range(repeats):
        for k, sim in sims.items():
            t0, c0 = time.perf_counter(), time.process_time()
            last[k] = np.asarray(sim.advance(chunk_s).data)
            wall[k].append(time.perf_counter() - t0)
            cpu[k].append(time.process_time() - c0)
            steps[k] = sim.last_chunk_stats["steps"]
    out: dict = {}
    for k, sim in sims.items():
        w, c = float(np.median(wall[k])), float(np.median(cpu[k]))
        out[k] = {
            "rtf": chunk_s / w,
            "rtf_cpu": chunk_s / c,
            "steps_per_s": steps[k] / w,
            "dt_s": sim.dt,
            "channels": list(sim.channels),
            "load": (load0, os.getloadavg()[0]),
            "modes": int(sim._stepper.map.basis.lam.size),
            "last": last[k],
        }
    return out


def reduction_table(
    cfg: object, channels: list[str], rpms: Sequence[float], chunk_s: float, repeats: int
) -> dict:
    """Full against reduced (``modal_cutoff_hz="auto"``) model, interleaved, DTE channels: RTF, modes,
    and the RMS difference of each channel over the last chunk (same dt rule, same samples)."""
    out: dict = {}
    for rpm in rpms:
        r = interleaved_rtf(
            {
                "full": (cfg, channels, {"modal_cutoff_hz": None}),
                "reduced": (cfg, channels, {"modal_cutoff_hz": "auto"}),
            },
            rpm,
            chunk_s,
            repeats,
        )
        full, red = r["full"].pop("last"), r["reduced"].pop("last")
        rms_f = np.sqrt(np.mean(full**2, axis=0))
        rms_r = np.sqrt(np.mean(red**2, axis=0))
        r["rms_dte_error_pct"] = [float(x) for x in 100.0 * (rms_r - rms_f) / rms_f]
        r["speedup"] = r["reduced"]["rtf"] / r["full"]["rtf"]
        out[f"{rpm:.0f}rpm"] = r
    return out


def setup_times(cfg: object, repeats: int) -> dict:
    """System assembly + linear model per temperature; eigendecomposition per speed; step map per dt."""
    out: dict = {}
    temps = iter(25.5 + 0.5 * np.arange(repeats))  # distinct temperatures (0.5 C quantum of the Simulator)
    out["assembly"] = timed(lambda: GearRotorSystem.from_config(cfg, float(next(temps))), repeats)
    system = GearRotorSystem.from_config(cfg, 25.0)
    out["linear_model"] = timed(lambda: LinearModel(system), repeats)
    lin = LinearModel(system)
    speeds = iter(np.linspace(1000.0, 19000.0, repeats + 1) * 2.0 * np.pi / 60.0)
    out["eig"] = timed(lambda: eigen_basis(lin, next(speeds)), repeats)
    basis = eigen_basis(lin, 3000.0 * 2.0 * np.pi / 60.0)
    out["eig_cond"] = float(basis.cond)
    out["eig_dense"] = bool(basis.dense)
    specs = parse_channels(system, Simulator.default_channels(system))

    def smap() -> None:
        gear_map(lin, step_map(lin, basis, 1.0 / (32 * 1450.0), specs), specs)

    out["step_map"] = timed(smap, repeats)
    return out


def sweep_time(n_speeds: int, workers: int) -> dict:
    """``run_bifurcation`` at 25 C over ``n_speeds`` speeds in 500..20000 rpm, set-up included."""
    from gear_rotor_sim.analysis import bifurcation as bif

    bif._SYSTEM_CACHE.clear()  # set-up included: the system is assembled inside the timed call
    la0 = _load()
    c0, w0 = time.process_time(), time.perf_counter()
    res = bif.run_bifurcation(
        bif.Case(25.0), np.linspace(500.0, 20000.0, n_speeds), workers=workers, progress=False
    )
    wall = time.perf_counter() - w0
    cpu = time.process_time() - c0
    return {
        "n_speeds": n_speeds,
        "workers": workers,
        "wall_s": wall,
        "cpu_s_parent": cpu,
        "load": (la0, _load()),
        "n": len(res.speeds_rpm),
    }


RAMPS = {
    "speed_3000_6000rpm": ({"speed_rpm": 6000.0}, 1.5),
    "temperature_25_125c": ({"temperature_c": 125.0}, 5.0),
}


def _ramp_once(cfg: object, target: dict, duration_s: float, **kw: float) -> tuple[dict, np.ndarray]:
    sim = Simulator(cfg, speed_rpm=3000.0, temperature_c=25.0, output_rate_hz=OUTPUT_RATE_HZ, **kw)
    sim.advance(0.3)
    w0 = time.perf_counter()
    sim.advance(1.0)
    steady = 1.0 / (time.perf_counter() - w0)
    sim.set_targets(**target)
    la0 = _load()
    w0, c0 = time.perf_counter(), time.process_time()
    data = np.asarray(sim.advance(duration_s).data)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    return {
        "rtf": duration_s / wall,
        "rtf_cpu": duration_s / cpu,
        "steady_rtf": steady,
        "load": (la0, _load()),
    }, data


def ramp_rtf(cfg: object, reference: bool) -> dict:
    """(i): both ramps, cold and warm eigenbasis cache, optionally against the per-quantum rebuild."""
    import tempfile

    from gear_rotor_sim.simulator import TEMPERATURE_QUANTUM_C
    from gear_rotor_sim.solver import basis_cache, newmark
    from gear_rotor_sim.solver.newmark import SPEED_QUANTUM_REL

    out: dict = {}
    old = os.environ.get("GEAR_ROTOR_SIM_BASIS_CACHE")
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["GEAR_ROTOR_SIM_BASIS_CACHE"] = tmp
        try:
            for name, (target, dur) in RAMPS.items():
                r: dict = {}
                for label in ("cold", "warm"):
                    newmark._BASIS_MEMO.clear()  # a new process: only the disk cache carries over
                    basis_cache._RECENT.clear()
                    r[label], data = _ramp_once(cfg, target, dur)
                if reference:
                    newmark._BASIS_MEMO.clear()
                    basis_cache._RECENT.clear()
                    os.environ["GEAR_ROTOR_SIM_BASIS_CACHE"] = "off"
                    grids = {"ramp_speed_quantum_rel": SPEED_QUANTUM_REL,
                             "ramp_temperature_quantum_c": TEMPERATURE_QUANTUM_C}  # fmt: skip
                    r["per_quantum"], ref = _ramp_once(cfg, target, dur, **grids)
                    os.environ["GEAR_ROTOR_SIM_BASIS_CACHE"] = tmp
                    rms = np.sqrt(np.mean(ref**2, axis=0))
                    diff = np.sqrt(np.mean((data - ref) ** 2, axis=0))
                    live = rms > 0.0
                    r["max_rms_diff_pct"] = float(np.max(100.0 * diff[live] / rms[live]))
                out[name] = r
        finally:
            if old is None:
                os.environ.pop("GEAR_ROTOR_SIM_BASIS_CACHE", None)
            else:
                os.environ["GEAR_ROTOR_SIM_BASIS_CACHE"] = old
    return out


def measure(quick: bool = True, ramps: bool = False) -> dict:
    """Benchmark figures; ``quick`` keeps it under about a minute (no sweep, shorter runs); ``ramps``
    adds part (i)."""
    repeats = 5
    cfg = paper_gearbox()
    system = GearRotorSystem.from_config(cfg, 25.0)
    dte = ("dte",)
    full = tuple(Simulator.default_channels(system))
    res: dict = {"load_start": os.getloadavg(), "quick": quick}
    res["kernel"] = {}
    res["steady"] = {}
    n_periods = 5000 if quick else 20000
    for name, ch in (("dte", dte), ("default16", full)):
        for rpm in SPEEDS_RPM:
            key = f"{name}_{rpm:.0f}rpm"
            if not quick or name == "dte":
                res["kernel"][key] = kernel_steps_per_s(system, rpm, ch, repeats)
            res["steady"][key] = steady_steps_per_s(system, rpm, ch, n_periods, repeats)
            if name == "dte":
                res.setdefault("steady_rule", {})[key] = steady_steps_per_s(
                    system, rpm, ch, n_periods, repeats, rule=True
                )
    res["simulator"] = {}
    chunk = 0.2 if quick else 0.5
    for name, ch in (("dte", ["dte"]), ("default16", None)):
        for rpm in SPEEDS_RPM:
            if quick and name != "dte":
                continue
            res["simulator"][f"{name}_{rpm:.0f}rpm"] = simulator_rtf(cfg, rpm, ch, chunk, repeats)
    res["setup"] = setup_times(cfg, repeats)
    two = interleaved_rtf(
        {
            "paper": (cfg, ["dte"]),
            "two_stage": (load_config("two_stage_example"), ["mesh1_dte", "mesh2_dte"]),
        },
        3000.0,
        chunk,
        repeats,
    )
    two["ratio"] = two["two_stage"]["rtf"] / two["paper"]["rtf"]
    two["ratio_cpu"] = two["two_stage"]["rtf_cpu"] / two["paper"]["rtf_cpu"]  # the figure under load
    for k in ("paper", "two_stage"):
        two[k].pop("last")
    res["two_stage_3000rpm"] = two
    res["paper_reduction"] = reduction_table(
        cfg, ["dte"], (3000.0, 7000.0, 12000.0, 20000.0), 0.1 if quick else 0.3, 3 if quick else repeats
    )
    res["two_stage_reduction"] = reduction_table(
        load_config("two_stage_example"),
        ["mesh1_dte", "mesh2_dte"],
        (3000.0, 7000.0, 12000.0, 20000.0),
        0.1 if quick else 0.3,
        3 if quick else repeats,
    )
    # issue 13's reproduce keys: the default model against the full one (paper gearbox)
    res.update(default_against_full(periods=200 if quick else 400))
    if not quick:
        one = sweep_time(40, 1)
        one["extrapolated_400_s"] = one["wall_s"] * 10.0
        res["sweep_40_one_worker"] = one
        res["sweep_400_default_workers"] = sweep_time(400, 0)
    if ramps:
        res["ramps"] = ramp_rtf(cfg, reference=not quick)
    res["load_end"] = os.getloadavg()
    res["steps_per_s"] = min(res["steady"][f"dte_{r:.0f}rpm"]["steps_per_s"] for r in SPEEDS_RPM)
    res["rtf_3000rpm"] = res["simulator"]["dte_3000rpm"]["rtf"]
    res["rtf_20000rpm"] = res["simulator"]["dte_20000rpm"]["rtf"]
    return res


def report(res: dict) -> None:
    def la(r: dict) -> str:
        return f"load {r['load'][0]:.1f}->{r['load'][1]:.1f}"

    print(f"load average at start {tuple(round(x, 2) for x in res['load_start'])}; quick={res['quick']}")
    print("\n(a) steps/s, full model, one core, 32 steps/mesh unless stated (median of 5; wall | CPU)")
    for part, label in (
        ("kernel", "NewmarkStepper.run, 65536-step chunks"),
        ("steady", "simulate_steady sample=mesh"),
        ("steady_rule", "simulate_steady, default dt rule"),
    ):
        for key, r in res[part].items():
            extra = f", {r['steps']} steps incl. set-up" if "steps" in r else ""
            if part == "steady_rule":
                extra += f", {r['steps_per_mesh']} steps/mesh, {'located' if r['located'] else 'not located'}"
            print(
                f"  {label:40s} {key:20s} {r['steps_per_s'] / 1e6:6.3f} | "
                f"{r['steps_per_cpu_s'] / 1e6:6.3f} M steps/s  ({la(r)}{extra})"
            )
    print("\n(b) Simulator.advance real-time factor, 25 C, 20 kHz output, default dt rule (wall | CPU)")
    for key, r in res["simulator"].items():
        print(
            f"  {key:20s} {r['n_channels']:2d} ch: RTF {r['rtf']:7.2f} | {r['rtf_cpu']:7.2f}  "
            f"(dt {r['dt_s'] * 1e6:.3f} us = {r['steps_per_mesh']:.1f} steps/mesh; {la(r)})"
        )
    s = res["setup"]
    print("\n(c) set-up (median of 5; wall | CPU)")
    for key, label in (
        ("assembly", "system assembly per temperature"),
        ("linear_model", "linear model (M^-1 K, M^-1 C, ...) per temperature"),
        ("eig", "eigendecomposition per speed (214 = 178 + 36 states)"),
        ("step_map", "step map + fast map per dt (16 channels)"),
    ):
        print(
            f"  {label:55s} {s[key]['wall_s'] * 1e3:7.1f} | {s[key]['cpu_s'] * 1e3:7.1f} ms  ({la(s[key])})"
        )
    print(f"  cond(Phi) {s['eig_cond']:.3g}, dense fallback {s['eig_dense']}")
    if "sweep_40_one_worker" in res:
        o = res["sweep_40_one_worker"]
        f = res["sweep_400_default_workers"]
        print("\n(d) bifurcation sweep 500-20000 rpm, 25 C, 300 transient + 200 sampled mesh periods/speed")
        print(
            f"  40 speeds, 1 worker: {o['wall_s']:.1f} s wall ({la(o)}); "
            f"EXTRAPOLATED to 400 speeds on one core: {o['extrapolated_400_s']:.0f} s"
        )
        print(f"  400 speeds, default workers (2), measured: {f['wall_s']:.1f} s wall ({la(f)})")
    t = res["two_stage_3000rpm"]
    print("\n(e) two-stage example next to the paper gearbox, 3000 rpm input, DTE channels only, interleaved")
    for key in ("paper", "two_stage"):
        r = t[key]
        print(
            f"  {key:10s} {','.join(r['channels']):20s} RTF {r['rtf']:7.2f} | {r['rtf_cpu']:7.2f}  "
            f"{r['steps_per_s'] / 1e6:6.3f} M steps/s wall (dt {r['dt_s'] * 1e6:.3f} us; {la(r)})"
        )
    print(
        f"  two-stage / paper RTF: {t['ratio']:.3f} wall | {t['ratio_cpu']:.3f} CPU (goal >= 0.40; on a "
        "loaded machine the CPU ratio is the measurement)"
    )
    print(
        "\n(f) two-stage example, full against reduced model (modal_cutoff_hz='auto'), DTE channels, "
        "interleaved"
    )
    for key, r in res["two_stage_reduction"].items():
        f, d = r["full"], r["reduced"]
        err = ", ".join(f"{e:+.3f}" for e in r["rms_dte_error_pct"])
        print(
            f"  {key:9s} full {f['modes']:3d} modes RTF {f['rtf']:6.2f} | {f['rtf_cpu']:6.2f}   reduced "
            f"{d['modes']:3d} modes RTF {d['rtf']:6.2f} | {d['rtf_cpu']:6.2f}  speed-up {r['speedup']:.2f}  "
            f"RMS DTE reduced - full: {err} %  (dt {f['dt_s'] * 1e6:.3f} us)"
        )
    print(
        "\n(h) paper gearbox, full against reduced (default) model, DTE only, interleaved "
        "(steps/s: integration steps per wall second)"
    )
    for key, r in res["paper_reduction"].items():
        f, d = r["full"], r["reduced"]
        err = ", ".join(f"{e:+.3f}" for e in r["rms_dte_error_pct"])
        print(
            f"  {key:9s} full {f['modes']:3d} modes RTF {f['rtf']:6.2f} | {f['rtf_cpu']:6.2f} "
            f"{f['steps_per_s'] / 1e6:5.2f} M/s   reduced {d['modes']:3d} modes RTF {d['rtf']:6.2f} | "
            f"{d['rtf_cpu']:6.2f} {d['steps_per_s'] / 1e6:5.2f} M/s  speed-up {r['speedup']:.2f}  "
            f"RMS DTE reduced - full (last chunk): {err} %  (dt {f['dt_s'] * 1e6:.3f} us)"
        )
    pts = ", ".join(
        f"{p['temperature_c']:.0f} C {p['speed_rpm']:.0f} rpm default {p['rms_dte_error_pct']:+.3f} % / "
        f"full {p['full_rule_error_pct']:+.3f} % ({p['motion']})"
        for p in res["accuracy_points"]
    )
    print(
        f"\n(g) default ({res['default_model']} model) against the full model, paper gearbox: speed-up "
        f"{res['speedup_vs_full']:.3f} (RTF {res['rtf_20000rpm_default_vs_full'][0]:.2f} / "
        f"{res['rtf_20000rpm_default_vs_full'][1]:.2f}, DTE only, 20000 rpm, interleaved); RMS DTE of the "
        f"default model (dt rule, modal cut-off) against {res['accuracy_reference']}: max "
        f"{res['max_rms_dte_error_pct']:.3f} % over the non-chaotic points (the full model with the same dt "
        f"rule alongside)\n  {pts}"
    )
    if "ramps" in res:
        print(
            "\n(i) ramps, 16 default channels, from steady 3000 rpm / 25 C (RTF wall | CPU; the steady RTF "
            "just before, same simulator)"
        )
        for key, r in res["ramps"].items():
            for label in ("cold", "warm", "per_quantum"):
                if label in r:
                    x = r[label]
                    print(
                        f"  {key:22s} {label:11s} RTF {x['rtf']:6.2f} | {x['rtf_cpu']:6.2f}  "
                        f"(steady {x['steady_rtf']:6.2f}; load {x['load'][0]:.1f}->{x['load'][1]:.1f})"
                    )
            if "max_rms_diff_pct" in r:
                print(
                    f"  {key:22s} default against per-quantum: max RMS difference "
                    f"{r['max_rms_diff_pct']:.3f} %"
                )
    print(f"\nload average at end {tuple(round(x, 2) for x in res['load_end'])}")
    print(
        "\nGOALS: steps/s (simulate_steady, DTE only, min over 3000/20000 rpm) "
        f"{res['steps_per_s'] / 1e6:.2f} M "
        f"(goal 2 M); RTF DTE-only (default model) 3000 rpm {res['rtf_3000rpm']:.1f} (goal 100), "
        f"20000 rpm {res['rtf_20000rpm']:.1f} (goal 15); default / full at 20000 rpm "
        f"{res['speedup_vs_full']:.2f} (goal 3); two-stage / paper {res['two_stage_3000rpm']['ratio']:.2f} "
        f"wall, {res['two_stage_3000rpm']['ratio_cpu']:.2f} CPU (goal 0.40)"
    )


def _capture_chunk(cfg: object, rpm: float, channels: list[str], cutoff: object) -> tuple:
    """Arguments of the longest ``run_chunk_gear`` call of a 0.05 s ``advance`` after 0.3 s."""
    import copy

    from gear_rotor_sim.solver import gear_kernel

    sim = Simulator(cfg, rpm, 25.0, OUTPUT_RATE_HZ, channels=channels, modal_cutoff_hz=cutoff)
    sim.advance(0.3)
    caps: list[tuple] = []
    orig = gear_kernel.run_chunk_gear

    def spy(*a: object) -> object:
        caps.append(copy.deepcopy(a))
        return orig(*a)

    gear_kernel.run_chunk_gear = spy
    try:
        sim.advance(0.05)
    finally:
        gear_kernel.run_chunk_gear = orig
    return max(caps, key=lambda a: a[4][0].shape[0])


def kernel_breakdown(repeats: int = 7) -> dict:
    """Part (k): the gear kernel alone on captured chunks, located and not, per rig and basis."""
    import copy

    from gear_rotor_sim.solver import gear_kernel

    rigs = {
        "paper_3000rpm": (paper_gearbox(), 3000.0, ["dte"]),
        "paper_20000rpm": (paper_gearbox(), 20000.0, ["dte"]),
        "two_stage_3000rpm": (load_config("two_stage_example"), 3000.0, ["mesh1_dte", "mesh2_dte"]),
    }
    res: dict = {"load_start": os.getloadavg()}
    for name, (cfg, rpm, ch) in rigs.items():
        for basis, cut in (("default", "auto"), ("full", None)):
            args = list(_capture_chunk(cfg, rpm, ch, cut))
            n = args[4][0].shape[0] - 1
            row: dict = {
                "steps": n,
                "modes": int(args[0][0].shape[0]),
                "forced_modes": int(args[1]),
                "columns": int(args[5][0].shape[0]),
                "meshes": int(args[4][0].shape[1]),
            }
            for loc in (bool(args[8]), False) if args[8] else (False,):
                args[8] = loc
                cpus = []
                for _ in range(repeats + 1):
                    a = copy.deepcopy(args)
                    c0 = time.process_time()
                    out = gear_kernel.run_chunk_gear(*a)
                    cpus.append(time.process_time() - c0)
                us = 1e6 * float(np.median(cpus[1:])) / n
                row["us_per_step_located" if loc else "us_per_step"] = us
                if loc:
                    row["substeps_per_step"] = out[3] / n
            if "us_per_step_located" in row:
                row["us_per_substep"] = (
                    (row["us_per_step_located"] - row["us_per_step"]) / (row["substeps_per_step"] * n) * n
                )
            row["ns_per_mode_column"] = 1e3 * row["us_per_step"] / (row["forced_modes"] * row["columns"])
            res[f"{name}_{basis}"] = row
    res["simulator_split_20000rpm"] = simulator_split(paper_gearbox(), 20000.0, repeats)
    res["load_end"] = os.getloadavg()
    return res


def simulator_split(cfg: object, rpm: float, repeats: int, chunk_s: float = 0.1) -> dict:
    """CPU of ``Simulator.advance(chunk_s)`` (DTE only) split into the gear kernel and the rest (the
    Python side: time and phase arrays, the decimator's store and FIR, the dt rule), medians."""
    from gear_rotor_sim.solver import gear_kernel

    sim = Simulator(cfg, rpm, 25.0, OUTPUT_RATE_HZ, channels=["dte"])
    sim.advance(0.3)
    acc = [0.0]
    orig = gear_kernel.run_chunk_gear

    def timed_kernel(*a: object) -> object:
        c0 = time.process_time()
        out = orig(*a)
        acc[0] += time.process_time() - c0
        return out

    total, kern = [], []
    gear_kernel.run_chunk_gear = timed_kernel
    ru0 = resource.getrusage(resource.RUSAGE_SELF)
    try:
        for _ in range(2 * repeats + 1):
            acc[0] = 0.0
            c0 = time.process_time()
            sim.advance(chunk_s)
            total.append(time.process_time() - c0)
            kern.append(acc[0])
    finally:
        gear_kernel.run_chunk_gear = orig
    ru1 = resource.getrusage(resource.RUSAGE_SELF)
    sim_s = (2 * repeats + 1) * chunk_s
    t, k = np.array(total), np.array(kern)
    return {
        "rpm": rpm,
        "ms_per_simulated_s": 1e3 * float(np.median(t)) / chunk_s,
        "kernel_ms_per_simulated_s": 1e3 * float(np.median(k)) / chunk_s,
        "rest_ms_per_simulated_s": 1e3 * float(np.median(t - k)) / chunk_s,
        "rtf_cpu": chunk_s / float(np.median(t)),
        "steps_per_simulated_s": sim.last_chunk_stats["steps"] / chunk_s,
        # pages mapped afresh (the simulator keeps its chunk arrays: newmark.ChunkBuffers), system CPU
        "minor_faults_per_simulated_s": (ru1.ru_minflt - ru0.ru_minflt) / sim_s,
        "system_cpu_ms_per_simulated_s": 1e3 * (ru1.ru_stime - ru0.ru_stime) / sim_s,
    }


def report_kernel(res: dict) -> None:
    la = f"load {res['load_start'][0]:.1f}->{res['load_end'][0]:.1f}"
    print(f"\n(k) gear kernel alone on captured chunks, DTE channels, CPU median ({la})")
    for key, r in res.items():
        if not isinstance(r, dict) or "meshes" not in r:
            continue
        loc = (
            f"located {r['us_per_step_located']:.3f} us/step ({r['substeps_per_step']:.3f} sub-steps "
            f"per step, {r['us_per_substep']:.2f} us each)"
            if "us_per_step_located" in r
            else "not located by the rule"
        )
        print(
            f"  {key:26s} {r['meshes']} mesh {r['forced_modes']:3d}/{r['modes']:3d} forced modes "
            f"{r['columns']} cols: {r['us_per_step']:.3f} us/step not located "
            f"({r['ns_per_mode_column']:.3f} ns per forced mode x column); {loc}"
        )
    sp = res.get("simulator_split_20000rpm")
    if sp:
        print(
            f"  Simulator.advance at {sp['rpm']:.0f} rpm, DTE only: {sp['ms_per_simulated_s']:.1f} ms CPU "
            f"per simulated s (RTF {sp['rtf_cpu']:.2f}): kernel {sp['kernel_ms_per_simulated_s']:.1f}, "
            f"the rest {sp['rest_ms_per_simulated_s']:.1f} ({sp['steps_per_simulated_s']:.0f} steps per "
            f"simulated s; {sp['minor_faults_per_simulated_s']:.0f} minor page faults and "
            f"{sp['system_cpu_ms_per_simulated_s']:.1f} ms system CPU per simulated s)"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description="solver benchmark (paper gearbox)")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json", default="")
    args = ap.parse_args()
    res = measure(args.quick, ramps=True)
    report(res)
    res["kernel_breakdown"] = kernel_breakdown(5 if args.quick else 9)
    report_kernel(res["kernel_breakdown"])
    from bench_replay import replay_table, report_replay  # here: reproduce loads this file by path

    res["periodic_replay"] = replay_table(0.2, 5)
    report_replay(res["periodic_replay"])
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(res, fh, indent=1, default=float)


if __name__ == "__main__":
    main()
