"""Readings of the paper's text tried against its Fig 6 bands (issue 13, the as-published band).

Sun et al. (2021) leave several choices open or state them twice in different ways. Each *reading*
below is one such choice, taken from the paper's text and applied on top of the as-published
configuration (``paper_sun2021_as_published``: the gear mass in Eq 20 and Eq 32). For every reading
the main chaotic band of the three Fig 6 panels is resolved on a fine speed grid (one continuation
segment, the band being the widest chaotic window after joining windows closer than ``gap_rpm``, as
:func:`gear_rotor_sim.analysis.reproduce_studies.refine_main_band` does), and the 25 C motion sequence
over 500-20000 rpm on a coarse grid. Nothing is fitted: each reading is a discrete alternative of the
text, and the table reports what each gives, whichever way it goes.

Readings (the paper's words in quotes):

* ``as_published``: Eq 27 "b is half of the backlash" with Sec 4.2 "the initial backlash is b = 35
  um" (half backlash 35 um), output torque T2 = 200 N m (Table 3), speed swept upwards ("with the
  increase of rotating speed (500-20000 rpm)").
* ``sweep_down``: the same model swept from high to low speed (the paper does not state the direction
  of its continuation; coexisting attractors make the band edges path-dependent).
* ``total_backlash``: Sec 4.2 "the initial backlash is b = 35 um" read as the whole backlash, so the
  half backlash of Eq 27 is 17.5 um.
* ``torque_150``: the output torque the paper's Fig 7 implies: its cold bearing-2 force at 1000 rpm
  (1088 N) is the static share of a 150 N m torque, not of Table 3's 200 N m (docs/REPRODUCTION.md).
* ``no_shaft_damping``: Eq 36 "M^e q'' + G^e q' + K^e q = F^e" has no damping matrix for the shaft
  elements; the system damping C^s then holds only the bearings' (Eqs 37-38) and the mesh's (Eq 30).
  The configurations add a shaft Rayleigh damping (beta = 1e-7 s) that the paper does not have.
* ``fresh_start``: the paper states neither its initial conditions nor whether a speed starts from the
  previous one; here every speed starts from the static equilibrium with the long first transient
  (no continuation), the other common way to draw a bifurcation diagram.

:func:`edge_sensitivity` complements the readings: the parameters the paper does not give at all
(mesh damping ratio, friction coefficient, transmission-error phase, the mesh stiffness of Ref [35],
the transient) and modelling details it leaves open (where the output torque acts, the shear
coefficient, the units of the bearings' tilt terms, the stress-free temperature) are varied one at a
time around the 25 C band to show which of them move its lower edge, and by how much. Those rows are
not readings of the text and are never adopted.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from gear_rotor_sim.analysis.bands import condense_windows, merge_windows
from gear_rotor_sim.analysis.bifurcation import (
    BIFURCATION_CHANNELS,
    BifurcationResult,
    Case,
    RunSettings,
    reduce_bifurcation,
    run_segment,
)
from gear_rotor_sim.analysis.paper_data import PANELS, PAPER_CHAOS

PUBLISHED = "paper_sun2021_as_published"


@dataclass(frozen=True)
class Reading:
    """One reading of the paper: overrides of the as-published case and the sweep direction."""

    key: str
    title: str
    text: str
    overrides: tuple[tuple[str, float], ...] = ()
    downward: bool = False
    fresh: bool = False


READINGS: tuple[Reading, ...] = (
    Reading(
        "as_published",
        "as published (Eq 32 gear mass, half backlash 35 um, T2 200 N m, upward)",
        'Eq 27 "b is half of the backlash", Sec 4.2 "the initial backlash is b = 35 um"; Table 3 '
        'T2 = 200 N m; Sec 4.2 "with the increase of rotating speed"',
    ),
    Reading(
        "sweep_down",
        "swept downward",
        "the direction of the paper's continuation is not stated",
        downward=True,
    ),
    Reading(
        "total_backlash",
        "backlash 35 um in total (half 17.5 um)",
        'Sec 4.2 "the initial backlash is b = 35 um" read as the whole backlash',
        (("half_backlash_m", 17.5e-6),),
    ),
    Reading(
        "torque_150",
        "output torque 150 N m",
        "the torque whose static share is the paper's cold Fig 7 bearing force (1088 N at 1000 rpm)",
        (("load_torque_nm", 150.0),),
    ),
    Reading(
        "no_shaft_damping",
        "no shaft damping",
        "Eq 36 \"M^e q'' + G^e q' + K^e q = F^e\" (no damping matrix for the shaft elements; C^s from "
        "the bearings, Eqs 37-38, and the mesh, Eq 30)",
        (("stiffness_s", 0.0),),
    ),
    Reading(
        "fresh_start",
        "every speed from the static equilibrium",
        "the initial conditions of each speed are not stated (a bifurcation diagram is drawn either by "
        "continuation or from the same start at every speed)",
        fresh=True,
    ),
)

#: Fine re-sweep windows per Fig 6 panel (rpm): the paper's band with at least 1500 rpm either side.
FINE_WINDOWS: dict[str, tuple[float, float]] = {
    "25C": (12000.0, 15800.0),
    "225C": (11500.0, 15800.0),
    "225C_fixed": (10600.0, 15800.0),
}


def reading_case(reading: Reading, panel: str) -> Case:
    """The as-published Fig 6 case of ``panel`` with the reading's overrides."""
    return dataclasses.replace(PANELS[panel], config=PUBLISHED, overrides=reading.overrides)


def sweep(
    case: Case,
    speeds_rpm: np.ndarray,
    settings: RunSettings,
    downward: bool = False,
    fresh: bool = False,
) -> BifurcationResult:
    """One continuation segment over ``speeds_rpm`` (increasing, or decreasing when ``downward``);
    the result is ordered by increasing speed either way. ``fresh``: no continuation, every speed
    starts from the static equilibrium with the first-speed transient (``first_transient_factor``)."""
    speeds = np.sort(np.asarray(speeds_rpm, dtype=float))
    order = speeds[::-1] if downward else speeds
    t0 = time.perf_counter()
    if fresh:
        parts = [run_segment(case, order[i : i + 1], settings, BIFURCATION_CHANNELS, reduce_bifurcation)
                 for i in range(order.size)]  # fmt: skip
        out = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    else:
        out = run_segment(case, order, settings, BIFURCATION_CHANNELS, reduce_bifurcation)
    if downward:
        out = {k: v[::-1] for k, v in out.items()}
    return BifurcationResult.from_arrays(
        case, speeds, out, settings, time.perf_counter() - t0, {"downward": downward, "fresh": fresh}
    )


def main_band_of(res: BifurcationResult, gap_rpm: float, above_rpm: float = 11000.0) -> tuple[float, float]:
    """Widest chaotic window ending above ``above_rpm`` after joining windows closer than ``gap_rpm``."""

    joined = [w for w in merge_windows(res.chaotic_windows(merge_gap=1), gap_rpm) if w[1] >= above_rpm]
    if not joined:
        return float("nan"), float("nan")
    return max(joined, key=lambda w: w[1] - w[0])


def lower_edge_detail(
    res: BifurcationResult, edge_rpm: float, before: int = 2, after: int = 3
) -> list[dict[str, Any]]:
    """Motion, 0-1 test statistic K and spread of the Poincare section (peak-to-peak over the DTE
    range) at the speeds around the lower edge of a band: whether the edge is a detection threshold
    (weak, narrow-band chaos that a bifurcation diagram would show as multi-period) or a jump into
    fully developed chaos."""
    motions = res.classify()
    i = int(np.searchsorted(res.speeds_rpm, edge_rpm))
    out = []
    for j in range(max(i - before, 0), min(i + after, res.speeds_rpm.size)):
        rng = float(res.dte_max[j] - res.dte_min[j])
        out.append(
            {
                "speed_rpm": float(res.speeds_rpm[j]),
                "label": motions[j].label,
                "k": float(motions[j].k),
                "section_spread": float(np.ptp(res.section[j]) / rng) if rng > 0 else 0.0,
            }
        )
    return out


def readings_study(
    settings: RunSettings,
    coarse_speeds_rpm: np.ndarray,
    step_rpm: float = 25.0,
    gap_rpm: float = 250.0,
    readings: tuple[Reading, ...] = READINGS,
    panels: tuple[str, ...] = tuple(PANELS),
) -> dict[str, Any]:
    """Fine Fig 6 main bands of every panel and the coarse 25 C sequence for every reading.

    Returns
    -------
    dict
        ``readings``: per reading ``key``, ``title``, ``text``, ``bands_rpm`` (panel -> [low, high]),
        ``edge_errors_rpm`` (panel -> [low - paper low, high - paper high]), ``windows_rpm`` (panel ->
        fine chaotic windows), ``sequence_25c`` (label, low, high on the coarse grid),
        ``diverged_rpm`` (panel or ``"25C_coarse"`` -> speed where a run left the physical range,
        :class:`gear_rotor_sim.solver.newmark.SimulationDiverged`; such a panel has NaN bands); plus
        ``step_rpm``, ``gap_rpm``, ``fine_windows_rpm``, ``paper_rpm`` and ``wall_time_s``.
    """
    from gear_rotor_sim.solver.newmark import SimulationDiverged

    t0 = time.perf_counter()
    rows = []
    edge: list[dict[str, Any]] = []
    for rd in readings:
        bands, errors, windows, diverged = {}, {}, {}, {}
        for panel in panels:
            lo, hi = FINE_WINDOWS[panel]
            speeds = np.arange(lo, hi + step_rpm / 2, step_rpm)
            plo, phi = PAPER_CHAOS[panel][0]
            try:
                res = sweep(reading_case(rd, panel), speeds, settings, rd.downward, rd.fresh)
            except SimulationDiverged as exc:  # reported with its speed, not dropped
                diverged[panel] = float(exc.speed_rpm)
                bands[panel] = [float("nan")] * 2
                errors[panel] = [float("nan")] * 2
                windows[panel] = []
                continue
            b = main_band_of(res, gap_rpm)
            bands[panel] = [float(b[0]), float(b[1])]
            errors[panel] = [float(b[0] - plo), float(b[1] - phi)]
            windows[panel] = [[float(a), float(c)] for a, c in res.chaotic_windows(merge_gap=1)]
            if rd.key == readings[0].key and panel == "25C" and np.isfinite(b[0]):
                edge = lower_edge_detail(res, b[0])
        try:
            coarse = sweep(reading_case(rd, "25C"), coarse_speeds_rpm, settings, rd.downward, rd.fresh)
            condensed = condense_windows(coarse.windows(), 3, coarse.speeds_rpm)
            sequence = [[lab, float(a), float(c)] for lab, a, c in condensed]
        except SimulationDiverged as exc:
            diverged["25C_coarse"] = float(exc.speed_rpm)
            sequence = []
        rows.append(
            {
                "key": rd.key,
                "title": rd.title,
                "text": rd.text,
                "bands_rpm": bands,
                "edge_errors_rpm": errors,
                "windows_rpm": windows,
                "sequence_25c": sequence,
                "diverged_rpm": diverged,
            }
        )
    return {
        "readings": rows,
        "step_rpm": step_rpm,
        "gap_rpm": gap_rpm,
        "fine_windows_rpm": {k: list(v) for k, v in FINE_WINDOWS.items() if k in panels},
        "paper_rpm": {k: list(PAPER_CHAOS[k][0]) for k in panels},
        "lower_edge_25c": edge,
        "wall_time_s": time.perf_counter() - t0,
    }


@dataclass(frozen=True)
class Variation:
    """One parameter the paper does not give, changed on its own (not a reading of the text)."""

    key: str
    title: str
    overrides: tuple[tuple[str, float], ...] = ()
    transient_factor: float = 1.0

    @classmethod
    def of(cls, key: str, title: str, parameter: str, value: float) -> Variation:
        """One parameter override ``parameter = value`` (a :class:`Case` override name)."""
        return cls(key, title, ((parameter, value),))


#: The unstated parameters varied around the as-published 25 C band (:func:`edge_sensitivity`).
VARIATIONS: tuple[Variation, ...] = (
    Variation("reference", "as published (zeta 0.07, mu 0.05, phi 0, k x 1)"),
    Variation.of("zeta_0.05", "mesh damping ratio 0.05", "damping_ratio", 0.05),
    Variation.of("zeta_0.06", "mesh damping ratio 0.06", "damping_ratio", 0.06),
    Variation.of("zeta_0.08", "mesh damping ratio 0.08", "damping_ratio", 0.08),
    # c_m = 2 zeta sqrt(k m_e) with m_e from the assembled (doubled) gear inertias: 0.07 sqrt(2)
    Variation.of(
        "zeta_assembled",
        "mesh damping ratio 0.07 of the assembled inertias (0.099)",
        "damping_ratio",
        0.07 * float(np.sqrt(2.0)),
    ),
    Variation.of("mu_0", "friction coefficient 0", "friction_coefficient", 0.0),
    Variation.of("mu_0.1", "friction coefficient 0.1", "friction_coefficient", 0.1),
    Variation.of(
        "phi_pi_2", "transmission-error phase pi/2", "transmission_error_phase_rad", float(np.pi / 2)
    ),
    Variation.of("k_0.98", "mesh stiffness x 0.98", "mesh_stiffness_scale", 0.98),
    Variation.of("k_1.02", "mesh stiffness x 1.02", "mesh_stiffness_scale", 1.02),
    Variation("transient_x2", "transient discarded x 2", transient_factor=2.0),
    # modelling details the paper leaves open or states in a form that can be read two ways
    Variation.of(
        "load_at_gear",
        "output torque on the gear's node 14 (Eq 32's theta_zg) instead of the shaft end, node 18",
        "load_node",
        14.0,
    ),
    Variation.of(
        "shear_1", "Timoshenko shear coefficient 1 (Eq 12's mu; Cowper's 0.89 used)", "shear_coefficient", 1.0
    ),
    Variation.of(
        "tilt_per_degree",
        "bearing tilt stiffness read per degree (Table 5 gives no unit; x 57.3)",
        "bearing_tilt_stiffness_scale",
        float(180.0 / np.pi),
    ),
    Variation.of(
        "no_tilt_damping",
        "no bearing tilt damping (Table 5 gives c_theta in N s/m, a translational unit)",
        "bearing_tilt_damping",
        0.0,
    ),
    Variation.of(
        "reference_20c",
        "stress-free temperature 20 C (the paper: 25 C, Sec 2.1 and Table 1)",
        "reference_temperature_c",
        20.0,
    ),
)


def edge_sensitivity(
    settings: RunSettings,
    step_rpm: float = 25.0,
    gap_rpm: float = 250.0,
    variations: tuple[Variation, ...] | None = None,
    window_rpm: tuple[float, float] = FINE_WINDOWS["25C"],
) -> dict[str, Any]:
    """The as-published 25 C main band with one unstated parameter changed at a time.

    ``variations`` defaults to :data:`VARIATIONS` and :func:`hertz_variation`. Each variation is swept
    upwards in one continuation segment over ``window_rpm`` on a
    ``step_rpm`` grid; the band is :func:`main_band_of` (windows closer than ``gap_rpm`` joined). A
    run that leaves the physical range (:class:`gear_rotor_sim.solver.newmark.SimulationDiverged`)
    is reported with the speed where it did, not dropped.

    Returns
    -------
    dict
        ``rows``: per variation ``key``, ``title``, ``band_rpm`` [low, high] (NaN when none),
        ``edge_errors_rpm`` against the paper's 13500-14700 rpm and ``diverged_rpm`` (None, or the
        speed of the divergence); plus ``step_rpm``, ``gap_rpm``, ``window_rpm``, ``wall_time_s``.
    """
    from gear_rotor_sim.solver.newmark import SimulationDiverged

    if variations is None:  # the module's list plus the non-linear Hertz proxy (computed here)
        variations = (*VARIATIONS, hertz_variation())
    t0 = time.perf_counter()
    base = READINGS[0]
    plo, phi = PAPER_CHAOS["25C"][0]
    speeds = np.arange(window_rpm[0], window_rpm[1] + step_rpm / 2, step_rpm)
    rows = []
    for v in variations:
        case = dataclasses.replace(reading_case(base, "25C"), overrides=v.overrides)
        st = dataclasses.replace(
            settings, n_transient_periods=round(settings.n_transient_periods * v.transient_factor)
        )
        diverged = None
        try:
            b = main_band_of(sweep(case, speeds, st), gap_rpm)
        except SimulationDiverged as exc:
            b, diverged = (float("nan"), float("nan")), float(exc.speed_rpm)
        rows.append(
            {
                "key": v.key,
                "title": v.title,
                "band_rpm": [float(b[0]), float(b[1])],
                "edge_errors_rpm": [float(b[0] - plo), float(b[1] - phi)],
                "diverged_rpm": diverged,
            }
        )
    return {
        "rows": rows,
        "step_rpm": step_rpm,
        "gap_rpm": gap_rpm,
        "window_rpm": [float(window_rpm[0]), float(window_rpm[1])],
        "wall_time_s": time.perf_counter() - t0,
    }


def nonlinear_hertz_stiffness(
    config: str = PUBLISHED, temperature_c: float = 25.0, linear: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Mesh stiffness over one mesh cycle with the non-linear Hertz stiffness, and the model's table.

    Sec 2.2 calls k_h of Eq 14 "the non-linear Hertzian contact stiffness"; the model uses the linear
    ``k_h = pi E L / (4 (1 - nu^2))``. The non-linear form common in the potential-energy literature,
    ``k_h = E^0.9 L^0.8 F^0.1 / 1.275`` (SI units), is evaluated with F the static load of each pair in
    contact (its share ``k_t^i / sum k_t`` of ``T2 / r_bg``, iterated because the share depends on
    k_h) and combined as Eqs 13-14 do. ``linear=True`` runs the same combination with the linear k_h
    (a check against the table).

    Returns
    -------
    (k, k_table) : numpy.ndarray
        N/m at the phases of the model's stiffness table, and the table's own stiffness.
    """
    from gear_rotor_sim.config import load_config
    from gear_rotor_sim.gears import paper_gear_pair

    cfg = load_config(config)
    mat = cfg.materials[cfg.gears[0].material]
    pair = paper_gear_pair(mat)
    table = pair.mesh_stiffness_table(temperature_c)
    pos = pair.contact_positions(table.phase)
    mask = np.isfinite(pos)
    s = np.where(mask, pos, pair.pitch_point)
    cp = pair.tooth_compliance(s.ravel() / pair.base_radius(True), True, temperature_c)
    cg = pair.tooth_compliance(
        (pair.line_of_action_length - s.ravel()) / pair.base_radius(False), False, temperature_c
    )
    teeth = (cp.tooth + cg.tooth).reshape(s.shape)
    kf1 = np.where(mask, (1.0 / cp.fillet).reshape(s.shape), 0.0).sum(axis=1)
    kf2 = np.where(mask, (1.0 / cg.fillet).reshape(s.shape), 0.0).sum(axis=1)
    e_mod, width = mat.youngs_modulus(temperature_c), pair.face_width
    force = cfg.load.torque_nm / pair.base_radius(False)
    kh = np.full(s.shape, pair.hertz_stiffness(temperature_c))
    for _ in range(30):
        kt = np.where(mask, 1.0 / (1.0 / kh + teeth), 0.0)
        if linear:
            break
        share = kt / kt.sum(axis=1, keepdims=True)
        kh = e_mod**0.9 * width**0.8 * np.maximum(share * force, 1e-3) ** 0.1 / 1.275
    kt = np.where(mask, 1.0 / (1.0 / kh + teeth), 0.0)
    k = 1.0 / (1.0 / kt.sum(axis=1) + 1.0 / kf1 + 1.0 / kf2)
    return k, np.asarray(table.stiffness, dtype=float)


def nonlinear_hertz_scale(
    config: str = PUBLISHED, temperature_c: float = 25.0, linear: bool = False
) -> float:
    """Mean of :func:`nonlinear_hertz_stiffness` over the model's mean mesh stiffness.

    ``edge_sensitivity`` scales the mesh stiffness by this ratio: a proxy of the non-linear Hertz
    reading (the mean changes, the shape over the mesh cycle stays the linear model's).
    """
    k, k_table = nonlinear_hertz_stiffness(config, temperature_c, linear)
    return float(k.mean() / k_table.mean())


def hertz_variation() -> Variation:
    """The non-linear Hertz reading of Sec 2.2 as a mesh-stiffness scale (:func:`nonlinear_hertz_scale`)."""
    scale = nonlinear_hertz_scale()
    return Variation(
        "nonlinear_hertz",
        f"non-linear Hertz stiffness of Sec 2.2 (E^0.9 L^0.8 F^0.1 / 1.275; mean k x {scale:.3f}, proxy)",
        (("mesh_stiffness_scale", scale),),
    )
