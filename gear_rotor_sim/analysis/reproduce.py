"""``gear-rotor-sim reproduce``: the paper's Section 4 results side by side with this model.

Regenerates ``docs/REPRODUCTION.md`` and ``docs/figures/*.png`` (and caches the raw results as
``docs/figures/data/*.npz``). ``--quick`` uses a coarser speed grid and shorter windows (< 5 min
on the 2-core development machine); ``--json`` prints one JSON object with the key numbers.

What is computed
----------------
* Fig 6: bifurcation diagrams (25 C; 225 C with and without thermal backlash), motion windows,
  the chaotic windows against the paper's, and the wall time of panel (a) with set-up included.
* Fig 7: RMS total force of bearing 2 against speed at 25/125/225 C (A#), the quoted points.
* Fig 8/9/10: one speed (19000 rpm), 25/125/225 C x A#/B#/C#: node displacement amplitudes,
  force shares per direction, bearing-2 orbits.
* Sensitivity of the Fig 7 points at 1000 rpm to the parameters the paper does not give (mesh
  damping ratio, friction coefficient, shaft Rayleigh damping).
* Solver benchmark: steps per second and real-time factors at 3000 and 20000 rpm.

The paper's numbers are in :mod:`~gear_rotor_sim.analysis.paper_data`, the Markdown report in
:mod:`~gear_rotor_sim.analysis.reproduction_report`.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from gear_rotor_sim.analysis.bifurcation import (
    BifurcationResult,
    Case,
    RunSettings,
    build_config,
    run_bifurcation,
)
from gear_rotor_sim.analysis.paper_data import (
    INV_ISO_SCALE,
    ISO_SCALE,
    PANEL_TITLES,
    PANELS,
    PAPER_CHAOS,
    PAPER_FIG7,
    PAPER_FIG8,
    PAPER_POINTS,
    STIFFNESS_SCALES,
    rel_error,
)
from gear_rotor_sim.analysis.reproduction_report import PUBLISHED_CONFIG, main_band, write_report
from gear_rotor_sim.analysis.sweep import grid_cases, run_sweep
from gear_rotor_sim.examples import PAPER_CONFIGS

#: The configuration of the main reproduction (the physically consistent model).
DEFAULT_CONFIG = PAPER_CONFIGS[0]


# ----------------------------------------------------------------------------------------------- plan
@dataclass(frozen=True)
class Plan:
    """How much to compute.

    Attributes
    ----------
    name : str
        ``"full"``, ``"quick"`` or ``"tiny"`` (tests).
    fig6_speeds : tuple of float
        Bifurcation grid.
    fig6 : RunSettings
        Window per speed of the bifurcation runs.
    fig7_speeds : tuple of float
        Fig 7 grid (always contains 1000 and 14400 rpm).
    sweep : RunSettings
        Window per speed of the force/displacement sweeps.
    fig8_bearings : tuple of str
        Bearing types of the 19000 rpm study.
    sensitivity : bool
        Run the parameter-sensitivity study.
    bench_duration_s : float
        Simulated seconds per benchmark speed.
    single_speed_figures : bool
        Draw the phase portraits, Poincare maps and spectra at 3000 and 14000 rpm.
    stiffness_scales : tuple of float
        Mesh-stiffness scales of the stiffness study (Fig 7 sweep and 19000 rpm point per scale);
        empty: no stiffness study.
    stiffness_bifurcations : tuple of (str, float)
        (Fig 6 panel key, scale) bifurcation runs of the stiffness study (scale 1 is the main run).
    """

    name: str
    fig6_speeds: tuple[float, ...]
    fig6: RunSettings
    fig7_speeds: tuple[float, ...]
    sweep: RunSettings
    fig8_bearings: tuple[str, ...]
    sensitivity: bool
    bench_duration_s: float
    single_speed_figures: bool = True
    stiffness_scales: tuple[float, ...] = ()
    stiffness_bifurcations: tuple[tuple[str, float], ...] = ()

    @staticmethod
    def level(name: str) -> Plan:
        def grid(n: int) -> tuple[float, ...]:
            return tuple(float(s) for s in np.round(np.linspace(500.0, 20000.0, n), 1))

        def fig7(n: int) -> tuple[float, ...]:
            return tuple(float(s) for s in np.union1d(np.linspace(500.0, 20000.0, n), [1000.0, 14400.0]))

        if name == "full":
            return Plan(
                "full",
                grid(400),
                RunSettings(300, 200, 32, 4.0),
                fig7(79),
                RunSettings(300, 200, 32, 4.0),
                ("A#", "B#", "C#"),
                True,
                0.5,
                stiffness_scales=STIFFNESS_SCALES,
                stiffness_bifurcations=(
                    ("25C", INV_ISO_SCALE),
                    ("25C", 0.87),
                    ("25C", 1.15),
                    ("25C", ISO_SCALE),
                    ("225C", INV_ISO_SCALE),
                    ("225C", ISO_SCALE),
                    ("225C_fixed", INV_ISO_SCALE),
                    ("225C_fixed", ISO_SCALE),
                ),
            )
        if name == "quick":
            return Plan(
                "quick",
                grid(80),
                RunSettings(150, 100, 32, 4.0),
                fig7(14),
                RunSettings(150, 100, 32, 4.0),
                ("A#", "B#", "C#"),
                True,
                0.1,
                stiffness_scales=STIFFNESS_SCALES,
                stiffness_bifurcations=(("25C", INV_ISO_SCALE), ("25C", ISO_SCALE)),
            )
        if name == "tiny":
            return Plan(
                "tiny",
                grid(2),
                RunSettings(10, 20, 16, 2.0),
                (1000.0, 14400.0),
                RunSettings(20, 20, 16, 4.0),
                ("A#",),
                False,
                0.005,
                False,
            )
        raise ValueError(f"level: {name!r} is not 'full', 'quick' or 'tiny'")


# ----------------------------------------------------------------------------------------------- helpers
def static_axial_estimate(temperature_c: float, bearing_type: str = "A#") -> dict[str, float]:
    """Closed-form axial thermal bearing force and end displacement of the input shaft.

    A free shaft of length L would grow by ``alpha dT L``; held by two axial bearing springs k_b
    in series with the shaft's axial stiffness ``k_s = E(T) A / L`` the growth is shared, so
    ``F = k_s alpha dT L / (1 + 2 k_s / k_b)`` and each end moves ``u = F / k_b``.
    """
    cfg = build_config(Case(temperature_c, bearing_type))
    shaft = cfg.shafts[0]
    mat = cfg.materials[shaft.elements[0].material] if hasattr(shaft.elements[0], "material") else None
    if mat is None:
        mat = next(iter(cfg.materials.values()))
    length = sum(e.length_m for e in shaft.elements)
    d_out = shaft.elements[0].outer_diameter_m
    d_in = shaft.elements[0].inner_diameter_m
    area = np.pi / 4 * (d_out**2 - d_in**2)
    k_s = mat.youngs_modulus(temperature_c) * area / length
    k_b = cfg.bearings[0].properties.k_axial
    dt = temperature_c - cfg.reference_temperature_c
    force = k_s * mat.expansion_coefficient * dt * length / (1.0 + 2.0 * k_s / k_b)
    return {
        "force_n": float(force),
        "displacement_um": float(force / k_b * 1e6),
        "k_shaft": float(k_s),
        "k_bearing": float(k_b),
    }


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


def _data_dir(out: Path) -> Path:
    d = out / "figures" / "data"
    d.mkdir(parents=True, exist_ok=True)
    return d


def _label_at(res: BifurcationResult, speed: float) -> str:
    i = int(np.argmin(np.abs(res.speeds_rpm - speed)))
    return f"{res.labels()[i]} ({res.speeds_rpm[i]:.0f} rpm)"


def _condensed(
    windows: list[tuple[str, float, float]], min_points: int, speeds: np.ndarray
) -> list[tuple[str, float, float]]:
    """Motion windows with runs shorter than ``min_points`` grid speeds absorbed by neighbours."""
    ds = float(np.mean(np.diff(speeds))) if speeds.size > 1 else 1.0
    out: list[tuple[str, float, float]] = []
    for lab, lo, hi in windows:
        n = round((hi - lo) / ds) + 1
        if out and (n < min_points or out[-1][0] == lab):
            out[-1] = (out[-1][0], out[-1][1], hi)
        else:
            out.append((lab, lo, hi))
    merged: list[tuple[str, float, float]] = []
    for w in out:
        if merged and merged[-1][0] == w[0]:
            merged[-1] = (w[0], merged[-1][1], w[2])
        else:
            merged.append(w)
    return merged


def _overlap(model: list[tuple[float, float]], paper: tuple[float, float]) -> tuple[float, float, float]:
    """Model chaotic extent within +-1500 rpm of a paper window: (lo, hi, Jaccard index)."""
    lo_p, hi_p = paper
    near = [(a, b) for a, b in model if b >= lo_p - 1500 and a <= hi_p + 1500]
    if not near:
        return float("nan"), float("nan"), 0.0
    lo, hi = min(a for a, _ in near), max(b for _, b in near)
    inter = max(0.0, min(hi, hi_p) - max(lo, lo_p))
    union = max(hi, hi_p) - min(lo, lo_p)
    return lo, hi, inter / union if union > 0 else 0.0


# ----------------------------------------------------------------------------------------------- the run
def compute(
    plan: Plan,
    out: Path,
    workers: int | None,
    scheduler: str | None,
    progress: bool,
    config: str = DEFAULT_CONFIG,
) -> dict[str, Any]:
    """Run every study of ``plan``; save caches and figures under ``out``; return the numbers.

    ``config`` names the paper configuration (:data:`gear_rotor_sim.examples.PAPER_CONFIGS`); a
    non-default one writes its figures to ``out/figures/<config>/``, prefixes its caches with the
    name and adds the finely resolved Fig 6a main band (:func:`refine_main_band`).
    """
    from gear_rotor_sim.analysis import figures

    data_dir = _data_dir(out)
    tag = "" if config == DEFAULT_CONFIG else f"{config}_"
    fig_dir = out / "figures" if config == DEFAULT_CONFIG else out / "figures" / config
    panels = {k: dataclasses.replace(c, config=config) for k, c in PANELS.items()}
    r: dict[str, Any] = {"level": plan.name, "config": config}

    # Fig 6 ---------------------------------------------------------------------------------------
    bif: dict[str, BifurcationResult] = {}
    load_avg: dict[str, list[float]] = {}
    for key, case in panels.items():
        load_before = _loadavg()
        t0 = time.perf_counter()
        res = run_bifurcation(
            case,
            np.array(plan.fig6_speeds),
            plan.fig6,
            workers=workers,
            scheduler=scheduler,
            progress=progress,
        )
        res.wall_time_s = time.perf_counter() - t0
        load_avg[key] = [load_before, _loadavg()]
        res.meta["loadavg_1min_before_after"] = load_avg[key]
        res.save(data_dir / f"{tag}fig6_{key}.npz")
        bif[key] = res
    figures.plot_bifurcation(
        [bif[k] for k in PANELS],
        fig_dir / "fig6_bifurcation.png",
        [PANEL_TITLES[k] for k in PANELS],
        [PAPER_CHAOS[k] for k in PANELS],
    )
    fig6: dict[str, Any] = {}
    for key, res in bif.items():
        labels = res.labels()
        model_chaos = res.chaotic_windows(merge_gap=1)
        windows = res.windows()
        low = (res.speeds_rpm >= 500) & (res.speeds_rpm <= 7300)
        fig6[key] = {
            "case": res.case.label(),
            "n_speeds": int(res.speeds_rpm.size),
            "n_periods": res.settings.n_periods,
            "wall_time_s": res.wall_time_s,
            "workers": res.meta.get("workers"),
            "loadavg_1min_before_after": load_avg[key],
            "period1_fraction_500_7300": float(
                np.mean([lab == "period-1" for lab, m in zip(labels, low, strict=True) if m])
            ),
            "chaotic_windows": model_chaos,
            "paper_chaotic_windows": list(PAPER_CHAOS[key]),
            "main_window_vs_paper": [_overlap(model_chaos, w) for w in PAPER_CHAOS[key]],
            "sequence": _condensed(windows, 3, res.speeds_rpm),
            "counts": {lab: int(sum(1 for x in labels if x == lab)) for lab in sorted(set(labels))},
        }
    fig6["points"] = [(k, s, p, _label_at(bif[k], s)) for k, s, p in PAPER_POINTS]
    r["fig6"] = fig6
    if config != DEFAULT_CONFIG:
        main = {
            c: max(mesh_modes(1.0, config=c), key=lambda m: m["mesh_energy"])
            for c in (DEFAULT_CONFIG, config)
        }
        r["mesh_mode"] = {
            "default_hz": main[DEFAULT_CONFIG]["f_hz"],
            "default_rpm": main[DEFAULT_CONFIG]["speed_rpm"],
            "config_hz": main[config]["f_hz"],
            "config_rpm": main[config]["speed_rpm"],
        }
        r["fig6_25c_main_band_fine"] = refine_main_band(
            panels["25C"], bif["25C"].chaotic_windows(merge_gap=1), plan.fig6
        )
        if config == PUBLISHED_CONFIG and plan.name != "tiny":
            from gear_rotor_sim.analysis.readings import edge_sensitivity, readings_study

            # readings of the paper's text tried against the Fig 6 bands (docs/REPRODUCTION.md), and
            # the 25 C band against the parameters the paper does not give
            r["readings"] = readings_study(plan.fig6, np.array(plan.fig6_speeds))
            r["edge_sensitivity"] = edge_sensitivity(plan.fig6)
    if plan.single_speed_figures:
        _single_speed_figures(fig_dir, plan)

    # Fig 7 ---------------------------------------------------------------------------------------
    s7 = run_sweep(
        _with_config(grid_cases([25.0, 125.0, 225.0], ["A#"]), config),
        np.array(plan.fig7_speeds),
        plan.sweep,
        workers=workers,
        scheduler=scheduler,
        progress=progress,
    )
    s7.save(data_dir / f"{tag}fig7_sweep.npz")
    figures.plot_bearing_force(
        s7, fig_dir / "fig7_bearing_force.png", paper_points=[(t, s, f) for t, s, f in PAPER_FIG7]
    )
    r["fig7"] = [
        {
            "temperature_c": t,
            "speed_rpm": s,
            "paper_n": f,
            "model_n": float(s7.get("bearing_total_rms", s7.index(t), s)[1]),
            "model_rms_xyz_n": [float(v) for v in s7.get("bearing_rms", s7.index(t), s)[1]],
        }
        for t, s, f in PAPER_FIG7
    ]
    for row in r["fig7"]:
        row["rel_error"] = rel_error(row["model_n"], row["paper_n"])
    r["fig9_1000rpm_A"] = {
        f"{t:g}": {
            k: [float(v) for v in s7.force_shares(s7.index(t), 1000.0, 2, k)] for k in ("rms", "power")
        }
        for t in (25.0, 125.0, 225.0)
    }

    # Figs 8-10 ------------------------------------------------------------------------------------
    s19 = run_sweep(
        _with_config(grid_cases([25.0, 125.0, 225.0], list(plan.fig8_bearings)), config),
        np.array([19000.0]),
        plan.sweep,
        workers=workers,
        scheduler=scheduler,
        progress=progress,
    )
    s19.save(data_dir / f"{tag}fig8_10_sweep_19000rpm.npz")
    bts = list(plan.fig8_bearings)
    figures.plot_displacement(
        s19,
        fig_dir / "fig8_displacement.png",
        19000.0,
        bearing_types=bts,
        paper_points=[p for p in PAPER_FIG8 if p[0] in bts],
    )
    figures.plot_force_share(s19, fig_dir / "fig9_force_share.png", 19000.0, bearing_types=bts, kind="power")
    figures.plot_orbit(s19, fig_dir / "fig10_orbit.png", 19000.0, bearing_types=bts)
    r["fig8"] = [
        {
            "bearing_type": bt,
            "temperature_c": t,
            "node": n,
            "paper_um": v,
            "model_um": float(s19.get("node_amp_max", s19.index(t, bt), 19000.0)[n - 1] * 1e6),
            "model_rms_um": float(s19.get("node_amp_rms", s19.index(t, bt), 19000.0)[n - 1] * 1e6),
            "static_estimate_um": static_axial_estimate(t, bt)["displacement_um"]
            if t != 25.0
            else float("nan"),
        }
        for bt, t, n, v in PAPER_FIG8
        if bt in bts
    ]
    for row in r["fig8"]:
        row["rel_error"] = rel_error(row["model_um"], row["paper_um"])
    r["fig9_19000rpm"] = {
        f"{bt} {t:g}": {
            k: [float(v) for v in s19.force_shares(s19.index(t, bt), 19000.0, 2, k)] for k in ("rms", "power")
        }
        for bt in bts
        for t in (25.0, 125.0, 225.0)
    }
    r["fig10_orbit_center_um"] = {
        f"{bt} {t:g}": [float(v) for v in s19.get("orbit", s19.index(t, bt), 19000.0)[0].mean(axis=0) * 1e6]
        for bt in bts
        for t in (25.0, 125.0, 225.0)
    }
    r["static_axial"] = {f"{t:g}": static_axial_estimate(t) for t in (125.0, 225.0)}

    # Sensitivity ---------------------------------------------------------------------------------
    if plan.sensitivity:
        variants = [
            ("damping_ratio", 0.03),
            ("damping_ratio", 0.07),
            ("damping_ratio", 0.1),
            ("friction_coefficient", 0.0),
            ("friction_coefficient", 0.05),
            ("friction_coefficient", 0.1),
            ("stiffness_s", 0.0),
            ("stiffness_s", 1e-6),
        ]
        cases = grid_cases([25.0, 125.0, 225.0], ["A#"], [True], [((k, v),) for k, v in variants])
        ss = run_sweep(
            cases,
            np.array([1000.0, 14400.0]),
            plan.sweep,
            workers=workers,
            scheduler=scheduler,
            progress=progress,
        )
        ss.save(data_dir / "sensitivity.npz")
        rows = []
        for c_i, c in enumerate(ss.cases):
            (k, v) = c.overrides[0]
            rows.append(
                {
                    "parameter": k,
                    "value": v,
                    "temperature_c": c.temperature_c,
                    "f_1000rpm_n": float(ss.get("bearing_total_rms", c_i, 1000.0)[1]),
                    "f_14400rpm_n": float(ss.get("bearing_total_rms", c_i, 14400.0)[1]),
                }
            )
        r["sensitivity"] = rows
        figures.plot_sensitivity(
            [
                {"label": f"{x['parameter']}={x['value']:g}", "value": x["f_1000rpm_n"]}
                for x in rows
                if x["temperature_c"] == 25.0
            ],
            fig_dir / "sensitivity_fig7_25C_1000rpm.png",
            1088.0,
            "Bearing 2 RMS force at 1000 rpm, 25 C, vs unstated parameters",
            "RMS total force (N)",
        )

    # Mesh-stiffness scale --------------------------------------------------------------------------
    if plan.stiffness_scales:
        r["stiffness"] = _stiffness_study(plan, bif, s7, data_dir, fig_dir, workers, scheduler, progress)

    # Benchmark -----------------------------------------------------------------------------------
    r["benchmark"] = benchmark(
        plan.bench_duration_s, quick=plan.name != "full", use_script=plan.name != "tiny"
    )
    return r


def _with_config(cases: list[Case], config: str) -> list[Case]:
    return [dataclasses.replace(c, config=config) for c in cases]


def merge_windows(windows: list[tuple[float, float]], gap_rpm: float) -> list[tuple[float, float]]:
    """Chaotic windows joined where the gap between them is below ``gap_rpm`` (sorted by start)."""
    out: list[list[float]] = []
    for a, b in sorted(windows):
        if out and a - out[-1][1] < gap_rpm:
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    return [(float(a), float(b)) for a, b in out]


def _fine_band(
    case: Case,
    lo: float,
    hi: float,
    settings: RunSettings,
    step_rpm: float,
    margin_rpm: float,
    gap_rpm: float,
) -> tuple[tuple[float, float], list[tuple[float, float]], np.ndarray]:
    speeds = np.arange(max(lo - margin_rpm, 500.0), hi + margin_rpm + step_rpm / 2, step_rpm)
    res = run_bifurcation(case, speeds, settings, workers=1, progress=False)
    fine = res.chaotic_windows(merge_gap=1)
    joined = [w for w in merge_windows(fine, gap_rpm) if w[1] >= lo and w[0] <= hi]
    band = max(joined, key=lambda w: w[1] - w[0]) if joined else (float("nan"), float("nan"))
    return band, fine, speeds


def refine_main_band(
    case: Case,
    coarse_windows: list[tuple[float, float]],
    settings: RunSettings,
    step_rpm: float = 25.0,
    margin_rpm: float = 750.0,
    gap_rpm: float = 250.0,
    check_steps_rpm: tuple[float, ...] = (20.0, 50.0),
) -> dict[str, Any]:
    """The Fig 6a main chaotic band with its edges resolved to ``step_rpm``.

    The coarse main band (chaotic windows closer than ``gap_rpm`` joined, then the widest one above
    11000 rpm) is re-swept from ``margin_rpm`` below to ``margin_rpm`` above on a ``step_rpm`` grid,
    in one segment (speeds increasing, each run continued from the previous one, as the coarse
    sweep does inside a segment). The band is the widest joined fine window overlapping the coarse
    band; its edges are accurate to one ``step_rpm``. The sweep is repeated on the grids of
    ``check_steps_rpm`` (other speeds, other continuation paths) to show how far the edges move.

    Returns
    -------
    dict
        ``band_rpm`` [low, high], ``coarse_band_rpm``, ``windows_rpm`` (fine, unjoined),
        ``step_rpm``, ``gap_rpm``, ``grid_rpm`` [first, last], ``other_grids`` (``step_rpm``,
        ``band_rpm`` per check grid), ``wall_time_s``.
    """
    lo, hi = main_band(merge_windows(coarse_windows, gap_rpm))
    if not np.isfinite(lo):
        return {"band_rpm": [float("nan"), float("nan")], "coarse_band_rpm": [lo, hi]}
    t0 = time.perf_counter()
    band, fine, speeds = _fine_band(case, lo, hi, settings, step_rpm, margin_rpm, gap_rpm)
    others = []
    for step in check_steps_rpm:
        b, _, _ = _fine_band(case, lo, hi, settings, step, margin_rpm, gap_rpm)
        others.append({"step_rpm": step, "band_rpm": [b[0], b[1]]})
    return {
        "band_rpm": [band[0], band[1]],
        "coarse_band_rpm": [lo, hi],
        "windows_rpm": fine,
        "step_rpm": step_rpm,
        "gap_rpm": gap_rpm,
        "grid_rpm": [float(speeds[0]), float(speeds[-1])],
        "other_grids": others,
        "wall_time_s": time.perf_counter() - t0,
    }


def _loadavg() -> float:
    """1-minute load average (NaN where unavailable)."""
    try:
        import os

        return float(os.getloadavg()[0])
    except (AttributeError, OSError):
        return float("nan")


def iso_stiffness_ratio(temperature_c: float = 25.0) -> dict[str, float]:
    """Mean potential-energy mesh stiffness of the model against ISO 6336-1 ``c_gamma_alpha b``."""
    from gear_rotor_sim.analysis.bifurcation import build_system
    from gear_rotor_sim.gears import paper_gear_pair

    cfg = build_config(Case(temperature_c))
    mat = cfg.materials[cfg.gears[0].material]
    iso = paper_gear_pair(mat).iso_mesh_stiffness(temperature_c)["mesh_stiffness"]
    k_pe = float(build_system(Case(temperature_c)).meshes[0].mean_stiffness)
    return {"k_pe": k_pe, "k_iso": float(iso), "iso_over_pe": float(iso) / k_pe}


def mesh_modes(
    scale: float, temperature_c: float = 25.0, min_fraction: float = 0.05, config: str = DEFAULT_CONFIG
) -> list[dict[str, float]]:
    """Natural frequencies of the model linearised with the mean mesh stiffness, and the share of
    each mode's strain energy stored in the mesh (modes with share >= ``min_fraction``, < 20 kHz).

    Returns
    -------
    list of dict
        ``f_hz``, ``mesh_energy`` (fraction) and ``speed_rpm`` at which the mesh frequency equals
        ``f_hz`` (``60 f / z1``).
    """
    import scipy.linalg as sla

    from gear_rotor_sim.analysis.bifurcation import build_system

    system = build_system(
        Case(temperature_c, overrides=(("mesh_stiffness_scale", float(scale)),), config=config)
    )
    m = system.meshes[0]
    v = m.line_of_action
    f = system.free_dofs
    k = system.K + m.mean_stiffness * np.outer(v, v)
    w2, x = sla.eigh(k[np.ix_(f, f)], system.M[np.ix_(f, f)])
    share = m.mean_stiffness * (v[f] @ x) ** 2 / np.abs(w2)
    fr = np.sqrt(np.abs(w2)) / (2 * np.pi)
    return [
        {"f_hz": float(a), "mesh_energy": float(b), "speed_rpm": float(a * 60.0 / m.pinion_teeth)}
        for a, b in zip(fr, share, strict=True)
        if b >= min_fraction and a < 20000.0
    ]


def _stiffness_study(
    plan: Plan,
    bif: dict[str, BifurcationResult],
    s7: Any,
    data_dir: Path,
    fig_dir: Path,
    workers: int | None,
    scheduler: str | None,
    progress: bool,
) -> dict[str, Any]:
    """Fig 6 band location, Fig 7 curves and the 19000 rpm Fig 8 points against the mesh-stiffness scale.

    The scale multiplies the potential-energy mesh stiffness at every phase (damping ratio kept,
    :func:`gear_rotor_sim.analysis.bifurcation.scale_mesh_stiffness`); scale 1 is the model of the
    other sections, ``ISO_SCALE`` makes its mean equal to the ISO 6336-1 value.
    """
    from gear_rotor_sim.analysis import figures

    out: dict[str, Any] = {
        "iso": iso_stiffness_ratio(25.0),
        "scales": list(plan.stiffness_scales),
        "modes": {f"{sc:g}": mesh_modes(sc) for sc in plan.stiffness_scales},
    }
    # Fig 6: band location per (panel, scale)
    rows = []
    results: dict[tuple[str, float], BifurcationResult] = {(k, 1.0): v for k, v in bif.items()}
    for key, scale in plan.stiffness_bifurcations:
        base = PANELS[key]
        case = dataclasses.replace(base, overrides=(("mesh_stiffness_scale", float(scale)),))
        t0 = time.perf_counter()
        res = run_bifurcation(
            case,
            np.array(plan.fig6_speeds),
            plan.fig6,
            workers=workers,
            scheduler=scheduler,
            progress=progress,
        )
        res.wall_time_s = time.perf_counter() - t0
        res.save(data_dir / f"fig6_{key}_k{scale:g}.npz")
        results[(key, float(scale))] = res
    for (key, scale), res in sorted(results.items(), key=lambda kv: (list(PANELS).index(kv[0][0]), kv[0][1])):
        if not any(k == key for k, _ in plan.stiffness_bifurcations):
            continue
        paper = PAPER_CHAOS[key][0]
        base_lo, base_hi = main_band(bif[key].chaotic_windows(merge_gap=1))
        chaos = res.chaotic_windows(merge_gap=1)
        lo, hi, jac = _overlap(chaos, paper)
        main_lo, main_hi = main_band(chaos)
        rows.append(
            {
                "panel": key,
                "scale": scale,
                "chaotic_windows": chaos,
                "main_band": [main_lo, main_hi],
                "near_paper": [lo, hi],
                "jaccard": jac,
                "paper": list(paper),
                "pred_lo": base_lo * np.sqrt(scale),
                "pred_hi": base_hi * np.sqrt(scale),
                "wall_time_s": res.wall_time_s,
                "label_at_paper_mid": _label_at(res, 0.5 * (paper[0] + paper[1])),
                "sequence": _condensed(res.windows(), 3, res.speeds_rpm),
            }
        )
    out["fig6"] = rows
    # the main band (the widest chaotic window above 12000 rpm) for the figure
    fig_rows = [
        {
            "panel": x["panel"],
            "scale": x["scale"],
            "lo": x["main_band"][0],
            "hi": x["main_band"][1],
            "pred_lo": x["pred_lo"],
            "pred_hi": x["pred_hi"],
        }
        for x in rows
    ]
    figures.plot_band_vs_scale(
        fig_rows,
        fig_dir / "fig6_band_vs_stiffness_scale.png",
        {k: PAPER_CHAOS[k][0] for k in PANELS},
        PANEL_TITLES,
    )
    panel25 = [results[("25C", sc)] for sc in sorted({sc for k, sc in results if k == "25C"})]
    figures.plot_bifurcation(
        panel25,
        fig_dir / "fig6_25C_stiffness_scales.png",
        [
            f"(a) 25 C, mesh stiffness x {dict(r.case.overrides).get('mesh_stiffness_scale', 1.0):g}"
            for r in panel25
        ],
        [PAPER_CHAOS["25C"]] * len(panel25),
    )
    # Fig 7 curves and Fig 8 points per scale
    scaled = [sc for sc in plan.stiffness_scales if sc != 1.0]
    overrides = [(("mesh_stiffness_scale", float(sc)),) for sc in scaled]
    s7k = run_sweep(
        grid_cases([25.0, 125.0, 225.0], ["A#"], [True], overrides),
        np.array(plan.fig7_speeds),
        plan.sweep,
        workers=workers,
        scheduler=scheduler,
        progress=progress,
    )
    s7k.save(data_dir / "fig7_sweep_stiffness_scales.npz")
    figures.plot_bearing_force_scales(
        s7k,
        fig_dir / "fig7_stiffness_scales.png",
        plan.stiffness_scales,
        paper_points=PAPER_FIG7,
        base=s7,
    )
    s19k = run_sweep(
        grid_cases([25.0, 125.0, 225.0], ["A#"], [True], overrides),
        np.array([19000.0]),
        plan.sweep,
        workers=workers,
        scheduler=scheduler,
        progress=progress,
    )
    s19k.save(data_dir / "fig8_19000rpm_stiffness_scales.npz")
    f7rows = []
    for sc in plan.stiffness_scales:
        for t, sp, paper_n in PAPER_FIG7:
            if sc == 1.0:
                src, ci = s7, s7.index(t)
            else:
                src, ci = s7k, s7k.index(t, overrides=(("mesh_stiffness_scale", float(sc)),))
            f2 = src.data["bearing_total_rms"][ci, :, 1]
            f7rows.append(
                {
                    "scale": sc,
                    "temperature_c": t,
                    "speed_rpm": sp,
                    "paper_n": paper_n,
                    "model_n": float(src.get("bearing_total_rms", ci, sp)[1]),
                    "peak_speed_rpm": float(src.speeds_rpm[int(np.argmax(f2))]),
                    "peak_n": float(np.max(f2)),
                }
            )
    out["fig7"] = f7rows
    f8rows = []
    for sc in scaled:
        for bt, t, node, paper_um in PAPER_FIG8:
            if bt != "A#" or node != 9:
                continue
            ci = s19k.index(t, overrides=(("mesh_stiffness_scale", float(sc)),))
            f8rows.append(
                {
                    "scale": sc,
                    "temperature_c": t,
                    "paper_um": paper_um,
                    "model_um": float(s19k.get("node_amp_max", ci, 19000.0)[node - 1] * 1e6),
                }
            )
    out["fig8_node9"] = f8rows
    return out


def _single_speed_figures(fig_dir: Path, plan: Plan) -> None:
    """Phase portrait, Poincare map and spectra at representative speeds of Fig 6a."""
    from gear_rotor_sim.analysis import figures
    from gear_rotor_sim.analysis.bifurcation import build_system, mesh_period_s, steady_run
    from gear_rotor_sim.analysis.classify import classify_motion
    from gear_rotor_sim.analysis.poincare import phase_portrait
    from gear_rotor_sim.analysis.signals import amplitude_spectrum, order_spectrum

    settings = dataclasses.replace(plan.fig6, n_periods=max(plan.fig6.n_periods, 116))
    system = build_system(PANELS["25C"])
    for rpm in (3000.0, 14000.0):
        data, _, used = steady_run(system, rpm, settings, ("dte",), None, first=True)
        spm = used.steps_per_mesh
        fs = spm / mesh_period_s(system, rpm)
        pp = phase_portrait(data[:, 0], fs, spm, offset=spm - 1)
        m = classify_motion(np.column_stack([pp.px, pp.pv]), [np.ptp(pp.x), np.ptp(pp.v)])
        title = f"25 C, A#, {rpm:g} rpm: {m.label}"
        figures.plot_phase_portrait(pp, fig_dir / f"phase_25C_{rpm:.0f}rpm.png", title)
        figures.plot_poincare(pp.px, pp.pv, fig_dir / f"poincare_25C_{rpm:.0f}rpm.png", title)
        figures.plot_spectrum(
            amplitude_spectrum(data[:, 0], fs),
            fig_dir / f"spectrum_dte_25C_{rpm:.0f}rpm.png",
            f"DTE spectrum, {title}",
            "m",
        )
        n_rev = (data.shape[0] // (29 * spm)) * 29 * spm
        figures.plot_spectrum(
            order_spectrum(data[:n_rev, 0], fs, rpm, samples_per_rev=29 * spm // 2),
            fig_dir / f"order_spectrum_dte_25C_{rpm:.0f}rpm.png",
            f"DTE order spectrum, {title}",
            "m",
            max_axis=100.0,
        )


# ----------------------------------------------------------------------------------------------- CLI
def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--quick", action="store_true", help="coarser grid and shorter windows (< 5 min)")
    parser.add_argument(
        "--level", choices=("full", "quick", "tiny"), default=None, help="explicit level (tiny: tests)"
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object with the key numbers")
    parser.add_argument("--out", default="docs", help="output directory (REPRODUCTION.md, figures/)")
    parser.add_argument(
        "--workers", type=int, default=None, help="local worker processes (default: all cores)"
    )
    parser.add_argument("--scheduler", default=None, help="Dask scheduler address")
    parser.add_argument("--no-report", action="store_true", help="do not write REPRODUCTION.md")
    parser.add_argument(
        "--config",
        choices=PAPER_CONFIGS,
        default=DEFAULT_CONFIG,
        help="paper configuration (paper_sun2021_as_published: gear mass in Eq 20 and Eq 32, "
        "docs/REPRODUCTION.md); a non-default one skips the sensitivity and stiffness studies, adds "
        "the finely resolved Fig 6a band and the as-published section of REPRODUCTION.md",
    )
    parser.add_argument(
        "--report-only",
        action="store_true",
        help="rewrite REPRODUCTION.md from the saved numbers (no simulation)",
    )


def _fig7_rows(r: dict[str, Any], speed_rpm: float) -> list[dict[str, Any]]:
    keys = ("temperature_c", "paper_n", "model_n", "rel_error")
    return [{k: x[k] for k in keys} for x in r["fig7"] if x["speed_rpm"] == speed_rpm]


def summary_json(r: dict[str, Any]) -> dict[str, Any]:
    """The JSON object printed by ``--json``."""
    b = r["benchmark"]
    return {
        "level": r["level"],
        "fig7_1000rpm": _fig7_rows(r, 1000.0),
        "fig7_14400rpm": _fig7_rows(r, 14400.0),
        "fig8_19000rpm_node9": [
            {
                "temperature_c": x["temperature_c"],
                "paper_um": x["paper_um"],
                "model_um": x["model_um"],
                "rel_error": x["rel_error"],
            }
            for x in r["fig8"]
            if x["node"] == 9 and x["bearing_type"] == "A#"
        ],
        "fig8_19000rpm_node1_225c": [
            {"bearing_type": x["bearing_type"], "paper_um": x["paper_um"], "model_um": x["model_um"]}
            for x in r["fig8"]
            if x["node"] == 1
        ],
        "fig9_axial_share_19000rpm": {k: v["rms"][2] for k, v in r["fig9_19000rpm"].items()},
        "fig6": {
            k: {
                "chaotic_windows": r["fig6"][k]["chaotic_windows"],
                "paper": r["fig6"][k]["paper_chaotic_windows"],
                "wall_time_s": r["fig6"][k]["wall_time_s"],
            }
            for k in PANELS
        },
        "stiffness_scale": _stiffness_json(r),
        "benchmark": {
            "steps_per_s": b["steps_per_s"],
            "rtf_3000rpm": b["rtf_3000rpm"],
            "rtf_20000rpm": b["rtf_20000rpm"],
            "speedup_vs_full": b.get("speedup_vs_full"),
            "max_rms_dte_error_pct": b.get("max_rms_dte_error_pct"),
            "default_model": b.get("default_model"),
        },
    }


def _stiffness_json(r: dict[str, Any]) -> dict[str, Any] | None:
    """Main chaotic band and the Fig 7 points per mesh-stiffness scale (None when not run)."""
    st = r.get("stiffness")
    if not st:
        return None
    return {
        "iso_over_potential_energy": st["iso"]["iso_over_pe"],
        "fig6_main_band": [
            {"panel": x["panel"], "scale": x["scale"], "model_rpm": x["main_band"], "paper_rpm": x["paper"]}
            for x in st["fig6"]
        ],
        "fig7": [
            {k: x[k] for k in ("scale", "temperature_c", "speed_rpm", "paper_n", "model_n")}
            for x in st["fig7"]
        ],
    }


def printed_json(r: dict[str, Any]) -> dict[str, Any]:
    """The object printed by ``--json``: :func:`summary_json`, plus ``fig6_25c_main_chaotic_band_rpm``
    (the finely resolved Fig 6a main band, :func:`refine_main_band`) for a non-default configuration."""
    s = summary_json(r)
    fine = r.get("fig6_25c_main_band_fine")
    if fine is not None:
        s["fig6_25c_main_chaotic_band_rpm"] = fine["band_rpm"]
    return s


def _default_results(out: Path, level: str) -> dict[str, Any] | None:
    """The saved default results REPRODUCTION.md is built from (full, else quick; tiny for tiny)."""
    for lv in ("tiny",) if level == "tiny" else ("full", "quick"):
        p = _data_dir(out) / f"reproduce_{lv}.json"
        if p.is_file():
            return json.loads(p.read_text(encoding="utf-8"))
    return None


def run(args: argparse.Namespace) -> int:
    level = args.level or ("quick" if args.quick else "full")
    config = getattr(args, "config", DEFAULT_CONFIG)
    plan = Plan.level(level)
    if config != DEFAULT_CONFIG:  # the studies of the default model are not repeated
        plan = dataclasses.replace(
            plan,
            sensitivity=False,
            single_speed_figures=False,
            stiffness_scales=(),
            stiffness_bifurcations=(),
        )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    suffix = "" if config == DEFAULT_CONFIG else f"_{config}"
    saved = _data_dir(out) / f"reproduce_{level}{suffix}.json"
    if args.report_only:
        r = json.loads(saved.read_text(encoding="utf-8"))
        base = r if config == DEFAULT_CONFIG else _default_results(out, level)
        path = write_report(base, out, float(base["total_wall_s"])) if base is not None else saved
        print(json.dumps(printed_json(r), default=float) if args.json else f"wrote {path}")
        return 0
    t0 = time.perf_counter()
    r = compute(plan, out, args.workers, args.scheduler, progress=True, config=config)
    total = time.perf_counter() - t0
    r["total_wall_s"] = total
    saved.write_text(json.dumps(r, indent=1, default=float), encoding="utf-8")
    if not args.no_report:
        # REPRODUCTION.md is the default model's report; a non-default run rewrites it from the saved
        # default results with its own section added (reproduction_report.published_section)
        base = r if config == DEFAULT_CONFIG else _default_results(out, level)
        if base is not None:
            path = write_report(base, out, float(base["total_wall_s"]))
            if not args.json:
                print(f"wrote {path} ({total:.0f} s)")
        elif not args.json:
            print(f"saved {saved} ({total:.0f} s); no default results in {out} to write REPRODUCTION.md from")
    if args.json:
        print(json.dumps(printed_json(r), default=float))
    sys.stdout.flush()
    return 0
