"""The Fig 6-10 runs of ``gear-rotor-sim reproduce`` and the numbers each adds to the results.

:func:`~gear_rotor_sim.analysis.reproduce.compute` calls them in order: the bifurcation runs of
Fig 6 (:func:`fig6_runs`) and their summary (:func:`fig6_numbers`), the extras of a non-default
configuration (:func:`config_extras`), the Fig 7 sweep (:func:`fig7_numbers`) and the 19000 rpm
sweep of Figs 8-10 (:func:`figs8_10_numbers`). Each saves its caches and draws its figures under
:class:`Output`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gear_rotor_sim.analysis.bands import condense_windows, label_at, overlap_near
from gear_rotor_sim.analysis.bifurcation import BifurcationResult, Case
from gear_rotor_sim.analysis.paper_data import (
    PANEL_TITLES,
    PANELS,
    PAPER_CHAOS,
    PAPER_FIG7,
    PAPER_FIG8,
    PAPER_POINTS,
    rel_error,
)
from gear_rotor_sim.analysis.report_published import PUBLISHED_CONFIG
from gear_rotor_sim.analysis.reproduce_studies import (
    Runner,
    mesh_modes,
    refine_main_band,
    static_axial_estimate,
)
from gear_rotor_sim.analysis.sweep import SweepResult, grid_cases
from gear_rotor_sim.examples import PAPER_CONFIGS

if TYPE_CHECKING:
    from gear_rotor_sim.analysis.reproduce import Plan

#: The configuration of the main reproduction (the physically consistent model).
DEFAULT_CONFIG = PAPER_CONFIGS[0]


@dataclass(frozen=True)
class Output:
    """Where one reproduce run writes: caches in ``data_dir`` (names prefixed by ``tag``), figures in
    ``fig_dir``."""

    data_dir: Path
    fig_dir: Path
    tag: str


def _loadavg() -> float:
    """1-minute load average (NaN where unavailable)."""
    try:
        import os

        return float(os.getloadavg()[0])
    except (AttributeError, OSError):
        return float("nan")


def _with_config(cases: list[Case], config: str) -> list[Case]:
    return [dataclasses.replace(c, config=config) for c in cases]


def fig6_runs(
    plan: Plan, runner: Runner, panels: dict[str, Case], o: Output
) -> tuple[dict[str, BifurcationResult], dict[str, list[float]]]:
    """The bifurcation run of each Fig 6 panel (saved, drawn), with the load average before and after."""
    from gear_rotor_sim.analysis import figures

    bif: dict[str, BifurcationResult] = {}
    load_avg: dict[str, list[float]] = {}
    for key, case in panels.items():
        load_before = _loadavg()
        res = runner.bifurcation(case, np.array(plan.fig6_speeds), plan.fig6)
        load_avg[key] = [load_before, _loadavg()]
        res.meta["loadavg_1min_before_after"] = load_avg[key]
        res.save(o.data_dir / f"{o.tag}fig6_{key}.npz")
        bif[key] = res
    figures.plot_bifurcation(
        [bif[k] for k in PANELS],
        o.fig_dir / "fig6_bifurcation.png",
        [PANEL_TITLES[k] for k in PANELS],
        [PAPER_CHAOS[k] for k in PANELS],
    )
    return bif, load_avg


def fig6_numbers(bif: dict[str, BifurcationResult], load_avg: dict[str, list[float]]) -> dict[str, Any]:
    """Per panel: motion windows, chaotic windows against the paper's, wall time; the paper's
    single-speed statements against the model's label at the nearest grid speed (``points``)."""
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
            "main_window_vs_paper": [overlap_near(model_chaos, w) for w in PAPER_CHAOS[key]],
            "sequence": condense_windows(windows, 3, res.speeds_rpm),
            "counts": {lab: int(sum(1 for x in labels if x == lab)) for lab in sorted(set(labels))},
        }
    fig6["points"] = [(k, s, p, label_at(bif[k], s)) for k, s, p in PAPER_POINTS]
    return fig6


def config_extras(
    plan: Plan, config: str, panels: dict[str, Case], bif: dict[str, BifurcationResult]
) -> dict[str, Any]:
    """For a non-default configuration: its torsional mesh mode against the default model's, the finely
    resolved Fig 6a main band and, for the as-published one (not at the tiny level), the readings of
    the paper and the 25 C band's sensitivity (:mod:`~gear_rotor_sim.analysis.readings`)."""
    out: dict[str, Any] = {}
    main = {
        c: max(mesh_modes(1.0, config=c), key=lambda m: m["mesh_energy"]) for c in (DEFAULT_CONFIG, config)
    }
    out["mesh_mode"] = {
        "default_hz": main[DEFAULT_CONFIG]["f_hz"],
        "default_rpm": main[DEFAULT_CONFIG]["speed_rpm"],
        "config_hz": main[config]["f_hz"],
        "config_rpm": main[config]["speed_rpm"],
    }
    out["fig6_25c_main_band_fine"] = refine_main_band(
        panels["25C"], bif["25C"].chaotic_windows(merge_gap=1), plan.fig6
    )
    if config == PUBLISHED_CONFIG and plan.name != "tiny":
        from gear_rotor_sim.analysis.readings import edge_sensitivity, readings_study

        # readings of the paper's text tried against the Fig 6 bands (docs/REPRODUCTION.md), and
        # the 25 C band against the parameters the paper does not give
        out["readings"] = readings_study(plan.fig6, np.array(plan.fig6_speeds))
        out["edge_sensitivity"] = edge_sensitivity(plan.fig6)
    return out


def fig7_numbers(plan: Plan, runner: Runner, config: str, o: Output) -> tuple[SweepResult, dict[str, Any]]:
    """The Fig 7 sweep (bearing-2 RMS force against speed at 25/125/225 C, A#; saved, drawn): the quoted
    points against the paper's and the 1000 rpm force shares; returns the sweep too (the stiffness
    study reuses it)."""
    from gear_rotor_sim.analysis import figures

    s7 = runner.sweep(
        _with_config(grid_cases([25.0, 125.0, 225.0], ["A#"]), config), np.array(plan.fig7_speeds), plan.sweep
    )
    s7.save(o.data_dir / f"{o.tag}fig7_sweep.npz")
    figures.plot_bearing_force(
        s7, o.fig_dir / "fig7_bearing_force.png", paper_points=[(t, s, f) for t, s, f in PAPER_FIG7]
    )
    r: dict[str, Any] = {}
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
    return s7, r


def figs8_10_numbers(plan: Plan, runner: Runner, config: str, o: Output) -> dict[str, Any]:
    """The 19000 rpm sweep of Figs 8-10 (saved, drawn): node amplitudes against the paper's with the
    closed-form axial estimate, force shares, orbit centres, the static axial estimates."""
    from gear_rotor_sim.analysis import figures

    s19 = runner.sweep(
        _with_config(grid_cases([25.0, 125.0, 225.0], list(plan.fig8_bearings)), config),
        np.array([19000.0]),
        plan.sweep,
    )
    s19.save(o.data_dir / f"{o.tag}fig8_10_sweep_19000rpm.npz")
    bts = list(plan.fig8_bearings)
    figures.plot_displacement(
        s19,
        o.fig_dir / "fig8_displacement.png",
        19000.0,
        bearing_types=bts,
        paper_points=[p for p in PAPER_FIG8 if p[0] in bts],
    )
    figures.plot_force_share(
        s19, o.fig_dir / "fig9_force_share.png", 19000.0, bearing_types=bts, kind="power"
    )
    figures.plot_orbit(s19, o.fig_dir / "fig10_orbit.png", 19000.0, bearing_types=bts)
    r: dict[str, Any] = {}
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
    return r
