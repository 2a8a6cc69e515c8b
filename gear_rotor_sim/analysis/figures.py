"""Matplotlib PNG figures: the paper's Figs 6-10 and single-speed analyses.

Every function draws on a fresh :class:`matplotlib.figure.Figure` (Agg canvas, no pyplot state, no
backend change at import time), writes a PNG and returns its path. Inputs are saved results
(:class:`~gear_rotor_sim.analysis.bifurcation.BifurcationResult`,
:class:`~gear_rotor_sim.analysis.sweep.SweepResult`) or plain arrays, so figures redraw without
re-simulating.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from gear_rotor_sim.analysis.classify import CHAOTIC, QUASI_PERIODIC

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from gear_rotor_sim.analysis.bifurcation import BifurcationResult
    from gear_rotor_sim.analysis.poincare import PhasePortrait
    from gear_rotor_sim.analysis.signals import Spectrum
    from gear_rotor_sim.analysis.sweep import SweepResult

UM = 1e6
TEMP_COLORS = {25.0: "tab:blue", 125.0: "tab:orange", 225.0: "tab:red"}


def _figure(width: float, height: float) -> Figure:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _save(fig: Figure, path: str | Path, dpi: int = 130) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    return path


def _color(t: float) -> str:
    return TEMP_COLORS.get(float(t), "tab:gray")


def plot_bifurcation(
    results: Sequence[BifurcationResult],
    path: str | Path,
    titles: Sequence[str] | None = None,
    paper_chaos: Sequence[Sequence[tuple[float, float]]] | None = None,
    rtol: float = 2e-3,
) -> Path:
    """Fig 6: DTE Poincare samples against speed, one panel per result.

    Parameters
    ----------
    results : sequence of BifurcationResult
        One per panel (e.g. 25 C; 225 C with thermal backlash; 225 C without).
    path : str or Path
        Output PNG.
    titles : sequence of str, optional
        Panel titles (default: the case labels).
    paper_chaos : sequence of list of (lo, hi), optional
        The paper's chaotic windows per panel, drawn as black bars above the points.
    rtol : float
        Classification tolerance; speeds classified chaotic are shaded red, quasi-periodic green.
    """
    fig = _figure(9.0, 2.9 * len(results))
    axes = fig.subplots(len(results), 1, sharex=True, squeeze=False)[:, 0]
    for i, (ax, r) in enumerate(zip(axes, results, strict=True)):
        labels = r.labels(rtol=rtol)
        ds = np.diff(r.speeds_rpm).mean() if r.speeds_rpm.size > 1 else 100.0
        for s, lab in zip(r.speeds_rpm, labels, strict=True):
            if lab == CHAOTIC:
                ax.axvspan(s - ds / 2, s + ds / 2, color="tab:red", alpha=0.12, lw=0)
            elif lab == QUASI_PERIODIC:
                ax.axvspan(s - ds / 2, s + ds / 2, color="tab:green", alpha=0.12, lw=0)
        sp = np.repeat(r.speeds_rpm, r.section.shape[1])
        ax.plot(sp, r.section.ravel() * UM, ",", color="k", alpha=0.6, rasterized=True)
        if paper_chaos is not None and i < len(paper_chaos):
            top = np.nanmax(r.section) * UM
            for lo, hi in paper_chaos[i]:
                ax.plot([lo, hi], [top, top], color="k", lw=4, solid_capstyle="butt")
        ax.set_ylabel("DTE (um)")
        ax.set_title(titles[i] if titles else r.case.label(), fontsize=10)
    axes[-1].set_xlabel("input speed (rpm)")
    fig.suptitle(
        "Bifurcation of the DTE (red: chaotic, green: quasi-periodic; bars: paper's chaos)", fontsize=10
    )
    return _save(fig, path, dpi=150)


def plot_phase_portrait(pp: PhasePortrait, path: str | Path, title: str = "") -> Path:
    """Phase portrait (DTE, DTE velocity) with the Poincare points in red."""
    fig = _figure(5.0, 4.2)
    ax = fig.add_subplot()
    ax.plot(pp.x * UM, pp.v, lw=0.4, color="tab:blue")
    ax.plot(pp.px * UM, pp.pv, "o", ms=3, color="tab:red", label="Poincare points")
    ax.set_xlabel("DTE (um)")
    ax.set_ylabel("DTE velocity (m/s)")
    ax.legend(fontsize=8, loc="upper right")
    ax.set_title(title or "Phase portrait", fontsize=10)
    return _save(fig, path)


def plot_poincare(px: np.ndarray, pv: np.ndarray, path: str | Path, title: str = "") -> Path:
    """Poincare map: section points (DTE, DTE velocity) once per mesh period."""
    fig = _figure(5.0, 4.2)
    ax = fig.add_subplot()
    ax.plot(np.asarray(px) * UM, pv, ".", ms=3, color="k")
    ax.set_xlabel("DTE (um)")
    ax.set_ylabel("DTE velocity (m/s)")
    ax.set_title(title or "Poincare map", fontsize=10)
    return _save(fig, path)


def plot_spectrum(
    spec: Spectrum, path: str | Path, title: str = "", unit: str = "", max_axis: float | None = None
) -> Path:
    """Amplitude spectrum (Hz) or order spectrum (orders) on a linear axis."""
    fig = _figure(7.0, 3.6)
    ax = fig.add_subplot()
    sel = spec.axis <= (max_axis if max_axis is not None else spec.axis[-1])
    ax.plot(spec.axis[sel], spec.amplitude[sel], lw=0.8)
    ax.set_xlabel("frequency (Hz)" if spec.unit == "Hz" else "order (per input-shaft revolution)")
    ax.set_ylabel(f"amplitude ({unit})" if unit else "amplitude")
    ax.set_title(title or "Amplitude spectrum", fontsize=10)
    return _save(fig, path)


def _paper_points_and_labels(
    ax: Any, paper_points: Sequence[tuple[float, float, float]], bearing: int
) -> None:
    """The paper's (temperature, speed, force) points as open circles, and the axis labels."""
    for t, s, f in paper_points:
        ax.plot([s], [f], "o", mfc="none", color=_color(t), ms=8)
    if paper_points:
        ax.plot([], [], "o", mfc="none", color="k", label="paper (text)")
    ax.set_xlabel("input speed (rpm)")
    ax.set_ylabel(f"RMS total force, bearing {bearing} (N)")


def plot_bearing_force(
    sweep: SweepResult,
    path: str | Path,
    temperatures_c: Sequence[float] = (25.0, 125.0, 225.0),
    bearing: int = 2,
    bearing_type: str = "A#",
    paper_points: Sequence[tuple[float, float, float]] = (),
) -> Path:
    """Fig 7: RMS total force of one bearing against speed, one line per temperature.

    Parameters
    ----------
    paper_points : sequence of (temperature_c, speed_rpm, force_n)
        The values quoted in the paper's text, drawn as markers.
    """
    fig = _figure(7.5, 4.2)
    ax = fig.add_subplot()
    for t in temperatures_c:
        ci = sweep.index(t, bearing_type)
        ax.plot(
            sweep.speeds_rpm,
            sweep.data["bearing_total_rms"][ci, :, bearing - 1],
            lw=1,
            color=_color(t),
            label=f"{t:g} C",
        )
    _paper_points_and_labels(ax, paper_points, bearing)
    ax.set_title(f"Bearing {bearing} force vs speed, bearings {bearing_type}", fontsize=10)
    ax.legend(fontsize=8)
    return _save(fig, path)


def plot_displacement(
    sweep: SweepResult,
    path: str | Path,
    speed_rpm: float = 19000.0,
    temperatures_c: Sequence[float] = (25.0, 125.0, 225.0),
    bearing_types: Sequence[str] = ("A#", "B#", "C#"),
    nodes: Sequence[int] = tuple(range(1, 10)),
    paper_points: Sequence[tuple[str, float, int, float]] = (),
) -> Path:
    """Fig 8: displacement amplitude (max of ``sqrt(x^2+y^2+z^2)``) per node, one panel per bearing type.

    Parameters
    ----------
    paper_points : sequence of (bearing_type, temperature_c, node, amplitude_um)
        Values quoted in the paper's text, drawn as open markers.
    """
    fig = _figure(4.0 * len(bearing_types), 3.8)
    axes = fig.subplots(1, len(bearing_types), sharey=True, squeeze=False)[0]
    idx = np.asarray(nodes) - 1
    width = 0.8 / len(temperatures_c)
    for ax, bt in zip(axes, bearing_types, strict=True):
        for k, t in enumerate(temperatures_c):
            ci = sweep.index(t, bt)
            amp = sweep.get("node_amp_max", ci, speed_rpm)[idx] * UM
            ax.bar(
                np.asarray(nodes) + (k - (len(temperatures_c) - 1) / 2) * width,
                amp,
                width,
                color=_color(t),
                label=f"{t:g} C",
            )
        for pbt, t, node, val in paper_points:
            if pbt == bt:
                ax.plot([node], [val], "D", mfc="none", color=_color(t), ms=7)
        ax.set_xticks(list(nodes))
        ax.set_xlabel("node")
        ax.set_title(f"bearings {bt}", fontsize=10)
    axes[0].set_ylabel("displacement amplitude (um)")
    axes[0].legend(fontsize=8)
    fig.suptitle(f"Vibration displacement amplitude at {speed_rpm:g} rpm (diamonds: paper)", fontsize=10)
    return _save(fig, path)


def plot_force_share(
    sweep: SweepResult,
    path: str | Path,
    speed_rpm: float,
    temperatures_c: Sequence[float] = (25.0, 125.0, 225.0),
    bearing_types: Sequence[str] = ("A#", "B#", "C#"),
    bearing: int = 2,
    kind: str = "rms",
) -> Path:
    """Fig 9: share of the bearing force per direction (stacked bars per temperature)."""
    fig = _figure(3.6 * len(bearing_types), 3.6)
    axes = fig.subplots(1, len(bearing_types), sharey=True, squeeze=False)[0]
    colors = ("tab:blue", "tab:green", "tab:red")
    for ax, bt in zip(axes, bearing_types, strict=True):
        x = np.arange(len(temperatures_c))
        bottom = np.zeros(len(temperatures_c))
        shares = np.array(
            [sweep.force_shares(sweep.index(t, bt), speed_rpm, bearing, kind) for t in temperatures_c]
        )
        for d, name in enumerate(("x", "y", "z (axial)")):
            ax.bar(x, shares[:, d] * 100, 0.6, bottom=bottom, color=colors[d], label=name)
            for xi, (b, h) in enumerate(zip(bottom, shares[:, d] * 100, strict=True)):
                if h > 4:
                    ax.text(xi, b + h / 2, f"{h:.0f}%", ha="center", va="center", fontsize=7, color="w")
            bottom += shares[:, d] * 100
        ax.set_xticks(x, [f"{t:g} C" for t in temperatures_c])
        ax.set_title(f"bearings {bt}", fontsize=10)
    axes[0].set_ylabel(f"share of bearing {bearing} force (%)")
    axes[-1].legend(fontsize=8, loc="lower right")
    fig.suptitle(
        f"Force share per direction, bearing {bearing}, {speed_rpm:g} rpm ({kind} shares)", fontsize=10
    )
    return _save(fig, path)


def plot_orbit(
    sweep: SweepResult,
    path: str | Path,
    speed_rpm: float,
    temperatures_c: Sequence[float] = (25.0, 125.0, 225.0),
    bearing_types: Sequence[str] = ("A#", "B#", "C#"),
    node: int = 9,
) -> Path:
    """Fig 10: axis orbit (x, y) of a node (node 9 = bearing 2) per bearing type and temperature."""
    k = sweep.orbit_nodes.index(node)
    fig = _figure(3.8 * len(bearing_types), 3.8)
    axes = fig.subplots(1, len(bearing_types), squeeze=False)[0]
    for ax, bt in zip(axes, bearing_types, strict=True):
        for t in temperatures_c:
            orb = sweep.get("orbit", sweep.index(t, bt), speed_rpm)[k] * UM
            ax.plot(orb[:, 0], orb[:, 1], lw=0.7, color=_color(t), label=f"{t:g} C")
        ax.plot([0], [0], "k+", ms=10)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x (um)")
        ax.set_title(f"bearings {bt}", fontsize=10)
    axes[0].set_ylabel("y (um)")
    axes[0].legend(fontsize=8)
    fig.suptitle(f"Axis orbit at node {node} (bearing 2), {speed_rpm:g} rpm; + ideal position", fontsize=10)
    return _save(fig, path)


def plot_sensitivity(
    rows: Sequence[dict[str, Any]], path: str | Path, paper_value: float, title: str, ylabel: str
) -> Path:
    """Bar chart of one model output against parameter variants, with the paper's value as a line.

    Parameters
    ----------
    rows : sequence of dict
        Each with ``label`` (str) and ``value`` (float).
    """
    fig = _figure(6.5, 3.6)
    ax = fig.add_subplot()
    ax.bar(range(len(rows)), [r["value"] for r in rows], color="tab:blue")
    ax.axhline(paper_value, color="k", ls="--", label=f"paper {paper_value:g}")
    ax.set_xticks(range(len(rows)), [r["label"] for r in rows], rotation=30, ha="right", fontsize=8)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)
    return _save(fig, path)


LINESTYLES = ("-", "--", ":", "-.")


def plot_bearing_force_scales(
    sweep: SweepResult,
    path: str | Path,
    scales: Sequence[float],
    temperatures_c: Sequence[float] = (25.0, 125.0, 225.0),
    bearing: int = 2,
    paper_points: Sequence[tuple[float, float, float]] = (),
    base: SweepResult | None = None,
) -> Path:
    """Fig 7 for several mesh-stiffness scales: colour = temperature, line style = scale.

    Parameters
    ----------
    sweep : SweepResult
        Cases with the override ``(("mesh_stiffness_scale", s),)`` for each ``s`` in ``scales``
        (bearings A#, thermal backlash).
    scales : sequence of float
        Stiffness scales to draw; a scale of 1 is taken from ``base`` when given (the plain cases).
    base : SweepResult, optional
        Sweep of the unmodified model (cases without overrides) on the same speeds.
    paper_points : sequence of (temperature_c, speed_rpm, force_n)
        The values quoted in the paper's text, drawn as markers.
    """
    fig = _figure(8.0, 4.6)
    ax = fig.add_subplot()
    for j, s in enumerate(scales):
        for t in temperatures_c:
            if s == 1.0 and base is not None:
                src, ci = base, base.index(t, "A#")
            else:
                src, ci = sweep, sweep.index(t, "A#", overrides=(("mesh_stiffness_scale", float(s)),))
            ax.plot(
                src.speeds_rpm,
                src.data["bearing_total_rms"][ci, :, bearing - 1],
                lw=1,
                ls=LINESTYLES[j % len(LINESTYLES)],
                color=_color(t),
                label=f"{t:g} C, k x {s:g}",
            )
    _paper_points_and_labels(ax, paper_points, bearing)
    ax.set_title(f"Bearing {bearing} force vs speed for mesh-stiffness scales (A#)", fontsize=10)
    ax.legend(fontsize=7, ncol=len(scales))
    return _save(fig, path)


def plot_band_vs_scale(
    rows: Sequence[dict[str, Any]],
    path: str | Path,
    paper_windows: dict[str, tuple[float, float]],
    titles: dict[str, str] | None = None,
) -> Path:
    """Location of the main chaotic band against the mesh-stiffness scale, per Fig 6 panel.

    Parameters
    ----------
    rows : sequence of dict
        Each with ``panel`` (key), ``scale``, ``lo`` and ``hi`` (rpm; NaN when no band) and
        ``pred_lo``/``pred_hi`` (the scale-1 band times ``sqrt(scale)``).
    paper_windows : dict
        Panel key -> the paper's chaotic window (rpm), drawn as a shaded band.
    titles : dict, optional
        Panel key -> legend label.
    """
    panels = list(dict.fromkeys(r["panel"] for r in rows))
    fig = _figure(3.4 * len(panels), 3.8)
    axes = fig.subplots(1, len(panels), sharey=True, squeeze=False)[0]
    for ax, key in zip(axes, panels, strict=True):
        rr = sorted((r for r in rows if r["panel"] == key), key=lambda r: r["scale"])
        x = np.array([r["scale"] for r in rr])
        for r in rr:
            if np.isfinite(r["lo"]):
                ax.plot([r["scale"]] * 2, [r["lo"], r["hi"]], color="tab:red", lw=6, alpha=0.7)
        ax.plot(x, [r["pred_lo"] for r in rr], "k--", lw=0.8, label="scale-1 band x sqrt(scale)")
        ax.plot(x, [r["pred_hi"] for r in rr], "k--", lw=0.8)
        lo, hi = paper_windows[key]
        ax.axhspan(lo, hi, color="tab:blue", alpha=0.2, label="paper window")
        ax.plot([], [], color="tab:red", lw=6, alpha=0.7, label="model chaotic band")
        ax.set_xlabel("mesh stiffness scale")
        ax.set_title((titles or {}).get(key, key), fontsize=9)
        ax.set_xticks(x)
    axes[0].set_ylabel("input speed (rpm)")
    axes[0].legend(fontsize=7, loc="lower right")
    return _save(fig, path)
