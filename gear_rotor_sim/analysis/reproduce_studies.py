"""The side studies of ``gear-rotor-sim reproduce``: statics in closed form, linear mesh modes, the
finely resolved Fig 6a band, the unstated-parameter sensitivity, the mesh-stiffness-scale study and the
single-speed figures.

Each runs the bifurcation / sweep machinery of :mod:`~gear_rotor_sim.analysis.bifurcation` and
:mod:`~gear_rotor_sim.analysis.sweep` and returns plain numbers (dicts and lists) for the JSON results
and :mod:`~gear_rotor_sim.analysis.reproduction_report`; :mod:`~gear_rotor_sim.analysis.reproduce`
calls them.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gear_rotor_sim.analysis.bands import condense_windows, label_at, main_band, merge_windows, overlap_near
from gear_rotor_sim.analysis.bifurcation import (
    BifurcationResult,
    Case,
    RunSettings,
    build_config,
    run_bifurcation,
)
from gear_rotor_sim.analysis.paper_data import PANEL_TITLES, PANELS, PAPER_CHAOS, PAPER_FIG7, PAPER_FIG8
from gear_rotor_sim.analysis.sweep import SweepResult, grid_cases, run_sweep
from gear_rotor_sim.examples import PAPER_CONFIGS

if TYPE_CHECKING:
    from gear_rotor_sim.analysis.reproduce import Plan


@dataclass(frozen=True)
class Runner:
    """Where the sweeps of one reproduce run execute.

    Attributes
    ----------
    workers : int or None
        Local worker processes (None: all cores).
    scheduler : str or None
        Dask scheduler address (None: local processes).
    progress : bool
        Print progress.
    """

    workers: int | None
    scheduler: str | None
    progress: bool

    def sweep(self, cases: list[Case], speeds_rpm: np.ndarray, settings: RunSettings) -> SweepResult:
        """:func:`~gear_rotor_sim.analysis.sweep.run_sweep` of ``cases`` over ``speeds_rpm``."""
        return run_sweep(
            cases,
            speeds_rpm,
            settings,
            workers=self.workers,
            scheduler=self.scheduler,
            progress=self.progress,
        )

    def bifurcation(self, case: Case, speeds_rpm: np.ndarray, settings: RunSettings) -> BifurcationResult:
        """:func:`~gear_rotor_sim.analysis.bifurcation.run_bifurcation` with ``wall_time_s`` set to the
        wall time of the call (set-up, workers and reduction included)."""
        t0 = time.perf_counter()
        res = run_bifurcation(
            case, speeds_rpm, settings, workers=self.workers, scheduler=self.scheduler, progress=self.progress
        )
        res.wall_time_s = time.perf_counter() - t0
        return res


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
    scale: float, temperature_c: float = 25.0, min_fraction: float = 0.05, config: str = PAPER_CONFIGS[0]
) -> list[dict[str, float]]:
    """Natural frequencies of the model linearised with the mean mesh stiffness, and the share of
    each mode's strain energy stored in the mesh (modes with share >= ``min_fraction``, < 20 kHz).

    Returns
    -------
    list of dict
        ``f_hz``, ``mesh_energy`` (fraction) and ``speed_rpm`` at which the mesh frequency equals
        ``f_hz`` (``60 f / z1``).
    """
    from gear_rotor_sim.analysis.bifurcation import build_system
    from gear_rotor_sim.system import mesh_mode_shares

    system = build_system(
        Case(temperature_c, overrides=(("mesh_stiffness_scale", float(scale)),), config=config)
    )
    m = system.meshes[0]
    fr, share = mesh_mode_shares(system, m.mean_stiffness)
    return [
        {"f_hz": float(a), "mesh_energy": float(b), "speed_rpm": float(a * 60.0 / m.pinion_teeth)}
        for a, b in zip(fr, share, strict=True)
        if b >= min_fraction and a < 20000.0
    ]


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


def sensitivity_study(plan: Plan, runner: Runner, data_dir: Path, fig_dir: Path) -> list[dict[str, Any]]:
    """Bearing-2 RMS force of Fig 7 at 1000 and 14400 rpm with one unstated parameter changed at a time.

    Mesh damping ratio, friction coefficient and shaft Rayleigh damping (``stiffness_s``) at 25, 125
    and 225 C (A#); saves ``sensitivity.npz`` and the 25 C, 1000 rpm bar chart.

    Returns
    -------
    list of dict
        ``parameter``, ``value``, ``temperature_c``, ``f_1000rpm_n``, ``f_14400rpm_n`` per case.
    """
    from gear_rotor_sim.analysis import figures

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
    ss = runner.sweep(cases, np.array([1000.0, 14400.0]), plan.sweep)
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
    return rows


def stiffness_study(
    plan: Plan,
    bif: dict[str, BifurcationResult],
    s7: SweepResult,
    runner: Runner,
    data_dir: Path,
    fig_dir: Path,
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
        res = runner.bifurcation(case, np.array(plan.fig6_speeds), plan.fig6)
        res.save(data_dir / f"fig6_{key}_k{scale:g}.npz")
        results[(key, float(scale))] = res
    for (key, scale), res in sorted(results.items(), key=lambda kv: (list(PANELS).index(kv[0][0]), kv[0][1])):
        if not any(k == key for k, _ in plan.stiffness_bifurcations):
            continue
        paper = PAPER_CHAOS[key][0]
        base_lo, base_hi = main_band(bif[key].chaotic_windows(merge_gap=1))
        chaos = res.chaotic_windows(merge_gap=1)
        lo, hi, jac = overlap_near(chaos, paper)
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
                "label_at_paper_mid": label_at(res, 0.5 * (paper[0] + paper[1])),
                "sequence": condense_windows(res.windows(), 3, res.speeds_rpm),
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
    s7k = runner.sweep(
        grid_cases([25.0, 125.0, 225.0], ["A#"], [True], overrides), np.array(plan.fig7_speeds), plan.sweep
    )
    s7k.save(data_dir / "fig7_sweep_stiffness_scales.npz")
    figures.plot_bearing_force_scales(
        s7k,
        fig_dir / "fig7_stiffness_scales.png",
        plan.stiffness_scales,
        paper_points=PAPER_FIG7,
        base=s7,
    )
    s19k = runner.sweep(
        grid_cases([25.0, 125.0, 225.0], ["A#"], [True], overrides), np.array([19000.0]), plan.sweep
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


def single_speed_figures(fig_dir: Path, plan: Plan) -> None:
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
