"""Solver speed and accuracy numbers of ``gear-rotor-sim reproduce`` (the ``benchmark`` JSON keys).

:func:`benchmark` times the solver (through ``benchmarks/bench_solver.py`` when it provides
``measure``), :func:`default_against_full` compares the default model (dt rule, modal reduction) with
the full model at the paper's operating points (issue 13's ``speedup_vs_full`` and
``max_rms_dte_error_pct``).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

BENCH_SOLVER = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_solver.py"


def _bench_solver_measure(path: Path | None = None) -> Callable[..., dict] | None:
    """``measure`` of ``benchmarks/bench_solver.py`` (loaded by path; not a package), if it has one."""
    path = BENCH_SOLVER if path is None else path
    if not path.is_file():
        return None
    import importlib.util

    spec = importlib.util.spec_from_file_location("_gear_rotor_sim_bench_solver", path)
    if spec is None or spec.loader is None:
        return None
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception:
        return None
    fn = getattr(module, "measure", None)
    return fn if callable(fn) else None


#: Reference of ``default_against_full``: steps per mesh period, events located (as
#: benchmarks/convergence_events.py).
REFERENCE_STEPS_PER_MESH = 1024
#: The points ``default_against_full`` checks in the quick and full runs: the Fig 7 speeds and the
#: Fig 8 speed of the JSON summary at the paper's three temperatures (C, rpm).
ACCURACY_POINTS = tuple((t, s) for t in (25.0, 125.0, 225.0) for s in (1000.0, 14400.0, 19000.0))


def default_against_full(
    points: tuple[tuple[float, float], ...] = ACCURACY_POINTS,
    periods: int = 200,
    transient_s: float = 0.2,
    settle: int = 50,
    rtf_chunk_s: float = 0.1,
    repeats: int = 3,
) -> dict[str, Any]:
    """The default model against the full model on the paper gearbox (issue 13's JSON keys).

    ``speedup_vs_full``: ``Simulator.advance`` RTF with the default settings over that with
    ``modal_cutoff_hz=None`` (the full model), DTE only at 20000 rpm, 20 kHz output, the two advanced
    alternately in ``rtf_chunk_s`` chunks after a warm-up (median of ``repeats``; same run).
    ``max_rms_dte_error_pct``: per point, the reference (full model, ``REFERENCE_STEPS_PER_MESH``
    located steps per mesh period, fixed) runs ``transient_s`` from the static equilibrium, then
    ``periods`` recorded mesh periods; the default dt rule runs from the reference's state
    (``settle`` periods, then ``periods``); the error of its RMS DTE against the reference's, largest
    over the points whose reference motion is not chaotic (the RMS of a chaotic window is a
    statistic, not a converged number; chaotic points are listed but not counted).

    The default model is the Simulator's: the default dt rule on the reduced modal basis of
    ``modal_cutoff_hz="auto"`` (:func:`simulator.auto_modal_cutoff_hz` at 20 kHz output; the steady
    runs here take the same cut-off), so the error combines the dt rule's and the reduction's;
    ``default_model`` says which model the default Simulator ran.
    """
    from gear_rotor_sim.analysis.classify import classify_motion
    from gear_rotor_sim.examples import paper_gearbox
    from gear_rotor_sim.simulator import Simulator, auto_modal_cutoff_hz
    from gear_rotor_sim.solver.newmark import mesh_frequency_hz
    from gear_rotor_sim.solver.steady import simulate_steady
    from gear_rotor_sim.system import GearRotorSystem

    cfg = paper_gearbox()
    sims = {
        "default": Simulator(cfg, 20000.0, 25.0, 20000.0, channels=["dte"]),
        "full": Simulator(cfg, 20000.0, 25.0, 20000.0, channels=["dte"], modal_cutoff_hz=None),
    }
    walls: dict[str, list[float]] = {k: [] for k in sims}
    for sim in sims.values():
        sim.advance(0.05)  # warm-up: kernels loaded, basis built
    for _ in range(repeats):
        for k, sim in sims.items():
            t0 = time.perf_counter()
            sim.advance(rtf_chunk_s)
            walls[k].append(time.perf_counter() - t0)
    rtf = {k: rtf_chunk_s / float(np.median(w)) for k, w in walls.items()}
    mp = sims["default"]._stepper.map
    reduced = mp is not None and mp.resid is not None
    rows = []
    for temp, rpm in points:
        system = GearRotorSystem.from_config(cfg, temp)
        ref_kw: dict[str, Any] = {"locate_events": True, "contact_loss_rate_hz": None}
        n_tr = max(1, int(transient_s * mesh_frequency_hz(system, rpm)))
        spm = REFERENCE_STEPS_PER_MESH
        _, st0 = simulate_steady(system, rpm, 0, n_tr, spm, ("dte",), **ref_kw)
        res_ref, _ = simulate_steady(system, rpm, 0, periods, spm, ("dte",), st0, "step", **ref_kw)
        x_ref = res_ref.channel("dte")
        motion = classify_motion(x_ref[spm - 1 :: spm], scale=float(np.ptp(x_ref))).label
        cut = auto_modal_cutoff_hz(mesh_frequency_hz(system, rpm), 20000.0) if reduced else None
        res_def, _ = simulate_steady(
            system, rpm, settle, periods, 32, ("dte",), st0, "step", modal_cutoff_hz=cut
        )
        rms_ref = float(np.sqrt(np.mean(x_ref**2)))
        rms_def = float(np.sqrt(np.mean(res_def.channel("dte") ** 2)))
        res_full, _ = simulate_steady(system, rpm, settle, periods, 32, ("dte",), st0, "step")
        rms_full = float(np.sqrt(np.mean(res_full.channel("dte") ** 2)))
        rows.append(
            {
                "temperature_c": temp,
                "speed_rpm": rpm,
                "motion": motion,
                "rms_dte_error_pct": 100.0 * (rms_def / rms_ref - 1.0),
                "default_steps_per_mesh": int(res_def.steps_per_mesh),
                "default_modal_cutoff_hz": cut,
                "full_rule_error_pct": 100.0 * (rms_full / rms_ref - 1.0),
            }
        )
    counted = [abs(r["rms_dte_error_pct"]) for r in rows if r["motion"] != "chaotic"]
    return {
        "speedup_vs_full": rtf["default"] / rtf["full"],
        "max_rms_dte_error_pct": max(counted) if counted else float("nan"),
        "default_model": "reduced" if reduced else "full",
        "rtf_20000rpm_default_vs_full": [rtf["default"], rtf["full"]],
        "accuracy_points": rows,
        "accuracy_reference": f"full model, {REFERENCE_STEPS_PER_MESH} located steps per mesh period",
    }


def benchmark(duration_s: float, quick: bool = True, use_script: bool = True) -> dict[str, Any]:
    """Steps per second and real-time factors of the solver (25 C, A#, the default dt rule).

    Uses ``measure(quick)`` of ``benchmarks/bench_solver.py`` when that script provides it (keys
    ``steps_per_s``, ``rtf_3000rpm``, ``rtf_20000rpm``); otherwise times ``Simulator.advance`` over
    ``duration_s`` simulated seconds after a warm-up chunk (set-up excluded; one process, BLAS
    single-threaded).

    Parameters
    ----------
    duration_s : float
        Simulated seconds per speed of the fallback measurement.
    quick : bool
        Passed to the script's ``measure``.
    use_script : bool
        Try the benchmark script first.
    """
    if use_script:
        measure = _bench_solver_measure()
        if measure is not None:
            try:
                got = dict(measure(quick=quick))
                if {"steps_per_s", "rtf_3000rpm", "rtf_20000rpm"} <= set(got):
                    got.setdefault("method", f"benchmarks/bench_solver.py measure(quick={quick})")
                    got["source"] = "benchmarks/bench_solver.py"
                    if not {"speedup_vs_full", "max_rms_dte_error_pct"} <= set(got):
                        got.update(default_against_full(periods=200 if quick else 400))
                    return got
            except Exception as exc:
                msg = f"reproduce: bench_solver.measure failed ({exc!r}); timing Simulator.advance"
                print(msg, file=sys.stderr)

    from gear_rotor_sim.analysis.bifurcation import restore_blas_threads, set_blas_threads
    from gear_rotor_sim.examples import paper_gearbox
    from gear_rotor_sim.simulator import Simulator

    out: dict[str, Any] = {}
    rates = []
    blas_before = set_blas_threads(1)  # one core
    try:
        for rpm in (3000.0, 20000.0):
            sim = Simulator(
                paper_gearbox(),
                speed_rpm=rpm,
                temperature_c=25.0,
                output_rate_hz=10000.0,
                channels=["dte"],
                steps_per_mesh=32,
            )
            sim.advance(min(0.01, duration_s))
            t0 = time.perf_counter()
            sim.advance(duration_s)
            wall = time.perf_counter() - t0
            rates.append(duration_s / sim.dt / wall)  # steps as integrated (the rule sets dt)
            out[f"rtf_{int(rpm)}rpm"] = duration_s / wall
    finally:
        restore_blas_threads(blas_before)
    out["steps_per_s"] = float(np.mean(rates))
    out["method"] = (
        f"Simulator.advance over {duration_s:g} s simulated, timed after a warm-up chunk, one process, "
        "DTE channel at 10 kHz, the default dt rule"
    )
    out["source"] = "reproduce.benchmark"
    # the smallest check (tests): one periodic point, short windows
    out.update(default_against_full(((25.0, 1000.0),), periods=40, transient_s=0.3, settle=10, repeats=1))
    return out
